//! Loader throughput: `cargo bench --bench loaders`. Writes 1,000,000 particles (position, velocity, density,
//! id) in every format in memory, parses each 5 times, prints the median as MB/s and particles/s.
//! A CPU benchmark (no GPU); numbers depend on the machine, so compare formats within one run.

use std::path::Path;
use std::time::Instant;

use meniscus::scene::format::ParticleFormat;
use meniscus::scene::format::FORMATS;
use meniscus::scene::Particles;

fn main() {
    let n = std::env::var("MENISCUS_BENCH_PARTICLES").ok().and_then(|v| v.parse().ok()).unwrap_or(1_000_000usize);
    let p = Particles {
        positions: (0..n)
            .map(|i| [(i % 100) as f32 * 0.01, (i / 100 % 100) as f32 * 0.01, (i / 10000) as f32 * 0.01])
            .collect(),
        velocities: Some((0..n).map(|i| [1.0, (i % 7) as f32, -2.0]).collect()),
        densities: Some((0..n).map(|i| 1000.0 + (i % 13) as f32).collect()),
        ids: Some((0..n as i64).collect()),
        ..Default::default()
    }
    .to_raw();
    // Every writer variant of every registered format.
    let cases: Vec<(String, &dyn ParticleFormat, Vec<u8>)> = FORMATS
        .iter()
        .flat_map(|f| {
            f.samples(&p)
                .into_iter()
                .filter(|(l, _)| *l != "text")
                .map(move |(l, b)| (format!("{} {l}", f.name()), *f, b))
        })
        .collect();
    // Also files written by other tools (e.g. VTK's writers with each compressor): MENISCUS_BENCH_FILES=DIR.
    let mut cases = cases;
    if let Ok(dir) = std::env::var("MENISCUS_BENCH_FILES") {
        let mut files: Vec<_> =
            std::fs::read_dir(&dir).expect("MENISCUS_BENCH_FILES").flatten().map(|e| e.path()).collect();
        files.sort();
        for f in files {
            let bytes = std::fs::read(&f).expect("read");
            if let Some(fmt) = meniscus::scene::detect_format(&f, &bytes) {
                let n_file = fmt.parse(&f, &bytes).map(|r| r.positions.len()).unwrap_or(0);
                if n_file == n {
                    cases.push((f.file_name().unwrap().to_string_lossy().into_owned(), fmt, bytes));
                }
            }
        }
    }
    println!("{n} particles (position + velocity + density + id; XYZ positions only), median of 5 parses\n");
    println!("| format | file MB | ms | MB/s | M particles/s |\n|---|---:|---:|---:|---:|");
    for (name, f, bytes) in cases {
        let mut t = vec![];
        for _ in 0..5 {
            let t0 = Instant::now();
            let r = f.parse(Path::new("bench"), &bytes).expect("parse");
            t.push(t0.elapsed().as_secs_f64());
            assert_eq!(r.positions.len(), n);
        }
        t.sort_by(f64::total_cmp);
        let s = t[2];
        let mb = bytes.len() as f64 / 1e6;
        println!("| {name} | {mb:.1} | {:.0} | {:.0} | {:.1} |", s * 1e3, mb / s, n as f64 / s / 1e6);
    }
}
