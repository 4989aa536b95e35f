//! `particles` pass (demo only): the particles as lit spheres coloured by an attribute, over the scene colour
//! the `view` pass put in the final image. Shader: shaders_glsl/particles.comp.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `particles`.
pub const NAME: &str = "particles";

/// Push constants of particles.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ParticlePush {
    /// Particles.
    pub count: u32,
    /// Sphere radius in particle radii.
    pub radius_scale: f32,
    /// Hue at value 0 and at value 1 (turns).
    pub hue: [f32; 2],
}

// Slots: frame, particles, per-particle values, raw depth (its R32_UINT view), out (covered pixels only).
declare_program!(pub PROGRAM: ParticlePush = compute(
    shaders::PARTICLES,
    [Uniform, BufRead, BufRead, ImgAltRead, ImgWrite]
));

/// The pass: its compute program(s), built once per device.
pub struct LitParticles {
    prog: ComputeProgram<ParticlePush>,
}

impl LitParticles {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(LitParticles { prog: ComputeProgram::new(gpu, &PROGRAM)? })
    }

    /// Draw the particles over the final image (after a mode-6 `view`).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        particles: &Buffer,
        values: &Buffer,
        count: u32,
        (depth, final_color): (&Image, &Image),
        radius_scale: f32,
    ) {
        ctx.pass(NAME, |ctx| {
            // Princisgh's two-colour ramp: blue (slow / light / low) to red, interpolated in hue.
            let push = ParticlePush { count, radius_scale, hue: [0.62, 0.0] };
            let res = [frame.into(), particles.into(), values.into(), depth.into(), final_color.into()];
            self.prog.dispatch(ctx, &res, &push, [count.div_ceil(super::LOCAL_1D), 1, 1]);
        });
    }
}
