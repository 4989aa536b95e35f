//! `splat` pass: nearest linear eye depth of every particle sphere (compute splat with atomicMin).
//! Shader: shaders_glsl/splat.comp. The depth image is R32_SFLOAT with an R32_UINT view for the atomics.
use std::sync::Arc;

use ash::vk;

use crate::error::Result;
use crate::gpu::pipeline::bt::*;
use crate::gpu::{Access, Bind, Buffer, ComputeProgram, FrameCtx, Gpu, Image, Use};
use crate::shaders;

pub const NAME: &str = "splat";

/// Per-thread pixel budget: a sphere covering more (it swallowed the camera) is skipped.
pub const MAX_PIXELS_PER_PARTICLE: u32 = 1 << 20;

pub struct Splat {
    prog: ComputeProgram,
}

impl Splat {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Splat { prog: ComputeProgram::new(gpu, NAME, shaders::SPLAT, &[UBO, SSBO, IMG], 12)? })
    }

    /// Clears `depth` to +inf ("no fluid") and splats `count` particles into it.
    /// `radius_scale`: splat spheres of this many particle radii.
    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, particles: &Buffer, count: u32, depth: &Image, radius_scale: f32) {
        ctx.pass(NAME, &[Use::Image(depth, Access::TransferDst, true)], |ctx| {
            clear(ctx, depth, vk::ClearColorValue { float32: [f32::INFINITY; 4] });
            ctx.barrier(&[Use::buf_read(frame), Use::buf_read(particles), Use::write(depth)]);
            let push = [count, MAX_PIXELS_PER_PARTICLE, radius_scale.to_bits()];
            let groups = [count.div_ceil(super::LOCAL_1D), 1, 1];
            self.prog.dispatch(
                ctx,
                &[Bind::Uniform(frame), Bind::StorageBuf(particles), Bind::StorageAlt(depth)],
                bytemuck::cast_slice(&push),
                groups,
            );
        });
    }
}

/// Clear a whole image that is in TRANSFER_DST layout (the caller declared `Access::TransferDst`).
pub(crate) fn clear(ctx: &FrameCtx, img: &Image, value: vk::ClearColorValue) {
    unsafe {
        ctx.gpu.device.cmd_clear_color_image(
            ctx.cmd,
            img.raw,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            &value,
            &[Image::color_range()],
        )
    };
}
