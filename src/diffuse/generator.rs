//! Diffuse particles frame after frame (Ihmsen et al. 2012): the old ones classified by their fluid neighbours
//! and advected (eq. 11–13), new ones spawned from the potentials (eq. 10); deterministic hashes seed every
//! random number. `Generator` walks a recorded sequence, `Live` a simulation. In: frames of fluid. Out: diffuse
//! particles.

use glam::Vec3;
use rayon::prelude::*;

use super::params::{clamp_normalise, Limits, Params};
use super::potentials::{calibrate, frame_maxima, Fluid};
use super::{Kind, Particle, GRAVITY};

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
    pub(super) fn advect(&mut self, f: &Fluid) {
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
