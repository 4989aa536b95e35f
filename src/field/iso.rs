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

/// Per-axis variance of the normalised cubic spline of support h, ÷ h² (∫ x² W dV ÷ ∫ W dV; numerically
/// 0.0750): the spread the smoothed field's blur adds to `[iso] smoothing`.
pub const KERNEL_VARIANCE: f32 = 0.075;
/// ∫ W(|x|/h) dV ÷ h³ of the unnormalised cubic spline [`kernel`]: π/8.
pub const KERNEL_INTEGRAL: f32 = std::f32::consts::PI / 8.0;

/// The smoothed field's parameters (`[iso] smoothing`, `bulk`, `voxel`), world units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeParams {
    /// σ of the 3D Gaussian blur of φ (world units; > 0).
    pub sigma: f32,
    /// The blur's weight ramps from 0 to 1 as the interpolated neighbour count c̄ goes from bulk[0] to bulk[1]
    /// (smoothstep; bulk[1] ≤ bulk[0]: the blur everywhere).
    pub bulk: [f32; 2],
    /// The lattice's spacing (world units).
    pub spacing: f32,
    /// The SPH kernel's support h (world units).
    pub support: f32,
}

/// ∫ (1 − |x|²)³ dV over the unit ball (4π · 16/315): the deposit kernel's normalisation.
pub const DEPOSIT_INTEGRAL: f32 = 0.638_304;

impl VolumeParams {
    /// The deposit kernel's radius R (world units): B stands for G_σ ∗ φ, a sum of kernels each of per-axis
    /// variance σ² + 0.075 h² (Gaussian ∗ cubic spline, taken as one smooth kernel of that variance); the
    /// kernel (1 − d²/R²)³ has variance R²/11 and the quadratic B-spline read adds s²/4, so R² = 11 (σ² +
    /// 0.075 h² − s²/4). At least one voxel (the field is then that much smoother than asked).
    pub fn deposit_radius(&self) -> f32 {
        let s = self.spacing;
        let v = self.sigma * self.sigma + KERNEL_VARIANCE * self.support * self.support - 0.25 * s * s;
        (11.0 * v).max(0.0).sqrt().max(s)
    }

    /// Voxels a particle's deposit reaches either side of it: ⌈R / s⌉.
    pub fn reach(&self) -> u32 {
        (self.deposit_radius() / self.spacing).ceil() as u32
    }

    /// A bound of |∇B| (1 / world units): water of density ρ ≤ 1.5 (the colour field's units; 1 at rest) under
    /// the kernel, whose 1D marginal peaks at 2π / (8 · 0.6383 R) = 1.23 / R, the B-spline read only lowering
    /// it. The cast skips (threshold − B) / this where the water is bulk.
    pub fn gradient_bound(&self) -> f32 {
        1.5 * 1.2304 / self.deposit_radius()
    }

    /// The deposit's scale: a particle's mass I_W h³ (÷ n_j) times the kernel's normalisation 1 / (0.6383 R³).
    pub fn deposit_scale(&self) -> f32 {
        KERNEL_INTEGRAL * self.support.powi(3) / (DEPOSIT_INTEGRAL * self.deposit_radius().powi(3))
    }
}

/// Voxels per edge of a brick of the smoothed field's sparse lattice.
pub const BRICK: u32 = crate::shader_constants::ISO_VOLUME_BRICK;
/// Voxels the GPU stores per brick: its [`BRICK`]³ and a one-voxel apron copied from its neighbours (10³).
pub const STORED_BRICK_VOXELS: u32 = (BRICK + 2) * (BRICK + 2) * (BRICK + 2);
/// Most bricks per axis of the lattice (iso_volume packs a brick's coordinates in 11 + 11 + 10 bits).
pub const MAX_BRICKS_PER_AXIS: [u32; 3] = [2047, 2047, 1023];

/// For per-axis sets of brick offsets −1, 0, +1 (3 bits each, x | y << 3 | z << 6), the neighbours of a brick
/// they span together: bit (x + 1) + 3 (y + 1) + 9 (z + 1) for each offset (x, y, z) of the product
/// ([`VolumeShape::marked`]).
static NEIGHBOURS: [u32; 512] = {
    let mut t = [0u32; 512];
    let mut i = 0;
    while i < 512 {
        let mut m = 0u32;
        let mut j = 0;
        while j < 27 {
            let (x, y, z) = (j % 3, (j / 3) % 3, j / 9);
            if (i >> x) & 1 != 0 && (i >> (3 + y)) & 1 != 0 && (i >> (6 + z)) & 1 != 0 {
                m |= 1 << j;
            }
            j += 1;
        }
        t[i] = m;
        i += 1;
    }
    t
};

/// The sparse lattice the smoothed field lives on: voxel (i, j, k) at origin + (i, j, k)·spacing, in bricks
/// of [`BRICK`]³ voxels; a brick exists only where a particle's deposit reaches within the blur's taps
/// ([`VolumeShape::marked`]), every voxel elsewhere is 0. The CPU reference holds the whole box densely
/// (x fastest); the GPU a table over the box's bricks and a pool of the allocated ones.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeShape {
    /// World position of voxel (0, 0, 0).
    pub origin: Vec3,
    /// Voxel spacing (world units).
    pub spacing: f32,
    /// Bricks per axis.
    pub bricks: [u32; 3],
    /// Voxels a particle's deposit reaches either side of it (which bricks it needs).
    pub taps: u32,
}

impl VolumeShape {
    /// The lattice for particles inside [lo, hi]: a margin of the deposit's reach + 3 voxels around them (the
    /// B-spline read's reach, rounding). Error: a box too long for the table (more than
    /// [`MAX_BRICKS_PER_AXIS`] bricks on an axis), with what to change.
    pub fn around(lo: Vec3, hi: Vec3, p: &VolumeParams) -> Result<VolumeShape, String> {
        let s = p.spacing.max(1e-9);
        let taps = p.reach();
        let margin = (taps + 3) as f32 * s;
        let origin = lo - Vec3::splat(margin);
        let n = ((hi - lo) / s).ceil() + Vec3::splat(2.0 * (taps + 3) as f32 + 2.0);
        let bricks = [n.x, n.y, n.z].map(|v| (v / BRICK as f32).ceil().max(1.0));
        for (axis, (&b, &max)) in bricks.iter().zip(&MAX_BRICKS_PER_AXIS).enumerate() {
            if b > max as f32 {
                return Err(format!(
                    "the smoothed iso field's lattice would need {b} bricks of {BRICK} voxels along {}, more than \
                     {max}: the water spans {:.3} with voxels of {s:.4}; set [iso] voxel larger or smoothing = 0 \
                     (--preset quality: the exact field, no lattice)",
                    ["x", "y", "z"][axis],
                    (hi - lo)[axis]
                ));
            }
        }
        Ok(VolumeShape { origin, spacing: s, bricks: bricks.map(|b| b as u32), taps })
    }

    /// Voxels per axis of the box.
    pub fn dims(&self) -> [u32; 3] {
        self.bricks.map(|b| b * BRICK)
    }

    /// Voxels of the whole box (the dense CPU reference's length).
    pub fn voxels(&self) -> usize {
        self.dims().iter().map(|&n| n as usize).product()
    }

    /// Entries of the brick table.
    pub fn table_len(&self) -> usize {
        self.bricks.iter().map(|&n| n as usize).product()
    }

    /// Index of voxel (x, y, z) in the dense box.
    pub fn index(&self, x: u32, y: u32, z: u32) -> usize {
        let d = self.dims();
        x as usize + d[0] as usize * (y as usize + d[1] as usize * z as usize)
    }

    /// Lattice coordinates of x, clamped 2 voxels outside the box (as iso_volume.comp: a stray point far from
    /// the water marks and deposits nothing).
    #[inline]
    pub fn lattice(&self, x: Vec3) -> Vec3 {
        let d = self.dims();
        ((x - self.origin) / self.spacing)
            .clamp(Vec3::splat(-2.0), Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32) + 2.0)
    }

    /// The bricks the points need (iso_volume's ISO_VOLUME_MARK): the voxels within the deposit's reach + 1 of
    /// the point's voxel (the cast's 3³ read around a voxel next to a nonzero one finds its brick). One flag
    /// per table entry.
    pub fn marked<T: Sync>(&self, points: &[T], pos: impl Fn(&T) -> Vec3 + Sync) -> Vec<bool> {
        use rayon::prelude::*;
        let n = self.table_len();
        let b = self.bricks.map(|n| n as i64);
        let t = self.taps as i64 + 1;
        // Floor division by the brick side as a shift (BRICK is a power of two).
        let shift = BRICK.trailing_zeros();
        const { assert!(BRICK.is_power_of_two()) };
        let at = |x: i64, y: i64, z: i64| (x + b[0] * (y + b[1] * z)) as usize;
        // `floor` without the libm call (exact: the lattice coordinates are clamped far below 2³¹).
        let floor = |x: f32| crate::field::extract::floor_i(x) as i64;
        // Every sequence frame and every new particle set counts its bricks here (the host's part of a frame),
        // so each point does one write: its own brick's mask of the 3³ neighbours its box reaches (a point's
        // box spans at most its brick and one either side while t < BRICK), OR-ed over chunks of points in
        // parallel, expanded once per brick after. A point whose box spans more, or whose brick is outside the
        // table, has its box listed and marked directly.
        type Boxes = Vec<([i64; 3], [i64; 3])>;
        // Each split of the points (about one per thread) ORs its chunks into one mask, not one per chunk.
        let chunk = |(mut reach, mut boxes): (Vec<u32>, Boxes), pts: &[T]| -> (Vec<u32>, Boxes) {
            for q in pts {
                let u = self.lattice(pos(q));
                let g = [floor(u.x), floor(u.y), floor(u.z)];
                let lo: [i64; 3] = std::array::from_fn(|a| ((g[a] - t) >> shift).max(0));
                let hi: [i64; 3] = std::array::from_fn(|a| ((g[a] + 1 + t) >> shift).min(b[a] - 1));
                let home: [i64; 3] = std::array::from_fn(|a| g[a] >> shift);
                let near = (0..3).all(|a| (0..b[a]).contains(&home[a]) && lo[a] >= home[a] - 1 && hi[a] <= home[a] + 1);
                if near {
                    // Per axis the offsets −1, 0, +1 it reaches (bits 0–2); their product over the 27 neighbours.
                    let bits: [u32; 3] = std::array::from_fn(|a| {
                        let (l, h) = (lo[a] - home[a] + 1, hi[a] - home[a] + 1);
                        ((1u32 << (h + 1)) - 1) & !((1u32 << l) - 1)
                    });
                    reach[at(home[0], home[1], home[2])] |=
                        NEIGHBOURS[(bits[0] | bits[1] << 3 | bits[2] << 6) as usize];
                } else {
                    boxes.push((lo, hi));
                }
            }
            (reach, boxes)
        };
        let (reach, boxes) = points.par_chunks(8192).fold(|| (vec![0u32; n], vec![]), chunk).reduce(
            || (vec![0u32; n], vec![]),
            |(mut r, mut b), (r2, b2)| {
                r.iter_mut().zip(&r2).for_each(|(x, y)| *x |= y);
                b.extend(b2);
                (r, b)
            },
        );
        let mut m = vec![false; n];
        for (lo, hi) in boxes {
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        m[at(x, y, z)] = true;
                    }
                }
            }
        }
        for (k, &r) in reach.iter().enumerate().filter(|(_, &r)| r != 0) {
            let k = k as i64;
            let home = [k % b[0], (k / b[0]) % b[1], k / (b[0] * b[1])];
            let mut bits = r;
            while bits != 0 {
                let j = bits.trailing_zeros() as i64;
                bits &= bits - 1;
                let (x, y, z) = (home[0] + j % 3 - 1, home[1] + (j / 3) % 3 - 1, home[2] + j / 9 - 1);
                if (0..b[0]).contains(&x) && (0..b[1]).contains(&y) && (0..b[2]).contains(&z) {
                    m[at(x, y, z)] = true;
                }
            }
        }
        m
    }

    /// How far (voxels) every point lies, along some axis, beyond the box of positions whose nearest voxel is
    /// in a brick [`VolumeShape::marked`] leaves unmarked: a point at voxel g marks the bricks of voxels g −
    /// t … g + 1 + t (t = taps + 1), and such a position is within half a voxel of its brick's voxels, so more
    /// than t + ½.
    pub fn empty_reach(&self) -> f32 {
        self.taps as f32 + 1.5
    }

    /// Where the brick of x's nearest voxel is inside the table and not `marked`: a lower bound of the distance
    /// from x to every point (world units), its depth inside that box plus [`VolumeShape::empty_reach`]
    /// voxels (iso_field.glsl's `iso_volume_at`, which the cast then skips by).
    pub fn gap(&self, marked: &[bool], x: Vec3) -> Option<f32> {
        let u = (x - self.origin) / self.spacing;
        let c = (u + Vec3::splat(0.5)).floor();
        let b = [c.x, c.y, c.z].map(|v| (v as i64).div_euclid(BRICK as i64));
        if (0..3).any(|a| b[a] < 0 || b[a] >= self.bricks[a] as i64) {
            return None;
        }
        let [bx, by, bz] = b.map(|v| v as u32);
        if marked[(bx + self.bricks[0] * (by + self.bricks[1] * bz)) as usize] {
            return None;
        }
        let lo = Vec3::new(bx as f32, by as f32, bz as f32) * BRICK as f32 - Vec3::splat(0.5);
        let depth_in = (u - lo).min(lo + Vec3::splat(BRICK as f32) - u);
        Some((depth_in.min_element() + self.empty_reach()) * self.spacing)
    }

    /// The `iso_volume` deposit, densely: per point j (xyz, 1/n_j) and voxel v within R, w = K (1 − d²/R²)³
    /// / n_j and w c_j, each rounded to ISO_VOLUME_FIX_BITS fixed-point bits (as the shader's integer atomics).
    /// Voxels outside the box are dropped.
    pub fn deposit(&self, points: &[[f32; 4]], c: &[f32], p: &VolumeParams) -> Vec<[u32; 2]> {
        let fix = (1u32 << crate::shader_constants::ISO_VOLUME_FIX_BITS) as f32;
        let k = p.deposit_scale();
        let rv = p.deposit_radius() / self.spacing;
        let d = self.dims().map(|n| n as i64);
        let mut acc = vec![[0u32; 2]; self.voxels()];
        for (pt, &cj) in points.iter().zip(c) {
            let u = self.lattice(Vec3::new(pt[0], pt[1], pt[2]));
            let lo = (u - Vec3::splat(rv)).ceil();
            let hi = (u + Vec3::splat(rv)).floor();
            let m = k * pt[3] * fix;
            for z in lo.z as i64..=hi.z as i64 {
                for y in lo.y as i64..=hi.y as i64 {
                    for x in lo.x as i64..=hi.x as i64 {
                        let q = 1.0 - (Vec3::new(x as f32, y as f32, z as f32) - u).length_squared() / (rv * rv);
                        if q <= 0.0 || x < 0 || y < 0 || z < 0 || x >= d[0] || y >= d[1] || z >= d[2] {
                            continue;
                        }
                        let w = q * q * q * m;
                        let a = &mut acc[self.index(x as u32, y as u32, z as u32)];
                        a[0] = a[0].wrapping_add((w + 0.5) as u32);
                        a[1] = a[1].wrapping_add((w * cj + 0.5) as u32);
                    }
                }
            }
        }
        acc
    }

    /// The deposit's sums as the cast reads them: (B, B c̄) per voxel.
    pub fn field(acc: &[[u32; 2]]) -> Vec<[f32; 2]> {
        let fix = (1u32 << crate::shader_constants::ISO_VOLUME_FIX_BITS) as f32;
        acc.iter().map(|a| [a[0] as f32 / fix, a[1] as f32 / fix]).collect()
    }

    /// The quadratic B-spline read of `field` (dense, two values per voxel) at x, as iso_field.glsl's
    /// iso_volume_at: 0 outside the box.
    pub fn sample(&self, field: &[[f32; 2]], x: Vec3) -> [f32; 2] {
        let u = (x - self.origin) / self.spacing;
        let c = (u + Vec3::splat(0.5)).floor();
        let t = u - c;
        let d = self.dims().map(|n| n as i64);
        let w = |t: f32| [0.5 * (0.5 - t) * (0.5 - t), 0.75 - t * t, 0.5 * (0.5 + t) * (0.5 + t)];
        let (wx, wy, wz) = (w(t.x), w(t.y), w(t.z));
        let mut s = [0.0f32; 2];
        for z in 0..3 {
            for y in 0..3 {
                for x in 0..3 {
                    let g = [c.x as i64 - 1 + x, c.y as i64 - 1 + y, c.z as i64 - 1 + z];
                    if (0..3).any(|a| g[a] < 0 || g[a] >= d[a]) {
                        continue;
                    }
                    let v = field[self.index(g[0] as u32, g[1] as u32, g[2] as u32)];
                    let ww = wx[x as usize] * (wy[y as usize] * wz[z as usize]);
                    s = [s[0] + ww * v[0], s[1] + ww * v[1]];
                }
            }
        }
        s
    }
}

/// The smoothed iso field at x (the volume cast's sample, iso_field.glsl): F = φ + w(c̄) (B − φ) with B and
/// B c̄ read from the lattice (`field`, dense; `marked`: the bricks [`VolumeShape::marked`] allocates), φ the
/// exact field (summed only where w < 1); and how far the march may skip, as the distance `march` takes less
/// `c.bound`: [`VolumeShape::gap`] in an unallocated brick (F = 0 there), [`IsoGrid::cast_sample`]'s distance
/// where w < 1, else `c.bound` + (threshold − B) / [`VolumeParams::gradient_bound`].
pub fn smoothed_field(
    grid: &IsoGrid,
    inv_n: &[f32],
    shape: &VolumeShape,
    (field, marked): (&[[f32; 2]], &[bool]),
    c: &IsoParams,
    x: Vec3,
) -> (f32, f32) {
    let p = c.volume.expect("the smoothed field's parameters");
    if let Some(gap) = shape.gap(marked, x) {
        return (0.0, gap);
    }
    let [b, bc] = shape.sample(field, x);
    let cbar = if b > 0.0 { bc / b } else { 0.0 };
    let w = bulk_weight(cbar, p.bulk);
    if w >= 1.0 {
        return (b, c.bound + (c.threshold - b).max(0.0) / p.gradient_bound());
    }
    let (phi, d) = grid.cast_sample(x, inv_n, None);
    (phi + w * (b - phi), d)
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

    /// `marked` (one neighbour mask per point's brick, chunks in parallel) marks exactly the bricks of every
    /// point's box, as marking each box brick by brick does: points inside the box, on brick faces, and
    /// outside it on every side (clamped into the lattice's margin).
    #[test]
    fn marked_bricks_are_each_points_box() {
        let r = 0.01;
        let p = VolumeParams { sigma: 1.1 * r, bulk: [4.0, 9.0], spacing: 2.0 * r, support: 4.0 * r };
        let shape = VolumeShape::around(Vec3::ZERO, Vec3::new(0.8, 0.5, 0.6), &p).unwrap();
        let mut seed = 11u32;
        let mut rnd = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut pts: Vec<Vec3> = (0..60).map(|_| Vec3::new(rnd(), rnd(), rnd()) * 1.6 - 0.4).collect();
        // A dense cluster (many points to a brick: the masks OR-ed across chunks).
        pts.extend((0..30_000).map(|_| Vec3::new(0.2, 0.1, 0.3) + Vec3::new(rnd(), rnd(), rnd()) * 0.15));
        // Points on brick faces (voxel coordinates multiples of BRICK) and far outside.
        for k in 0..20 {
            let v = Vec3::splat((k % 9 * BRICK) as f32) * shape.spacing + shape.origin;
            pts.push(v + Vec3::new(0.0, rnd() * 0.3, rnd() * 0.3));
        }
        pts.extend([Vec3::splat(-1e6), Vec3::splat(1e6), Vec3::new(-1e6, 0.2, 1e6)]);
        let b = shape.bricks.map(|n| n as i64);
        let t = shape.taps as i64 + 1;
        let mut want = vec![false; shape.table_len()];
        for &x in &pts {
            let u = shape.lattice(x).floor();
            let g = [u.x as i64, u.y as i64, u.z as i64];
            let lo: [i64; 3] = std::array::from_fn(|a| (g[a] - t).div_euclid(BRICK as i64).max(0));
            let hi: [i64; 3] = std::array::from_fn(|a| (g[a] + 1 + t).div_euclid(BRICK as i64).min(b[a] - 1));
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        want[(x + b[0] * (y + b[1] * z)) as usize] = true;
                    }
                }
            }
        }
        let got = shape.marked(&pts, |&x| x);
        assert!(want.iter().any(|&m| m) && want.iter().any(|&m| !m), "a partly marked table");
        assert_eq!(got, want);
    }

    /// The cast's skip through an unallocated brick ([`VolumeShape::gap`]) never passes a point: wherever it
    /// gives a distance, every point is at least that far (brute force over a sparse scene of clusters and
    /// strays, at positions all over the lattice's box), and the box holds such bricks.
    #[test]
    fn empty_brick_gap_is_a_lower_bound_of_the_nearest_point() {
        let r = 0.01;
        let p = VolumeParams { sigma: 1.1 * r, bulk: [4.0, 9.0], spacing: 2.0 * r, support: 4.0 * r };
        let mut seed = 7u32;
        let mut rnd = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut pts = vec![];
        for c in [Vec3::ZERO, Vec3::new(1.1, 0.3, 0.2), Vec3::new(0.2, 0.9, 1.0)] {
            for _ in 0..200 {
                pts.push(c + Vec3::new(rnd(), rnd(), rnd()) * 0.1);
            }
        }
        for _ in 0..20 {
            pts.push(Vec3::new(rnd(), rnd(), rnd()) * 1.2);
        }
        let (lo, hi) =
            pts.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), &q| (a.min(q), b.max(q)));
        let shape = VolumeShape::around(lo, hi, &p).unwrap();
        let marked = shape.marked(&pts, |&q| q);
        assert!(marked.iter().any(|&m| !m), "the scene leaves bricks unallocated");
        let size = Vec3::new(shape.dims()[0] as f32, shape.dims()[1] as f32, shape.dims()[2] as f32) * shape.spacing;
        let mut gaps = 0;
        for _ in 0..20_000 {
            let x = shape.origin + Vec3::new(rnd(), rnd(), rnd()) * size;
            if let Some(g) = shape.gap(&marked, x) {
                let nearest = pts.iter().map(|q| q.distance(x)).fold(f32::MAX, f32::min);
                assert!(g <= nearest, "gap {g} at {x}, nearest point {nearest}");
                assert!(g >= shape.empty_reach() * shape.spacing);
                gaps += 1;
            }
        }
        assert!(gaps > 1000, "{gaps} samples in unallocated bricks");
    }
}
