//! The smoothed SPH field (`[iso] smoothing`): the colour field φ of `field::iso` blurred by a 3-D Gaussian of
//! σ where the water is calm (the blur's weight a smoothstep of the interpolated neighbour count c̄ over
//! `bulk`), deposited on a brick lattice of voxels `voxel` r apart — the CPU reference of the `iso_volume` and
//! `iso_density` passes and of the smoothed cast. In: an [`IsoGrid`] and 1/n_j. Out: the lattice's shape and
//! values, the blended field at a point.

use glam::Vec3;

use super::iso::{IsoGrid, IsoParams};
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
    /// σ of the blur for particles that sit on a lattice (world units; [`lattice_order`] 1), blended with
    /// `sigma` by their order: a lattice's surface crosses its layers in terraces whose treads are wider than
    /// `sigma` blurs away. Equal to `sigma`: one blur for every particle.
    pub lattice_sigma: f32,
    /// The particles' spacing (world units; 2 r): the scale [`lattice_order`] reads neighbour distances in.
    pub particle_spacing: f32,
}

/// ∫ (1 − |x|²)³ dV over the unit ball (4π · 16/315): the deposit kernel's normalisation.
pub const DEPOSIT_INTEGRAL: f32 = 0.638_304;

impl VolumeParams {
    /// The deposit kernel's radius R (world units) of a particle of lattice order `order` ([`lattice_order`]):
    /// B stands for G_σ ∗ φ, a sum of kernels each of per-axis variance σ² + 0.075 h² (Gaussian ∗ cubic spline,
    /// taken as one smooth kernel of that variance); the kernel (1 − d²/R²)³ has variance R²/11 and the
    /// quadratic B-spline read adds s²/4, so R² = 11 (σ² + 0.075 h² − s²/4), with σ² blended from `sigma`² to
    /// `lattice_sigma`² by the order. At least one voxel (the field is then that much smoother than asked).
    pub fn deposit_radius(&self, order: f32) -> f32 {
        let (s, o) = (self.spacing, order.clamp(0.0, 1.0));
        let sigma2 = self.sigma * self.sigma + o * (self.lattice_sigma * self.lattice_sigma - self.sigma * self.sigma);
        let v = sigma2 + KERNEL_VARIANCE * self.support * self.support - 0.25 * s * s;
        (11.0 * v).max(0.0).sqrt().max(s)
    }

    /// The deposit radius of the least and of the most ordered particle: R(0), R(1) (world units).
    pub fn deposit_radii(&self) -> [f32; 2] {
        [self.deposit_radius(0.0), self.deposit_radius(1.0)]
    }

    /// Voxels a particle's deposit reaches either side of it, the widest of the two: ⌈max R / s⌉.
    pub fn reach(&self) -> u32 {
        let [r0, r1] = self.deposit_radii();
        (r0.max(r1) / self.spacing).ceil() as u32
    }

    /// A bound of |∇B| (1 / world units): water of density ρ ≤ 1.5 (the colour field's units; 1 at rest) under
    /// the narrowest kernel, whose 1D marginal peaks at 2π / (8 · 0.6383 R) = 1.23 / R, the B-spline read only
    /// lowering it. The cast skips (threshold − B) / this where the water is bulk.
    pub fn gradient_bound(&self) -> f32 {
        let [r0, r1] = self.deposit_radii();
        1.5 * 1.2304 / r0.min(r1)
    }

    /// The deposit's scale for a kernel of radius `r` (world units): a particle's mass I_W h³ (÷ n_j) times
    /// the kernel's normalisation 1 / (0.6383 R³).
    pub fn deposit_scale(&self, r: f32) -> f32 {
        KERNEL_INTEGRAL * self.support.powi(3) / (DEPOSIT_INTEGRAL * r.powi(3))
    }
}

use crate::shader_constants::{
    LATTICE_FEW, LATTICE_GAP_AT, LATTICE_GAP_HALF, LATTICE_MANY, LATTICE_NEAR_FROM, LATTICE_NEAR_TO,
    LATTICE_SHARE_FROM, LATTICE_SHARE_TO,
};

/// GLSL's smoothstep.
fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// One neighbour at distance `t` spacings: (its weight in the gap, its weight among the near ones).
#[inline]
pub fn lattice_terms(t: f32) -> (f32, f32) {
    let gap = (1.0 - (t - LATTICE_GAP_AT).abs() / LATTICE_GAP_HALF).max(0.0);
    (gap, 1.0 - smoothstep(LATTICE_NEAR_FROM, LATTICE_NEAR_TO, t))
}

/// A particle's lattice order from the sums of [`lattice_terms`] pooled over its neighbourhood and its own near
/// count: 1 where none of the near neighbours sits between a lattice's first two shells, 0 where a liquid's
/// share does or where the particle has few near neighbours (spray).
#[inline]
pub fn lattice_order(gap: f32, near: f32, own_near: f32) -> f32 {
    (1.0 - smoothstep(LATTICE_SHARE_FROM, LATTICE_SHARE_TO, gap / near.max(1.0)))
        * smoothstep(LATTICE_FEW, LATTICE_MANY, own_near)
}

/// Voxels per edge of a brick of the smoothed field's sparse lattice.
pub const BRICK: u32 = crate::shader_constants::ISO_VOLUME_BRICK;
/// Voxels the GPU stores per brick: its [`BRICK`]³ and a one-voxel apron copied from its neighbours (10³).
pub const STORED_BRICK_VOXELS: u32 = crate::shader_constants::ISO_STORE.pow(3);
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
        let floor = |x: f32| crate::field::extract::blocks::floor_i(x) as i64;
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

    /// The `iso_volume` deposit, densely: per point j (xyz, 1/n_j; its neighbour count c_j and lattice order
    /// o_j in `c`) and voxel v within R(o_j), w = K(R) (1 − d²/R²)³ / n_j and w c_j, each rounded to
    /// ISO_VOLUME_FIX_BITS fixed-point bits (as the shader's integer atomics). Voxels outside the box are
    /// dropped.
    pub fn deposit(&self, points: &[[f32; 4]], c: &[[f32; 2]], p: &VolumeParams) -> Vec<[u32; 2]> {
        let fix = (1u32 << crate::shader_constants::ISO_VOLUME_FIX_BITS) as f32;
        let mut acc = vec![[0u32; 2]; self.voxels()];
        self.each_deposit(points, c, p, |j, voxel, q, k| {
            let w = q * q * q * (k * points[j][3] * fix);
            let a = &mut acc[voxel];
            a[0] = a[0].wrapping_add((w + 0.5) as u32);
            a[1] = a[1].wrapping_add((w * c[j][0] + 0.5) as u32);
        });
        acc
    }

    /// How many point–voxel deposits [`VolumeShape::deposit`] makes (the `iso_volume` pass's own count of its
    /// work, `crate::work::IsoVolumeWork::deposits`).
    pub fn deposits(&self, points: &[[f32; 4]], c: &[[f32; 2]], p: &VolumeParams) -> u64 {
        let mut n = 0u64;
        self.each_deposit(points, c, p, |_, _, _, _| n += 1);
        n
    }

    /// Every deposit of `points`: (point, voxel index, q = 1 − d²/R² > 0, the point's scale K(R)), as
    /// iso_volume.comp visits them: R² (voxels) blended from R(0)² to R(1)² by the point's order c[j][1].
    fn each_deposit(
        &self,
        points: &[[f32; 4]],
        c: &[[f32; 2]],
        p: &VolumeParams,
        mut f: impl FnMut(usize, usize, f32, f32),
    ) {
        let [r0, r1] = p.deposit_radii().map(|r| r / self.spacing);
        let k0 = p.deposit_scale(p.deposit_radius(0.0));
        let d = self.dims().map(|n| n as i64);
        for (j, pt) in points.iter().enumerate() {
            let (rv, k) = point_radius(r0, r1, c[j][1], k0);
            let u = self.lattice(Vec3::new(pt[0], pt[1], pt[2]));
            let lo = (u - Vec3::splat(rv)).ceil();
            let hi = (u + Vec3::splat(rv)).floor();
            for z in lo.z as i64..=hi.z as i64 {
                for y in lo.y as i64..=hi.y as i64 {
                    for x in lo.x as i64..=hi.x as i64 {
                        let q = 1.0 - (Vec3::new(x as f32, y as f32, z as f32) - u).length_squared() / (rv * rv);
                        if q <= 0.0 || x < 0 || y < 0 || z < 0 || x >= d[0] || y >= d[1] || z >= d[2] {
                            continue;
                        }
                        f(j, self.index(x as u32, y as u32, z as u32), q, k);
                    }
                }
            }
        }
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

/// A point's deposit radius (voxels) and scale, as iso_volume.comp computes them: R² = R0² + o (R1² − R0²)
/// and K = K0 (R0 / R)³, from the least ordered point's R0, R1 (voxels) and K0.
#[inline]
pub fn point_radius(r0: f32, r1: f32, order: f32, k0: f32) -> (f32, f32) {
    let r = (r0 * r0 + order.clamp(0.0, 1.0) * (r1 * r1 - r0 * r0)).sqrt();
    let ratio = r0 / r;
    (r, k0 * (ratio * ratio * ratio))
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

    /// Each sorted point's (c_j, o_j): its neighbour count ([`IsoGrid::neighbour_weights`]) and its lattice order
    /// (distances in `particle_spacing`s), as iso_density.comp's two dispatches compute them: per point the
    /// sums (g_j, m_j) of [`lattice_terms`] over its neighbours within the support, then [`lattice_order`] of
    /// those sums pooled over its neighbourhood (weights 1 − d²/h², itself 1).
    pub fn volume_weights(&self, particle_spacing: f32) -> Vec<[f32; 2]> {
        use rayon::prelude::*;
        let (h, inv_a) = (self.support, 1.0 / particle_spacing);
        let at = |p: &[f32; 4]| Vec3::new(p[0], p[1], p[2]);
        let own: Vec<[f32; 3]> = self
            .points
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let x = at(p);
                let (mut c, mut gap, mut near) = (0.0, 0.0, 0.0);
                self.for_each_near(x, |j, y| {
                    let d2 = x.distance_squared(y);
                    if j != i && d2 < h * h {
                        c += 1.0 - d2 / (h * h);
                        let (g, n) = lattice_terms(d2.sqrt() * inv_a);
                        gap += g;
                        near += n;
                    }
                });
                [c, gap, near]
            })
            .collect();
        self.points
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let x = at(p);
                let (mut gap, mut near) = (0.0, 0.0);
                self.for_each_near(x, |j, y| {
                    let d2 = x.distance_squared(y);
                    if d2 < h * h {
                        let w = 1.0 - d2 / (h * h);
                        gap += w * own[j][1];
                        near += w * own[j][2];
                    }
                });
                [own[i][0], lattice_order(gap, near, own[i][2])]
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
