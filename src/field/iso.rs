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
        IsoGrid::build_reaching(positions, support, support)
    }

    /// As `build`, with cells at least `reach` (≥ `support`) wide: kernels whose centres moved up to
    /// `reach − support` from their particle (anisotropic kernels with smoothed centres) are still found in the
    /// 3×3×3 cells around a point.
    pub fn build_reaching(positions: &[[f32; 3]], support: f32, reach: f32) -> IsoGrid {
        IsoGrid { grid: UniformGrid::new(positions, reach.max(support)), support }
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
        self.field_with(x, inv_n, None)
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

/// Parameters of the anisotropic kernels (Yu & Turk 2013 §4); see `passes::anisotropy::Params`.
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
pub const JACOBI_SWEEPS: usize = 6;

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
    /// Samples of the GPU cast's first dispatch before a ray is queued for the second (scheduling only: the
    /// surface is the same; 0 = one dispatch). The CPU reference ignores it.
    pub first_steps: u32,
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
    march(|x| grid.field_with(x, inv_n, aniso), p, origin, dir, d_start, d_end)
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

/// The smoothed field's parameters (`[iso] smoothing`, `bulk`, `voxel`), world units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeParams {
    /// σ of the 3D Gaussian blur of φ (world units; > 0).
    pub sigma: f32,
    /// The blur's weight ramps from 0 to 1 as the interpolated neighbour count c̄ goes from bulk[0] to bulk[1]
    /// (smoothstep; bulk[1] ≤ bulk[0]: the blur everywhere).
    pub bulk: [f32; 2],
    /// The lattice's spacing (world units), unless the box needs more than ISO_VOLUME_MAX_VOXELS voxels.
    pub spacing: f32,
}

impl VolumeParams {
    /// Taps either side of the blur's separable kernel at lattice spacing `spacing`: 4 σ, rounded (as scipy's
    /// `gaussian_filter`, which the prototype tools/quality-volume.py used).
    pub fn taps(&self, spacing: f32) -> u32 {
        (4.0 * self.sigma / spacing + 0.5) as u32
    }

    /// The normalised weights of the blur's taps 0 ..= taps (symmetric).
    pub fn weights(&self, spacing: f32) -> Vec<f32> {
        let s = self.sigma / spacing;
        let k = self.taps(spacing) as i32;
        let g: Vec<f32> = (0..=k).map(|i| (-(i * i) as f32 / (2.0 * s * s)).exp()).collect();
        let total = g[0] + 2.0 * g[1..].iter().sum::<f32>();
        g.iter().map(|w| w / total).collect()
    }
}

/// The lattice the smoothed field is sampled on: voxel (i, j, k) at origin + (i, j, k)·spacing, x fastest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeShape {
    /// World position of voxel (0, 0, 0).
    pub origin: Vec3,
    /// Voxel spacing (world units).
    pub spacing: f32,
    /// Voxels per axis.
    pub dims: [u32; 3],
}

impl VolumeShape {
    /// The lattice over the box `lo`…`hi` that holds every particle, grown by the kernel support and the blur's
    /// reach, at `p.spacing`, or coarser where that would exceed ISO_VOLUME_MAX_VOXELS.
    pub fn around(lo: Vec3, hi: Vec3, support: f32, p: &VolumeParams) -> VolumeShape {
        let max = crate::shader_constants::ISO_VOLUME_MAX_VOXELS as f64;
        let mut spacing = p.spacing.max(1e-6);
        loop {
            let margin = support + (p.taps(spacing) + 1) as f32 * spacing;
            let (a, b) = (lo - Vec3::splat(margin), hi + Vec3::splat(margin));
            let d = ((b - a) / spacing).ceil() + Vec3::ONE;
            let dims = [d.x as u32, d.y as u32, d.z as u32].map(|n| n.max(2));
            let voxels = dims.iter().map(|&n| n as f64).product::<f64>();
            if voxels <= max {
                return VolumeShape { origin: a, spacing, dims };
            }
            spacing *= ((voxels / max).cbrt() * 1.01) as f32;
        }
    }

    /// Voxels in all.
    pub fn voxels(&self) -> usize {
        self.dims.iter().map(|&n| n as usize).product()
    }

    /// Bricks of ISO_VOLUME_BRICK³ voxels in all (`iso_blur` skips the empty ones).
    pub fn bricks(&self) -> usize {
        let b = crate::shader_constants::ISO_VOLUME_BRICK;
        self.dims.iter().map(|&n| n.div_ceil(b) as usize).product()
    }

    /// Index of voxel (x, y, z).
    pub fn index(&self, x: u32, y: u32, z: u32) -> usize {
        x as usize + self.dims[0] as usize * (y as usize + self.dims[1] as usize * z as usize)
    }

    /// Trilinear sample of `field` (one value per voxel) at x; 0 outside the lattice (as iso_field.glsl's
    /// ISO_VOLUME sampler).
    pub fn sample(&self, field: &[f32], x: Vec3) -> f32 {
        let u = (x - self.origin) / self.spacing;
        let i = u.floor();
        let f = u - i;
        let d = self.dims.map(|n| n as f32);
        if i.x < 0.0 || i.y < 0.0 || i.z < 0.0 || i.x >= d[0] - 1.0 || i.y >= d[1] - 1.0 || i.z >= d[2] - 1.0 {
            return 0.0;
        }
        let (x0, y0, z0) = (i.x as u32, i.y as u32, i.z as u32);
        let at = |dx, dy, dz| field[self.index(x0 + dx, y0 + dy, z0 + dz)];
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let row = |dy, dz| lerp(at(0, dy, dz), at(1, dy, dz), f.x);
        let plane = |dz| lerp(row(0, dz), row(1, dz), f.y);
        lerp(plane(0), plane(1), f.z)
    }
}

impl IsoGrid {
    /// Each sorted point's neighbour count c_j = Σ_{k ≠ j} max(0, 1 − |x_j − x_k|² / h²): splashsurf's feature
    /// weight, high in the bulk, low at the surface and in spray (the smoothed field's c̄, and the mesh
    /// smoothing's feature weights in src/field/smooth.rs).
    pub fn neighbour_weights(&self) -> Vec<f32> {
        use rayon::prelude::*;
        let h = self.support;
        self.points
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let x = Vec3::new(p[0], p[1], p[2]);
                let mut c = 0.0;
                self.for_each_near(x, |j, y| {
                    if j != i {
                        c += (1.0 - x.distance_squared(y) / (h * h)).max(0.0);
                    }
                });
                c
            })
            .collect()
    }

    /// The `iso_volume` pass's sums on the lattice `shape`: per voxel v, Σ_j W_j(v) / n_j (φ) and Σ_j W_j(v)
    /// c_j / n_j, each term rounded to ISO_VOLUME_FIX_BITS fixed-point bits (as the shader's integer atomics).
    pub fn volume_sums(&self, inv_n: &[f32], shape: &VolumeShape) -> Vec<[u32; 2]> {
        let c = self.neighbour_weights();
        let fix = (1u32 << crate::shader_constants::ISO_VOLUME_FIX_BITS) as f32;
        let mut acc = vec![[0u32; 2]; shape.voxels()];
        let (h, s) = (self.support, shape.spacing);
        let rv = h / s;
        let dims = shape.dims.map(|n| n as i64);
        for (j, p) in self.points.iter().enumerate() {
            let u = (Vec3::new(p[0], p[1], p[2]) - shape.origin) / s;
            let lo = [u.x, u.y, u.z].map(|a| (a - rv).ceil().max(0.0) as i64);
            let hi = [u.x, u.y, u.z].map(|a| (a + rv).floor() as i64);
            for z in lo[2]..=hi[2].min(dims[2] - 1) {
                for y in lo[1]..=hi[1].min(dims[1] - 1) {
                    for x in lo[0]..=hi[0].min(dims[0] - 1) {
                        let q = ((Vec3::new(x as f32, y as f32, z as f32) - u) * s).length() / h;
                        if q < 1.0 {
                            let w = kernel(q) * inv_n[j];
                            let a = &mut acc[shape.index(x as u32, y as u32, z as u32)];
                            a[0] = a[0].wrapping_add((w * fix + 0.5) as u32);
                            a[1] = a[1].wrapping_add((w * c[j] * fix + 0.5) as u32);
                        }
                    }
                }
            }
        }
        acc
    }
}

/// The smoothed field from the `iso_volume` sums (the `iso_blur` pass's CPU reference): φ blurred by the
/// separable Gaussian (zero outside the lattice), blended into φ by smoothstep of c̄ = Σ W c / n ÷ Σ W / n
/// over `p.bulk`: F = φ + w(c̄) (G_σ ∗ φ − φ).
pub fn smooth_volume(acc: &[[u32; 2]], shape: &VolumeShape, p: &VolumeParams) -> Vec<f32> {
    let fix = (1u32 << crate::shader_constants::ISO_VOLUME_FIX_BITS) as f32;
    let phi: Vec<f32> = acc.iter().map(|a| a[0] as f32 / fix).collect();
    let g = p.weights(shape.spacing);
    let k = g.len() as i64 - 1;
    let strides = [1usize, shape.dims[0] as usize, (shape.dims[0] * shape.dims[1]) as usize];
    let mut cur = phi.clone();
    for axis in 0..3 {
        let mut next = vec![0.0f32; cur.len()];
        for (v, out) in next.iter_mut().enumerate() {
            let c = (v / strides[axis]) as i64 % shape.dims[axis] as i64;
            let mut sum = 0.0;
            for t in -k..=k {
                if (0..shape.dims[axis] as i64).contains(&(c + t)) {
                    sum += g[t.unsigned_abs() as usize] * cur[(v as i64 + t * strides[axis] as i64) as usize];
                }
            }
            *out = sum;
        }
        cur = next;
    }
    cur.iter()
        .zip(&phi)
        .zip(acc)
        .map(|((&blur, &f), a)| {
            let cbar = if a[0] > 0 { a[1] as f32 / a[0] as f32 } else { 0.0 };
            f + bulk_weight(cbar, p.bulk) * (blur - f)
        })
        .collect()
}

/// The blur's weight at interpolated neighbour count c̄: smoothstep over `bulk` (1 when bulk[1] ≤ bulk[0]).
pub fn bulk_weight(cbar: f32, bulk: [f32; 2]) -> f32 {
    if bulk[1] <= bulk[0] {
        return 1.0;
    }
    let t = ((cbar - bulk[0]) / (bulk[1] - bulk[0])).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
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
        let p = IsoParams {
            threshold: 0.6,
            step: 0.25 * r,
            bound: 2.0 * r,
            max_steps: 256,
            refine: 16,
            first_steps: 0,
            aniso: None,
            radius: 0.0,
            fine_px: 0.0,
            near: 0.01,
            volume: None,
        };
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

    fn aniso_params() -> AnisoParams {
        AnisoParams { ratio: 4.0, min_neighbours: 6, centre_blend: 0.0, max_shift: 0.0, stretch: 1.0, radius: 0.04 }
    }

    #[test]
    fn jacobi_decomposes_a_symmetric_matrix() {
        let a = [[4.0, 1.0, -2.0], [1.0, 2.0, 0.5], [-2.0, 0.5, 3.0]];
        let (ev, v) = sym_eigen(a);
        // V diag(ev) Vᵀ = A, and V is orthonormal.
        for r in 0..3 {
            for c in 0..3 {
                let got: f32 = (0..3).map(|k| v[r][k] * ev[k] * v[c][k]).sum();
                assert!((got - a[r][c]).abs() < 1e-5, "({r},{c}): {got} vs {}", a[r][c]);
                let dot: f32 = (0..3).map(|k| v[k][r] * v[k][c]).sum();
                assert!((dot - (r == c) as u8 as f32).abs() < 1e-5);
            }
        }
        // Already diagonal, and repeated eigenvalues.
        let (ev, _) = sym_eigen([[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]]);
        assert_eq!(ev, [2.0, 2.0, 1.0]);
    }

    #[test]
    fn isolated_particle_keeps_a_spherical_kernel_and_a_plane_flattens() {
        let h = 0.04;
        let g = IsoGrid::build(&[[0.3, 0.2, 0.1]], h);
        let a = g.anisotropy(&aniso_params());
        assert_eq!(a[0], Aniso::isotropic(Vec3::new(0.3, 0.2, 0.1)));
        // A tilted square lattice of spacing h/4: every point's shortest axis is the plane's normal, at h / k_r.
        let n = Vec3::new(0.3, 1.0, -0.2).normalize();
        let u = n.any_orthonormal_vector();
        let w = n.cross(u);
        let mut pts = vec![];
        for i in -8..=8 {
            for j in -8..=8 {
                pts.push((u * i as f32 + w * j as f32) * (h / 4.0));
            }
        }
        let g = IsoGrid::build(&pts.iter().map(|p| p.to_array()).collect::<Vec<_>>(), h);
        let a = g.anisotropy(&aniso_params());
        let centre = g.points.iter().position(|p| Vec3::new(p[0], p[1], p[2]).length() < 1e-6).unwrap();
        let (len, dirs) = a[centre].axes();
        assert!((len[0] - 1.0).abs() < 1e-4 && (len[1] - 1.0).abs() < 1e-4, "{len:?}");
        assert!((len[2] - 0.25).abs() < 1e-4, "{len:?}");
        assert!(dirs[2].dot(n).abs() > 0.9999, "short axis {:?} vs normal {n:?}", dirs[2]);
        assert!((a[centre].det() - 4.0).abs() < 1e-3);
        // The field of the flat kernels is flatter: on the plane's normal through the centre, the surface
        // (φ = 0.6) is nearer the plane than with the spheres.
        let inv = g.inv_density();
        let cross = |an: Option<&[Aniso]>| {
            (0..400).map(|k| k as f32 * h / 400.0).find(|t| g.field_with(n * *t, &inv, an).0 < 0.6).unwrap()
        };
        let (iso, ani) = (cross(None), cross(Some(&a)));
        assert!(ani < iso, "anisotropic surface at {ani}, isotropic at {iso}");
    }
}
