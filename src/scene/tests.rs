//! Tests of scene/mod.rs: spacing, bounds and the other helpers over loaded particles.

use super::*;

#[test]
fn spacing_of_a_grid() {
    let mut pos = vec![];
    for z in 0..20 {
        for y in 0..20 {
            for x in 0..20 {
                pos.push([x as f32 * 0.025, y as f32 * 0.025, z as f32 * 0.025]);
            }
        }
    }
    let s = estimate_spacing(&pos).unwrap();
    assert!((s - 0.025).abs() < 1e-4, "{s}");
    assert!((estimate_radius(&pos).unwrap() - 0.0125).abs() < 1e-4);
}

#[test]
fn isolated_particles_are_marked_isolated() {
    let mut pos = vec![];
    for z in 0..8 {
        for y in 0..8 {
            for x in 0..8 {
                pos.push([x as f32 * 0.02, y as f32 * 0.02, z as f32 * 0.02]);
            }
        }
    }
    pos.push([1.0, 1.0, 1.0]);
    let p = Particles { positions: pos, ..Default::default() };
    let m = isolated_mask(&p, 0.01, 0.5);
    assert!(m[512] && !m[100] && m.iter().filter(|x| **x).count() < 20);
    // With densities from the file.
    let p2 = Particles {
        densities: Some(vec![1000.0, 990.0, 300.0, 1010.0]),
        positions: vec![[0.0; 3]; 4],
        ..Default::default()
    };
    assert_eq!(isolated_mask(&p2, 0.01, 0.6), vec![false, false, true, false]);
    assert_eq!(isolated_mask(&p2, 0.01, 0.0), vec![false; 4]);
}

#[test]
fn non_finite_positions_are_dropped_with_their_attributes() {
    let raw = Raw {
        positions: vec![[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [1.0, f32::INFINITY, 0.0], [2.0, 2.0, 2.0]],
        arrays: vec![
            Attribute { name: "density".into(), components: 1, data: vec![1.0, 2.0, 3.0, 4.0] },
            Attribute { name: "velocity".into(), components: 3, data: (0..12).map(f64::from).collect() },
            Attribute { name: "odd".into(), components: 1, data: vec![9.0] },
        ],
    };
    let p = raw.into_particles(&LoadOptions::default());
    assert_eq!(p.dropped_non_finite, 2);
    assert_eq!(p.positions, vec![[0.0, 0.0, 0.0], [2.0, 2.0, 2.0]]);
    assert_eq!(p.densities, Some(vec![1.0, 4.0]));
    assert_eq!(p.velocities, Some(vec![[0.0, 1.0, 2.0], [9.0, 10.0, 11.0]]));
    assert_eq!(p.extra[0].data, vec![9.0], "an array of another length is left alone");
}

#[test]
fn radius_from_number_density_of_a_disordered_packing() {
    // A lattice of spacing 0.025 (r = 0.0125) jittered by ±15 % of the spacing: the nearest neighbours crowd in
    // (half their median distance drops well below r) while the number density stays 1/(2r)³.
    let mut pos = vec![];
    let mut seed = 12345u32;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        seed as f32 / u32::MAX as f32 - 0.5
    };
    for z in 0..24 {
        for y in 0..24 {
            for x in 0..24 {
                let j = 0.3 * 0.025;
                pos.push([
                    (x as f32 + 0.0) * 0.025 + j * rnd(),
                    y as f32 * 0.025 + j * rnd(),
                    z as f32 * 0.025 + j * rnd(),
                ]);
            }
        }
    }
    let nn_half = 0.5 * estimate_spacing(&pos).unwrap();
    let r = estimate_radius(&pos).unwrap();
    assert!(nn_half < 0.0115, "the nearest-neighbour estimate should be fooled here: {nn_half}");
    // A random jitter is less uniform than an SPH fluid (the shared frames come within 1 %).
    assert!((r - 0.0125).abs() < 0.025 * 0.0125, "number-density radius {r}");
}

#[test]
fn the_fluid_box_leaves_strays_out() {
    let mut pos: Vec<[f32; 3]> = (0..1000).map(|i| [(i % 10) as f32 * 0.1, (i / 100) as f32 * 0.1, 0.0]).collect();
    pos.push([4.5, 0.2, 0.0]); // a droplet beside the water stays
    pos.push([1e6, 0.0, 0.0]); // a stray does not
    let (b, out) = fluid_bounds(&pos, 0.0).unwrap();
    assert_eq!(out, 1);
    assert_eq!(b.hi.x, 4.5);
    assert_eq!(b.lo, Vec3::new(0.0, 0.0, 0.0));
}

#[test]
fn percentiles_ignore_strays() {
    let mut pos: Vec<[f32; 3]> = (0..1000).map(|i| [(i % 10) as f32, (i / 100) as f32, 0.0]).collect();
    pos.push([1e6, 0.0, 0.0]);
    let b = percentile_bounds(&pos, 0.01).unwrap();
    assert!(b.hi.x <= 9.0);
}

/// The percentiles are the sorted values' entries (negative and positive values, NaN and infinities
/// left out), for low and high percentiles and the median.
#[test]
fn percentiles_are_the_sorted_values() {
    let mut seed = 5u32;
    let mut rnd = move || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) as f32 / (1u32 << 24) as f32 * 20.0 - 10.0
    };
    let mut pos: Vec<[f32; 3]> = (0..5000).map(|_| [rnd(), rnd() * 1e-3, -rnd().abs()]).collect();
    pos.extend([[f32::NAN, f32::INFINITY, f32::NEG_INFINITY], [-0.0, 0.0, -0.0]]);
    for p in [0.01, 0.25, 0.5, 0.75, 0.99] {
        let b = percentile_bounds(&pos, p).unwrap();
        for a in 0..3 {
            let mut v: Vec<f32> = pos.iter().map(|q| q[a]).filter(|x| x.is_finite()).collect();
            v.sort_by(f32::total_cmp);
            let n = v.len() - 1;
            let (lo, hi) = (v[(n as f64 * p).round() as usize], v[(n as f64 * (1.0 - p)).round() as usize]);
            assert_eq!((b.lo[a].to_bits(), b.hi[a].to_bits()), (lo.to_bits(), hi.to_bits()), "p {p} axis {a}");
        }
    }
}
