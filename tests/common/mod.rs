//! Shared test helpers: a validated lavapipe device that FAILS (never skips) when absent, CPU references.
#![allow(dead_code)]

use std::sync::Arc;

use meniscus::gpu::{Gpu, GpuOptions};
use meniscus::scene::camera::Camera;
use meniscus::settings::Settings;
use meniscus::view::Environment;
use meniscus::view::View;

/// The `meniscus` binary of this build, as a command to run.
pub fn meniscus() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_meniscus"))
}

/// A fresh empty folder for test `name` of suite `suite` (emptied if a previous run left it).
pub fn tmpdir(suite: &str, name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("meniscus-{suite}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A command's stderr as text.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// An axis-aligned box lo..hi as OBJ text: 8 vertices and 6 quads (12 triangles once loaded).
pub fn box_obj(lo: [f32; 3], hi: [f32; 3]) -> String {
    let mut obj = String::new();
    for i in 0..8 {
        let c = |k: usize| if (i >> k) & 1 == 1 { hi[k] } else { lo[k] };
        obj += &format!("v {} {} {}\n", c(0), c(1), c(2));
    }
    obj + "f 1 2 4 3\nf 5 7 8 6\nf 1 5 6 2\nf 3 4 8 7\nf 1 3 7 5\nf 2 6 8 4\n"
}

/// A renderer that has drawn `particles` once from `v` with `s`, keeping the unsmoothed depth when `raw`.
pub fn rendered(
    gpu: &Arc<Gpu>,
    particles: &[[f32; 3]],
    v: &View,
    s: &Settings,
    raw: bool,
) -> meniscus::renderer::Renderer {
    let mut r = meniscus::renderer::Renderer::new(gpu).unwrap();
    *r.parts_mut().keep_raw_depth = raw;
    r.upload(meniscus::renderer::Upload::points(particles)).unwrap();
    r.render(v, s).unwrap();
    r
}

/// A device with validation + synchronization validation. No device is a test FAILURE, in CI and out.
pub fn gpu() -> Arc<Gpu> {
    match Gpu::new(&GpuOptions { validation: true, ..Default::default() }) {
        Ok(g) => {
            assert!(g.validation_enabled(), "validation layer must be active in tests");
            g
        }
        Err(e) => panic!(
            "GPU test needs a Vulkan device (lavapipe: apt-get install mesa-vulkan-drivers vulkan-validationlayers); CI={}: {e}",
            std::env::var("CI").unwrap_or_default()
        ),
    }
}

/// Assert no validation error or warning was reported on `gpu`.
pub fn assert_clean(gpu: &Gpu) {
    let v = gpu.validation();
    assert_eq!(v.errors() + v.warnings(), 0, "validation messages: {:#?}", v.messages());
}

/// A camera at `eye` looking at the origin, with nothing else in the scene.
pub fn view(eye: [f32; 3], target: [f32; 3], w: u32, h: u32, fovy: f32) -> View {
    let mut camera =
        Camera::parse(&format!("{},{},{}:{},{},{}:{fovy}", eye[0], eye[1], eye[2], target[0], target[1], target[2]))
            .unwrap();
    camera.near = 0.05;
    View {
        camera,
        width: w,
        height: h,
        env: Environment {
            ground_y: -100.0,
            tile: 1.0,
            fog: 1e6,
            ground: false,
            boxes: vec![],
            spheres: vec![],
            sky_cube: false,
        },
    }
}

/// Settings with the given radius and nothing extra: spheres + narrow-range (the `fast` preset's surface and
/// filter, which most pass tests look at); with `surface = Iso` the exact field (no `[iso] smoothing`).
pub fn settings(radius: f32) -> Settings {
    Settings::default().with(|s| {
        s.radius = radius;
        s.surface = meniscus::settings::Surface::Spheres;
        s.filter.method = meniscus::named::Filter::NarrowRange;
        s.iso.smoothing = 0.0;
        s.background.boxes = false;
        s.background.ground = false;
        s.splat.radius_scale = 1.0;
        // The pass references compare normals and colours without the patent's waves and foam.
        s.noise.enabled = false;
    })
}

/// View-space ray direction through pixel (x, y) (z = −1), mirroring `pixel_dir` in common.glsl, in f64.
pub fn pixel_dir(x: usize, y: usize, w: usize, h: usize, f: f64) -> [f64; 3] {
    [(x as f64 + 0.5 - 0.5 * w as f64) / f, -(y as f64 + 0.5 - 0.5 * h as f64) / f, -1.0]
}

/// Entry/exit linear depth of a ray (z = −1 direction) through a sphere at view-space centre c, radius r.
pub fn ray_sphere(dir: [f64; 3], c: [f64; 3], r: f64) -> Option<(f64, f64)> {
    let len = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
    let u = [dir[0] / len, dir[1] / len, dir[2] / len];
    let tc = u[0] * c[0] + u[1] * c[1] + u[2] * c[2];
    let q = [c[0] - tc * u[0], c[1] - tc * u[1], c[2] - tc * u[2]];
    let h2 = r * r - (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
    (h2 >= 0.0).then(|| ((tc - h2.sqrt()) / len, (tc + h2.sqrt()) / len))
}

/// Pixel rectangle [lo, hi] a sphere (view-space centre `c`, radius `r`) covers in a `w`×`h` image of focal `f`,
/// mirroring `sphere_bounds` in sphere.glsl (f32, the same rounding); the whole image when it crosses `near`.
pub fn sphere_bounds(c: [f32; 3], r: f32, w: usize, h: usize, f: f32, near: f32) -> Option<([i32; 2], [i32; 2])> {
    let cd = -c[2];
    if cd + r <= near {
        return None;
    }
    if cd - r <= near {
        return Some(([0, 0], [w as i32 - 1, h as i32 - 1]));
    }
    let (d0, d1) = (cd - r, cd + r);
    let xmin = ((c[0] - r) / d0).min((c[0] - r) / d1);
    let xmax = ((c[0] + r) / d0).max((c[0] + r) / d1);
    let ymin = ((c[1] - r) / d0).min((c[1] - r) / d1);
    let ymax = ((c[1] + r) / d0).max((c[1] + r) / d1);
    let (hx, hy) = (0.5 * w as f32, 0.5 * h as f32);
    let lo = [((hx + f * xmin - 0.5).ceil() as i32).max(0), ((hy - f * ymax - 0.5).ceil() as i32).max(0)];
    let hi = [
        ((hx + f * xmax - 0.5).floor() as i32).min(w as i32 - 1),
        ((hy - f * ymin - 0.5).floor() as i32).min(h as i32 - 1),
    ];
    (lo[0] <= hi[0] && lo[1] <= hi[1]).then_some((lo, hi))
}

/// The `iso` march's far bound per `tile`×`tile` tile (splat_cull.comp): the deepest centre depth + r of the
/// spheres whose pixel rectangle touches the tile, 0 where none does. Row-major, ⌈w/tile⌉ tiles per row.
pub fn tile_back(centres: &[[f32; 3]], r: f32, w: usize, h: usize, f: f32, near: f32, tile: usize) -> Vec<f32> {
    let tw = w.div_ceil(tile);
    let mut out = vec![0f32; tw * h.div_ceil(tile)];
    for c in centres {
        if let Some((lo, hi)) = sphere_bounds(*c, r, w, h, f, near) {
            for ty in lo[1] as usize / tile..=hi[1] as usize / tile {
                for tx in lo[0] as usize / tile..=hi[0] as usize / tile {
                    let b = &mut out[ty * tw + tx];
                    *b = b.max(-c[2] + r);
                }
            }
        }
    }
    out
}

/// A folder or file of `../shared/data` (relative to it; `MENISCUS_SHARED_DATA` names another place, as the GPU
/// bundle's copy of the test binaries does). Missing data FAILS under `CI=true` (the data is there in CI, so its
/// absence means a broken set-up); outside CI it returns None and the test says it checked nothing.
pub fn shared_data(rel: &str) -> Option<std::path::PathBuf> {
    let root = std::env::var_os("MENISCUS_SHARED_DATA").map(std::path::PathBuf::from);
    let root = root.unwrap_or_else(|| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data"));
    let p = root.join(rel);
    if p.exists() {
        return Some(p);
    }
    if std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "0" && v != "false") {
        panic!("shared data {} is missing under CI=true: this test must not pass without it", p.display());
    }
    eprintln!("shared data {} not present: this test checked nothing (it fails under CI=true)", p.display());
    None
}

/// The process's resident set size in bytes, from `/proc/self/statm` (Linux).
pub fn rss_bytes() -> u64 {
    let s = std::fs::read_to_string("/proc/self/statm").expect("/proc/self/statm (Linux)");
    let pages: u64 = s.split_whitespace().nth(1).and_then(|p| p.parse().ok()).expect("statm's second field");
    pages * 4096
}

/// `width,height,frames` of a movie's video stream, as ffprobe counts them (tools/dev installs ffmpeg).
pub fn probe_video(movie: &std::path::Path) -> String {
    let o = std::process::Command::new("ffprobe")
        .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
        .args(["-show_entries", "stream=nb_read_frames,width,height", "-of", "csv=p=0"])
        .arg(movie)
        .output()
        .expect("ffprobe (tools/dev installs ffmpeg)");
    String::from_utf8_lossy(&o.stdout).trim().to_string()
}
