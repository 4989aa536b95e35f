//! Loaders: round trips on generated data, malformed files (truncated, wrong magic, counts larger than the
//! data) → an error naming the file and the problem; the shared SPlisHSPlasH data when present.

use std::path::{Path, PathBuf};

use meniscus::scene::{self, bgeo, vtk, Particles};
use meniscus::Error;

fn sample(n: usize) -> Particles {
    Particles {
        positions: (0..n).map(|i| [i as f32 * 0.5, -(i as f32), 0.25 * i as f32]).collect(),
        velocities: Some((0..n).map(|i| [1.0, i as f32, -2.0]).collect()),
        densities: Some((0..n).map(|i| 1000.0 + i as f32).collect()),
        ids: Some((0..n as i64).rev().collect()),
    }
}

fn tmp(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("meniscus-loader-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn bgeo_round_trip_plain_and_gzip() {
    let p = sample(37);
    for gz in [false, true] {
        let path = tmp(&format!("rt{gz}.bgeo"), &bgeo::write(&p, gz));
        assert_eq!(scene::load(&path).unwrap(), p);
    }
}

#[test]
fn vtk_round_trip_ascii_and_binary() {
    let p = sample(23);
    for bin in [false, true] {
        let path = tmp(&format!("rt{bin}.vtk"), &vtk::write(&p, bin));
        assert_eq!(scene::load(&path).unwrap(), p, "binary={bin}");
    }
}

#[test]
fn format_is_detected_from_content_not_extension() {
    let p = sample(5);
    let path = tmp("actually_vtk.bgeo", &vtk::write(&p, true));
    assert_eq!(scene::load(&path).unwrap(), p);
    let path = tmp("actually_bgeo.dat", &bgeo::write(&p, true));
    assert_eq!(scene::load(&path).unwrap(), p);
}

fn parse_err(path: &Path) -> (u64, String) {
    match scene::load(path) {
        Err(Error::Parse { path: p, offset, reason }) => {
            assert_eq!(p, path);
            let msg = format!("{}", scene::load(path).unwrap_err());
            assert!(msg.contains(&path.display().to_string()), "message names the file: {msg}");
            (offset, reason)
        }
        other => panic!("expected a parse error for {}, got {other:?}", path.display()),
    }
}

#[test]
fn malformed_bgeo_files_are_clear_errors() {
    let good = bgeo::write(&sample(10), false);
    // Truncated inside the records.
    let (_, why) = parse_err(&tmp("trunc.bgeo", &good[..good.len() - 50]));
    assert!(why.contains("points") && why.contains("remain"), "{why}");
    // Truncated inside the header.
    let (off, why) = parse_err(&tmp("trunc_header.bgeo", &good[..20]));
    assert!(why.contains("truncated"), "{why}");
    assert!(off >= 5);
    // Wrong magic.
    let mut bad = good.clone();
    bad[0] = b'X';
    let (off, why) = parse_err(&tmp("magic.bgeo", &bad));
    assert_eq!(off, 0);
    assert!(why.contains("magic"), "{why}");
    // A count far beyond the data: must be an error, not an allocation of 2^31 records.
    let mut huge = good.clone();
    huge[9..13].copy_from_slice(&i32::MAX.to_be_bytes());
    let (_, why) = parse_err(&tmp("huge.bgeo", &huge));
    assert!(why.contains("2147483647"), "{why}");
    // Negative count.
    let mut neg = good.clone();
    neg[9..13].copy_from_slice(&(-5i32).to_be_bytes());
    let (off, why) = parse_err(&tmp("neg.bgeo", &neg));
    assert_eq!(off, 9);
    assert!(why.contains("negative"), "{why}");
    // Corrupt gzip.
    let mut gz = bgeo::write(&sample(10), true);
    let n = gz.len();
    gz.truncate(n / 2);
    let (_, why) = parse_err(&tmp("corrupt.bgeo", &gz));
    assert!(why.contains("gzip"), "{why}");
}

#[test]
fn malformed_vtk_files_are_clear_errors() {
    let good = vtk::write(&sample(10), true);
    let (_, why) = parse_err(&tmp("trunc.vtk", &good[..150]));
    assert!(why.contains("remain") || why.contains("truncated"), "{why}");
    let (off, why) = parse_err(&tmp("magic.vtk", b"# not vtk\nx\nASCII\n"));
    assert_eq!(off, 0);
    assert!(why.contains("magic"), "{why}");
    let huge = b"# vtk DataFile Version 4.1\nt\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 2000000000 float\n\0\0\0\0";
    let (_, why) = parse_err(&tmp("huge.vtk", huge));
    assert!(why.contains("2000000000") || why.contains("6000000000"), "{why}");
    let ascii = b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0 1 1 x\n";
    let (_, why) = parse_err(&tmp("badnum.vtk", ascii));
    assert!(why.contains("\"x\""), "{why}");
}

#[test]
fn empty_or_unknown_files_are_errors() {
    let (_, why) = parse_err(&tmp("empty.bin", b""));
    assert!(why.contains("unknown"), "{why}");
    let r = scene::load(Path::new("/nonexistent/particles.bgeo"));
    assert!(matches!(r, Err(Error::Io { .. })));
}

/// The shared SPlisHSPlasH frames, when present: .bgeo and .vtk of the same frame hold the same particles.
#[test]
fn shared_splishsplash_bgeo_equals_vtk() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/splishsplash/dambreak_6859");
    if !root.exists() {
        eprintln!("shared data not present; skipping (the project's own loader tests above ran)");
        return;
    }
    for n in [1, 20] {
        let b = scene::load(&root.join(format!("partio/ParticleData_Fluid_{n}.bgeo"))).unwrap();
        let v = scene::load(&root.join(format!("vtk/ParticleData_Fluid_{n}.vtk"))).unwrap();
        assert_eq!(b.len(), 6859);
        assert_eq!(b.positions, v.positions);
        assert_eq!(b.velocities, v.velocities);
        assert_eq!(b.densities, v.densities);
        assert_eq!(b.ids, v.ids);
        let r = scene::estimate_radius(&b.positions).unwrap();
        if n == 1 {
            assert!((r - 0.025).abs() < 0.003, "estimated radius {r}");
        }
    }
}
