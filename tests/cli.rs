//! The `meniscus` binary as a user runs it: a PNG from a built-in scene, clear errors and no PNG on bad input.

mod common;

use common::meniscus;

/// The names of the partial files (`NAME.PID.HOST.partial`, what a writer renames into place) left in `d`.
fn partials(d: &std::path::Path) -> Vec<String> {
    std::fs::read_dir(d)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".partial"))
        .collect()
}

/// `meniscus render FRAME` at 64×48 with `extra` flags, into `png`.
fn render_small(frame: &std::path::Path, extra: &[&str], png: &std::path::Path) -> std::process::Output {
    let size = ["--width", "64", "--height", "48"];
    meniscus().arg("render").arg(frame).args(size).args(extra).arg("--out").arg(png).output().unwrap()
}

/// `meniscus bench ARGS --validation --json FILE` in a fresh folder named `name`: it must succeed; its output
/// and the JSON report.
fn bench_json(name: &str, args: &[&str]) -> (std::process::Output, serde_json::Value) {
    let json = common::tmpdir("cli", name).join("bench.json");
    let o = meniscus().arg("bench").args(args).args(["--validation", "--json"]).arg(&json).output().unwrap();
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    (o, serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap())
}

#[test]
fn render_builtin_scene_writes_png_and_timings() {
    let d = common::tmpdir("cli", "ok");
    let out = d.join("f.png");
    let o = meniscus()
        .args(["render", "drop", "--particles", "3000", "--width", "64", "--height", "48", "--timings", "--validation"])
        .args(["--surface", "spheres", "--dump", "depth,smoothed,thickness,normals,ssr"])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    // Not recorded here: upsample (full resolution), anisotropy/iso/mesh (spheres), diffuse (no spray, no
    // diffuse particles).
    let absent = ["upsample", "anisotropy", "iso", "mesh", "diffuse"];
    for pass in meniscus::renderer::pass_names().iter().filter(|p| !absent.contains(*p)) {
        assert!(stdout.contains(&format!("| {pass} |")), "timings lack {pass}: {stdout}");
    }
    let img = image::open(&out).unwrap();
    assert_eq!((img.width(), img.height()), (64, 48));
    for dump in ["f.depth.npy", "f.smoothed.npy", "f.thickness.npy", "f.normals.npy", "f.ssr.png"] {
        let bytes = std::fs::read(d.join(dump)).unwrap_or_else(|e| panic!("{dump}: {e}"));
        if dump.ends_with(".npy") {
            assert!(bytes.starts_with(b"\x93NUMPY"), "{dump} is not .npy");
        }
    }
    // Reduced resolution runs the upsample pass; the iso-surface runs the iso pass (here at half resolution).
    let o = meniscus()
        .args([
            "render",
            "drop",
            "--particles",
            "3000",
            "--width",
            "64",
            "--height",
            "48",
            "--timings",
            "--fluid-scale",
            "0.5",
        ])
        .args(["--surface", "iso", "--validation"])
        .arg("--out")
        .arg(d.join("half.png"))
        .output()
        .unwrap();
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("| upsample |") && stdout.contains("| iso |"), "{stdout}");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!stderr.contains("[vulkan"), "validation messages: {stderr}");
    // Anisotropic kernels add the anisotropy pass before iso (the kernels, like the weights, are made when the
    // particles change: the table lists them from the first frame); a bad kernel name is a one-line error.
    let o = meniscus()
        .args(["render", "drop", "--particles", "3000", "--width", "64", "--height", "48", "--timings"])
        .args(["--surface", "iso", "--kernel", "anisotropic", "--validation"])
        .arg("--out")
        .arg(d.join("aniso.png"))
        .output()
        .unwrap();
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    let once = |p: &str| stdout.contains(&format!("| {p} (first frame only: runs when the particles change) |"));
    assert!(once("anisotropy") && once("iso_density") && stdout.contains("| iso |"), "{stdout}");
    let o = meniscus().args(["render", "drop", "--kernel", "elliptic"]).output().unwrap();
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("isotropic, anisotropic"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn corrupt_file_gives_one_line_error_and_no_png() {
    let d = common::tmpdir("cli", "bad");
    let bad = d.join("broken.bgeo");
    let mut bytes = meniscus::scene::bgeo::write(
        &meniscus::scene::Particles { positions: vec![[0.0; 3]; 100], ..Default::default() }.to_raw(),
        false,
    );
    bytes.truncate(300);
    std::fs::write(&bad, bytes).unwrap();
    let out = d.join("never.png");
    let o = meniscus().arg("render").arg(&bad).arg("--out").arg(&out).output().unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
    assert!(err.contains("broken.bgeo") && err.contains("byte"), "{err}");
    assert!(!out.exists(), "no PNG on failure");
    assert_eq!(partials(&d), Vec::<String>::new(), "a partial file was left");
}

#[test]
fn bad_background_obj_is_a_one_line_error_with_the_byte_offset() {
    let d = common::tmpdir("cli", "obj");
    let obj = d.join("bad.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap();
    let out = d.join("never.png");
    let o = meniscus()
        .args(["render", "drop", "--particles", "500", "--width", "32", "--height", "24", "--background-obj"])
        .arg(&obj)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.obj") && err.contains("byte 16") && err.contains("index 9"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out.exists());
}

#[test]
fn bad_flags_are_errors_not_panics() {
    for args in [
        vec!["render", "no-such-scene"],
        vec!["render", "block", "--camera", "1,2:3"],
        vec!["render", "block", "--width", "0"],
        vec!["render", "block", "--radius", "-1"],
        vec!["render", "block", "--dump", "bogus"],
    ] {
        let o = meniscus().args(&args).arg("--out").arg(common::tmpdir("cli", "flags").join("x.png")).output().unwrap();
        assert_eq!(o.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.starts_with("error:") && !err.contains("panicked"), "{args:?}: {err}");
    }
}

/// CI smoke test of the benchmark: tiny workload, valid JSON with every pass; no timing is asserted.
#[test]
fn tiny_bench_writes_valid_json() {
    let (o, v) = bench_json(
        "bench",
        &["--scenes", "block:2000", "--preset", "fast", "--resolutions", "64x64", "--warmup", "1", "--frames", "3"],
    );
    assert_eq!(v["schema"], 1);
    assert!(!v["device"]["name"].as_str().unwrap().is_empty());
    let e = &v["entries"][0];
    assert_eq!(e["width"], 64);
    assert_eq!(e["frames"], 3);
    let passes: Vec<&str> = e["passes"].as_array().unwrap().iter().map(|p| p[0].as_str().unwrap()).collect();
    let want: Vec<&str> = meniscus::renderer::pass_names()
        .iter()
        .copied()
        .filter(|p| !["upsample", "anisotropy", "iso", "mesh", "diffuse"].contains(p))
        .collect();
    assert_eq!(passes, want);
    assert!(e["memory_images_bytes"].as_u64().unwrap() > 0);
    // Timing sanity: one entry per pass, none negative, and every frame's total is at least the sum of the passes'
    // minima (the total is the per-frame sum of the passes).
    let stat = |p: &serde_json::Value, k: &str| p[k].as_f64().unwrap();
    let mut sum_min = 0.0;
    for p in e["passes"].as_array().unwrap() {
        assert!(stat(&p[1], "min") >= 0.0 && stat(&p[1], "median") >= stat(&p[1], "min"), "{p}");
        sum_min += stat(&p[1], "min");
    }
    assert!(stat(&e["gpu_total"], "min") + 1e-9 >= sum_min, "total {} < sum of minima {sum_min}", e["gpu_total"]);
    // The work each pass did (pipeline statistics, which lavapipe has): every pass counted, the composite at
    // least one invocation per pixel.
    if v["device"]["pipeline_statistics"] == true {
        let inv = e["invocations"].as_array().unwrap();
        let count = |p: &str| inv.iter().find(|x| x[0] == p).and_then(|x| x[1].as_u64());
        for p in &want {
            assert!(count(p).is_some_and(|n| n > 0), "{p}: no invocations in {inv:?}");
        }
        assert!(count("composite").unwrap() >= 64 * 64, "{inv:?}");
    } else {
        assert!(!v["device"]["name"].as_str().unwrap().contains("llvmpipe"), "lavapipe has pipeline statistics");
    }
    // Host memory at the start and end of the run (issue #17).
    assert!(v["rss_start_bytes"].as_u64().unwrap() > 0 && v["rss_end_bytes"].as_u64().unwrap() > 0);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("[vulkan"));
}

/// `bench --also-presets` measures the main preset and the others with their frames interleaved (one renderer
/// each): one entry per preset in order, each with its own passes (iso in `default` and `quality`, the depth
/// filter in `fast`; the weights and the smoothed field of a static frame were built in a warm-up frame and so
/// are not in the measured ones), and the ratio lines. No timing is asserted.
#[test]
fn bench_also_presets_interleaves_every_preset() {
    let (o, v) = bench_json(
        "bench-also",
        &[
            "--scenes",
            "wave:3000",
            "--resolutions",
            "64x48",
            "--warmup",
            "1",
            "--frames",
            "2",
            "--also-presets",
            "quality,fast",
        ],
    );
    let entries = v["entries"].as_array().unwrap();
    let variants: Vec<&str> = entries.iter().map(|e| e["variant"].as_str().unwrap()).collect();
    assert_eq!(variants, ["default", "quality", "fast"]);
    let has = |e: &serde_json::Value, pass: &str| e["passes"].as_array().unwrap().iter().any(|p| p[0] == pass);
    for e in entries {
        assert_eq!(e["frames"], 2);
        assert_eq!(has(e, "iso"), e["variant"] != "fast", "{}", e["variant"]);
        assert_eq!(has(e, "filter"), e["variant"] == "fast", "{}", e["variant"]);
        // The iso pass's queued rays are reported where it ran (a count, not a time).
        assert_eq!(e["iso_work"]["queued"].is_u64(), has(e, "iso"), "{}", e["iso_work"]);
        // Each pass's own counts of its work where it ran: field samples, sphere–pixel tests.
        assert_eq!(e["iso_work"]["samples"].as_u64().is_some_and(|n| n > 0), has(e, "iso"), "{}", e["iso_work"]);
        assert!(e["splat_work"]["tests"].as_u64().is_some_and(|n| n > 0), "{}", e["splat_work"]);
        for once in ["iso_density", "iso_volume"] {
            assert!(!has(e, once), "{once} of a static frame runs once, in warm-up");
        }
        assert!(e["iso_volume_work"].is_null(), "no measured frame rebuilt the field");
        assert!(e["cpu_frame_in_flight"].is_null(), "frames in flight only with --in-flight");
    }
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("Work per pass") && out.contains("sphere–pixel tests"), "{out}");
    assert!(out.contains("quality") && out.contains("÷ default"), "{out}");
    assert!(!String::from_utf8_lossy(&o.stderr).contains("[vulkan"));
}

/// `bench --in-flight` renders as many frames again with the renderer's frames in flight, a new frame of a
/// sequence uploaded while the GPU works on the one before (validation and synchronisation validation on), and
/// reports their wall time per frame beside the CPU frame, for every preset of the run. No timing is asserted.
#[test]
fn bench_in_flight_reports_the_overlapped_frame_time() {
    let d = common::tmpdir("cli", "bench-in-flight-frames");
    // Three frames of different particle counts: each frame's box and grid differ.
    for k in 0..3 {
        let g = meniscus::scene::procedural::generate("wave", 2000 + 300 * k).unwrap();
        meniscus::scene::write_particles(&d.join(format!("f_{k}.bgeo")), &g.particles).unwrap();
    }
    let pattern = d.join("f_{}.bgeo");
    let (o, v) = bench_json(
        "bench-in-flight",
        &[
            "--scenes",
            pattern.to_str().unwrap(),
            "--sequence-frames",
            "0..2",
            "--resolutions",
            "64x48",
            "--warmup",
            "1",
            "--frames",
            "3",
            "--also-presets",
            "fast",
            "--in-flight",
        ],
    );
    let entries = v["entries"].as_array().unwrap();
    assert_eq!(entries.len(), 2);
    for e in entries {
        let ms = e["cpu_frame_in_flight"].as_f64().unwrap_or(0.0);
        assert!(ms > 0.0, "{}: {}", e["variant"], e["cpu_frame_in_flight"]);
    }
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("CPU frame, frames in flight"), "{out}");
    assert!(!String::from_utf8_lossy(&o.stderr).contains("[vulkan"));
}

/// The same SPlisHSPlasH frame from .bgeo and from .vtk renders to byte-identical PNGs (shared data; fails under
/// CI=true when absent).
#[test]
fn bgeo_and_vtk_of_one_frame_render_identically() {
    let Some(root) = common::shared_data("splishsplash/dambreak_6859") else { return };
    let d = common::tmpdir("cli", "same");
    let mut outs = vec![];
    for f in ["partio/ParticleData_Fluid_20.bgeo", "vtk/ParticleData_Fluid_20.vtk"] {
        let out = d.join(format!("{}.png", f.replace('/', "_")));
        let o = meniscus()
            .arg("render")
            .arg(root.join(f))
            .args(["--width", "160", "--height", "90", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        outs.push(std::fs::read(&out).unwrap());
    }
    assert!(outs[0] == outs[1], "the .bgeo and .vtk renders differ");
}

/// A sequence renders to numbered PNGs, honouring --frames and --shard.
#[test]
fn sequence_renders_numbered_pngs() {
    let d = common::tmpdir("cli", "seq");
    for n in [1, 2, 3, 10, 11] {
        let p = meniscus::scene::procedural::generate("drop", 800).unwrap().particles;
        std::fs::write(d.join(format!("f_{n}.bgeo")), meniscus::scene::bgeo::write(&p.to_raw(), true)).unwrap();
    }
    let out = d.join("out");
    let o = meniscus()
        .arg("render")
        .arg(format!("{}/f_{{}}.bgeo", d.display()))
        .args(["--frames", "2..11", "--shard", "1/2", "--width", "48", "--height", "32", "--out"])
        .arg(out.join("img_{}.png"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut names: Vec<String> =
        std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    // Frames 2, 3, 10, 11 → shard 1/2 keeps 2 and 10.
    assert_eq!(names, vec!["img_0002.png", "img_0010.png"]);
}

/// `mesh` of a sequence: one mesh per frame of --frames, numbered, and a closing line (the bar is hidden when
/// stderr is not a terminal).
#[test]
fn mesh_of_a_sequence_honours_frames() {
    let d = common::tmpdir("cli", "meshseq");
    for n in [1, 2, 3] {
        let p = meniscus::scene::procedural::generate("drop", 500).unwrap().particles;
        std::fs::write(d.join(format!("f_{n}.bgeo")), meniscus::scene::bgeo::write(&p.to_raw(), true)).unwrap();
    }
    let o = meniscus()
        .arg("mesh")
        .arg(format!("{}/f_{{}}.bgeo", d.display()))
        .args(["--frames", "2..3", "--cube-size", "1", "--out"])
        .arg(d.join("out/m_{}.obj"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("2 meshes"), "{err}");
    let mut names: Vec<String> = std::fs::read_dir(d.join("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, vec!["m_0002.obj", "m_0003.obj"]);
}

/// A camera east of / below the origin: values with a leading minus sign are values, not flags.
#[test]
fn negative_numbers_in_flag_values() {
    let d = common::tmpdir("cli", "neg");
    let out = d.join("neg.png");
    let o = meniscus()
        .args(["render", "drop", "--particles", "800", "--width", "32", "--height", "24"])
        .args(["--camera", "-0.5,1.0,2.2:0.3,0.3,-0.5:50", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--camera -0.5,"));
    // A negative value where it makes no sense is the flag's own error, not clap's "unexpected argument".
    let o = meniscus().args(["render", "drop", "--scale", "-2", "--out"]).arg(d.join("bad.png")).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && !err.contains("unexpected argument"), "{err}");
    assert!(!d.join("bad.png").exists());
}

/// Issue #16: a ParaView `.pvd` collection renders as a sequence (frames in timestep order, progress bar), and
/// `info` lists it.
#[test]
fn pvd_series_renders_as_a_sequence() {
    let d = common::tmpdir("cli", "pvd");
    let pvd = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/vtk/series.pvd");
    let o = meniscus()
        .arg("render")
        .arg(&pvd)
        .args(["--width", "40", "--height", "30", "--radius", "0.05", "--out"])
        .arg(d.join("s_{}.png"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("3 frames"), "{err}");
    for k in 0..3 {
        assert!(d.join(format!("s_{k:04}.png")).exists(), "frame {k} missing: {err}");
    }
    let o = meniscus().arg("info").arg(&pvd).output().unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && out.contains("sequence:    3 frames") && out.contains("step_0.vtu"), "{out}");
}

/// Issue #12: a sequence renders with frames in flight (2 on the GPU, PNGs written on a worker thread) clean
/// under synchronization validation, and every frame is pixel-identical to the same sequence rendered one frame
/// at a time (`--frames-in-flight 1`).
#[test]
fn sequence_with_frames_in_flight_matches_one_at_a_time() {
    let d = common::tmpdir("cli", "inflight");
    for n in 1..=6 {
        let mut p = meniscus::scene::procedural::generate("drop", 600).unwrap().particles;
        for q in p.positions.iter_mut() {
            q[1] += 0.02 * n as f32; // every frame differs
        }
        std::fs::write(d.join(format!("f_{n}.bgeo")), meniscus::scene::bgeo::write(&p.to_raw(), false)).unwrap();
    }
    let pattern = format!("{}/f_{{}}.bgeo", d.display());
    for (fif, out) in [("2", "a_{}.png"), ("1", "b_{}.png")] {
        let o = meniscus()
            .arg("render")
            .arg(&pattern)
            .args(["--radius", "0.02", "--width", "64", "--height", "48", "--validation"])
            .args(["--frames-in-flight", fif, "--out"])
            .arg(d.join(out))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{err}");
        assert!(!err.contains("[vulkan"), "{err}");
    }
    for n in 1..=6 {
        let a = image::open(d.join(format!("a_{n:04}.png"))).unwrap().to_rgba8();
        let b = image::open(d.join(format!("b_{n:04}.png"))).unwrap().to_rgba8();
        assert!(a == b, "frame {n}: 2 frames in flight and 1 differ");
    }
}

/// Issue #14 (first part): `meniscus mesh` writes a PLY or OBJ that loads back (vertices = the mesh's), the same
/// mesh with 1 and 2 threads; a wrong extension is a one-line error and no file.
#[test]
fn mesh_subcommand_writes_ply_and_obj() {
    let d = common::tmpdir("cli", "mesh");
    let run = |out: &str, threads: &str| {
        meniscus()
            .args(["mesh", "drop", "--particles", "600", "--cube-size", "1", "--threads", threads, "--out"])
            .arg(d.join(out))
            .output()
            .unwrap()
    };
    let o = run("a.ply", "1");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("triangles"), "{err}");
    // Where the time goes: the block path's stages.
    assert!(["scatter", "march", "weld", "written in"].iter().all(|s| err.contains(s)), "{err}");
    // Laplacian smoothing moves the vertices, not the connectivity.
    let o = meniscus()
        .args(["mesh", "drop", "--particles", "600", "--cube-size", "1", "--smoothing-iters", "5", "--out"])
        .arg(d.join("s.ply"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.contains("smoothed (5 iterations)"), "{err}");
    let (raw, smooth) =
        (meniscus::scene::load(&d.join("a.ply")).unwrap(), meniscus::scene::load(&d.join("s.ply")).unwrap());
    assert_eq!(raw.len(), smooth.len());
    assert!(raw.positions != smooth.positions, "smoothing moved nothing");
    let o =
        meniscus().args(["mesh", "drop", "--smoothing-iters", "5000", "--out"]).arg(d.join("t.ply")).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--smoothing-iters"));
    assert!(!d.join("t.ply").exists());
    // The same bytes on any thread count (the automatic block size follows the particles, not the threads).
    let o = run("b.ply", "2");
    assert!(o.status.success());
    let same_block = |out: &str, threads: &str| {
        let o = meniscus()
            .args(["mesh", "drop", "--particles", "600", "--cube-size", "1", "--block", "64", "--threads", threads])
            .arg("--out")
            .arg(d.join(out))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(d.join(out)).unwrap()
    };
    assert_eq!(same_block("a64.ply", "1"), same_block("b64.ply", "2"), "threads changed the mesh");
    assert_eq!(std::fs::read(d.join("a.ply")).unwrap(), std::fs::read(d.join("b.ply")).unwrap(), "threads changed it");
    let p = meniscus::scene::load(&d.join("a.ply")).unwrap();
    assert!(p.len() > 100, "{} vertices", p.len());
    assert!(run("c.obj", "2").status.success());
    let obj = std::fs::read_to_string(d.join("c.obj")).unwrap();
    assert_eq!(obj.lines().filter(|l| l.starts_with("v ")).count(), p.len());
    assert!(obj.lines().any(|l| l.starts_with("f ")));
    let o = run("d.stl", "1");
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains(".ply, .obj, .vtk, .usd or .vdb"));
    assert!(!d.join("d.stl").exists());
    assert_eq!(partials(&d), Vec::<String>::new(), "a partial file was left");
    // Particles too far apart for one lattice at this cube size: an error naming the file, no output.
    std::fs::write(d.join("far.csv"), "x,y,z\n0,0,0\n1000000,1000000,1000000\n").unwrap();
    let o = meniscus()
        .args(["mesh", "--radius", "0.001", "--out"])
        .arg(d.join("far.ply"))
        .arg(d.join("far.csv"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("far.csv") && err.contains("--cube-size"), "{err}");
    assert!(!d.join("far.ply").exists());
    // --gpu (the `mc` pass, under validation): the same vertices, and the GPU stages' times printed.
    let o = meniscus()
        .args(["mesh", "drop", "--particles", "600", "--cube-size", "1", "--gpu", "--validation", "--out"])
        .arg(d.join("g.ply"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("mc_field") && err.contains("mc_emit"), "{err}");
    let g = meniscus::scene::load(&d.join("g.ply")).unwrap();
    assert_eq!(g.len(), p.len(), "GPU and CPU vertex counts");
    // The GPU numbers its vertices in its own order: every GPU vertex has a CPU vertex within 1e-4.
    let mut cpu = p.positions.clone();
    cpu.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let dmax = g
        .positions
        .iter()
        .map(|a| {
            let lo = cpu.partition_point(|b| b[0] < a[0] - 1e-4);
            cpu[lo..]
                .iter()
                .take_while(|b| b[0] <= a[0] + 1e-4)
                .map(|b| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0f32, f32::max))
                .fold(f32::INFINITY, f32::min)
        })
        .fold(0f32, f32::max);
    assert!(dmax < 1e-4, "GPU vertices {dmax} from the CPU's");
    // Legacy VTK POLYDATA: the same vertices (our loader reads its POINTS).
    assert!(run("e.vtk", "2").status.success());
    let v = meniscus::scene::load(&d.join("e.vtk")).unwrap();
    assert_eq!(
        v.positions,
        meniscus::scene::load(&d.join("b.ply")).unwrap().positions,
        "the PLY's vertices (2 threads)"
    );
    // The thesis' metaball field: a closed mesh too; a threshold past its peak is an error.
    let o = meniscus()
        .args(["mesh", "drop", "--particles", "600", "--cube-size", "1", "--field", "metaball", "--out"])
        .arg(d.join("mb.ply"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(meniscus::scene::load(&d.join("mb.ply")).unwrap().len() > 100);
    let o = meniscus().args(["mesh", "drop", "--field", "metaball", "--threshold", "0.5"]).output().unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("(0, 0.25)"));
    // The thesis' comparison: three labelled panels side by side.
    let o = meniscus()
        .args(["mesh", "drop", "--particles", "600", "--cube-size", "1", "--width", "80", "--height", "60"])
        .args(["--validation", "--compare"])
        .arg(d.join("cmp.png"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("ms CPU extraction + BVH") && err.contains("iso-surface ray cast"), "{err}");
    let img = image::open(d.join("cmp.png")).unwrap();
    assert_eq!((img.width(), img.height()), (240, 60));
}

/// `bench --flicker` reports a sequence's flicker in its JSON and table (`meniscus quality`'s measure): a
/// sequence of one frame repeated does not change at all, the same frame jittered by a tenth of a radius per
/// frame does (the control); a still workload has none.
#[test]
fn bench_reports_a_sequences_flicker() {
    let d = common::tmpdir("cli", "bench-flicker");
    let g = meniscus::scene::procedural::generate("wave", 3000).unwrap();
    let r = g.radius;
    for k in 1..=4u32 {
        meniscus::scene::write_particles(&d.join(format!("still_{k}.bgeo")), &g.particles).unwrap();
        let mut p = g.particles.clone();
        for (i, x) in p.positions.iter_mut().enumerate() {
            // A fixed pseudo-random offset per particle and frame, ±0.1 r on each axis.
            let h = |a: u32| ((i as u32).wrapping_mul(2_654_435_761) ^ (k * 97 + a).wrapping_mul(40_503)) % 1000;
            for (a, c) in x.iter_mut().enumerate() {
                *c += r * 0.1 * (h(a as u32) as f32 / 500.0 - 1.0);
            }
        }
        meniscus::scene::write_particles(&d.join(format!("jitter_{k}.bgeo")), &p).unwrap();
    }
    let flicker = |pattern: &str| {
        let scene = d.join(pattern).to_string_lossy().into_owned();
        let args = ["--scenes", &scene, "--resolutions", "160x90", "--warmup", "1", "--frames", "3", "--flicker"];
        let (o, j) = bench_json(&format!("bench-flicker-{}", &pattern[..5]), &args);
        assert!(String::from_utf8_lossy(&o.stdout).contains("Flicker"), "{}", String::from_utf8_lossy(&o.stdout));
        j["entries"][0]["flicker"].clone()
    };
    let still = flicker("still_{}.bgeo");
    let jitter = flicker("jitter_{}.bgeo");
    assert_eq!(still["pairs"], 3);
    // Identical pictures (the angle between a normal and itself rounds to under a thousandth of a degree).
    assert_eq!(still["colour_mean"].as_f64(), Some(0.0));
    assert!(still["normal_mean_deg"].as_f64().unwrap() < 1e-3, "{still}");
    assert!(jitter["colour_mean"].as_f64().unwrap() > 0.05, "{jitter}");
    assert!(jitter["normal_mean_deg"].as_f64().unwrap() > 0.1, "{jitter}");
    let (_, j) = bench_json(
        "bench-flicker-wave",
        &["--scenes", "wave:2000", "--resolutions", "160x90", "--warmup", "1", "--frames", "1", "--flicker"],
    );
    assert!(j["entries"][0]["flicker"].is_null(), "a still workload has no flicker: {}", j["entries"][0]["flicker"]);
}

/// A scene file's dynamic sphere moves in the simulation, so the export's scene.json carries its centre at every
/// exported frame (`Meniscus.bodies`) and `render` of a frame draws it there: the frames where the ball has
/// fallen differ from a render of the same particles with the track held at frame 1 (the control).
#[test]
fn sim_exports_a_moving_sphere_that_renders_where_it_was() {
    let d = common::tmpdir("cli", "sim-body");
    // An octahedron: round enough (its box is a cube) to be the dynamic sphere, radius 0.2 m.
    std::fs::write(d.join("ball.obj"), "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\nf 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n").unwrap();
    std::fs::write(
        d.join("scene.json"),
        r#"{"Configuration": {"particleRadius": 0.025, "simulationMethod": 4, "dataExportFPS": 25},
            "RigidBodies": [
                {"geometryFile": "UnitBox.obj", "translation": [0, 0.75, 0], "scale": [1.5, 1.5, 1.0], "isWall": true},
                {"geometryFile": "ball.obj", "translation": [0.3, 1.1, 0], "scale": [0.2, 0.2, 0.2], "isDynamic": true,
                 "density": 500}],
            "FluidBlocks": [{"start": [-0.7, 0.0, -0.45], "end": [0.0, 0.4, 0.45]}]}"#,
    )
    .unwrap();
    let out = d.join("cache");
    let o = meniscus()
        .arg("sim")
        .arg(d.join("scene.json"))
        .args(["--frames", "8", "--export"])
        .arg(out.join("f_{}.bgeo"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("dynamic sphere"), "{err}");
    let sj = meniscus::scene::splishsplash::SceneJson::load(&out.join("scene.json")).unwrap();
    assert_eq!(sj.tracks.len(), 1, "{:?}", sj.tracks);
    let t = &sj.tracks[0];
    assert_eq!(t.centres.len(), 8, "one centre per exported frame");
    assert!((t.radius - 0.2).abs() < 1e-3 && t.centres[0].abs_diff_eq(glam::Vec3::new(0.3, 1.1, 0.0), 1e-5));
    // Falling freely for 7 frames (0.28 s): about g t² / 2 = 0.38 m.
    let fall = t.centres[0].y - t.centres[7].y;
    assert!((0.3..0.45).contains(&fall), "fell {fall} m");
    let last = out.join("f_8.bgeo");
    let (moved, held) = (d.join("moved.png"), d.join("held.png"));
    let o = render_small(&last, &[], &moved);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The control: the same frame with the track stopped at frame 1 (the ball where it started).
    let text = std::fs::read_to_string(out.join("scene.json")).unwrap();
    let mut j: serde_json::Value = serde_json::from_str(&text).unwrap();
    let first = j["Meniscus"]["bodies"][0]["centres"][0].clone();
    j["Meniscus"]["bodies"][0]["centres"] = serde_json::json!([first]);
    std::fs::write(out.join("scene.json"), serde_json::to_string(&j).unwrap()).unwrap();
    let o = render_small(&last, &[], &held);
    assert!(o.status.success());
    let (a, b) = (image::open(&moved).unwrap().to_rgba8(), image::open(&held).unwrap().to_rgba8());
    let differ = a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count();
    assert!(differ > 20, "{differ} pixels differ between the ball's place at frame 8 and at frame 1");
}

/// Issue #13: `meniscus sim` writes a cache (position, velocity, density, id) as .bgeo and .vtk that the loaders,
/// `info` and `render` read; bad scenes and patterns are one-line errors that write nothing.
#[test]
fn sim_exports_a_cache_that_loads_and_renders() {
    let d = common::tmpdir("cli", "sim");
    for ext in ["bgeo", "vtk"] {
        let pattern = d.join(format!("f_{{}}.{ext}"));
        let foam = d.join(format!("foam/d_{{}}.{ext}"));
        let o = meniscus()
            .args(["sim", "dambreak", "--particles", "3000", "--frames", "4", "--validation", "--export"])
            .arg(&pattern)
            .arg("--diffuse")
            .arg(&foam)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "stderr: {err}");
        // The live diffuse particles: a file per frame that loads (the first frame spawns only from still water).
        assert!(err.contains("files of diffuse particles"), "{err}");
        for n in 1..=4 {
            meniscus::diffuse::io::load(&d.join(format!("foam/d_{n}.{ext}"))).unwrap();
        }
        assert!(err.contains("sim_solve") && err.contains("steps/s"), "no per-stage times: {err}");
        let first = meniscus::scene::load(&d.join(format!("f_1.{ext}"))).unwrap();
        let last = meniscus::scene::load(&d.join(format!("f_4.{ext}"))).unwrap();
        assert_eq!(first.len(), 14 * 14 * 14);
        assert_eq!(last.len(), first.len(), "particle count conserved");
        let ids = last.ids.as_ref().expect("ids");
        let mut sorted = ids.clone();
        sorted.sort();
        assert_eq!(sorted, (0..first.len() as i64).collect::<Vec<_>>(), "every id once");
        let v = last.velocities.as_ref().expect("velocities");
        assert!(v.iter().any(|v| v[1] < -0.5), "the water is falling");
        let rho = last.densities.as_ref().expect("densities");
        assert!(rho.iter().all(|r| r.is_finite() && *r > 0.0));
        // Every particle inside the tank.
        assert!(last.positions.iter().all(|p| p[0].abs() <= 2.0 && p[1] >= 0.0 && p[2].abs() <= 0.75));
    }
    let png = d.join("sim.png");
    let o = render_small(&d.join("f_4.bgeo"), &[], &png);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "render of the export: {err}");
    assert!(png.exists());
    // The export's scene.json (SPlisHSPlasH's format) gives the radius and the tank, drawn as walls.
    let sj = meniscus::scene::splishsplash::SceneJson::load(&d.join("scene.json")).unwrap();
    assert_eq!(sj.containers.len(), 1);
    assert!((sj.radius.unwrap() - 0.5 * (1.0f32 / 3000.0).cbrt()).abs() < 1e-6);
    assert!(err.contains("(SceneJson)") && err.contains("1 container(s)"), "{err}");
    // Without it the background has no tank: the pictures differ.
    let plain = d.join("plain.png");
    let o = render_small(&d.join("f_4.bgeo"), &["--no-scene-json"], &plain);
    assert!(o.status.success() && String::from_utf8_lossy(&o.stderr).contains("(Estimated)"));
    assert_ne!(image::open(&png).unwrap().to_rgba8(), image::open(&plain).unwrap().to_rgba8());
    // A broken scene.json is reported with its byte and ignored; a foreign one is never overwritten.
    std::fs::write(d.join("scene.json"), "{\"RigidBodies\": [1]}").unwrap();
    let o = render_small(&d.join("f_4.bgeo"), &[], &plain);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.contains("warning: ignoring") && err.contains("byte 17"), "{err}");
    let o = meniscus()
        .args(["sim", "dambreak", "--particles", "300", "--frames", "1", "--overwrite", "--export"])
        .arg(d.join("f_{}.bgeo"))
        .output()
        .unwrap();
    assert!(o.status.success() && String::from_utf8_lossy(&o.stderr).contains("was not written by meniscus"));
    assert_eq!(std::fs::read_to_string(d.join("scene.json")).unwrap(), "{\"RigidBodies\": [1]}");
    for (args, expect) in [
        (vec!["sim", "nope"], "known: dambreak"),
        (vec!["sim", "drop", "--export", "x.png"], ".bgeo or .vtk"),
        (vec!["sim", "drop", "--export", "x.bgeo"], "{}"),
        (vec!["sim", "drop", "--frames", "0"], "--frames"),
        (vec!["sim", "drop", "--particles", "3"], "at least 8"),
    ] {
        let o = meniscus().args(&args).current_dir(&d).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(expect), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    }
    assert!(!d.join("x.png").exists() && !d.join("x.bgeo").exists());
}

/// Issue #13: `sim --collider FILE.obj` keeps the water out of a closed mesh (water that starts inside is removed);
/// a missing, broken or misplaced OBJ is a one-line error naming the file.
#[test]
fn sim_with_a_mesh_collider() {
    let d = common::tmpdir("cli", "sim-collider");
    // A block through the dam-break water cube (x −1.95..−0.95): some water starts inside it.
    let (lo, hi) = ([-1.5f32, 0.0, -0.3], [-0.5f32, 0.4, 0.3]);
    let block = d.join("block.obj");
    std::fs::write(&block, common::box_obj(lo, hi)).unwrap();
    let o = meniscus()
        .args(["sim", "dambreak", "--particles", "3000", "--frames", "6", "--collider"])
        .arg(&block)
        .arg("--export")
        .arg(d.join("f_{}.bgeo"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let first = meniscus::scene::load(&d.join("f_1.bgeo")).unwrap();
    let last = meniscus::scene::load(&d.join("f_6.bgeo")).unwrap();
    assert!(first.len() < 14 * 14 * 14, "the block displaced no water: {}", first.len());
    assert_eq!(last.len(), first.len(), "particle count conserved");
    let r = 0.5 * (1.0f32 / 3000.0).cbrt();
    let inside = |p: &[f32; 3], m: f32| (0..3).all(|k| p[k] > lo[k] - m && p[k] < hi[k] + m);
    assert!(first.positions.iter().all(|p| !inside(p, 0.5 * r)), "water left inside the block");
    assert!(last.positions.iter().all(|p| !inside(p, 0.5 * r)), "water entered the block");
    assert!(last.positions.iter().any(|p| inside(p, 2.0 * r)), "the water never reached the block");
    // The export's scene.json lists the block, so `render` of the export draws it without --background-obj.
    let sj = meniscus::scene::splishsplash::SceneJson::load(&d.join("scene.json")).unwrap();
    assert_eq!(sj.meshes.len(), 1);
    assert_eq!(sj.meshes[0].load().unwrap().triangles.len(), 12);
    let png = d.join("with-block.png");
    let o = render_small(&d.join("f_6.bgeo"), &[], &png);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.contains("1 mesh(es)") && !err.contains("not drawn"), "{err}");
    std::fs::write(d.join("broken.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap();
    std::fs::write(d.join("far.obj"), "v 10 10 10\nv 11 10 10\nv 10 11 10\nf 1 2 3\n").unwrap();
    for (file, expect) in
        [("missing.obj", "missing.obj"), ("broken.obj", "byte 16"), ("far.obj", "outside the container")]
    {
        let o = meniscus().args(["sim", "pool", "--frames", "1", "--collider", file]).current_dir(&d).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(expect), "{file}: {err}");
        assert!(!err.contains("panicked"), "{file} panicked: {err}");
    }
}

/// Issue #13: `bench --sim` reports every stage per step, steps/s, and render + simulate frames with async
/// compute off and on, as JSON.
#[test]
fn bench_sim_reports_stages_and_overlap() {
    let (_, v) = bench_json(
        "bench-sim",
        &[
            "--sim",
            "dambreak:2000",
            "--warmup",
            "0",
            "--frames",
            "1",
            "--resolutions",
            "64x48",
            "--async",
            "both",
            "--diffuse",
        ],
    );
    let stages: Vec<&str> =
        v["stages_ms_per_step"].as_array().unwrap().iter().map(|s| s[0].as_str().unwrap()).collect();
    // Every stage in order, under its one name; sim_vorticity only runs with confinement on (off by default).
    let expected: Vec<&str> =
        meniscus::sim::stages::STAGE_NAMES.iter().copied().filter(|n| *n != "sim_vorticity").collect();
    assert_eq!(stages, expected);
    assert!(v["steps_per_second"].as_f64().unwrap() > 0.0);
    // With --diffuse the spray, foam and bubble stages, once per frame, apart from the step's.
    let diffuse: Vec<&str> =
        v["diffuse_stages_ms_per_frame"].as_array().unwrap().iter().map(|s| s[0].as_str().unwrap()).collect();
    assert_eq!(diffuse, meniscus::sim::diffuse::STAGE_NAMES);
    let combined = v["combined"].as_array().unwrap();
    assert_eq!(combined.len(), 2);
    for c in combined {
        let names: Vec<&str> = c["passes"].as_array().unwrap().iter().map(|p| p[0].as_str().unwrap()).collect();
        assert!(names.contains(&"sim_solve") && names.contains(&"sim_diffuse_spawn"), "{names:?}");
        assert!(names.contains(&"diffuse") && names.contains(&"composite"), "{names:?}");
        assert!(c["union_ms"].as_f64().unwrap() > 0.0);
    }
}

/// `bench --mesh FILE`: every thread count and cube size gets a row with its phases, the first thread count a
/// speed-up of 1, the same mesh at every thread count, and the JSON says so; flags of the analysis are refused
/// without --mesh.
#[test]
fn bench_mesh_reports_phases_per_thread_count() {
    let d = common::tmpdir("cli", "bench-mesh");
    let mut pos = vec![];
    for z in 0..10 {
        for y in 0..10 {
            for x in 0..10 {
                pos.push([x as f32 * 0.02, y as f32 * 0.02, z as f32 * 0.02]);
            }
        }
    }
    let p = meniscus::scene::Particles { positions: pos, ..Default::default() };
    let f = d.join("block.bgeo");
    std::fs::write(&f, meniscus::scene::bgeo::write(&p.to_raw(), true)).unwrap();
    let json = d.join("mesh.json");
    let o = meniscus()
        .arg("bench")
        .arg("--mesh")
        .arg(&f)
        .args(["--radius", "0.01", "--threads", "1,2", "--cube-size", "1.0,0.75", "--mesh-repeat", "1", "--json"])
        .arg(&json)
        .arg("--chart")
        .arg(d.join("scaling.png"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    // The scaling chart: one panel per cube size, side by side.
    let chart = image::open(d.join("scaling.png")).unwrap();
    assert_eq!((chart.width(), chart.height()), (1440, 560));
    let out = String::from_utf8_lossy(&o.stdout);
    // The block size follows the particles and the cube, not the threads: this small frame takes blocks of 32
    // (64 would leave fewer than AUTO_BLOCK_MIN) on one thread and on two.
    assert!(out.contains("| 1 r | 32 | cpu | 1 |") && out.contains("| 1 r | 32 | cpu | 2 |"), "{out}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let rows: Vec<&serde_json::Value> = v["rows"].as_array().unwrap().iter().filter(|r| r["path"] == "cpu").collect();
    assert_eq!(rows.len(), 4);
    for pair in rows.chunks(2) {
        assert_eq!(pair[0]["speedup"].as_f64(), Some(1.0));
        assert_eq!(pair[0]["triangles"], pair[1]["triangles"], "the same mesh at every thread count");
        for r in pair {
            assert!(r["wall"].as_f64().unwrap() > 0.0 && r["blocks"].as_f64().unwrap() > 0.0, "{r}");
            assert!(r["triangles"].as_u64().unwrap() > 100, "{r}");
        }
    }
    let o = meniscus().args(["bench", "--threads", "2"]).output().unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("apply to --mesh FILE"));
}

/// The old spellings still work, each with a warning naming the new one: `meniscus foam` is `meniscus
/// diffuse`, `--foam` is `--diffuse`, and a settings file's `[noise] foam*` keys are `whitecaps*`.
#[test]
fn deprecated_spellings_still_work_with_a_warning() {
    let d = common::tmpdir("cli", "deprecated");
    let stderr = |o: &std::process::Output| String::from_utf8_lossy(&o.stderr).into_owned();
    // The subcommand and the flag: parsed as the new ones (the missing input is the error after the warning).
    let missing = d.join("none_{}.bgeo").to_string_lossy().into_owned();
    let export = d.join("out_{}.bgeo").to_string_lossy().into_owned();
    let o = meniscus().args(["foam", &missing, "--export", &export]).output().unwrap();
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("`meniscus foam` is deprecated: it is `meniscus diffuse` now"), "{e}");
    let o = meniscus().args(["render", &missing, "--foam", "--out"]).arg(d.join("f_{}.png")).output().unwrap();
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("`--foam` is deprecated: it is `--diffuse` now"), "{e}");
    // The settings key: the frame renders with the tint the old key sets, as with the new key.
    let old = d.join("old.toml");
    std::fs::write(&old, "[noise]\nfoam = 0.3\n").unwrap();
    let new = d.join("new.toml");
    std::fs::write(&new, "[noise]\nwhitecaps = 0.3\n").unwrap();
    let mut pngs = vec![];
    for (k, f) in [&old, &new].into_iter().enumerate() {
        let png = d.join(format!("{k}.png"));
        let o = meniscus()
            .args(["render", "drop", "--particles", "2000", "--width", "48", "--height", "32", "--settings"])
            .arg(f)
            .arg("--out")
            .arg(&png)
            .output()
            .unwrap();
        let e = stderr(&o);
        assert!(o.status.success(), "{e}");
        assert_eq!(e.contains("[noise] foam is deprecated: it is spelled whitecaps now"), k == 0, "{e}");
        pngs.push(image::open(&png).unwrap().to_rgba8());
    }
    assert!(pngs[0] == pngs[1], "the old key renders differently from the new one");
    std::fs::remove_dir_all(&d).ok();
}

/// A default `meniscus mesh` writes the same bytes on any machine and at any `--threads` (1, 2, 3, 8), in every
/// format, on a frame of many blocks (the shared 6,859-particle dam break at 0.5 r). Negative control: another
/// block size numbers the same mesh's vertices in another order, and the comparison sees it.
#[test]
fn mesh_bytes_do_not_depend_on_the_thread_count() {
    let Some(frame) = common::shared_data("splishsplash/dambreak_6859/partio/ParticleData_Fluid_40.bgeo") else {
        return;
    };
    let d = common::tmpdir("cli", "mesh-threads");
    let run = |out: &str, extra: &[&str]| -> Vec<u8> {
        let o = meniscus()
            .arg("mesh")
            .arg(&frame)
            .args(["--radius", "0.025", "--cube-size", "0.5"])
            .args(extra)
            .arg("--out")
            .arg(d.join(out))
            .output()
            .unwrap();
        assert!(o.status.success(), "{out}: {}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(d.join(out)).unwrap()
    };
    for ext in ["ply", "obj", "vtk", "usda", "vdb"] {
        let one = run(&format!("t1.{ext}"), &["--threads", "1"]);
        assert!(one.len() > 1000, "{ext}: {} bytes", one.len());
        for t in ["2", "3", "8"] {
            assert!(run(&format!("t{t}.{ext}"), &["--threads", t]) == one, "{ext}: --threads {t} changed the bytes");
        }
    }
    // The frame has many blocks (else the thread count could not matter), and the comparison can fail.
    let (b32, b64) = (run("b32.ply", &["--block", "32"]), run("b64.ply", &["--block", "64"]));
    assert!(b32 != b64, "blocks of 32 and 64 wrote the same bytes: the comparison above could not fail");
}

/// docs/cli.md is the command-line reference generated from clap's tree (`meniscus cli-reference`): the test fails
/// when a flag or its help changed and the page was not regenerated. The generator itself is checked to list every
/// subcommand and a known flag of each (so an empty or truncated reference cannot match a truncated page).
#[test]
fn the_cli_reference_is_current() {
    let o = meniscus().arg("cli-reference").output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let now = String::from_utf8(o.stdout).unwrap();
    for (sub, flag) in [
        ("render", "--radius"),
        ("encode", "--crf"),
        ("info", "--device"),
        ("bench", "--scenes"),
        ("mesh", "--cube-size"),
        ("diffuse", "--export"),
        ("sim", "--solver"),
        ("demo", "--sim"),
    ] {
        let at = now.find(&format!("## meniscus {sub}\n")).unwrap_or_else(|| panic!("no section for {sub}"));
        let section = &now[at..now[at + 1..].find("\n## ").map_or(now.len(), |e| at + 1 + e)];
        assert!(section.contains(&format!("`{flag}`")), "{sub}: {flag} not listed");
    }
    let page = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/cli.md"))
        .unwrap_or_default();
    assert!(
        page == now,
        "docs/cli.md is stale: regenerate it with `target/release/meniscus cli-reference > docs/cli.md` (or \
         `tools/dev cli-reference > docs/cli.md`)"
    );
}

/// `bench --parts` times each part of a pass on its own (an API flag, `FrameRequest::time_parts`, not the
/// environment): the JSON lists `splat/clear` and the like only when asked. Control: the same run without the
/// flag lists none.
#[test]
fn bench_parts_are_a_flag() {
    let args = ["--scenes", "drop:2000", "--resolutions", "64x48", "--warmup", "1", "--frames", "1"];
    let parts_of = |json: &serde_json::Value| -> Vec<String> {
        json["entries"][0]["passes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p[0].as_str().unwrap().to_string())
            .filter(|n| n.contains('/'))
            .collect()
    };
    let (o, plain) = bench_json("parts-off", &args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut with = args.to_vec();
    with.push("--parts");
    let (o, timed) = bench_json("parts-on", &with);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(parts_of(&plain), Vec::<String>::new(), "parts timed without --parts");
    let parts = parts_of(&timed);
    assert!(parts.iter().any(|p| p == "splat/clear"), "no parts with --parts: {parts:?}");
}
