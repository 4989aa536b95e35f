//! THE neighbour grid: particles counting-sorted into a dense uniform grid of cubic cells (`cells[c]` =
//! first sorted point, count), queried through the 27 cells around a point. One structure serves the CPU
//! statistics (spacing, the number-density radius estimate, isolated-particle neighbour counts) and the iso surface (the
//! GPU walks the same sorted points and cell table, see `crate::field::iso::IsoGrid`). Positions that are not finite
//! are left out (and find no neighbours).

use glam::{IVec3, UVec3, Vec3};

/// Most grid cells, as a multiple of the particle count (cells grow past the requested size for sparse, wide
/// scenes, which keeps memory bounded; queries stay correct since a cell is never smaller than asked for).
pub const CELLS_PER_PARTICLE: u64 = 8;

/// Particles sorted by cell.
#[derive(Clone, Debug, Default)]
pub struct UniformGrid {
    /// Sorted positions (w = 0; the GPU writes 1/n_j into a separate buffer).
    pub points: Vec<[f32; 4]>,
    /// Index into the input of every sorted point.
    pub order: Vec<u32>,
    /// Per cell: (first sorted point, count), x fastest.
    pub cells: Vec<[u32; 2]>,
    /// Corner of cell (0, 0, 0).
    pub origin: Vec3,
    /// Cell side (at least the size asked for).
    pub cell: f32,
    /// Cells along x, y, z.
    pub dims: [u32; 3],
}

impl UniformGrid {
    /// Sort every finite position of `pos` into cells at least `min_cell` wide.
    pub fn new(pos: &[[f32; 3]], min_cell: f32) -> UniformGrid {
        let min_cell = if min_cell.is_finite() && min_cell > 0.0 { min_cell } else { 1.0 };
        let (idx, pts): (Vec<u32>, Vec<Vec3>) =
            pos.iter().enumerate().map(|(i, p)| (i as u32, Vec3::from(*p))).filter(|(_, p)| p.is_finite()).unzip();
        if pts.is_empty() {
            return UniformGrid { cells: vec![[0, 0]], dims: [1, 1, 1], cell: min_cell, ..Default::default() };
        }
        let (lo, hi) = pts.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), p| (a.min(*p), b.max(*p)));
        let (cell, dims) = UniformGrid::shape_for(lo, hi, min_cell, pts.len());
        let last = UVec3::new(dims[0] - 1, dims[1] - 1, dims[2] - 1);
        let index = |p: Vec3| -> usize {
            let c = ((p - lo) / cell).floor().as_uvec3().min(last);
            (c.x + dims[0] * (c.y + dims[1] * c.z)) as usize
        };
        // Counting sort by cell.
        let total = dims.iter().map(|&d| d as usize).product::<usize>();
        let mut cells = vec![[0u32, 0u32]; total];
        let keys: Vec<usize> = pts.iter().map(|p| index(*p)).collect();
        for &k in &keys {
            cells[k][1] += 1;
        }
        let mut start = 0u32;
        for c in cells.iter_mut() {
            c[0] = start;
            start += c[1];
        }
        let mut fill: Vec<u32> = cells.iter().map(|c| c[0]).collect();
        let mut points = vec![[0f32; 4]; pts.len()];
        let mut order = vec![0u32; pts.len()];
        for ((p, &k), &i) in pts.iter().zip(&keys).zip(&idx) {
            points[fill[k] as usize] = [p.x, p.y, p.z, 0.0];
            order[fill[k] as usize] = i;
            fill[k] += 1;
        }
        UniformGrid { points, order, cells, origin: lo, cell, dims }
    }

    /// The cell side and cells per axis of a grid over the box `lo`..`hi` (origin `lo`) for `n` points: cells at
    /// least `min_cell` wide, grown by 1.25× until there are at most max(8 n, 4096) of them. The GPU grid of
    /// the iso surface uses the same shape.
    pub fn shape_for(lo: Vec3, hi: Vec3, min_cell: f32, n: usize) -> (f32, [u32; 3]) {
        let min_cell = if min_cell.is_finite() && min_cell > 0.0 { min_cell } else { 1.0 };
        let ext = (hi - lo).max(Vec3::splat(min_cell * 1e-3));
        let max_cells = (n as u64 * CELLS_PER_PARTICLE).max(4096) as f64;
        let mut cell = min_cell;
        let count = |c: f32| ((ext / c).floor() + Vec3::ONE).as_dvec3();
        while {
            let n = count(cell);
            n.x * n.y * n.z > max_cells
        } {
            cell *= 1.25;
        }
        let n = (ext / cell).floor() + Vec3::ONE;
        (cell, [n.x as u32, n.y as u32, n.z as u32])
    }

    /// Each cell's empty distance (iso_empty.comp, which the iso casts skip by): the Chebyshev distance in cells
    /// to the nearest cell holding a point, at most `reach` + 1.
    pub fn empty_distance(&self, reach: u32) -> Vec<u8> {
        let n = self.dims.map(|d| d as i64);
        let k = reach as i64;
        let far = (reach + 1) as u8;
        let at = |c: [i64; 3]| (c[0] + n[0] * (c[1] + n[1] * c[2])) as usize;
        // Separable, as the shader: along x from the counts, then y, then z, each a min over the offsets o of
        // max(|o|, the distance so far).
        let along = |axis: usize, so_far: &dyn Fn([i64; 3]) -> u8| {
            let mut out = vec![far; self.cells.len()];
            for z in 0..n[2] {
                for y in 0..n[1] {
                    for x in 0..n[0] {
                        let mut e = far;
                        for o in -k..=k {
                            let mut q = [x, y, z];
                            q[axis] += o;
                            if (0..n[axis]).contains(&q[axis]) {
                                e = e.min((o.unsigned_abs() as u8).max(so_far(q)));
                            }
                        }
                        out[at([x, y, z])] = e;
                    }
                }
            }
            out
        };
        let occupied = |q: [i64; 3]| if self.cells[at(q)][1] > 0 { 0 } else { far };
        let a = along(0, &occupied);
        let b = along(1, &|q| a[at(q)]);
        along(2, &|q| b[at(q)])
    }

    /// Visit every sorted point in the 3×3×3 cells around `x` (a superset of the points within one cell
    /// size): `f(sorted index, position)`.
    pub fn for_each_near(&self, x: Vec3, f: impl FnMut(usize, Vec3)) {
        self.for_each_within_cells(x, 1, f)
    }

    /// Visit every sorted point in the (2k+1)³ cells around `x` (a superset of the points within k cell sizes),
    /// in the shaders' order (rows of cells, x fastest): `f(sorted index, position)`.
    pub fn for_each_within_cells(&self, x: Vec3, k: i32, f: impl FnMut(usize, Vec3)) {
        self.walk_cells(x, k, |_| true, f)
    }

    /// [`UniformGrid::for_each_near`] without the cells wholly farther than `r` (≤ the cell size) from `x`:
    /// the same points within `r`, in the same order, about half the cells skipped — for sums whose terms
    /// vanish beyond `r` (a kernel of support `r`), which come out bit for bit the same.
    pub fn for_each_in_reach(&self, x: Vec3, r: f32, f: impl FnMut(usize, Vec3)) {
        let frac = (x - self.origin) / self.cell - ((x - self.origin) / self.cell).floor();
        // Squared distance (in cells) from x to the neighbouring slab −1, 0, +1 along one axis.
        let gap = |d: i32, t: f32| match d {
            -1 => t * t,
            1 => (1.0 - t) * (1.0 - t),
            _ => 0.0,
        };
        let r2 = (r / self.cell) * (r / self.cell);
        self.walk_cells(x, 1, |d| gap(d.x, frac.x) + gap(d.y, frac.y) + gap(d.z, frac.z) <= r2, f)
    }

    /// The cell walk of both: the (2k+1)³ cells around `x`'s cell that `keep(offset)` accepts, rows of cells x
    /// fastest, each cell's sorted points in order.
    fn walk_cells(&self, x: Vec3, k: i32, keep: impl Fn(IVec3) -> bool, mut f: impl FnMut(usize, Vec3)) {
        if !x.is_finite() || self.points.is_empty() {
            return;
        }
        let c = ((x - self.origin) / self.cell).floor().as_ivec3();
        let dims = IVec3::new(self.dims[0] as i32, self.dims[1] as i32, self.dims[2] as i32);
        for dz in -k..=k {
            for dy in -k..=k {
                for dx in -k..=k {
                    let d = IVec3::new(dx, dy, dz);
                    let q = c + d;
                    if q.min_element() < 0 || q.cmpge(dims).any() || !keep(d) {
                        continue;
                    }
                    let [s, n] =
                        self.cells[(q.x as u32 + self.dims[0] * (q.y as u32 + self.dims[1] * q.z as u32)) as usize];
                    for i in s..s + n {
                        let p = self.points[i as usize];
                        f(i as usize, Vec3::new(p[0], p[1], p[2]));
                    }
                }
            }
        }
    }

    /// Calls `f(j, distance)` for every input particle `j` within `h` of `p` (`h` ≤ the cell size), `p` itself
    /// included when it is one of the particles.
    pub fn for_each_within(&self, p: [f32; 3], h: f32, mut f: impl FnMut(usize, f32)) {
        debug_assert!(h <= self.cell * 1.0001, "query radius {h} exceeds the cell size {}", self.cell);
        let q = Vec3::from(p);
        let h2 = h * h;
        self.for_each_near(q, |i, y| {
            let d2 = (y - q).length_squared();
            if d2 <= h2 {
                f(self.order[i] as usize, d2.sqrt());
            }
        });
    }
}

/// Indices of up to `max` particles spread evenly over the set (every k-th).
pub fn sample_indices(n: usize, max: usize) -> impl Iterator<Item = usize> {
    (0..n).step_by((n / max.max(1)).max(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The separable empty distance equals the brute-force Chebyshev distance to the nearest occupied cell,
    /// capped at reach + 1.
    #[test]
    fn empty_distance_is_the_chebyshev_distance_to_an_occupied_cell() {
        let mut seed = 3u32;
        let mut rnd = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let pts: Vec<[f32; 3]> = (0..60).map(|_| [rnd() * 3.0, rnd() * 2.0, rnd() * 2.5]).collect();
        let g = UniformGrid::new(&pts, 0.1);
        let e = g.empty_distance(3);
        let n = g.dims.map(|d| d as i64);
        let occupied: Vec<[i64; 3]> = (0..g.cells.len() as i64)
            .filter(|&i| g.cells[i as usize][1] > 0)
            .map(|i| [i % n[0], (i / n[0]) % n[1], i / (n[0] * n[1])])
            .collect();
        assert!(e.contains(&4) && e.contains(&2) && e.contains(&0));
        for i in 0..g.cells.len() as i64 {
            let c = [i % n[0], (i / n[0]) % n[1], i / (n[0] * n[1])];
            let want =
                occupied.iter().map(|o| (0..3).map(|a| (o[a] - c[a]).abs()).max().unwrap()).min().unwrap().min(4);
            assert_eq!(e[i as usize] as i64, want, "cell {c:?}");
        }
    }

    /// Brute force agrees with the grid, cells never shrink below the request, non-finite points are out.
    #[test]
    fn grid_queries_match_brute_force() {
        let mut pos: Vec<[f32; 3]> = (0..500)
            .map(|i| [(i * 37 % 101) as f32 * 0.01, (i * 59 % 97) as f32 * 0.01, (i % 13) as f32 * 0.02])
            .collect();
        pos.push([f32::NAN, 0.0, 0.0]);
        let h = 0.05;
        let g = UniformGrid::new(&pos, h);
        assert!(g.cell >= h && g.points.len() == 500);
        for (i, p) in pos.iter().enumerate().step_by(7) {
            let mut got = vec![];
            g.for_each_within(*p, h, |j, _| got.push(j));
            got.sort();
            let want: Vec<usize> = (0..500).filter(|&j| (Vec3::from(pos[j]) - Vec3::from(*p)).length() <= h).collect();
            if i < 500 {
                assert_eq!(got, want, "point {i}");
            } else {
                assert!(got.is_empty());
            }
        }
    }
}
