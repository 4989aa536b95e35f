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

use super::volume::VolumeParams;
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

/// The iso surface's grid: THE neighbour grid (`scene::grid::UniformGrid`, cells at least the kernel support wide,
/// so every particle within `support` of a point lies in the 3×3×3 cells around the point's cell) and the
/// support. The GPU walks its sorted points and cell table.
#[derive(Clone, Debug, Default)]
pub struct IsoGrid {
    /// The sorted points and cell table.
    pub grid: UniformGrid,
    /// Kernel support h (world units).
    pub support: f32,
    /// Each cell's empty distance (ISO_EMPTY_REACH; [`UniformGrid::empty_distance`]), which the casts skip by:
    /// computed at the first cast's sample ([`IsoGrid::empty`]), so the grids of mesh extraction and of the
    /// renderer's upload (whose GPU computes its own) never pay for it.
    empty: std::sync::OnceLock<Vec<u8>>,
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
        IsoGrid::build_reaching(positions, support, support)
    }

    /// As `build`, with cells at least `reach` (≥ `support`) wide: kernels whose centres moved up to
    /// `reach − support` from their particle (anisotropic kernels with smoothed centres) are still found in the
    /// 3×3×3 cells around a point.
    pub fn build_reaching(positions: &[[f32; 3]], support: f32, reach: f32) -> IsoGrid {
        IsoGrid { grid: UniformGrid::new(positions, reach.max(support)), support, empty: Default::default() }
    }

    /// 1 / n_j for every sorted point (the GPU's `iso` pass computes the same on the device). A point's terms are
    /// the points of the 3×3×3 cells around it, in the walk's order ([`UniformGrid::for_each_near`]); those
    /// beyond the support (a hair wider, so that no rounding drops a term) add exactly zero and are skipped —
    /// the same sum, bit for bit. The points of one cell share their candidates: the 27 cells are gathered once
    /// per cell into a dense list (rows of cells in parallel), not walked once per point — less than half the
    /// time on the 59k dam break (docs/mesh-extraction.md).
    pub fn inv_density(&self) -> Vec<f32> {
        use rayon::prelude::*;
        let reach = self.support * 1.0001;
        let reach2 = reach * reach;
        let [nx, ny, nz] = self.dims.map(|d| d as i32);
        let cell = |x: i32, y: i32, z: i32| self.cells[(x + nx * (y + ny * z)) as usize];
        // Rows of cells (y, z) hold consecutive sorted points: split the output along them.
        let mut rows: Vec<(i32, i32, &mut [f32])> = Vec::with_capacity((ny * nz) as usize);
        let mut inv = vec![0f32; self.points.len()];
        let mut rest = inv.as_mut_slice();
        for z in 0..nz {
            for y in 0..ny {
                let n: u32 = (0..nx).map(|x| cell(x, y, z)[1]).sum();
                let (row, tail) = std::mem::take(&mut rest).split_at_mut(n as usize);
                rest = tail;
                if n > 0 {
                    rows.push((y, z, row));
                }
            }
        }
        rows.into_par_iter().for_each_init(
            || (Vec::<Vec3>::new(), Vec::<f32>::new()),
            |(near, kept), (y, z, out)| {
                let mut at = 0;
                for x in 0..nx {
                    let [first, count] = cell(x, y, z);
                    if count == 0 {
                        continue;
                    }
                    // Every point of the cell walks the same 27 cells: walk them once, from its first point.
                    near.clear();
                    let p = self.points[first as usize];
                    self.for_each_near(Vec3::new(p[0], p[1], p[2]), |_, y| near.push(y));
                    kept.resize(near.len(), 0.0);
                    for p in &self.points[first as usize..(first + count) as usize] {
                        let x = Vec3::new(p[0], p[1], p[2]);
                        // The squared distances within reach, in order (branch-free: every one is written, the
                        // count advances for those kept), then the kernel over them.
                        let mut m = 0;
                        for &y in near.iter() {
                            let d2 = x.distance_squared(y);
                            kept[m] = d2;
                            m += (d2 < reach2) as usize;
                        }
                        let s: f32 = kept[..m].iter().fold(0.0, |s, &d2| s + kernel(d2.sqrt() / self.support));
                        out[at] = 1.0 / s;
                        at += 1;
                    }
                }
            },
        );
        inv
    }

    /// φ(x) and the distance to the nearest point (capped at the cell size).
    pub fn field(&self, x: Vec3, inv_n: &[f32]) -> (f32, f32) {
        self.field_with(x, inv_n, None)
    }

    /// φ(x) alone, bit for bit [`IsoGrid::field`]'s, visiting only the cells the support reaches (the
    /// exporters' volumes evaluate it at millions of voxels).
    pub fn field_value(&self, x: Vec3, inv_n: &[f32]) -> f32 {
        let mut s = 0.0;
        self.for_each_in_reach(x, self.support, |i, y| s += kernel(x.distance(y) / self.support) * inv_n[i]);
        s
    }

    /// φ(x) with the isotropic kernel, or with each point's anisotropic kernel `aniso[j]` (same order as the
    /// sorted points): φ(x) = Σ_j det(M_j) W(|M_j (x − c_j)| / h) / n_j. Also the distance to the nearest point
    /// (the particles themselves, not the kernel centres), capped at the cell size.
    pub fn field_with(&self, x: Vec3, inv_n: &[f32], aniso: Option<&[Aniso]>) -> (f32, f32) {
        let mut s = 0.0;
        let mut dmin = self.cell;
        self.for_each_near(x, |i, y| {
            let d = x.distance(y);
            dmin = dmin.min(d);
            match aniso {
                None => s += kernel(d / self.support) * inv_n[i],
                Some(a) => {
                    let v = x - a[i].centre();
                    s += a[i].det() * kernel((a[i].matrix() * v).length() / self.support) * inv_n[i];
                }
            }
        });
        (s, dmin)
    }

    /// A cast's sample (the casts' iso_sum_points with ISO_CELL_EMPTY): [`IsoGrid::field_with`], except where
    /// x's cell has an empty distance E ≥ 2: there the 27 cells are empty (φ = 0) and every point is at least
    /// E − 1 cells away, the distance the march skips by.
    pub fn cast_sample(&self, x: Vec3, inv_n: &[f32], aniso: Option<&[Aniso]>) -> (f32, f32) {
        match self.empty_at(x) {
            Some(e) if e >= 2 => (0.0, (e - 1) as f32 * self.cell),
            _ => self.field_with(x, inv_n, aniso),
        }
    }

    /// Each cell's empty distance (computed at the first call).
    pub fn empty(&self) -> &[u8] {
        self.empty.get_or_init(|| self.grid.empty_distance(crate::shader_constants::ISO_EMPTY_REACH))
    }

    /// The empty distance of x's cell (None outside the grid): every point is at least (E − 1) cells from x.
    pub fn empty_at(&self, x: Vec3) -> Option<u8> {
        let c = ((x - self.origin) / self.cell).floor();
        let d = self.dims;
        if !c.is_finite() || c.min_element() < 0.0 || c.x >= d[0] as f32 || c.y >= d[1] as f32 || c.z >= d[2] as f32 {
            return None;
        }
        let i = c.x as usize + d[0] as usize * (c.y as usize + d[1] as usize * c.z as usize);
        self.empty().get(i).copied()
    }

    /// The weighted neighbourhood of sorted point `i` (Yu & Turk 2013 eq. 4–5, over the particles within
    /// `radius` (≥ the kernel support h), weights w = 1 − (d/radius)³, the point itself included): the weighted
    /// mean's offset from the point, the weighted covariance about that mean (row-major), and the number of
    /// OTHER points within h.
    pub fn covariance(&self, i: usize, radius: f32) -> (Vec3, [[f32; 3]; 3], u32) {
        let p = self.points[i];
        let x = Vec3::new(p[0], p[1], p[2]);
        let h = self.support;
        let r = radius.max(h);
        let k = (r / self.cell - 1e-5).ceil().max(1.0) as i32;
        let (mut sw, mut sv, mut svv, mut n) = (0.0f32, Vec3::ZERO, [[0.0f32; 3]; 3], 0u32);
        self.for_each_within_cells(x, k, |j, y| {
            let v = y - x;
            let d = v.length();
            if d < r {
                let q = d / r;
                let w = 1.0 - q * q * q;
                sw += w;
                sv += w * v;
                for r in 0..3 {
                    for c in 0..3 {
                        svv[r][c] += w * v[r] * v[c];
                    }
                }
                if j != i && d < h {
                    n += 1;
                }
            }
        });
        let mean = sv / sw;
        let mut cov = [[0.0f32; 3]; 3];
        for r in 0..3 {
            for c in 0..3 {
                cov[r][c] = svv[r][c] / sw - mean[r] * mean[c];
            }
        }
        (mean, cov, n)
    }

    /// Every sorted point's anisotropic kernel (the CPU reference of the `anisotropy` pass,
    /// shaders_glsl/anisotropy.comp).
    pub fn anisotropy(&self, p: &AnisoParams) -> Vec<Aniso> {
        use rayon::prelude::*;
        (0..self.points.len())
            .into_par_iter()
            .map(|i| {
                let (mean, cov, n) = self.covariance(i, p.radius);
                let q = self.points[i];
                Aniso::from_covariance(Vec3::new(q[0], q[1], q[2]), mean, cov, n, self.support, p)
            })
            .collect()
    }
}

/// Parameters of the anisotropic kernels (Yu & Turk 2013 §4) in world units: the one form the `anisotropy` pass and
/// the CPU reference read. The `[anisotropy]` section (`surface::grid::params::Params`) holds the same keys in
/// particle radii (`max_shift`) and supports (`radius`); its `world()` is the one conversion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnisoParams {
    /// Largest ratio of the longest to the shortest axis (Yu & Turk's k_r).
    pub ratio: f32,
    /// Points with fewer neighbours within h keep the isotropic kernel (Yu & Turk's N_ε).
    pub min_neighbours: u32,
    /// Blend λ of the kernel centre towards the weighted mean of the neighbours (Yu & Turk eq. 6): 0 keeps the
    /// particle positions.
    pub centre_blend: f32,
    /// Longest move of a kernel centre (world units): the grid's cells are this much wider than h.
    pub max_shift: f32,
    /// Longest axis of a kernel, in units of h (≥ 1): the axes keep the sphere's volume (det M = 1) unless
    /// the longest would exceed this; the grid's cells are at least this many h wide.
    pub stretch: f32,
    /// Radius of the neighbourhood whose covariance and mean shape a kernel (world units, ≥ h; Yu & Turk: 2 h).
    pub radius: f32,
}

/// Jacobi sweeps of `sym_eigen` (a 3×3 symmetric matrix converges to float precision in 4–5).
pub const JACOBI_SWEEPS: usize = crate::shader_constants::JACOBI_SWEEPS as usize;

/// Eigen-decomposition of a symmetric 3×3 matrix by cyclic Jacobi rotations (the same steps as
/// `sym_eigen` in anisotropy.comp): the eigenvalues (unsorted) and the eigenvectors as the COLUMNS of the
/// returned row-major matrix. Written by hand because it runs in the shader too, and the CPU reference must
/// take the same steps.
pub fn sym_eigen(mut a: [[f32; 3]; 3]) -> ([f32; 3], [[f32; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..JACOBI_SWEEPS {
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            let apq = a[p][q];
            if apq.abs() <= 1e-30 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * apq);
            let sign = if theta >= 0.0 { 1.0 } else { -1.0 };
            let t = sign / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← Pᵀ A P and V ← V P, with P the rotation in the (p, q) plane.
            for row in a.iter_mut().chain(v.iter_mut()) {
                let (kp, kq) = (row[p], row[q]);
                row[p] = c * kp - s * kq;
                row[q] = s * kp + c * kq;
            }
            let (rp, rq) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * rp[k] - s * rq[k];
                a[q][k] = s * rp[k] + c * rq[k];
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], v)
}

/// One point's anisotropic kernel as the GPU stores it (three vec4): the centre and det M, then the
/// symmetric matrix M (m00 m01 m02 m11, m12 m22). The kernel is det(M) W(|M (x − c)| / h): an ellipsoid of
/// semi-axes h / (M's eigenvalues), the sphere's volume where the longest stays within `stretch` h, so the
/// kernel's integral is W's.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Aniso(pub [f32; 12]);

impl Aniso {
    /// The isotropic kernel at `x`.
    pub fn isotropic(x: Vec3) -> Aniso {
        Aniso([x.x, x.y, x.z, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0])
    }

    /// The kernel of a point at `x` whose neighbourhood has weighted mean `x + mean`, covariance `cov` and `n`
    /// other points (Yu & Turk 2013 §4: the covariance's eigenvalues σ, the small ones raised to σ_max / k_r;
    /// the axes in proportion to them, the longest h).
    pub fn from_covariance(x: Vec3, mean: Vec3, cov: [[f32; 3]; 3], n: u32, h: f32, p: &AnisoParams) -> Aniso {
        let mut shift = mean * p.centre_blend;
        if shift.length() > p.max_shift {
            shift *= p.max_shift / shift.length();
        }
        let centre = x + shift;
        let (sig, vecs) = sym_eigen(cov);
        let smax = sig[0].max(sig[1]).max(sig[2]);
        if n < p.min_neighbours || smax <= 1e-12 * h * h {
            return Aniso::isotropic(centre);
        }
        // Axes in proportion to the clamped eigenvalues, scaled to the sphere's volume, the longest at most
        // `stretch` (so at least 1: the flattest kernel keeps its long axes at h).
        let s = sig.map(|x| x.max(smax / p.ratio) / smax);
        let g = (s[0] * s[1] * s[2]).cbrt();
        let scale = (1.0 / g).min(p.stretch.max(1.0)) * g;
        let mut m = [[0.0f32; 3]; 3];
        let mut det = 1.0;
        for k in 0..3 {
            let s = s[k] / g * scale;
            det /= s;
            for r in 0..3 {
                for c in 0..3 {
                    m[r][c] += vecs[r][k] * vecs[c][k] / s;
                }
            }
        }
        Aniso([centre.x, centre.y, centre.z, det, m[0][0], m[0][1], m[0][2], m[1][1], m[1][2], m[2][2], 0.0, 0.0])
    }

    /// The kernel's centre.
    pub fn centre(&self) -> Vec3 {
        Vec3::new(self.0[0], self.0[1], self.0[2])
    }

    /// det M.
    pub fn det(&self) -> f32 {
        self.0[3]
    }

    /// M.
    pub fn matrix(&self) -> glam::Mat3 {
        let a = &self.0;
        glam::Mat3::from_cols_array(&[a[4], a[5], a[6], a[5], a[7], a[8], a[6], a[8], a[9]])
    }

    /// The ellipsoid's semi-axes in units of h, longest first, with their directions (unit columns).
    pub fn axes(&self) -> ([f32; 3], [Vec3; 3]) {
        let m = self.matrix();
        let rows = [m.row(0).to_array(), m.row(1).to_array(), m.row(2).to_array()];
        let (ev, vecs) = sym_eigen(rows);
        let mut k = [0usize, 1, 2];
        k.sort_by(|a, b| ev[*a].total_cmp(&ev[*b]));
        let col = |i: usize| Vec3::new(vecs[0][i], vecs[1][i], vecs[2][i]);
        (k.map(|i| 1.0 / ev[i]), k.map(col))
    }
}

/// Parameters of the ray cast and the smoothed field in world units: the one form the `iso` cast, the
/// `iso_volume` lattice and the CPU reference read. The `[iso]` section (`surface::iso::params::Params`) holds the
/// same keys in particle radii; its `world()` is the one conversion (`Settings::iso_params` adds the kernels').
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
    /// Samples of the GPU cast's first dispatch before a ray is queued for the second (scheduling only: the
    /// surface is the same; 0 = one dispatch). The CPU reference ignores it.
    pub first_steps: u32,
    /// Lanes that march one queued ray together in the GPU cast's second dispatch (1 or 8; scheduling only,
    /// see `[iso] rest_lanes`). The CPU reference ignores it.
    pub rest_lanes: u32,
    /// The anisotropic kernels' parameters (`None`: the isotropic kernel).
    pub aniso: Option<AnisoParams>,
    /// The particle radius (coarse-to-fine's units).
    pub radius: f32,
    /// Coarse-to-fine on the GPU (`[iso] fine_px`, 0: off); the CPU reference marches every ray.
    pub fine_px: f32,
    /// The camera's near plane (linear depth): a march that starts inside steps back no nearer.
    pub near: f32,
    /// The field smoothed in 3D where the water is bulk, sampled from a lattice (`[iso] smoothing` > 0,
    /// isotropic kernels; `None`: the exact field, summed over the neighbours at every sample).
    pub volume: Option<VolumeParams>,
}

impl IsoParams {
    /// The farthest a kernel of support `h` (world) reaches from its particle: `h`, or for anisotropic kernels
    /// `stretch` supports from a centre that moved up to `max_shift`. The iso grid's cells are at least this wide.
    pub fn reach(&self, h: f32) -> f32 {
        self.aniso.map_or(h, |a| a.stretch.max(1.0) * h + a.max_shift)
    }
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
/// bracketed by the march (or, when φ ≥ threshold at the start, by up to ISO_BACK_STEPS steps back towards
/// the eye), bisected `refine` times, then linearly interpolated. The march steps by the nearest particle's
/// distance less the bound radius, at least `step` (2 `step` after ISO_SHORT_STEPS samples).
pub fn cast(
    grid: &IsoGrid,
    inv_n: &[f32],
    p: &IsoParams,
    origin: Vec3,
    dir: Vec3,
    d_start: f32,
    d_end: f32,
) -> Option<f32> {
    cast_with(grid, inv_n, None, p, origin, dir, d_start, d_end)
}

/// `cast` with the isotropic kernel or, given `aniso`, each point's anisotropic kernel.
#[allow(clippy::too_many_arguments)]
pub fn cast_with(
    grid: &IsoGrid,
    inv_n: &[f32],
    aniso: Option<&[Aniso]>,
    p: &IsoParams,
    origin: Vec3,
    dir: Vec3,
    d_start: f32,
    d_end: f32,
) -> Option<f32> {
    march(|x| grid.cast_sample(x, inv_n, aniso), p, origin, dir, d_start, d_end)
}

/// The march of `cast` over any field: `field(x)` gives the field and the distance to the nearest point (0
/// where unknown: the march then takes its smallest steps).
pub fn march(
    field: impl Fn(Vec3) -> (f32, f32),
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
        let (phi, dmin) = field(origin + dir * d);
        if phi >= p.threshold {
            let (mut a, mut b, mut fa, mut fb) = (prev, d, phi_prev, phi);
            if k == 0 {
                // Started inside: step back towards the eye (at most ISO_BACK_STEPS steps, not past `near`).
                (a, fa) = (d, phi);
                let mut j = 0;
                while j < crate::shader_constants::ISO_BACK_STEPS && fa >= p.threshold && a > p.near {
                    (b, fb) = (a, fa);
                    a = (a - p.step / len).max(p.near);
                    fa = field(origin + dir * a).0;
                    j += 1;
                }
                if fa >= p.threshold {
                    return Some(a);
                }
            }
            for _ in 0..p.refine {
                let m = 0.5 * (a + b);
                let fm = field(origin + dir * m).0;
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
        let step = if k >= crate::shader_constants::ISO_SHORT_STEPS { 2.0 * p.step } else { p.step };
        d += (dmin - p.bound).max(step) / len;
    }
    None
}

#[cfg(test)]
mod tests;
