//! Soak test (issue #17): host memory must stay flat over many rendered frames. Before the fix every frame kept
//! ~300 kB on lavapipe (Mesa 22.3 recompiled the composite shader at each dispatch because of a uniform-dependent
//! branch it tried to inline), so 400 frames grew RSS by ~120 MB; the bound here is 6 MB. Alone in its own test
//! binary so no other test's allocations land in the measurement.

mod common;

use meniscus::renderer::Renderer;
use meniscus::scene::camera::Camera;
use meniscus::scene::{self, procedural};
use meniscus::settings::{Settings, Surface};
use meniscus::view::Environment;
use meniscus::view::View;

fn rss_mb() -> f64 {
    common::rss_bytes() as f64 / 1e6
}

#[test]
fn rss_stays_flat_over_hundreds_of_frames() {
    // Without the validation layer: it keeps state of its own per submission (~26 kB/frame measured with it on),
    // which is not the renderer's memory. Every other GPU test runs validated. No device is a failure.
    let gpu = meniscus::gpu::Gpu::new(&meniscus::gpu::GpuOptions::default())
        .unwrap_or_else(|e| panic!("the soak test needs a Vulkan device (lavapipe): {e}"));
    let gen = procedural::generate("drop", 4000).unwrap();
    let bounds = scene::percentile_bounds(&gen.particles.positions, 0.01).unwrap();
    let mut r = Renderer::new(&gpu).unwrap();
    r.upload(meniscus::renderer::Upload::Points {
        positions: &gen.particles.positions,
        radii: None,
        isolated: None,
        motion: None,
    })
    .unwrap();
    r.parts_mut().background.always_render = true;
    for surface in [Surface::Spheres, Surface::Iso] {
        let s = Settings { radius: gen.radius, surface, ..Settings::default() };
        let view = View {
            camera: Camera::fit(&bounds, 16.0 / 9.0),
            width: 96,
            height: 54,
            env: Environment::around(&bounds, s.radius, &s),
        };
        let frames = if surface == Surface::Spheres { 400 } else { 150 };
        for _ in 0..40 {
            r.render(&view, &s).unwrap();
        }
        let start = rss_mb();
        for _ in 0..frames {
            r.render(&view, &s).unwrap();
        }
        let end = rss_mb();
        eprintln!("{surface:?}: RSS {start:.1} → {end:.1} MB over {frames} frames");
        assert!(end - start < 6.0, "{surface:?}: RSS grew {start:.1} → {end:.1} MB over {frames} frames");
    }
}
