//! Every flag of every subcommand, walked from clap's command tree (`meniscus cli-reference --flags`, so a new
//! flag is walked without editing this file), is given the values a hostile user types: `nan`, `inf`, `1e39`,
//! `-1`, `0` and 4294967295 for numbers, an unknown name for a choice, an empty string and punctuation for text,
//! the input file itself, a missing folder and the input's folder for a path. Each run starts from a small
//! valid command of its subcommand, with the one flag replaced or added. Whatever the value, the run:
//!
//! - ends by itself within [`LIMIT`] (a count that would run for hours is refused up front),
//! - exits 0 (accepted) or with a clean error (1, or clap's 2) — never a panic, an abort or a signal,
//! - leaves its input files byte for byte as they were (no output over an input),
//! - refuses a non-finite number by the flag's name, and an unknown choice.
//!
//! `verdict` holds these rules; `the_rules_reject_what_they_describe` shows each rejecting an outcome that
//! breaks it.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use meniscus::scene::{self, Particles};

/// The longest a single hostile run may take: every base command below finishes in about a second on lavapipe.
const LIMIT: Duration = Duration::from_secs(60);

/// What one run did.
#[derive(Debug)]
struct Outcome {
    /// The exit code; None when a signal ended it or it was killed at [`LIMIT`].
    code: Option<i32>,
    stderr: String,
    timed_out: bool,
    /// The input files' bytes are as they were.
    input_intact: bool,
}

/// The kinds `cli-reference --flags` prints.
fn hostile_values(kind: &str, input: &Path, dir: &Path) -> Vec<String> {
    let s = |v: &str| v.to_string();
    match kind {
        "float" => vec![s("nan"), s("inf"), s("1e39"), s("-1e39"), s("-1"), s("0")],
        "int" => vec![s("0"), s("4294967295"), s("-1")],
        "path" => vec![
            input.display().to_string(),
            dir.join("missing/folder/x").display().to_string(),
            input.parent().unwrap().display().to_string(),
        ],
        "text" => vec![s(""), s("-1:nan/0..0x0"), input.display().to_string()],
        k if k.starts_with("one-of:") => vec![s("bogus")],
        _ => vec![],
    }
}

/// The rules every run keeps; Err names the broken one.
fn verdict(kind: &str, flag: &str, value: &str, o: &Outcome) -> Result<(), String> {
    if o.timed_out {
        return Err(format!("still running after {} s", LIMIT.as_secs()));
    }
    match o.code {
        Some(0..=2) => {}
        other => return Err(format!("ended with {other:?} (a panic, an abort or a signal)")),
    }
    if o.stderr.contains("panicked") || o.stderr.contains("RUST_BACKTRACE") {
        return Err("panicked".into());
    }
    if !o.input_intact {
        return Err("wrote over its input".into());
    }
    // Not finite as an f32 (an f64 flag may refuse 1e39 by its range instead, with exit 1).
    let non_finite = kind == "float" && matches!(value, "nan" | "inf" | "1e39" | "-1e39");
    let unknown_choice = kind.starts_with("one-of:");
    if (non_finite || unknown_choice) && (o.code == Some(0) || !o.stderr.contains(flag)) {
        return Err(format!("accepted {value:?} (exit {:?}) or refused it without naming {flag}", o.code));
    }
    Ok(())
}

#[test]
fn the_rules_reject_what_they_describe() {
    let ok = |code| Outcome { code: Some(code), stderr: String::new(), timed_out: false, input_intact: true };
    assert!(verdict("int", "--frames", "0", &ok(0)).is_ok());
    assert!(verdict("int", "--frames", "0", &ok(1)).is_ok());
    // A panic (101), an abort (134), a signal, a run past the limit, an input written over.
    assert!(verdict("int", "--frames", "0", &ok(101)).is_err());
    assert!(verdict("int", "--frames", "0", &ok(134)).is_err());
    assert!(verdict("int", "--frames", "0", &Outcome { code: None, ..ok(0) }).is_err());
    assert!(verdict("int", "--frames", "0", &Outcome { timed_out: true, ..ok(0) }).is_err());
    assert!(verdict("int", "--frames", "0", &Outcome { input_intact: false, ..ok(0) }).is_err());
    let panicked = Outcome { stderr: "thread 'main' panicked at src/x.rs:1".into(), ..ok(1) };
    assert!(verdict("text", "--camera", "", &panicked).is_err());
    // A NaN accepted, or refused without the flag's name; an unknown choice accepted.
    assert!(verdict("float", "--radius", "nan", &ok(0)).is_err());
    assert!(verdict("float", "--radius", "nan", &Outcome { stderr: "error: bad".into(), ..ok(2) }).is_err());
    let named = Outcome { stderr: "error: invalid value 'nan' for '--radius <RADIUS>'".into(), ..ok(2) };
    assert!(verdict("float", "--radius", "nan", &named).is_ok());
    assert!(verdict("float", "--radius", "-1", &ok(0)).is_ok());
    assert!(verdict("one-of:y|z", "--up", "bogus", &ok(0)).is_err());
}

/// A block of 6³ particles 0.02 apart, shifted by `t` (one frame of a sequence).
fn frame(t: f32) -> Particles {
    let mut positions = vec![];
    for z in 0..6 {
        for y in 0..6 {
            for x in 0..6 {
                positions.push([x as f32 * 0.02 + t, y as f32 * 0.02, z as f32 * 0.02]);
            }
        }
    }
    let velocities = Some(vec![[0.5, 0.0, 0.0]; positions.len()]);
    Particles { positions, velocities, ..Default::default() }
}

/// Every input file's bytes.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let b = std::fs::read(&p).unwrap();
            (p, b)
        })
        .collect();
    v.sort();
    v
}

/// The small valid command each subcommand's hostile runs start from; `{out}` is the run's own folder.
fn base(sub: &str, seq: &Path, png: &Path) -> Vec<String> {
    let f1 = seq.join("f_1.bgeo").display().to_string();
    let pattern = seq.join("f_{}.bgeo").display().to_string();
    let v: Vec<&str> = match sub {
        "render" => vec!["drop", "--particles", "300", "--width", "32", "--height", "18", "--out", "{out}/o.png"],
        "encode" => return vec![png.join("f_{}.png").display().to_string(), "--out".into(), "{out}/o.gif".into()],
        "info" => return vec![f1],
        "bench" => vec!["--scenes", "drop:300", "--resolutions", "32x18", "--warmup", "0", "--frames", "1"],
        "mesh" => return vec![f1, "--out".into(), "{out}/o.ply".into()],
        "diffuse" => return vec![pattern, "--export".into(), "{out}/d_{}.bgeo".into()],
        "sim" => vec!["drop", "--particles", "300", "--frames", "2"],
        "quality" => vec!["drop", "--particles", "300", "--width", "32", "--height", "18"],
        "demo" => vec!["drop", "--particles", "300", "--width", "32", "--height", "18", "--frames", "1"],
        other => panic!("no base command for `meniscus {other}`: add one here"),
    };
    v.into_iter().map(String::from).collect()
}

/// Run `args` with a deadline; the input folder's bytes are compared after.
fn run(args: &[String], seq: &Path, before: &[(PathBuf, Vec<u8>)]) -> Outcome {
    let mut child = Command::new(env!("CARGO_BIN_EXE_meniscus"))
        .args(args)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut err, &mut s);
        s
    });
    let t0 = Instant::now();
    let (status, timed_out) = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break (Some(s), false);
        }
        if t0.elapsed() > LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            break (None, true);
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let stderr = reader.join().unwrap();
    // New files beside the inputs are allowed (a folder given as an output gets frame.png); changed ones are not,
    // and are put back so the runs after this one start from the same inputs.
    let _ = seq;
    let mut input_intact = true;
    for (path, bytes) in before {
        if std::fs::read(path).ok().as_deref() != Some(bytes.as_slice()) {
            input_intact = false;
            std::fs::write(path, bytes).unwrap();
        }
    }
    Outcome { code: status.and_then(|s| s.code()), stderr, timed_out, input_intact }
}

#[test]
fn every_flag_keeps_the_rules_whatever_its_value() {
    let root = std::env::temp_dir().join(format!("meniscus-flags-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let (seq, png) = (root.join("seq"), root.join("png"));
    std::fs::create_dir_all(&seq).unwrap();
    std::fs::create_dir_all(&png).unwrap();
    for k in 1..=3 {
        let raw = frame(0.01 * k as f32).to_raw();
        std::fs::write(seq.join(format!("f_{k}.bgeo")), scene::bgeo::write(&raw, true)).unwrap();
        image::RgbaImage::from_pixel(16, 8, image::Rgba([40, 90, 200, 255]))
            .save(png.join(format!("f_{k}.png")))
            .unwrap();
    }
    let before = snapshot(&seq);
    let input = seq.join("f_1.bgeo");

    let o = Command::new(env!("CARGO_BIN_EXE_meniscus")).args(["cli-reference", "--flags"]).output().unwrap();
    assert!(o.status.success());
    let listing = String::from_utf8(o.stdout).unwrap();
    let flags: Vec<[&str; 3]> = listing
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            [f[0], f[1], f[2]]
        })
        .collect();
    // The walk covers every subcommand and every kind of value (a listing that lost them would pass vacuously).
    for sub in ["render", "encode", "info", "bench", "mesh", "diffuse", "sim", "quality", "demo"] {
        assert!(flags.iter().any(|f| f[0] == sub), "no flags listed for {sub}");
    }
    for kind in ["float", "int", "path", "text", "one-of:", "switch"] {
        assert!(flags.iter().any(|f| f[2].starts_with(kind)), "no {kind} flag listed");
    }
    assert!(flags.len() > 150, "{} flags listed", flags.len());

    // Each (flag, value) run, its base command with the flag replaced (when the base sets it) or added.
    let mut runs = vec![];
    for [sub, flag, kind] in &flags {
        for value in hostile_values(kind, &input, &root) {
            let mut args = vec![sub.to_string()];
            let mut b = base(sub, &seq, &png);
            match b.iter().position(|a| a == flag) {
                Some(i) => b[i + 1] = value.clone(),
                None => b.extend([flag.to_string(), value.clone()]),
            }
            args.extend(b);
            runs.push((sub.to_string(), flag.to_string(), kind.to_string(), value, args));
        }
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let failures = std::sync::Mutex::new(vec![]);
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some((sub, flag, kind, value, args)) = runs.get(k) else { break };
                let out = root.join(format!("out{k}"));
                std::fs::create_dir_all(&out).unwrap();
                let args: Vec<String> = args.iter().map(|a| a.replace("{out}", &out.display().to_string())).collect();
                let o = run(&args, &seq, &before);
                if let Err(why) = verdict(kind, flag, value, &o) {
                    let last = o.stderr.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("").to_string();
                    failures.lock().unwrap().push(format!("meniscus {sub} … {flag} {value:?}: {why} — {last}"));
                }
                let _ = std::fs::remove_dir_all(&out);
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    assert!(failures.is_empty(), "{} of {} runs broke a rule:\n{}", failures.len(), runs.len(), failures.join("\n"));
    eprintln!("{} runs over {} flags kept every rule", runs.len(), flags.len());
    let _ = std::fs::remove_dir_all(&root);
}
