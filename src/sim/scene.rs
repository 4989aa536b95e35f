//! The simulation's scenes: a container (the box the water stays in), colliders, the water's initial shape
//! and an optional emitter. Particle count is a request; the spacing follows from the water's volume
//! (d = (V/N)^(1/3), radius r = d/2), and the lattice fill gives the actual count.
//!
//! - `dambreak`: the shared SPlisHSPlasH sequences' set-up (../shared/data/splishsplash/*/scene.json): tank
//!   4 × 3 × 1.5 m centred at (0, 1.5, 0), a 1 m water cube at x ∈ [−1.95, −0.95], y ∈ [0.05, 1.05],
//!   z ∈ [−0.5, 0.5].
//! - `drop`: a sphere of water falling into a pool (the crown splash).
//! - `waterfall`: water emitted over a ledge (a solid box) into a basin.
//! - `pool`: water at rest (the resting-pool test).

use glam::Vec3;

use super::sdf::Sdf;
use crate::error::{Error, Result};
use crate::scene::geometry::Geometry;

/// A solid the water cannot enter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Collider {
    /// Solid sphere.
    Sphere {
        /// Centre.
        centre: Vec3,
        /// Radius.
        radius: f32,
    },
    /// Solid axis-aligned box.
    Box {
        /// Centre.
        centre: Vec3,
        /// Half extents.
        half: Vec3,
    },
    /// Half-space: the water keeps n·x ≥ offset.
    Plane {
        /// Unit normal pointing into the water's side.
        normal: Vec3,
        /// Offset along the normal.
        offset: f32,
    },
}

impl Collider {
    /// The two vec4 of the collider in sim_common.glsl's uniform block (its kind, `shader_constants::COLLIDER_*`,
    /// in the first one's w).
    pub fn encode(&self) -> [[f32; 4]; 2] {
        use crate::shader_constants::{COLLIDER_BOX, COLLIDER_PLANE, COLLIDER_SPHERE};
        match *self {
            Collider::Sphere { centre, radius } => {
                [centre.extend(COLLIDER_SPHERE as f32).to_array(), [radius, 0.0, 0.0, 0.0]]
            }
            Collider::Box { centre, half } => {
                [centre.extend(COLLIDER_BOX as f32).to_array(), half.extend(0.0).to_array()]
            }
            Collider::Plane { normal, offset } => {
                [normal.normalize_or(Vec3::Y).extend(COLLIDER_PLANE as f32).to_array(), [offset, 0.0, 0.0, 0.0]]
            }
        }
    }
}

/// Particles entering the scene through a rectangle (or the disc inscribed in it), one lattice layer each time
/// the water has moved one spacing (SPlisHSPlasH's emitters work the same way).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emitter {
    /// Centre of the rectangle.
    pub centre: Vec3,
    /// Velocity of the emitted water (the rectangle faces along it).
    pub velocity: Vec3,
    /// Half extents of the rectangle (across the flow: along `width_axis`, then the axis across both).
    pub half: [f32; 2],
    /// The rectangle's first axis; zero: horizontal, across the flow (velocity × y).
    pub width_axis: Vec3,
    /// Emission from `start` to `end` seconds of simulated time.
    pub start: f64,
    /// See `start`.
    pub end: f64,
    /// Only the lattice points within the ellipse inscribed in the rectangle (SPlisHSPlasH's emitter type 1).
    pub circle: bool,
    /// Recycling (SPlisHSPlasH's `emitterReuseParticles` with `emitterBoxMin/Max`): particles outside this box
    /// (lo, hi) are emitted again before the room for new ones is used, and slowed while they wait
    /// ([`crate::sim::Simulation`]'s frame start); `None`: emitted particles stay.
    pub reuse: Option<(Vec3, Vec3)>,
}

impl Emitter {
    /// The rectangle's axes: along the flow, up (the height's), across (the width's).
    pub fn axes(&self) -> [Vec3; 3] {
        let dir = self.velocity.normalize_or(Vec3::X);
        let w = self.width_axis - dir * self.width_axis.dot(dir);
        let across = if w.length_squared() > 1e-12 { w.normalize() } else { dir.cross(Vec3::Y).normalize_or(Vec3::Z) };
        [dir, across.cross(dir), across]
    }

    /// The nozzle at simulated time `t`, as sim_common.glsl's uniform block holds it: SPlisHSPlasH's emitters
    /// (`Emitter::emitParticles`, `getSize`; the sizes of its density- and volume-map boundaries, particles
    /// spaced `d`, support radius 2d) move every particle in a box reaching half a support radius behind the
    /// emitter and 1.5 ahead, 1.25 d wider than the rectangle on each side (a cylinder 2.25 support radii long of
    /// 1.125 (the disc's radius + d) for a circular one), at the emitter's velocity from 0.25 s before its start
    /// to its end — before the start at 40 radii per second, to clear the way. Zero (none) outside that time.
    pub fn nozzle(&self, d: f32, t: f64) -> [[f32; 4]; 5] {
        if t < self.start - 0.25 || t > self.end {
            return [[0.0; 4]; 5];
        }
        let [dir, up, across] = self.axes();
        let support = 2.0 * d;
        let (kind, half) = if self.circle {
            (2.0, [1.125 * support, 1.125 * (self.half[0] + d), 0.0])
        } else {
            (1.0, [support, self.half[1] + 1.25 * d, self.half[0] + 1.25 * d])
        };
        let v = if t < self.start { dir * 20.0 * d } else { self.velocity };
        [
            (self.centre + dir * 0.5 * support).extend(kind).to_array(),
            dir.extend(half[0]).to_array(),
            up.extend(half[1]).to_array(),
            across.extend(half[2]).to_array(),
            v.extend(0.0).to_array(),
        ]
    }
}

/// A scene with its particles laid out.
#[derive(Clone, Debug)]
pub struct SimScene {
    /// `dambreak`, `drop`, `waterfall`, `pool`.
    pub name: &'static str,
    /// Container interior (lo, hi).
    pub container: (Vec3, Vec3),
    /// Colliders besides the container.
    pub colliders: Vec<Collider>,
    /// Particle spacing d (the radius is d/2).
    pub spacing: f32,
    /// Initial positions.
    pub positions: Vec<[f32; 3]>,
    /// Initial velocities.
    pub velocities: Vec<[f32; 3]>,
    /// Most particles the scene will hold (emitters grow to it).
    pub capacity: usize,
    /// The emitter, if any.
    pub emitter: Option<Emitter>,
    /// Kinematic viscosity (m²/s) when `[sim] viscosity` does not set one.
    pub viscosity: f32,
    /// A triangle mesh the water cannot enter, as a signed distance field ([`SimScene::add_mesh_collider`]).
    pub mesh_collider: Option<std::sync::Arc<Sdf>>,
    /// A dynamic rigid sphere coupled both ways with the water (DFSPH; a SPlisHSPlasH scene file's `isDynamic`
    /// sphere): [`Body`].
    pub body: Option<Body>,
}

/// A dynamic rigid sphere (`RigidBodies[]` with `isDynamic` in a SPlisHSPlasH scene file): its mass from its
/// density and volume, moved by gravity, the water's pressure on it and the container's faces, and moving the
/// water (DFSPH: its surface enters the solves as the container's walls do, `sim_body` integrates it;
/// src/sim/dfsph.rs). Its rotation is not simulated: a sphere's shape does not turn with it, and only friction
/// at the walls would spin it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    /// Centre at the start.
    pub centre: Vec3,
    /// Radius.
    pub radius: f32,
    /// Density (kg/m³).
    pub density: f32,
    /// Velocity at the start.
    pub velocity: Vec3,
    /// Restitution against the container's faces (SPlisHSPlasH's `restitution`).
    pub restitution: f32,
    /// Coulomb friction against the container's faces (`friction`).
    pub friction: f32,
    /// The box its centre's contacts keep it in (lo, hi of the faces); None: the container's.
    pub contact_box: Option<(Vec3, Vec3)>,
}

impl Body {
    /// Mass (kg).
    pub fn mass(&self) -> f32 {
        self.density * 4.0 / 3.0 * std::f32::consts::PI * self.radius.powi(3)
    }
}

/// The built-in scenes, with their default particle counts.
pub const SCENES: &[(&str, usize, &str)] = &[
    ("dambreak", 59_319, "the shared SPlisHSPlasH set-up: a 1 m water cube breaking in a 4 × 3 × 1.5 m tank"),
    ("drop", 60_000, "a sphere of water falling into a pool (crown splash)"),
    ("waterfall", 60_000, "water emitted over a ledge into a basin"),
    ("pool", 20_000, "a pool at rest"),
];

/// The gap, in spacings, between a container's face and a lattice's first layer beyond the half spacing a
/// particle keeps: where the walls' continuum density term (sim_common.glsl's `wall_density`, h = 2 d) makes
/// that layer exactly ρ0. At no gap the layer starts 2.6 % denser, and a solve that converges pushes it off the
/// wall at once and the water sloshes (docs/simulation.md). Test: `a_pool_lattice_starts_at_rest_density`.
pub const WALL_GAP: f32 = 0.0558;

/// The spacing nearest `d` that fits whole cells across `width` with [`WALL_GAP`] at both walls, so a lattice
/// filling a container's floor reaches its walls: a pool that left a sliver of a spacing free at one wall would
/// collapse into it and slosh.
fn fit(width: f32, d: f32) -> f32 {
    width / ((width / d).round().max(1.0) + 2.0 * WALL_GAP)
}

/// The box a pool's lattice of spacing `d` fills: the container's floor lo..hi (x, z) up to `depth`, [`WALL_GAP`]
/// from its walls and floor.
fn pool_box(lo: Vec3, hi: Vec3, depth: f32, d: f32) -> (Vec3, Vec3) {
    let g = WALL_GAP * d;
    (lo + g, Vec3::new(hi.x - g, depth + g, hi.z - g))
}

/// Lattice points (cell centres) of spacing `d` in the box lo..hi, kept where `keep` holds.
fn lattice(lo: Vec3, hi: Vec3, d: f32, keep: impl Fn(Vec3) -> bool) -> Vec<[f32; 3]> {
    let n = ((hi - lo) / d + 1e-3).floor().as_uvec3();
    let mut out = vec![];
    for k in 0..n.z {
        for j in 0..n.y {
            for i in 0..n.x {
                let p = lo + (Vec3::new(i as f32, j as f32, k as f32) + 0.5) * d;
                if keep(p) {
                    out.push(p.to_array());
                }
            }
        }
    }
    out
}

impl SimScene {
    /// Build scene `name` with about `particles` particles.
    pub fn new(name: &str, particles: usize) -> Result<SimScene> {
        if particles < 8 {
            return Err(Error::Invalid(format!("--particles {particles}: a simulation needs at least 8 particles")));
        }
        if particles > super::scene_file::MAX_PARTICLES {
            return Err(Error::Invalid(format!(
                "--particles {particles}: at most {} particles (the simulation's state is 32 bytes a particle, and more)",
                super::scene_file::MAX_PARTICLES
            )));
        }
        let n = particles as f32;
        let tank = (Vec3::new(-2.0, 0.0, -0.75), Vec3::new(2.0, 3.0, 0.75));
        let scene = match name {
            "dambreak" => {
                let (lo, hi) = (Vec3::new(-1.95, 0.05, -0.5), Vec3::new(-0.95, 1.05, 0.5));
                let d = (1.0 / n).cbrt();
                let positions = lattice(lo, hi, d, |_| true);
                SimScene::still("dambreak", tank, vec![], d, positions)
            }
            "pool" => {
                let (lo, hi) = (Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 2.0, 0.5));
                let depth = 0.4;
                let d = fit(hi.x - lo.x, (depth / n).cbrt());
                let (a, b) = pool_box(lo, hi, depth, d);
                let positions = lattice(a, b, d, |_| true);
                SimScene::still("pool", (lo, hi), vec![], d, positions)
            }
            "drop" => {
                let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0));
                let (depth, centre, radius) = (0.25f32, Vec3::new(0.0, 0.9, 0.0), 0.22f32);
                let volume = 4.0 * depth + 4.0 / 3.0 * std::f32::consts::PI * radius.powi(3);
                let d = fit(hi.x - lo.x, (volume / n).cbrt());
                let (a, b) = pool_box(lo, hi, depth, d);
                let mut positions = lattice(a, b, d, |_| true);
                let ball = lattice(centre - radius, centre + radius, d, |p| p.distance(centre) <= radius);
                let first_ball = positions.len();
                positions.extend(ball);
                let mut s = SimScene::still("drop", (lo, hi), vec![], d, positions);
                for v in &mut s.velocities[first_ball..] {
                    *v = [0.0, -2.5, 0.0];
                }
                s.viscosity = 0.001;
                s
            }
            "waterfall" => {
                // A ledge over the left third of the tank; the emitter pours over it for a few seconds.
                let ledge = Collider::Box { centre: Vec3::new(-1.4, 0.6, 0.0), half: Vec3::new(0.6, 0.6, 0.75) };
                let emitter = Emitter {
                    centre: Vec3::new(-1.85, 1.45, 0.0),
                    velocity: Vec3::new(1.6, 0.0, 0.0),
                    half: [0.3, 0.12],
                    width_axis: Vec3::ZERO,
                    start: 0.0,
                    end: f64::INFINITY,
                    circle: false,
                    reuse: None,
                };
                // About 6 s of emission fill the capacity.
                let rate = 4.0 * emitter.half[0] * emitter.half[1] * emitter.velocity.length();
                let d = (rate * 6.0 / n).cbrt();
                let mut s = SimScene::still("waterfall", tank, vec![ledge], d, vec![]);
                s.emitter = Some(emitter);
                s.capacity = particles;
                s.viscosity = 0.001;
                s
            }
            other => {
                let known: Vec<&str> = SCENES.iter().map(|s| s.0).collect();
                return Err(Error::Invalid(format!(
                    "unknown simulation scene {other:?} (known: {})",
                    known.join(", ")
                )));
            }
        };
        Ok(scene)
    }

    fn still(
        name: &'static str,
        container: (Vec3, Vec3),
        colliders: Vec<Collider>,
        d: f32,
        positions: Vec<[f32; 3]>,
    ) -> SimScene {
        let n = positions.len();
        SimScene {
            name,
            container,
            colliders,
            spacing: d,
            velocities: vec![[0.0; 3]; n],
            positions,
            capacity: n,
            emitter: None,
            viscosity: 0.02,
            mesh_collider: None,
            body: None,
        }
    }

    /// Make `mesh` (world coordinates, closed for inside/outside; see src/sim/sdf.rs) a collider: its signed
    /// distance ([`Sdf::for_particles`]). Water that starts inside it (closer than r) is removed — the solid displaces it;
    /// returns how many particles that was.
    pub fn add_mesh_collider(&mut self, mesh: &Geometry) -> Result<usize> {
        let r = self.radius();
        let sdf = Sdf::for_particles(mesh, r, self.container)?;
        let keep: Vec<bool> = self.positions.iter().map(|p| sdf.sample(Vec3::from(*p)).0 >= r).collect();
        let removed = keep.iter().filter(|k| !**k).count();
        let mut k = keep.iter();
        self.positions.retain(|_| *k.next().unwrap());
        let mut k = keep.iter();
        self.velocities.retain(|_| *k.next().unwrap());
        if self.emitter.is_none() {
            self.capacity = self.positions.len();
        }
        if self.positions.is_empty() && self.emitter.is_none() {
            return Err(Error::Invalid("the collider mesh covers all of the scene's water".into()));
        }
        self.mesh_collider = Some(std::sync::Arc::new(sdf));
        Ok(removed)
    }

    /// Particle radius (half the spacing).
    pub fn radius(&self) -> f32 {
        0.5 * self.spacing
    }

    /// The scene's spheres as the background draws them: each sphere collider standing still (one centre), then
    /// the dynamic body at its start (a simulation adds its later centres).
    pub fn sphere_tracks(&self) -> Vec<crate::scene::splishsplash::BodyTrack> {
        use crate::scene::splishsplash::BodyTrack;
        let still = self.colliders.iter().filter_map(|c| match *c {
            Collider::Sphere { centre, radius } => Some(BodyTrack { radius, centres: vec![centre] }),
            _ => None,
        });
        still.chain(self.body.map(|b| BodyTrack { radius: b.radius, centres: vec![b.centre] })).collect()
    }

    /// The water the emitter adds when it has run `from`..`to` seconds: positions and velocities of the
    /// lattice layers whose travel crossed the rectangle in that interval (at most `room` particles).
    pub fn emit(&self, from: f64, to: f64, room: usize) -> Vec<([f32; 3], [f32; 3])> {
        let Some(e) = self.emitter else { return vec![] };
        let d = self.spacing as f64;
        let speed = e.velocity.length() as f64;
        if speed <= 0.0 || room == 0 {
            return vec![];
        }
        // The width axis made perpendicular to the flow (or the horizontal across it).
        let [dir, up, across] = e.axes();
        let (na, nu) = ((2.0 * e.half[0] / self.spacing) as i32, (2.0 * e.half[1] / self.spacing) as i32);
        let mut out = vec![];
        // Layer k leaves the rectangle at t = start + k d / speed (until `end`); a layer emitted at t has
        // travelled speed (to − t).
        let layer = |t: f64| ((t.min(e.end) - e.start).max(0.0) * speed / d).ceil() as i64;
        let (k0, k1) = (layer(from), layer(to));
        for k in k0..k1 {
            let travelled = (to - e.start - k as f64 * d / speed) * speed;
            for a in 0..na {
                for u in 0..nu {
                    if out.len() >= room {
                        return out;
                    }
                    let (oa, ou) =
                        ((a as f32 + 0.5) * self.spacing - e.half[0], (u as f32 + 0.5) * self.spacing - e.half[1]);
                    if e.circle && (oa / e.half[0]).powi(2) + (ou / e.half[1]).powi(2) > 1.0 {
                        continue;
                    }
                    let off = across * oa + up * ou;
                    let p = e.centre + off + dir * travelled as f32;
                    out.push((p.to_array(), e.velocity.to_array()));
                }
            }
        }
        out
    }

    /// The container's walls as background boxes (back, left and right walls and a low front lip, `thick`
    /// thick), so the tank shows without hiding the water.
    pub fn wall_boxes(&self) -> Vec<(Vec3, Vec3)> {
        let (lo, hi) = self.container;
        let mut b = crate::scene::splishsplash::container_walls(lo, hi, self.wall_thickness()).to_vec();
        b.extend(self.box_colliders());
        b
    }
}

impl SimScene {
    /// The box colliders as (lo, hi).
    pub fn box_colliders(&self) -> Vec<(Vec3, Vec3)> {
        self.colliders
            .iter()
            .filter_map(|c| match c {
                Collider::Box { centre, half } => Some((*centre - *half, *centre + *half)),
                _ => None,
            })
            .collect()
    }

    /// The wall thickness drawn for the container.
    pub fn wall_thickness(&self) -> f32 {
        let (lo, hi) = self.container;
        (0.02 * (hi - lo).max_element()).max(self.spacing)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dambreak_matches_the_shared_set_up() {
        let s = SimScene::new("dambreak", 59_319).unwrap();
        assert_eq!(s.positions.len(), 39 * 39 * 39);
        assert!((s.radius() - 0.5 / 39.0).abs() < 1e-6);
        let lo = s.positions.iter().fold(Vec3::INFINITY, |a, p| a.min(Vec3::from(*p)));
        let hi = s.positions.iter().fold(Vec3::NEG_INFINITY, |a, p| a.max(Vec3::from(*p)));
        assert!((lo - Vec3::new(-1.95, 0.05, -0.5) - Vec3::splat(s.radius())).abs().max_element() < 1e-4);
        assert!((hi - Vec3::new(-0.95, 1.05, 0.5) + Vec3::splat(s.radius())).abs().max_element() < 1e-4);
    }

    #[test]
    fn scenes_build_and_unknown_names_are_errors() {
        for (name, n, _) in SCENES {
            let s = SimScene::new(name, *n / 10).unwrap();
            assert!(s.capacity >= s.positions.len());
        }
        assert!(SimScene::new("nope", 1000).unwrap_err().to_string().contains("dambreak"));
        assert!(SimScene::new("dambreak", 0).is_err());
    }

    #[test]
    fn the_emitter_adds_layers_at_its_speed() {
        let s = SimScene::new("waterfall", 20_000).unwrap();
        let a = s.emit(0.0, 0.5, usize::MAX).len();
        let b = s.emit(0.5, 1.0, usize::MAX).len();
        assert!(a > 0 && (a as i64 - b as i64).abs() <= (a as i64 / 5).max(1));
        assert_eq!(s.emit(0.0, 0.5, 10).len(), 10);
    }

    /// SPlisHSPlasH's nozzle: a box from half a support radius (2d) behind the emitter to 1.5 ahead, 1.25 d wider
    /// than the rectangle each side, moving at the emitter's velocity from 0.25 s before its start (at 20 d/s
    /// then) to its end; none outside that time.
    #[test]
    fn the_nozzle_holds_the_box_ahead_of_the_emitter() {
        let e = Emitter {
            centre: Vec3::new(1.0, 2.0, 3.0),
            velocity: Vec3::new(0.0, 0.0, -2.0),
            half: [0.3, 0.1],
            width_axis: Vec3::X,
            start: 1.0,
            end: 2.0,
            circle: false,
            reuse: None,
        };
        let d = 0.05;
        assert_eq!(e.nozzle(d, 0.7), [[0.0; 4]; 5]);
        assert_eq!(e.nozzle(d, 2.01), [[0.0; 4]; 5]);
        let close = |a: [f32; 4], b: [f32; 4]| a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-6);
        let n = e.nozzle(d, 1.5);
        assert!(close(n[0], [1.0, 2.0, 3.0 - d, 1.0]), "{:?}", n[0]);
        assert!(close(n[1], [0.0, 0.0, -1.0, 2.0 * d]), "{:?}", n[1]);
        assert!(close(n[2], [0.0, 1.0, 0.0, 0.1 + 1.25 * d]), "{:?}", n[2]);
        assert!(close(n[3], [1.0, 0.0, 0.0, 0.3 + 1.25 * d]), "{:?}", n[3]);
        assert!(close(n[4], [0.0, 0.0, -2.0, 0.0]), "{:?}", n[4]);
        assert!(close(e.nozzle(d, 0.8)[4], [0.0, 0.0, -20.0 * d, 0.0]));
        let c = Emitter { circle: true, ..e }.nozzle(d, 1.5);
        assert!(close([c[0][3], c[1][3], c[2][3], 0.0], [2.0, 2.25 * d, 1.125 * (0.3 + d), 0.0]), "{c:?}");
    }
}
