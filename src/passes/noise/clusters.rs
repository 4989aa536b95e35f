//! The per-sprite noise splat's clusters (CPU drivers): a particle set's nearby particles grouped so a frame's cull
//! tests only the groups that may draw (NVIDIA patent US 8,947,430, eq. 15–17; method.md §8; the per-particle test
//! is unchanged, so the listed sprites — and N — are the full cull's). Built once per particle set on the device:
//! the particles counting-sorted into a coarse grid (`compute::grid`, cells of [`CLUSTER_SIDE`] radii), each
//! cell's particles cut into clusters of at most LOCAL_1D with their tight bounding box (noise_clusters.comp,
//! NOISE_CLUSTERS_BUILD). Each frame: the fluid depth's farthest value per tile (NOISE_CLUSTERS_DEPTH), every
//! cluster tested against its tiles and the screen (NOISE_CLUSTERS_TEST), and noise_cull.comp's
//! NOISE_CULL_CLUSTERS variant dispatched over the kept clusters, a work group each.
//! Why: on lavapipe a kernel that only loads each particle costs 7 ms over the waterfall's 814 k particles and
//! the full cull 12–20 ms, while most particles of a large set are off screen or deeper below the surface than a
//! sprite's cut (docs/gpu-frame.md, "Clusters"). The clusters pay for themselves only over frames that reuse
//! them: the effect builds them for a set it renders a second time (a still frame, a paused or explored set,
//! bench's frames), not for a sequence's or a simulation's new set each frame.
//! In: the particle buffer (positions), the host's copy of the positions (the grid's box), the fluid depth. Out:
//! the kept clusters and the cull's indirect dispatch.
use std::sync::Arc;

use ash::vk;
use glam::Vec3;
use gpu_allocator::MemoryLocation;

use super::SpritePush;
use crate::compute::grid::{GridBuffers, GridShape, NeighbourGrid};
use crate::declare_program;
use crate::error::Result;
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu, Image, Res};
use crate::shader_constants::{LOCAL_1D, NOISE_CLUSTER_TILE};
use crate::shaders;

/// The coarse grid's cell side, in particle radii: a full cell at the rest spacing (2 r) holds 64 particles, one
/// cluster (LOCAL_1D) — a cluster is about as wide as a close sprite (`[noise] size` 3 r) and small against the
/// screen's depth tiles.
pub const CLUSTER_SIDE: f32 = 8.0;

/// Sets of fewer particles are culled one by one every frame (their full cull costs little).
pub const CLUSTER_MIN: u32 = 8192;

/// The grid has at most one cell per this many particles (a sparse set spread over a large box gets larger cells).
const PARTICLES_PER_CELL_MIN: u32 = 8;

/// Push constants of the build.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BuildPush {
    /// Cells of the grid.
    pub cells: u32,
}

// Build: frame (unused), particles, the grid's counts, start and order → records, header (the test's dispatch).
declare_program!(pub BUILD: BuildPush = compute(shaders::NOISE_CLUSTERS_BUILD, [Uniform, BufRead, BufRead, BufRead, BufRead, BufWrite, BufWrite]));
// Depth: frame (unused), fluid depth → the tiles' farthest depths.
declare_program!(pub DEPTH: () = compute(shaders::NOISE_CLUSTERS_DEPTH, [Uniform, ImgRead, BufWrite]));
// Test: frame, records, header, tiles → kept (the cull's dispatch, then the kept clusters' particles); the fluid
// depth, the grid's order.
declare_program!(pub TEST: SpritePush = compute(shaders::NOISE_CLUSTERS_TEST, [Uniform, BufRead, BufRead, BufRead, BufWrite, ImgRead, BufRead]));
// The cull over the kept clusters' particles: frame, particles, fluid depth → work, listed; kept.
declare_program!(pub CULL: SpritePush = compute(shaders::NOISE_CULL_CLUSTERS, [Uniform, BufRead, ImgRead, BufWrite, BufWrite, BufRead]));

/// The programs (the per-sprite splat's, built once per device).
pub struct ClusterPrograms {
    grid: NeighbourGrid,
    build: ComputeProgram<BuildPush>,
    depth: ComputeProgram<()>,
    test: ComputeProgram<SpritePush>,
    cull: ComputeProgram<SpritePush>,
}

/// One particle set's clusters on the device.
pub struct Clusters {
    grid: GridBuffers,
    /// Two vec4 per cluster: (lo.xyz, first sorted place), (hi.xyz, particles).
    records: Buffer,
    /// {work groups x, 1, 1, clusters}: the test's indirect dispatch.
    header: Buffer,
    /// {work groups, 1, 1, particles} (the cull's indirect dispatch), then the kept clusters' particle indices.
    kept: Buffer,
    /// The particle set ([`crate::particles::ParticleSet::generation`]) and count they were built for.
    generation: u64,
    count: u32,
    /// Built by the next recorded frame.
    build: std::cell::Cell<bool>,
    capacity: u32,
}

/// The tiles of a `width`×`height` fluid depth that the test reads (one f32 each).
pub fn depth_tiles(width: u32, height: u32) -> u32 {
    width.div_ceil(NOISE_CLUSTER_TILE) * height.div_ceil(NOISE_CLUSTER_TILE)
}

impl ClusterPrograms {
    /// Build the programs.
    pub fn new(gpu: &Arc<Gpu>) -> Result<ClusterPrograms> {
        Ok(ClusterPrograms {
            grid: NeighbourGrid::new(gpu)?,
            build: ComputeProgram::new(gpu, &BUILD)?,
            depth: ComputeProgram::new(gpu, &DEPTH)?,
            test: ComputeProgram::new(gpu, &TEST)?,
            cull: ComputeProgram::new(gpu, &CULL)?,
        })
    }

    /// Record the cull by clusters (`noise/clusters`, then `noise/cull` over the kept ones; the set's clusters
    /// first built when due): the same list and counts as the full cull. `cull` holds the full cull's resources
    /// (frame, particles, depth, work, listed).
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        c: &Clusters,
        frame: &Buffer,
        particles: &Buffer,
        depth: &Image,
        tiles: &Buffer,
        cull: [Res<'_>; 5],
        push: &SpritePush,
    ) {
        if c.build.replace(false) {
            ctx.part("noise/clusters/build", |ctx| {
                self.grid.record(ctx, particles, c.count, &c.grid);
                ctx.fill(&c.header, 0);
                let cells = c.grid.shape.cells();
                let res = [
                    frame.into(),
                    particles.into(),
                    (&c.grid.counts).into(),
                    (&c.grid.start).into(),
                    (&c.grid.order).into(),
                    (&c.records).into(),
                    (&c.header).into(),
                ];
                self.build.dispatch(ctx, &res, &BuildPush { cells }, [cells.div_ceil(LOCAL_1D), 1, 1]);
            });
        }
        ctx.part("noise/clusters", |ctx| {
            let (w, h) = (depth.extent.width, depth.extent.height);
            let res = [frame.into(), depth.into(), tiles.into()];
            self.depth.dispatch(ctx, &res, &(), [depth_tiles(w, h).div_ceil(LOCAL_1D), 1, 1]);
            ctx.fill(&c.kept, 0);
            let res = [
                frame.into(),
                (&c.records).into(),
                (&c.header).into(),
                tiles.into(),
                (&c.kept).into(),
                depth.into(),
                (&c.grid.order).into(),
            ];
            self.test.dispatch_indirect(ctx, &res, push, &c.header, 0);
        });
        let [f, p, d, work, listed] = cull;
        let res = [f, p, d, work, listed, (&c.kept).into()];
        ctx.part("noise/cull", |ctx| self.cull.dispatch_indirect(ctx, &res, push, &c.kept, 0));
    }
}

impl Clusters {
    /// Whether these clusters are for particle set `generation` of `count` particles.
    pub fn are_for(&self, generation: u64, count: u32) -> bool {
        self.generation == generation && self.count == count
    }

    /// Whether these clusters hold `count` particles (the frame's particle count).
    pub fn are_for_count(&self, count: u32) -> bool {
        self.count == count
    }

    /// Clusters for particle set `generation` (host positions `positions`, radius `radius`), built by the next
    /// recorded frame; `old`'s buffers are kept when they hold the new set (the caller has waited for the frames
    /// in flight when they do not).
    pub fn for_set(
        gpu: &Arc<Gpu>,
        old: Option<Clusters>,
        generation: u64,
        positions: &[[f32; 3]],
        radius: f32,
    ) -> Result<Clusters> {
        let count = positions.len() as u32;
        let shape = shape_for(positions, radius);
        let capacity = shape.cells() + count.div_ceil(LOCAL_1D) + 1;
        if let Some(mut c) = old.filter(|c| c.grid.holds(&shape, count) && c.capacity >= capacity && c.kept.size >= 16 + 4 * count as u64) {
            c.grid.shape = shape;
            c.generation = generation;
            c.count = count;
            c.build.set(true);
            return Ok(c);
        }
        // Room for a quarter more, so a set that grows a little keeps its buffers.
        let room = |x: u32| x.saturating_add(x / 4);
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
        let indirect = usage | vk::BufferUsageFlags::INDIRECT_BUFFER;
        let gpu_only = MemoryLocation::GpuOnly;
        let capacity = room(capacity);
        Ok(Clusters {
            grid: GridBuffers::with_room(gpu, shape, room(shape.cells()), room(count.max(1)))?,
            records: Buffer::new(gpu, "noise_clusters", 32 * capacity as u64, usage, gpu_only)?,
            header: Buffer::new(gpu, "noise_clusters_header", 16, indirect, gpu_only)?,
            kept: Buffer::new(gpu, "noise_clusters_kept", 16 + 4 * room(count.max(1)) as u64, indirect, gpu_only)?,
            generation,
            count,
            build: std::cell::Cell::new(true),
            capacity,
        })
    }

    /// (name, bytes) of each resource, for the memory table.
    pub fn memory(&self) -> Vec<(&str, u64)> {
        let g = &self.grid;
        [&self.records, &self.header, &self.kept, &g.counts, &g.start, &g.order, &g.keys]
            .iter()
            .map(|b| (b.name.as_str(), b.size))
            .collect()
    }
}

/// The coarse grid over the particles' box: cells of [`CLUSTER_SIDE`] radii, larger where that would make more
/// than one cell per [`PARTICLES_PER_CELL_MIN`] particles. Non-finite positions are left out of the box.
fn shape_for(positions: &[[f32; 3]], radius: f32) -> GridShape {
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for p in positions.iter().map(|p| Vec3::from(*p)).filter(|p| p.is_finite()) {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    if lo.x > hi.x {
        (lo, hi) = (Vec3::ZERO, Vec3::ZERO);
    }
    let extent = (hi - lo).max(Vec3::splat(1e-6));
    let most = (positions.len() as u32 / PARTICLES_PER_CELL_MIN).max(1) as f32;
    let k: f32 = std::env::var("MENISCUS_CLUSTER_SIDE").ok().and_then(|v| v.parse().ok()).unwrap_or(CLUSTER_SIDE);
    let side = (k * radius.max(1e-9)).max((extent.x * extent.y * extent.z / most).cbrt());
    let mut shape = GridShape::covering(lo, hi, side);
    // The rounding up of each axis may still pass the budget: grow the cells until it holds.
    let mut side = side;
    while shape.cells() as f32 > 2.0 * most {
        side *= 1.25;
        shape = GridShape::covering(lo, hi, side);
    }
    shape
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grid's cells follow the radius, and a sparse or degenerate set keeps the cell budget.
    #[test]
    fn grid_shape_keeps_its_budget() {
        let lattice: Vec<[f32; 3]> =
            (0..32 * 32 * 32).map(|k| [(k % 32) as f32 * 0.02, (k / 32 % 32) as f32 * 0.02, (k / 1024) as f32 * 0.02]).collect();
        let s = shape_for(&lattice, 0.01);
        assert_eq!(s.origin_cell[3], 0.08);
        assert_eq!(s.dims[..3], [8, 8, 8]);
        let mut sparse = lattice.clone();
        sparse[0] = [1e4, -1e4, 1e4];
        let s = shape_for(&sparse, 0.01);
        assert!(s.cells() <= 2 * (sparse.len() as u32 / PARTICLES_PER_CELL_MIN), "{s:?}");
        let flat = vec![[1.0, 2.0, 3.0]; 100];
        assert_eq!(shape_for(&flat, 0.01).cells(), 1);
        let odd = vec![[f32::NAN, 0.0, 0.0], [0.0, 0.0, 0.0]];
        assert!(shape_for(&odd, 0.01).cells() >= 1);
    }
}
