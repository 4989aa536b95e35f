//! Issue #16: files written by VTK's own XML writers and by meshio (tests/fixtures/vtk, made by
//! tools/vtk-fixtures/make_fixtures.py — every data mode, header type, byte order and compressor) load to the
//! particles the script wrote; a ParaView `.pvd` collection is a sequence in timestep order; broken variants
//! are one clear error with the byte offset.

use std::path::{Path, PathBuf};

use meniscus::scene::{self, sequence};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/vtk")
}

/// Positions, velocities, densities and ids.
type Columns = (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<f32>, Vec<i64>);

/// The particles make_fixtures.py writes (x shifted by `shift` in the series).
fn expected(shift: f64) -> Columns {
    let n = 25;
    let pos = (0..n)
        .map(|i| {
            let i = i as f64;
            [(0.1 * i + shift) as f32, (0.5 + 0.01 * i * i) as f32, (-0.2 * i + 0.003 * i * i * i) as f32]
        })
        .collect();
    let vel = (0..n).map(|i| [i as f32, -0.5 * i as f32, 0.25]).collect();
    let rho = (0..n).map(|i| 1000.0 + 0.5 * i as f32).collect();
    let ids = (0..n).map(|i| 3 * i as i64 + 1).collect();
    (pos, vel, rho, ids)
}

fn check(path: &Path, shift: f64) {
    let p = scene::load(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (pos, vel, rho, ids) = expected(shift);
    let name = path.file_name().unwrap().to_string_lossy();
    assert_eq!(p.positions, pos, "{name}: positions");
    assert_eq!(p.velocities.as_ref(), Some(&vel), "{name}: velocity");
    assert_eq!(p.densities.as_ref(), Some(&rho), "{name}: density");
    assert_eq!(p.ids.as_ref(), Some(&ids), "{name}: id");
}

#[test]
fn every_vtk_and_meshio_fixture_loads() {
    let mut n = 0;
    let mut names = vec![];
    for e in std::fs::read_dir(dir()).unwrap() {
        let path = e.unwrap().path();
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if ext == "vtu" || ext == "vtp" {
            check(&path, 0.0);
            names.push(path.file_name().unwrap().to_string_lossy().into_owned());
            n += 1;
        }
    }
    names.sort();
    // 2 writers × (ascii + 3 binary modes × (4 compressors × 2 header types + 2 big-endian)) + 4 meshio files.
    assert_eq!(n, 2 * (1 + 3 * (4 * 2 + 2)) + 4, "fixtures: {names:?}");
    for must in ["vtu_appended_b64_none_uint64.vtu", "vtu_appended_raw_lz4_uint32.vtu", "vtp_binary_lzma_uint64.vtp"] {
        assert!(names.iter().any(|m| m == must), "{must} missing");
    }
}

#[test]
fn pvd_collection_is_a_sequence_in_timestep_order() {
    let pvd = dir().join("series.pvd");
    let spec = pvd.to_str().unwrap();
    assert!(sequence::is_sequence(spec));
    let frames = sequence::resolve(spec, None, None).unwrap();
    assert_eq!(frames.iter().map(|f| f.number).collect::<Vec<_>>(), vec![0, 1, 2]);
    for (f, shift) in frames.iter().zip([0.0, 0.5, 1.0]) {
        check(&f.path, shift);
    }
}

fn tmp(name: &str, bytes: &[u8]) -> PathBuf {
    let d = std::env::temp_dir().join(format!("meniscus-vtkfix-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// The file cut `keep` bytes into its appended section (inside the point data).
fn cut_appended(b: Vec<u8>, keep: usize) -> Vec<u8> {
    let at = b.windows(13).position(|w| w == b"<AppendedData").unwrap();
    b[..at + keep].to_vec()
}

/// Each broken variant gives one error naming the file, a byte offset and the reason.
#[test]
fn broken_variants_are_clear_errors() {
    let read = |n: &str| std::fs::read(dir().join(n)).unwrap();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("cut_b64.vtu", cut_appended(read("vtu_appended_b64_none_uint64.vtu"), 300), "more than the file holds"),
        ("cut_lz4.vtu", cut_appended(read("vtu_appended_raw_lz4_uint64.vtu"), 100), ""),
        ("bad_compressor.vtu", String::from_utf8(read("vtu_binary_zlib_uint64.vtu")).unwrap().replace("vtkZLibDataCompressor", "vtkZstdDataCompressor").into_bytes(), "vtkZstdDataCompressor"),
        ("bad_b64.vtu", String::from_utf8(read("vtu_binary_none_uint64.vtu")).unwrap().replacen("WAIAAAAA", "WA!AAAAA", 1).into_bytes(), "truncated"),
        ("no_file.pvd", b"<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\"><Collection><DataSet timestep=\"0\"/></Collection></VTKFile>\n".to_vec(), "file="),
        ("bad_step.pvd", b"<VTKFile type=\"Collection\"><Collection><DataSet timestep=\"x\" file=\"a.vtu\"/></Collection></VTKFile>".to_vec(), "timestep"),
    ];
    for (name, bytes, want) in cases {
        let path = tmp(name, &bytes);
        let r = if name.ends_with(".pvd") {
            sequence::resolve(path.to_str().unwrap(), None, None).map(|_| ())
        } else {
            scene::load(&path).map(|_| ())
        };
        let e = r.err().unwrap_or_else(|| panic!("{name}: loaded"));
        let msg = e.to_string();
        assert!(msg.contains(name) && msg.contains("byte ") && msg.contains(want), "{name}: {msg}");
    }
    // A .pvd that names a missing file fails when that frame loads, naming the file.
    let path = tmp(
        "missing.pvd",
        b"<VTKFile type=\"Collection\"><Collection><DataSet timestep=\"0\" file=\"nope.vtu\"/></Collection></VTKFile>",
    );
    let frames = sequence::resolve(path.to_str().unwrap(), None, None).unwrap();
    let e = scene::load(&frames[0].path).unwrap_err().to_string();
    assert!(e.contains("nope.vtu"), "{e}");
}

/// A deterministic mutation sweep over every fixture (truncations, byte flips, base64 and header damage): the
/// VTU/VTP parser returns Ok or Err, never panics, whatever the layout or compressor. (libFuzzer runs the same
/// paths through tools/fuzz, seeded with these files.)
#[test]
fn mutated_fixtures_never_panic() {
    let vtu = meniscus::scene::format::by_key("vtu").unwrap();
    let mut runs = 0;
    for e in std::fs::read_dir(dir()).unwrap() {
        let path = e.unwrap().path();
        if !path.extension().is_some_and(|e| e == "vtu" || e == "vtp") {
            continue;
        }
        let b = std::fs::read(&path).unwrap();
        let step = (b.len() / 60).max(1);
        let mut variants: Vec<Vec<u8>> = (0..b.len()).step_by(step).map(|k| b[..k].to_vec()).collect();
        for k in (0..b.len()).step_by(step) {
            for flip in [0x01u8, 0x80, 0x3f] {
                let mut m = b.clone();
                m[k] ^= flip;
                variants.push(m);
            }
        }
        for m in variants {
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| vtu.parse(&path, &m)));
            assert!(r.is_ok(), "{}: the parser panicked on a mutation", path.display());
            runs += 1;
        }
    }
    assert!(runs > 10_000, "{runs} mutations");
}
