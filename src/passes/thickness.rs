//! `thickness` pass: additive chord length of every sphere at reduced resolution, cut by the scene depth,
//! then a 2D Gaussian blur. Shaders: shaders_glsl/thickness.comp, shaders_glsl/thickness_blur.comp.
use std::sync::Arc;

use ash::vk;

use crate::error::Result;
use crate::gpu::pipeline::bt::*;
use crate::gpu::{Access, Bind, Buffer, ComputeProgram, FrameCtx, Gpu, Image, Use};
use crate::shaders;

pub const NAME: &str = "thickness";

pub struct Thickness {
    accumulate: ComputeProgram,
    blur: ComputeProgram,
}

impl Thickness {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Thickness {
            accumulate: ComputeProgram::new(gpu, NAME, shaders::THICKNESS, &[UBO, SSBO, IMG, IMG], 8)?,
            blur: ComputeProgram::new(gpu, NAME, shaders::THICKNESS_BLUR, &[UBO, IMG, IMG], 8)?,
        })
    }

    /// `accum` (R32_UINT) is cleared and filled; `out` (R32_SFLOAT, world units) receives the blurred result.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        particles: &Buffer,
        count: u32,
        scene_depth: &Image,
        accum: &Image,
        out: &Image,
        blur_radius: u32,
    ) {
        ctx.pass(NAME, &[Use::Image(accum, Access::TransferDst, true)], |ctx| {
            super::splat::clear(ctx, accum, vk::ClearColorValue { uint32: [0; 4] });
            ctx.barrier(&[Use::buf_read(frame), Use::buf_read(particles), Use::read(scene_depth), Use::write(accum)]);
            let push = [count, super::splat::MAX_PIXELS_PER_PARTICLE];
            self.accumulate.dispatch(
                ctx,
                &[Bind::Uniform(frame), Bind::StorageBuf(particles), Bind::Storage(scene_depth), Bind::Storage(accum)],
                bytemuck::cast_slice(&push),
                [count.div_ceil(super::LOCAL_1D), 1, 1],
            );
            ctx.barrier(&[Use::read(accum), Use::overwrite(out)]);
            let sigma = (blur_radius as f32 * 0.5).max(0.5);
            let push: [u32; 2] = [blur_radius, sigma.to_bits()];
            let g = ComputeProgram::groups_2d(out.extent.width, out.extent.height, super::LOCAL_2D);
            self.blur.dispatch(
                ctx,
                &[Bind::Uniform(frame), Bind::Storage(accum), Bind::Storage(out)],
                bytemuck::cast_slice(&push),
                g,
            );
        });
    }
}
