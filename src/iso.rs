//! The SPH colour-field iso-surface that the `iso` pass ray-casts, on the CPU: the uniform grid the GPU
//! walks (built here, at upload), and a reference implementation of the field and of the per-pixel ray cast
//! that the tests hold the shaders to.
//!
//! The field is the one splashsurf reconstructs (Löschner et al.; the shared quality reference is made with
//! it): cubic-spline kernel W of compact support h, per-particle normalisation n_j = Σ_k W(|x_j − x_k|)
//! (the particle's volume m/ρ_j up to the rest mass, which cancels), and
//!     φ(x) = Σ_j W(|x − x_j|) / n_j,
//! ≈ 1 inside the fluid, 0 far from it; the surface is φ = threshold (splashsurf: 0.6, h = 4 r).
//! An isolated particle is a sphere of radius ≈ 1.24 r; close particles merge into one smooth surface, so no
//! sphere bumps appear in the first place (Fraedrich et al. 2010 ray-cast such fields directly too).

use glam::Vec3;

/// Cubic spline kernel, without its normalisation constant (it cancels in φ): q = distance / support.
pub fn kernel(q: f32) -> f32 {
    if q <= 0.5 {
        1.0 - 6.0 * q * q + 6.0 * q * q * q
    } else if q < 1.0 {
        let a = 1.0 - q;
        2.0 * a * a * a
    } else {
        0.0
    }
}

/// Most grid cells, as a multiple of the particle count (the cells grow past h for sparse, wide scenes).
const CELLS_PER_PARTICLE: u64 = 8;

/// A dense uniform grid of cells at least `support` wide over the particles' bounding box; points sorted by
/// cell, `cells[c] = (first point, count)`. Every particle within `support` of a point lies in the 3×3×3
/// cells around the point's cell.
#[derive(Clone, Debug, Default)]
pub struct IsoGrid {
    /// Sorted positions (w = 0; the GPU writes 1/n_j into a separate buffer).
    pub points: Vec<[f32; 4]>,
    pub cells: Vec<[u32; 2]>,
    pub origin: Vec3,
    pub cell: f32,
    pub dims: [u32; 3],
    pub support: f32,
}

impl IsoGrid {
    /// Build over `positions` (non-finite positions are dropped) for kernel support `support`.
    pub fn build(positions: &[[f32; 3]], support: f32) -> IsoGrid {
        let pts: Vec<Vec3> = positions.iter().map(|p| Vec3::from(*p)).filter(|p| p.is_finite()).collect();
        if pts.is_empty() || !(support > 0.0 && support.is_finite()) {
            return IsoGrid {
                cells: vec![[0, 0]],
                dims: [1, 1, 1],
                cell: support.max(1.0),
                support,
                ..Default::default()
            };
        }
        let (lo, hi) = pts.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), p| (a.min(*p), b.max(*p)));
        let ext = (hi - lo).max(Vec3::splat(support * 1e-3));
        let max_cells = (pts.len() as u64 * CELLS_PER_PARTICLE).max(4096) as f64;
        let mut cell = support;
        let count = |c: f32| ((ext / c).floor() + Vec3::ONE).as_dvec3();
        while {
            let n = count(cell);
            n.x * n.y * n.z > max_cells
        } {
            cell *= 1.25;
        }
        let n = (ext / cell).floor() + Vec3::ONE;
        let dims = [n.x as u32, n.y as u32, n.z as u32];
        let index = |p: Vec3| -> usize {
            let c = ((p - lo) / cell).floor().as_uvec3().min(glam::UVec3::new(dims[0] - 1, dims[1] - 1, dims[2] - 1));
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
        for (p, &k) in pts.iter().zip(&keys) {
            points[fill[k] as usize] = [p.x, p.y, p.z, 0.0];
            fill[k] += 1;
        }
        IsoGrid { points, cells, origin: lo, cell, dims, support }
    }

    /// Visit every point in the 3×3×3 cells around `x` (a superset of the points within `support`).
    fn for_near(&self, x: Vec3, mut f: impl FnMut(usize, Vec3)) {
        let c = ((x - self.origin) / self.cell).floor().as_ivec3();
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let q = c + glam::IVec3::new(dx, dy, dz);
                    if q.min_element() < 0
                        || q.x >= self.dims[0] as i32
                        || q.y >= self.dims[1] as i32
                        || q.z >= self.dims[2] as i32
                    {
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

    /// 1 / n_j for every sorted point (the GPU's `iso` pass computes the same on the device).
    pub fn inv_density(&self) -> Vec<f32> {
        use rayon::prelude::*;
        self.points
            .par_iter()
            .map(|p| {
                let x = Vec3::new(p[0], p[1], p[2]);
                let mut s = 0.0;
                self.for_near(x, |_, y| s += kernel(x.distance(y) / self.support));
                1.0 / s
            })
            .collect()
    }

    /// φ(x) and the distance to the nearest point (capped at the cell size).
    pub fn field(&self, x: Vec3, inv_n: &[f32]) -> (f32, f32) {
        let mut s = 0.0;
        let mut dmin = self.cell;
        self.for_near(x, |i, y| {
            let d = x.distance(y);
            dmin = dmin.min(d);
            s += kernel(d / self.support) * inv_n[i];
        });
        (s, dmin)
    }
}

/// Parameters of the ray cast (all lengths in world units), shared with the shader's push constants.
#[derive(Clone, Copy, Debug)]
pub struct IsoParams {
    pub threshold: f32,
    /// Smallest step along the ray.
    pub step: f32,
    /// Radius of the spheres whose splatted depth starts the march (the iso-surface lies inside them).
    pub bound: f32,
    pub max_steps: u32,
    /// Bisection iterations after the first step past the threshold.
    pub refine: u32,
}

/// Depth at which the ray `origin + d·dir` leaves the grid's box grown by the support (as `iso.comp`).
pub fn ray_end(grid: &IsoGrid, origin: Vec3, dir: Vec3) -> f32 {
    let lo = grid.origin - Vec3::splat(grid.support);
    let hi = grid.origin
        + Vec3::new(grid.dims[0] as f32, grid.dims[1] as f32, grid.dims[2] as f32) * grid.cell
        + Vec3::splat(grid.support);
    let safe = Vec3::select(dir.abs().cmplt(Vec3::splat(1e-12)), Vec3::splat(1e-12), dir);
    let (t0, t1) = ((lo - origin) / safe, (hi - origin) / safe);
    t0.max(t1).min_element()
}

/// CPU reference of the march of `iso.comp` along `origin + d·dir` (d: linear depth, dir with unit forward
/// component) from `d_start` (the bound spheres' depth) to `d_end`: the first depth where φ ≥ threshold,
/// bracketed by the march, bisected `refine` times, then linearly interpolated.
pub fn cast(
    grid: &IsoGrid,
    inv_n: &[f32],
    p: &IsoParams,
    origin: Vec3,
    dir: Vec3,
    d_start: f32,
    d_end: f32,
) -> Option<f32> {
    let len = dir.length();
    let (mut d, mut prev, mut phi_prev) = (d_start, d_start, 0.0);
    for k in 0..p.max_steps {
        if d > d_end {
            return None;
        }
        let (phi, dmin) = grid.field(origin + dir * d, inv_n);
        if phi >= p.threshold {
            if k == 0 {
                return Some(d);
            }
            let (mut a, mut b, mut fa, mut fb) = (prev, d, phi_prev, phi);
            for _ in 0..p.refine {
                let m = 0.5 * (a + b);
                let fm = grid.field(origin + dir * m, inv_n).0;
                if fm >= p.threshold {
                    (b, fb) = (m, fm);
                } else {
                    (a, fa) = (m, fm);
                }
            }
            return Some(a + (b - a) * ((p.threshold - fa) / (fb - fa).max(1e-12)).clamp(0.0, 1.0));
        }
        prev = d;
        phi_prev = phi;
        d += (dmin - p.bound).max(p.step) / len;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isolated_particle_is_a_sphere_of_the_threshold_radius() {
        let r = 0.01;
        let g = IsoGrid::build(&[[0.3, 0.2, 0.1]], 4.0 * r);
        let inv = g.inv_density();
        assert!((inv[0] - 1.0).abs() < 1e-6);
        let p = IsoParams { threshold: 0.6, step: 0.25 * r, bound: 2.0 * r, max_steps: 256, refine: 16 };
        // Ray along −z through the centre, from 1 unit in front.
        let d = cast(&g, &inv, &p, Vec3::new(0.3, 0.2, 1.1), Vec3::new(0.0, 0.0, -1.0), 1.0 - 2.0 * r, 2.0).unwrap();
        // Analytic: 1 − 6q² + 6q³ = 0.6 → q = 0.31108…
        let q = (1.0 - d) / (4.0 * r);
        assert!((kernel(q) - 0.6).abs() < 1e-3, "q {q}");
        assert!((q - 0.31108).abs() < 1e-3, "q {q}");
    }

    #[test]
    fn grid_finds_every_neighbour_and_stays_bounded() {
        // A wide sparse scene: two clusters far apart force cells wider than the support.
        let mut pts = vec![];
        for i in 0..50 {
            pts.push([i as f32 * 0.01, 0.0, 0.0]);
            pts.push([1000.0 + i as f32 * 0.01, 0.0, 0.0]);
        }
        let g = IsoGrid::build(&pts, 0.04);
        assert!(g.cells.len() as u64 <= 4096.max(pts.len() as u64 * CELLS_PER_PARTICLE));
        assert!(g.cell >= 0.04);
        let inv = g.inv_density();
        // Brute force n_j.
        for (k, p) in g.points.iter().enumerate() {
            let x = Vec3::new(p[0], p[1], p[2]);
            let n: f32 = g.points.iter().map(|q| kernel(x.distance(Vec3::new(q[0], q[1], q[2])) / 0.04)).sum();
            assert!((1.0 / inv[k] - n).abs() < 1e-4, "{k}: {} vs {n}", 1.0 / inv[k]);
        }
    }
}
