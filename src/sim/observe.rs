//! Observables that move with the flow, for comparing two particle sets of one scene frame by frame (this
//! solver against SPlisHSPlasH's own output of the same scene file, say). Each is a number a wrong simulation
//! changes:
//! - **occupancy IoU**: the cells of a grid of edge 2 r that hold at least one particle, intersection over union
//!   of the two sets' cells (1 = the water occupies the same cells);
//! - **height field**: per column of that grid in x–z, the highest particle's y; the RMS difference over the
//!   columns either set occupies (a column one set leaves empty counts at the `floor`), in particle radii;
//! - **kinetic energy** ½|v|² and **potential energy** g·(y − floor), per unit mass (equal particle masses);
//! - **centre of mass**, and the distance between the two, in radii.
//!
//! These replace "the largest |x| of any particle" as the double dam break's front: the two columns start
//! against the tank's walls, so that value stays within 2 % of a constant whether or not the water moves.

use glam::Vec3;
use std::collections::HashSet;

/// What one particle set is, for [`compare`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Observables {
    /// Mean ½|v|² (J/kg); NaN without velocities.
    pub kinetic: f64,
    /// Mean g·(y − floor) (J/kg).
    pub potential: f64,
    /// Centre of mass (m).
    pub centre: [f64; 3],
}

/// Two sets of one frame compared ([`compare`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Agreement {
    /// Occupancy intersection over union on the grid of edge 2 r.
    pub iou: f64,
    /// RMS of the height-field difference, in radii.
    pub height_rms_radii: f64,
    /// Relative kinetic-energy difference |a − b| / b (NaN where either has no velocities).
    pub kinetic: f64,
    /// Relative potential-energy difference |a − b| / b.
    pub potential: f64,
    /// Distance between the centres of mass, in radii.
    pub centre_radii: f64,
}

/// [`Observables`] of `positions` (and `velocities`, when given) with gravity `g` (m/s², positive) above `floor`.
pub fn observe(positions: &[[f32; 3]], velocities: Option<&[[f32; 3]]>, g: f64, floor: f64) -> Observables {
    let n = positions.len().max(1) as f64;
    let mut c = [0.0f64; 3];
    for p in positions {
        for a in 0..3 {
            c[a] += p[a] as f64;
        }
    }
    let centre = c.map(|x| x / n);
    let potential = g * (centre[1] - floor);
    let kinetic = match velocities {
        Some(v) if !v.is_empty() => v.iter().map(|v| 0.5 * Vec3::from(*v).length_squared() as f64).sum::<f64>() / n,
        _ => f64::NAN,
    };
    Observables { kinetic, potential, centre }
}

fn cell(p: &[f32; 3], origin: Vec3, edge: f32) -> [i32; 3] {
    let q = (Vec3::from(*p) - origin) / edge;
    [q.x.floor() as i32, q.y.floor() as i32, q.z.floor() as i32]
}

/// The two sets compared on a grid of edge `2 r` anchored at `origin` (the tank's lower corner, so both sets
/// share it), gravity `g` above `floor`.
pub fn compare(
    a: (&[[f32; 3]], Option<&[[f32; 3]]>),
    b: (&[[f32; 3]], Option<&[[f32; 3]]>),
    r: f32,
    origin: [f32; 3],
    g: f64,
    floor: f64,
) -> Agreement {
    let (edge, o) = (2.0 * r, Vec3::from(origin));
    let cells = |p: &[[f32; 3]]| p.iter().map(|q| cell(q, o, edge)).collect::<HashSet<_>>();
    let (ca, cb) = (cells(a.0), cells(b.0));
    let inter = ca.intersection(&cb).count();
    let union = ca.len() + cb.len() - inter;
    let iou = if union == 0 { 1.0 } else { inter as f64 / union as f64 };
    let heights = |p: &[[f32; 3]]| {
        let mut h = std::collections::HashMap::<(i32, i32), f32>::new();
        for q in p {
            let c = cell(q, o, edge);
            let e = h.entry((c[0], c[2])).or_insert(f32::NEG_INFINITY);
            *e = e.max(q[1]);
        }
        h
    };
    let (ha, hb) = (heights(a.0), heights(b.0));
    let columns: HashSet<_> = ha.keys().chain(hb.keys()).copied().collect();
    let sq: f64 = columns
        .iter()
        .map(|k| {
            let ya = ha.get(k).map_or(floor, |&y| y as f64);
            let yb = hb.get(k).map_or(floor, |&y| y as f64);
            (ya - yb).powi(2)
        })
        .sum();
    let height_rms_radii = (sq / columns.len().max(1) as f64).sqrt() / r as f64;
    let (oa, ob) = (observe(a.0, a.1, g, floor), observe(b.0, b.1, g, floor));
    let rel = |x: f64, y: f64| (x - y).abs() / y.abs().max(1e-12);
    let d = (0..3).map(|k| (oa.centre[k] - ob.centre[k]).powi(2)).sum::<f64>().sqrt();
    Agreement {
        iou,
        height_rms_radii,
        kinetic: rel(oa.kinetic, ob.kinetic),
        potential: rel(oa.potential, ob.potential),
        centre_radii: d / r as f64,
    }
}

/// Bounds a frame's [`Agreement`] must meet; [`Gate::check`] names the first one it breaks.
#[derive(Clone, Copy, Debug)]
pub struct Gate {
    /// Occupancy IoU at least this.
    pub iou: f64,
    /// Height-field RMS at most this many radii.
    pub height_rms_radii: f64,
    /// Kinetic energy within this fraction.
    pub kinetic: f64,
    /// Potential energy within this fraction.
    pub potential: f64,
    /// Centres of mass at most this many radii apart.
    pub centre_radii: f64,
}

impl Gate {
    /// `Err` naming every bound `x` breaks, with its value.
    pub fn check(&self, x: &Agreement) -> std::result::Result<(), String> {
        let mut broken = vec![];
        // Each test as "within", so a NaN is outside.
        let (iou, height) = (x.iou >= self.iou, x.height_rms_radii <= self.height_rms_radii);
        let (kinetic, potential) = (x.kinetic.is_nan() || x.kinetic <= self.kinetic, x.potential <= self.potential);
        let centre = x.centre_radii <= self.centre_radii;
        if !iou {
            broken.push(format!("occupancy IoU {:.3} < {:.3}", x.iou, self.iou));
        }
        if !height {
            broken.push(format!("height-field RMS {:.2} r > {:.2} r", x.height_rms_radii, self.height_rms_radii));
        }
        if !kinetic {
            broken.push(format!("kinetic energy off by {:.1} % > {:.1} %", 100.0 * x.kinetic, 100.0 * self.kinetic));
        }
        if !potential {
            broken.push(format!(
                "potential energy off by {:.2} % > {:.2} %",
                100.0 * x.potential,
                100.0 * self.potential
            ));
        }
        if !centre {
            broken.push(format!("centres of mass {:.2} r apart > {:.2} r", x.centre_radii, self.centre_radii));
        }
        if broken.is_empty() {
            Ok(())
        } else {
            Err(broken.join("; "))
        }
    }
}

/// Per frame, the worst of each observable over a run: the least IoU, the largest of the others.
pub fn worst(frames: &[Agreement]) -> Agreement {
    frames.iter().fold(
        Agreement { iou: 1.0, height_rms_radii: 0.0, kinetic: 0.0, potential: 0.0, centre_radii: 0.0 },
        |w, x| Agreement {
            iou: w.iou.min(x.iou),
            height_rms_radii: w.height_rms_radii.max(x.height_rms_radii),
            kinetic: if x.kinetic.is_nan() { w.kinetic } else { w.kinetic.max(x.kinetic) },
            potential: w.potential.max(x.potential),
            centre_radii: w.centre_radii.max(x.centre_radii),
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block(lo: [f32; 3], n: [u32; 3], d: f32) -> Vec<[f32; 3]> {
        let mut v = vec![];
        for i in 0..n[0] {
            for j in 0..n[1] {
                for k in 0..n[2] {
                    v.push([lo[0] + (i as f32 + 0.5) * d, lo[1] + (j as f32 + 0.5) * d, lo[2] + (k as f32 + 0.5) * d]);
                }
            }
        }
        v
    }

    /// A set against itself agrees exactly; the same set moved by 4 r, or a column half as high, does not.
    #[test]
    fn the_observables_see_a_moved_or_collapsed_column() {
        let r = 0.01;
        let a = block([0.0; 3], [10, 20, 10], 2.0 * r);
        let same = compare((&a, None), (&a, None), r, [0.0; 3], 9.81, 0.0);
        assert_eq!((same.iou, same.height_rms_radii, same.centre_radii, same.potential), (1.0, 0.0, 0.0, 0.0));
        let gate = Gate { iou: 0.9, height_rms_radii: 2.0, kinetic: 0.1, potential: 0.02, centre_radii: 1.0 };
        assert!(gate.check(&same).is_ok());
        let moved: Vec<[f32; 3]> = a.iter().map(|p| [p[0] + 4.0 * r, p[1], p[2]]).collect();
        let m = compare((&moved, None), (&a, None), r, [0.0; 3], 9.81, 0.0);
        assert!(m.iou < 0.9 && (m.centre_radii - 4.0).abs() < 1e-3, "{m:?}");
        assert!(gate.check(&m).unwrap_err().contains("IoU"));
        let low = block([0.0; 3], [20, 10, 10], 2.0 * r);
        let l = compare((&low, None), (&a, None), r, [0.0; 3], 9.81, 0.0);
        assert!(l.height_rms_radii > 5.0 && l.potential > 0.4, "{l:?}");
        let e = gate.check(&l).unwrap_err();
        assert!(e.contains("height-field") && e.contains("potential"), "{e}");
        // Kinetic energy: the same positions at twice the speed.
        let v1 = vec![[1.0f32, 0.0, 0.0]; a.len()];
        let v2 = vec![[2.0f32, 0.0, 0.0]; a.len()];
        let k = compare((&a, Some(&v2)), (&a, Some(&v1)), r, [0.0; 3], 9.81, 0.0);
        assert!((k.kinetic - 3.0).abs() < 1e-9 && gate.check(&k).unwrap_err().contains("kinetic"), "{k:?}");
        let w = worst(&[same, m, l]);
        assert_eq!((w.iou, w.height_rms_radii), (m.iou.min(l.iou), l.height_rms_radii.max(m.height_rms_radii)));
    }
}
