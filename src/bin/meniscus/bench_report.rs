//! `meniscus bench`'s report: the statistics of a series, one entry per measured configuration, the JSON
//! report (benches/README.md gives its schema) and the markdown tables, the process's memory, and the chart's
//! points.

use std::sync::Arc;

use anyhow::Result;
use serde::Serialize;

use meniscus::device::{DeviceInfo, Gpu};
use meniscus::settings::Settings;
use meniscus::timing::percentile;

use crate::bench::{BenchArgs, SCHEMA};

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
    /// With `--in-flight`: wall ms per frame over as many frames again with the renderer's frames in flight
    /// (the host's work overlapping the GPU's, as a sequence or a live view runs); absent without.
    pub cpu_frame_in_flight: Option<f64>,
    pub memory: Vec<Mem>,
    pub memory_images_bytes: u64,
    /// The fluid's own screen-sized images (all but the background's colour/depth and the 8-bit output).
    pub memory_fluid_images_bytes: u64,
    pub memory_particles_bytes: u64,
    /// Resident memory of the process after the warm-up frames and after the last measured frame (Linux;
    /// issue #17: the difference is what measured frames cost in host memory).
    pub rss_after_warmup_bytes: Option<u64>,
    /// Whether the frame was split over the main and the async compute queue (issue #12).
    pub async_compute: bool,
    /// Busy time of the main queue's passes per frame.
    pub queue_main_ms: Stat,
    /// Busy time of the async compute queue's passes per frame (0 when not split).
    pub queue_compute_ms: Stat,
    /// First begin to last end over both queues per frame; (union with async off) − (union with async on) is
    /// the work the overlap hid.
    pub union_ms: Stat,
    /// The queue every pass ran on ("main" or "compute").
    pub pass_queues: Vec<(String, String)>,
    pub rss_after_frames_bytes: Option<u64>,
    /// Every live GPU allocation by name after the measured frames, and the totals (the allocator's report:
    /// grids, the smoothed field's lattice, simulation buffers, images). With `--also-presets` it covers every
    /// renderer of the run (they share the device).
    pub gpu_memory: meniscus::device::MemoryReport,
    /// The `noise` pass's work in the last measured frame (its own counters; absent when the pass is off): the
    /// coarsest level of detail, sprite texels visited, sprites drawn, texels evaluated — a GPU's cost follows
    /// these, whatever the CPU driver's milliseconds say.
    pub noise_work: Option<meniscus::work::NoiseWork>,
    /// The `iso` pass's work in the last measured frame (absent when the frame had no `iso` pass): its field
    /// samples, and the rays its first dispatch left for the second, whose cost does not shrink with the pixels.
    pub iso_work: Option<meniscus::work::IsoWork>,
    /// The compute `splat` pass's work in the last measured frame (absent for the rasterised variants): its
    /// sphere–pixel tests, spheres drawn and tiles the occlusion bound skipped.
    pub splat_work: Option<meniscus::work::SplatWork>,
    /// The smoothed field's deposit at its last build in the measured frames (absent when no measured frame
    /// rebuilt it: a still scene builds it once, in the warm-up).
    pub iso_volume_work: Option<meniscus::work::IsoVolumeWork>,
    /// The live mesh surface's extraction (`--surface mesh` extracted on the GPU), its latest: occupied blocks,
    /// cubes visited, field samples, triangles and vertices (absent on the CPU path).
    pub mesh_work: Option<meniscus::work::MeshWork>,
    /// The effect images that exist (`noise_accum`, `noise`, `diffuse_white`, …), by name: none when the
    /// effects are off.
    pub effect_images: Vec<String>,
    /// The host's stages per frame, ms ([`HOST_STAGES`]): a sequence frame's upload (`set_scene_particles`:
    /// the isolated-particle classification and the copy into the particle set), then the renderer's own
    /// (`RendererState::host_times`), and the wait for the GPU with the timestamps' read-back.
    pub host_ms: Vec<(String, Stat)>,
    /// A sequence's per-frame analysis for the iso surface (its box and bricks), ms: computed before the frame
    /// as `render`'s prefetch thread computes it beside the load, so not in `host_ms` (absent for a still scene
    /// or another surface).
    pub analysis_ahead_ms: Option<Stat>,
    /// Compute shader invocations per pass in the last measured frame (a pipeline-statistics query, where the
    /// device has them: `info --device`), in frame order; a pass timed inside another is counted in its parent.
    /// The work a pass did, device-independent: a change's GPU cost can be judged from it on lavapipe.
    pub invocations: Vec<(String, u64)>,
    /// With `--flicker`, a sequence's flicker over its frames rendered once more after the measured ones
    /// (`meniscus quality`'s measure: docs/quality.md); absent otherwise.
    pub flicker: Option<meniscus::quality::Flicker>,
}

/// The host stages `bench` times per frame (`Entry::host_ms`).
pub const HOST_STAGES: [&str; 7] = ["upload", "prepare", "slot_wait", "stage", "record", "submit", "wait"];

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

/// `--parts` for this process's measurements (the frames' `FrameRequest::time_parts`, the steps'
/// `Simulation::time_parts`); `MENISCUS_PARTS=1` is its older, deprecated spelling.
pub static PARTS: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether `--parts` is on.
pub fn parts() -> bool {
    PARTS.load(std::sync::atomic::Ordering::Relaxed)
}

/// Markdown table of entries, one row each, columns = passes (medians, ms), like Moritz tables 4.1–4.4.
pub fn markdown(entries: &[Entry]) -> String {
    // The frame passes, then any other timed scope that ran in a measured frame (`grid`, `iso_density`: they run
    // only when the particles change, so a static frame shows them as –).
    let mut names: Vec<&str> = meniscus::renderer::pass_names().to_vec();
    for e in entries {
        for (p, _) in &e.passes {
            if !names.contains(&p.as_str()) {
                names.push(p);
            }
        }
    }
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
    // The host's stages beside the GPU's time (medians, ms); with --in-flight the frame time once they overlap.
    let overlap = entries.iter().any(|e| e.cpu_frame_in_flight.is_some());
    s.push_str(&format!(
        "\nHost stages per frame (ms, medians):\n\n| scene | resolution | variant | {} | CPU frame |{} GPU total |\n|---|---|---|{}---:|{}---:|\n",
        HOST_STAGES.join(" | "),
        if overlap { " CPU frame, frames in flight |" } else { "" },
        "---:|".repeat(HOST_STAGES.len()),
        if overlap { "---:|" } else { "" }
    ));
    for e in entries {
        let stages: Vec<String> = e.host_ms.iter().map(|(_, st)| format!("{:.3}", st.median)).collect();
        let flight = match (overlap, e.cpu_frame_in_flight) {
            (false, _) => String::new(),
            (true, Some(ms)) => format!(" {ms:.3} |"),
            (true, None) => " – |".to_string(),
        };
        s.push_str(&format!(
            "| {} | {}×{} | {} | {} | {:.3} |{} {:.3} |\n",
            e.scene,
            e.width,
            e.height,
            e.variant,
            stages.join(" | "),
            e.cpu_frame.median,
            flight,
            e.gpu_total.median
        ));
    }
    for e in entries.iter().filter(|e| e.analysis_ahead_ms.is_some()) {
        let st = e.analysis_ahead_ms.as_ref().expect("filtered");
        s.push_str(&format!(
            "\n{} {}×{} {}: each frame's iso analysis (box, bricks) {:.3} ms (median), computed ahead as `render`'s \
             prefetch thread does beside the load, not in the stages above\n",
            e.scene, e.width, e.height, e.variant, st.median
        ));
    }
    // The work each pass did: compute invocations (pipeline statistics), the last measured frame.
    if entries.iter().any(|e| !e.invocations.is_empty()) {
        let counted: Vec<&str> = names
            .iter()
            .copied()
            .filter(|n| entries.iter().any(|e| e.invocations.iter().any(|(p, _)| p == n)))
            .collect();
        s.push_str(&format!(
            "
Compute invocations per pass (pipeline statistics, last measured frame; thousands):

| scene | resolution | variant | {} | total |
|---|---|---|{}---:|
",
            counted.join(" | "),
            "---:|".repeat(counted.len())
        ));
        for e in entries {
            let cells: Vec<String> = counted
                .iter()
                .map(|n| {
                    e.invocations
                        .iter()
                        .find(|(p, _)| p == n)
                        .map_or("–".into(), |(_, k)| format!("{:.1}", *k as f64 / 1e3))
                })
                .collect();
            let total: u64 = e.invocations.iter().map(|(_, k)| k).sum();
            s.push_str(&format!(
                "| {} | {}×{} | {} | {} | {:.1} |
",
                e.scene,
                e.width,
                e.height,
                e.variant,
                cells.join(" | "),
                total as f64 / 1e3
            ));
        }
    }
    // The passes' own counts of their work, the last measured frame.
    s.push_str(&work_table(entries));
    if entries.iter().any(|e| e.flicker.is_some()) {
        s.push_str(&flicker_table(entries));
    }
    // GPU memory: every live allocation after each workload's last entry (the JSON has them per entry).
    for (i, e) in entries.iter().enumerate() {
        let last = entries.get(i + 1).is_none_or(|n| n.scene != e.scene || n.width != e.width || n.height != e.height);
        if last {
            let m = &e.gpu_memory;
            let top: Vec<String> =
                m.allocations.iter().take(8).map(|(n, b)| format!("{n} {:.1}", *b as f64 / 1e6)).collect();
            s.push_str(&format!(
                "\nGPU memory after {} {}×{} (every live allocation of the run): {:.1} MB allocated ({:.1} MB of device \
                 blocks); largest, MB: {}\n",
                e.scene,
                e.width,
                e.height,
                m.allocated_bytes as f64 / 1e6,
                m.reserved_bytes as f64 / 1e6,
                top.join(", ")
            ));
        }
    }
    s
}

/// The passes' own counts of what they did in the last measured frame (markdown): what a GPU's cost follows,
/// whatever a CPU driver's milliseconds say. "–": the pass did not run (or, for `iso_volume`, did not rebuild).
pub fn work_table(entries: &[Entry]) -> String {
    let mut s = String::from(
        "\nWork per pass (each pass's own counters, from a frame counted after the timed ones, which run without \
         counting):\n\n| scene | resolution | variant | splat: \
         sphere–pixel tests (spheres) | iso: field samples (rays queued; tiles cast) | iso_volume: deposits (atomics) | noise: \
         texels evaluated (level) | mesh: field samples (blocks; triangles) |\n|---|---|---|---:|---:|---:|---:|---:|\n",
    );
    let dash = || "–".to_string();
    for e in entries {
        let splat = e.splat_work.map_or_else(dash, |w| format!("{} ({})", w.tests, w.spheres));
        let iso = e.iso_work.map_or_else(dash, |w| format!("{} ({}; {})", w.samples, w.queued + w.fallbacks, w.tiles));
        let vol = e.iso_volume_work.map_or_else(dash, |w| format!("{} ({})", w.deposits, w.atomics));
        let noise = e.noise_work.map_or_else(dash, |w| format!("{} ({})", w.evaluated, w.level));
        let mesh = e.mesh_work.map_or_else(dash, |w| format!("{} ({}; {})", w.field_samples, w.blocks, w.triangles));
        s.push_str(&format!(
            "| {} | {}×{} | {} | {splat} | {iso} | {vol} | {noise} | {mesh} |\n",
            e.scene, e.width, e.height, e.variant
        ));
    }
    s
}

/// The sequences' flicker (`--flicker`, markdown): colour and normal change between consecutive frames where
/// the water stays, and the normals' warping error along the particles' velocities (docs/quality.md).
pub fn flicker_table(entries: &[Entry]) -> String {
    let mut s = String::from(
        "\nFlicker (the sequence rendered once more after the timed frames, as `meniscus quality` measures it):\n\n\
         | scene | resolution | variant | pairs | colour mean (steps) | colour p99 (steps) | normals mean (°) | \
         normals p90 (°) | warping error (°) | pixels warped | particle step (r) |\n\
         |---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    let opt = |v: Option<f32>, k: usize| v.map_or("–".to_string(), |v| format!("{v:.k$}"));
    for e in entries {
        let Some(f) = &e.flicker else { continue };
        s.push_str(&format!(
            "| {} | {}×{} | {} | {} | {:.3} | {:.0} | {:.3} | {:.3} | {} | {} | {} |\n",
            e.scene,
            e.width,
            e.height,
            e.variant,
            f.pairs,
            f.colour_mean,
            f.colour_p99,
            f.normal_mean_deg,
            f.normal_p90_deg,
            opt(f.warp_mean_deg, 2),
            f.warp_coverage.map_or("–".to_string(), |c| format!("{:.0} %", 100.0 * c)),
            opt(f.particle_step_median_r, 3),
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

/// Per-queue times and the hidden time of `--async both` pairs (same scene, size, preset).
pub fn overlap_report(entries: &[Entry]) -> String {
    let mut out = String::new();
    for on in entries.iter().filter(|e| e.async_compute) {
        let off = entries.iter().find(|e| {
            !e.async_compute
                && e.scene == on.scene
                && e.width == on.width
                && e.height == on.height
                && e.variant.trim_end_matches(" async off") == on.variant.trim_end_matches(" async on")
        });
        if let Some(off) = off {
            out += &format!(
                "{} {}×{}: union {:.2} ms (async off) → {:.2} ms (on); main queue {:.2} ms, compute queue {:.2} ms; hidden {:.2} ms\n",
                on.scene,
                on.width,
                on.height,
                off.union_ms.median,
                on.union_ms.median,
                on.queue_main_ms.median,
                on.queue_compute_ms.median,
                off.union_ms.median - on.union_ms.median
            );
        }
    }
    out
}

/// Write the JSON report (`--json`) and the markdown table (`--markdown`) of a bench run.
pub fn write_reports(
    a: &BenchArgs,
    gpu: &std::sync::Arc<Gpu>,
    settings: Settings,
    entries: Vec<Entry>,
    table: &str,
) -> Result<()> {
    let report = Report {
        schema: SCHEMA,
        device: device_info(gpu),
        git_commit: git_commit(),
        preset: a.preset.clone(),
        settings,
        entries,
        rss_start_bytes: start_rss(),
        rss_end_bytes: rss_bytes(),
    };
    if let Some(p) = &a.json {
        meniscus::output::write_json(p, &report)?;
        eprintln!("wrote {}", p.display());
    }
    if let Some(p) = &a.markdown {
        meniscus::output::write_atomic(p, meniscus::output::FileKind::Markdown, |w| {
            std::io::Write::write_all(w, table.as_bytes())
        })?;
    }
    Ok(())
}

/// Per-pass medians plus the total of an entry, for the chart.
pub fn chart_point(e: &Entry) -> Vec<(String, f64)> {
    let mut v: Vec<(String, f64)> = e.passes.iter().map(|(n, s)| (n.clone(), s.median)).collect();
    v.push(("total".into(), e.gpu_total.median));
    v
}
