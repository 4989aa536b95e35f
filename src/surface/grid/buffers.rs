//! The particles' grid on the device as the SPH field's shaders read it (shaders_glsl/iso/iso_field.glsl): the
//! sorted points, the cell table, each point's weight 1/n_j, neighbour count and anisotropic kernel, and the
//! push block that carries the grid's shape. Shared by the iso surface's cast and the spheres' ellipsoids.
//! In: what `IsoResources` builds or uploads. Out: the buffers the `iso_density`, `anisotropy` and `iso` passes
//! read and write.

use ash::vk;

use crate::field::iso::IsoGrid;
use crate::gpu::Buffer;

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
    /// Each sorted point's neighbour count c_j and lattice order o_j (RG32F), written by `iso_density`, read by
    /// `iso_volume`.
    pub counts: Buffer,
    /// Each sorted point's lattice sums (g_j, m_j) (RG32F): its neighbours in a lattice's gap and near it,
    /// written by `iso_density`, pooled into o_j by its second dispatch.
    pub lattice: Buffer,
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
    /// `counts` hold each point's lattice order for the current particles (`iso_density`'s second dispatch, run
    /// only for a smoothed field that widens its blur by it; the first dispatch writes the orders 0).
    pub ordered: std::cell::Cell<bool>,
    /// How many times the particles (or the support) changed since the buffers were made: what a technique
    /// derives from the weights (the iso surface's smoothed field) is stale when this moved.
    pub generation: std::cell::Cell<u64>,
}

impl IsoBuffers {
    /// The particles (or the support) changed: the weights, the kernels and what a technique derives from
    /// them must be computed again.
    pub fn mark_stale(&self) {
        self.weights_stale.set(true);
        self.kernels_for.set(None);
        self.generation.set(next_generation());
    }

    /// The texel formats iso_field.glsl reads them in: points xyzw, cells (first, count), weights, kernels.
    pub const POINTS: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
    /// See [`IsoBuffers::POINTS`].
    pub const CELLS: vk::Format = vk::Format::R32G32_UINT;
    /// See [`IsoBuffers::POINTS`].
    pub const WEIGHTED: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
    /// See [`IsoBuffers::POINTS`].
    pub const ANISO: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
    /// The neighbour counts and lattice orders (c_j, o_j) iso_volume.comp reads.
    pub const COUNTS: vk::Format = vk::Format::R32G32_SFLOAT;
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

    /// Kernel support (world units).
    pub fn support(&self) -> f32 {
        self.params[0]
    }
}

/// A generation number no grid's buffers have had before in this process (`IsoBuffers::generation`): what was
/// derived from one set of buffers is never taken for another's.
pub fn next_generation() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}
