//! Block extraction, the default path of [`super::extract`]: the lattice cut into blocks of `block`³ cubes
//! (only those within a particle's support), each scattered, marched and its owned vertices made in parallel,
//! then numbered by a prefix sum over the blocks (see [`extract_blocks`]). In: an [`IsoGrid`] and 1/n_j. Out: an
//! indexed [`TriMesh`] and where the time went ([`ExtractTimes`]).

use super::*;
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
    use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering::Relaxed};
    let t0 = std::time::Instant::now();
    let p = &resolve_block(grid, p);
    let lat = Lattice::of(grid, p.cube.max(1e-6));
    let b = p.block.max(1) as i32;
    let (blocks, reaches, nb) = occupied_blocks_counted(grid, &lat, b);
    // Per-thread scratch (corner values, inside flags, edge → vertex slots of two corner layers), reused from
    // block to block.
    let n = b + 3;
    let cells = (n as usize).pow(3);
    let (scatter_ns, march_ns) = (AtomicU64::new(0), AtomicU64::new(0));
    // The blocks heaviest first (the particles reaching each), each worker taking the next one left: a list
    // schedule whose last blocks are the lightest, so the workers finish together even when a frame has few
    // blocks (the 6,859-particle frame has 3–32 of 64³).
    let mut order: Vec<usize> = (0..blocks.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(reaches[i]));
    let next = AtomicUsize::new(0);
    let workers = rayon::current_num_threads().clamp(1, blocks.len().max(1));
    let mut made: Vec<(usize, BlockMesh)> = (0..workers)
        .into_par_iter()
        .flat_map_iter(|_| {
            let (mut v, mut inside, mut slot, mut rows) = (
                vec![0f32; cells],
                vec![0u8; cells],
                vec![u32::MAX; 2 * 3 * (n * n) as usize],
                vec![0u8; (n * n) as usize],
            );
            let mut mine = vec![];
            while let Some(&i) = order.get(next.fetch_add(1, Relaxed)) {
                let bk = blocks[i];
                let bi = glam::IVec3::new(
                    (bk / nb.z as i64 / nb.y as i64) as i32,
                    (bk / nb.z as i64 % nb.y as i64) as i32,
                    (bk % nb.z as i64) as i32,
                );
                // Corners of the block with the margin: global c0 − 1 … c0 + b + 1.
                let blk = BlockShape { c0: bi * b - 1, n, b, nb };
                let t = std::time::Instant::now();
                scatter_block(grid, inv_n, p, &lat, &blk, &mut v);
                let t_scatter = t.elapsed();
                let out = march_block(&lat, &blk, &v, p.threshold, &mut inside, &mut slot, &mut rows);
                scatter_ns.fetch_add(t_scatter.as_nanos() as u64, Relaxed);
                march_ns.fetch_add((t.elapsed() - t_scatter).as_nanos() as u64, Relaxed);
                mine.push((i, out));
            }
            mine
        })
        .collect();
    // Back in block order (the weld numbers the vertices block by block).
    made.sort_unstable_by_key(|&(i, _)| i);
    let outs: Vec<BlockMesh> = made.into_iter().map(|(_, out)| out).collect();
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
    // A particle's squared distances along x to the block's corner columns: the same for every row it reaches.
    let mut dx2 = vec![0f32; n as usize];
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
                    for i in lx..=ux {
                        let dx = lat.lo.x + (c0.x + i) as f32 * h - x.x;
                        dx2[i as usize] = dx * dx;
                    }
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
                            let line = &mut v[row..row + n as usize];
                            scatter_row(line, &dx2, (i0, i1), d2, inv_support, w_j, p.metaball);
                        }
                    }
                }
            }
        }
    }
}

/// Step 3 of [`extract_blocks`]: march the block's own cubes (local 1 … b, skipping cubes past the lattice and
/// rows of cubes with no crossing); each crossing edge's vertex is made once per block (`slot`: local edge →
/// vertex, for the two corner layers the current layer of cubes touches — an edge starts at its lower corner, so
/// once the march has moved past a corner layer no cube looks its edges up again. Two layers (108 KB at 64³)
/// instead of the block's every corner (3.6 MB per thread, faulted in at the start and refilled every block)
/// stay in cache: docs/mesh-extraction.md). Triangles in memory order; [`weld_blocks`] puts them in cube order.
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
    // Which of the two slot layers hold vertices (cleared before the layer is reused).
    let layer = 3 * (blk.n * blk.n) as usize;
    let mut dirty = [true; 2];
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
        // Cubes of layer k touch corner layers k and k + 1: layer k + 1's slots (last used by corner layer k − 1,
        // which no cube looks at any more) start empty — and both at the block's first layer.
        for z in if k == 1 { 1..=2 } else { k + 1..=k + 1 } {
            let ring = (z & 1) as usize;
            if dirty[ring] {
                slot[ring * layer..(ring + 1) * layer].fill(u32::MAX);
                dirty[ring] = false;
            }
        }
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
                        let ring = (la.z & 1) as usize;
                        let s = &mut slot[ring * layer + ((la.y * blk.n + la.x) * 3) as usize + axis];
                        if *s == u32::MAX {
                            dirty[ring] = true;
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

/// Add one particle's kernel to the corners `chord.0 ..= chord.1` of a row of corner values `line`: `dx2` holds
/// the squared distances along x to the particle (per corner of the row, valid on the chord), `d2` the squared
/// distance across the row, `w` the particle's weight.
///
/// A window of a multiple of four corners holding the chord, the corners outside the chord masked by index (a
/// masked corner gets + 0.0, which leaves its value's bits as they are: every value is ≥ +0), so that the vector
/// loop has no scalar tail; the distances along x are the particle's, computed once for all its rows. (Windows
/// aligned to the row's quads, so that consecutive particles load and store the same quads, were no faster.)
/// The same operations in the same order per corner as before: the same bits. Branch-free (the kernel as
/// selects) so that it vectorises. (Tried before: an AVX2 build chosen at run time, of this function and of the whole block
/// scatter — no faster.)
#[inline(always)]
fn scatter_row(line: &mut [f32], dx2: &[f32], chord: (i32, i32), d2: f32, inv_support: f32, w: f32, metaball: bool) {
    let (i0, i1) = chord;
    // A window of a multiple of four corners inside the row holding the chord (or the whole row, where blocks are
    // smaller than the support).
    let len = (((i1 - i0 + 4) & !3) as usize).min(line.len());
    let s = (i0 as usize).min(line.len() - len);
    for (o, (val, &dd)) in line[s..s + len].iter_mut().zip(&dx2[s..s + len]).enumerate() {
        let i = (s + o) as i32;
        let q = (dd + d2).sqrt() * inv_support;
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
        *val += if i >= i0 && i <= i1 { k * w } else { 0.0 };
    }
}

/// The blocks of `b`³ cubes that some particle's support reaches (cube lower corners in [c − reach, c + reach]),
/// as sorted keys `(x · nb.y + y) · nb.z + z`, and `nb`, the blocks per axis. Shared by the CPU and GPU paths.
pub(crate) fn occupied_blocks(grid: &IsoGrid, lat: &Lattice, b: i32) -> (Vec<i64>, glam::IVec3) {
    let (mut blocks, nb) = block_reaches(grid, lat, b);
    blocks.dedup();
    (blocks, nb)
}

/// How many blocks of `b`³ cubes [`occupied_blocks`] lists, from one bit per block (no list, no sort: what the
/// choice of the block size reads).
pub(crate) fn occupied_count(grid: &IsoGrid, lat: &Lattice, b: i32) -> usize {
    occupied_count_of(&grid.points, lat, grid.support, b)
}

/// [`occupied_count`] of `points` (xyz first) with kernel `support`: what the live mesh surface sizes its
/// buffers by (src/surface/mesh/live.rs, whose mc_blocks.comp marks the same blocks on the device).
pub(crate) fn occupied_count_of<P: AsRef<[f32]> + Sync>(points: &[P], lat: &Lattice, support: f32, b: i32) -> usize {
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    let r = BlockReach::with_support(support, lat, b);
    let blocks = r.nb.x as usize * r.nb.y as usize * r.nb.z as usize;
    let bits: Vec<AtomicU64> = (0..blocks.div_ceil(64)).map(|_| AtomicU64::new(0)).collect();
    points.par_iter().filter(|q| q.as_ref()[..3].iter().all(|x| x.is_finite())).for_each(|q| {
        for k in r.keys(q.as_ref()) {
            bits[k as usize / 64].fetch_or(1 << (k % 64), Relaxed);
        }
    });
    bits.iter().map(|w| w.load(Relaxed).count_ones() as usize).sum()
}

/// The blocks of `b`³ cubes a particle's support reaches: its lattice cell ± the support in cubes, clipped to the
/// lattice's dims − 1 cubes, as block keys (x-major: (x · nb.y + y) · nb.z + z).
struct BlockReach {
    lo: Vec3,
    h: f32,
    reach: i32,
    dims: glam::IVec3,
    b: i32,
    /// Blocks per axis.
    nb: glam::IVec3,
}

impl BlockReach {
    fn new(grid: &IsoGrid, lat: &Lattice, b: i32) -> BlockReach {
        Self::with_support(grid.support, lat, b)
    }

    fn with_support(support: f32, lat: &Lattice, b: i32) -> BlockReach {
        let (h, dims) = (lat.h, lat.dims);
        BlockReach { lo: lat.lo, h, reach: (support / h).ceil() as i32, dims, b, nb: (dims - 1 + b - 1) / b }
    }

    fn keys(&self, q: &[f32]) -> impl Iterator<Item = i64> + '_ {
        let c = ((Vec3::new(q[0], q[1], q[2]) - self.lo) / self.h).floor().as_ivec3();
        let b0 = ((c - self.reach).max(glam::IVec3::ZERO)) / self.b;
        let b1 = ((c + self.reach).min(self.dims - 2)) / self.b;
        let nb = self.nb;
        (b0.x..=b1.x).flat_map(move |x| {
            (b0.y..=b1.y).flat_map(move |y| {
                (b0.z..=b1.z).map(move |z| (x as i64 * nb.y as i64 + y as i64) * nb.z as i64 + z as i64)
            })
        })
    }
}

/// [`occupied_blocks`], and for each block the particles whose support reaches it (what scattering it costs).
pub(crate) fn occupied_blocks_counted(grid: &IsoGrid, lat: &Lattice, b: i32) -> (Vec<i64>, Vec<u32>, glam::IVec3) {
    let (reaches, nb) = block_reaches(grid, lat, b);
    let (mut blocks, mut counts) = (Vec::new(), Vec::new());
    for (i, &k) in reaches.iter().enumerate() {
        if i == 0 || reaches[i - 1] != k {
            blocks.push(k);
            counts.push(0);
        }
        *counts.last_mut().unwrap() += 1;
    }
    (blocks, counts, nb)
}

/// Every (particle, block its support reaches) as the block's key, sorted: [`occupied_blocks`] before the dedup.
fn block_reaches(grid: &IsoGrid, lat: &Lattice, b: i32) -> (Vec<i64>, glam::IVec3) {
    let r = BlockReach::new(grid, lat, b);
    let mut blocks: Vec<i64> = grid.points.par_iter().flat_map_iter(|q| r.keys(q)).collect();
    blocks.par_sort_unstable();
    (blocks, r.nb)
}
