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
//!
//! Files of one concern each: `params` (the `[diffuse]` section, the potentials' limits), `potentials` (the
//! kernel, a frame of fluid and its potentials, the calibration), `generator` (classification, advection and
//! spawning, frame after frame: `Generator` for a sequence, `Live` for a simulation), `io` (diffuse particles as
//! a file's attributes). The GPU stages are `crate::sim::diffuse`, the draw pass `crate::passes::diffuse`.

use glam::Vec3;

pub mod generator;
pub mod io;
pub mod params;
pub mod potentials;

/// The one name of diffuse particles (module, pass, shader, timestamp, JSON key, settings section).
pub const NAME: &str = "diffuse";

/// Gravity (world units per s², y up).
pub const GRAVITY: Vec3 = Vec3::new(0.0, -9.81, 0.0);

/// A diffuse particle's type, numbered as SPlisHSPlasH's FoamGenerator numbers them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum Kind {
    /// Carried on the surface by the fluid.
    Foam = crate::shader_constants::DIFFUSE_FOAM as u8,
    /// In the air, ballistic.
    Spray = crate::shader_constants::DIFFUSE_SPRAY as u8,
    /// Under water, rising.
    Bubble = crate::shader_constants::DIFFUSE_BUBBLE as u8,
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

#[cfg(test)]
mod tests {
    use super::generator::*;
    use super::io::*;
    use super::params::*;
    use super::potentials::*;
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
        let k = CubicSpline::new(0.1);
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
        let k = CubicSpline::new(0.1);
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
