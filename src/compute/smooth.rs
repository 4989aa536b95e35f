//! `mesh_smooth` pass: Laplacian smoothing with feature weights and area-weighted vertex normals of an extracted
//! mesh on the GPU — the GPU form of src/field/smooth.rs (splashsurf's finishing step, `[mesh] smoothing_iters`),
//! so `meniscus mesh --gpu` with smoothing (`--preset smooth`) iterates on the device. On the device
//! (shaders_glsl/mesh_smooth.comp): each vertex's incident triangles and edge neighbours (a counting sort of the
//! triangles' corners: count, the `grid` pass's scan, fill, then each run sorted and the neighbours deduplicated
//! — `vertex_neighbours`' lists), the iterations and the normals, each in the CPU's order of additions: the
//! result equals the CPU's within the floats' rounding (tests/gpu_passes.rs, `gpu_mesh_smoothing_matches_the_cpu`).
//! The feature weights too: each particle's neighbour count, then each vertex's interpolation of them.
use std::sync::Arc;

use crate::compute::grid::{record_scan, ScanPush, SCAN};
use crate::compute::{device_buffer, groups_2d};
use crate::declare_program;
use crate::error::Result;
use crate::field::extract::TriMesh;
use crate::field::iso::IsoGrid;
use crate::field::smooth::SmoothParams;
use crate::gpu::transfer::{host_vec, read_back, upload_buffer};
use crate::gpu::{ComputeProgram, FrameCtx, Gpu, Timer};
use crate::shader_constants::{LOCAL_1D, SCAN_BLOCK};
use crate::shaders;
use crate::timing::PassTimes;

/// The pass's one name (module, shader stem, timestamp key).
pub const NAME: &str = "mesh_smooth";

/// Push constants (SmoothPush in mesh_smooth.comp).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SmoothPush {
    /// x: vertices, triangles (count, fill) or particles (neighbour counts).
    pub n: [u32; 4],
    /// The particles' grid: origin, cell side.
    pub grid: [f32; 4],
    /// Its cells per axis.
    pub gdims: [u32; 4],
    /// x: support h, y: the neighbour count of full weight.
    pub field: [f32; 4],
}

// Neighbour counts: points, cells → c_j.
declare_program!(pub NEIGHBOURS: SmoothPush = compute(shaders::MESH_SMOOTH_NEIGHBOURS, [BufRead, BufRead, BufWrite]));
// Feature weights: points, cells, 1/n_j, c_j, positions → weights.
declare_program!(pub WEIGHTS: SmoothPush = compute(shaders::MESH_SMOOTH_WEIGHTS, [BufRead, BufRead, BufRead, BufRead, BufRead, BufWrite]));
// Count: triangles → each vertex's incident triangles (atomic).
declare_program!(pub COUNT: SmoothPush = compute(shaders::MESH_SMOOTH_COUNT, [BufRead, BufWrite]));
// Fill: triangles, starts, fill → triangle runs, neighbour runs.
declare_program!(pub FILL: SmoothPush = compute(shaders::MESH_SMOOTH_FILL, [BufRead, BufRead, BufWrite, BufWrite, BufWrite]));
// Sort: starts, counts, triangle runs, neighbour runs → the runs sorted, the neighbours deduplicated, their ranges.
declare_program!(pub SORT: SmoothPush = compute(shaders::MESH_SMOOTH_SORT, [BufRead, BufRead, BufWrite, BufWrite, BufWrite]));
// An iteration: positions, neighbour ranges, neighbour runs, weights → the next positions.
declare_program!(pub ITERATE: SmoothPush = compute(shaders::MESH_SMOOTH, [BufRead, BufRead, BufRead, BufRead, BufWrite]));
// Normals: positions, starts, counts, triangle runs, triangles → normals.
declare_program!(pub NORMALS: SmoothPush = compute(shaders::MESH_SMOOTH_NORMALS, [BufRead, BufRead, BufRead, BufRead, BufRead, BufWrite]));

/// The pass's programs.
pub struct GpuSmooth {
    neighbours: ComputeProgram<SmoothPush>,
    weights: ComputeProgram<SmoothPush>,
    count: ComputeProgram<SmoothPush>,
    fill: ComputeProgram<SmoothPush>,
    sort: ComputeProgram<SmoothPush>,
    scan: ComputeProgram<ScanPush>,
    iterate: ComputeProgram<SmoothPush>,
    normals: ComputeProgram<SmoothPush>,
}

impl GpuSmooth {
    /// Build the pipelines.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(GpuSmooth {
            neighbours: ComputeProgram::new(gpu, &NEIGHBOURS)?,
            weights: ComputeProgram::new(gpu, &WEIGHTS)?,
            count: ComputeProgram::new(gpu, &COUNT)?,
            fill: ComputeProgram::new(gpu, &FILL)?,
            sort: ComputeProgram::new(gpu, &SORT)?,
            scan: ComputeProgram::new(gpu, &SCAN)?,
            iterate: ComputeProgram::new(gpu, &ITERATE)?,
            normals: ComputeProgram::new(gpu, &NORMALS)?,
        })
    }

    /// Smooth `m` in place as [`crate::field::smooth::smooth`] does (`grid` and `inv_n`: the particles it was
    /// extracted from, for the feature weights), the iterations and the normals on the GPU. Returns the GPU
    /// time per stage (`mesh_smooth/weights`, `mesh_smooth/adjacency`, `mesh_smooth`: the iterations,
    /// `mesh_smooth/normals`).
    pub fn smooth(
        &self,
        gpu: &Arc<Gpu>,
        m: &mut TriMesh,
        grid: &IsoGrid,
        inv_n: &[f32],
        p: &SmoothParams,
    ) -> Result<PassTimes> {
        if p.iterations == 0 || m.vertices.is_empty() {
            return Ok(PassTimes::default());
        }
        let (nv, nt) = (m.vertices.len() as u32, m.triangles.len() as u32);
        let bytes = 12 * nv as u64;
        let scratch = |name: &str, bytes: u64| device_buffer(gpu, name, bytes);
        // Both position buffers readable back (the last iteration may end in either).
        let first = upload_buffer(
            gpu,
            "mesh_smooth_pos",
            bytemuck::cast_slice(&m.vertices),
            Some(scratch("mesh_smooth_pos", bytes)?),
        )?;
        let pos = [first, scratch("mesh_smooth_pos2", bytes)?];
        let wts = scratch("mesh_smooth_weights", 4 * nv as u64)?;
        let g = &grid.grid;
        let np = g.points.len() as u32;
        let points = upload_buffer(gpu, "mesh_smooth_points", bytemuck::cast_slice(&g.points), None)?;
        let cells = upload_buffer(gpu, "mesh_smooth_cells", bytemuck::cast_slice(&g.cells), None)?;
        let inv = upload_buffer(gpu, "mesh_smooth_inv_n", bytemuck::cast_slice(inv_n), None)?;
        let c = scratch("mesh_smooth_c", 4 * np as u64)?;
        let tris = upload_buffer(gpu, "mesh_smooth_tris", bytemuck::cast_slice(&m.triangles), None)?;
        let corners = 3 * nt as u64;
        let (counts, starts, fill) = (
            scratch("mesh_smooth_counts", 4 * nv as u64)?,
            scratch("mesh_smooth_starts", 4 * nv as u64)?,
            scratch("mesh_smooth_fill", 4 * nv as u64)?,
        );
        let sums = scratch("mesh_smooth_sums", 4 * nv.div_ceil(SCAN_BLOCK) as u64)?;
        let (tri_runs, nbr_runs) =
            (scratch("mesh_smooth_tri_runs", 4 * corners)?, scratch("mesh_smooth_nbr_runs", 8 * corners)?);
        let ranges = scratch("mesh_smooth_ranges", 8 * nv as u64)?;
        let nrm = scratch("mesh_smooth_normals", bytes)?;
        let push = |n: u32| SmoothPush {
            n: [n, 0, 0, 0],
            grid: [g.origin.x, g.origin.y, g.origin.z, g.cell],
            gdims: [g.dims[0], g.dims[1], g.dims[2], 0],
            field: [grid.support, p.normalization, 0.0, 0.0],
        };
        let (pv, pt) = (push(nv), push(nt));
        let (gv, gt) = (groups_2d(nv.div_ceil(LOCAL_1D)), groups_2d(nt.div_ceil(LOCAL_1D)));
        let iterations = p.iterations as usize;
        let mut timer = Timer::new(gpu)?;
        gpu.one_shot(|cmd| {
            let mut ctx = FrameCtx::new(gpu, cmd, Some(&mut timer));
            ctx.pass("mesh_smooth/weights", |ctx| {
                if p.weights {
                    let res = [(&points).into(), (&cells).into(), (&c).into()];
                    self.neighbours.dispatch(ctx, &res, &push(np), groups_2d(np.div_ceil(LOCAL_1D)));
                    let res = [
                        (&points).into(),
                        (&cells).into(),
                        (&inv).into(),
                        (&c).into(),
                        (&pos[0]).into(),
                        (&wts).into(),
                    ];
                    self.weights.dispatch(ctx, &res, &pv, gv);
                } else {
                    ctx.fill(&wts, 1f32.to_bits());
                }
            });
            ctx.pass("mesh_smooth/adjacency", |ctx| {
                ctx.fill(&counts, 0);
                ctx.fill(&fill, 0);
                self.count.dispatch(ctx, &[(&tris).into(), (&counts).into()], &pt, gt);
                record_scan(&self.scan, ctx, (&counts, &starts, &sums), nv);
                let res = [(&tris).into(), (&starts).into(), (&fill).into(), (&tri_runs).into(), (&nbr_runs).into()];
                self.fill.dispatch(ctx, &res, &pt, gt);
                let res =
                    [(&starts).into(), (&counts).into(), (&tri_runs).into(), (&nbr_runs).into(), (&ranges).into()];
                self.sort.dispatch(ctx, &res, &pv, gv);
            });
            ctx.pass(NAME, |ctx| {
                for k in 0..iterations {
                    let (src, dst) = (&pos[k % 2], &pos[(k + 1) % 2]);
                    let res = [src.into(), (&ranges).into(), (&nbr_runs).into(), (&wts).into(), dst.into()];
                    self.iterate.dispatch(ctx, &res, &pv, gv);
                }
            });
            ctx.pass("mesh_smooth/normals", |ctx| {
                let res = [
                    (&pos[iterations % 2]).into(),
                    (&starts).into(),
                    (&counts).into(),
                    (&tri_runs).into(),
                    (&tris).into(),
                    (&nrm).into(),
                ];
                self.normals.dispatch(ctx, &res, &pv, gv);
            });
            Ok(())
        })?;
        let times = timer.read()?;
        let back = read_back(gpu, &[(&pos[iterations % 2], 0, bytes), (&nrm, 0, bytes)])?;
        let n = m.vertices.len();
        m.vertices = bytemuck::pod_collect_to_vec(&host_vec::<f32>(&back[0], 3 * n)?);
        m.normals = bytemuck::pod_collect_to_vec(&host_vec::<f32>(&back[1], 3 * n)?);
        Ok(times)
    }
}
