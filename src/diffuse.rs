//! Diffuse particles — spray, foam and air bubbles that live with the flow (Ihmsen, Akinci, Akinci & Teschner
//! 2012, "Unified spray, foam and air bubbles for particle-based fluids"; the automatic thresholds of Bender,
//! Koschier, Kugelstadt & Weiler 2019, "Turbulent micropolar SPH fluids with foam", as SPlisHSPlasH's
//! FoamGenerator applies them).
//!
//! Per frame of fluid (positions and velocities), in time order ([`Generator::step`]):
//! 1. the diffuse particles of the frames before are **classified** by their number of fluid neighbours within the
//!    kernel support h = 4 r (fewer than `spray_below`: spray; more than `bubble_above`: bubble; else foam) and
//!    **advected**: spray ballistically with a little air drag, foam with the SPH-interpolated fluid velocity,
//!    bubbles by buoyancy and drag toward the fluid velocity (Ihmsen eq. 11–13); all of them age (Ihmsen ages only
//!    foam: spray and bubbles trapped away from the surface then pile up without bound), and die at the end of
//!    their lifetime or when they fall below the water's floor;
//! 2. every fluid particle with at least `min_neighbours` neighbours gets its **potentials** — trapped air
//!    (eq. 2: relative velocities of neighbours moving toward each other), wave crest (eq. 4–7: curvature of the
//!    surface where it moves along its normal), kinetic energy — clamped and normalised between limits (eq. 1);
//! 3. it **spawns** round(foam_scale · I_ke · (I_ta + I_wc) · Δt) diffuse particles in the cylinder around its
//!    velocity (eq. 10), with lifetimes between `lifetime[0]` and `lifetime[1]` by its kinetic energy.
//!
//! The limits calibrate themselves ([`calibrate`], Bender 2019's automatic mode): the mean over the sequence's
//! frames of each potential's per-frame maximum is the upper limit, a tenth of it the lower; so foam appears at
//! any simulation scale. Set `automatic = false` and the limits by hand to override.
//!
//! Deterministic: every random number is a hash of the source particle's id, the frame number and the spawn's
//! index, and spawns are appended in the order of the fluid particles; the work is split over threads only
//! where each result depends on its own index. The same frames give the same particles on any thread count.

use glam::Vec3;
use rayon::prelude::*;

use crate::scene::UniformGrid;

/// The one name of diffuse particles (module, pass, shader, timestamp, JSON key, settings section).
pub const NAME: &str = "diffuse";

/// Gravity (world units per s², y up).
pub const GRAVITY: Vec3 = Vec3::new(0.0, -9.81, 0.0);

/// A diffuse particle's type, numbered as SPlisHSPlasH's FoamGenerator numbers them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum Kind {
    /// Carried on the surface by the fluid.
    Foam = 0,
    /// In the air, ballistic.
    Spray = 1,
    /// Under water, rising.
    Bubble = 2,
}

impl Kind {
    /// Every kind, by number.
    pub const ALL: [Kind; 3] = [Kind::Foam, Kind::Spray, Kind::Bubble];

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Foam => "foam",
            Kind::Spray => "spray",
            Kind::Bubble => "bubbles",
        }
    }

    /// The kind numbered `k` in a file's `type` attribute.
    pub fn from_code(k: f64) -> Option<Kind> {
        Kind::ALL.into_iter().find(|t| *t as u8 as f64 == k)
    }
}

/// One diffuse particle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Particle {
    /// A hash of its source's id, the frame and the spawn's index ([`spawn_id`]): the same wherever it is
    /// generated (CPU or GPU); it varies the particle's size.
    pub id: u32,
    /// The id of the fluid particle that spawned it.
    pub source: u32,
    /// Its type, from its fluid neighbours at the last step.
    pub kind: Kind,
    /// World position.
    pub position: Vec3,
    /// Velocity (world units / s).
    pub velocity: Vec3,
    /// Seconds left to live.
    pub lifetime: f32,
    /// Seconds since it was spawned (it fades in over `fade_in`).
    pub age: f32,
}

/// The `[diffuse]` section of a settings file: how diffuse particles are generated and moved (this module), and
/// how the `diffuse` pass draws them (`crate::passes::diffuse`). Lengths in particle radii.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Draw diffuse particles and the low-density spray (false: the `diffuse` pass is not recorded).
    pub enabled: bool,
    /// Billboard radius (radii).
    pub size: f32,
    /// Sizes vary per particle by ± this fraction.
    pub size_spread: f32,
    /// Motion blur: billboards stretch along the velocity over this many seconds.
    pub shutter: f32,
    /// Coverage at a billboard's centre.
    pub opacity: f32,
    /// The last seconds of a particle's life, over which it fades out.
    pub fade: f32,
    /// The first seconds of a particle's life, over which it fades in (no popping up at birth).
    pub fade_in: f32,
    /// Depth below the fluid surface (radii) where foam still shows.
    pub foam_depth: f32,
    /// Depth of water (radii) that attenuates a bubble by 1/e.
    pub bubble_depth: f32,
    /// Colour of foam and spray (lit by the ambient light and the sun).
    pub color: [f32; 3],
    /// How much of the bubbles' coverage shows (0 … 1).
    pub bubbles: f32,
    /// Diffuse particles spawned per unit of potential and second (FoamGenerator's `foamscale`).
    pub foam_scale: f32,
    /// Calibrate the limits from the sequence (Bender 2019); false: use the limits below.
    pub automatic: bool,
    /// Trapped-air potential limits (min, max).
    pub trapped_air: [f32; 2],
    /// Wave-crest potential limits.
    pub wave_crest: [f32; 2],
    /// Kinetic-energy limits.
    pub kinetic: [f32; 2],
    /// Lifetime in seconds (min, max; the kinetic energy picks within).
    pub lifetime: [f32; 2],
    /// Bubbles' buoyancy (× gravity).
    pub buoyancy: f32,
    /// Bubbles' drag toward the fluid velocity (fraction per step).
    pub drag: f32,
    /// Spray's air drag (per second).
    pub air_drag: f32,
    /// Fewer fluid neighbours than this: spray.
    pub spray_below: u32,
    /// More fluid neighbours than this: bubble.
    pub bubble_above: u32,
    /// Only fluid particles with at least this many neighbours spawn.
    pub min_neighbours: u32,
    /// At most this many diffuse particles live at once (spawns beyond it are dropped, in order).
    pub max_particles: u32,
    /// At most this many living diffuse particles per fluid particle that spawned them (spawns beyond it are
    /// dropped): bounds the memory of the live simulation's pool (this many slots per fluid particle).
    pub per_particle: u32,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            enabled: true,
            size: 0.5,
            size_spread: 0.5,
            shutter: 0.01,
            opacity: 0.35,
            fade: 0.5,
            fade_in: 0.12,
            foam_depth: 1.5,
            bubble_depth: 4.0,
            color: [0.95, 0.97, 1.0],
            bubbles: 0.6,
            foam_scale: 400.0,
            automatic: true,
            trapped_air: [5.0, 20.0],
            wave_crest: [2.0, 8.0],
            kinetic: [5.0, 50.0],
            lifetime: [1.0, 3.0],
            buoyancy: 2.0,
            drag: 0.8,
            air_drag: 0.5,
            spray_below: 6,
            bubble_above: 20,
            min_neighbours: 15,
            max_particles: 2_000_000,
            per_particle: 8,
        }
    }
}

impl Params {
    /// The first value out of range, as (key, reason).
    pub fn check(&self) -> std::result::Result<(), (&'static str, String)> {
        let range = |k: &'static str, v: [f32; 2]| {
            if v[0].is_finite() && v[1].is_finite() && 0.0 <= v[0] && v[0] < v[1] {
                Ok(())
            } else {
                Err((k, format!("[diffuse] {k} = [{}, {}] must be 0 ≤ min < max", v[0], v[1])))
            }
        };
        let non_neg = |k: &'static str, v: f32, max: f32| {
            if (0.0..=max).contains(&v) {
                Ok(())
            } else {
                Err((k, format!("[diffuse] {k} = {v} is out of range (0 ≤ {k} ≤ {max})")))
            }
        };
        let pos = |k: &'static str, v: f32, max: f32| {
            if v > 0.0 && v <= max {
                Ok(())
            } else {
                Err((k, format!("[diffuse] {k} = {v} is out of range (0 < {k} ≤ {max})")))
            }
        };
        pos("size", self.size, 16.0)?;
        if !(0.0..1.0).contains(&self.size_spread) {
            return Err((
                "size_spread",
                format!("[diffuse] size_spread = {} is out of range (0 ≤ size_spread < 1)", self.size_spread),
            ));
        }
        non_neg("shutter", self.shutter, 1.0)?;
        non_neg("opacity", self.opacity, 16.0)?;
        non_neg("fade", self.fade, 60.0)?;
        non_neg("fade_in", self.fade_in, 60.0)?;
        non_neg("foam_depth", self.foam_depth, 64.0)?;
        pos("bubble_depth", self.bubble_depth, 1e4)?;
        if self.color.iter().any(|c| !(0.0..=1.0).contains(c)) {
            return Err(("color", "[diffuse] color components are 0 … 1".into()));
        }
        non_neg("bubbles", self.bubbles, 1.0)?;
        non_neg("foam_scale", self.foam_scale, 1e6)?;
        range("trapped_air", self.trapped_air)?;
        range("wave_crest", self.wave_crest)?;
        range("kinetic", self.kinetic)?;
        range("lifetime", self.lifetime)?;
        non_neg("buoyancy", self.buoyancy, 100.0)?;
        non_neg("drag", self.drag, 1.0)?;
        non_neg("air_drag", self.air_drag, 100.0)?;
        if self.bubble_above < self.spray_below {
            return Err((
                "bubble_above",
                format!(
                    "[diffuse] bubble_above = {} must be at least spray_below = {}",
                    self.bubble_above, self.spray_below
                ),
            ));
        }
        if self.per_particle == 0 || self.per_particle > 64 {
            return Err((
                "per_particle",
                format!("[diffuse] per_particle = {} is out of range (1 … 64)", self.per_particle),
            ));
        }
        if self.max_particles == 0 || self.max_particles > 64_000_000 {
            return Err((
                "max_particles",
                format!("[diffuse] max_particles = {} is out of range (1 … 64000000)", self.max_particles),
            ));
        }
        Ok(())
    }

    /// The hand-set limits.
    pub fn limits(&self) -> Limits {
        Limits { trapped_air: self.trapped_air, wave_crest: self.wave_crest, kinetic: self.kinetic }
    }
}

/// The potentials' limits (min, max) of eq. 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Trapped air.
    pub trapped_air: [f32; 2],
    /// Wave crest.
    pub wave_crest: [f32; 2],
    /// Kinetic energy.
    pub kinetic: [f32; 2],
}

/// Eq. 1: `v` clamped to the limits and normalised to 0 … 1.
pub fn clamp_normalise(v: f32, [lo, hi]: [f32; 2]) -> f32 {
    if hi <= lo {
        return 0.0;
    }
    (v.min(hi) - v.min(lo)) / (hi - lo)
}

/// The cubic spline kernel of SPlisHSPlasH (support h): W(r) and dW/dr.
#[derive(Clone, Copy, Debug)]
pub struct Kernel {
    h: f32,
    k: f32,
    l: f32,
}

impl Kernel {
    /// The kernel of support `h`.
    pub fn new(h: f32) -> Kernel {
        let h3 = h * h * h;
        Kernel { h, k: 8.0 / (std::f32::consts::PI * h3), l: 48.0 / (std::f32::consts::PI * h3) }
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
    kernel: Kernel,
    grid: UniformGrid,
    /// Neighbours of each particle (itself excluded), in the grid's order.
    neighbours: Vec<Vec<u32>>,
    densities: Vec<f32>,
    normals: Vec<Vec3>,
    /// The lowest particle's height: diffuse particles falling below it by h die.
    floor: f32,
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
        let kernel = Kernel::new(h);
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

/// Diffuse particles of a live simulation, one frame of state at a time. Automatic limits are calibrated as the
/// run goes, from the largest per-frame maximum so far: a live run cannot look ahead as a recorded sequence's
/// calibration does (the mean of every frame's maximum, [`calibrate`]), and a mean over the frames so far would
/// be held down by a calm start, so the first breaking wave would saturate every potential.
pub struct Live {
    params: Params,
    gen: Generator,
    /// The largest per-frame maxima of the potentials so far.
    top: [f32; 3],
    frame: u64,
}

impl Live {
    /// A generator for frames `1 / fps` seconds apart.
    pub fn new(params: &Params, fps: f32) -> Live {
        Live {
            params: params.clone(),
            gen: Generator::new(params, params.limits(), 1.0 / fps),
            top: [0.0; 3],
            frame: 0,
        }
    }

    /// The next frame's fluid (positions, velocities, ids; radius `radius`): calibrate, then step.
    pub fn step(&mut self, p: &crate::scene::Particles, radius: f32) -> StepStats {
        let f = Fluid::new(&p.positions, p.velocities.as_deref(), p.ids.as_deref(), radius);
        if self.params.automatic {
            let m = frame_maxima(&f, self.params.min_neighbours);
            self.top = std::array::from_fn(|k| self.top[k].max(m[k]));
            self.gen.limits = calibrate(&[self.top], f.kinetic_floor());
        }
        let stats = self.gen.step(&f, self.frame);
        self.frame += 1;
        stats
    }

    /// The living particles.
    pub fn particles(&self) -> &[Particle] {
        &self.gen.particles
    }

    /// Living particles of each kind (foam, spray, bubbles).
    pub fn counts(&self) -> [usize; 3] {
        self.gen.counts()
    }
}

/// A well-mixed 32-bit hash of four words (the spawns' random numbers).
pub fn hash4(a: u32, b: u32, c: u32, d: u32) -> u32 {
    let mut h = 0x9e37_79b9u32;
    for w in [a, b, c, d] {
        h ^= w.wrapping_mul(0x85eb_ca6b);
        h = h.rotate_left(13).wrapping_mul(5).wrapping_add(0xe654_6b64);
        h ^= h >> 16;
        h = h.wrapping_mul(0x7feb_352d);
        h ^= h >> 15;
        h = h.wrapping_mul(0x846c_a68b);
        h ^= h >> 16;
    }
    h
}

/// The id of the `k`-th spawn of fluid particle `source` in frame `frame`.
pub fn spawn_id(source: u32, frame: u32, k: u32) -> u32 {
    hash4(source, frame, k, 7)
}

/// Two unit vectors orthogonal to the unit vector `n` and to each other (Duff et al. 2017, "Building an
/// orthonormal basis, revisited"; the same arithmetic as shaders_glsl/sim_diffuse.glsl's).
pub fn orthonormal_pair(n: Vec3) -> (Vec3, Vec3) {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// A uniform number in [0, 1) from a hash.
pub fn unit(h: u32) -> f32 {
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// What one step did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepStats {
    /// Spawned this step.
    pub spawned: usize,
    /// Died this step (lifetime, or fell out of the water's box).
    pub died: usize,
    /// Spawns dropped because `max_particles` live.
    pub dropped: usize,
}

/// The diffuse particles of a sequence walked in time order (see the module).
pub struct Generator {
    model: Params,
    limits: Limits,
    dt: f32,
    /// The living particles, in spawn order.
    pub particles: Vec<Particle>,
}

impl Generator {
    /// A generator for frames `dt` seconds apart with these limits (the model's own when not automatic).
    pub fn new(model: &Params, limits: Limits, dt: f32) -> Generator {
        Generator { model: model.clone(), limits, dt, particles: Vec::new() }
    }

    /// The limits in use.
    pub fn limits(&self) -> Limits {
        self.limits
    }

    /// Particles of each kind (foam, spray, bubbles).
    pub fn counts(&self) -> [usize; 3] {
        let mut c = [0; 3];
        for p in &self.particles {
            c[p.kind as usize] += 1;
        }
        c
    }

    /// One frame `frame` of fluid: classify and advect the particles of the frames before with it, remove the
    /// dead, then spawn from it (see the module).
    pub fn step(&mut self, f: &Fluid, frame: u64) -> StepStats {
        let before = self.particles.len();
        self.advect(f);
        self.particles.retain(|p| p.lifetime > 0.0);
        let died = before - self.particles.len();
        let (spawned, dropped) = self.spawn(f, frame);
        StepStats { spawned, died, dropped }
    }

    /// Eq. 11–13: classify each particle by its fluid neighbours, then move it.
    fn advect(&mut self, f: &Fluid) {
        let (m, dt) = (&self.model, self.dt);
        let floor = f.floor - f.h;
        self.particles.par_iter_mut().for_each(|p| {
            let (vf, n) = f.velocity_at(p.position);
            p.kind = if n < m.spray_below {
                Kind::Spray
            } else if n > m.bubble_above {
                Kind::Bubble
            } else {
                Kind::Foam
            };
            match p.kind {
                Kind::Spray => {
                    p.velocity += dt * (GRAVITY - m.air_drag * p.velocity);
                    p.position += dt * p.velocity;
                    p.lifetime -= dt;
                }
                Kind::Foam => {
                    p.velocity = vf;
                    p.position += dt * vf;
                    p.lifetime -= dt;
                }
                Kind::Bubble => {
                    p.velocity += -m.buoyancy * dt * GRAVITY + m.drag * (vf - p.velocity);
                    p.position += dt * p.velocity;
                    p.lifetime -= dt;
                }
            }
            p.age += dt;
            if !(p.position.y >= floor && p.position.is_finite()) {
                p.lifetime = 0.0;
            }
        });
    }

    /// Eq. 10: spawn in the cylinder around each fluid particle's velocity; returns (spawned, dropped).
    fn spawn(&mut self, f: &Fluid, frame: u64) -> (usize, usize) {
        let (m, l, dt) = (&self.model, self.limits, self.dt);
        let frame32 = (frame ^ (frame >> 32)) as u32;
        // Living children per source: a fluid particle spawns into at most `per_particle` places.
        let mut living: std::collections::HashMap<u32, u32> = std::collections::HashMap::new();
        for p in &self.particles {
            *living.entry(p.source).or_default() += 1;
        }
        let per: Vec<Vec<Particle>> = (0..f.len())
            .into_par_iter()
            .map(|i| {
                if f.neighbour_count(i) < m.min_neighbours as usize {
                    return Vec::new();
                }
                let [ta, wc, ke] = f.potentials(i);
                let i_ke = clamp_normalise(ke, l.kinetic);
                let n = (m.foam_scale
                    * i_ke
                    * (clamp_normalise(ta, l.trapped_air) + clamp_normalise(wc, l.wave_crest))
                    * dt
                    + 0.5)
                    .floor()
                    .max(0.0) as u32;
                let id = f.ids[i];
                let n = n.min(m.per_particle.saturating_sub(living.get(&id).copied().unwrap_or(0)));
                if n == 0 {
                    return Vec::new();
                }
                let (x, v) = (Vec3::from(f.positions[i]), Vec3::from(f.velocities[i]));
                let speed = v.length();
                let axis = if speed > 0.0 { v / speed } else { Vec3::Y };
                let (e1, e2) = orthonormal_pair(axis);
                (0..n)
                    .map(|k| {
                        let u = |c: u32| unit(hash4(id, frame32, k, c));
                        let r = f.radius * u(0).sqrt();
                        let theta = std::f32::consts::TAU * u(1);
                        let h = (u(2) - 0.5) * dt * speed;
                        let radial = r * theta.cos() * e1 + r * theta.sin() * e2;
                        Particle {
                            id: spawn_id(id, frame32, k),
                            source: id,
                            kind: Kind::Foam,
                            position: x + radial + h * axis,
                            velocity: radial + v,
                            lifetime: m.lifetime[0] + i_ke * u(3) * (m.lifetime[1] - m.lifetime[0]),
                            age: 0.0,
                        }
                    })
                    .collect()
            })
            .collect();
        let room = (m.max_particles as usize).saturating_sub(self.particles.len());
        let total: usize = per.iter().map(Vec::len).sum();
        let mut spawned = 0;
        for p in per.into_iter().flatten().take(room) {
            self.particles.push(p);
            spawned += 1;
        }
        (spawned, total - spawned)
    }
}

/// The particles as a file's attributes: `velocity`, `lifetime` (s left), `age` (s since spawned), `source` (the
/// spawning fluid particle's id), `type` (0 foam, 1 spray, 2 bubbles, as SPlisHSPlasH's FoamGenerator numbers
/// them) and `id`.
pub fn to_particles(ps: &[Particle]) -> crate::scene::Particles {
    let scalar = |name: &str, value: fn(&Particle) -> f64| crate::scene::Attribute {
        name: name.into(),
        components: 1,
        data: ps.iter().map(value).collect(),
    };
    crate::scene::Particles {
        positions: ps.iter().map(|p| p.position.to_array()).collect(),
        velocities: Some(ps.iter().map(|p| p.velocity.to_array()).collect()),
        ids: Some(ps.iter().map(|p| p.id as i64).collect()),
        extra: vec![
            scalar("lifetime", |p| p.lifetime as f64),
            scalar("source", |p| p.source as f64),
            scalar("age", |p| p.age as f64),
            scalar("type", |p| p.kind as u8 as f64),
        ],
        ..Default::default()
    }
}

/// Diffuse particles from a file: its `type` (default foam), `lifetime` (default 1 s) and `age` (default 1 s)
/// attributes, its
/// velocities (default 0) and ids (default the index).
pub fn from_particles(p: &crate::scene::Particles) -> std::result::Result<Vec<Particle>, String> {
    let attr = |name: &str| p.extra.iter().find(|a| a.name == name && a.components == 1);
    let kinds = attr("type");
    let life = attr("lifetime");
    let age = attr("age");
    let source = attr("source");
    (0..p.len())
        .map(|i| {
            let kind = match kinds {
                Some(a) => Kind::from_code(a.data[i]).ok_or_else(|| {
                    format!("particle {i}: type {} is not 0 (foam), 1 (spray) or 2 (bubbles)", a.data[i])
                })?,
                None => Kind::Foam,
            };
            Ok(Particle {
                id: p.ids.as_ref().map_or(i as u32, |ids| ids[i] as u32),
                kind,
                position: Vec3::from(p.positions[i]),
                velocity: p.velocities.as_ref().map_or(Vec3::ZERO, |v| Vec3::from(v[i])),
                lifetime: life.map_or(1.0, |a| a.data[i] as f32),
                age: age.map_or(1.0, |a| a.data[i] as f32),
                source: source.map_or(0, |a| a.data[i] as u32),
            })
        })
        .collect()
}

/// Read an exported frame of diffuse particles (`meniscus foam --export`, or any particle file with the
/// attributes of [`to_particles`]); a file with no particles is an empty frame.
pub fn load(path: &std::path::Path) -> crate::error::Result<Vec<Particle>> {
    use crate::error::Error;
    let bytes = crate::input::read(path)?;
    let format = crate::scene::detect_format(path, &bytes).ok_or_else(|| Error::Parse {
        path: path.to_path_buf(),
        offset: 0,
        reason: "unknown particle format".into(),
    })?;
    let raw = crate::scene::parse_raw(format, path, &bytes)?;
    let p = raw.into_particles(&crate::scene::LoadOptions::default());
    from_particles(&p).map_err(|reason| Error::Parse { path: path.to_path_buf(), offset: 0, reason })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block of fluid on a lattice of spacing 2r.
    fn block(nx: usize, ny: usize, nz: usize, r: f32) -> Vec<[f32; 3]> {
        let mut v = vec![];
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    v.push([x as f32 * 2.0 * r, y as f32 * 2.0 * r, z as f32 * 2.0 * r]);
                }
            }
        }
        v
    }

    #[test]
    fn kernel_is_normalised_and_its_derivative_matches() {
        let k = Kernel::new(0.1);
        // ∫ W dV = 1 (midpoint rule over shells).
        let steps = 20000;
        let dr = 0.1 / steps as f32;
        let integral: f32 =
            (0..steps).map(|s| (s as f32 + 0.5) * dr).map(|r| 4.0 * std::f32::consts::PI * r * r * k.w(r) * dr).sum();
        assert!((integral - 1.0).abs() < 1e-3, "{integral}");
        for r in [0.01f32, 0.04, 0.06, 0.09] {
            let fd = (k.w(r + 1e-4) - k.w(r - 1e-4)) / 2e-4;
            assert!((fd - k.dw(r)).abs() < 1e-2 * k.dw(r).abs().max(1.0), "{r}: {fd} vs {}", k.dw(r));
        }
    }

    #[test]
    fn clamp_and_normalise_is_eq_1() {
        assert_eq!(clamp_normalise(1.0, [2.0, 4.0]), 0.0);
        assert_eq!(clamp_normalise(3.0, [2.0, 4.0]), 0.5);
        assert_eq!(clamp_normalise(9.0, [2.0, 4.0]), 1.0);
    }

    /// Still water has no trapped air, no crest, no energy: nothing spawns, whatever the limits.
    #[test]
    fn still_water_spawns_nothing() {
        let r = 0.025;
        let pos = block(10, 6, 10, r);
        let vel = vec![[0.0; 3]; pos.len()];
        let f = Fluid::new(&pos, Some(&vel), None, r);
        let mut g = Generator::new(&Params::default(), Params::default().limits(), 0.04);
        for frame in 0..5 {
            assert_eq!(g.step(&f, frame).spawned, 0);
        }
        assert!(g.particles.is_empty());
        assert_eq!(frame_maxima(&f, 15), [0.0, 0.0, 0.0]);
    }

    /// The trapped-air potential of two neighbours closing on each other, by hand (eq. 2): |v_ij| (1 − v̂_ij·x̂_ij)
    /// m/ρ_j W(r); and zero when they move apart.
    #[test]
    fn trapped_air_of_two_particles() {
        let r = 0.025;
        let pos = vec![[0.0, 0.0, 0.0], [0.05, 0.0, 0.0]];
        let closing = vec![[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]];
        let f = Fluid::new(&pos, Some(&closing), None, r);
        let k = Kernel::new(0.1);
        let rho = f.mass * (k.w(0.0) + k.w(0.05));
        let want = 2.0 * (1.0 - (-1.0)) * f.mass / rho * k.w(0.05);
        let got = f.potentials(0)[0];
        assert!((got - want).abs() < 1e-5 * want, "{got} vs {want}");
        let apart = vec![[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let f = Fluid::new(&pos, Some(&apart), None, r);
        assert!(f.potentials(0)[0].abs() < 1e-6);
    }

    /// Advection of each kind against its equation: spray falls ballistically with drag, foam moves with the
    /// fluid, bubbles rise.
    #[test]
    fn advection_of_each_kind() {
        let r = 0.025;
        let pos = block(12, 8, 12, r);
        let vel = vec![[0.5, 0.0, 0.0]; pos.len()];
        let f = Fluid::new(&pos, Some(&vel), None, r);
        let m = Params::default();
        let mut g = Generator::new(&m, m.limits(), 0.04);
        let p = |x: [f32; 3]| Particle {
            id: 0,
            source: 0,
            kind: Kind::Foam,
            position: Vec3::from(x),
            velocity: Vec3::ZERO,
            lifetime: 10.0,
            age: 0.0,
        };
        // Far above the water: spray. Deep inside: bubble. At the top layer: foam.
        let top = 7.0 * 2.0 * r;
        g.particles = vec![p([0.3, 2.0, 0.3]), p([0.3, 0.2, 0.3]), p([0.3, top + 0.5 * r, 0.3])];
        g.advect(&f);
        let [spray, bubble, foam] = [g.particles[0], g.particles[1], g.particles[2]];
        assert_eq!((spray.kind, bubble.kind, foam.kind), (Kind::Spray, Kind::Bubble, Kind::Foam));
        let dt = 0.04;
        let v = dt * GRAVITY;
        assert!((spray.velocity - v).length() < 1e-6);
        assert!((spray.position - (Vec3::new(0.3, 2.0, 0.3) + dt * v)).length() < 1e-6);
        assert!((foam.velocity - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-5, "{:?}", foam.velocity);
        assert!((foam.lifetime - (10.0 - dt)).abs() < 1e-6);
        let vb = -m.buoyancy * dt * GRAVITY + m.drag * Vec3::new(0.5, 0.0, 0.0);
        assert!((bubble.velocity - vb).length() < 1e-5, "{:?} vs {vb:?}", bubble.velocity);
        assert!((bubble.lifetime - (10.0 - dt)).abs() < 1e-6);
    }

    /// The same frames give the same particles on one thread and on two.
    #[test]
    fn spawns_do_not_depend_on_the_thread_count() {
        let r = 0.025;
        let pos = block(12, 6, 12, r);
        let vel: Vec<[f32; 3]> =
            pos.iter().map(|p| [(p[1] * 40.0).sin() * 2.0, 1.0 + p[0] * 3.0, -(p[2] * 30.0).cos()]).collect();
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let f = Fluid::new(&pos, Some(&vel), None, r);
                let lim = calibrate(&[frame_maxima(&f, 15)], f.kinetic_floor());
                let mut g = Generator::new(&Params::default(), lim, 0.04);
                for frame in 0..4 {
                    g.step(&f, frame);
                }
                g.particles
            })
        };
        let one = run(1);
        assert!(one.len() > 50, "{}", one.len());
        assert_eq!(one, run(2));
    }

    /// `meniscus foam --export` files (.bgeo and .vtk, through the library's writers and loaders) give back the
    /// same particles; a frame without any is an empty file that reads as no particles.
    #[test]
    fn export_round_trips_through_the_loaders() {
        let dir = std::env::temp_dir().join(format!("meniscus-diffuse-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let ps: Vec<Particle> = (0..50)
            .map(|i| Particle {
                id: spawn_id(7 * i, 3, i),
                source: 7 * i,
                kind: Kind::ALL[i as usize % 3],
                position: Vec3::new(i as f32 * 0.1, 1.0 / (1.0 + i as f32), -0.25),
                velocity: Vec3::new(0.5, -(i as f32), 2.0),
                lifetime: 0.1 * i as f32 + 0.05,
                age: 0.02 * i as f32,
            })
            .collect();
        for name in ["f_0001.bgeo", "f_0001.vtk"] {
            let path = dir.join(name);
            crate::scene::write_particles(&path, &to_particles(&ps)).unwrap();
            assert_eq!(load(&path).unwrap(), ps, "{name}");
            // (A file read is an input of the process: never written over, so the empty frame is another.)
            let empty = dir.join(format!("empty_{name}"));
            crate::scene::write_particles(&empty, &to_particles(&[])).unwrap();
            assert_eq!(load(&empty).unwrap(), vec![], "{name} (empty)");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn export_round_trips_through_the_attributes() {
        let ps = vec![
            Particle {
                id: 3,
                source: 1,
                kind: Kind::Spray,
                position: Vec3::new(1.0, 2.0, 3.0),
                velocity: Vec3::X,
                lifetime: 0.5,
                age: 0.0,
            },
            Particle {
                id: 4,
                source: 2,
                kind: Kind::Bubble,
                position: Vec3::ZERO,
                velocity: Vec3::Y,
                lifetime: 2.0,
                age: 3.0,
            },
        ];
        assert_eq!(from_particles(&to_particles(&ps)).unwrap(), ps);
    }
}
