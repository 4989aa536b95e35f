//! The hostile-input campaign as properties (proptest, stable Rust): every loader and every parsed CLI surface,
//! fed structure-aware mutations of real files (each format's writers, tests/fixtures, tests/malformed), ends in
//! Ok or an error — never a panic, never an allocation beyond what the bytes can hold.
//!
//! CI runs `MENISCUS_FUZZ_CASES` cases per target (default 20,000: about 5 s); a longer run:
//! `MENISCUS_FUZZ_CASES=100000 cargo test --release --test properties` (and tools/fuzz/run.sh for libFuzzer).

use std::path::Path;

use proptest::prelude::*;

use meniscus::scene;
use meniscus::scene::format::FORMATS;

fn cases() -> u32 {
    std::env::var("MENISCUS_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(20000)
}

/// The seeds, made once.
fn seeds() -> &'static [(String, Vec<u8>)] {
    static SEEDS: std::sync::OnceLock<Vec<(String, Vec<u8>)>> = std::sync::OnceLock::new();
    SEEDS.get_or_init(make_seeds)
}

/// Every writer's output for a small particle set with attributes, and the fixture files on disk.
fn make_seeds() -> Vec<(String, Vec<u8>)> {
    let n = 27;
    let raw = scene::Raw {
        positions: (0..n).map(|i| [(i % 3) as f32 * 0.1, (i / 3 % 3) as f32 * 0.1, (i / 9) as f32 * 0.1]).collect(),
        arrays: vec![
            scene::Attribute { name: "velocity".into(), components: 3, data: (0..3 * n).map(|i| i as f64).collect() },
            scene::Attribute { name: "id".into(), components: 1, data: (0..n).map(|i| i as f64).collect() },
        ],
    };
    let mut v = vec![];
    for f in FORMATS {
        for (label, bytes) in f.samples(&raw) {
            v.push((format!("x.{}", f.extensions()[0]), bytes));
            let _ = label;
        }
    }
    for dir in ["tests/fixtures/vtk", "tests/malformed"] {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
        for e in std::fs::read_dir(&dir).unwrap().flatten().filter(|e| e.path().is_file()) {
            let bytes = std::fs::read(e.path()).unwrap();
            if bytes.len() <= 1 << 16 {
                v.push((e.file_name().to_string_lossy().into_owned(), bytes));
            }
        }
    }
    assert!(v.len() > 20, "seeds: {}", v.len());
    v
}

/// One structure-aware mutation: truncate, flip bits, overwrite a 4- or 8-byte field with an extreme count,
/// splice in a header keyword, or duplicate a span (data beyond what the header declares).
#[derive(Clone, Debug)]
enum Mutation {
    Truncate(usize),
    Flip(usize, u8),
    Int32(usize, i32),
    Int64(usize, i64),
    Text(usize, &'static str),
    Duplicate(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let extreme =
        prop_oneof![Just(-1i32), Just(0), Just(1), Just(i32::MAX), Just(i32::MIN), Just(0x7fff), any::<i32>()];
    let extreme64 = prop_oneof![Just(-1i64), Just(0), Just(i64::MAX), Just(1i64 << 40), any::<i64>()];
    let word = prop_oneof![
        Just("4294967295"),
        Just("-1"),
        Just("18446744073709551615"),
        Just("nan"),
        Just("inf"),
        Just("\"99999999999\""),
        Just("element vertex 1000000000\n"),
        Just("NumberOfPoints=\"2147483647\""),
        Just("POINTS 999999999 float\n"),
    ];
    prop_oneof![
        any::<usize>().prop_map(Mutation::Truncate),
        (any::<usize>(), 1u8..=255).prop_map(|(i, x)| Mutation::Flip(i, x)),
        (any::<usize>(), extreme).prop_map(|(i, x)| Mutation::Int32(i, x)),
        (any::<usize>(), extreme64).prop_map(|(i, x)| Mutation::Int64(i, x)),
        (any::<usize>(), word).prop_map(|(i, w)| Mutation::Text(i, w)),
        (any::<usize>(), 1usize..4096).prop_map(|(i, n)| Mutation::Duplicate(i, n)),
    ]
}

fn apply(mut b: Vec<u8>, muts: &[Mutation]) -> Vec<u8> {
    for m in muts {
        let n = b.len().max(1);
        match *m {
            Mutation::Truncate(k) => b.truncate(k % n),
            Mutation::Flip(i, x) if !b.is_empty() => b[i % n] ^= x,
            Mutation::Int32(i, x) if b.len() >= 4 => {
                let at = i % (b.len() - 3);
                b[at..at + 4].copy_from_slice(&x.to_be_bytes());
            }
            Mutation::Int64(i, x) if b.len() >= 8 => {
                let at = i % (b.len() - 7);
                b[at..at + 8].copy_from_slice(&x.to_le_bytes());
            }
            Mutation::Text(i, w) => {
                let at = i % n.min(b.len() + 1);
                b.splice(at..at, w.bytes());
            }
            Mutation::Duplicate(i, len) if !b.is_empty() => {
                let at = i % b.len();
                let end = (at + len).min(b.len());
                let span = b[at..end].to_vec();
                b.splice(end..end, span);
            }
            _ => {}
        }
    }
    b
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), failure_persistence: None, ..ProptestConfig::default() })]

    /// Every loader, as `meniscus` calls it (detect → parse → attributes), on mutated seeds.
    #[test]
    fn loaders_never_panic(seed in any::<prop::sample::Index>(), muts in prop::collection::vec(mutation(), 1..4)) {
        let seeds = seeds();
        let (name, bytes) = &seeds[seed.index(seeds.len())];
        let bytes = apply(bytes.clone(), &muts);
        let path = Path::new(name);
        if let Some(f) = scene::detect_format(path, &bytes) {
            if let Ok(raw) = f.parse(path, &bytes) {
                // What a loader returns is consistent: every array fits the particle count or is left alone.
                let p = raw.into_particles(&scene::LoadOptions::default());
                prop_assert!(p.velocities.as_ref().is_none_or(|v| v.len() == p.positions.len()));
            }
        }
        // Each parser also on bytes meant for another one.
        for f in FORMATS {
            let _ = f.parse(path, &bytes);
        }
    }

    /// The CLI's parsed surfaces: --camera, --frames, --shard and a settings file over the defaults.
    #[test]
    fn cli_surfaces_never_panic(text in ".{0,40}", nums in prop::collection::vec(prop_oneof![any::<f32>(), Just(f32::NAN), Just(f32::INFINITY), Just(1e30f32), Just(0.0f32)], 7)) {
        let _ = scene::camera::Camera::parse(&text);
        let cam = format!("{},{},{}:{},{},{}:{}", nums[0], nums[1], nums[2], nums[3], nums[4], nums[5], nums[6]);
        if let Ok(c) = scene::camera::Camera::parse(&cam) {
            prop_assert!(c.check().is_ok() && c.view().is_finite(), "{cam} parsed but cannot render");
        }
        let _ = scene::sequence::FrameRange::parse(&text);
        let _ = scene::sequence::parse_shard(&text);
    }

    #[test]
    fn settings_files_never_panic(key in prop::sample::select(vec!["radius", "surface", "[iso]\nsmoothing", "[iso]\nbulk", "[filter.narrow]\nradius", "[ssr]\nstride", "[mesh]\nsmoothing_iters", "[anisotropy]\nratio", "fluid_scale"]),
                                  value in prop_oneof![Just("inf".to_string()), Just("-inf".to_string()), Just("nan".to_string()), Just("1e300".to_string()), Just("-1".to_string()), Just("0".to_string()), Just("[1, 2]".to_string()), Just("\"x\"".to_string()), any::<i64>().prop_map(|x| x.to_string()), any::<f64>().prop_map(|x| format!("{x:?}"))]) {
        let dir = std::env::temp_dir().join(format!("meniscus-props-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("s.toml");
        std::fs::write(&f, format!("{key} = {value}\n")).unwrap();
        if let Ok(mut s) = meniscus::settings::Settings::default().with_toml(&f) {
            s.radius = 0.01;
            let _ = s.validate();
        }
    }
}
