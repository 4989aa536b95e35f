//! The model's kernel (SPlisHSPlasH's cubic spline), a frame of fluid with its neighbour lists, densities and
//! normals, and its potentials — trapped air, wave crest, kinetic energy (Ihmsen et al. 2012 eq. 1–7) — and the
//! automatic calibration of their limits (Bender et al. 2019). In: positions, velocities, ids. Out: potentials,
//! limits.

use glam::Vec3;
use rayon::prelude::*;

use super::params::Limits;
use super::GRAVITY;
use crate::scene::grid::UniformGrid;

/// The cubic spline kernel of SPlisHSPlasH (support h): W(r) and dW/dr.
#[derive(Clone, Copy, Debug)]
pub struct CubicSpline {
    h: f32,
    k: f32,
    l: f32,
}

impl CubicSpline {
    /// The kernel of support `h`.
    pub fn new(h: f32) -> CubicSpline {
        let h3 = h * h * h;
        CubicSpline { h, k: 8.0 / (std::f32::consts::PI * h3), l: 48.0 / (std::f32::consts::PI * h3) }
    }

    /// The coefficients 8 / (π h³) of W and 48 / (π h³) of its derivative (the GPU stages' push constants).
    pub fn coefficients(&self) -> (f32, f32) {
        (self.k, self.l)
    }

    /// W at distance `r`.
    pub fn w(&self, r: f32) -> f32 {
        let q = r / self.h;
        if q <= 0.5 {
            self.k * (6.0 * q * q * q - 6.0 * q * q + 1.0)
        } else if q <= 1.0 {
            self.k * 2.0 * (1.0 - q).powi(3)
        } else {
            0.0
        }
    }

    /// dW/dr at distance `r` (≤ 0).
    pub fn dw(&self, r: f32) -> f32 {
        let q = r / self.h;
        if q <= 0.5 {
            self.l * q * (3.0 * q - 2.0) / self.h
        } else if q <= 1.0 {
            -self.l * (1.0 - q) * (1.0 - q) / self.h
        } else {
            0.0
        }
    }
}

/// The model's particle mass for radius `r`: FoamGenerator's 0.8 (2r)³ ρ0 with ρ0 = 1000.
pub fn model_mass(r: f32) -> f32 {
    0.8 * (2.0 * r).powi(3) * 1000.0
}

/// The kinetic energy of a particle of `mass` moving at √(g h): the least kinetic energy that spawns.
pub fn kinetic_floor(mass: f32, h: f32) -> f32 {
    0.5 * mass * GRAVITY.length() * h
}

/// A frame of fluid with what the model needs of it: the neighbour grid, densities, surface normals and the
/// neighbour lists within the support h = 4 r.
pub struct Fluid<'a> {
    /// Positions.
    pub positions: &'a [[f32; 3]],
    /// Velocities (zero when the frame has none).
    pub velocities: std::borrow::Cow<'a, [[f32; 3]]>,
    /// Ids (seed the spawns).
    pub ids: Vec<u32>,
    /// The kernel support.
    pub h: f32,
    /// The particle radius.
    pub radius: f32,
    /// Mass of a particle (FoamGenerator's 0.8 (2r)³ ρ0, ρ0 = 1000).
    pub mass: f32,
    kernel: CubicSpline,
    grid: UniformGrid,
    /// Neighbours of each particle (itself excluded), in the grid's order.
    neighbours: Vec<Vec<u32>>,
    densities: Vec<f32>,
    normals: Vec<Vec3>,
    /// The lowest particle's height: diffuse particles falling below it by h die.
    pub(super) floor: f32,
}

impl<'a> Fluid<'a> {
    /// Prepare a frame: `velocities` (none: at rest); `ids` (else the index) seed the spawns; `radius`: the
    /// particle radius.
    pub fn new(
        positions: &'a [[f32; 3]],
        velocities: Option<&'a [[f32; 3]]>,
        ids: Option<&[i64]>,
        radius: f32,
    ) -> Fluid<'a> {
        let n = positions.len();
        let velocities = velocities.map_or_else(|| vec![[0.0; 3]; n].into(), std::borrow::Cow::Borrowed);
        let h = 4.0 * radius;
        let kernel = CubicSpline::new(h);
        let mass = model_mass(radius);
        let grid = UniformGrid::new(positions, h);
        let neighbours: Vec<Vec<u32>> = (0..n)
            .into_par_iter()
            .map(|i| {
                let mut v = Vec::new();
                grid.for_each_within(positions[i], h, |j, _| {
                    if j != i {
                        v.push(j as u32)
                    }
                });
                v
            })
            .collect();
        let at = |i: usize| Vec3::from(positions[i]);
        let densities: Vec<f32> = (0..n)
            .into_par_iter()
            .map(|i| {
                mass * (kernel.w(0.0)
                    + neighbours[i].iter().map(|&j| kernel.w(at(i).distance(at(j as usize)))).sum::<f32>())
            })
            .collect();
        // Colour-field normals of the particles near the surface (few neighbours), pointing out of the water.
        let normals: Vec<Vec3> = (0..n)
            .into_par_iter()
            .map(|i| {
                if neighbours[i].len() > 20 {
                    return Vec3::ZERO;
                }
                let mut g = Vec3::ZERO;
                for &j in &neighbours[i] {
                    let d = at(i) - at(j as usize);
                    let r = d.length();
                    if r > 1e-9 {
                        g += mass / densities[j as usize] * -kernel.dw(r) * d / r;
                    }
                }
                g.normalize_or_zero()
            })
            .collect();
        let floor = positions.iter().map(|p| p[1]).filter(|y| y.is_finite()).fold(f32::INFINITY, f32::min);
        let ids = (0..n).map(|i| ids.map_or(i as u32, |ids| ids[i] as u32)).collect();
        Fluid { positions, velocities, ids, h, radius, mass, kernel, grid, neighbours, densities, normals, floor }
    }

    /// The kinetic energy of a particle moving at √(g h) (the speed of a fall through the kernel support): the
    /// least kinetic energy that spawns diffuse particles.
    pub fn kinetic_floor(&self) -> f32 {
        kinetic_floor(self.mass, self.h)
    }

    /// Particles in the frame.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the frame has no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Fluid neighbours of particle `i`.
    pub fn neighbour_count(&self, i: usize) -> usize {
        self.neighbours[i].len()
    }

    /// The surface normal of particle `i` (zero inside the water).
    pub fn normal(&self, i: usize) -> Vec3 {
        self.normals[i]
    }

    /// Eq. 2, 4–7 and the kinetic energy of particle `i`, unclamped: (trapped air, wave crest, kinetic).
    pub fn potentials(&self, i: usize) -> [f32; 3] {
        let kernel = self.kernel;
        let (xi, vi, ni) = (Vec3::from(self.positions[i]), Vec3::from(self.velocities[i]), self.normals[i]);
        let (mut ta, mut wc) = (0.0f32, 0.0f32);
        for &j in &self.neighbours[i] {
            let j = j as usize;
            let (xj, vj) = (Vec3::from(self.positions[j]), Vec3::from(self.velocities[j]));
            let d = xi - xj;
            let r = d.length();
            let w = self.mass / self.densities[j] * kernel.w(r);
            let xij = d.normalize_or_zero();
            let vij = vi - vj;
            let speed = vij.length();
            let vdir = if speed > 1e-6 { vij / speed } else { vij };
            ta += speed * (1.0 - vdir.dot(xij)) * w;
            // The neighbour lies behind the surface: the surface curves away (convex) there.
            if (xj - xi).normalize_or_zero().dot(ni) < 0.0 {
                wc += (1.0 - ni.dot(self.normals[j])) * w;
            }
        }
        // Only where the surface moves along its normal (a crest, not a trough).
        if vi.normalize_or_zero().dot(ni) < 0.6 {
            wc = 0.0;
        }
        [ta, wc, 0.5 * self.mass * vi.length_squared()]
    }

    /// The SPH-interpolated fluid velocity at `x` and its number of fluid neighbours within h.
    pub fn velocity_at(&self, x: Vec3) -> (Vec3, u32) {
        let kernel = self.kernel;
        let (mut v, mut sum, mut n) = (Vec3::ZERO, 0.0f32, 0u32);
        self.grid.for_each_within(x.to_array(), self.h, |j, r| {
            let k = kernel.w(r);
            v += k * Vec3::from(self.velocities[j]);
            sum += k;
            n += 1;
        });
        (if sum > 0.0 { v / sum } else { Vec3::ZERO }, n)
    }
}

/// The per-frame maxima of the three potentials over the particles that may spawn (FoamGenerator's query).
pub fn frame_maxima(f: &Fluid, min_neighbours: u32) -> [f32; 3] {
    (0..f.len())
        .into_par_iter()
        .filter(|&i| f.neighbour_count(i) >= min_neighbours as usize)
        .map(|i| f.potentials(i))
        .reduce(|| [0.0; 3], |a, b| [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])])
}

/// Bender 2019's automatic limits from the per-frame maxima of a sequence: the mean maximum is the upper limit,
/// a tenth of it the lower. The kinetic energy's lower limit is at least `kinetic_floor` ([`Fluid::kinetic_floor`]):
/// water calmer than that spawns nothing, so a resting pool, whose largest potentials are its solver's jitter,
/// stays clear however the limits scale.
pub fn calibrate(maxima: &[[f32; 3]], kinetic_floor: f32) -> Limits {
    let n = maxima.len().max(1) as f32;
    let mean = |k: usize| maxima.iter().map(|m| m[k]).sum::<f32>() / n;
    let lim = |m: f32| if m > 0.0 { [0.1 * m, m] } else { [0.0, f32::MAX] };
    let ke = mean(2);
    let kinetic = [(0.1 * ke).max(kinetic_floor), ke.max(2.0 * kinetic_floor)];
    Limits { trapped_air: lim(mean(0)), wave_crest: lim(mean(1)), kinetic }
}
