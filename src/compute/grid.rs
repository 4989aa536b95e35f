//! `grid` pass: THE GPU neighbour grid — points counting-sorted into a dense uniform grid of cubic cells on the
//! device (count with atomics, exclusive prefix sum, scatter), so no CPU work per frame and GPU-resident
//! particles (the live simulation) work too. Green 2008, "Particle simulation using CUDA"; the same layout as
//! the CPU grid (`scene::grid::UniformGrid`: cells x fastest, a cell's points contiguous), which the tests hold
//! it to. Shaders: shaders_glsl/grid_count.comp, grid_run_sum.comp, grid_scan.comp, grid_run_place.comp,
//! grid_scatter.comp (and grid.glsl, which the passes that query the grid include). The prefix sum scans run
//! totals of GRID_RUN cells, not every cell: lavapipe runs grid_scan's barriers as coroutines, which cost 15 of
//! the pass's 17 ms at the 59k dam break when every cell went through it (docs/simulation.md, commit 434fdd1).
//!
//! In: points (vec4, xyz used), their count, the grid's shape. Out: `counts[c]`, `start[c]` (first sorted place
//! of cell c) and `order[k]` (the point at sorted place k). Within a cell the order is the atomics' order, so
//! it may differ between runs; the members never do.
use std::sync::Arc;

use ash::vk;
use glam::Vec3;
use gpu_allocator::MemoryLocation;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu};
use crate::shader_constants::{GRID_RUN, LOCAL_1D, SCAN_BLOCK, SCAN_LOCAL};
use crate::shaders;

/// The pass's one name (module, shader stems `grid_*`, debug label, timestamp key, JSON key): `grid`.
pub const NAME: &str = "grid";

/// A grid's shape as the shaders read it (grid.glsl's `GridShape`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GridShape {
    /// Corner of cell (0, 0, 0) (xyz) and the cell side (w).
    pub origin_cell: [f32; 4],
    /// Cells along x, y, z, and in all (w).
    pub dims: [u32; 4],
}

impl GridShape {
    /// Cells of side at least `cell` covering the box `lo`..`hi` (points outside fall into border cells).
    pub fn covering(lo: Vec3, hi: Vec3, cell: f32) -> GridShape {
        let n = ((hi - lo) / cell).ceil().max(Vec3::ONE).as_uvec3();
        GridShape { origin_cell: [lo.x, lo.y, lo.z, cell], dims: [n.x, n.y, n.z, n.x * n.y * n.z] }
    }

    /// Cells in all.
    pub fn cells(&self) -> u32 {
        self.dims[3]
    }

    /// The cell index of `p` (the shaders' `grid_index(grid_cell(p))`).
    pub fn index(&self, p: Vec3) -> u32 {
        let o = Vec3::new(self.origin_cell[0], self.origin_cell[1], self.origin_cell[2]);
        let c = ((p - o) / self.origin_cell[3]).floor();
        let clamp = |v: f32, n: u32| (v.max(0.0) as u32).min(n - 1);
        let (x, y, z) = (clamp(c.x, self.dims[0]), clamp(c.y, self.dims[1]), clamp(c.z, self.dims[2]));
        x + self.dims[0] * (y + self.dims[1] * z)
    }
}

/// Push constants of grid_count.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CountPush {
    /// The grid.
    pub shape: GridShape,
    /// Points.
    pub n: u32,
}

/// Push constants of grid_scan.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ScanPush {
    /// Cells.
    pub cells: u32,
    /// Blocks of SCAN_BLOCK cells.
    pub blocks: u32,
    /// 0: scan each block; 1: scan the block sums; 2: add them.
    pub mode: u32,
}

/// Push constants of grid_run_sum.comp and grid_run_place.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RunPush {
    /// Cells.
    pub cells: u32,
}

/// Push constants of grid_scatter.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ScatterPush {
    /// Points.
    pub n: u32,
}

// Count: points → counts (atomics), keys.
declare_program!(pub COUNT: CountPush = compute(shaders::GRID_COUNT, [BufRead, BufWrite, BufWrite]));
// Run sums: counts → run_counts.
declare_program!(pub RUN_SUM: RunPush = compute(shaders::GRID_RUN_SUM, [TexelRead, BufWrite]));
// Scan: run_counts → run_start, sums.
declare_program!(pub SCAN: ScanPush = compute(shaders::GRID_SCAN, [BufRead, BufWrite, BufWrite]));
// Places: counts, run_start → start.
declare_program!(pub RUN_PLACE: RunPush = compute(shaders::GRID_RUN_PLACE, [TexelRead, BufRead, BufWrite]));
// Scatter: keys, start → order.
declare_program!(pub SCATTER: ScatterPush = compute(shaders::GRID_SCATTER, [TexelRead, TexelRead, BufWrite]));

/// The device buffers of one grid (sized for a capacity of points and a shape).
pub struct GridBuffers {
    /// Points per cell (also read as texels by the prefix sum's run stages).
    pub counts: Buffer,
    /// First sorted place of every cell.
    pub start: Buffer,
    /// Sorted place → point index.
    pub order: Buffer,
    /// Per point: (cell, slot in the cell).
    pub keys: Buffer,
    /// Points per run of GRID_RUN cells.
    pub run_counts: Buffer,
    /// First sorted place of every run.
    pub run_start: Buffer,
    /// Per scan block of runs: its total, then its offset.
    pub sums: Buffer,
    /// The grid (any shape of at most `cell_capacity` cells: [`GridBuffers::holds`]).
    pub shape: GridShape,
    /// Most points.
    pub capacity: u32,
    /// Most cells.
    pub cell_capacity: u32,
}

impl GridBuffers {
    /// Buffers for up to `capacity` points in `shape`, named after their `owner` (`sim_grid_keys`, …).
    pub fn new(gpu: &Arc<Gpu>, owner: &str, shape: GridShape, capacity: u32) -> Result<GridBuffers> {
        Self::with_room(gpu, owner, shape, shape.cells(), capacity)
    }

    /// Buffers for up to `capacity` points in `shape` or any other shape of at most `cell_capacity` cells, named
    /// after their `owner` (`iso_grid_keys`, …: the memory table tells the iso grid's from the simulation's).
    pub fn with_room(
        gpu: &Arc<Gpu>,
        owner: &str,
        shape: GridShape,
        cell_capacity: u32,
        capacity: u32,
    ) -> Result<GridBuffers> {
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC;
        let name = |what: &str| format!("{owner}_grid_{what}");
        let buf = |what: &str, bytes: u64| Buffer::new(gpu, &name(what), bytes.max(16), usage, MemoryLocation::GpuOnly);
        let cell_capacity = cell_capacity.max(shape.cells());
        let cells = cell_capacity as u64;
        let runs = cells.div_ceil(GRID_RUN as u64);
        Ok(GridBuffers {
            counts: Buffer::texels(gpu, &name("counts"), (4 * cells).max(16), usage, vk::Format::R32_UINT)?,
            // These three are also read as texels (see `Buffer::with_texel_view`): sim_neighbours reads a row's
            // bounds, sim_reorder a particle's cell and that cell's places.
            start: Buffer::texels(gpu, &name("start"), (4 * cells).max(16), usage, vk::Format::R32_UINT)?,
            order: Buffer::texels(gpu, &name("order"), (4 * capacity as u64).max(16), usage, vk::Format::R32_UINT)?,
            keys: Buffer::texels(gpu, &name("keys"), (8 * capacity as u64).max(16), usage, vk::Format::R32G32_UINT)?,
            run_counts: buf("run_counts", 4 * runs)?,
            run_start: buf("run_start", 4 * runs)?,
            sums: buf("sums", 4 * runs.div_ceil(SCAN_BLOCK as u64))?,
            shape,
            capacity,
            cell_capacity,
        })
    }

    /// Whether these buffers hold `n` points sorted into `shape` (set `shape` to it before recording).
    pub fn holds(&self, shape: &GridShape, n: u32) -> bool {
        shape.cells() <= self.cell_capacity && n <= self.capacity
    }
}

/// The exclusive prefix sum of the first `n` values of `counts` into `start` (grid_scan.comp's three dispatches;
/// `sums`: scratch of 4 bytes per SCAN_BLOCK values), as the grid, the marching cubes and the mesh smoothing take
/// it.
pub fn record_scan(
    scan: &ComputeProgram<ScanPush>,
    ctx: &mut FrameCtx,
    (counts, start, sums): (&Buffer, &Buffer, &Buffer),
    n: u32,
) {
    let blocks = n.div_ceil(SCAN_BLOCK);
    let res = [counts.into(), start.into(), sums.into()];
    scan.dispatch(ctx, &res, &ScanPush { cells: n, blocks, mode: 0 }, [blocks, 1, 1]);
    scan.dispatch(ctx, &res, &ScanPush { cells: n, blocks, mode: 1 }, [1, 1, 1]);
    scan.dispatch(ctx, &res, &ScanPush { cells: n, blocks, mode: 2 }, [n.div_ceil(SCAN_LOCAL), 1, 1]);
}

/// The pass: its five programs.
pub struct NeighbourGrid {
    count: ComputeProgram<CountPush>,
    run_sum: ComputeProgram<RunPush>,
    scan: ComputeProgram<ScanPush>,
    run_place: ComputeProgram<RunPush>,
    scatter: ComputeProgram<ScatterPush>,
}

impl NeighbourGrid {
    /// Build the pipelines.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(NeighbourGrid {
            count: ComputeProgram::new(gpu, &COUNT)?,
            run_sum: ComputeProgram::new(gpu, &RUN_SUM)?,
            scan: ComputeProgram::new(gpu, &SCAN)?,
            run_place: ComputeProgram::new(gpu, &RUN_PLACE)?,
            scatter: ComputeProgram::new(gpu, &SCATTER)?,
        })
    }

    /// Sort the first `n` points of `points` (≤ the buffers' capacity) into `g`'s cells, inside the current
    /// pass scope (the caller names it: `grid` here, or a stage of the simulation).
    pub fn record(&self, ctx: &mut FrameCtx, points: &Buffer, n: u32, g: &GridBuffers) {
        debug_assert!(n <= g.capacity);
        let cells = g.shape.cells();
        let runs = cells.div_ceil(GRID_RUN);
        ctx.fill(&g.counts, 0);
        let push = CountPush { shape: g.shape, n };
        self.count.dispatch(
            ctx,
            &[points.into(), (&g.counts).into(), (&g.keys).into()],
            &push,
            [n.div_ceil(LOCAL_1D), 1, 1],
        );
        let run_groups = [runs.div_ceil(LOCAL_1D), 1, 1];
        self.run_sum.dispatch(ctx, &[(&g.counts).into(), (&g.run_counts).into()], &RunPush { cells }, run_groups);
        record_scan(&self.scan, ctx, (&g.run_counts, &g.run_start, &g.sums), runs);
        let res = [(&g.counts).into(), (&g.run_start).into(), (&g.start).into()];
        self.run_place.dispatch(ctx, &res, &RunPush { cells }, run_groups);
        let res = [(&g.keys).into(), (&g.start).into(), (&g.order).into()];
        self.scatter.dispatch(ctx, &res, &ScatterPush { n }, [n.div_ceil(LOCAL_1D), 1, 1]);
    }

    /// [`NeighbourGrid::record`] in its own pass scope named [`NAME`].
    pub fn record_pass(&self, ctx: &mut FrameCtx, points: &Buffer, n: u32, g: &GridBuffers) {
        ctx.pass(NAME, |ctx| self.record(ctx, points, n, g));
    }
}
