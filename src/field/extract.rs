//! Iso-surface MESH extraction from the particles (the thesis' second technique, Janisz §2.2; method.md §10):
//! marching cubes over the SPH colour field the `iso` pass ray-casts (splashsurf's: cubic spline of support
//! h = 4 r, per-particle normalisation, threshold 0.6), so the mesh, the ray-cast surface and splashsurf agree.
//!
//! * The case table is GENERATED here, not copied: for each of the 256 corner sign patterns, every cube face
//!   contributes directed segments between its edge crossings — one per cyclic run of inside corners, from the
//!   crossing where the run ends to the one where it starts, seen from outside the cube (an ambiguous face
//!   therefore always separates its inside corners; the rule depends only on the face, so neighbouring cubes
//!   agree and the mesh is watertight). The segments close into loops around the cube; each loop is a fan of
//!   triangles, consistently oriented (normals point from the fluid outwards).
//! * Default path ([`extract_blocks`]): the lattice is cut into blocks of 64³ cubes (only those within the
//!   kernel support of some particle); each block, in parallel (rayon), SCATTERS the particles that reach it into
//!   a dense array of its corner values (with a one-corner margin), then marches its cubes. Every corner is
//!   summed over the same particles in the same global order whichever block computes it, so shared faces
//!   agree bit for bit: watertight, and the same mesh for any block size and thread count. A crossed edge
//!   belongs to the block of the cube it starts at, which numbers its vertex (a prefix sum over the blocks): the
//!   mesh comes out indexed, vertices block by block, with no sort.
//! * Vertex normals (default path): the negative field gradient by central differences of the corner values,
//!   interpolated along the edge (Lorensen & Cline's choice): the surface's own normal, smooth across
//!   triangles, where angle-weighted face normals would show the cubes, and free once the corners are known.
//!   Within 1.2° (median) of the field's exact gradient on a random cloud.
//! * The per-corner paths (`block = 0`; the reference the tests hold the blocks to): every corner gathers its
//!   particles; only cubes within the support are visited, either all of them (`dense`) or by following the
//!   surface in from the outside; vertex normals by central differences of the field itself at a quarter cube.
//!   8–12× slower than the blocks on the dam-break frame.

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;

use crate::field::iso::IsoGrid;

/// The 12 cube edges as (corner a, corner b, axis); corner c = (c & 1, c >> 1 & 1, c >> 2 & 1).
pub(crate) const EDGES: [(usize, usize, usize); 12] = [
    (0, 1, 0),
    (2, 3, 0),
    (4, 5, 0),
    (6, 7, 0),
    (0, 2, 1),
    (1, 3, 1),
    (4, 6, 1),
    (5, 7, 1),
    (0, 4, 2),
    (1, 5, 2),
    (2, 6, 2),
    (3, 7, 2),
];

fn corner_pos(c: usize) -> Vec3 {
    Vec3::new((c & 1) as f32, (c >> 1 & 1) as f32, (c >> 2 & 1) as f32)
}

fn edge_of(a: usize, b: usize) -> usize {
    EDGES.iter().position(|&(x, y, _)| (x, y) == (a.min(b), a.max(b))).expect("cube edge")
}

/// Triangles (as edge triples) of every corner pattern; bit c of the pattern = corner c inside.
pub fn case_table() -> &'static [Vec<[u8; 3]>; 256] {
    static TABLE: std::sync::OnceLock<[Vec<[u8; 3]>; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|mask| triangulate(mask as u8)))
}

/// The four corners of each face in counter-clockwise order seen from outside the cube.
fn faces() -> Vec<[usize; 4]> {
    let mut out = vec![];
    for axis in 0..3 {
        for side in 0..2 {
            let mut n = Vec3::ZERO;
            n[axis] = if side == 1 { 1.0 } else { -1.0 };
            let corners: Vec<usize> = (0..8).filter(|c| (c >> axis & 1) == side).collect();
            let centre = corners.iter().map(|&c| corner_pos(c)).sum::<Vec3>() / 4.0;
            // A basis (u, v) of the face with u × v = n.
            let u = Vec3::new(n.y.abs() + n.z.abs(), n.x.abs(), 0.0).normalize().cross(n).normalize();
            let v = n.cross(u);
            let mut sorted = corners.clone();
            sorted.sort_by(|&a, &b| {
                let ang = |c: usize| {
                    let d = corner_pos(c) - centre;
                    d.dot(v).atan2(d.dot(u))
                };
                ang(a).total_cmp(&ang(b))
            });
            out.push([sorted[0], sorted[1], sorted[2], sorted[3]]);
        }
    }
    out
}

fn triangulate(mask: u8) -> Vec<[u8; 3]> {
    let inside = |c: usize| mask >> c & 1 == 1;
    // next[e] = the crossing the surface goes to from crossing e (one segment per face).
    let mut next: [Option<usize>; 12] = [None; 12];
    for f in faces() {
        let ins: Vec<bool> = f.iter().map(|&c| inside(c)).collect();
        if ins.iter().all(|&x| x) || ins.iter().all(|&x| !x) {
            continue;
        }
        for i in 0..4 {
            // A run of inside corners starts at i when i is inside and the corner before it is not.
            if !ins[i] || ins[(i + 3) % 4] {
                continue;
            }
            let mut j = i;
            while ins[(j + 1) % 4] {
                j = (j + 1) % 4;
            }
            let enter = edge_of(f[(i + 3) % 4], f[i]);
            let leave = edge_of(f[j], f[(j + 1) % 4]);
            next[leave] = Some(enter);
        }
    }
    let mut tris = vec![];
    let mut seen = [false; 12];
    for start in 0..12 {
        if seen[start] || next[start].is_none() {
            continue;
        }
        let mut lp = vec![];
        let mut e = start;
        while !seen[e] {
            seen[e] = true;
            lp.push(e);
            e = next[e].expect("closed loop");
        }
        for k in 1..lp.len().saturating_sub(1) {
            // Reversed: the loops run clockwise seen from outside the fluid.
            tris.push([lp[0] as u8, lp[k + 1] as u8, lp[k] as u8]);
        }
    }
    tris
}

/// A triangle mesh with per-vertex normals.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions (world).
    pub vertices: Vec<[f32; 3]>,
    /// Unit normals, one per vertex, pointing out of the fluid.
    pub normals: Vec<[f32; 3]>,
    /// Triangles as vertex indices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// The mesh as the writer takes it (`output::write_mesh`).
    pub fn data(&self) -> crate::output::MeshData<'_> {
        crate::output::MeshData { vertices: &self.vertices, normals: &self.normals, triangles: &self.triangles }
    }

    /// The same mesh in edge-key order, given each vertex's lattice edge key ([`extract_blocks_keyed`],
    /// `compute::mc::Mc::extract_keyed`): vertices sorted by key, triangles renumbered and sorted — the one order
    /// in which meshes that number their vertices differently (block sizes, the per-corner paths, the GPU)
    /// compare. None when a key repeats (an edge with two vertices: a weld that failed).
    pub fn in_key_order(&self, keys: &[i64]) -> Option<TriMesh> {
        let mut order: Vec<usize> = (0..keys.len()).collect();
        order.sort_by_key(|&i| keys[i]);
        if !order.windows(2).all(|w| keys[w[0]] < keys[w[1]]) {
            return None;
        }
        let mut rank = vec![0u32; keys.len()];
        for (k, &i) in order.iter().enumerate() {
            rank[i] = k as u32;
        }
        let mut triangles: Vec<[u32; 3]> = self.triangles.iter().map(|t| t.map(|i| rank[i as usize])).collect();
        triangles.sort_unstable();
        Some(TriMesh {
            vertices: order.iter().map(|&i| self.vertices[i]).collect(),
            normals: order.iter().map(|&i| self.normals[i]).collect(),
            triangles,
        })
    }
}

/// The edges of a triangle mesh: every distinct edge once (its two vertices, lower first, in key order) and, per
/// corner of each triangle, the index of the edge from that corner to the next (Blender's `.edge_verts` and
/// `.corner_edge`). Ranked by [`rank_by_key`] like the extraction's weld.
pub fn mesh_edges(triangles: &[[u32; 3]]) -> (Vec<[u32; 2]>, Vec<u32>) {
    let keys: Vec<(i64, u32)> = (0..triangles.len() * 3)
        .into_par_iter()
        .map(|c| {
            let t = &triangles[c / 3];
            let (a, b) = (t[c % 3], t[(c % 3 + 1) % 3]);
            ((a.min(b) as i64) << 32 | a.max(b) as i64, c as u32)
        })
        .collect();
    let (corner_edge, first) = rank_by_key(keys, triangles.len() * 3);
    let edges = first
        .iter()
        .map(|&c| {
            let t = &triangles[c as usize / 3];
            let (a, b) = (t[c as usize % 3], t[(c as usize % 3 + 1) % 3]);
            [a.min(b), a.max(b)]
        })
        .collect();
    (edges, corner_edge)
}

/// How to extract.
#[derive(Clone, Copy, Debug)]
pub struct ExtractParams {
    /// Cube edge in world units (splashsurf's `--cube-size` × r).
    pub cube: f32,
    /// Field value of the surface (splashsurf: 0.6).
    pub threshold: f32,
    /// Evaluate the field at every corner within the kernel support (the reference) instead of following the
    /// surface in from the outside. The two agree except that following skips closed cavities inside the
    /// fluid (bubbles not connected to the outside), whose surfaces it does not reach.
    pub dense: bool,
    /// Cubes per edge of a block (the default path, [`extract_blocks`]); 0 = the per-corner paths above
    /// (`dense`, or surface following); [`AUTO_BLOCK`] (the default) = chosen by the thread count
    /// ([`auto_block`]). Changes nothing but the time and the memory.
    pub block: u32,
    /// The thesis' metaball field instead of the SPH colour field (Janisz §2.2, method.md §10):
    /// F(x) = Σ f(|x − x_j|), f(d) = (d/(√2 R_c))⁴ − (d/(√2 R_c))² + ¼ for d < R_c, else 0 — unnormalised
    /// (the 1/n_j weights are not used), with R_c the grid's support. Block path only.
    pub metaball: bool,
}

impl ExtractParams {
    /// The default: the SPH colour field, blocks of 64³ cubes.
    pub fn new(cube: f32, threshold: f32) -> ExtractParams {
        ExtractParams { cube, threshold, dense: false, block: AUTO_BLOCK, metaball: false }
    }
}

/// [`ExtractParams::block`]: choose the block size by the thread count ([`auto_block`]).
pub const AUTO_BLOCK: u32 = u32::MAX;

/// The block size for `threads` threads: 64 cubes per edge (the fastest on 1–2 threads: the one-corner margin
/// costs least), else the largest of 64, 32, 16 that leaves at least 40 occupied blocks per thread, so that no
/// thread waits long for the last blocks. Measured on the 16-core host of an H100 (59k dam break f20,
/// `bench --mesh --block 64,32,16`; benches/results/nvidia-h100-host-bench-mesh-93097bc/): at 0.5 r and 16
/// threads 64 → 0.30 s, 32 → 0.23, 16 → 0.29; at 1 r 0.077, 0.074, 0.066; on 4 threads 64 and 32 tie.
pub fn auto_block(grid: &IsoGrid, cube: f32, threads: usize) -> u32 {
    if threads <= 2 || grid.points.is_empty() {
        return 64;
    }
    let lat = Lattice::of(grid, cube.max(1e-6));
    for b in [64, 32] {
        if occupied_blocks(grid, &lat, b).0.len() >= 40 * threads {
            return b as u32;
        }
    }
    16
}

/// `p` with its block size decided ([`AUTO_BLOCK`] resolved for the current thread pool).
pub fn resolve_block(grid: &IsoGrid, p: &ExtractParams) -> ExtractParams {
    if p.block == AUTO_BLOCK {
        ExtractParams { block: auto_block(grid, p.cube, rayon::current_num_threads()), ..*p }
    } else {
        *p
    }
}

/// The metaball falloff f(d) of [`ExtractParams::metaball`] at q = d / R_c: ((q²/2) − ½)² for q < 1.
pub fn metaball(q: f32) -> f32 {
    if q < 1.0 {
        let s = 0.5 * q * q - 0.5;
        s * s
    } else {
        0.0
    }
}

/// The metaball threshold that puts an isolated particle's surface at distance `r` for influence radius `rc`.
pub fn metaball_threshold(r: f32, rc: f32) -> f32 {
    metaball(r / rc)
}

/// The field at the two ends of the lattice edge a mesh vertex `v` lies on (the axis along which `v` is off the
/// lattice planes), as the extraction evaluates it: how well the vertex is determined. A vertex interpolated on
/// an edge whose values differ by |v1 − v0| moves by about h · δ / |v1 − v0| when the values carry rounding
/// errors δ — the bound two correct extractions with different float arithmetic (summation order, fused
/// multiply-adds) agree within. For tests and diagnostics: O(particles) per call with the metaball field.
pub fn edge_values(grid: &IsoGrid, inv_n: &[f32], p: &ExtractParams, v: [f32; 3]) -> (f32, f32) {
    let lat = Lattice::of(grid, p.cube.max(1e-6));
    let u = (Vec3::from(v) - lat.lo) / lat.h;
    let off = u - u.round();
    let axis = (0..3).max_by(|&a, &b| off[a].abs().total_cmp(&off[b].abs())).unwrap_or(0);
    let mut c0 = u.round();
    c0[axis] = u[axis].floor();
    let mut c1 = c0;
    c1[axis] += 1.0;
    let field = |c: Vec3| -> f32 {
        let x = lat.lo + c * lat.h;
        if p.metaball {
            grid.points.iter().map(|q| metaball(x.distance(Vec3::new(q[0], q[1], q[2])) / grid.support)).sum()
        } else {
            grid.field(x, inv_n).0
        }
    };
    (field(c0), field(c1))
}

/// The lattice of cube edge `cube` over `grid`'s particles fits the extraction's 64-bit edge keys (corners ×
/// 3 below 2⁶²); an error naming its size otherwise (particles spread far apart at a small cube size).
pub fn check_lattice(grid: &IsoGrid, cube: f32) -> crate::error::Result<()> {
    if grid.points.is_empty() {
        return Ok(());
    }
    // In f64: a lattice too large for i32 indices must be reported, not wrapped round.
    let (lo, hi) = grid.points.iter().fold((glam::DVec3::INFINITY, glam::DVec3::NEG_INFINITY), |(a, b), q| {
        let q = glam::DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64);
        (a.min(q), b.max(q))
    });
    let corners = ((hi - lo + 2.0 * grid.support as f64) / cube.max(1e-6) as f64).ceil() + 1.0;
    if corners.max_element() < i32::MAX as f64 / 2.0 && corners.x * corners.y * corners.z * 3.0 < 2f64.powi(62) {
        return Ok(());
    }
    Err(crate::error::Error::Limit(format!(
        "the particles span {:.3e} × {:.3e} × {:.3e} (world units): {:.3e} × {:.3e} × {:.3e} cubes of {cube}, too \
         many for one marching-cubes lattice; if they really span this much, mesh them with a larger --cube-size \
         or in parts",
        hi.x - lo.x,
        hi.y - lo.y,
        hi.z - lo.z,
        corners.x,
        corners.y,
        corners.z
    )))
}

/// The memory (bytes) an extraction of `grid` with `p` on `threads` threads needs at least, estimated before
/// anything is allocated: the block path's per-thread scratch ((b + 3)³ corners × 17 bytes) and block list,
/// or the per-corner paths' bitset over the lattice and their per-cube lists over the occupied 16³ blocks.
pub fn memory_estimate(grid: &IsoGrid, p: &ExtractParams, threads: usize) -> u64 {
    if grid.points.is_empty() {
        return 0;
    }
    let p = &if p.block == AUTO_BLOCK { ExtractParams { block: auto_block(grid, p.cube, threads), ..*p } } else { *p };
    let lat = Lattice::of(grid, p.cube.max(1e-6));
    if (p.block > 0 && !p.dense) || p.metaball {
        let n = p.block.max(1) as u64 + 3;
        let (blocks, _) = occupied_blocks(grid, &lat, p.block.max(1) as i32);
        return threads.max(1) as u64 * n * n * n * 17 + blocks.len() as u64 * 8;
    }
    let total = lat.dims.as_dvec3();
    let bitset = (total.x * total.y * total.z / 8.0) as u64;
    let (blocks, _) = occupied_blocks(grid, &lat, 16);
    let cubes = blocks.len() as u64 * 4096;
    bitset + cubes * if p.dense { 104 } else { 40 }
}

/// [`memory_estimate`] against what the machine has ([`crate::input::available_memory`]): an error with both
/// numbers, and what to change, when the estimate exceeds it.
pub fn check_memory(grid: &IsoGrid, p: &ExtractParams, threads: usize) -> crate::error::Result<()> {
    let need = memory_estimate(grid, p, threads);
    let Some(have) = crate::input::available_memory() else { return Ok(()) };
    if need <= have {
        return Ok(());
    }
    Err(crate::error::Error::Limit(format!(
        "this extraction needs about {:.1} GB of memory, more than the {:.1} GB available (cube {}, block {}{}, {} \
         thread(s)); use a larger --cube-size, the default --block 64, or fewer --threads",
        need as f64 / 1e9,
        have as f64 / 1e9,
        p.cube,
        p.block,
        if p.dense { ", dense" } else { "" },
        threads
    )))
}

/// Extract the iso-surface of `grid`'s field (with 1/n_j `inv_n`, see [`IsoGrid::inv_density`]).
pub fn extract(grid: &IsoGrid, inv_n: &[f32], p: &ExtractParams) -> TriMesh {
    extract_timed(grid, inv_n, p).0
}

/// [`extract`], and where the time went when it took the block path (the default).
pub fn extract_timed(grid: &IsoGrid, inv_n: &[f32], p: &ExtractParams) -> (TriMesh, Option<ExtractTimes>) {
    if grid.points.is_empty() {
        return (TriMesh::default(), None);
    }
    let p = &resolve_block(grid, p);
    if (p.block > 0 && !p.dense) || p.metaball {
        let (m, t) = extract_blocks_timed(grid, inv_n, &ExtractParams { block: p.block.max(1), ..*p });
        return (m, Some(t));
    }
    (extract_corners(grid, inv_n, p), None)
}

/// The per-corner paths (`block = 0`): surface following, or `dense`.
fn extract_corners(grid: &IsoGrid, inv_n: &[f32], p: &ExtractParams) -> TriMesh {
    let h = p.cube.max(1e-6);
    // The lattice: corners at origin + h·(i, j, k), covering the particles' box grown by the support.
    let lo = grid.points.iter().fold(Vec3::INFINITY, |a, q| a.min(Vec3::new(q[0], q[1], q[2]))) - grid.support;
    let hi = grid.points.iter().fold(Vec3::NEG_INFINITY, |a, q| a.max(Vec3::new(q[0], q[1], q[2]))) + grid.support;
    let dims = ((hi - lo) / h).ceil().as_ivec3() + 1;
    let corner_key =
        |i: i32, j: i32, k: i32| -> i64 { (i as i64 * dims.y as i64 + j as i64) * dims.z as i64 + k as i64 };
    let corner_at = |key: i64| -> Vec3 {
        let k = key % dims.z as i64;
        let j = key / dims.z as i64 % dims.y as i64;
        let i = key / dims.z as i64 / dims.y as i64;
        lo + Vec3::new(i as f32, j as f32, k as f32) * h
    };
    // Cubes within the support of some particle (the field is 0 elsewhere), marked in a bitset over the lattice
    // (one bit a cube: 9 MB for the dam-break tank at 0.5 r), then listed by their lower corners' keys.
    let reach = (grid.support / h).ceil() as i32;
    let total = dims.x as usize * dims.y as usize * dims.z as usize;
    let mut marked = vec![0u64; total.div_ceil(64)];
    for q in &grid.points {
        let c = ((Vec3::new(q[0], q[1], q[2]) - lo) / h).floor().as_ivec3();
        for i in (c.x - reach).max(0)..=(c.x + reach).min(dims.x - 2) {
            for j in (c.y - reach).max(0)..=(c.y + reach).min(dims.y - 2) {
                let row = corner_key(i, j, 0);
                let (k0, k1) = ((c.z - reach).max(0), (c.z + reach).min(dims.z - 2));
                for k in k0..=k1 {
                    let bit = (row + k as i64) as usize;
                    marked[bit / 64] |= 1 << (bit % 64);
                }
            }
        }
    }
    let (values, cubes): (HashMap<i64, f32>, Vec<i64>) = if p.dense {
        let cubes: Vec<i64> = marked
            .iter()
            .enumerate()
            .flat_map(|(w, &bits)| (0..64).filter(move |b| bits >> b & 1 == 1).map(move |b| (w * 64 + b) as i64))
            .collect();
        let mut corners: Vec<i64> =
            cubes.par_iter().flat_map_iter(|&c| (0..8).map(move |n| c + corner_offset(n, dims))).collect();
        corners.par_sort_unstable();
        corners.dedup();
        let values: Vec<f32> = corners.par_iter().map(|&c| grid.field(corner_at(c), inv_n).0).collect();
        (corners.into_iter().zip(values).collect(), cubes)
    } else {
        follow(&marked, dims, p.threshold, |c| grid.field(corner_at(c), inv_n).0)
    };
    drop(marked);
    // Corners never evaluated are inside the fluid (following stops at the first inside corner).
    let value = |c: i64| -> f32 { values.get(&c).copied().unwrap_or(f32::INFINITY) };
    let table = case_table();
    // March: per cube its triangles as (edge key, edge key, edge key); edge key = corner key × 3 + axis.
    let tris: Vec<[i64; 3]> = cubes
        .par_iter()
        .flat_map_iter(|&c| {
            let v: [f32; 8] = std::array::from_fn(|n| value(c + corner_offset(n, dims)));
            let mask = (0..8).fold(0u8, |m, n| m | (((v[n] >= p.threshold) as u8) << n));
            table[mask as usize].iter().map(move |t| {
                t.map(|e| {
                    let (a, _, axis) = EDGES[e as usize];
                    (c + corner_offset(a, dims)) * 3 + axis as i64
                })
            })
        })
        .collect();
    // Vertices: one per grid edge used, in key order (deterministic whatever the thread count).
    let mut keys: Vec<i64> = tris.iter().flatten().copied().collect();
    keys.par_sort_unstable();
    keys.dedup();
    let index: HashMap<i64, u32> = keys.iter().enumerate().map(|(i, &k)| (k, i as u32)).collect();
    let vertices: Vec<[f32; 3]> = keys
        .par_iter()
        .map(|&key| {
            let (c, axis) = (key / 3, (key % 3) as usize);
            let a = corner_at(c);
            let mut d = Vec3::ZERO;
            d[axis] = h;
            let (fa, fb) = (value(c), value(c + axis_offset(axis, dims)));
            let t = ((p.threshold - fa) / (fb - fa)).clamp(0.0, 1.0);
            (a + d * t).to_array()
        })
        .collect();
    let normals: Vec<[f32; 3]> = vertices
        .par_iter()
        .map(|x| {
            let x = Vec3::from(*x);
            let e = h * 0.25;
            let f = |d: Vec3| grid.field(x + d, inv_n).0;
            let g = Vec3::new(
                f(Vec3::X * e) - f(-Vec3::X * e),
                f(Vec3::Y * e) - f(-Vec3::Y * e),
                f(Vec3::Z * e) - f(-Vec3::Z * e),
            );
            (-g).normalize_or_zero().to_array()
        })
        .collect();
    let triangles = tris.iter().map(|t| t.map(|k| index[&k])).collect();
    TriMesh { vertices, normals, triangles }
}

/// The lattice of an extraction: corner (i, j, k) at `lo + h·(i, j, k)`, `dims` corners per axis, keys
/// `(i·dims.y + j)·dims.z + k` (the per-corner paths use the same keys).
/// The marching-cubes lattice: corners at `lo + h·(i, j, k)`, covering the particles' box grown by the support.
pub(crate) struct Lattice {
    pub(crate) lo: Vec3,
    pub(crate) h: f32,
    pub(crate) dims: glam::IVec3,
}

impl Lattice {
    pub(crate) fn of(grid: &IsoGrid, h: f32) -> Lattice {
        let lo = grid.points.iter().fold(Vec3::INFINITY, |a, q| a.min(Vec3::new(q[0], q[1], q[2]))) - grid.support;
        let hi = grid.points.iter().fold(Vec3::NEG_INFINITY, |a, q| a.max(Vec3::new(q[0], q[1], q[2]))) + grid.support;
        Lattice { lo, h, dims: ((hi - lo) / h).ceil().as_ivec3() + 1 }
    }
    pub(crate) fn key(&self, c: glam::IVec3) -> i64 {
        (c.x as i64 * self.dims.y as i64 + c.y as i64) * self.dims.z as i64 + c.z as i64
    }
}

/// The blocks of `b`³ cubes that some particle's support reaches (cube lower corners in [c − reach, c + reach]),
/// as sorted keys `(x · nb.y + y) · nb.z + z`, and `nb`, the blocks per axis. Shared by the CPU and GPU paths.
pub(crate) fn occupied_blocks(grid: &IsoGrid, lat: &Lattice, b: i32) -> (Vec<i64>, glam::IVec3) {
    let (h, dims) = (lat.h, lat.dims);
    let reach = (grid.support / h).ceil() as i32;
    let nb = (dims - 1 + b - 1) / b; // blocks per axis over the dims − 1 cubes
    let mut blocks: Vec<i64> = grid
        .points
        .par_iter()
        .flat_map_iter(|q| {
            let c = ((Vec3::new(q[0], q[1], q[2]) - lat.lo) / h).floor().as_ivec3();
            let b0 = ((c - reach).max(glam::IVec3::ZERO)) / b;
            let b1 = ((c + reach).min(dims - 2)) / b;
            (b0.x..=b1.x).flat_map(move |x| {
                (b0.y..=b1.y).flat_map(move |y| {
                    (b0.z..=b1.z).map(move |z| (x as i64 * nb.y as i64 + y as i64) * nb.z as i64 + z as i64)
                })
            })
        })
        .collect();
    blocks.par_sort_unstable();
    blocks.dedup();
    (blocks, nb)
}

/// Block extraction (the default): the lattice is cut into blocks of `p.block`³ cubes; only blocks within the
/// kernel support of some particle exist. Each block, independently and in parallel (rayon):
/// 1. gathers the particles whose support reaches it (from the neighbour grid's cells), in their global order;
/// 2. SCATTERS them into a dense array of its corner values, with a margin of one corner on every side (each
///    particle adds W(d/h)/n_j to the ≈ 2,100 corners within its support at 0.5 r cubes — a sweep of rows, one
///    square root per corner — instead of every corner gathering ≈ 200 candidate particles);
/// 3. marches its cubes (rows of cubes between four corner rows on one side are skipped whole), making each
///    crossing edge's vertex once (linear interpolation) with its normal: the negative field gradient, central
///    differences of the corner values interpolated along the edge (the margin is what makes them available),
///    i.e. the field's own normal;
/// 4. each crossed edge is owned by the block of the cube it starts at: the blocks' owned vertices are numbered
///    by a prefix sum over the blocks, a triangle corner on a neighbour's edge finds it in that neighbour's face
///    list, the triangles follow in block order ([`weld_blocks`]: no sort, parallel throughout).
///
/// Every corner's value is summed over the same particles in the same (global) order whichever block computes
/// it, so blocks that share a face agree bit for bit: the mesh is watertight, and the same for any block size
/// and thread count up to the order of vertices and triangles (the same order for one block size on any thread
/// count; [`extract_blocks_keyed`] gives each vertex's edge key, for comparisons in edge-key order).
///
/// Speed (commit 0b5cc2b, dam break 59k frame 20 at 0.5 r, 1 thread): 2.2 s → 1.0 s, as fast as splashsurf 0.14,
/// from making each vertex once per block instead of once per triangle corner (and sorting 4.3 M of them),
/// skipping uniform rows of cubes, blocks of 64³ (the one-corner margin costs (67/64)³ instead of (35/32)³),
/// reusing each thread's block arrays, and floor/ceil without libm calls. Peak memory 290 → 140 MB.
pub fn extract_blocks(grid: &IsoGrid, inv_n: &[f32], p: &ExtractParams) -> TriMesh {
    extract_blocks_timed(grid, inv_n, p).0
}

/// Where a block extraction's time went, in seconds (`meniscus mesh` prints it).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExtractTimes {
    /// Occupied blocks.
    pub blocks: usize,
    /// Scattering the particles into the blocks' corner values, summed over the threads.
    pub scatter: f64,
    /// Marching the blocks' cubes, summed over the threads.
    pub march: f64,
    /// Welding the blocks' vertices and ordering the triangles (wall).
    pub weld: f64,
    /// The blocks' scatter and march together (wall): with `scatter + march` (thread time), the parallel
    /// efficiency of the block phase.
    pub blocks_wall: f64,
    /// Cubes per block edge (after [`AUTO_BLOCK`] was resolved).
    pub block: u32,
}

/// [`extract_blocks`], and where its time went.
pub fn extract_blocks_timed(grid: &IsoGrid, inv_n: &[f32], p: &ExtractParams) -> (TriMesh, ExtractTimes) {
    let (m, _, t) = extract_blocks_keyed(grid, inv_n, p);
    (m, t)
}

/// [`extract_blocks_timed`], and each vertex's lattice edge key (`(corner key) · 3 + axis`): the block path
/// numbers its vertices block by block, so comparisons with other paths (the per-corner reference, the GPU)
/// put both in key order.
pub fn extract_blocks_keyed(grid: &IsoGrid, inv_n: &[f32], p: &ExtractParams) -> (TriMesh, Vec<i64>, ExtractTimes) {
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    let t0 = std::time::Instant::now();
    let p = &resolve_block(grid, p);
    let lat = Lattice::of(grid, p.cube.max(1e-6));
    let b = p.block.max(1) as i32;
    let (blocks, nb) = occupied_blocks(grid, &lat, b);
    // Per-thread scratch (corner values, inside flags, edge → vertex slots), reused from block to block.
    let n = b + 3;
    let cells = (n as usize).pow(3);
    let (scatter_ns, march_ns) = (AtomicU64::new(0), AtomicU64::new(0));
    let outs: Vec<BlockMesh> = blocks
        .par_iter()
        .map_init(
            || (vec![0f32; cells], vec![0u8; cells], vec![u32::MAX; 3 * cells], vec![0u8; (n * n) as usize]),
            |(v, inside, slot, rows), &bk| {
                let bi = glam::IVec3::new(
                    (bk / nb.z as i64 / nb.y as i64) as i32,
                    (bk / nb.z as i64 % nb.y as i64) as i32,
                    (bk % nb.z as i64) as i32,
                );
                // Corners of the block with the margin: global c0 − 1 … c0 + b + 1.
                let blk = BlockShape { c0: bi * b - 1, n, b, nb };
                let t = std::time::Instant::now();
                scatter_block(grid, inv_n, p, &lat, &blk, v);
                let t_scatter = t.elapsed();
                let out = march_block(&lat, &blk, v, p.threshold, inside, slot, rows);
                scatter_ns.fetch_add(t_scatter.as_nanos() as u64, Relaxed);
                march_ns.fetch_add((t.elapsed() - t_scatter).as_nanos() as u64, Relaxed);
                out
            },
        )
        .collect();
    let t_blocks = t0.elapsed();
    let (mesh, keys) = weld_blocks(outs, &blocks);
    let times = ExtractTimes {
        blocks: blocks.len(),
        scatter: scatter_ns.into_inner() as f64 * 1e-9,
        march: march_ns.into_inner() as f64 * 1e-9,
        weld: (t0.elapsed() - t_blocks).as_secs_f64(),
        blocks_wall: t_blocks.as_secs_f64(),
        block: p.block,
    };
    (mesh, keys, times)
}

/// A block's place in the lattice: its corners (margin included) are global `c0 + (0 … n − 1)` per axis, its
/// own cubes local `1 … b`.
struct BlockShape {
    c0: glam::IVec3,
    n: i32,
    b: i32,
    /// Blocks per axis (block keys).
    nb: glam::IVec3,
}

impl BlockShape {
    fn idx(&self, l: glam::IVec3) -> usize {
        ((l.z * self.n + l.y) * self.n + l.x) as usize
    }
}

/// What one block emits. A crossed edge is OWNED by the block of the cube it starts at (its own cubes are local
/// 1 … b), so every edge has one owner: the block makes the vertices of the edges it owns (`verts`, in the order
/// made) and names the others by key and owner (`foreign`); its triangles refer to either (`FOREIGN` marks the
/// second kind), a cube's triangles consecutive, in table order.
struct BlockMesh {
    /// Owned vertices.
    verts: Vec<MadeVertex>,
    /// The owned vertices on the block's lower faces — the only ones a neighbour's triangles reach: (key, index
    /// into `verts`), sorted by key.
    face: Vec<(i64, u32)>,
    /// Edges owned by a neighbour: key, the owner's block key, and the vertex as made here (the owner makes the
    /// same, bit for bit; kept should the owner not be found).
    foreign: Vec<(i64, i64, [f32; 3], [f32; 3])>,
    /// Triangles: indices into `verts`, or `FOREIGN | index into foreign`.
    tris: Vec<[u32; 3]>,
}

/// A vertex as a block makes it: edge key, position, normal.
type MadeVertex = (i64, [f32; 3], [f32; 3]);

/// Marks a triangle corner of [`BlockMesh::tris`] that names a neighbour's vertex.
const FOREIGN: u32 = 1 << 31;

/// `floor` without the libm call baseline x86-64 makes of `f32::floor` (no SSE4.1 round): exact for |x| < 2³¹.
#[inline(always)]
pub(crate) fn floor_i(x: f32) -> i32 {
    let i = x as i32;
    i - (x < i as f32) as i32
}

/// `ceil` likewise.
#[inline(always)]
fn ceil_i(x: f32) -> i32 {
    let i = x as i32;
    i + (x > i as f32) as i32
}

/// Step 1–2 of [`extract_blocks`]: the particles whose support reaches the block (cells in index order, so in
/// the global sorted order), each SCATTERED into the block's dense corner values `v` (zeroed here).
fn scatter_block(grid: &IsoGrid, inv_n: &[f32], p: &ExtractParams, lat: &Lattice, blk: &BlockShape, v: &mut [f32]) {
    let (h, n, c0) = (lat.h, blk.n, blk.c0);
    v.fill(0.0);
    let support = grid.support;
    let g = &grid.grid;
    let gdims = glam::IVec3::new(g.dims[0] as i32, g.dims[1] as i32, g.dims[2] as i32);
    let box_lo = lat.lo + c0.as_vec3() * h;
    let box_hi = box_lo + Vec3::splat((n - 1) as f32 * h);
    let cl = ((box_lo - support - g.origin) / g.cell).floor().as_ivec3().max(glam::IVec3::ZERO);
    let ch = ((box_hi + support - g.origin) / g.cell).floor().as_ivec3().min(gdims - 1);
    let s2 = support * support;
    let inv_support = 1.0 / support;
    let inv_h = 1.0 / h;
    // The support in lattice units.
    let rs = support * inv_h;
    // Cells in index order (z, y, x nested) = the global sorted order of their points.
    for z in cl.z..=ch.z {
        for y in cl.y..=ch.y {
            let row = (gdims.x * (y + gdims.y * z)) as usize;
            for c in row + cl.x as usize..=row + ch.x as usize {
                let [first, count] = g.cells[c];
                for j in first..first + count {
                    let q = g.points[j as usize];
                    let x = Vec3::new(q[0], q[1], q[2]);
                    let w_j = if p.metaball { 1.0 } else { inv_n[j as usize] };
                    // The corners within the support, as GLOBAL lattice ranges (so every block that holds a
                    // corner includes the same particles in it: shared faces agree bit for bit), clipped to the
                    // block. A corner the rounding leaves out lies at q ≈ 1, where the kernel is ≈ 0, in every
                    // block alike.
                    let gx = (x - lat.lo) * inv_h; // in lattice units
                    let lx = (ceil_i(gx.x - rs) - c0.x).max(0);
                    let ly = (ceil_i(gx.y - rs) - c0.y).max(0);
                    let lz = (ceil_i(gx.z - rs) - c0.z).max(0);
                    let ux = (floor_i(gx.x + rs) - c0.x).min(n - 1);
                    let uy = (floor_i(gx.y + rs) - c0.y).min(n - 1);
                    let uz = (floor_i(gx.z + rs) - c0.z).min(n - 1);
                    for k in lz..=uz {
                        let dz = lat.lo.z + (c0.z + k) as f32 * h - x.z;
                        for jj in ly..=uy {
                            let dy = lat.lo.y + (c0.y + jj) as f32 * h - x.y;
                            let d2 = dy * dy + dz * dz;
                            if d2 >= s2 {
                                continue;
                            }
                            let row = ((k * n + jj) * n) as usize;
                            // The row's chord through the support sphere.
                            let half = (s2 - d2).sqrt() * inv_h;
                            let i0 = (ceil_i(gx.x - half) - c0.x).max(lx);
                            let i1 = (floor_i(gx.x + half) - c0.x).min(ux);
                            if i1 < i0 {
                                continue;
                            }
                            let seg = &mut v[row + i0 as usize..=row + i1 as usize];
                            scatter_row(seg, c0.x + i0, lat.lo.x, h, x.x, d2, inv_support, w_j, p.metaball);
                        }
                    }
                }
            }
        }
    }
}

/// Step 3 of [`extract_blocks`]: march the block's own cubes (local 1 … b, skipping cubes past the lattice and
/// rows of cubes with no crossing); each crossing edge's vertex is made once per block (`slot`: local edge →
/// vertex). Triangles in memory order; [`weld_blocks`] puts them in cube order.
fn march_block(
    lat: &Lattice,
    blk: &BlockShape,
    v: &[f32],
    threshold: f32,
    inside: &mut [u8],
    slot: &mut [u32],
    uniform: &mut [u8],
) -> BlockMesh {
    let (h, dims, c0, b) = (lat.h, lat.dims, blk.c0, blk.b);
    let table = case_table();
    let at = |l: glam::IVec3| v[blk.idx(l)];
    let grad = |l: glam::IVec3| {
        Vec3::new(
            at(l + glam::IVec3::X) - at(l - glam::IVec3::X),
            at(l + glam::IVec3::Y) - at(l - glam::IVec3::Y),
            at(l + glam::IVec3::Z) - at(l - glam::IVec3::Z),
        )
    };
    for (f, s) in v.iter().zip(inside.iter_mut()) {
        *s = (*f >= threshold) as u8;
    }
    slot.fill(u32::MAX);
    // Index offsets of the 8 cube corners.
    let off: [usize; 8] = std::array::from_fn(|m| blk.idx(corner_delta(m)));
    let (ie, je, ke) = ((dims.x - 2 - c0.x).min(b), (dims.y - 2 - c0.y).min(b), (dims.z - 2 - c0.z).min(b));
    // Per row of corners (j, k): whether its corners 1 … ie + 1 are all on one side (1 outside, 2 inside), so
    // the rows of cubes between four such rows on the same side are skipped without looking at their cubes.
    let n = blk.n;
    for (r, u) in uniform.iter_mut().enumerate() {
        let r = r as i32;
        let row = &inside[(r * n + 1) as usize..=(r * n + ie + 1) as usize];
        let s: usize = row.iter().map(|&x| x as usize).sum();
        *u = if s == 0 {
            1
        } else if s == row.len() {
            2
        } else {
            0
        };
    }
    let mut out = BlockMesh { verts: vec![], face: vec![], foreign: vec![], tris: vec![] };
    for k in 1..=ke {
        for j in 1..=je {
            let r = (k * n + j) as usize;
            let u = uniform[r];
            let nn = n as usize;
            if u != 0 && uniform[r + 1] == u && uniform[r + nn] == u && uniform[r + nn + 1] == u {
                continue;
            }
            for i in 1..=ie {
                let l = glam::IVec3::new(i, j, k);
                let base = blk.idx(l);
                let mask = (0..8).fold(0u8, |acc, m| acc | (inside[base + off[m]] << m));
                if mask == 0 || mask == 255 {
                    continue;
                }
                for t in &table[mask as usize] {
                    let tri = t.map(|e| {
                        let (a, bb, axis) = EDGES[e as usize];
                        let la = l + corner_delta(a);
                        let s = &mut slot[blk.idx(la) * 3 + axis];
                        if *s == u32::MAX {
                            let lb = l + corner_delta(bb);
                            let (fa, fb) = (at(la), at(lb));
                            let tt = ((threshold - fa) / (fb - fa)).clamp(0.0, 1.0);
                            let pa = lat.lo + (c0 + la).as_vec3() * h;
                            let mut d = Vec3::ZERO;
                            d[axis] = h;
                            let pos = pa + d * tt;
                            let nrm = -(grad(la) * (1.0 - tt) + grad(lb) * tt).normalize_or_zero();
                            let key = lat.key(c0 + la) * 3 + axis as i64;
                            // Owned when its start corner is one of the block's own cubes (local 1 … b).
                            if la.cmple(glam::IVec3::splat(b)).all() {
                                *s = out.verts.len() as u32;
                                if la.cmpeq(glam::IVec3::ONE).any() {
                                    out.face.push((key, *s));
                                }
                                out.verts.push((key, pos.to_array(), nrm.to_array()));
                            } else {
                                let owner = (c0 + la).div_euclid(glam::IVec3::splat(b));
                                let nb = blk.nb;
                                let owner_key =
                                    (owner.x as i64 * nb.y as i64 + owner.y as i64) * nb.z as i64 + owner.z as i64;
                                *s = FOREIGN | out.foreign.len() as u32;
                                out.foreign.push((key, owner_key, pos.to_array(), nrm.to_array()));
                            }
                        }
                        *s
                    });
                    out.tris.push(tri);
                }
            }
        }
    }
    out.face.sort_unstable();
    out
}

/// Weld on keys: sorts `(key, item)` pairs and walks them; returns every item's vertex (the rank of its key among
/// the distinct keys, so vertices come in key order) and, per vertex, the first item with its key (the lowest
/// item index: its data stands for the vertex). Used by [`mesh_edges`].
/// Parallel throughout (the sort, the run starts, their numbering by a prefix sum over chunks, the scatter of
/// ranks): the walk it replaced was the extraction's serial part (0.06 s of 1.4 M vertices on the 59k frame).
pub(crate) fn rank_by_key(mut keys: Vec<(i64, u32)>, items: usize) -> (Vec<u32>, Vec<u32>) {
    use std::sync::atomic::{AtomicU32, Ordering::Relaxed};
    keys.par_sort_unstable();
    // Run starts, counted per chunk, then each chunk's first run number (a prefix sum over the chunks).
    let chunk = (keys.len() / (4 * rayon::current_num_threads()).max(1)).max(1 << 14);
    let starts = |c: usize| -> usize {
        let lo = c * chunk;
        let hi = (lo + chunk).min(keys.len());
        (lo..hi).filter(|&i| i == 0 || keys[i].0 != keys[i - 1].0).count()
    };
    let chunks = keys.len().div_ceil(chunk);
    let counts: Vec<usize> = (0..chunks).into_par_iter().map(starts).collect();
    let mut offsets = Vec::with_capacity(chunks);
    let mut total = 0usize;
    for c in &counts {
        offsets.push(total);
        total += c;
    }
    let rank: Vec<AtomicU32> = (0..items).map(|_| AtomicU32::new(0)).collect();
    let first: Vec<AtomicU32> = (0..total).map(|_| AtomicU32::new(0)).collect();
    (0..chunks).into_par_iter().for_each(|c| {
        let lo = c * chunk;
        let hi = (lo + chunk).min(keys.len());
        // The run the chunk's first key belongs to: the one before this chunk's first start, unless it starts one.
        let mut run = offsets[c] as i64 - 1;
        for i in lo..hi {
            let (key, item) = keys[i];
            if i == 0 || key != keys[i - 1].0 {
                run += 1;
                first[run as usize].store(item, Relaxed);
            }
            rank[item as usize].store(run as u32, Relaxed);
        }
    });
    (rank.into_iter().map(AtomicU32::into_inner).collect(), first.into_iter().map(AtomicU32::into_inner).collect())
}

/// Step 4 of [`extract_blocks`]: the blocks' owned vertices numbered by a prefix sum over the blocks (block
/// order, then the order made), the triangles' foreign corners found in their owner's face list (a binary search
/// of the sorted block keys, then of the owner's face keys), the triangles in block order — no sort of the mesh,
/// every step parallel. Returns the mesh and each vertex's edge key. (Sorting every vertex key and every
/// triangle's cube key instead took 0.148 s of the 59k frame's 0.65 s at 0.5 r on 2 threads, this 0.045 s:
/// docs/mesh-extraction.md.)
fn weld_blocks(outs: Vec<BlockMesh>, blocks: &[i64]) -> (TriMesh, Vec<i64>) {
    let mut base = Vec::with_capacity(outs.len() + 1);
    base.push(0usize);
    for o in &outs {
        base.push(base.last().copied().unwrap_or(0) + o.verts.len());
    }
    let owned = base[outs.len()];
    // Each foreign corner's vertex: its owner's, or (an owner not found: not expected) the block's own copy,
    // appended after the owned vertices.
    let resolved: Vec<Vec<Result<u32, MadeVertex>>> = outs
        .par_iter()
        .map(|o| {
            o.foreign
                .iter()
                .map(|&(key, owner, p, n)| {
                    blocks
                        .binary_search(&owner)
                        .ok()
                        .and_then(|ob| {
                            let f = &outs[ob].face;
                            f.binary_search_by_key(&key, |e| e.0).ok().map(|k| (base[ob] + f[k].1 as usize) as u32)
                        })
                        .ok_or((key, p, n))
                })
                .collect()
        })
        .collect();
    let mut extra: Vec<MadeVertex> = vec![];
    let resolved: Vec<Vec<u32>> = resolved
        .into_iter()
        .map(|r| {
            r.into_iter()
                .map(|x| {
                    x.unwrap_or_else(|v| {
                        let i = extra.iter().position(|e| e.0 == v.0).unwrap_or_else(|| {
                            extra.push(v);
                            extra.len() - 1
                        });
                        (owned + i) as u32
                    })
                })
                .collect()
        })
        .collect();
    let all = || outs.par_iter().flat_map_iter(|o| o.verts.iter()).chain(extra.par_iter());
    let vertices = all().map(|v| v.1).collect();
    let normals = all().map(|v| v.2).collect();
    let keys = all().map(|v| v.0).collect();
    let triangles = outs
        .par_iter()
        .zip(&resolved)
        .zip(&base)
        .flat_map_iter(|((o, r), &b)| {
            o.tris
                .iter()
                .map(move |t| t.map(|i| if i & FOREIGN != 0 { r[(i & !FOREIGN) as usize] } else { b as u32 + i }))
        })
        .collect();
    (TriMesh { vertices, normals, triangles }, keys)
}

/// Add one particle's kernel to a row of corner values: corner `o` of `seg` is global lattice index `i0 + o`
/// along x (position `lo_x + index·h`), `d2` the squared distance across the row, `w` the particle's weight.
/// Branch-free (the kernel as selects) so that it vectorises. (Tried twice: an AVX2 build chosen at run time, of
/// this function and of the whole block scatter — no faster: the rows are only ~13 corners long.)
#[allow(clippy::too_many_arguments)]
fn scatter_row(
    seg: &mut [f32],
    i0: i32,
    lo_x: f32,
    h: f32,
    px: f32,
    d2: f32,
    inv_support: f32,
    w: f32,
    metaball: bool,
) {
    for (o, val) in seg.iter_mut().enumerate() {
        let dx = lo_x + (i0 + o as i32) as f32 * h - px;
        let q = (dx * dx + d2).sqrt() * inv_support;
        let k = if metaball {
            let s = 0.5 * q * q - 0.5;
            if q < 1.0 {
                s * s
            } else {
                0.0
            }
        } else {
            // The cubic spline (crate::field::iso::kernel).
            let a = 1.0 - q;
            let near = 1.0 - 6.0 * q * q + 6.0 * q * q * q;
            let far = 2.0 * a * a * a;
            if q <= 0.5 {
                near
            } else if q < 1.0 {
                far
            } else {
                0.0
            }
        };
        *val += k * w;
    }
}

/// Surface following: the corners of the band's outer boundary lie farther than the support from every
/// particle (field 0); from them a breadth-first walk over lattice corners evaluates the field, crossing corners
/// below the threshold (outside the fluid) and stopping at the first corner above it. Every edge that crosses
/// the surface has an outside end the walk reached, so it evaluated both ends; the cubes to march are those
/// around the inside corners it stopped at. Interior corners are never evaluated. Returns the values and the
/// cubes. Each frontier is evaluated in parallel; the sets do not depend on the thread count.
fn follow(
    marked: &[u64],
    dims: glam::IVec3,
    threshold: f32,
    field: impl Fn(i64) -> f32 + Sync,
) -> (HashMap<i64, f32>, Vec<i64>) {
    let (dy, dz) = (dims.y as i64, dims.z as i64);
    let ijk = |key: i64| glam::IVec3::new((key / dz / dy) as i32, (key / dz % dy) as i32, (key % dz) as i32);
    let key_of = |c: glam::IVec3| (c.x as i64 * dy + c.y as i64) * dz + c.z as i64;
    let cube_marked = |c: glam::IVec3| {
        c.min_element() >= 0 && c.x <= dims.x - 2 && c.y <= dims.y - 2 && c.z <= dims.z - 2 && {
            let k = key_of(c) as usize;
            marked[k / 64] >> (k % 64) & 1 == 1
        }
    };
    // (any adjacent cube marked, any adjacent cube not marked)
    let around = |corner: i64| {
        let c = ijk(corner);
        let (mut any, mut all) = (false, true);
        for n in 0..8usize {
            let m = cube_marked(c - corner_delta(n));
            any |= m;
            all &= m;
        }
        (any, !all)
    };
    let band: Vec<i64> = marked
        .par_iter()
        .enumerate()
        .flat_map_iter(|(w, &bits)| (0..64).filter(move |b| bits >> b & 1 == 1).map(move |b| (w * 64 + b) as i64))
        .collect();
    let mut seeds: Vec<i64> = band
        .par_iter()
        .flat_map_iter(|&c| (0..8).map(move |n| c + corner_offset(n, dims)))
        .filter(|&c| around(c) == (true, true))
        .collect();
    seeds.par_sort_unstable();
    seeds.dedup();
    let mut values: HashMap<i64, f32> = seeds.iter().map(|&c| (c, 0.0)).collect();
    let mut frontier = seeds;
    let steps = [1i64, -1, dz, -dz, dy * dz, -dy * dz];
    while !frontier.is_empty() {
        let mut next: Vec<i64> = frontier
            .par_iter()
            .flat_map_iter(|&c| {
                let at = ijk(c);
                steps.iter().filter_map(move |&s| {
                    let n = c + s;
                    let nc = ijk(n);
                    ((nc - at).abs().element_sum() == 1).then_some(n)
                })
            })
            .filter(|n| !values.contains_key(n) && around(*n).0)
            .collect();
        next.par_sort_unstable();
        next.dedup();
        let evaluated: Vec<f32> = next.par_iter().map(|&c| field(c)).collect();
        frontier = next.iter().zip(&evaluated).filter(|(_, &v)| v < threshold).map(|(&c, _)| c).collect();
        values.extend(next.into_iter().zip(evaluated));
    }
    // The cubes around the inside corners the walk stopped at.
    let mut cubes: Vec<i64> = values
        .iter()
        .filter(|(_, &v)| v >= threshold)
        .flat_map(|(&c, _)| {
            let at = ijk(c);
            (0..8usize).filter_map(move |n| {
                let cube = at - corner_delta(n);
                cube_marked(cube).then(|| key_of(cube))
            })
        })
        .collect();
    cubes.par_sort_unstable();
    cubes.dedup();
    (values, cubes)
}

/// Lattice offset of cube corner `n` from the cube's lower corner.
pub(crate) fn corner_delta(n: usize) -> glam::IVec3 {
    glam::IVec3::new((n & 1) as i32, (n >> 1 & 1) as i32, (n >> 2 & 1) as i32)
}

/// Key offset of cube corner `n` from the cube's lower corner.
fn corner_offset(n: usize, dims: glam::IVec3) -> i64 {
    let (x, y, z) = ((n & 1) as i64, (n >> 1 & 1) as i64, (n >> 2 & 1) as i64);
    (x * dims.y as i64 + y) * dims.z as i64 + z
}

/// Key offset one corner along `axis`.
fn axis_offset(axis: usize, dims: glam::IVec3) -> i64 {
    [dims.y as i64 * dims.z as i64, dims.z as i64, 1][axis]
}

/// Every edge of the mesh used by exactly two triangles, in opposite directions (closed and consistently
/// oriented); returns the number of edges that are not.
pub fn open_or_flipped_edges(m: &TriMesh) -> usize {
    let mut count: HashMap<(u32, u32), i32> = HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *count.entry((a, b)).or_default() += 1;
        }
    }
    count.iter().filter(|(&(a, b), &n)| n != 1 || count.get(&(b, a)) != Some(&1)).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pattern's triangles close up across a cube with random corner values, and a whole random field
    /// gives a closed, consistently oriented mesh (the generated table's contract).
    #[test]
    fn table_gives_closed_oriented_meshes() {
        let t = case_table();
        assert!(t[0].is_empty() && t[255].is_empty());
        assert_eq!(t[1].len(), 1);
        // One inside corner (0): the triangle faces away from it.
        let tri = t[1][0].map(|e| {
            let (a, b, _) = EDGES[e as usize];
            (corner_pos(a) + corner_pos(b)) * 0.5
        });
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        assert!(n.dot(Vec3::ONE) > 0.0, "mask 1's triangle must point away from corner 0");
        assert!(t.iter().all(|c| c.len() <= 6));
    }

    /// The metaball field: one particle's surface at the analytic distance; a random cloud closed and oriented.
    #[test]
    fn metaball_field() {
        let (r, rc) = (0.1f32, 0.3f32);
        let t = metaball_threshold(r, rc);
        let one = IsoGrid::build(&[[0.3, 0.2, 0.1]], rc);
        let p = ExtractParams { metaball: true, ..ExtractParams::new(0.25 * r, t) };
        let m = extract(&one, &one.inv_density(), &p);
        assert!(m.triangles.len() > 100);
        assert_eq!(open_or_flipped_edges(&m), 0);
        for v in &m.vertices {
            let d = (Vec3::from(*v) - Vec3::new(0.3, 0.2, 0.1)).length();
            assert!((d - r).abs() < 0.02 * r, "vertex at {d}, the surface is at {r}");
        }
        let pts: Vec<[f32; 3]> = (0..200)
            .map(|i| [(i * 37 % 101) as f32 * 0.01, (i * 59 % 97) as f32 * 0.005, (i % 13) as f32 * 0.03])
            .collect();
        let g = IsoGrid::build(&pts, 0.09);
        let m = extract(
            &g,
            &g.inv_density(),
            &ExtractParams { metaball: true, ..ExtractParams::new(0.015, metaball_threshold(0.03, 0.09)) },
        );
        assert!(m.triangles.len() > 1000);
        assert_eq!(open_or_flipped_edges(&m), 0);
    }

    /// One particle: a closed sphere whose vertices sit where the field equals the threshold; two far
    /// particles: two components; random clouds: closed and consistently oriented; 1 and 2 threads agree.
    #[test]
    fn single_pair_and_random_particles() {
        let r = 0.1f32;
        let one = IsoGrid::build(&[[0.3, 0.2, 0.1]], 4.0 * r);
        let inv = one.inv_density();
        let m = extract(&one, &inv, &ExtractParams::new(0.25 * r, 0.6));
        assert!(m.triangles.len() > 100);
        assert_eq!(open_or_flipped_edges(&m), 0);
        // The analytic radius where one particle's normalised field W(d/h)/W(0) equals the threshold.
        let (mut lo, mut hi) = (0.0f32, 1.0f32);
        for _ in 0..60 {
            let q = 0.5 * (lo + hi);
            if crate::field::iso::kernel(q) > 0.6 {
                lo = q;
            } else {
                hi = q;
            }
        }
        let want = lo * 4.0 * r;
        let c = Vec3::new(0.3, 0.2, 0.1);
        for (v, n) in m.vertices.iter().zip(&m.normals) {
            let d = (Vec3::from(*v) - c).length();
            assert!((d - want).abs() < 0.02 * r, "vertex at {d}, the surface is at {want}");
            assert!(Vec3::from(*n).dot(Vec3::from(*v) - c) > 0.0, "vertex normal points into the fluid");
        }
        for t in &m.triangles {
            let [a, b, cc] = t.map(|i| Vec3::from(m.vertices[i as usize]));
            assert!((b - a).cross(cc - a).dot(a - c) >= 0.0, "triangle faces into the fluid");
        }
        let two = IsoGrid::build(&[[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]], 4.0 * r);
        let m2 = extract(&two, &two.inv_density(), &ExtractParams::new(0.25 * r, 0.6));
        assert_eq!(open_or_flipped_edges(&m2), 0);
        let ratio = m2.triangles.len() as f32 / m.triangles.len() as f32;
        assert!((ratio - 2.0).abs() < 0.1, "two far particles: {ratio} × one particle's triangles");
        let mut seed = 12345u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as f32 / (1 << 24) as f32
        };
        let pts: Vec<[f32; 3]> = (0..300).map(|_| [rnd() * 0.8, rnd() * 0.5, rnd() * 0.6]).collect();
        let g = IsoGrid::build(&pts, 4.0 * 0.03);
        let inv = g.inv_density();
        let p = ExtractParams { block: 0, ..ExtractParams::new(0.015, 0.6) };
        let a = extract(&g, &inv, &p);
        // Surface following gives exactly the mesh of the dense reference (no closed cavities here).
        let dense = extract(&g, &inv, &ExtractParams { dense: true, ..p });
        assert_eq!(a, dense, "surface following and the dense evaluation differ");
        assert!(a.triangles.len() > 1000);
        assert_eq!(open_or_flipped_edges(&a), 0);
        let b = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| extract(&g, &inv, &p));
        assert_eq!(a, b, "1 thread and the default pool give the same mesh");
        // Blocks: one big block and many small ones (and 1 or 2 threads) give exactly the same mesh up to the order
        // of vertices and triangles (each block numbers its own edges' vertices), in edge-key order the same ...
        let blocks = |block: u32| {
            let (m, keys, _) = extract_blocks_keyed(&g, &inv, &ExtractParams { block, ..p });
            assert_eq!(open_or_flipped_edges(&m), 0, "block {block}");
            m.in_key_order(&keys).expect("an edge has two vertices")
        };
        let big = blocks(256);
        for block in [3, 8, 32] {
            assert_eq!(blocks(block), big, "block {block} differs from one block");
        }
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| blocks(8));
        assert_eq!(one, big, "1 thread differs");
        // ... and one block size gives the same mesh in the same order on any thread count.
        let (m8, _, _) = extract_blocks_keyed(&g, &inv, &ExtractParams { block: 8, ..p });
        let (m8_one, _, _) = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| extract_blocks_keyed(&g, &inv, &ExtractParams { block: 8, ..p }));
        assert_eq!(m8, m8_one, "block 8 on 1 thread and on the pool");
        // ... and the surface of the per-corner reference: the corner values differ only in the order of their
        // sums, so the same triangles and vertices within 1e-5 of the cube; normals (lattice central
        // differences over one cube, Lorensen & Cline's choice, vs the field's gradient over a quarter cube) within
        // 2° at the median and 12° at the 99th percentile (measured 1.2° and ~10°: thin features of a random
        // cloud vary within one cube).
        let mut a_tris = a.triangles.clone();
        a_tris.sort_unstable();
        assert_eq!(big.triangles, a_tris);
        let mut angles = vec![];
        for ((v, w), (n, m)) in big.vertices.iter().zip(&a.vertices).zip(big.normals.iter().zip(&a.normals)) {
            assert!((Vec3::from(*v) - Vec3::from(*w)).length() < 1e-5 * p.cube.max(1.0));
            angles.push(Vec3::from(*n).dot(Vec3::from(*m)).clamp(-1.0, 1.0).acos().to_degrees());
        }
        angles.sort_by(f32::total_cmp);
        let (median, p99) = (angles[angles.len() / 2], angles[angles.len() * 99 / 100]);
        assert!(median < 2.0 && p99 < 12.0, "normal angles: median {median}°, p99 {p99}°");
    }
}
