//! Writes small valid files of every format (the fuzzers' seed corpus): `cargo run --example fuzz_seeds -- DIR`.
use meniscus::scene::{bgeo, csv, ply, realflow, vtk, vtu, xyz, Particles};

fn main() {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "tools/fuzz/corpus".into()));
    let p = Particles {
        positions: (0..5).map(|i| [i as f32, 0.5 * i as f32, -(i as f32)]).collect(),
        velocities: Some((0..5).map(|i| [1.0, i as f32, 0.0]).collect()),
        densities: Some(vec![1000.0; 5]),
        ids: Some((0..5).collect()),
        ..Default::default()
    }
    .to_raw();
    let files: Vec<(&str, &str, Vec<u8>)> = vec![
        ("bgeo", "plain.bgeo", bgeo::write(&p, false)),
        ("bgeo", "gz.bgeo", bgeo::write(&p, true)),
        ("vtk", "ascii.vtk", vtk::write(&p, false)),
        ("vtk", "binary.vtk", vtk::write(&p, true)),
        ("vtu", "ascii.vtu", vtu::write(&p, vtu::Encoding::Ascii)),
        ("vtu", "binary.vtu", vtu::write(&p, vtu::Encoding::Binary { zlib: false })),
        ("vtu", "binary_z.vtu", vtu::write(&p, vtu::Encoding::Binary { zlib: true })),
        ("vtu", "raw.vtu", vtu::write(&p, vtu::Encoding::AppendedRaw { zlib: false })),
        ("vtu", "raw_z.vtu", vtu::write(&p, vtu::Encoding::AppendedRaw { zlib: true })),
        ("vtu", "b64.vtu", vtu::write(&p, vtu::Encoding::AppendedBase64)),
        ("ply", "ascii.ply", ply::write(&p, "ascii")),
        ("ply", "le.ply", ply::write(&p, "binary_little_endian")),
        ("ply", "be.ply", ply::write(&p, "binary_big_endian")),
        ("xyz", "bin.xyz", xyz::write(&p)),
        ("xyz", "ascii.xyz", b"0 1 2\n3 4 5\n".to_vec()),
        ("csv", "a.csv", csv::write(&p)),
        ("realflow", "v11.bin", realflow::write(&p)),
    ];
    for (sub, name, bytes) in files {
        let d = dir.join(sub);
        std::fs::create_dir_all(&d).expect("create corpus dir");
        std::fs::write(d.join(name), bytes).expect("write seed");
    }
}
