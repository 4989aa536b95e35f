//! The marching cubes against their references: the case table, the block and per-corner paths, watertightness.

use super::blocks::extract_blocks_keyed;
use super::*;

/// Uniform numbers in [0, 1) from a linear congruential generator seeded with `seed` (the tests' clouds).
fn uniform(mut seed: u32) -> impl FnMut() -> f32 {
    move || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        (seed >> 8) as f32 / (1 << 24) as f32
    }
}

/// Every pattern's triangles close up across a cube with random corner values, and a whole random field
/// gives a closed, consistently oriented mesh (the generated table's contract).
#[test]
fn table_gives_closed_oriented_meshes() {
    let t = case_table();
    assert!(t[0].is_empty() && t[255].is_empty());
    assert_eq!(t[1].len(), 1);
    // One inside corner (0): the triangle faces away from it.
    let tri = t[1][0].map(|e| {
        let (a, b, _) = EDGES[e as usize];
        (corner_pos(a) + corner_pos(b)) * 0.5
    });
    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
    assert!(n.dot(Vec3::ONE) > 0.0, "mask 1's triangle must point away from corner 0");
    assert!(t.iter().all(|c| c.len() <= 6));
}

/// The metaball field: one particle's surface at the analytic distance; a random cloud closed and oriented.
#[test]
fn metaball_field() {
    let (r, rc) = (0.1f32, 0.3f32);
    let t = metaball_threshold(r, rc);
    let one = IsoGrid::build(&[[0.3, 0.2, 0.1]], rc);
    let p = ExtractParams { metaball: true, ..ExtractParams::new(0.25 * r, t) };
    let m = extract(&one, &one.inv_density(), &p);
    assert!(m.triangles.len() > 100);
    assert_eq!(open_or_flipped_edges(&m), 0);
    for v in &m.vertices {
        let d = (Vec3::from(*v) - Vec3::new(0.3, 0.2, 0.1)).length();
        assert!((d - r).abs() < 0.02 * r, "vertex at {d}, the surface is at {r}");
    }
    let pts: Vec<[f32; 3]> = (0..200)
        .map(|i| [(i * 37 % 101) as f32 * 0.01, (i * 59 % 97) as f32 * 0.005, (i % 13) as f32 * 0.03])
        .collect();
    let g = IsoGrid::build(&pts, 0.09);
    let m = extract(
        &g,
        &g.inv_density(),
        &ExtractParams { metaball: true, ..ExtractParams::new(0.015, metaball_threshold(0.03, 0.09)) },
    );
    assert!(m.triangles.len() > 1000);
    assert_eq!(open_or_flipped_edges(&m), 0);
}

/// One particle: a closed sphere whose vertices sit where the field equals the threshold; two far
/// particles: two components; random clouds: closed and consistently oriented; 1 and 2 threads agree.
#[test]
fn single_pair_and_random_particles() {
    let r = 0.1f32;
    let one = IsoGrid::build(&[[0.3, 0.2, 0.1]], 4.0 * r);
    let inv = one.inv_density();
    let m = extract(&one, &inv, &ExtractParams::new(0.25 * r, 0.6));
    assert!(m.triangles.len() > 100);
    assert_eq!(open_or_flipped_edges(&m), 0);
    // The analytic radius where one particle's normalised field W(d/h)/W(0) equals the threshold.
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    for _ in 0..60 {
        let q = 0.5 * (lo + hi);
        if crate::field::iso::kernel(q) > 0.6 {
            lo = q;
        } else {
            hi = q;
        }
    }
    let want = lo * 4.0 * r;
    let c = Vec3::new(0.3, 0.2, 0.1);
    for (v, n) in m.vertices.iter().zip(&m.normals) {
        let d = (Vec3::from(*v) - c).length();
        assert!((d - want).abs() < 0.02 * r, "vertex at {d}, the surface is at {want}");
        assert!(Vec3::from(*n).dot(Vec3::from(*v) - c) > 0.0, "vertex normal points into the fluid");
    }
    for t in &m.triangles {
        let [a, b, cc] = t.map(|i| Vec3::from(m.vertices[i as usize]));
        assert!((b - a).cross(cc - a).dot(a - c) >= 0.0, "triangle faces into the fluid");
    }
    let two = IsoGrid::build(&[[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]], 4.0 * r);
    let m2 = extract(&two, &two.inv_density(), &ExtractParams::new(0.25 * r, 0.6));
    assert_eq!(open_or_flipped_edges(&m2), 0);
    let ratio = m2.triangles.len() as f32 / m.triangles.len() as f32;
    assert!((ratio - 2.0).abs() < 0.1, "two far particles: {ratio} × one particle's triangles");
    let mut rnd = uniform(12345u32);
    let pts: Vec<[f32; 3]> = (0..300).map(|_| [rnd() * 0.8, rnd() * 0.5, rnd() * 0.6]).collect();
    let g = IsoGrid::build(&pts, 4.0 * 0.03);
    let inv = g.inv_density();
    let p = ExtractParams { block: 0, ..ExtractParams::new(0.015, 0.6) };
    let a = extract(&g, &inv, &p);
    // Surface following gives exactly the mesh of the dense reference (no closed cavities here).
    let dense = extract(&g, &inv, &ExtractParams { dense: true, ..p });
    assert_eq!(a, dense, "surface following and the dense evaluation differ");
    assert!(a.triangles.len() > 1000);
    assert_eq!(open_or_flipped_edges(&a), 0);
    let b = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| extract(&g, &inv, &p));
    assert_eq!(a, b, "1 thread and the default pool give the same mesh");
    // Blocks: one big block and many small ones (and 1 or 2 threads) give exactly the same mesh up to the order
    // of vertices and triangles (each block numbers its own edges' vertices), in edge-key order the same ...
    let blocks = |block: u32| {
        let (m, keys, _) = extract_blocks_keyed(&g, &inv, &ExtractParams { block, ..p });
        assert_eq!(open_or_flipped_edges(&m), 0, "block {block}");
        m.in_key_order(&keys).expect("an edge has two vertices")
    };
    let big = blocks(256);
    for block in [3, 8, 32] {
        assert_eq!(blocks(block), big, "block {block} differs from one block");
    }
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| blocks(8));
    assert_eq!(one, big, "1 thread differs");
    // ... and one block size gives the same mesh in the same order on any thread count.
    let (m8, _, _) = extract_blocks_keyed(&g, &inv, &ExtractParams { block: 8, ..p });
    let (m8_one, _, _) = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| extract_blocks_keyed(&g, &inv, &ExtractParams { block: 8, ..p }));
    assert_eq!(m8, m8_one, "block 8 on 1 thread and on the pool");
    // ... and the surface of the per-corner reference: the corner values differ only in the order of their
    // sums, so the same triangles and vertices within 1e-5 of the cube; normals (lattice central
    // differences over one cube, Lorensen & Cline's choice, vs the field's gradient over a quarter cube) within
    // 2° at the median and 12° at the 99th percentile (measured 1.2° and ~10°: thin features of a random
    // cloud vary within one cube).
    let mut a_tris = a.triangles.clone();
    a_tris.sort_unstable();
    assert_eq!(big.triangles, a_tris);
    let mut angles = vec![];
    for ((v, w), (n, m)) in big.vertices.iter().zip(&a.vertices).zip(big.normals.iter().zip(&a.normals)) {
        assert!((Vec3::from(*v) - Vec3::from(*w)).length() < 1e-5 * p.cube.max(1.0));
        angles.push(Vec3::from(*n).dot(Vec3::from(*m)).clamp(-1.0, 1.0).acos().to_degrees());
    }
    angles.sort_by(f32::total_cmp);
    let (median, p99) = (angles[angles.len() / 2], angles[angles.len() * 99 / 100]);
    assert!(median < 2.0 && p99 < 12.0, "normal angles: median {median}°, p99 {p99}°");
}

/// The block size's choice: the bit count of occupied blocks equals the listed blocks; blocks of 32 where blocks of
/// 64 would leave fewer than AUTO_BLOCK_MIN, 64 where they would not — from the particles and the cube alone.
#[test]
fn the_block_size_follows_the_occupied_blocks() {
    let mut rnd = uniform(777u32);
    let pts: Vec<[f32; 3]> = (0..2000).map(|_| [rnd() * 2.0, rnd() * 0.3, rnd() * 1.0]).collect();
    let g = IsoGrid::build(&pts, 4.0 * 0.02);
    let lat = Lattice::of(&g, 0.01);
    for b in [3, 16, 32, 64] {
        assert_eq!(blocks::occupied_count(&g, &lat, b), occupied_blocks(&g, &lat, b).0.len(), "blocks of {b}");
    }
    let n64 = occupied_blocks(&g, &lat, 64).0.len();
    assert!(n64 < AUTO_BLOCK_MIN, "the cloud is small enough for the choice to matter: {n64} blocks of 64");
    assert_eq!(auto_block(&g, 0.01), 32);
    // A cube a quarter as large: 4³ × as many blocks of 64.
    assert!(occupied_blocks(&g, &Lattice::of(&g, 0.0025), 64).0.len() >= AUTO_BLOCK_MIN);
    assert_eq!(auto_block(&g, 0.0025), 64);
}
