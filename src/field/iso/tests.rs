//! Tests of the iso surface's CPU field: the grid, 1/n, the kernel, the anisotropic kernels, the volume's bricks.
use super::*;
use crate::field::volume::*;
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
        rest_lanes: 1,
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

/// The sum that skips cells and points beyond the support equals the plain sum over the 3×3×3 cells bit for
/// bit (the GPU computes the plain sum): a jittered block of particles, cells exactly the support wide and
/// wider.
#[test]
fn inv_density_equals_the_full_cell_sum_bit_for_bit() {
    let mut pts = vec![];
    let mut seed = 0x2545_f491_u32;
    let mut jitter = || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        (seed as f32 / u32::MAX as f32 - 0.5) * 0.01
    };
    for i in 0..20 {
        for j in 0..20 {
            for k in 0..12 {
                pts.push([i as f32 * 0.02 + jitter(), j as f32 * 0.02 + jitter(), k as f32 * 0.02 + jitter()]);
            }
        }
    }
    for reach in [0.05, 0.07] {
        let g = IsoGrid::build_reaching(&pts, 0.05, reach);
        let full: Vec<f32> = g
            .points
            .iter()
            .map(|p| {
                let x = Vec3::new(p[0], p[1], p[2]);
                let mut s = 0.0;
                g.for_each_near(x, |_, y| s += kernel(x.distance(y) / g.support));
                1.0 / s
            })
            .collect();
        let got = g.inv_density();
        assert!(full.iter().zip(&got).all(|(a, b)| a.to_bits() == b.to_bits()), "cells {reach}");
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

/// The smoothed field's parameters at their defaults for particles of radius `r` (σ 1.1 r, 2 r on a lattice).
fn default_volume(r: f32) -> VolumeParams {
    VolumeParams {
        sigma: 1.1 * r,
        bulk: [4.0, 9.0],
        spacing: 2.0 * r,
        support: 4.0 * r,
        lattice_sigma: 2.0 * r,
        particle_spacing: 2.0 * r,
    }
}

/// `marked` (one neighbour mask per point's brick, chunks in parallel) marks exactly the bricks of every
/// point's box, as marking each box brick by brick does: points inside the box, on brick faces, and
/// outside it on every side (clamped into the lattice's margin).
#[test]
fn marked_bricks_are_each_points_box() {
    let r = 0.01;
    let p = default_volume(r);
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
    let p = default_volume(r);
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
    let (lo, hi) = pts.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), &q| (a.min(q), b.max(q)));
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

/// The lattice order (what widens the blur where particles sit on a lattice): 1 on a cubic lattice, exact or
/// jittered by ±5 % per axis (the built-in scenes), at its faces and edges too (a jittered corner, with fewer
/// near neighbours, at least ½); 0 for most particles of the same lattice jittered by ±25 % (a disordered
/// liquid's neighbour distances) and for isolated spray.
#[test]
fn lattice_order_is_one_on_a_lattice_and_zero_in_a_liquid_and_in_spray() {
    let r = 0.01;
    let mut seed = 3u32;
    let mut rnd = move || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
    };
    let mut block = |jitter: f32| -> Vec<[f32; 3]> {
        let mut p = vec![];
        for k in 0..10 {
            for j in 0..8 {
                for i in 0..10 {
                    p.push([i, j, k].map(|c| (c as f32 + jitter * rnd()) * 2.0 * r));
                }
            }
        }
        p
    };
    let orders = |pts: &[[f32; 3]]| -> Vec<f32> {
        IsoGrid::build(pts, 4.0 * r).volume_weights(2.0 * r).iter().map(|w| w[1]).collect()
    };
    for jitter in [0.0, 0.1] {
        let o = orders(&block(jitter));
        let least = o.iter().copied().fold(1.0f32, f32::min);
        let whole = o.iter().filter(|&&o| o > 0.99).count();
        assert!(
            least > 0.5 && whole + 8 >= o.len(),
            "a lattice jittered by {jitter}: least order {least}, {whole} of {} at 1",
            o.len()
        );
    }
    let liquid = orders(&block(0.5));
    let ordered = liquid.iter().filter(|&&o| o > 0.5).count();
    assert!(ordered * 20 < liquid.len(), "{ordered} of {} disordered particles counted as a lattice", liquid.len());
    let spray: Vec<[f32; 3]> = (0..20).map(|k| [k as f32 * 0.2, 0.0, 0.0]).collect();
    assert!(orders(&spray).iter().all(|&o| o == 0.0), "isolated particles are not a lattice");
}
