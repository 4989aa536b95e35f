//! The windowed demo under an X server (CI starts Xvfb through tools/dev): a few frames of a built-in scene on
//! lavapipe with validation on, a screenshot that shows the fluid, a clean exit. Without DISPLAY the test
//! FAILS (it never skips silently); tools/dev test provides Xvfb.

mod common;

use std::path::PathBuf;
use std::process::{Command, Output};

/// A scratch folder for one test (also the demo's XDG_RUNTIME_DIR); fails when there is no X server.
fn x_dir(name: &str) -> PathBuf {
    let display = std::env::var("DISPLAY").unwrap_or_default();
    assert!(!display.is_empty(), "no DISPLAY: run the tests through `tools/dev test` (starts Xvfb) or set DISPLAY");
    let dir = std::env::temp_dir().join(format!("meniscus-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Run `meniscus ARGS…` with `dir` as its runtime folder; its output and its stderr as text.
fn meniscus_in(dir: &std::path::Path, args: &[&std::ffi::OsStr]) -> (Output, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_meniscus")).args(args).env("XDG_RUNTIME_DIR", dir).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    (o, err)
}

#[test]
fn demo_runs_under_x_and_screenshot_shows_fluid() {
    let dir = x_dir("demo");
    let shot = dir.join("demo.png");
    let args = "demo drop --particles 4000 --width 320 --height 200 --frames 6 --validation --screenshot";
    let mut args: Vec<&std::ffi::OsStr> = args.split_whitespace().map(std::ffi::OsStr::new).collect();
    args.push(shot.as_os_str());
    let (o, err) = meniscus_in(&dir, &args);
    assert!(o.status.success(), "demo failed: {err}");
    assert!(!err.contains("[vulkan"), "validation messages: {err}");
    let img = image::open(&shot).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (320, 200));
    // Water pixels: clearly more blue/green than red (the background is grey/white and orange).
    let water = img.pixels().filter(|p| p[2] as i32 > p[0] as i32 + 40 && p[1] as i32 > p[0] as i32 + 20).count();
    assert!(water > 500, "only {water} water-coloured pixels in the screenshot");
    assert!(err.contains("6 frames in"), "{err}");
}

/// `--record` writes the drawn frames into a movie through ffmpeg; it refuses a name that is not a movie.
#[test]
fn demo_records_a_movie() {
    let dir = x_dir("record");
    let movie = dir.join("demo.mp4");
    let args = "demo drop --particles 2000 --width 160 --height 100 --frames 5 --validation --record";
    let mut args: Vec<&std::ffi::OsStr> = args.split_whitespace().map(std::ffi::OsStr::new).collect();
    args.push(movie.as_os_str());
    let (o, err) = meniscus_in(&dir, &args);
    assert!(o.status.success(), "demo failed: {err}");
    assert!(err.contains("recorded 5 frames"), "{err}");
    assert_eq!(common::probe_video(&movie), "160,100,5");
    let (o, err) = meniscus_in(&dir, &["demo".as_ref(), "--record".as_ref(), dir.join("x.png").as_os_str()]);
    assert!(!o.status.success() && err.contains("--record") && err.contains(".mp4"), "{err}");
}

#[test]
fn demo_without_a_display_is_a_clear_error() {
    let o = Command::new(env!("CARGO_BIN_EXE_meniscus"))
        .args(["demo", "drop", "--particles", "1000", "--frames", "1"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("X server") || err.contains("DISPLAY"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// Issue #11: `render`, `bench`, `demo` and `info` of the same file and flags start from the same job — the same
/// particles and per-particle radii (a file with a `radius`/pscale attribute: `bench` used to drop it), the same
/// radius and the same camera. Each prints one `job:` line; they must agree (info's has no camera).
#[test]
fn render_bench_demo_and_info_see_the_same_job() {
    let dir = x_dir("job");
    let mut positions = vec![];
    let mut radii = vec![];
    for i in 0..12 {
        for j in 0..6 {
            for k in 0..8 {
                let jit = ((i * 7 + j * 13 + k * 29) % 11) as f32 * 0.001;
                positions.push([i as f32 * 0.05 + jit, j as f32 * 0.05, k as f32 * 0.05 - jit]);
                radii.push(0.02 + 0.01 * ((i + k) % 3) as f32);
            }
        }
    }
    let p = meniscus::scene::Particles { positions, radii: Some(radii), ..Default::default() };
    let file = dir.join("pscale.bgeo");
    std::fs::write(&file, meniscus::scene::bgeo::write(&p.to_raw(), false)).unwrap();
    let f = file.to_str().unwrap();
    let job_line = |args: &[&str]| -> String {
        let args: Vec<&std::ffi::OsStr> = args.iter().map(std::ffi::OsStr::new).collect();
        let (o, err) = meniscus_in(&dir, &args);
        assert!(o.status.success(), "{args:?} failed: {err}");
        let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("job: ")).collect();
        assert_eq!(lines.len(), 1, "{args:?}: expected one job line in: {err}");
        lines[0].to_string()
    };
    let out = dir.join("r.png");
    let render = job_line(&["render", f, "--width", "96", "--height", "64", "--out", out.to_str().unwrap()]);
    let bench = job_line(&["bench", "--scenes", f, "--resolutions", "96x64", "--warmup", "0", "--frames", "1"]);
    let demo = job_line(&["demo", f, "--width", "96", "--height", "64", "--frames", "1"]);
    let info = job_line(&["info", f]);
    assert!(render.contains("576 particles") && render.contains("per-particle radii yes"), "{render}");
    assert!(render.contains("(Estimated)") && render.contains("camera --camera"), "{render}");
    assert_eq!(render, bench, "render and bench disagree");
    assert_eq!(render, demo, "render and demo disagree");
    assert!(render.starts_with(&info), "info's job line is not the start of render's:\n{info}\n{render}");
}

/// Issue #12: with frames in flight, resizing the window (the swapchain recreated while frames are on the GPU)
/// survives, clean under validation, and the last frame has the window's final size.
#[test]
fn demo_survives_resizes_with_frames_in_flight() {
    let dir = x_dir("resize");
    let shot = dir.join("resized.png");
    let args = "demo drop --particles 2000 --width 200 --height 120 --frames 24 --exercise-resize --validation";
    let mut args: Vec<&std::ffi::OsStr> = args.split_whitespace().map(std::ffi::OsStr::new).collect();
    args.extend(["--screenshot".as_ref(), shot.as_os_str()]);
    let (o, err) = meniscus_in(&dir, &args);
    assert!(o.status.success(), "demo failed: {err}");
    assert!(!err.contains("[vulkan"), "validation messages: {err}");
    assert!(err.contains("24 frames in"), "{err}");
    // Created at 200×120, recreated at 150×90 and back.
    let sizes: Vec<&str> = err.lines().filter(|l| l.starts_with("swapchain ")).collect();
    assert!(sizes.contains(&"swapchain 150×90") && sizes.last() == Some(&"swapchain 200×120"), "{sizes:?}");
    let img = image::open(&shot).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (200, 120));
}

/// Issue #13: `demo --sim` plays the solver live (the step recorded into each frame), clean under validation,
/// and draws water in the tank.
#[test]
fn demo_plays_a_live_simulation() {
    let dir = x_dir("demo-sim");
    let shot = dir.join("sim.png");
    // A block in the water's way: the background mesh is also the live water's collider.
    let block = dir.join("block.obj");
    std::fs::write(&block, common::box_obj([0.2, 0.0, -0.3], [0.6, 0.5, 0.3])).unwrap();
    let args = "demo --sim dambreak --particles 4000 --width 160 --height 96 --frames 12 --fps 1000 --async on \
                --validation";
    let mut args: Vec<&std::ffi::OsStr> = args.split_whitespace().map(std::ffi::OsStr::new).collect();
    args.extend(["--screenshot".as_ref(), shot.as_os_str(), "--background-obj".as_ref(), block.as_os_str()]);
    let (o, err) = meniscus_in(&dir, &args);
    assert!(o.status.success(), "demo --sim failed: {err}");
    assert!(err.contains("sim dambreak"), "{err}");
    assert!(err.contains("mesh collider") && err.contains("12 triangles"), "{err}");
    let img = image::open(&shot).unwrap().to_rgba8();
    // Water is drawn: some pixels are clearly bluer than the grey-and-white ground and the tank walls.
    let blue = img.pixels().filter(|p| p[2] as i32 > p[0] as i32 + 40).count();
    assert!(blue > 50, "no water in the picture ({blue} blue pixels)");
}

/// `demo --sim dambreak --surface mesh`: the simulation's particles never reach the host, so the mesh surface is
/// extracted on the GPU inside each frame (the demo says so) and drawn live: the screenshot shows water, under
/// validation. (A surface that drew nothing — the CPU path meshes only a GPU-written set's box, and is refused
/// for it — leaves no water-coloured pixels.)
#[test]
fn demo_meshes_a_live_simulation_on_the_gpu() {
    let dir = x_dir("demo-sim-mesh");
    let shot = dir.join("mesh.png");
    let args = "demo --sim dambreak --particles 2000 --surface mesh --width 320 --height 200 --frames 4 --validation \
                --screenshot";
    let mut args: Vec<&std::ffi::OsStr> = args.split_whitespace().map(std::ffi::OsStr::new).collect();
    args.push(shot.as_os_str());
    let (o, err) = meniscus_in(&dir, &args);
    assert!(o.status.success(), "demo --sim --surface mesh failed: {err}");
    assert!(!err.contains("[vulkan"), "validation messages: {err}");
    assert!(err.contains("mesh surface: extracted on the GPU in the frame"), "{err}");
    let img = image::open(&shot).unwrap().to_rgba8();
    let blue = img.pixels().filter(|p| p[2] as i32 > p[0] as i32 + 40).count();
    assert!(blue > 50, "no water in the picture ({blue} blue pixels)");
}
