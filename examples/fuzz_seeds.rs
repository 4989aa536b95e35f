//! Writes small valid files of every registered format (the fuzzer's seed corpus):
//! `cargo run --example fuzz_seeds -- DIR`. The one fuzz target (`tools/fuzz/fuzz_targets/parse.rs`) picks the
//! parser from the first byte of its input, so every seed is the format's index byte followed by the file.
use meniscus::scene::format::FORMATS;
use meniscus::scene::Particles;

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
    let d = dir.join("parse");
    std::fs::create_dir_all(&d).expect("create corpus dir");
    for (k, f) in FORMATS.iter().enumerate() {
        for (label, bytes) in f.samples(&p) {
            let mut seed = vec![k as u8];
            seed.extend_from_slice(&bytes);
            std::fs::write(d.join(format!("{}_{label}", f.key())), seed).expect("write seed");
        }
    }
}
