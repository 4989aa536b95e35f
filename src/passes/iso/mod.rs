//! `iso` pass (runs after `splat` when `surface = "iso"`): replaces the splatted sphere depth by the depth of
//! the SPH colour-field iso-surface, ray-cast per pixel (shaders_glsl/iso.comp, field in iso_field.glsl,
//! CPU reference and grid build in src/field/iso/mod.rs). The grid (points sorted by cell + cell table) is built on the GPU
//! (`grid` pass, or uploaded with isolated particles) and the `iso_density` pass (1/n_j per point, its own timestamp; and
//! each cell's empty distance, iso_empty.comp, which the casts skip empty space by) runs when the particles
//! change; every frame, the march from the bound spheres' depth (two dispatches: the first samples of every ray,
//! then the queued long rays).
//! With `[iso] smoothing` > 0 (the default) the field is smoothed in 3D where the water is bulk: when the
//! particles change, `iso_volume` (iso_volume.comp) allocates the bricks of a sparse lattice where the particles
//! reach and deposits their mass and neighbour counts there with a smooth kernel as wide as the smoothing; the
//! cast (iso_vol.comp) reads them with a quadratic B-spline and blends them with the exact field where the water
//! is not bulk. CPU reference: VolumeShape::{marked, deposit, sample}, smoothed_field in src/field/iso/mod.rs.
use std::sync::Arc;

use ash::vk;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::field::iso::IsoGrid;
use crate::shaders;

pub mod queue;
mod volume;
pub use volume::{IsoVolume, VolPush};

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `iso`.
pub const NAME: &str = "iso";
/// The weights' pass (shaders_glsl/iso_density.comp), recorded only when the particles changed.
pub const DENSITY_NAME: &str = "iso_density";
/// The smoothed field's sparse lattice (shaders_glsl/iso_volume.comp), recorded when the particles or
/// `[iso] smoothing`, `bulk` or `voxel` changed.
pub const VOLUME_NAME: &str = "iso_volume";

/// Settings of the `iso` pass: the `[iso]` section of a settings file.
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
        k.each("bulk", &self.bulk, 0.0, 1000.0)?;
        k.within("voxel", self.voxel, 0.25, 4.0)
    }
}

/// Coarse-to-fine: the widest spread of the marched neighbours' depths, and the longest Newton step, that a
/// fine pixel trusts (particle radii; see [`Params::fine_px`]).
pub const FINE_SPREAD: f32 = 1.0;
/// See [`FINE_SPREAD`].
pub const FINE_STEP: f32 = 0.25;

/// The grid on the device, and its shape (origin, cell, dims, point count, support) as push constants; the
/// CPU copy of the grid is not kept.
pub struct IsoBuffers {
    /// Grid points sorted by cell.
    pub points: Buffer,
    /// Cell table (first point, count).
    pub cells: Buffer,
    /// The casts' copy of the cell table, each cell's empty distance in the count's top bits (`iso_density`'s
    /// iso_empty dispatches write it), and their scratch (two u32 per cell).
    pub cells_empty: Buffer,
    /// See [`IsoBuffers::cells_empty`].
    pub empty_scratch: Buffer,
    /// The sorted points with their weights (xyz, 1 / n_j), written by `iso_density`, read by the casts.
    pub weighted: Buffer,
    /// Each point's anisotropic kernel (three vec4), written by the `anisotropy` pass.
    pub aniso: Buffer,
    /// Each sorted point's neighbour count c_j (R32F), written by `iso_density`, read by `iso_volume`.
    pub counts: Buffer,
    /// Grid shape as push constants.
    pub shape: IsoPush,
    /// The GPU grid (`grid` pass + `iso_gather`) that fills `points` and `cells` from the particle buffer;
    /// `None` when the CPU built and uploaded them.
    pub gpu: Option<crate::compute::grid::GridBuffers>,
    /// The GPU grid must be rebuilt by the next frame (its particles changed).
    pub rebuild: std::cell::Cell<bool>,
    /// `weighted` must be recomputed (`iso_density`) before the next cast: the particles or the support changed.
    /// The weights depend on the particles alone, not the view, so a static set of particles (a paused demo, a
    /// file explored with a moving camera, `bench` of one frame) computes them once, like its grid.
    pub weights_stale: std::cell::Cell<bool>,
    /// The parameters `aniso` was computed with for the current particles (`None`: stale). The kernels, like the
    /// weights, depend on the particles, not the view: the `anisotropy` pass runs when either changes.
    pub kernels_for: std::cell::Cell<Option<crate::field::iso::AnisoParams>>,
    /// The smoothed field's lattice (`[iso] smoothing` > 0; allocated by the renderer for the grid's box).
    pub volume: Option<IsoVolume>,
    /// The parameters `volume` holds the field for, for the current particles (`None`: stale).
    pub volume_for: std::cell::Cell<Option<crate::field::volume::VolumeParams>>,
}

impl IsoBuffers {
    /// The particles (or the support) changed: the weights, the kernels and the smoothed field must be
    /// computed again.
    pub fn mark_stale(&self) {
        self.weights_stale.set(true);
        self.kernels_for.set(None);
        self.volume_for.set(None);
    }

    /// The texel formats iso_field.glsl reads them in: points xyzw, cells (first, count), weights, kernels.
    pub const POINTS: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
    /// See [`IsoBuffers::POINTS`].
    pub const CELLS: vk::Format = vk::Format::R32G32_UINT;
    /// See [`IsoBuffers::POINTS`].
    pub const WEIGHTED: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
    /// See [`IsoBuffers::POINTS`].
    pub const ANISO: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
}

/// Push constants (IsoPush in iso_field.glsl).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct IsoPush {
    /// Grid origin xyz, w: cell size.
    pub origin: [f32; 4],
    /// Grid dimensions xyz, w: point count.
    pub dims: [u32; 4],
    /// x: support, y: threshold, z: smallest step, w: bound sphere radius (world units).
    pub params: [f32; 4],
    /// x: most steps, y: bisection iterations, z: the far bound (0 none, 1 per pixel, 2 per 8×8 tile), w: samples
    /// of the first dispatch (the rest are queued).
    pub steps: [u32; 4],
    /// The `anisotropy` pass's parameters: k_r, N_ε, centre blend, longest centre move (world units).
    pub aniso: [f32; 4],
    /// x: the kernels' longest axis (units of h).
    pub aniso2: [f32; 4],
    /// Coarse-to-fine: x: particle radius ÷ the least radius on screen in pixels (0: off), y: iso_fine's phase
    /// (0: the marched pixels' Newton step, 1: the other pixels) and the queue round iso_rest finishes (0: the
    /// first dispatch's rays, 1: the fine dispatch's fallbacks), z: the widest spread of the marched neighbours'
    /// depths, w: the longest Newton step (world units).
    pub fine: [f32; 4],
    /// The smoothed field's cast: xy: the bulk ramp of c̄, z: the bound of |∇B| (VolumeParams::gradient_bound),
    /// w: how far (voxels) every point lies beyond a brick the lattice left unallocated
    /// (VolumeShape::empty_reach).
    pub volume: [f32; 4],
}

impl IsoPush {
    /// The shape of the CPU-built grid `g`; the march parameters are filled in by `with`.
    pub fn shape(g: &IsoGrid) -> IsoPush {
        let o = g.origin;
        IsoPush::grid([o.x, o.y, o.z, g.cell], [g.dims[0], g.dims[1], g.dims[2], g.points.len() as u32], g.support)
    }

    /// A grid's shape: origin and cell side, cells per axis and point count, kernel support (world units).
    pub fn grid(origin_cell: [f32; 4], dims_points: [u32; 4], support: f32) -> IsoPush {
        IsoPush {
            origin: origin_cell,
            dims: dims_points,
            params: [support, 0.0, 0.0, 0.0],
            steps: [0; 4],
            aniso: [0.0; 4],
            aniso2: [1.0, 0.0, 0.0, 0.0],
            fine: [0.0; 4],
            volume: [0.0; 4],
        }
    }

    /// This shape with the march parameters `p`; `back`: 0, or the far bound per pixel (1) or per 8×8 tile (2).
    pub fn with(self, p: &crate::field::iso::IsoParams, back: u32) -> IsoPush {
        IsoPush {
            params: [self.params[0], p.threshold, p.step, p.bound],
            steps: [p.max_steps, p.refine, back, if p.first_steps == 0 { p.max_steps } else { p.first_steps }],
            aniso2: [p.aniso.map_or(1.0, |a| a.stretch.max(1.0)), 0.0, 0.0, 0.0],
            // No gradient of the anisotropic field: those casts march every pixel. `record` turns it off for a
            // frame whose particles are all smaller on screen.
            fine: [
                if p.aniso.is_none() && p.fine_px > 0.0 { p.radius / p.fine_px } else { 0.0 },
                0.0,
                FINE_SPREAD * p.radius,
                FINE_STEP * p.radius,
            ],
            ..self
        }
    }

    /// Kernel support (world units).
    pub fn support(&self) -> f32 {
        self.params[0]
    }
}

/// The pass: its compute program(s), built once per device.
pub struct Iso {
    density: ComputeProgram<IsoPush>,
    empty: [ComputeProgram<EmptyPush>; 3],
    cast: ComputeProgram<IsoPush>,
    cast_blocks: ComputeProgram<IsoPush>,
    cast_aniso: ComputeProgram<IsoPush>,
    /// The tiles that hold fluid, for the first dispatch (iso_tiles.comp).
    tiles: ComputeProgram<()>,
    rest: ComputeProgram<IsoPush>,
    rest_aniso: ComputeProgram<IsoPush>,
    fine: ComputeProgram<IsoPush>,
    grid: crate::compute::grid::NeighbourGrid,
    gather: ComputeProgram<GatherPush>,
    volume: [ComputeProgram<VolPush>; 4],
    cast_vol: ComputeProgram<IsoPush>,
    rest_vol: ComputeProgram<IsoPush>,
    /// The queued rays marched by 8 and by 32 lanes each (exact and smoothed field), where the device shuffles
    /// within subgroups that wide (`DeviceInfo::subgroup_shuffle`, `subgroup_size`).
    rest_wide8: Option<[ComputeProgram<IsoPush>; 2]>,
    /// With 32 lanes: [32 lanes for few rays, 8 for many] per field (exact, smoothed).
    rest_wide32: Option<[[ComputeProgram<IsoPush>; 2]; 2]>,
}

/// Push constants of iso_gather.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GatherPush {
    /// Points.
    pub n: u32,
    /// Cells.
    pub cells: u32,
}

// Gather: particles, order, start, counts → sorted points, cell table.
declare_program!(pub GATHER: GatherPush = compute(shaders::ISO_GATHER, [BufRead, BufRead, BufRead, BufRead, BufRead, BufWrite, BufWrite]));

// Density: frame, grid points, cell table → the weighted points (xyz, 1/n_j), the neighbour counts c_j.
declare_program!(pub DENSITY: IsoPush = compute(shaders::ISO_DENSITY, [Uniform, TexelRead, TexelRead, BufWrite, BufWrite]));
// The cells' empty distance, an axis per dispatch: cell table → scratch .x; scratch .x → .y; cell table and
// scratch .y → the casts' cell table.
declare_program!(pub EMPTY_X: EmptyPush = compute(shaders::ISO_EMPTY_X, [Uniform, TexelRead, BufWrite]));
declare_program!(pub EMPTY_Y: EmptyPush = compute(shaders::ISO_EMPTY_Y, [Uniform, BufWrite]));
declare_program!(pub EMPTY_Z: EmptyPush = compute(shaders::ISO_EMPTY_Z, [Uniform, TexelRead, BufRead, BufWrite]));

/// Push constants of iso_empty.comp: cells per axis, and all cells.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct EmptyPush {
    /// xyz: cells per axis; w: cells.
    pub dims: [u32; 4],
}
// Ray cast: frame, the weighted points, the cell table, depth (read as the start, written as the surface), back
// depth, the queue of unfinished rays and its header (written).
declare_program!(pub CAST: IsoPush = compute(shaders::ISO, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufWrite, BufWrite, BufWrite, BufRead]));
// The tiles of the bound spheres' depth that hold fluid: frame (binding 0, unread), depth → the queue's header (the first dispatch's work
// groups), the tiles listed; the first dispatch (CAST, CAST_ANISO, CAST_VOL) reads them after its work counts.
declare_program!(pub TILES: () = compute(shaders::ISO_TILES, [Uniform, ImgRead, BufWrite, BufWrite]));
// The first dispatch with coarse-to-fine on: one invocation per 2×2 block (iso_cast.glsl).
declare_program!(pub CAST_BLOCKS: IsoPush = compute(shaders::ISO_BLOCKS, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufWrite, BufWrite, BufWrite]));
// The same over the anisotropic kernels (a separate program: a run-time branch in the field's inner loop doubled
// the isotropic cast's cost on lavapipe, 553 → 988 ms on the dam-break frame at 960×540).
declare_program!(pub CAST_ANISO: IsoPush = compute(shaders::ISO_ANISO, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufWrite, BufWrite, TexelRead, BufWrite, BufRead]));
// The second dispatches: the queued rays finished (the queue and its header read).
declare_program!(pub REST: IsoPush = compute(shaders::ISO_REST, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, BufWrite]));
// The same, 8 or 32 lanes per ray (`[iso] rest_lanes`; iso_cast.glsl).
declare_program!(pub REST_WIDE8: IsoPush = compute(shaders::ISO_REST_WIDE8, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, BufWrite]));
declare_program!(pub REST_WIDE32: IsoPush = compute(shaders::ISO_REST_WIDE32, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, BufWrite]));
declare_program!(pub REST_WIDE8_MANY: IsoPush = compute(shaders::ISO_REST_WIDE8_MANY, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, BufWrite]));
declare_program!(pub REST_ANISO: IsoPush = compute(shaders::ISO_ANISO_REST, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, TexelRead, BufWrite]));
// Coarse-to-fine (isotropic only), twice: phase 0 (fine.y = 0) polishes the marched pixels with a Newton step;
// phase 1 gives the pixels the first dispatches left their marched neighbours' depth (with a Newton step where
// the surface curves) and queues those it cannot trust (round 1) for a second `rest`.
declare_program!(pub FINE: IsoPush = compute(shaders::ISO_FINE, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufWrite, BufWrite, BufWrite]));

// The smoothed field: the weighted points mark the bricks they need in the table; the marked bricks take pool
// indices (the header counts them, their coordinates listed); the points deposit their sums (integer atomics).
declare_program!(pub VOLUME_MARK: VolPush = compute(shaders::ISO_VOLUME_MARK, [Uniform, TexelRead, BufWrite]));
declare_program!(pub VOLUME_ALLOC: VolPush = compute(shaders::ISO_VOLUME_ALLOC, [Uniform, BufWrite, BufWrite, BufWrite]));
declare_program!(pub VOLUME: VolPush = compute(shaders::ISO_VOLUME, [Uniform, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite]));
// The same deposit with one 64-bit atomic per voxel (devices with shaderBufferInt64Atomics: `DeviceInfo::int64_atomics`).
declare_program!(pub VOLUME_DEPOSIT64: VolPush = compute(shaders::ISO_VOLUME_DEPOSIT64, [Uniform, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite]));
// Each allocated brick's apron copied from its neighbours.
declare_program!(pub VOLUME_APRON: VolPush = compute(shaders::ISO_VOLUME_APRON, [Uniform, TexelRead, TexelRead, TexelRead, BufWrite]));
// The casts over the smoothed field: frame, weighted points, cells, depth, back, queue, header, table, field.
declare_program!(pub CAST_VOL: IsoPush = compute(shaders::ISO_VOL, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufWrite, BufWrite, TexelRead, TexelRead, BufWrite, BufRead]));
declare_program!(pub REST_VOL: IsoPush = compute(shaders::ISO_VOL_REST, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, TexelRead, TexelRead, BufWrite]));
declare_program!(pub REST_VOL_WIDE8: IsoPush = compute(shaders::ISO_VOL_REST_WIDE8, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, TexelRead, TexelRead, BufWrite]));
declare_program!(pub REST_VOL_WIDE32: IsoPush = compute(shaders::ISO_VOL_REST_WIDE32, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, TexelRead, TexelRead, BufWrite]));
declare_program!(pub REST_VOL_WIDE8_MANY: IsoPush = compute(shaders::ISO_VOL_REST_WIDE8_MANY, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, TexelRead, TexelRead, BufWrite]));

impl Iso {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Iso {
            density: ComputeProgram::new(gpu, &DENSITY)?,
            empty: [
                ComputeProgram::new(gpu, &EMPTY_X)?,
                ComputeProgram::new(gpu, &EMPTY_Y)?,
                ComputeProgram::new(gpu, &EMPTY_Z)?,
            ],
            cast: ComputeProgram::new(gpu, &CAST)?,
            cast_blocks: ComputeProgram::new(gpu, &CAST_BLOCKS)?,
            cast_aniso: ComputeProgram::new(gpu, &CAST_ANISO)?,
            tiles: ComputeProgram::new(gpu, &TILES)?,
            rest: ComputeProgram::new(gpu, &REST)?,
            rest_aniso: ComputeProgram::new(gpu, &REST_ANISO)?,
            fine: ComputeProgram::new(gpu, &FINE)?,
            grid: crate::compute::grid::NeighbourGrid::new(gpu)?,
            gather: ComputeProgram::new(gpu, &GATHER)?,
            volume: [
                ComputeProgram::new(gpu, &VOLUME_MARK)?,
                ComputeProgram::new(gpu, &VOLUME_ALLOC)?,
                ComputeProgram::new(gpu, if gpu.info.int64_atomics { &VOLUME_DEPOSIT64 } else { &VOLUME })?,
                ComputeProgram::new(gpu, &VOLUME_APRON)?,
            ],
            cast_vol: ComputeProgram::new(gpu, &CAST_VOL)?,
            rest_vol: ComputeProgram::new(gpu, &REST_VOL)?,
            rest_wide8: if gpu.info.shuffle_lanes(8) == 8 {
                Some([ComputeProgram::new(gpu, &REST_WIDE8)?, ComputeProgram::new(gpu, &REST_VOL_WIDE8)?])
            } else {
                None
            },
            rest_wide32: if gpu.info.shuffle_lanes(32) == 32 {
                Some([
                    [ComputeProgram::new(gpu, &REST_WIDE32)?, ComputeProgram::new(gpu, &REST_WIDE8_MANY)?],
                    [ComputeProgram::new(gpu, &REST_VOL_WIDE32)?, ComputeProgram::new(gpu, &REST_VOL_WIDE8_MANY)?],
                ])
            } else {
                None
            },
        })
    }

    /// When `b` has a GPU grid due for a rebuild: sort the first `n` particles of `particles` into it (the
    /// `grid` pass) and gather the sorted points and the cell table.
    pub fn record_grid(&self, ctx: &mut FrameCtx, particles: &Buffer, n: u32, b: &IsoBuffers) {
        let Some(g) = &b.gpu else { return };
        if !b.rebuild.replace(false) {
            return;
        }
        ctx.pass(crate::compute::grid::NAME, |ctx| {
            self.grid.record(ctx, particles, n, g);
            let cells = g.shape.cells();
            let (order, start, counts, keys) = (&g.order, &g.start, &g.counts, &g.keys);
            let res = [
                particles.into(),
                order.into(),
                start.into(),
                counts.into(),
                keys.into(),
                (&b.points).into(),
                (&b.cells).into(),
            ];
            self.gather.dispatch(ctx, &res, &GatherPush { n, cells }, [n.max(cells).div_ceil(super::LOCAL_1D), 1, 1]);
        });
    }

    /// When `b`'s weights are stale: the `iso_density` pass, each sorted point with its weight 1/n_j (its own
    /// timestamp, so sequences, where it runs every frame, show its cost).
    pub fn record_density(&self, ctx: &mut FrameCtx, frame: &Buffer, b: &IsoBuffers) {
        if !b.weights_stale.replace(false) {
            return;
        }
        ctx.pass(DENSITY_NAME, |ctx| {
            let n = b.shape.dims[3];
            let bufs = [frame.into(), (&b.points).into(), (&b.cells).into(), (&b.weighted).into(), (&b.counts).into()];
            self.density.dispatch(ctx, &bufs, &b.shape, [n.div_ceil(super::LOCAL_1D), 1, 1]);
            let d = b.shape.dims;
            let cells = d[0] * d[1] * d[2];
            let push = EmptyPush { dims: [d[0], d[1], d[2], cells] };
            let g = [cells.div_ceil(super::LOCAL_1D), 1, 1];
            let (table, scratch) = ((&b.cells).into(), (&b.empty_scratch).into());
            self.empty[0].dispatch(ctx, &[frame.into(), table, scratch], &push, g);
            self.empty[1].dispatch(ctx, &[frame.into(), scratch], &push, g);
            self.empty[2].dispatch(ctx, &[frame.into(), table, scratch, (&b.cells_empty).into()], &push, g);
        });
    }

    /// When `b`'s smoothed field is stale for `p` (new particles or parameters): `iso_volume` (the bricks
    /// marked and allocated, the sums deposited), with its own timestamp. Like the weights, the field depends
    /// on the particles alone: a static set builds it once.
    pub fn record_volume(&self, ctx: &mut FrameCtx, frame: &Buffer, b: &IsoBuffers, p: &crate::field::volume::VolumeParams) {
        let Some(v) = &b.volume else { return };
        if b.volume_for.get() == Some(*p) {
            return;
        }
        b.volume_for.set(Some(*p));
        let n = b.shape.dims[3];
        let per_point = [n.div_ceil(super::LOCAL_1D), 1, 1];
        ctx.pass(VOLUME_NAME, |ctx| {
            ctx.part("iso_volume/clear", |ctx| {
                ctx.fill(&v.table, 0);
                ctx.fill(&v.header, 0);
                ctx.fill(&v.acc, 0);
                ctx.fill(&v.work.buffer, 0);
            });
            let push = v.vol_push(p, n);
            let mark = [frame.into(), (&b.weighted).into(), (&v.table).into()];
            ctx.part("iso_volume/mark", |ctx| self.volume[0].dispatch(ctx, &mark, &push, per_point));
            let table = [(v.shape.table_len() as u32).div_ceil(super::LOCAL_1D), 1, 1];
            let alloc = [frame.into(), (&v.table).into(), (&v.header).into(), (&v.coords).into()];
            ctx.part("iso_volume/alloc", |ctx| self.volume[1].dispatch(ctx, &alloc, &push, table));
            let (weighted, counts, table, acc, work) = (&b.weighted, &b.counts, &v.table, &v.acc, &v.work.buffer);
            let dep = [frame.into(), weighted.into(), counts.into(), table.into(), acc.into(), work.into()];
            ctx.part("iso_volume/deposit", |ctx| self.volume[2].dispatch(ctx, &dep, &push, per_point));
            let apron = [frame.into(), (&v.table).into(), (&v.coords).into(), (&v.header).into(), (&v.acc).into()];
            let stored = v.capacity as u64 * crate::field::volume::STORED_BRICK_VOXELS as u64;
            let groups = [stored.div_ceil(super::LOCAL_1D as u64) as u32, 1, 1];
            ctx.part("iso_volume/apron", |ctx| self.volume[3].dispatch(ctx, &apron, &push, groups));
        });
    }

    /// Ray-cast the iso-surface into `depth` (which holds the bound spheres' depth on entry); `back`: the far
    /// bound from the splat, per pixel or per 8×8 tile, where the march may stop (else it runs to the grid's box);
    /// `queue`: where the first dispatch leaves the rays the second finishes. Coarse-to-fine runs when the
    /// nearest particle (`info.d_near`) is at least `[iso] fine_px` pixels in radius on screen.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        b: &IsoBuffers,
        params: &crate::field::iso::IsoParams,
        depth: &Image,
        back: Option<crate::passes::splat::BackBound>,
        queue: &queue::IsoQueue,
        info: &crate::passes::FrameInfo,
    ) {
        use crate::passes::splat::BackBound;
        let (mode, back) = match back {
            None => (0, None),
            Some(BackBound::Pixel(i)) => (1, Some(i)),
            Some(BackBound::Tile(i)) => (2, Some(i)),
        };
        let mut push = b.shape.with(params, mode);
        if params.radius * info.focal_px_fluid < params.fine_px * info.d_near {
            push.fine[0] = 0.0;
        }
        // The smoothed field: its lattice in the push constants; no coarse-to-fine (no field gradient there).
        let volume = b.volume.as_ref().zip(params.volume.as_ref());
        if let Some((v, vp)) = volume {
            push = v.push(push, vp);
            push.fine[0] = 0.0;
        }
        // Without a back image the binding still needs an image: the depth itself (never read then).
        let back_img = back.unwrap_or(depth);
        ctx.pass(NAME, |ctx| {
            ctx.fill(&queue.header, 0);
            ctx.fill(&queue.work.buffer, 0);
            // Coarse-to-fine: one invocation per 2×2 block (iso_cast.glsl).
            let block = if push.fine[0] > 0.0 { 2 } else { 1 };
            let (w, h) = (depth.extent.width.div_ceil(block), depth.extent.height.div_ceil(block));
            let g = groups_2d(w, h, super::LOCAL_2D);
            let (q, h) = ((&queue.entries).into(), (&queue.header).into());
            let mut all =
                vec![frame.into(), (&b.weighted).into(), (&b.cells_empty).into(), depth.into(), back_img.into(), q, h];
            let (cast, rest) = match (params.aniso, volume) {
                (Some(_), _) => {
                    all.push((&b.aniso).into());
                    (&self.cast_aniso, &self.rest_aniso)
                }
                (None, Some((v, _))) => {
                    all.push((&v.table).into());
                    all.push((&v.acc).into());
                    (&self.cast_vol, &self.rest_vol)
                }
                (None, None) => (&self.cast, &self.rest),
            };
            // The work counts after the field's bindings (iso_cast.glsl's ISO_WORK_BINDING).
            all.push((&queue.work.buffer).into());
            // Round 0's queued rays by 8 or 32 lanes each where asked for and the device can (isotropic only).
            let lanes = if params.aniso.is_none() { ctx.gpu.info.shuffle_lanes(params.rest_lanes) } else { 1 };
            let field = usize::from(volume.is_some());
            // (program, its arguments' offset) per dispatch: 32 lanes for few rays and 8 for many both run, one
            // of them finding nothing to do.
            let wide: Vec<(&ComputeProgram<IsoPush>, u64)> = match (lanes, &self.rest_wide8, &self.rest_wide32) {
                (32, _, Some(w)) => vec![(&w[field][0], queue::WIDE32_ARGS), (&w[field][1], queue::WIDE8_ARGS)],
                (8, Some(w), _) => vec![(&w[field], queue::WIDE8_ARGS)],
                _ => vec![],
            };
            let fine = push.fine[0] > 0.0;
            if fine {
                ctx.part("iso/cast", |ctx| self.cast_blocks.dispatch(ctx, &all, &push, g));
            } else {
                // A work group per tile of the bound spheres' depth that holds fluid (iso_tiles.comp).
                ctx.part("iso/tiles", |ctx| {
                    self.tiles.dispatch(ctx, &[frame.into(), depth.into(), h, (&queue.tiles).into()], &(), g);
                });
                let mut first = all.clone();
                first.push((&queue.tiles).into());
                ctx.part("iso/cast", |ctx| cast.dispatch_indirect(ctx, &first, &push, &queue.header, queue::TILES_ARGS));
            }
            if push.steps[3] < push.steps[0] {
                ctx.part("iso/rest", |ctx| {
                    if wide.is_empty() {
                        rest.dispatch_indirect(ctx, &all, &push, &queue.header, 0);
                    }
                    for (w, at) in &wide {
                        w.dispatch_indirect(ctx, &all, &push, &queue.header, *at);
                    }
                });
            }
            if fine {
                let phase = |k: f32| IsoPush { fine: [push.fine[0], k, push.fine[2], push.fine[3]], ..push };
                ctx.part("iso/fine", |ctx| {
                    self.fine.dispatch(ctx, &all, &phase(0.0), g);
                    self.fine.dispatch(ctx, &all, &phase(1.0), g);
                });
                ctx.part("iso/fine_rest", |ctx| rest.dispatch_indirect(ctx, &all, &phase(1.0), &queue.header, 16));
            }
        });
    }
}
