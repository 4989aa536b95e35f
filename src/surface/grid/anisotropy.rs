//! `anisotropy` pass (with `kernel = "anisotropic"`: the iso surface's kernels, or the spheres' ellipsoids): each particle's anisotropic kernel
//! after Yu & Turk 2013, "Reconstructing surfaces of particle-based fluids using anisotropic kernels" (§4) — the
//! weighted covariance of its neighbours, its eigen-decomposition, the axis ratios clamped to k_r, optionally
//! the centre moved towards the neighbours' weighted mean — so the `iso` field is flat where the water is calm
//! (no particle-scale bumps) while isolated droplets keep their spheres. Runs after the `grid` pass on its
//! sorted points; the `iso` ray cast reads the result. Shader: shaders_glsl/anisotropy.comp; CPU reference:
//! `IsoGrid::anisotropy` in src/field/iso/mod.rs.
//!
//! In: the iso grid's sorted points and cell table. Out: `IsoBuffers::aniso` (three vec4 per point).
//! Where the method is ours: the kernel's longest axis is h (Yu & Turk scale by k_s so that interior kernels
//! come out near h) so every kernel stays inside the support ball and the grid's 3×3×3 lookup still finds it;
//! the field multiplies by det M so the kernel's integral, hence the field inside the fluid, is unchanged.
use std::sync::Arc;

use super::buffers::{IsoBuffers, IsoPush};
use crate::declare_program;
use crate::error::Result;
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu};
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `anisotropy`.
pub const NAME: &str = "anisotropy";

/// The pass: its compute program, built once per device.
pub struct Anisotropy {
    program: ComputeProgram<IsoPush>,
}

// Frame, sorted points, cell table → kernels.
declare_program!(pub PROGRAM: IsoPush = compute(shaders::ANISOTROPY, [Uniform, TexelRead, TexelRead, BufWrite]));

impl Anisotropy {
    /// Build the pass's pipeline.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Anisotropy { program: ComputeProgram::new(gpu, &PROGRAM)? })
    }

    /// Every grid point's kernel into `b.aniso`, unless they were computed for these particles with `p` already
    /// (the kernels depend on the particles, not the view).
    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, b: &IsoBuffers, p: &crate::field::iso::AnisoParams) {
        if b.kernels_for.get() == Some(*p) {
            return;
        }
        b.kernels_for.set(Some(*p));
        let push = IsoPush {
            aniso: [p.ratio, p.min_neighbours as f32, p.centre_blend, p.max_shift],
            aniso2: [p.stretch.max(1.0), 0.0, p.radius, 0.0],
            ..b.shape
        };
        ctx.pass(NAME, |ctx| {
            let res = [frame.into(), (&b.points).into(), (&b.cells).into(), (&b.aniso).into()];
            self.program.dispatch(ctx, &res, &push, [b.shape.dims[3].div_ceil(crate::passes::LOCAL_1D), 1, 1]);
        });
    }
}
