//! `overlay` pass (demo only): blends the demo's text overlay (an RGBA8 image) over the top-left of the final
//! image. Shader: shaders_glsl/overlay.comp.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `overlay`.
pub const NAME: &str = "overlay";

// Slots: frame (unused by the shader), overlay, out (blended in place).
declare_program!(pub PROGRAM: () = compute(shaders::OVERLAY, [Uniform, ImgRead, ImgWrite]));

/// The pass: its compute program(s), built once per device.
pub struct Overlay {
    prog: ComputeProgram<()>,
}

impl Overlay {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Overlay { prog: ComputeProgram::new(gpu, &PROGRAM)? })
    }

    /// Blend `overlay` over the top-left of `out`.
    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, overlay: &Image, out: &Image) {
        ctx.pass(NAME, |ctx| {
            let g = groups_2d(overlay.extent.width, overlay.extent.height, super::LOCAL_2D);
            self.prog.dispatch(ctx, &[frame.into(), overlay.into(), out.into()], &(), g);
        });
    }
}
