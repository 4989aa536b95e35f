//! Hostile input ends cleanly: one test per class of failure — closed pipes, sizes beyond the machine, inflation
//! bombs and devices, stray particles, top-down and non-finite cameras, headers that under-count their data,
//! gaps and bad attributes in sequences, folders as outputs, failing writes, corrupt frames mid-sequence.
//! Each ends in a clear one-line error with a non-zero exit, or (strays, top-down views) a correct picture.
//! And the ways a run could lose or keep a broken file: a sequence written over another run's cache, a movie
//! encoded onto a full disk, `--resume` trusting a damaged frame, an export that spoils its input folder, flags
//! accepted and ignored, partial files a killed run left behind.

use std::path::Path;
use std::process::{Command, Output};

mod common;

use common::{meniscus, stderr};

use meniscus::scene::{self, Particles};

/// Failed with a clean message containing each of `want` (no panic, no backtrace).
fn fails_with(o: &Output, want: &[&str]) {
    let e = stderr(o);
    assert!(!o.status.success(), "should have failed: {e}");
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(!e.contains("panicked") && !e.contains("RUST_BACKTRACE"), "{e}");
    for w in want {
        assert!(e.contains(w), "{w:?} not in: {e}");
    }
}

/// A block of `n`³ particles 0.02 apart, plus `extra`.
fn block(n: usize, extra: &[[f32; 3]]) -> Particles {
    let mut pos = vec![];
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                pos.push([x as f32 * 0.02, y as f32 * 0.02, z as f32 * 0.02]);
            }
        }
    }
    pos.extend_from_slice(extra);
    Particles { positions: pos, ..Default::default() }
}

fn write_bgeo(path: &Path, p: &Particles) {
    std::fs::write(path, scene::bgeo::write(&p.to_raw(), true)).unwrap();
}

#[test]
fn a_closed_stdout_is_a_normal_end() {
    let d = common::tmpdir("hostile", "pipe");
    let f = d.join("p.bgeo");
    write_bgeo(&f, &block(6, &[]));
    // `true` exits at once: by the time `info` prints, nobody reads its stdout.
    let script = format!(
        "{{ sleep 0.3; '{}' info '{}'; }} | true; exit ${{PIPESTATUS[0]}}",
        env!("CARGO_BIN_EXE_meniscus"),
        f.display()
    );
    let o = Command::new("bash").args(["-c", &script]).output().unwrap();
    assert!(o.status.success(), "exit {:?}: {}", o.status.code(), stderr(&o));
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
}

#[test]
fn sizes_beyond_the_machine_are_refused_before_allocating() {
    let d = common::tmpdir("hostile", "sizes");
    let f = d.join("p.bgeo");
    write_bgeo(&f, &block(6, &[]));
    let o = meniscus().arg("mesh").arg(&f).args(["--radius", "0.01", "--block", "1500"]).output().unwrap();
    assert!(!o.status.success() && stderr(&o).contains("1500"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    let o = meniscus()
        .arg("mesh")
        .arg(&f)
        .args(["--radius", "0.01", "--block", "1024", "--threads", "64", "--out"])
        .arg(d.join("m.ply"))
        .output()
        .unwrap();
    fails_with(&o, &["GB of memory, more than the", "available"]);
    assert!(!d.join("m.ply").exists());
    // The estimate of the per-corner paths follows the occupied lattice, not the whole box.
    let p = block(6, &[]);
    let grid = meniscus::field::iso::IsoGrid::build(&p.positions, 0.04);
    let params = meniscus::field::extract::ExtractParams {
        block: 0,
        dense: true,
        ..meniscus::field::extract::ExtractParams::new(0.005, 0.6)
    };
    let fine = meniscus::field::extract::memory_estimate(&grid, &params, 1);
    let coarse = meniscus::field::extract::memory_estimate(
        &grid,
        &meniscus::field::extract::ExtractParams { cube: 0.01, ..params },
        1,
    );
    assert!(fine > 2 * coarse && fine < 1 << 33, "{fine} vs {coarse}");
}

#[test]
fn inflation_bombs_and_devices_are_bounded() {
    let d = common::tmpdir("hostile", "bomb");
    // A BGEO header for 10 points followed by 512 MiB of zeros, gzip'ed (about 0.5 MB).
    let mut head = scene::bgeo::write(&block(1, &[]).to_raw(), false);
    head.truncate(head.len() - 2);
    let bomb = d.join("bomb.bgeo");
    {
        use std::io::Write;
        let f = std::fs::File::create(&bomb).unwrap();
        let mut e = flate2::write::GzEncoder::new(f, flate2::Compression::fast());
        e.write_all(&head).unwrap();
        let zeros = vec![0u8; 1 << 20];
        for _ in 0..512 {
            e.write_all(&zeros).unwrap();
        }
        e.finish().unwrap();
    }
    for path in [bomb.as_path(), Path::new("/dev/zero")] {
        let o = Command::new("/usr/bin/time")
            .args(["-f", "maxrss_kb=%M"])
            .arg(env!("CARGO_BIN_EXE_meniscus"))
            .arg("info")
            .arg(path)
            .output()
            .unwrap();
        let e = stderr(&o);
        assert!(!o.status.success(), "{e}");
        let kb: u64 = e.split("maxrss_kb=").nth(1).and_then(|s| s.trim().parse().ok()).expect("time's output");
        assert!(kb < 100_000, "{}: {kb} kB resident", path.display());
        if path == bomb {
            assert!(e.contains("inflates past the") && e.contains("header declares"), "{e}");
        } else {
            assert!(e.contains("not a regular file"), "{e}");
        }
    }
}

/// Finite depth pixels in a depth dump (`.npy`, float32 after a 128-byte header here).
fn covered(npy: &Path) -> usize {
    let b = std::fs::read(npy).unwrap();
    let hlen = u16::from_le_bytes([b[8], b[9]]) as usize + 10;
    b[hlen..].chunks_exact(4).filter(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]).is_finite()).count()
}

#[test]
fn stray_particles_do_not_cost_the_surface() {
    let d = common::tmpdir("hostile", "stray");
    let (clean, stray) = (d.join("clean.bgeo"), d.join("stray.bgeo"));
    write_bgeo(&clean, &block(10, &[]));
    write_bgeo(&stray, &block(10, &[[1e6, 0.0, 0.0]]));
    let cam = ["--camera", "0.09,0.4,0.6:0.09,0.09,0.09", "--radius", "0.01", "--width", "96", "--height", "64"];
    let mut px = vec![];
    for f in [&clean, &stray] {
        let out = d.join(f.file_name().unwrap()).with_extension("png");
        let o =
            meniscus().arg("render").arg(f).args(cam).args(["--dump", "depth", "--out"]).arg(&out).output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        if f == &stray {
            assert!(stderr(&o).contains("1 particle is far from the fluid"), "{}", stderr(&o));
        }
        px.push(covered(&out.with_extension("depth.npy")));
    }
    assert!(px[0] > 500, "the block covers {} pixels", px[0]);
    assert!(px[0].abs_diff(px[1]) <= px[0] / 50, "with a stray: {} pixels of {}", px[1], px[0]);
    // The mesh leaves it out with the same warning instead of an overflowing lattice.
    let o =
        meniscus().arg("mesh").arg(&stray).args(["--radius", "0.01", "--out"]).arg(d.join("m.ply")).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("1 particle is far from the fluid"), "{}", stderr(&o));
}

#[test]
fn top_down_views_render_and_non_finite_cameras_are_refused() {
    let d = common::tmpdir("hostile", "camera");
    let f = d.join("p.bgeo");
    write_bgeo(&f, &block(10, &[]));
    // Straight down (straight up the view basis is the same code: src/scene/camera.rs's test; from below, the
    // ground plane under the water hides it, as it should).
    for cam in ["0.09,1,0.09:0.09,0,0.09", "0.09,1.5,0.09:0.09,0.05,0.09:30"] {
        let out = d.join("top.png");
        let o = meniscus()
            .arg("render")
            .arg(&f)
            .args(["--camera", cam, "--radius", "0.01", "--width", "64", "--height", "64", "--dump", "depth", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(covered(&d.join("top.depth.npy")) > 300, "{cam}: the water is not seen");
    }
    let o = meniscus().arg("render").arg(&f).args(["--scale", "1e30", "--out"]).arg(d.join("x.png")).output().unwrap();
    fails_with(&o, &["--scale 1e30", "[1e-6, 1e6]"]);
    assert!(!d.join("x.png").exists());
    // Coordinates a unit conversion cannot explain are refused by their size.
    let far = block(4, &[]).positions.iter().map(|p| p.map(|x| 1e16 + x * 1e14)).collect();
    write_bgeo(&d.join("far.bgeo"), &Particles { positions: far, ..Default::default() });
    let o = meniscus().arg("render").arg(d.join("far.bgeo")).arg("--out").arg(d.join("x.png")).output().unwrap();
    fails_with(&o, &["coordinates reach", "--scale"]);
    assert!(!d.join("x.png").exists());
}

#[test]
fn headers_that_under_count_their_data_are_reported() {
    let d = common::tmpdir("hostile", "count");
    let p = block(4, &[]);
    let raw = p.to_raw();
    // BGEO: nPoints is the int32 at byte 9.
    let mut b = scene::bgeo::write(&raw, false);
    b[9..13].copy_from_slice(&60i32.to_be_bytes());
    let e = scene::bgeo::parse(Path::new("x.bgeo"), &b).unwrap_err().to_string();
    assert!(e.contains("follow the 60 points"), "{e}");
    // PLY, ASCII and binary.
    for enc in ["ascii", "binary_little_endian"] {
        let t = scene::ply::write(&raw, enc);
        let s = String::from_utf8_lossy(&t).into_owned();
        let at = s.find("element vertex 64").unwrap();
        let mut t2 = t.clone();
        t2[at..at + 17].copy_from_slice(b"element vertex 60");
        // With the writer's face element after the vertices: an error at a byte offset either way.
        let e = scene::ply::parse(Path::new("x.ply"), &t2).unwrap_err().to_string();
        assert!(e.contains("x.ply: byte "), "{enc}: {e}");
        // Vertices only: the extra vertices are reported where they start.
        let face = "element face 1\nproperty list uchar int vertex_indices\n";
        let cut = if enc == "ascii" { 8 } else { 13 };
        let s2 = String::from_utf8_lossy(&t2).into_owned();
        let h = s2.find(face).unwrap();
        let mut t3 = t2[..t2.len() - cut].to_vec();
        t3.drain(h..h + face.len());
        let e = scene::ply::parse(Path::new("x.ply"), &t3).unwrap_err().to_string();
        assert!(e.contains("follow the 60 vertices"), "{enc}: {e}");
    }
    // VTU: NumberOfPoints under-counts the ascii and binary arrays.
    for enc in [scene::vtu::Encoding::Ascii, scene::vtu::Encoding::Binary { zlib: false }] {
        let t = String::from_utf8(scene::vtu::write(&raw, enc))
            .unwrap()
            .replace("NumberOfPoints=\"64\"", "NumberOfPoints=\"60\"");
        let e = scene::vtu::parse(Path::new("x.vtu"), t.as_bytes()).unwrap_err().to_string();
        assert!(e.contains("under-counts"), "{e}");
    }
    let _ = d;
}

#[test]
fn sequences_report_gaps_bad_attributes_and_folders() {
    let d = common::tmpdir("hostile", "seq");
    for n in [1, 2, 4] {
        write_bgeo(&d.join(format!("f_{n}.bgeo")), &block(5, &[]));
    }
    let seq = d.join("f_{}.bgeo").to_string_lossy().into_owned();
    let small = ["--width", "32", "--height", "24", "--radius", "0.01"];
    // A folder as the output: frames go inside it.
    let o = meniscus()
        .args(["render", &seq])
        .args(small)
        .arg("--out")
        .arg(format!("{}/", d.join("frames").display()))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("1 frame is missing from the numbering: 3"), "{}", stderr(&o));
    for n in [1, 2, 4] {
        assert!(d.join(format!("frames/frame_{n:04}.png")).is_file(), "frame {n}");
    }
    let o = meniscus().args(["render", &seq, "--velocity-attr", "nosuch"]).args(small).output().unwrap();
    fails_with(&o, &["--velocity-attr nosuch: no such attribute"]);
    let mut p = block(5, &[]);
    p.ids = Some((0..125).collect());
    write_bgeo(&d.join("ids.bgeo"), &p);
    let o =
        meniscus().arg("render").arg(d.join("ids.bgeo")).args(["--radius-attr", "id"]).args(small).output().unwrap();
    fails_with(&o, &["--radius-attr id: a radius must be positive; particle 0 has 0"]);
}

#[test]
fn failing_writes_and_corrupt_frames_say_what_happened() {
    let d = common::tmpdir("hostile", "writes");
    for n in 1..=3 {
        write_bgeo(&d.join(format!("f_{n}.bgeo")), &block(5, &[]));
    }
    let seq = d.join("f_{}.bgeo").to_string_lossy().into_owned();
    let small = ["--width", "32", "--height", "24", "--radius", "0.01"];
    // The output folder is a file: the error names the path and the reason.
    std::fs::write(d.join("blocker"), "a file").unwrap();
    let o =
        meniscus().args(["render", &seq]).args(small).arg("--out").arg(d.join("blocker/f_{}.png")).output().unwrap();
    fails_with(&o, &["blocker", "is a file, not a folder"]);
    // A corrupt frame in the middle: the frame before it is written, the count is said.
    std::fs::write(d.join("f_2.bgeo"), b"Bgeo garbage").unwrap();
    let out = d.join("a");
    let o = meniscus().args(["render", &seq]).args(small).arg("--out").arg(out.join("f_{}.png")).output().unwrap();
    fails_with(&o, &["f_2.bgeo", "1 of 3 frames written"]);
    assert!(out.join("f_0001.png").is_file());
    let out = d.join("b");
    let o = meniscus()
        .args(["render", &seq, "--skip-bad-frames"])
        .args(small)
        .arg("--out")
        .arg(out.join("f_{}.png"))
        .output()
        .unwrap();
    fails_with(&o, &["warning: skipping frame 2", "2 of 3 frames written", "1 frame(s) could not be read"]);
    assert!(out.join("f_0001.png").is_file() && out.join("f_0003.png").is_file());
}

#[test]
fn frames_larger_than_the_device_holds_are_a_clear_error() {
    let o = meniscus()
        .args(["render", "drop", "--particles", "1000", "--width", "16384", "--height", "16384", "--out"])
        .arg(common::tmpdir("hostile", "huge").join("x.png"))
        .output()
        .unwrap();
    fails_with(&o, &["16384×16384"]);
}

/// `meniscus ARGS…` run with its files limited to `kib` KiB (RLIMIT_FSIZE, with SIGXFSZ ignored so a write past
/// the limit fails with EFBIG, "File too large", as a full disk fails with ENOSPC): the writer's side of a full
/// disk, with no privilege needed (no mount), so the case runs on every machine.
fn meniscus_with_file_limit(kib: u32, args: &[&std::ffi::OsStr]) -> Output {
    let bin = env!("CARGO_BIN_EXE_meniscus");
    // The shell's `ulimit -f` counts 512-byte blocks (POSIX); `trap '' XFSZ` is inherited across exec.
    Command::new("sh")
        .arg("-c")
        .arg(format!("trap '' XFSZ; ulimit -f {}; exec \"$0\" \"$@\"", kib * 2))
        .arg(bin)
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn a_sequence_write_does_not_replace_another_runs_cache() {
    let d = common::tmpdir("hostile", "cache");
    let partio = d.join("c/partio");
    std::fs::create_dir_all(&partio).unwrap();
    for n in 1..=3 {
        write_bgeo(&partio.join(format!("ParticleData_Fluid_{n}.bgeo")), &block(3 + n, &[]));
    }
    let before: Vec<Vec<u8>> =
        (1..=3).map(|n| std::fs::read(partio.join(format!("ParticleData_Fluid_{n}.bgeo"))).unwrap()).collect();
    let pattern = partio.join("ParticleData_Fluid_{}.bgeo").to_string_lossy().into_owned();
    let sim = |extra: &[&str]| {
        meniscus().args(["sim", "dambreak", "--particles", "2000", "--frames", "3"]).args(extra).output().unwrap()
    };
    let o = sim(&["--export", &pattern]);
    fails_with(&o, &["--export", "3 of the 3 files to write exist already", "--overwrite"]);
    for n in 1..=3 {
        assert_eq!(std::fs::read(partio.join(format!("ParticleData_Fluid_{n}.bgeo"))).unwrap(), before[n - 1]);
    }
    assert!(!partio.join("scene.json").exists(), "a scene.json was dropped into the cache's folder");
    // --diffuse onto an unrelated file.
    std::fs::write(d.join("notes_2.bgeo"), scene::bgeo::write(&block(2, &[]).to_raw(), true)).unwrap();
    let foam = d.join("notes_{}.bgeo").to_string_lossy().into_owned();
    let o = sim(&["--diffuse", &foam]);
    fails_with(&o, &["--diffuse", "1 of the 3 files to write exist already", "notes_2.bgeo"]);
    // `foam --export` likewise.
    let exported = d.join("f/foam_{}.bgeo").to_string_lossy().into_owned();
    std::fs::create_dir_all(d.join("f")).unwrap();
    std::fs::write(d.join("f/foam_0002.bgeo"), scene::bgeo::write(&block(2, &[]).to_raw(), true)).unwrap();
    let o = meniscus().args(["diffuse", &pattern, "--radius", "0.01", "--export", &exported]).output().unwrap();
    fails_with(&o, &["--export", "exist already", "--overwrite"]);
    // With --overwrite the user asked for it.
    let o = sim(&["--export", &pattern, "--overwrite"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_ne!(std::fs::read(partio.join("ParticleData_Fluid_1.bgeo")).unwrap(), before[0]);
}

#[test]
fn a_movie_on_a_full_disk_keeps_the_good_one() {
    let d = common::tmpdir("hostile", "movie-src");
    for n in 1..=12 {
        // Noisy frames: each costs the encoder some kilobytes.
        let img = image::RgbaImage::from_fn(64, 48, |x, y| {
            let h = (x * 7919 + y * 104_729 + n * 31) % 251;
            image::Rgba([h as u8, (h * 3 % 251) as u8, (h * 7 % 251) as u8, 255])
        });
        img.save(d.join(format!("f_{n}.png"))).unwrap();
    }
    let disk = common::tmpdir("hostile", "movie-disk");
    let movie = disk.join("m.mp4");
    let frames = d.join("f_{}.png").to_string_lossy().into_owned();
    let o = meniscus().args(["encode", &frames, "--out"]).arg(&movie).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let good = std::fs::read(&movie).unwrap();
    // The lossless encode is larger than the limit: its write fails part-way.
    let limit = 16u32;
    assert!(good.len() > 1024, "the good movie is {} bytes", good.len());
    let args: Vec<&std::ffi::OsStr> = ["encode", frames.as_str(), "--crf", "0", "--out"]
        .into_iter()
        .map(|a| a.as_ref())
        .chain([movie.as_os_str()])
        .collect();
    let o = meniscus_with_file_limit(limit, &args);
    let kept = std::fs::read(&movie).unwrap();
    let leftovers: Vec<_> = std::fs::read_dir(&disk)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n != "m.mp4")
        .collect();
    // The failure names the file and its cause (the write that did not fit), on one line with the file.
    fails_with(&o, &["m.mp4"]);
    let e = stderr(&o);
    assert!(
        e.lines().any(|l| l.contains("m.mp4") && (l.contains("File too large") || l.contains("No space"))),
        "the cause (the write that did not fit) is not said with the file: {e}"
    );
    assert!(kept == good, "the good movie was replaced");
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// `mesh SEQ` writes frame k − 1 on its own thread while frame k is extracted: a write that fails there (a full
/// disk) still ends the run with the file and the cause said, and leaves no partial file; the control: the same
/// run without the limit writes every frame.
#[test]
fn a_mesh_sequence_on_a_full_disk_says_which_file() {
    let d = common::tmpdir("hostile", "mesh-disk");
    for n in 1..=4 {
        write_bgeo(&d.join(format!("f_{n}.bgeo")), &block(12, &[[0.1 * n as f32, 0.3, 0.1]]));
    }
    let seq = d.join("f_{}.bgeo").to_string_lossy().into_owned();
    let run = |folder: &str, limit: Option<u32>| {
        let out = d.join(folder).join("m.ply");
        std::fs::create_dir_all(d.join(folder)).unwrap();
        let args: Vec<&std::ffi::OsStr> = ["mesh", seq.as_str(), "--radius", "0.01", "--out"]
            .into_iter()
            .map(|a| a.as_ref())
            .chain([out.as_os_str()])
            .collect();
        let o = match limit {
            Some(kib) => meniscus_with_file_limit(kib, &args),
            None => meniscus().args(&args).output().unwrap(),
        };
        let names: Vec<String> = std::fs::read_dir(d.join(folder))
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        (o, names)
    };
    let (o, names) = run("ok", None);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(names.len(), 4, "{names:?}");
    let (o, names) = run("full", Some(16));
    fails_with(&o, &["m_0001.ply"]);
    let e = stderr(&o);
    assert!(e.contains("File too large") || e.contains("No space"), "the cause is not said: {e}");
    assert!(!names.iter().any(|n| n.contains(".partial")), "partial files left: {names:?}");
}

#[test]
fn resume_renders_damaged_frames_again() {
    let d = common::tmpdir("hostile", "resume");
    for n in 1..=5 {
        write_bgeo(&d.join(format!("f_{n}.bgeo")), &block(5, &[]));
    }
    let seq = d.join("f_{}.bgeo").to_string_lossy().into_owned();
    let small = ["--width", "40", "--height", "30", "--radius", "0.01"];
    let out = d.join("png/f_{}.png").to_string_lossy().into_owned();
    let o = meniscus().args(["render", &seq, "--out", &out]).args(small).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let frame = |n: u32| d.join(format!("png/f_{n:04}.png"));
    let good: Vec<Vec<u8>> = (1..=5).map(|n| std::fs::read(frame(n)).unwrap()).collect();
    let png = &good[0];
    std::fs::write(frame(1), &png[..png.len() / 2]).unwrap(); // truncated
    let mut crc = png.clone();
    let mid = crc.len() / 2;
    crc[mid] ^= 0x55; // damaged inside a chunk: its CRC no longer matches
    std::fs::write(frame(2), &crc).unwrap();
    std::fs::write(frame(3), b"").unwrap(); // 0 bytes
    std::fs::write(frame(4), &png[..33]).unwrap(); // signature and IHDR only
    let o = meniscus().args(["render", &seq, "--resume", "--out", &out]).args(small).output().unwrap();
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    for (n, why) in [(1, "truncated"), (2, "CRC"), (3, "empty"), (4, "truncated")] {
        let name = format!("f_{n:04}.png: ");
        assert!(e.lines().any(|l| l.contains(&name) && l.contains(why)), "frame {n}: {why} not said on its line: {e}");
    }
    assert!(e.contains("rendering it again") && !e.contains("f_0005.png: "), "{e}");
    for n in 1..=5 {
        assert!(std::fs::read(frame(n)).unwrap() == good[n as usize - 1], "frame {n} differs after --resume");
    }
    // A frame of another size is not this job's frame either.
    let o = meniscus()
        .args(["render", &seq, "--resume", "--out", &out, "--width", "41", "--height", "30"])
        .args(&small[4..])
        .output()
        .unwrap();
    assert!(o.status.success() && stderr(&o).contains("is 40×30, the frames are 41×30"), "{}", stderr(&o));
}

#[test]
fn an_export_beside_its_input_does_not_spoil_the_folder() {
    let d = common::tmpdir("hostile", "spoil");
    let p = d.join("p");
    std::fs::create_dir_all(&p).unwrap();
    for n in 1..=3 {
        write_bgeo(&p.join(format!("ParticleData_Fluid_{n}.bgeo")), &block(6, &[]));
    }
    // The export's first frames hold no particles (nothing has spawned yet): valid frames for every reader.
    let pattern = p.join("ParticleData_Fluid_{}.bgeo").to_string_lossy().into_owned();
    let foam = p.join("foam_{}.bgeo").to_string_lossy().into_owned();
    let o = meniscus().args(["diffuse", &pattern, "--radius", "0.01", "--export", &foam]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = meniscus().arg("info").arg(p.join("foam_0001.bgeo")).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("particles:   0"), "{}", String::from_utf8_lossy(&o.stdout));
    // The folder now holds two sequences: it names them instead of mixing them.
    let o = meniscus()
        .arg("render")
        .arg(&p)
        .args(["--radius", "0.01", "--width", "32", "--height", "24", "--out"])
        .arg(d.join("out/"))
        .output()
        .unwrap();
    fails_with(&o, &["holds 2 particle sequences", "ParticleData_Fluid_{}.bgeo' (3 files)", "foam_{}.bgeo' (3 files)"]);
    // Each reader takes a file without particles; what needs particles says so.
    let empty = Particles::default();
    write_bgeo(&d.join("empty.bgeo"), &empty);
    std::fs::write(d.join("empty.vtk"), scene::vtk::write(&empty.to_raw(), true)).unwrap();
    std::fs::write(d.join("empty.csv"), "x,y,z\n").unwrap();
    std::fs::write(
        d.join("empty.ply"),
        "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
    )
    .unwrap();
    for f in ["empty.bgeo", "empty.vtk", "empty.csv", "empty.ply"] {
        let got = scene::load(&d.join(f));
        assert!(got.as_ref().is_ok_and(|p| p.is_empty()), "{f}: {:?}", got.err());
    }
    let o = meniscus().arg("render").arg(d.join("empty.bgeo")).arg("--out").arg(d.join("x.png")).output().unwrap();
    fails_with(&o, &["holds no particles"]);
    // A sequence whose first frame is empty fits its camera and radius to the first frame with particles.
    let q = d.join("q");
    std::fs::create_dir_all(&q).unwrap();
    write_bgeo(&q.join("g_1.bgeo"), &empty);
    write_bgeo(&q.join("g_2.bgeo"), &block(6, &[]));
    let o = meniscus()
        .arg("render")
        .arg(q.join("g_{}.bgeo"))
        .args(["--width", "32", "--height", "24", "--out"])
        .arg(d.join("q-out/"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(d.join("q-out/frame_0001.png").is_file() && d.join("q-out/frame_0002.png").is_file());
}

#[test]
fn errors_say_what_happened() {
    let d = common::tmpdir("hostile", "say");
    // `encode` of a folder of PNG frames, as its help says.
    let frames = d.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for n in 1..=3 {
        image::RgbaImage::from_pixel(32, 24, image::Rgba([n as u8 * 60, 80, 120, 255]))
            .save(frames.join(format!("frame_{n:04}.png")))
            .unwrap();
    }
    let o = meniscus()
        .arg("encode")
        .arg(format!("{}/", frames.display()))
        .arg("--out")
        .arg(d.join("m.mp4"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("3 frames"), "{}", stderr(&o));
    let o = meniscus().arg("encode").arg(&d).arg("--out").arg(d.join("n.mp4")).output().unwrap();
    fails_with(&o, &["holds no PNG files"]);
    // All particles at one point: why the radius cannot be estimated, and what to do.
    let one = Particles { positions: vec![[1e-30; 3]; 500], ..Default::default() };
    write_bgeo(&d.join("one.bgeo"), &one);
    let o = meniscus().arg("info").arg(d.join("one.bgeo")).output().unwrap();
    fails_with(&o, &["cannot estimate the particle radius", "500 particles within", "--radius"]);
    // A GPU mesh larger than the device gives one buffer: the size, the flag and what to do.
    let dense = d.join("dense.bgeo");
    write_bgeo(&dense, &block(19, &[]));
    let o = meniscus()
        .arg("mesh")
        .arg(&dense)
        .args(["--radius", "0.01", "--gpu", "--cube-size", "0.06", "--out"])
        .arg(d.join("g.ply"))
        .output()
        .unwrap();
    fails_with(&o, &["--cube-size 0.06", "GB", "larger --cube-size"]);
    assert!(!stderr(&o).contains("Vulkan call"), "{}", stderr(&o));
    // A legacy VTK whose POINTS count is too small for its data.
    let raw = block(4, &[]).to_raw();
    for binary in [false, true] {
        let mut t = scene::vtk::write(&raw, binary);
        let at = t.windows(9).position(|w| w == b"POINTS 64").unwrap();
        t[at..at + 9].copy_from_slice(b"POINTS 60");
        let e = scene::vtk::parse(Path::new("x.vtk"), &t).unwrap_err().to_string();
        assert!(e.contains("the data of POINTS is longer than its count (60) says"), "binary {binary}: {e}");
    }
}

#[test]
fn flags_are_used_or_refused() {
    let d = common::tmpdir("hostile", "flags");
    let o = meniscus().args(["bench", "--chart"]).arg(d.join("c.png")).output().unwrap();
    fails_with(&o, &["--chart", "--sweep"]);
    let o =
        meniscus().args(["sim", "dambreak", "--particles", "2000", "--frames", "2", "--fps", "1e9"]).output().unwrap();
    fails_with(&o, &["fps"]);
    let o = meniscus()
        .args(["sim", "dambreak", "--particles", "2000", "--frames", "2", "--fluid-scale", "0.3"])
        .output()
        .unwrap();
    fails_with(&o, &["--fluid-scale", "draws nothing"]);
    let f = d.join("p.bgeo");
    write_bgeo(&f, &block(6, &[]));
    let o = meniscus().arg("render").arg(&f).args(["--scale", "1e-20", "--out"]).arg(d.join("x.png")).output().unwrap();
    fails_with(&o, &["--scale"]);
    assert!(!d.join("x.png").exists());
}

/// A killed run's partial files are removed by the next run that writes the same outputs, and only those: a
/// partial-looking file of another name (a user's, another job's frame this run does not write) stays, and so
/// does another machine's.
#[test]
fn a_killed_runs_partial_files_are_cleaned_by_the_next_run() {
    let d = common::tmpdir("hostile", "litter");
    for n in 1..=4 {
        write_bgeo(&d.join(format!("f_{n}.bgeo")), &block(5, &[]));
    }
    let seq = d.join("f_{}.bgeo").to_string_lossy().into_owned();
    let out = d.join("m/m.ply");
    std::fs::create_dir_all(d.join("m")).unwrap();
    // What a SIGKILL'ed `mesh SEQ` leaves: a partial file of a process that no longer runs.
    let mut child = Command::new("sleep").arg("0").spawn().unwrap();
    let dead = child.id();
    child.wait().unwrap();
    let host = meniscus::output::host_tag();
    let litter = d.join(format!("m/m_0002.ply.{dead}.{host}.partial"));
    let older = d.join(format!("m/m_0001.ply.{dead}.partial"));
    // Not this run's outputs: a frame it does not write, and a user's file that merely looks like a partial one.
    let later = d.join(format!("m/m_0004.ply.{dead}.{host}.partial"));
    let users = d.join(format!("m/notes.txt.{dead}.{host}.partial"));
    // Another machine's partial file (a cluster shard writing into the same folder) is never touched.
    let other = d.join(format!("m/m_0002.ply.{dead}.othernode.partial"));
    for f in [&litter, &older, &later, &users, &other] {
        std::fs::write(f, b"ply\nhalf").unwrap();
    }
    let run = |frames: &str| {
        let o = meniscus().args(["mesh", &seq, "--radius", "0.01", "--frames", frames, "--out"]).arg(&out).output();
        let o = o.unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    };
    run("1..2");
    assert!(
        !litter.exists() && !older.exists(),
        "the killed run's partial files of this run's outputs are still there"
    );
    assert!(later.exists(), "a partial file of a frame this run does not write was removed");
    assert!(users.exists(), "a file of another name was removed");
    assert!(other.exists(), "another machine's partial file was removed");
    assert!(d.join("m/m_0001.ply").is_file());
    // The run that writes frame 4 cleans its litter.
    run("3..4");
    assert!(!later.exists() && users.exists());
}

/// Silent garbage a hostile user found, each now an error that says why, with no output written: a `--scale`
/// that leaves a given radius meaningless, a frame rate whose steps the step bound cannot hold (or a `max_dt`
/// that needs more than 1,000 steps a frame), the fluid's own files given as diffuse particles, an output named
/// only by its extension, and a report whose folder does not exist. Each case is run once as it should work first
/// (the negative control: the refusal is about the value, not the command).
#[test]
fn silent_garbage_is_an_error() {
    let d = common::tmpdir("hostile", "garbage");
    for n in 1..=2 {
        write_bgeo(&d.join(format!("f_{n}.bgeo")), &block(8, &[]));
    }
    let f1 = d.join("f_1.bgeo");
    let seq = d.join("f_{}.bgeo").to_string_lossy().into_owned();
    // --scale: the radius (given) against the particles' spacing.
    let mesh = |scale: &str, out: &str| {
        meniscus()
            .arg("mesh")
            .arg(&f1)
            .args(["--radius", "0.01", "--scale", scale, "--out"])
            .arg(d.join(out))
            .output()
            .unwrap()
    };
    assert!(mesh("1", "ok.ply").status.success());
    fails_with(&mesh("1e-5", "tiny.ply"), &["f_1.bgeo", "radius", "--scale"]);
    assert!(!d.join("tiny.ply").exists());
    // The step bound: --fps 1e-9 would run 1,000 steps of 1e6 s.
    let sim = |fps: &str, out: &str| {
        meniscus()
            .args(["sim", "dambreak", "--particles", "1000", "--frames", "1", "--fps", fps, "--export"])
            .arg(d.join(out))
            .output()
            .unwrap()
    };
    assert!(sim("25", "ok_{}.bgeo").status.success(), "{}", stderr(&sim("25", "ok2_{}.bgeo")));
    fails_with(&sim("1e-9", "slow_{}.bgeo"), &["frames/s", "max_dt"]);
    assert!(!d.join("slow_1.bgeo").exists());
    std::fs::write(d.join("dt.toml"), "[sim]\nmax_dt = 1e-9\n").unwrap();
    let o = meniscus()
        .args(["sim", "dambreak", "--particles", "1000", "--frames", "1", "--settings"])
        .arg(d.join("dt.toml"))
        .arg("--export")
        .arg(d.join("dt_{}.bgeo"))
        .output()
        .unwrap();
    fails_with(&o, &["max_dt"]);
    // --diffuse given the fluid's own files.
    let o = meniscus()
        .args(["render", &seq, "--width", "40", "--height", "30", "--radius", "0.01", "--diffuse", &seq, "--out"])
        .arg(d.join("png/f_{}.png"))
        .output()
        .unwrap();
    fails_with(&o, &["not a file of diffuse particles"]);
    // An output named only by its extension.
    let o =
        meniscus().arg("mesh").arg(&f1).args(["--radius", "0.01", "--out"]).arg(d.join("m/.usda")).output().unwrap();
    fails_with(&o, &[".usda", "nothing before"]);
    assert!(!d.join("m/.usda").exists());
    // A report into a folder that does not exist is refused, and the folder is not made.
    let o = meniscus()
        .arg("bench")
        .arg("--mesh")
        .arg(&f1)
        .args(["--radius", "0.01", "--threads", "1", "--cube-size", "1.0", "--chart"])
        .arg(d.join("nowhere/deeper/c.png"))
        .output()
        .unwrap();
    fails_with(&o, &["--chart", "does not exist"]);
    assert!(!d.join("nowhere").exists(), "a report created its folders");
}
