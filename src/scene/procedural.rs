//! Built-in procedural scenes that need no files, deterministic for a given particle count.
//! Units are metres, y up; the particle radius is half the lattice spacing, chosen to hit the count.
//! * `block` — a dense cube of particles (the worst case when it fills the screen);
//! * `wave`  — a pool with a breaking wave crest moving in +x (Moritz's "wave" workload, 143,944 by default);
//! * `drop`  — a still pool with a sphere of water falling into it and a crown rising where it lands.

use crate::error::{Error, Result};
use crate::scene::Particles;

/// Names of the built-in scenes and their default particle counts.
pub const SCENES: &[(&str, usize, &str)] = &[
    ("block", 65_536, "a dense cube of particles"),
    ("wave", 143_944, "a pool with a breaking wave crest"),
    ("drop", 100_000, "a drop falling into a pool, crown rising"),
    ("crown", 157_944, "a crown splash: a thin rising ring around an impact crater"),
    ("waterfall", 819_417, "a falling sheet of water over a ledge into a pool"),
];

/// A generated scene and the radius it was generated with.
pub struct Generated {
    /// The particles.
    pub particles: Particles,
    /// The radius they were made for.
    pub radius: f32,
}

/// Small deterministic jitter in [−0.5, 0.5) from a lattice index (so the lattice does not alias).
fn jitter(i: u32, k: u32) -> f32 {
    let mut h = i.wrapping_mul(0x9E37_79B9) ^ k.wrapping_mul(0x85EB_CA6B);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7FEB_352D);
    h ^= h >> 15;
    (h as f32 / u32::MAX as f32) - 0.5
}

/// Fill the region `inside(x, y, z)` within the box [lo, hi] on a lattice of spacing `s`.
fn fill(
    lo: [f32; 3],
    hi: [f32; 3],
    s: f32,
    inside: &dyn Fn(f32, f32, f32) -> bool,
    vel: &dyn Fn(f32, f32, f32) -> [f32; 3],
) -> Particles {
    let n = |a: usize| ((hi[a] - lo[a]) / s).floor().max(0.0) as u32 + 1;
    let (nx, ny, nz) = (n(0), n(1), n(2));
    let mut p =
        Particles { velocities: Some(vec![]), densities: Some(vec![]), ids: Some(vec![]), ..Default::default() };
    let mut id = 0i64;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let lin = (k * ny + j) * nx + i;
                let x = lo[0] + (i as f32 + 0.5 + 0.1 * jitter(lin, 1)) * s;
                let y = lo[1] + (j as f32 + 0.5 + 0.1 * jitter(lin, 2)) * s;
                let z = lo[2] + (k as f32 + 0.5 + 0.1 * jitter(lin, 3)) * s;
                if x > hi[0] || y > hi[1] || z > hi[2] || !inside(x, y, z) {
                    continue;
                }
                p.positions.push([x, y, z]);
                p.velocities.as_mut().unwrap().push(vel(x, y, z));
                p.densities.as_mut().unwrap().push(1000.0);
                p.ids.as_mut().unwrap().push(id);
                id += 1;
            }
        }
    }
    p
}

fn wave_height(x: f32, z: f32) -> f32 {
    // Calm water 0.3 m deep, a crest 0.55 m high centred at x = 2.6 with a steep front and ripples.
    let u = x - 2.6;
    let crest = if u < 0.0 { (-(u / 0.9).powi(2)).exp() } else { (-(u / 0.25).powi(2)).exp() };
    0.3 + 0.55 * crest + 0.02 * (6.0 * z + 3.0 * x).sin()
}

/// Generate scene `name` with about `count` particles.
pub fn generate(name: &str, count: usize) -> Result<Generated> {
    if count == 0 || count > 64_000_000 {
        return Err(Error::Invalid(format!("particle count {count} is out of range (1 … 64,000,000)")));
    }
    // Find the lattice spacing by the region's volume, then refine once on the real count.
    let build = |s: f32| -> Result<Particles> {
        Ok(match name {
            "block" => fill([0.0; 3], [1.0; 3], s, &|_, _, _| true, &|_, _, _| [0.0; 3]),
            "wave" => fill([0.0, 0.0, 0.0], [4.0, 0.9, 1.5], s, &|x, y, z| y < wave_height(x, z), &|x, y, _| {
                let u = x - 2.6;
                let push = (-(u / 0.6).powi(2)).exp();
                [2.5 * push * (0.5 + y), 0.8 * push * (-u).signum().max(0.0), 0.0]
            }),
            "drop" => fill(
                [0.0, 0.0, 0.0],
                [2.0, 1.3, 2.0],
                s,
                &|x, y, z| {
                    let (dx, dz) = (x - 1.0, z - 1.0);
                    let rr = (dx * dx + dz * dz).sqrt();
                    let pool = y < 0.25;
                    let crown = (rr - 0.32).abs() < 0.05 && y < 0.25 + 0.22 * (1.0 + 0.4 * (8.0 * dz.atan2(dx)).sin());
                    let drop = dx * dx + (y - 0.95).powi(2) + dz * dz < 0.15 * 0.15;
                    pool || crown || drop
                },
                &|x, y, z| {
                    if y > 0.7 {
                        [0.0, -3.0, 0.0]
                    } else {
                        [(x - 1.0) * 2.0, 1.5 * (y > 0.25) as i32 as f32, (z - 1.0) * 2.0]
                    }
                },
            ),
            "crown" => fill(
                [0.0, 0.0, 0.0],
                [2.0, 1.0, 2.0],
                s,
                &|x, y, z| {
                    let (dx, dz) = (x - 1.0, z - 1.0);
                    let rr = (dx * dx + dz * dz).sqrt();
                    let a = dz.atan2(dx);
                    let pool = y < 0.12 && (rr > 0.25 || y < 0.12 - 0.08 * (1.0 - rr / 0.25));
                    let top = 0.12 + 0.45 * (1.0 + 0.25 * (12.0 * a).cos());
                    let wall = (rr - 0.3 - 0.15 * (y - 0.12)).abs() < 0.025 && y < top;
                    // Droplets at the rim's spikes.
                    let spike = (12.0 * a).cos() > 0.97
                        && (rr - 0.3 - 0.15 * (top - 0.12)).abs() < 0.03
                        && (y - top - 0.06).abs() < 0.03;
                    pool || wall || spike
                },
                &|x, y, z| [(x - 1.0) * 1.5, 2.0 * (y > 0.12) as i32 as f32, (z - 1.0) * 1.5],
            ),
            "waterfall" => fill(
                [0.0, 0.0, 0.0],
                [3.0, 2.0, 1.5],
                s,
                &|x, y, _z| {
                    let upper = x < 1.0 && y > 1.5 && y < 1.7;
                    // The sheet leaves the ledge at x = 1 and follows a ballistic curve.
                    let t = ((x - 1.0) / 1.2).max(0.0);
                    let centre = 1.6 - 4.9 * t * t;
                    let sheet = x >= 1.0 && (y - centre).abs() < 0.05 + 0.05 * t && y > 0.2;
                    let pool = y < 0.2 && x > 0.8;
                    upper || sheet || pool
                },
                &|x, y, _| if x < 1.0 && y > 1.4 { [1.2, 0.0, 0.0] } else { [1.2, -3.0, 0.0] },
            ),
            other => {
                let known: Vec<&str> = SCENES.iter().map(|s| s.0).collect();
                return Err(Error::Invalid(format!("unknown scene {other:?} (built-in scenes: {})", known.join(", "))));
            }
        })
    };
    let probe_s = 0.05;
    let probe = build(probe_s)?;
    let vol = probe.len().max(1) as f32 * probe_s.powi(3);
    let mut s = (vol / count as f32).cbrt();
    let mut p = build(s)?;
    // One correction step on the real count.
    s *= (p.len() as f32 / count as f32).cbrt();
    if p.len() != count {
        p = build(s)?;
    }
    Ok(Generated { particles: p, radius: 0.5 * s })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_are_close_and_deterministic() {
        for (name, _, _) in SCENES {
            let g = generate(name, 20_000).unwrap();
            let n = g.particles.len() as f32;
            assert!((n / 20_000.0 - 1.0).abs() < 0.1, "{name}: {n}");
            assert_eq!(generate(name, 20_000).unwrap().particles, g.particles);
            let est = crate::scene::estimate_radius(&g.particles.positions).unwrap();
            assert!((est / g.radius - 1.0).abs() < 0.15, "{name}: estimated {est} vs {}", g.radius);
        }
    }

    #[test]
    fn unknown_scene_is_an_error() {
        assert!(generate("pool-party", 10).is_err());
    }
}
