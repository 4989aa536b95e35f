//! `background` pass: the scene behind the fluid — ground plane, boxes, sky — into colour + linear depth.
//! Shader: shaders_glsl/background.comp.
use std::sync::Arc;

use crate::error::Result;
use crate::gpu::pipeline::bt::*;
use crate::gpu::{Bind, Buffer, ComputeProgram, FrameCtx, Gpu, Image, Use};
use crate::shaders;

pub const NAME: &str = "background";

pub struct Background {
    prog: ComputeProgram,
}

impl Background {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Background { prog: ComputeProgram::new(gpu, NAME, shaders::BACKGROUND, &[UBO, IMG, IMG, TEX], 0)? })
    }

    /// Writes all of `color` and `depth`; `sky` is the cube map (a placeholder when procedural).
    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, sky: &Image, color: &Image, depth: &Image) {
        ctx.pass(NAME, &[Use::buf_read(frame), Use::sampled(sky), Use::overwrite(color), Use::overwrite(depth)], |ctx| {
            let g = ComputeProgram::groups_2d(color.extent.width, color.extent.height, super::LOCAL_2D);
            self.prog.dispatch(
                ctx,
                &[Bind::Uniform(frame), Bind::Storage(color), Bind::Storage(depth), Bind::Linear(sky)],
                &[],
                g,
            );
        });
    }
}
