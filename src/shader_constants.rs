// Constants shared by Rust and GLSL, defined once here. build.rs `include!`s this file and passes every entry of
// `SHADER_CONSTANTS` to shaderc as a macro definition (`#define LOCAL_2D 8u`), so the shaders never spell them;
// the library uses the same `pub const`s (as `meniscus::shader_constants::*`). Plain `//` comments only: the file
// is also included into build.rs, where inner doc comments are not allowed.

/// 8×8 work groups for image passes.
pub const LOCAL_2D: u32 = 8;
/// Texels of a row each invocation of the compute clear (shaders_glsl/clear.comp) writes.
pub const CLEAR_SPAN: u32 = 4;
/// 64-thread work groups for per-particle passes.
pub const LOCAL_1D: u32 = 64;
/// Work-group edge of the tiled curvature-flow shader (filter_curvature.comp).
pub const CURVATURE_LOCAL: u32 = 8;
/// Boxes of the background scene in the frame's uniform block.
pub const MAX_BOXES: u32 = 8;
/// Spheres in the background scene (the frame block's `spheres`: a simulation's moving bodies).
pub const MAX_SPHERES: u32 = 4;
/// Value of an `ssr` pixel whose ray hits nothing.
pub const SSR_MISS: u32 = 0xffff_ffff;
/// Per-thread pixel budget of the particle passes: a sphere covering more (it swallowed the camera) is skipped.
pub const MAX_PIXELS_PER_PARTICLE: u32 = 1 << 20;
/// Coarser levels of the `noise` pass's accumulator (level L holds texels of 2^L × 2^L pixels): a sprite is
/// evaluated at the coarsest level that still samples its finer octave `[noise] lod_samples` times per cycle.
pub const NOISE_LEVELS: u32 = 6;
/// The most samples per cycle of the noise's finer octave a sprite's level keeps (`[noise] lod_samples`, the
/// `noise` pass's level of detail; default 4): NOISE_MAX_TILES assumes no more.
pub const NOISE_LOD_SAMPLES: u32 = 6;
/// Texels per edge of a tile of the `noise` pass's tiled splat (a 16×16 work group sums one tile).
pub const NOISE_TILE: u32 = 16;
/// Sprites of a tile's list that one work group of noise_gather.comp sums (one batch in shared memory): a tile
/// with more is split into chunks, each its own work group (noise_scan.comp numbers them).
pub const NOISE_CHUNK: u32 = NOISE_TILE * NOISE_TILE;
/// Most tiles one sprite is binned to (a sprite's level keeps it under 39 texels across: at most 4 × 4 tiles).
pub const NOISE_MAX_TILES: u32 = 16;
/// Fixed-point units per particle radius of a detail height field (the `noise` pass's accumulator, read by
/// `normals` and the composite's tint layer): 2^16, so a term's rounding error is 2^−17 radii.
pub const DETAIL_UNITS: u32 = 1 << 16;
/// Layers the `composite` pass lays over the shaded water (the effects' images: `crate::layer::Layer`).
pub const COMPOSITE_LAYERS: u32 = 4;
/// Vec4s per fluid particle in the renderer's particle buffer ([`ParticleLayout`]): its position and, after all
/// positions, its motion (id bits, |Δv|/Δt), read by the `noise` pass.
pub const PARTICLE_VEC4S: u32 = 2;
/// Vec4s per diffuse particle in the renderer's particle buffer ([`ParticleLayout`]).
pub const DIFFUSE_VEC4S: u32 = 2;
/// Bytes per particle of the renderer's particle buffer (PARTICLE_VEC4S vec4s).
pub const BYTES_PER_PARTICLE: u64 = 16 * PARTICLE_VEC4S as u64;
/// Where everything lives in the particle buffer, in vec4s — the one definition of its layout (the shaders
/// compute the same offsets with shaders_glsl/particle_layout.glsl): `count` positions, `count` motions, a
/// header vec4 when a GPU producer writes the diffuse particles (the `diffuse` pass's indirect dispatch:
/// groups, 1, 1, particles drawn), then `diffuse` diffuse particles of two vec4 each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(dead_code)] // build.rs includes this file too
pub struct ParticleLayout {
    /// Fluid particles.
    pub count: u32,
    /// Whether the diffuse particles follow a header (a GPU producer's).
    pub header: bool,
    /// Diffuse particles (at most, for a GPU producer's).
    pub diffuse: u32,
}

#[allow(dead_code)]
impl ParticleLayout {
    /// The first motion (vec4 index).
    pub fn motions(&self) -> u64 {
        self.count as u64
    }

    /// The diffuse header (vec4 index; written only when `header`).
    pub fn diffuse_header(&self) -> u64 {
        PARTICLE_VEC4S as u64 * self.count as u64
    }

    /// The first diffuse particle (vec4 index).
    pub fn diffuse(&self) -> u64 {
        self.diffuse_header() + u64::from(self.header)
    }

    /// Bytes of the whole buffer.
    pub fn bytes(&self) -> u64 {
        16 * (self.diffuse() + DIFFUSE_VEC4S as u64 * self.diffuse as u64)
    }
}
/// Tile size of the splat's occlusion bound (`splat_cull`).
pub const SPLAT_TILE: u32 = 8;
/// Colliders of a simulation scene (sim_common.glsl's uniform block).
pub const MAX_COLLIDERS: u32 = 8;
/// Most neighbours a simulated particle keeps per step (sim_neighbours.comp).
pub const MAX_NEIGHBOURS: u32 = 64;
/// Threads of a prefix-sum work group (grid_scan.comp); each scans 4 cells, a block is 4 × this.
pub const SCAN_LOCAL: u32 = 256;
/// Cells scanned by one work group of grid_scan.comp.
pub const SCAN_BLOCK: u32 = 4 * SCAN_LOCAL;
/// Consecutive cells summed by one thread before the `grid` pass's prefix sum (grid_run_sum.comp).
pub const GRID_RUN: u32 = 32;

/// Smallest steps the `iso` march may take back towards the eye when it starts inside the surface (the surface
/// bulges past the bound sphere there), so a bound sphere tighter than every bulge stays exact.
pub const ISO_BACK_STEPS: u32 = 4;
/// Samples after which the `iso` march's smallest step doubles (rays that long graze the surface's shell).
pub const ISO_SHORT_STEPS: u32 = 8;
// The `iso` cast's wide second dispatch marches a queued ray with 8 or 32 consecutive lanes of a subgroup
// (`[iso] rest_lanes`, iso_cast.glsl): its work groups of LOCAL_1D threads hold whole rays of either width.
const _: () = assert!(LOCAL_1D.is_multiple_of(32));
/// With `[iso] rest_lanes` = 32, the most queued rays marched by 32 lanes each; more are marched by 8 each. On an
/// H100 (`first_steps` 4) 32 lanes won up to 18.9 k rays (the 59k still frame at 1080p: `iso/rest` 0.108 against
/// 0.141 ms) and 8 won from 41.7 k (the worst case at 540p: 0.049 against 0.095; the 59k sequence at 1080p, 56 k
/// rays: 0.175 against 0.222): the nvidia-h100-iso-lanes32-10b74e8 run (in git history)
pub const ISO_WIDE_SPLIT: u32 = 32768;
/// Work groups per row of the `iso` cast's first dispatch, one per tile that holds fluid (iso_tiles.comp): the
/// rows keep the dispatch within every device's 65,535 work groups per dimension (a 4K output has 129,600 tiles),
/// and at most this many − 1 groups of the last row find no tile.
pub const ISO_TILE_ROW: u32 = 64;
/// Cells the iso casts' empty distance looks along each axis (iso_empty.comp): a position in a cell at least
/// this + 1 cells (Chebyshev) from every cell holding a point is at least this many cells from every point.
pub const ISO_EMPTY_REACH: u32 = 3;
/// Top bits of the count in the casts' copy of the cell table that hold the cell's empty distance (≤ 15).
pub const ISO_EMPTY_BITS: u32 = 4;
/// Cubes per edge of a block of the GPU marching cubes (`mc` pass; the CPU path's blocks are 32).
pub const MC_BLOCK: u32 = 8;
/// Most triangles of one cube in the generated case table (mc_emit.comp's table stride).
pub const MC_MAX_TRIS: u32 = 12;

/// Fixed-point bits of the `iso_volume` pass's sums (integer atomics: the same sums in any order, no float-atomic
/// extension needed; 2^-20 per term, sums up to 4096).
pub const ISO_VOLUME_FIX_BITS: u32 = 20;
/// Voxels per edge of a brick of the smoothed iso field's sparse lattice: bricks exist only where particles
/// reach (most of a splash's box is air). The shaders index within a brick by shifts and masks: 8 only.
pub const ISO_VOLUME_BRICK: u32 = 8;
const _: () = assert!(ISO_VOLUME_BRICK == 8);

/// Voxels per edge of a brick as stored (the brick and a one-voxel apron each side: ISO_VOLUME_BRICK + 2), the
/// unit of iso_volume.glsl's store index.
pub const ISO_STORE: u32 = ISO_VOLUME_BRICK + 2;
/// Jacobi sweeps of the 3×3 symmetric eigen-decomposition of the anisotropic kernels (anisotropy.comp and
/// `field::iso::sym_eigen`: converges to float precision in 4–5).
pub const JACOBI_SWEEPS: u32 = 6;

/// Diffuse particle kinds as the pool stores them (`crate::diffuse::Kind`, numbered as SPlisHSPlasH's
/// FoamGenerator numbers them): foam …
pub const DIFFUSE_FOAM: u32 = 0;
/// … spray …
pub const DIFFUSE_SPRAY: u32 = 1;
/// … and air bubbles.
pub const DIFFUSE_BUBBLE: u32 = 2;
/// Collider kinds in the simulation's uniform block (`crate::sim::scene::Collider::encode`, sim_common.glsl's
/// `collide`): a sphere …
pub const COLLIDER_SPHERE: u32 = 1;
/// … a solid box …
pub const COLLIDER_BOX: u32 = 2;
/// … and a half-space.
pub const COLLIDER_PLANE: u32 = 3;

/// Float constants shared by Rust and GLSL (build.rs defines them as float literals).
/// The noise's depth below the surface, in falloffs, past which a particle adds nothing (noise.glsl).
pub const NOISE_DEEP: f32 = 4.0;
/// The 2D noise's scale: its RMS (0.3045 over the lattice) brought to the 3D gradient noise's slice (0.2698).
pub const NOISE_2D_RMS: f32 = 0.886;
/// Fixed-point units of the diffuse pass's coverage images per unit of coverage (diffuse.comp, passes::diffuse).
pub const DIFFUSE_UNITS: f32 = 4096.0;

/// The composite's blend codes (`crate::layer::Blend`, composite.comp's layers): a tint of the water …
pub const BLEND_TINT: f32 = 1.0;
/// … coverage under the surface …
pub const BLEND_UNDER: f32 = 2.0;
/// … and coverage over everything.
pub const BLEND_OVER: f32 = 3.0;

/// A particle's lattice order (iso_density.comp, `crate::field::volume::lattice_order`), distances in particle
/// spacings (2 r): the gap between a cubic lattice's first two shells (at 1 and √2; a jitter of ±5 % per axis
/// leaves them outside) is weighted by a tent of this centre and half-width, where a liquid's first peak of
/// neighbours spreads …
pub const LATTICE_GAP_AT: f32 = 1.19;
/// … (the tent's half-width) …
pub const LATTICE_GAP_HALF: f32 = 0.07;
/// … the neighbours counted: up to this many spacings (a cubic lattice's first two shells, 18 neighbours; a
/// liquid's first shell, about 12) …
pub const LATTICE_NEAR_FROM: f32 = 1.4;
/// … fading out by this many …
pub const LATTICE_NEAR_TO: f32 = 1.5;
/// … and the gap's share of them, pooled over a particle's neighbourhood, over which the order falls from 1 to
/// 0 (smoothstep). A lattice's share is 0 (SPlisHSPlasH's fill exactly; the built-in scenes' jitter of ±5 %
/// per axis moves no neighbour into the tent: the first shell reaches 1.109, the second 1.273); a single
/// liquid particle's is about 0.12 (median on the shared sequences' moving frames), pooled over its
/// neighbours it is rarely below 0.04.
pub const LATTICE_SHARE_FROM: f32 = 0.01;
/// … (where the order reaches 0) …
pub const LATTICE_SHARE_TO: f32 = 0.03;
/// … times a ramp over the particle's own near neighbours: spray and droplets (few) are not a lattice; a
/// cubic lattice's corner has 6, an edge 9, a face 13.
pub const LATTICE_FEW: f32 = 2.0;
/// … (the ramp's top).
pub const LATTICE_MANY: f32 = 5.0;

/// Every float constant above, by its GLSL name.
pub const SHADER_CONSTANTS_F32: &[(&str, f32)] = &[
    ("LATTICE_GAP_AT", LATTICE_GAP_AT),
    ("LATTICE_GAP_HALF", LATTICE_GAP_HALF),
    ("LATTICE_NEAR_FROM", LATTICE_NEAR_FROM),
    ("LATTICE_NEAR_TO", LATTICE_NEAR_TO),
    ("LATTICE_SHARE_FROM", LATTICE_SHARE_FROM),
    ("LATTICE_SHARE_TO", LATTICE_SHARE_TO),
    ("LATTICE_FEW", LATTICE_FEW),
    ("LATTICE_MANY", LATTICE_MANY),
    ("NOISE_DEEP", NOISE_DEEP),
    ("NOISE_2D_RMS", NOISE_2D_RMS),
    ("DIFFUSE_UNITS", DIFFUSE_UNITS),
    ("BLEND_TINT", BLEND_TINT),
    ("BLEND_UNDER", BLEND_UNDER),
    ("BLEND_OVER", BLEND_OVER),
];

/// Every constant above, by its GLSL name.
pub const SHADER_CONSTANTS: &[(&str, u32)] = &[
    ("DIFFUSE_FOAM", DIFFUSE_FOAM),
    ("DIFFUSE_SPRAY", DIFFUSE_SPRAY),
    ("DIFFUSE_BUBBLE", DIFFUSE_BUBBLE),
    ("COLLIDER_SPHERE", COLLIDER_SPHERE),
    ("COLLIDER_BOX", COLLIDER_BOX),
    ("COLLIDER_PLANE", COLLIDER_PLANE),
    ("LOCAL_2D", LOCAL_2D),
    ("CLEAR_SPAN", CLEAR_SPAN),
    ("LOCAL_1D", LOCAL_1D),
    ("NOISE_LEVELS", NOISE_LEVELS),
    ("COMPOSITE_LAYERS", COMPOSITE_LAYERS),
    ("NOISE_LOD_SAMPLES", NOISE_LOD_SAMPLES),
    ("NOISE_TILE", NOISE_TILE),
    ("NOISE_CHUNK", NOISE_CHUNK),
    ("NOISE_MAX_TILES", NOISE_MAX_TILES),
    ("DETAIL_UNITS", DETAIL_UNITS),
    ("CURVATURE_LOCAL", CURVATURE_LOCAL),
    ("MAX_BOXES", MAX_BOXES),
    ("MAX_SPHERES", MAX_SPHERES),
    ("SSR_MISS", SSR_MISS),
    ("MAX_PIXELS_PER_PARTICLE", MAX_PIXELS_PER_PARTICLE),
    ("SPLAT_TILE", SPLAT_TILE),
    ("ISO_BACK_STEPS", ISO_BACK_STEPS),
    ("ISO_SHORT_STEPS", ISO_SHORT_STEPS),
    ("ISO_WIDE_SPLIT", ISO_WIDE_SPLIT),
    ("ISO_TILE_ROW", ISO_TILE_ROW),
    ("ISO_EMPTY_REACH", ISO_EMPTY_REACH),
    ("ISO_EMPTY_BITS", ISO_EMPTY_BITS),
    ("ISO_VOLUME_FIX_BITS", ISO_VOLUME_FIX_BITS),
    ("ISO_VOLUME_BRICK", ISO_VOLUME_BRICK),
    ("MAX_COLLIDERS", MAX_COLLIDERS),
    ("MAX_NEIGHBOURS", MAX_NEIGHBOURS),
    ("SCAN_LOCAL", SCAN_LOCAL),
    ("MC_BLOCK", MC_BLOCK),
    ("PARTICLE_VEC4S", PARTICLE_VEC4S),
    ("DIFFUSE_VEC4S", DIFFUSE_VEC4S),
    ("MC_MAX_TRIS", MC_MAX_TRIS),
    ("SCAN_BLOCK", SCAN_BLOCK),
    ("GRID_RUN", GRID_RUN),
    ("ISO_STORE", ISO_STORE),
    ("JACOBI_SWEEPS", JACOBI_SWEEPS),
];
