//! `mc` pass: marching cubes on the GPU (the GPU path of `meniscus mesh --gpu`; Janisz §2.2, method.md §10),
//! sparse over the same blocks and lattice as the CPU block extraction (src/field/extract.rs), so the two meshes are
//! the same mesh up to float rounding (the tests hold them to it):
//! 1. `mc_field`: every corner of every occupied block gathers the field from the neighbour grid;
//! 2. `mc_count`: triangles per cube from the case table;
//! 3. `mc_scan`: exclusive prefix sum of the counts (the `grid` pass's scan);
//! 4. `mc_emit`: every cube writes its triangles at its place, with vertex normals from the corner values.
//!
//! The host enumerates the occupied blocks (a few ms; the same function the CPU path uses), reads the triangle
//! total between the count and the emit (the output's size), and welds the vertices on global edge keys after
//! the emit (shared vertices, watertight; the CPU path's vertex and triangle order). Shaders: mc_*.comp,
//! mc_common.glsl, mc_cube.glsl.
use std::sync::Arc;
use std::time::Instant;

use ash::vk;
use glam::IVec3;
use gpu_allocator::MemoryLocation;
use rayon::prelude::*;

use crate::compute::grid::{ScanPush, SCAN};
use crate::declare_program;
use crate::error::Result;
use crate::field::extract::{case_table, corner_delta, occupied_blocks, ExtractParams, Lattice, TriMesh, EDGES};
use crate::field::iso::IsoGrid;
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu, PassTimes, Timer};
use crate::shader_constants::{LOCAL_1D, MC_BLOCK, MC_MAX_TRIS, SCAN_BLOCK, SCAN_LOCAL};
use crate::shaders;

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
// Count: corner values, blocks, table → triangles per cube.
declare_program!(pub COUNT: McPush = compute(shaders::MC_COUNT, [BufRead, BufRead, BufRead, BufWrite]));
// Emit: corner values, blocks, table, start → positions, normals, triangle records.
declare_program!(pub EMIT: McPush = compute(shaders::MC_EMIT, [BufRead, BufRead, BufRead, BufRead, BufWrite, BufWrite, BufWrite]));

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
    /// Host ms: block enumeration and upload; read-back and welding.
    pub host_setup_ms: f64,
    /// Host ms of the read-back and the weld.
    pub host_weld_ms: f64,
}

/// The pass's programs.
pub struct Mc {
    field: ComputeProgram<McPush>,
    count: ComputeProgram<McPush>,
    scan: ComputeProgram<ScanPush>,
    emit: ComputeProgram<McPush>,
}

fn groups_2d(n: u32) -> [u32; 3] {
    let x = n.clamp(1, 32_768);
    [x, n.div_ceil(x).max(1), 1]
}

fn device_buffer(gpu: &Arc<Gpu>, name: &str, bytes: u64) -> Result<Buffer> {
    let usage =
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST;
    Buffer::new(gpu, name, bytes.max(16), usage, MemoryLocation::GpuOnly)
}

impl Mc {
    /// Build the pipelines.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Mc {
            field: ComputeProgram::new(gpu, &FIELD)?,
            count: ComputeProgram::new(gpu, &COUNT)?,
            scan: ComputeProgram::new(gpu, &SCAN)?,
            emit: ComputeProgram::new(gpu, &EMIT)?,
        })
    }

    /// Extract the iso-surface of `grid`'s field (weights `inv_n`, see [`IsoGrid::inv_density`]) on the GPU:
    /// the same lattice, threshold and field as [`crate::field::extract::extract_blocks`] (`p.block` is ignored: the
    /// GPU's blocks are MC_BLOCK³ cubes; `p.dense` too).
    pub fn extract(
        &self,
        gpu: &Arc<Gpu>,
        grid: &IsoGrid,
        inv_n: &[f32],
        p: &ExtractParams,
    ) -> Result<(TriMesh, McStats)> {
        let mut stats = McStats::default();
        if grid.points.is_empty() {
            return Ok((TriMesh::default(), stats));
        }
        let t0 = Instant::now();
        let lat = Lattice::of(grid, p.cube.max(1e-6));
        let b = MC_BLOCK as i32;
        let (keys, nb) = occupied_blocks(grid, &lat, b);
        stats.blocks = keys.len();
        let c0s: Vec<[i32; 4]> = keys
            .iter()
            .map(|&k| {
                let bi = IVec3::new(
                    (k / nb.z as i64 / nb.y as i64) as i32,
                    (k / nb.z as i64 % nb.y as i64) as i32,
                    (k % nb.z as i64) as i32,
                );
                let c0 = bi * b - 1;
                [c0.x, c0.y, c0.z, 0]
            })
            .collect();
        let g = &grid.grid;
        let weights: Vec<f32> = if p.metaball { vec![1.0; g.points.len()] } else { inv_n.to_vec() };
        let up = |name: &str, data: &[u8]| crate::gpu::transfer::upload_buffer(gpu, name, data, None);
        let points = up("mc_points", bytemuck::cast_slice(&g.points))?;
        let cells = up("mc_cells", bytemuck::cast_slice(&g.cells))?;
        let wts = up("mc_weights", bytemuck::cast_slice(&weights))?;
        let blocks = up("mc_blocks", bytemuck::cast_slice(&c0s))?;
        let table = up("mc_table", bytemuck::cast_slice(&table_words()))?;
        let nblocks = keys.len() as u32;
        let ncubes = nblocks * MC_BLOCK * MC_BLOCK * MC_BLOCK;
        let nc = (MC_BLOCK + 3).pow(3) as u64;
        let field = device_buffer(gpu, "mc_field", 4 * nc * nblocks as u64)?;
        let counts = device_buffer(gpu, "mc_counts", 4 * ncubes as u64)?;
        let start = device_buffer(gpu, "mc_start", 4 * ncubes as u64)?;
        let sums = device_buffer(gpu, "mc_sums", 4 * ncubes.div_ceil(SCAN_BLOCK) as u64)?;
        let push = McPush {
            lat: [lat.lo.x, lat.lo.y, lat.lo.z, lat.h],
            grid: [g.origin.x, g.origin.y, g.origin.z, g.cell],
            gdims: [g.dims[0], g.dims[1], g.dims[2], p.metaball as u32],
            ldims: [lat.dims.x, lat.dims.y, lat.dims.z, nblocks as i32],
            field: [grid.support, 1.0 / grid.support, p.threshold, 0.0],
        };
        stats.host_setup_ms = t0.elapsed().as_secs_f64() * 1e3;
        let mut timer = Timer::new(gpu)?;
        gpu.one_shot(|cmd| {
            let mut ctx = FrameCtx::new(gpu, cmd, Some(&mut timer));
            ctx.pass("mc_field", |ctx| {
                let res = [(&points).into(), (&cells).into(), (&wts).into(), (&blocks).into(), (&field).into()];
                self.field.dispatch(ctx, &res, &push, groups_2d(nblocks));
            });
            ctx.pass("mc_count", |ctx| {
                let res = [(&field).into(), (&blocks).into(), (&table).into(), (&counts).into()];
                self.count.dispatch(ctx, &res, &push, groups_2d(ncubes.div_ceil(LOCAL_1D)));
            });
            ctx.pass("mc_scan", |ctx| {
                let res = [(&counts).into(), (&start).into(), (&sums).into()];
                let sb = ncubes.div_ceil(SCAN_BLOCK);
                self.scan.dispatch(ctx, &res, &ScanPush { cells: ncubes, blocks: sb, mode: 0 }, [sb, 1, 1]);
                self.scan.dispatch(ctx, &res, &ScanPush { cells: ncubes, blocks: sb, mode: 1 }, [1, 1, 1]);
                let g2 = ncubes.div_ceil(SCAN_LOCAL);
                self.scan.dispatch(ctx, &res, &ScanPush { cells: ncubes, blocks: sb, mode: 2 }, [g2, 1, 1]);
            });
            Ok(())
        })?;
        let mut times = timer.read()?.0;
        // The triangle total: the last cube's start plus its count.
        let last = 4 * (ncubes as u64 - 1);
        let s = crate::gpu::transfer::read_buffer_at(gpu, &start, last, 4)?;
        let c = crate::gpu::transfer::read_buffer_at(gpu, &counts, last, 4)?;
        let total = u32::from_le_bytes(s[..4].try_into().expect("4 bytes"))
            + u32::from_le_bytes(c[..4].try_into().expect("4 bytes"));
        if total == 0 {
            // No cube crosses the threshold: nothing to emit (and no zero-sized copies to make).
            stats.gpu = PassTimes(times);
            return Ok((TriMesh::default(), stats));
        }
        let pos = device_buffer(gpu, "mc_pos", 48 * total as u64)?;
        let nrm = device_buffer(gpu, "mc_nrm", 48 * total as u64)?;
        let tri = device_buffer(gpu, "mc_tri", 16 * total as u64)?;
        let mut timer = Timer::new(gpu)?;
        gpu.one_shot(|cmd| {
            let mut ctx = FrameCtx::new(gpu, cmd, Some(&mut timer));
            ctx.pass("mc_emit", |ctx| {
                let res = [
                    (&field).into(),
                    (&blocks).into(),
                    (&table).into(),
                    (&start).into(),
                    (&pos).into(),
                    (&nrm).into(),
                    (&tri).into(),
                ];
                self.emit.dispatch(ctx, &res, &push, groups_2d(ncubes.div_ceil(LOCAL_1D)));
            });
            Ok(())
        })?;
        times.extend(timer.read()?.0);
        stats.gpu = PassTimes(times);
        let t1 = Instant::now();
        let pos: Vec<[f32; 4]> =
            bytemuck::pod_collect_to_vec(&crate::gpu::transfer::read_buffer(gpu, &pos, 48 * total as u64)?);
        let nrm: Vec<[f32; 4]> =
            bytemuck::pod_collect_to_vec(&crate::gpu::transfer::read_buffer(gpu, &nrm, 48 * total as u64)?);
        let tri: Vec<[i32; 4]> =
            bytemuck::pod_collect_to_vec(&crate::gpu::transfer::read_buffer(gpu, &tri, 16 * total as u64)?);
        let mesh = weld(&lat, &pos, &nrm, &tri);
        stats.host_weld_ms = t1.elapsed().as_secs_f64() * 1e3;
        Ok((mesh, stats))
    }
}

/// Shared vertices on global edge keys (vertices in key order, triangles in cube order, then table order: the
/// CPU block path's order). Ranks (edge key, corner) pairs (`extract::rank_by_key`, as the CPU path), not whole
/// vertices, with no searches (commit 0b5cc2b; the weld was 0.39 s of the H200's 0.81 s).
fn weld(lat: &Lattice, pos: &[[f32; 4]], nrm: &[[f32; 4]], tri: &[[i32; 4]]) -> TriMesh {
    let key_of = |t: &[i32; 4], v: usize| -> i64 {
        let e = (t[3] as u32 >> (8 + 4 * v) & 15) as usize;
        let (a, _, axis) = EDGES[e];
        lat.key(IVec3::new(t[0], t[1], t[2]) + corner_delta(a)) * 3 + axis as i64
    };
    let keys: Vec<(i64, u32)> =
        (0..tri.len() * 3).into_par_iter().map(|k| (key_of(&tri[k / 3], k % 3), k as u32)).collect();
    let (rank, first) = crate::field::extract::rank_by_key(keys, tri.len() * 3);
    let (vertices, normals) = first
        .par_iter()
        .map(|&k| (pos[k as usize], nrm[k as usize]))
        .map(|(p, n)| ([p[0], p[1], p[2]], [n[0], n[1], n[2]]))
        .unzip();
    let mut order: Vec<(i64, u32, u32)> = tri
        .par_iter()
        .enumerate()
        .map(|(i, t)| (lat.key(IVec3::new(t[0], t[1], t[2])), t[3] as u32 & 255, i as u32))
        .collect();
    order.par_sort_unstable();
    let triangles = order.par_iter().map(|&(_, _, i)| [0, 1, 2].map(|v| rank[3 * i as usize + v])).collect();
    TriMesh { vertices, normals, triangles }
}
