//! The `[iso]` section of a settings file: the iso surface's ray cast and its smoothed field, in particle radii,
//! its check, and its world units (`crate::field::iso::IsoParams`, the one type the cast, the lattice and the
//! CPU reference read). A leaf: it imports nothing of the renderer, so `settings` can hold it.

/// The section's name.
const NAME: &str = "iso";

/// Settings of the `iso` surface: the `[iso]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Iso-surface: kernel support in particle radii (splashsurf: 2 × smoothing length 2.0 = 4).
    pub support: f32,
    /// Iso-surface: threshold of the normalised field (splashsurf: 0.6).
    pub threshold: f32,
    /// Iso-surface: smallest march step, particle radii.
    pub step: f32,
    /// Iso-surface: radius of the spheres the march starts from, particle radii. Where the surface bulges past
    /// them the march steps back to it; only silhouettes outside every bound sphere are lost. Measured on the
    /// shared frame (tools/quality.sh, lavapipe), the exact field: 2.0 → IoU 0.997 at 276 ms, 1.75 → 0.996 at
    /// 194 ms, 1.5 → 0.987 at 142 ms, normals unchanged (0.8° median); the smoothed default: 1.75 → IoU 0.995,
    /// 1.5 → 0.985 against the raw reference, normals within 0.1°, the cast 27 % cheaper on the moving 59k
    /// sequence (docs/iso-surface.md).
    pub bound: f32,
    /// Iso-surface: most march steps per pixel.
    pub max_steps: u32,
    /// Iso-surface: bisection iterations after the first step past the threshold, before the final linear
    /// interpolation (0: the interpolation alone, as accurate on the shared frame and 28 % cheaper than 4).
    pub refine: u32,
    /// Iso-surface: samples per ray in the cast's first dispatch; the rays still marching after them are queued
    /// and finished by a second, indirect dispatch (`rest_lanes` lanes each), so a SIMD vector or warp of the
    /// first dispatch does not wait on one long ray among short ones (0: one dispatch runs every ray to the
    /// end). The same surface with `rest_lanes` = 1; only the cost changes (see iso_cast.glsl). 4 by default:
    /// on an H100 the `iso` pass 0.47 → 0.43 ms on the 59k sequence at 1080p and 0.36 → 0.30 at 540p against 8
    /// (the nvidia-h100-iso-rest-lanes runs, in git history), on lavapipe within its noise.
    pub first_steps: u32,
    /// Iso-surface: lanes that march one queued ray together in the cast's second dispatch (1, 8 or 32). With
    /// more than one, each step samples that many consecutive smallest steps at once and the ray moves to the
    /// farthest point they show free of the surface, so the longest rays — a few hundred grazing rays behind
    /// spray, which bound the dispatch on a GPU whatever the resolution — take that many times fewer dependent
    /// steps. 32 takes 32 lanes per ray while at most ISO_WIDE_SPLIT (32,768) rays are queued and 8 for more
    /// (decided on the GPU from the queue's count). The device's subgroups bound it (`meniscus info --device`):
    /// 32 needs subgroups of 32 or 64 (NVIDIA, AMD), 8 of 8 or more (lavapipe: 8); the pass takes the widest
    /// the device allows up to this, 1 where it cannot shuffle. The crossing is bracketed on a finer lattice
    /// than one lane's march, so a queued ray's depth may differ from it within the final interpolation's
    /// error (tests/gpu_passes.rs, `iso_surface_matches_cpu_ray_cast`).
    pub rest_lanes: u32,
    /// Iso-surface, coarse-to-fine: where a particle's radius on screen is at least this many pixels (the
    /// frame's nearest particle decides whether it runs at all), only the pixels with even x and y march, then
    /// take one Newton step of the field; every other pixel keeps its marched neighbours' mean depth where
    /// their second differences say the surface is flat there, else takes one Newton step from it (one field
    /// sum instead of a march), or marches where a neighbour missed, the neighbours' depths spread more than
    /// 1 r, or the step is longer than ¼ r. Isotropic kernels only (0: every pixel marches).
    pub fine_px: f32,
    /// Iso-surface: σ of a 3D Gaussian blur of the field where the water is bulk, particle radii (0: the exact
    /// field). The blurred field is then built once per set of particles on a sparse lattice of `voxel` radii
    /// (`iso_volume`: bricks only where particles reach) and read with a quadratic B-spline; the cast
    /// blends it with the exact field by `bulk`: calm water loses the particle-scale bumps the raw field has,
    /// spray and thin sheets keep their shape. Isotropic kernels only. The default 1.1 meets both references'
    /// targets on the shared frames and on a drop's splash, where 1.5 smoothed the jet 7.2° away from the raw
    /// reference (docs/iso-surface.md).
    pub smoothing: f32,
    /// Iso-surface: σ of the blur for water whose particles sit on a lattice (particle radii): a scene
    /// generator's output, a simulation's first frames, a resting pool before it settles. Such water crosses
    /// its particle layers in terraces whose treads are wider than `smoothing` blurs away (the built-in wave
    /// shows them as rows); each particle's blur is blended from `smoothing` to this by its lattice order (1
    /// where none of its neighbours lies between a lattice's first two shells, 0 in a liquid: iso_density.comp),
    /// so disordered, moving water keeps `smoothing`. 2.0: the wave's and the drop's roughness p90 3.8° → 1.4°,
    /// the shared frames unchanged (docs/quality.md). Equal to `smoothing`: one blur for all.
    pub lattice_smoothing: f32,
    /// Iso-surface smoothing: the blur's weight ramps (smoothstep) from 0 to 1 as the neighbour count c_j =
    /// Σ_k (1 − d²/h²) (splashsurf's feature weight), interpolated to the lattice, goes from bulk[0] to bulk[1]
    /// (bulk[1] ≤ bulk[0]: blur everywhere).
    pub bulk: [f32; 2],
    /// Iso-surface smoothing: the lattice's spacing, particle radii. The lattice holds only the blurred field
    /// (σ ≈ 1.55 r with the kernel's own spread at the default smoothing), which voxels of 2 r hold without
    /// creases (a tilted sheet's normals step 0.36° between pixels; tests/gpu_passes.rs, docs/iso-surface.md);
    /// never changed behind the user's back: a box too long for the brick table is an error that says so.
    pub voxel: f32,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            support: 4.0,
            threshold: 0.6,
            step: 0.5,
            bound: 1.5,
            max_steps: 512,
            refine: 0,
            first_steps: 4,
            rest_lanes: 32,
            fine_px: 4.0,
            smoothing: 1.1,
            lattice_smoothing: 2.0,
            bulk: [4.0, 9.0],
            voxel: 2.0,
        }
    }
}

impl Params {
    /// In world units for particles of `radius` (the frame's), with the anisotropic kernels' parameters when
    /// the kernels are ellipsoids (the smoothed field is isotropic only). The view's near plane is set per frame.
    pub fn world(&self, radius: f32, aniso: Option<crate::field::iso::AnisoParams>) -> crate::field::iso::IsoParams {
        crate::field::iso::IsoParams {
            threshold: self.threshold,
            step: self.step * radius,
            bound: self.bound * radius,
            max_steps: self.max_steps,
            refine: self.refine,
            first_steps: self.first_steps,
            rest_lanes: self.rest_lanes,
            radius,
            fine_px: self.fine_px,
            volume: (self.smoothing > 0.0 && aniso.is_none()).then_some(crate::field::volume::VolumeParams {
                sigma: self.smoothing * radius,
                bulk: self.bulk,
                spacing: self.voxel * radius,
                support: self.support * radius,
                lattice_sigma: self.lattice_smoothing * radius,
                particle_spacing: 2.0 * radius,
            }),
            aniso,
            // The view's (the GPU reads it from the frame); CPU references set it.
            near: 0.0,
        }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(NAME);
        k.within("support", self.support, 1.0, 16.0)?;
        k.above("threshold", self.threshold, 0.0, 1.0)?;
        k.rule("threshold", self.threshold < 1.0, || format!("threshold = {} must be below 1", self.threshold))?;
        k.within("step", self.step, 0.01, 4.0)?;
        k.within("bound", self.bound, 0.5, 16.0)?;
        k.rule("bound", self.bound <= self.support, || {
            format!("bound = {} must be at most support = {}", self.bound, self.support)
        })?;
        k.count("max_steps", self.max_steps, 1, 65536)?;
        k.count("refine", self.refine, 0, 32)?;
        k.count("first_steps", self.first_steps, 0, 65536)?;
        k.rule("rest_lanes", matches!(self.rest_lanes, 1 | 8 | 32), || {
            format!("rest_lanes = {} must be 1, 8 or 32", self.rest_lanes)
        })?;
        k.within("fine_px", self.fine_px, 0.0, 64.0)?;
        k.rule("fine_px", self.fine_px == 0.0 || self.fine_px >= 1.0, || {
            format!("fine_px = {} must be 0 (off) or 1 … 64", self.fine_px)
        })?;
        k.within("smoothing", self.smoothing, 0.0, 8.0)?;
        k.within("lattice_smoothing", self.lattice_smoothing, 0.0, 8.0)?;
        k.each("bulk", &self.bulk, 0.0, 1000.0)?;
        k.within("voxel", self.voxel, 0.25, 4.0)
    }
}

/// Coarse-to-fine: the widest spread of the marched neighbours' depths, and the longest Newton step, that a
/// fine pixel trusts (particle radii; see [`Params::fine_px`]).
pub const FINE_SPREAD: f32 = 1.0;
/// See [`FINE_SPREAD`].
pub const FINE_STEP: f32 = 0.25;
