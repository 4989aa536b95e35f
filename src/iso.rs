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

use crate::scene::grid::UniformGrid;

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

/// The iso surface's grid: THE neighbour grid (`scene::UniformGrid`, cells at least the kernel support wide,
/// so every particle within `support` of a point lies in the 3×3×3 cells around the point's cell) and the
/// support. The GPU walks its sorted points and cell table.
#[derive(Clone, Debug, Default)]
pub struct IsoGrid {
    /// The sorted points and cell table.
    pub grid: UniformGrid,
    /// Kernel support h (world units).
    pub support: f32,
}

impl std::ops::Deref for IsoGrid {
    type Target = UniformGrid;
    fn deref(&self) -> &UniformGrid {
        &self.grid
    }
}

impl IsoGrid {
    /// Build over `positions` (non-finite positions are dropped) for kernel support `support`.
    pub fn build(positions: &[[f32; 3]], support: f32) -> IsoGrid {
        IsoGrid { grid: UniformGrid::new(positions, support), support }
    }

    /// 1 / n_j for every sorted point (the GPU's `iso` pass computes the same on the device).
    pub fn inv_density(&self) -> Vec<f32> {
        use rayon::prelude::*;
        self.points
            .par_iter()
            .map(|p| {
                let x = Vec3::new(p[0], p[1], p[2]);
                let mut s = 0.0;
                self.for_each_near(x, |_, y| s += kernel(x.distance(y) / self.support));
                1.0 / s
            })
            .collect()
    }

    /// φ(x) and the distance to the nearest point (capped at the cell size).
    pub fn field(&self, x: Vec3, inv_n: &[f32]) -> (f32, f32) {
        let mut s = 0.0;
        let mut dmin = self.cell;
        self.for_each_near(x, |i, y| {
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
    /// Field value of the surface (splashsurf: 0.6).
    pub threshold: f32,
    /// Smallest step along the ray.
    pub step: f32,
    /// Radius of the spheres whose splatted depth starts the march (the iso-surface lies inside them).
    pub bound: f32,
    /// Most march steps per pixel.
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
    use crate::scene::grid::CELLS_PER_PARTICLE;

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
