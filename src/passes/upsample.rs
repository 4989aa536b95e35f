//! `upsample` pass: reduced-resolution fluid depth → full resolution, bilinear inside the fluid, nearest across
//! silhouettes and depth jumps. Runs only when `fluid_scale` < 1. Shader: shaders_glsl/upsample.comp.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `upsample`.
pub const NAME: &str = "upsample";

/// The pass: its compute program(s), built once per device.
pub struct Upsample {
    prog: ComputeProgram<f32>,
}

// Push: the silhouette edge threshold (world units).
declare_program!(pub PROGRAM: f32 = compute(shaders::UPSAMPLE, [Uniform, ImgRead, ImgOverwrite]));

impl Upsample {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Upsample { prog: ComputeProgram::new(gpu, &PROGRAM)? })
    }

    /// `edge`: depth jump (world) above which neighbours belong to different surfaces.
    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, low: &Image, full: &Image, edge: f32) {
        ctx.pass(NAME, |ctx| {
            let g = groups_2d(full.extent.width, full.extent.height, super::LOCAL_2D);
            self.prog.dispatch(ctx, &[frame.into(), low.into(), full.into()], &edge, g);
        });
    }
}
