//! Meniscus as a library: one frame of a built-in scene, rendered headless and written as a PNG, through the
//! renderer's door — a device, one particle `Upload`, one frame (`render`, or `submit` + `finish` for frames in
//! flight), and what the renderer holds after it (`state()`: the image, the memory, the host's times).
//!
//!     cargo run --release --example render_frame -- [OUT.png]
use meniscus::renderer::{Renderer, Upload};
use meniscus::scene::{percentile_bounds, procedural};
use meniscus::settings::Settings;
use meniscus::view::View;

fn main() -> meniscus::Result<()> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "frame.png".into());
    let gpu = meniscus::device::Gpu::new(&Default::default())?;
    let scene = procedural::generate("wave", 50_000)?;
    let s = Settings { radius: scene.radius, ..Settings::preset("default")? };
    let bounds = percentile_bounds(&scene.particles.positions, 0.01)
        .ok_or_else(|| meniscus::Error::Invalid("no finite particles".into()))?;
    let view = View::around(&bounds, None, 960, 540, &s);

    let mut r = Renderer::new(&gpu)?;
    r.upload(Upload::scene(&scene.particles, &s))?;
    let times = r.render(&view, &s)?;

    let state = r.state();
    // The one writer of files: atomic (a partial file is never left) and never over an input.
    meniscus::output::write_png(std::path::Path::new(&out), &state.read_final()?)?;
    let mb = state.memory().iter().map(|(_, b)| b).sum::<u64>() as f64 / 1e6;
    println!("{out}: {} passes, {:.2} ms on {}, {mb:.0} MB of images", times.0.len(), times.total(), gpu.info.name);
    Ok(())
}
