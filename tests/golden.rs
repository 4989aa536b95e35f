//! A small golden frame: the built-in `wave` scene at 160×96 compared with tests/golden/wave_160x96.png with a
//! tolerance. A missing golden FAILS; blessing is deliberate: `MENISCUS_BLESS=1 cargo test --test golden`
//! (tools/bless-golden). On a mismatch, `-actual.png` and `-difference.png` are written to target/golden-out/.

mod common;

use common::*;
use meniscus::renderer::Renderer;
use meniscus::scene::camera::Camera;
use meniscus::scene::{self, procedural};
use meniscus::view::Environment;
use meniscus::view::View;

#[test]
fn golden_wave_frame() {
    let gpu = gpu();
    let g = procedural::generate("wave", 20_000).unwrap();
    let mut s = meniscus::settings::Settings { radius: g.radius, ..Default::default() };
    s.radius = g.radius;
    let b = scene::percentile_bounds(&g.particles.positions, 0.01).unwrap();
    let (w, h) = (160u32, 96u32);
    let v = View {
        camera: Camera::fit(&b, w as f32 / h as f32),
        width: w,
        height: h,
        env: Environment::around(&b, g.radius, &s),
    };
    let mut r = Renderer::new(&gpu).unwrap();
    r.upload(meniscus::renderer::Upload::points(&g.particles.positions)).unwrap();
    r.render(&v, &s).unwrap();
    let img = r.state().read_final().unwrap();
    assert_clean(&gpu);

    let golden = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/wave_160x96.png");
    if std::env::var("MENISCUS_BLESS").as_deref() == Ok("1") {
        assert!(std::env::var("CI").is_err(), "never bless goldens in CI");
        meniscus::output::write_png(&golden, &img).unwrap();
        eprintln!("blessed {}", golden.display());
        return;
    }
    let want = image::open(&golden)
        .unwrap_or_else(|e| {
            panic!("golden {} missing or unreadable ({e}); bless it with tools/bless-golden", golden.display())
        })
        .to_rgba8();
    assert_eq!(want.dimensions(), img.dimensions());
    let mut diff = image::RgbaImage::new(w, h);
    let (mut sum, mut bad) = (0u64, 0u32);
    for (x, y, p) in img.enumerate_pixels() {
        let q = want.get_pixel(x, y);
        let d = (0..3).map(|c| (p[c] as i32 - q[c] as i32).unsigned_abs()).max().unwrap();
        sum += d as u64;
        if d > 24 {
            bad += 1;
        }
        let v = (d * 8).min(255) as u8;
        diff.put_pixel(x, y, image::Rgba([v, v, v, 255]));
    }
    let mean = sum as f64 / (w * h) as f64;
    // Tolerance: mean channel difference ≤ 2 levels and ≤ 0.5 % of pixels off by more than 24 levels.
    if mean > 2.0 || bad as f64 > 0.005 * (w * h) as f64 {
        let out = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/golden-out");
        std::fs::create_dir_all(&out).unwrap();
        img.save(out.join("wave_160x96-actual.png")).unwrap();
        diff.save(out.join("wave_160x96-difference.png")).unwrap();
        panic!("golden mismatch: mean diff {mean:.2}, {bad} pixels > 24 levels; see {}", out.display());
    }
}

/// Issue #12: the split frame — background and thickness on the async compute queue (mapped onto lavapipe's one
/// queue, with the same semaphores and derived waits), fluid and shading on the main queue — gives the same
/// image as the one-queue frame, bit for bit, over several frames in flight with a moving camera, under
/// synchronization validation.
#[test]
fn async_split_frame_is_bit_identical() {
    let gpu = gpu();
    let g = procedural::generate("wave", 20_000).unwrap();
    let s = meniscus::settings::Settings { radius: g.radius, ..Default::default() };
    let b = scene::percentile_bounds(&g.particles.positions, 0.01).unwrap();
    let (w, h) = (160u32, 96u32);
    let views: Vec<View> = (0..5)
        .map(|k| {
            let mut camera = Camera::fit(&b, w as f32 / h as f32);
            camera.eye.x += 0.1 * k as f32; // a new background every frame
            View { camera, width: w, height: h, env: Environment::around(&b, g.radius, &s) }
        })
        .collect();
    let run = |split: bool, s: &meniscus::settings::Settings| -> Vec<image::RgbaImage> {
        // Two frames in flight: each frame is read back before its slot is reused.
        let mut out = vec![];
        let mut r2 = Renderer::new(&gpu).unwrap();
        *r2.parts_mut().async_compute = split;
        let mut pending = std::collections::VecDeque::new();
        for (k, v) in views.iter().enumerate() {
            // New particles every frame (the split frame uploads them on the async queue, double-buffered).
            let moved: Vec<[f32; 3]> =
                g.particles.positions.iter().map(|p| [p[0], p[1] + 0.01 * k as f32, p[2]]).collect();
            r2.upload(meniscus::renderer::Upload::points(&moved)).unwrap();
            pending.push_back(r2.submit(meniscus::renderer::FrameRequest::new(v, s).readback()).unwrap());
            if pending.len() == r2.slots().count() {
                out.push(r2.read_submitted(pending.pop_front().unwrap()).unwrap());
            }
        }
        while let Some(p) = pending.pop_front() {
            out.push(r2.read_submitted(p).unwrap());
        }
        let times = r2.render(&views[0], s).unwrap();
        assert!(times.get("thickness").is_some() && times.get("composite").is_some(), "{times:?}");
        out
    };
    let one = run(false, &s);
    let split = run(true, &s);
    assert_eq!(one.len(), 5);
    for (k, (a, b)) in one.iter().zip(&split).enumerate() {
        assert!(a == b, "frame {k}: the split (async) frame differs from the one-queue frame");
    }
    // Ellipsoid splats: the grid and the anisotropic kernels move to the async part before `thickness`, and the
    // fluid part's splat waits for them. The kernels sum neighbours in the grid's atomics order, so frames agree
    // to rounding, not bit for bit.
    let s = s.with(|s| s.kernel = meniscus::settings::Kernel::Anisotropic);
    let (one, split) = (run(false, &s), run(true, &s));
    for (k, (a, b)) in one.iter().zip(&split).enumerate() {
        let off =
            a.pixels().zip(b.pixels()).filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > 2)).count();
        assert!(off * 1000 <= a.len() / 4, "frame {k}: {off} pixels of the split frame differ with ellipsoids");
    }
    assert_clean(&gpu);
}
