//! `meniscus bench`: scenes × resolutions under one settings preset, headless. Warm-up frames, then N measured
//! frames; per pass the GPU median, p95 and min (timestamps), the GPU frame total, the CPU frame time
//! (submit → fence), and the bytes of every image and buffer. Prints a markdown table shaped like Moritz
//! tables 4.1–4.4 and returns a JSON-serialisable report (schema: benches/README.md).

use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use crate::error::Result;
use crate::frame::{Environment, View};
use crate::gpu::timer::percentile;
use crate::gpu::{DeviceInfo, Gpu};
use crate::renderer::Renderer;
use crate::scene::{self, Camera, Particles};
use crate::settings::Settings;

/// JSON schema version of [`Report`].
pub const SCHEMA: u32 = 1;

/// One workload: particles, how much of the screen they cover, a label.
pub struct Workload {
    pub label: String,
    pub particles: Particles,
    pub radius: f32,
    /// Camera distance factor relative to the automatic fit (2 ≈ a quarter of the screen, < 1 fills it).
    pub distance: f32,
    /// An explicit camera (overrides `distance`).
    pub camera: Option<Camera>,
}

/// Statistics of one series of milliseconds.
#[derive(Clone, Debug, Serialize)]
pub struct Stat {
    pub median: f64,
    pub p95: f64,
    pub min: f64,
}

impl Stat {
    pub fn of(v: &[f64]) -> Stat {
        let mut v = v.to_vec();
        Stat { median: percentile(&mut v, 0.5), p95: percentile(&mut v, 0.95), min: percentile(&mut v, 0.0) }
    }
}

/// Bytes of one GPU allocation.
#[derive(Clone, Debug, Serialize)]
pub struct Mem {
    pub name: String,
    pub bytes: u64,
}

/// One measured configuration.
#[derive(Clone, Debug, Serialize)]
pub struct Entry {
    pub scene: String,
    pub particles: usize,
    pub radius: f32,
    pub width: u32,
    pub height: u32,
    pub variant: String,
    pub filter: String,
    pub camera: String,
    pub frames: u32,
    pub warmup: u32,
    /// Pass name → statistics, in frame order.
    pub passes: Vec<(String, Stat)>,
    pub gpu_total: Stat,
    pub cpu_frame: Stat,
    pub memory: Vec<Mem>,
    pub memory_images_bytes: u64,
    /// The fluid's own screen-sized images (all but the background's colour/depth and the 8-bit output).
    pub memory_fluid_images_bytes: u64,
    pub memory_particles_bytes: u64,
}

/// The whole benchmark run.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub schema: u32,
    pub device: DeviceInfo,
    pub git_commit: String,
    pub preset: String,
    pub settings: Settings,
    pub entries: Vec<Entry>,
    /// Resident set size of the process when the run started ([`note_start_rss`]) and when the report was
    /// made, in bytes (Linux; absent elsewhere): long runs show host-memory growth here (issue #17).
    pub rss_start_bytes: Option<u64>,
    /// See `rss_start_bytes`.
    pub rss_end_bytes: Option<u64>,
}

static START_RSS: std::sync::OnceLock<Option<u64>> = std::sync::OnceLock::new();

/// The process's resident set size in bytes, from `/proc/self/statm` (None where that does not exist).
pub fn rss_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = s.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096)
}

/// Remember the RSS at the start of a bench run (the first call wins); returned by [`start_rss`].
pub fn note_start_rss() {
    START_RSS.get_or_init(rss_bytes);
}

/// The RSS noted by [`note_start_rss`].
pub fn start_rss() -> Option<u64> {
    START_RSS.get().copied().flatten()
}

/// Run one workload at one size with settings `s`.
#[allow(clippy::too_many_arguments)]
pub fn measure(
    r: &mut Renderer,
    w: &Workload,
    width: u32,
    height: u32,
    s: &Settings,
    variant: &str,
    warmup: u32,
    frames: u32,
) -> Result<Entry> {
    let mut s = s.clone();
    s.radius = w.radius;
    let bounds = scene::percentile_bounds(&w.particles.positions, 0.01)
        .ok_or_else(|| crate::Error::Invalid(format!("{}: no finite particles", w.label)))?;
    let camera = w.camera.unwrap_or_else(|| {
        let mut c = Camera::fit(&bounds, width as f32 / height as f32);
        c.eye = c.target + (c.eye - c.target) * w.distance;
        c
    });
    let view = View { camera, width, height, env: Environment::around(&bounds, s.radius, &s) };
    let spray = scene::spray_mask_with(&w.particles, s.radius, s.spray_density, s.spray_by_neighbours);
    r.set_particles_with(&w.particles.positions, None, Some(&spray))?;
    let mut per_pass: Vec<(String, Vec<f64>)> = vec![];
    let (mut totals, mut cpu) = (vec![], vec![]);
    for k in 0..warmup + frames.max(1) {
        let t0 = Instant::now();
        let times = r.render(&view, &s)?;
        let cpu_ms = t0.elapsed().as_secs_f64() * 1e3;
        if k < warmup {
            continue;
        }
        for (name, ms) in &times.0 {
            match per_pass.iter_mut().find(|(n, _)| n == name) {
                Some(e) => e.1.push(*ms),
                None => per_pass.push((name.clone(), vec![*ms])),
            }
        }
        totals.push(times.total());
        cpu.push(cpu_ms);
    }
    let t = r.targets.as_ref().expect("rendered");
    let memory: Vec<Mem> = t.memory().into_iter().map(|(n, b)| Mem { name: n.to_string(), bytes: b }).collect();
    Ok(Entry {
        scene: w.label.clone(),
        particles: w.particles.len(),
        radius: s.radius,
        width,
        height,
        variant: variant.to_string(),
        filter: s.filter.name().to_string(),
        camera: camera.to_arg(),
        frames: frames.max(1),
        warmup,
        passes: per_pass.into_iter().map(|(n, v)| (n, Stat::of(&v))).collect(),
        gpu_total: Stat::of(&totals),
        cpu_frame: Stat::of(&cpu),
        memory_images_bytes: memory.iter().map(|m| m.bytes).sum(),
        memory_fluid_images_bytes: memory
            .iter()
            .filter(|m| !matches!(m.name.as_str(), "scene_color" | "scene_depth" | "final"))
            .map(|m| m.bytes)
            .sum(),
        memory,
        memory_particles_bytes: 16 * w.particles.len() as u64,
    })
}

/// Markdown table of entries, one row each, columns = passes (medians, ms), like Moritz tables 4.1–4.4.
pub fn markdown(entries: &[Entry]) -> String {
    let names: Vec<&str> = crate::passes::PASS_NAMES.to_vec();
    let mut s = String::from("| scene | particles | resolution | variant |");
    for n in &names {
        s.push_str(&format!(" {n} |"));
    }
    s.push_str(" GPU total (median / p95) | CPU frame | fluid images MB |\n|---|---:|---|---|");
    for _ in &names {
        s.push_str("---:|");
    }
    s.push_str("---:|---:|---:|\n");
    for e in entries {
        s.push_str(&format!("| {} | {} | {}×{} | {} |", e.scene, e.particles, e.width, e.height, e.variant));
        for n in &names {
            match e.passes.iter().find(|(p, _)| p == n) {
                Some((_, st)) => s.push_str(&format!(" {:.3} |", st.median)),
                None => s.push_str(" – |"),
            }
        }
        s.push_str(&format!(
            " {:.3} / {:.3} | {:.3} | {:.1} |\n",
            e.gpu_total.median,
            e.gpu_total.p95,
            e.cpu_frame.median,
            e.memory_fluid_images_bytes as f64 / 1e6
        ));
    }
    s
}

/// Device information for the report.
pub fn device_info(gpu: &Arc<Gpu>) -> DeviceInfo {
    gpu.info.clone()
}

/// The commit the binary was built from.
pub fn git_commit() -> String {
    env!("MENISCUS_GIT_COMMIT").to_string()
}
