//! `upsample` pass: reduced-resolution fluid depth → full resolution, bilinear inside the fluid, nearest across
//! silhouettes and depth jumps. Runs only when `fluid_scale` < 1. Shader: shaders_glsl/upsample.comp.
use std::sync::Arc;

use crate::error::Result;
use crate::gpu::pipeline::bt::*;
use crate::gpu::{Bind, Buffer, ComputeProgram, FrameCtx, Gpu, Image, Use};
use crate::shaders;

pub const NAME: &str = "upsample";

pub struct Upsample {
    prog: ComputeProgram,
}

impl Upsample {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Upsample { prog: ComputeProgram::new(gpu, NAME, shaders::UPSAMPLE, &[UBO, IMG, IMG], 4)? })
    }

    /// `edge`: depth jump (world) above which neighbours belong to different surfaces.
    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, low: &Image, full: &Image, edge: f32) {
        ctx.pass(NAME, &[Use::buf_read(frame), Use::read(low), Use::overwrite(full)], |ctx| {
            let g = ComputeProgram::groups_2d(full.extent.width, full.extent.height, super::LOCAL_2D);
            self.prog.dispatch(
                ctx,
                &[Bind::Uniform(frame), Bind::Storage(low), Bind::Storage(full)],
                bytemuck::bytes_of(&edge),
                g,
            );
        });
    }
}
