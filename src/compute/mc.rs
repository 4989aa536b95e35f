//! `mc` pass: marching cubes on the GPU (the GPU path of `meniscus mesh --gpu`; Janisz §2.2),
//! sparse over the same blocks and lattice as the CPU block extraction (src/field/extract/mod.rs), so the two meshes are
//! the same mesh up to float rounding (the tests hold them to it):
//! 1. `mc_field`: every corner of every occupied block gathers the field from the neighbour grid;
//! 2. `mc_count`: triangles per cube from the case table, and the crossed edges each cube owns (those starting at
//!    its lower corner: every crossed edge of the lattice has one owner);
//! 3. `mc_scan`: exclusive prefix sums of both counts (the `grid` pass's scan);
//! 4. `mc_emit`: every cube writes its own edges' vertices (with normals from the corner values) and its
//!    triangles as indices of those vertices (a triangle's edge owned by a neighbouring cube, in the block or the
//!    next block, is found there), so the mesh comes out welded and indexed: shared vertices, watertight.
//!
//! The host enumerates the occupied blocks (the same function the CPU path uses), reads the two totals between
//! the count and the emit (the output's size), and copies the indexed mesh: it does not weld. Vertices come in
//! the GPU's order (block by block, cube by cube, edges in axis order), triangles in cube order within blocks:
//! the CPU path's mesh up to the order of vertices and triangles (the tests compare them in edge-key order,
//! [`Mc::extract_keyed`]). Shaders: mc_*.comp, mc_common.glsl, mc_cube.glsl.
use std::sync::Arc;
use std::time::Instant;

use glam::IVec3;
use rayon::prelude::*;

use crate::compute::grid::{record_scan, ScanPush, SCAN};
use crate::compute::{device_buffer, groups_2d};
use crate::declare_program;
use crate::error::{Error, Result};
use crate::field::extract::{case_table, occupied_blocks, ExtractParams, Lattice, TriMesh, EDGES};
use crate::field::iso::IsoGrid;
use crate::gpu::transfer::{host_vec, read_back};
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu, Timer};
use crate::shader_constants::{LOCAL_1D, MC_BLOCK, MC_MAX_TRIS, SCAN_BLOCK};
use crate::shaders;
use crate::timing::PassTimes;

/// The pass's one name (module, shader stems `mc_*`, debug label, timestamp keys `mc_*`).
pub const NAME: &str = "mc";

/// Push constants (McPush in mc_common.glsl).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct McPush {
    /// Lattice origin, cube edge.
    pub lat: [f32; 4],
    /// Neighbour grid origin, cell side.
    pub grid: [f32; 4],
    /// Neighbour grid cells per axis; w: 1 = metaball field.
    pub gdims: [u32; 4],
    /// Lattice corners per axis; w: blocks.
    pub ldims: [i32; 4],
    /// Support, 1 / support, threshold.
    pub field: [f32; 4],
}

// Field: points, cells, weights, blocks → corner values.
declare_program!(pub FIELD: McPush = compute(shaders::MC_FIELD, [BufRead, BufRead, BufRead, BufRead, BufWrite]));
// Count: corner values, blocks, table → triangles and owned crossed edges per cube.
declare_program!(pub COUNT: McPush = compute(shaders::MC_COUNT, [BufRead, BufRead, BufRead, BufWrite, BufWrite]));
// Emit: corner values, blocks, table, triangle start, vertex start → positions, normals, triangles, vertex edges.
declare_program!(pub EMIT: McPush = compute(shaders::MC_EMIT, [BufRead, BufRead, BufRead, BufRead, BufRead, BufWrite, BufWrite, BufWrite, BufWrite]));

/// The case table as the shaders read it: 12 packed edges, 256 counts, then MC_MAX_TRIS × 3 edges per case.
pub fn table_words() -> Vec<u32> {
    let t = case_table();
    let mut w: Vec<u32> = EDGES.iter().map(|&(a, b, axis)| (a | b << 4 | axis << 8) as u32).collect();
    w.extend(t.iter().map(|c| c.len() as u32));
    for c in t.iter() {
        assert!(c.len() <= MC_MAX_TRIS as usize, "a case has more than MC_MAX_TRIS triangles");
        let mut e = vec![0u32; 3 * MC_MAX_TRIS as usize];
        for (k, tri) in c.iter().enumerate() {
            for v in 0..3 {
                e[3 * k + v] = tri[v] as u32;
            }
        }
        w.extend(e);
    }
    w
}

/// What the GPU path measured.
#[derive(Clone, Debug, Default)]
pub struct McStats {
    /// Occupied blocks of MC_BLOCK³ cubes.
    pub blocks: usize,
    /// GPU ms per stage (`mc_field`, `mc_count`, `mc_scan`, `mc_emit`).
    pub gpu: PassTimes,
    /// Host ms: the occupied blocks' enumeration.
    pub host_setup_ms: f64,
    /// Host ms: the particles, cells, weights, blocks and table copied to the device.
    pub host_upload_ms: f64,
    /// Host ms: the indexed mesh copied back (the host does not weld).
    pub host_copy_ms: f64,
}

impl McStats {
    /// GPU ms, all stages.
    pub fn gpu_ms(&self) -> f64 {
        self.gpu.0.iter().map(|(_, t)| t).sum()
    }

    /// Host ms: set-up, upload and copy.
    pub fn host_ms(&self) -> f64 {
        self.host_setup_ms + self.host_upload_ms + self.host_copy_ms
    }
}

/// The pass's programs, and the device buffers it keeps between extractions (a sequence's frames, a simulator's
/// calls): the case table, uploaded once, and the scratch buffers, grown when a frame needs more.
pub struct Mc {
    field: ComputeProgram<McPush>,
    count: ComputeProgram<McPush>,
    scan: ComputeProgram<ScanPush>,
    emit: ComputeProgram<McPush>,
    kept: std::sync::Mutex<Kept>,
    /// The mesh's Laplacian smoothing and normals on the device (`compute::smooth`).
    smooth: crate::compute::smooth::GpuSmooth,
}

/// What [`Mc`] keeps between extractions.
#[derive(Default)]
struct Kept {
    /// The case table (`table_words`), uploaded on the first extraction.
    table: Option<Buffer>,
    /// Scratch buffers by name, each at least as large as the largest extraction so far needed.
    scratch: Vec<(&'static str, Buffer)>,
}

impl Kept {
    /// The scratch buffer `name` of at least `bytes`: the kept one when it is large enough, else a new one with a
    /// quarter to spare (the next frames of a sequence grow a little).
    fn take(&mut self, gpu: &Arc<Gpu>, name: &'static str, bytes: u64) -> Result<Buffer> {
        if let Some(k) = self.scratch.iter().position(|(n, b)| *n == name && b.size >= bytes.max(16)) {
            return Ok(self.scratch.swap_remove(k).1);
        }
        self.scratch.retain(|(n, _)| *n != name);
        device_buffer(gpu, name, bytes.saturating_add(bytes / 4))
    }

    /// Keep `bufs` for the next extraction.
    fn keep(&mut self, bufs: impl IntoIterator<Item = Buffer>, names: &[&'static str]) {
        self.scratch.extend(names.iter().copied().zip(bufs));
    }

    /// Bytes of device memory kept.
    fn bytes(&self) -> u64 {
        self.scratch.iter().map(|(_, b)| b.size).sum::<u64>() + self.table.as_ref().map_or(0, |t| t.size)
    }
}

/// The lower corners (one cube of margin below) of the blocks with keys `keys` in a lattice of `nb` blocks per
/// axis of `b` cubes each.
fn block_corners(keys: &[i64], nb: IVec3, b: i32) -> Vec<[i32; 4]> {
    keys.par_iter()
        .map(|&k| {
            let bi = IVec3::new(
                (k / nb.z as i64 / nb.y as i64) as i32,
                (k / nb.z as i64 % nb.y as i64) as i32,
                (k % nb.z as i64) as i32,
            );
            let c0 = bi * b - 1;
            [c0.x, c0.y, c0.z, 0]
        })
        .collect()
}

impl Mc {
    /// Build the pipelines.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Mc {
            field: ComputeProgram::new(gpu, &FIELD)?,
            count: ComputeProgram::new(gpu, &COUNT)?,
            scan: ComputeProgram::new(gpu, &SCAN)?,
            emit: ComputeProgram::new(gpu, &EMIT)?,
            kept: Default::default(),
            smooth: crate::compute::smooth::GpuSmooth::new(gpu)?,
        })
    }

    /// Smooth an extracted mesh on the device as `field::smooth::smooth` does on the CPU (`compute::smooth`).
    pub fn smooth(
        &self,
        gpu: &Arc<Gpu>,
        m: &mut TriMesh,
        grid: &IsoGrid,
        inv_n: &[f32],
        p: &crate::field::smooth::SmoothParams,
    ) -> Result<PassTimes> {
        self.smooth.smooth(gpu, m, grid, inv_n, p)
    }

    /// Bytes of device memory it keeps between extractions (the case table and the scratch buffers).
    pub fn kept_bytes(&self) -> u64 {
        self.kept.lock().map_or(0, |k| k.bytes())
    }

    /// Extract the iso-surface of `grid`'s field (weights `inv_n`, see [`IsoGrid::inv_density`]) on the GPU:
    /// the same lattice, threshold and field as [`crate::field::extract::blocks::extract_blocks`] (`p.block` is ignored: the
    /// GPU's blocks are MC_BLOCK³ cubes; `p.dense` too). The mesh comes back indexed from the GPU.
    pub fn extract(
        &self,
        gpu: &Arc<Gpu>,
        grid: &IsoGrid,
        inv_n: &[f32],
        p: &ExtractParams,
    ) -> Result<(TriMesh, McStats)> {
        self.run(gpu, grid, inv_n, p, false).map(|(m, _, st)| (m, st))
    }

    /// [`Mc::extract`], and each vertex's lattice edge as the CPU path keys it (`(corner key) · 3 + axis`; the
    /// CPU path's vertices are in ascending key order): what a comparison of the two meshes needs.
    pub fn extract_keyed(
        &self,
        gpu: &Arc<Gpu>,
        grid: &IsoGrid,
        inv_n: &[f32],
        p: &ExtractParams,
    ) -> Result<(TriMesh, Vec<i64>, McStats)> {
        self.run(gpu, grid, inv_n, p, true)
    }

    fn run(
        &self,
        gpu: &Arc<Gpu>,
        grid: &IsoGrid,
        inv_n: &[f32],
        p: &ExtractParams,
        keyed: bool,
    ) -> Result<(TriMesh, Vec<i64>, McStats)> {
        let mut stats = McStats::default();
        if grid.points.is_empty() {
            return Ok((TriMesh::default(), vec![], stats));
        }
        let t0 = Instant::now();
        let lat = Lattice::of(grid, p.cube.max(1e-6));
        let b = MC_BLOCK as i32;
        let (keys, nb) = occupied_blocks(grid, &lat, b);
        stats.blocks = keys.len();
        // Block lower corners (with the margin), in key order = (x, y, z) order: mc_emit searches them.
        let c0s = block_corners(&keys, nb, b);
        let g = &grid.grid;
        let weights: Vec<f32> = if p.metaball { vec![1.0; g.points.len()] } else { inv_n.to_vec() };
        stats.host_setup_ms = t0.elapsed().as_secs_f64() * 1e3;
        let t0 = Instant::now();
        let up = |name: &str, data: &[u8]| crate::gpu::transfer::upload_buffer(gpu, name, data, None);
        let points = up("mc_points", bytemuck::cast_slice(&g.points))?;
        let cells = up("mc_cells", bytemuck::cast_slice(&g.cells))?;
        let wts = up("mc_weights", bytemuck::cast_slice(&weights))?;
        let blocks = up("mc_blocks", bytemuck::cast_slice(&c0s))?;
        let mut kept = self.kept.lock().map_err(|_| Error::Invalid("mc: a previous extraction panicked".into()))?;
        if kept.table.is_none() {
            kept.table = Some(up("mc_table", bytemuck::cast_slice(&table_words()))?);
        }
        let nblocks = keys.len() as u32;
        let ncubes = nblocks * MC_BLOCK * MC_BLOCK * MC_BLOCK;
        let nc = (MC_BLOCK + 3).pow(3) as u64;
        let per_cube = 4 * ncubes as u64;
        let field = kept.take(gpu, "mc_field", 4 * nc * nblocks as u64)?;
        let counts = kept.take(gpu, "mc_counts", per_cube)?;
        let start = kept.take(gpu, "mc_start", per_cube)?;
        let vcounts = kept.take(gpu, "mc_vcounts", per_cube)?;
        let vstart = kept.take(gpu, "mc_vstart", per_cube)?;
        let sums = kept.take(gpu, "mc_sums", 4 * ncubes.div_ceil(SCAN_BLOCK) as u64)?;
        let table = kept.table.take().expect("uploaded");
        let push = McPush {
            lat: [lat.lo.x, lat.lo.y, lat.lo.z, lat.h],
            grid: [g.origin.x, g.origin.y, g.origin.z, g.cell],
            gdims: [g.dims[0], g.dims[1], g.dims[2], p.metaball as u32],
            ldims: [lat.dims.x, lat.dims.y, lat.dims.z, nblocks as i32],
            field: [grid.support, 1.0 / grid.support, p.threshold, 0.0],
        };
        stats.host_upload_ms = t0.elapsed().as_secs_f64() * 1e3;
        let mut timer = Timer::new(gpu)?;
        gpu.one_shot(|cmd| {
            let mut ctx = FrameCtx::new(gpu, cmd, Some(&mut timer));
            ctx.pass("mc_field", |ctx| {
                let res = [(&points).into(), (&cells).into(), (&wts).into(), (&blocks).into(), (&field).into()];
                self.field.dispatch(ctx, &res, &push, groups_2d(nblocks));
            });
            ctx.pass("mc_count", |ctx| {
                let res = [(&field).into(), (&blocks).into(), (&table).into(), (&counts).into(), (&vcounts).into()];
                self.count.dispatch(ctx, &res, &push, groups_2d(ncubes.div_ceil(LOCAL_1D)));
            });
            ctx.pass("mc_scan", |ctx| {
                for (c, st) in [(&counts, &start), (&vcounts, &vstart)] {
                    record_scan(&self.scan, ctx, (c, st, &sums), ncubes);
                }
            });
            Ok(())
        })?;
        let mut times = timer.read()?.0;
        // The totals: the last cube's start plus its count, for triangles and vertices.
        let last = 4 * (ncubes as u64 - 1);
        let t_copy = Instant::now();
        let tails = read_back(gpu, &[(&start, last, 4), (&counts, last, 4), (&vstart, last, 4), (&vcounts, last, 4)])?;
        let word = |i: usize| -> Result<u32> { Ok(host_vec::<u32>(&tails[i], 1)?[0]) };
        let (total, vtotal) = (word(0)? + word(1)?, word(2)? + word(3)?);
        stats.host_copy_ms = t_copy.elapsed().as_secs_f64() * 1e3;
        const SCRATCH: [&str; 6] = ["mc_field", "mc_counts", "mc_start", "mc_vcounts", "mc_vstart", "mc_sums"];
        if total == 0 {
            // No cube crosses the threshold: nothing to emit (and no zero-sized copies to make).
            stats.gpu = PassTimes(times);
            kept.table = Some(table);
            kept.keep([field, counts, start, vcounts, vstart, sums], &SCRATCH);
            return Ok((TriMesh::default(), vec![], stats));
        }
        let pos = kept.take(gpu, "mc_pos", 12 * vtotal as u64)?;
        let nrm = kept.take(gpu, "mc_nrm", 12 * vtotal as u64)?;
        let tri = kept.take(gpu, "mc_tri", 12 * total as u64)?;
        let edge = kept.take(gpu, "mc_edge", 16 * vtotal as u64)?;
        let mut timer = Timer::new(gpu)?;
        gpu.one_shot(|cmd| {
            let mut ctx = FrameCtx::new(gpu, cmd, Some(&mut timer));
            ctx.pass("mc_emit", |ctx| {
                let res = [
                    (&field).into(),
                    (&blocks).into(),
                    (&table).into(),
                    (&start).into(),
                    (&vstart).into(),
                    (&pos).into(),
                    (&nrm).into(),
                    (&tri).into(),
                    (&edge).into(),
                ];
                self.emit.dispatch(ctx, &res, &push, groups_2d(ncubes.div_ceil(LOCAL_1D)));
            });
            Ok(())
        })?;
        times.extend(timer.read()?.0);
        stats.gpu = PassTimes(times);
        let t1 = Instant::now();
        let (v3, t3) = (12 * vtotal as u64, 12 * total as u64);
        let mut ranges = vec![(&pos, 0, v3), (&nrm, 0, v3), (&tri, 0, t3)];
        if keyed {
            ranges.push((&edge, 0, 16 * vtotal as u64));
        }
        let host = read_back(gpu, &ranges)?;
        kept.table = Some(table);
        kept.keep([field, counts, start, vcounts, vstart, sums], &SCRATCH);
        kept.keep([pos, nrm, tri, edge], &["mc_pos", "mc_nrm", "mc_tri", "mc_edge"]);
        drop(kept);
        let (nv, nt) = (vtotal as usize, total as usize);
        let vertices: Vec<[f32; 3]> = host_vec(&host[0], nv)?;
        let normals: Vec<[f32; 3]> = host_vec(&host[1], nv)?;
        let triangles: Vec<[u32; 3]> = host_vec(&host[2], nt)?;
        let edges: Vec<[i32; 4]> = if keyed { host_vec(&host[3], nv)? } else { vec![] };
        // Every triangle corner names a vertex (an owner the emit could not find would be u32::MAX).
        if triangles.par_iter().any(|t| t.iter().any(|&i| i >= vtotal)) {
            return Err(Error::Invalid(format!(
                "mc: a triangle of the GPU mesh names no vertex ({vtotal} vertices, {total} triangles): the owner \
                 of a crossed edge was not among the {nblocks} blocks"
            )));
        }
        let edge_keys = edges.par_iter().map(|e| lat.key(IVec3::new(e[0], e[1], e[2])) * 3 + e[3] as i64).collect();
        stats.host_copy_ms += t1.elapsed().as_secs_f64() * 1e3;
        Ok((TriMesh { vertices, normals, triangles }, edge_keys, stats))
    }
}
