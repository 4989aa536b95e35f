//! `anisotropy` pass (with `surface = "iso"` and `kernel = "anisotropic"`): each particle's anisotropic kernel
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

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu};
use crate::passes::iso::{IsoBuffers, IsoPush};
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `anisotropy`.
pub const NAME: &str = "anisotropy";

/// Settings of the `anisotropy` pass: the `[anisotropy]` section of a settings file (used with
/// `kernel = "anisotropic"`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Largest ratio of the kernel's longest to its shortest axis (Yu & Turk's k_r = 4).
    pub ratio: f32,
    /// Particles with fewer neighbours within the kernel support keep a sphere (Yu & Turk's N_ε; a particle
    /// inside the fluid has about 32 within 4 r).
    pub min_neighbours: u32,
    /// Blend λ of each kernel's centre towards its neighbours' weighted mean (Yu & Turk eq. 6: 0.9; 0 keeps
    /// the particle positions). A blend above 0 widens the grid's cells by `max_shift`.
    pub centre_blend: f32,
    /// Longest move of a kernel centre, in particle radii.
    pub max_shift: f32,
    /// Longest axis of a kernel in units of the support (≥ 1): the kernels keep the sphere's volume up to this
    /// stretch; the grid's cells are this many supports wide, so the iso cast's cost grows with its cube.
    pub stretch: f32,
    /// Radius of the neighbourhood in supports (1 … 2; Yu & Turk use 2): its covariance shapes the kernel and
    /// its mean moves the centre. 2 visits about 8× the neighbours.
    pub radius: f32,
}

impl Default for Params {
    fn default() -> Self {
        Params { ratio: 4.0, min_neighbours: 20, centre_blend: 0.0, max_shift: 1.0, stretch: 1.0, radius: 1.0 }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    /// (`max_shift` is also at most `[iso] support`: `Settings::check`.)
    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(NAME);
        k.within("ratio", self.ratio, 1.0, 16.0)?;
        k.count("min_neighbours", self.min_neighbours, 0, 1000)?;
        k.within("centre_blend", self.centre_blend, 0.0, 1.0)?;
        k.within("max_shift", self.max_shift, 0.0, 16.0)?;
        k.within("stretch", self.stretch, 1.0, 3.0)?;
        k.within("radius", self.radius, 1.0, 2.0)
    }
}

impl Params {
    /// In world units for particles of `radius` and a kernel support of `support` radii.
    pub fn world(&self, radius: f32, support: f32) -> crate::field::iso::AnisoParams {
        crate::field::iso::AnisoParams {
            ratio: self.ratio,
            min_neighbours: self.min_neighbours,
            centre_blend: self.centre_blend,
            max_shift: if self.centre_blend > 0.0 { self.max_shift * radius } else { 0.0 },
            stretch: self.stretch,
            radius: self.radius.max(1.0) * support * radius,
        }
    }
}

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
            self.program.dispatch(ctx, &res, &push, [b.shape.dims[3].div_ceil(super::LOCAL_1D), 1, 1]);
        });
    }
}
