//! `meniscus bench`: scenes × resolutions under one settings preset, headless. Warm-up frames, then N measured
//! frames; per pass the GPU median, p95 and min (timestamps), the GPU frame total, the CPU frame time
//! (submit → fence), and the bytes of every image and buffer. Prints a markdown table shaped like Moritz
//! tables 4.1–4.4 and returns a JSON-serialisable report (schema: benches/README.md). File workloads start
//! from the same [`Job`] as `render` and `demo`.

use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;

use meniscus::named::{Filter, SplatMode};
use meniscus::scene::procedural;

use crate::args::{finish, GpuArgs, LoadArgs, SceneArgs};
use crate::job::{Job, Select};
use meniscus::device::{DeviceInfo, Gpu};
use meniscus::renderer::{FrameRequest, Renderer, Upload};
use meniscus::scene::camera::Camera;
use meniscus::scene::{self, Particles};
use meniscus::settings::Settings;
use meniscus::timing::percentile;
use meniscus::view::Environment;
use meniscus::view::View;

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
    /// A sequence's frames (from its first, in order): every rendered frame, warm-up included, takes the next
    /// one (cycling), so the passes that run when the particles change (the grid, the iso weights, the
    /// smoothed field) are measured in every frame, as `render` of a sequence pays them. Empty: one set of
    /// particles for every frame.
    pub sequence: Vec<Particles>,
    /// The spray, foam and bubbles of each sequence frame (`--diffuse`), drawn by the `diffuse` pass.
    pub diffuse: Vec<Vec<meniscus::diffuse::Particle>>,
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

/// How many frames a measurement renders: warm-up, measured, and whether it then renders as many again with
/// the renderer's frames in flight (`--in-flight`).
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    pub warmup: u32,
    pub frames: u32,
    pub in_flight: bool,
}

/// Run one workload at one size with settings `s`.
pub fn measure(
    r: &mut Renderer,
    w: &Workload,
    (width, height): (u32, u32),
    s: &Settings,
    variant: &str,
    plan: Plan,
) -> Result<Entry> {
    let mut series = Series::new(r, w, width, height, s, variant)?;
    for k in 0..plan.warmup + plan.frames.max(1) {
        series.frame(r, w, k < plan.warmup, k + 1 == plan.warmup)?;
    }
    if plan.in_flight {
        series.in_flight_ms = Some(series.in_flight(r, w, plan.frames)?);
    }
    series.finish(r, w, plan.warmup, plan.frames)
}

/// Run several settings on one workload at one size with frames interleaved (frame k of every variant, then
/// frame k + 1), each variant on its own renderer, so they see the same host: on a shared 2-core machine the
/// speed drifts ±20 % within seconds, and variants measured one after another gave frame ratios from 1.1 to
/// 1.5 for the same build. Entries in the order of `variants`.
/// With `--in-flight` each variant's frames in flight follow, one variant after another.
pub fn measure_interleaved(
    rs: &mut [Renderer],
    w: &Workload,
    (width, height): (u32, u32),
    variants: &[(String, Settings)],
    plan: Plan,
) -> Result<Vec<Entry>> {
    let mut series = vec![];
    for (r, (label, s)) in rs.iter_mut().zip(variants) {
        series.push(Series::new(r, w, width, height, s, label)?);
    }
    for k in 0..plan.warmup + plan.frames.max(1) {
        for (r, x) in rs.iter_mut().zip(&mut series) {
            x.frame(r, w, k < plan.warmup, k + 1 == plan.warmup)?;
        }
    }
    if plan.in_flight {
        for (r, x) in rs.iter_mut().zip(&mut series) {
            x.in_flight_ms = Some(x.in_flight(r, w, plan.frames)?);
        }
    }
    rs.iter_mut().zip(series).map(|(r, x)| x.finish(r, w, plan.warmup, plan.frames)).collect()
}

/// One variant's measured frames: set up once (camera, particles), then one [`Series::frame`] per frame.
struct Series {
    view: View,
    s: Settings,
    variant: String,
    per_pass: Vec<(String, Vec<f64>)>,
    totals: Vec<f64>,
    cpu: Vec<f64>,
    /// Per measured frame, the host's stages (ms, [`HOST_STAGES`] order).
    host: Vec<[f64; 7]>,
    main_ms: Vec<f64>,
    compute_ms: Vec<f64>,
    union_ms: Vec<f64>,
    pass_queues: Vec<(String, String)>,
    /// Compute invocations per pass, the last measured frame.
    invocations: Vec<(String, u64)>,
    rss_after_warmup: Option<u64>,
    /// Frames rendered (the next sequence frame to upload).
    rendered: usize,
    /// Wall ms per frame with the renderer's frames in flight ([`Series::in_flight`]).
    in_flight_ms: Option<f64>,
    /// A sequence's frames analysed for the iso surface as `render`'s prefetch thread does beside each load
    /// (`surface::iso::analyse`), and how long each took (ms): the upload hands them over.
    ahead: Vec<Option<meniscus::particles::SetAnalysis>>,
    ahead_ms: Vec<f64>,
}

impl Series {
    fn new(r: &mut Renderer, w: &Workload, width: u32, height: u32, s: &Settings, variant: &str) -> Result<Series> {
        let mut s = s.clone();
        s.radius = w.radius;
        let bounds = scene::percentile_bounds(&w.particles.positions, 0.01)
            .ok_or_else(|| meniscus::Error::Invalid(format!("{}: no finite particles", w.label)))?;
        let camera = w.camera.unwrap_or_else(|| {
            let mut c = Camera::fit(&bounds, width as f32 / height as f32);
            c.eye = c.target + (c.eye - c.target) * w.distance;
            c
        });
        let view = View { camera, width, height, env: Environment::around(&bounds, s.radius, &s) };
        // The one upload path of every subcommand: isolated flags and per-particle radii (pscale) included.
        r.upload(Upload::scene(&w.particles, &s))?;
        // A sequence: each frame's analysis, as `render` computes it on its prefetch thread (timed apart: the host
        // stages below are the render thread's).
        let analyser = crate::job::Job::analyser_for(&s);
        let (mut ahead, mut ahead_ms) = (vec![], vec![]);
        for p in &w.sequence {
            let t = Instant::now();
            ahead.push(analyser(p));
            ahead_ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
        Ok(Series {
            view,
            s,
            variant: variant.to_string(),
            per_pass: vec![],
            totals: vec![],
            cpu: vec![],
            host: vec![],
            main_ms: vec![],
            compute_ms: vec![],
            union_ms: vec![],
            pass_queues: vec![],
            invocations: vec![],
            rss_after_warmup: rss_bytes(),
            rendered: 0,
            in_flight_ms: None,
            ahead,
            ahead_ms,
        })
    }

    /// A sequence's next frame of particles (and its diffuse particles) uploaded; a still scene keeps its own.
    fn next_particles(&mut self, r: &mut Renderer, w: &Workload) -> Result<()> {
        if !w.sequence.is_empty() {
            // The upload is recorded into the frame (its copy is on the GPU clock, not in a pass).
            let k = self.rendered % w.sequence.len();
            let ahead = self.ahead.get(k).and_then(|a| a.as_ref());
            r.upload(Upload::Scene { particles: &w.sequence[k], settings: &self.s, motion: None, ahead })?;
            if let Some(d) = w.diffuse.get(k) {
                r.upload(Upload::Diffuse { particles: d, settings: &self.s })?;
            }
        }
        self.rendered += 1;
        Ok(())
    }

    /// `frames` more frames with the renderer's frames in flight, as `render` runs a sequence: the next frame's
    /// particles are uploaded and its commands recorded and submitted while the GPU works on the one before.
    /// Returns the wall ms per frame — what a sequence or a live view sustains: the slower of the host and the
    /// GPU once they overlap (the CPU frame of one frame at a time is their sum).
    fn in_flight(&mut self, r: &mut Renderer, w: &Workload, frames: u32) -> Result<f64> {
        let slots = r.slots().count().max(1);
        let mut pending = std::collections::VecDeque::new();
        let t0 = Instant::now();
        for _ in 0..frames.max(1) {
            self.next_particles(r, w)?;
            pending.push_back(r.submit(FrameRequest::new(&self.view, &self.s).time_parts(parts()))?);
            if pending.len() >= slots {
                if let Some(sub) = pending.pop_front() {
                    r.finish(sub)?;
                }
            }
        }
        for sub in pending {
            r.finish(sub)?;
        }
        Ok(t0.elapsed().as_secs_f64() * 1e3 / frames.max(1) as f64)
    }

    /// Render one frame; a warm-up frame is not recorded (`last_warmup`: note the memory after it).
    fn frame(&mut self, r: &mut Renderer, w: &Workload, warmup: bool, last_warmup: bool) -> Result<()> {
        let t_upload = Instant::now();
        self.next_particles(r, w)?;
        let upload_ms = t_upload.elapsed().as_secs_f64() * 1e3;
        let t0 = Instant::now();
        let sub = r.submit(FrameRequest::new(&self.view, &self.s).time_parts(parts()))?;
        let spans = r.spans(sub)?;
        let cpu_ms = t0.elapsed().as_secs_f64() * 1e3;
        let h = r.state().host_times();
        let before = h.total();
        let host = [upload_ms, h.prepare, h.slot_wait, h.stage, h.record, h.submit, (cpu_ms - before).max(0.0)];
        // Same-named scopes summed, in recording order.
        let mut times: Vec<(String, f64)> = vec![];
        for sp in &spans {
            let ms = (sp.end_ns - sp.begin_ns) * 1e-6;
            match times.iter_mut().find(|(n, _)| *n == sp.name) {
                Some(e) => e.1 += ms,
                None => times.push((sp.name.clone(), ms)),
            }
            if !self.pass_queues.iter().any(|(n, _)| *n == sp.name) {
                self.pass_queues.push((sp.name.clone(), format!("{:?}", sp.queue).to_lowercase()));
            }
        }
        let times = meniscus::timing::PassTimes(times);
        if last_warmup {
            self.rss_after_warmup = rss_bytes();
        }
        if warmup {
            return Ok(());
        }
        // Invocations per pass (same-named scopes summed), the last measured frame's.
        self.invocations.clear();
        for sp in &spans {
            if let Some(n) = sp.invocations {
                match self.invocations.iter_mut().find(|(p, _)| *p == sp.name) {
                    Some(e) => e.1 += n,
                    None => self.invocations.push((sp.name.clone(), n)),
                }
            }
        }
        for (name, ms) in &times.0 {
            match self.per_pass.iter_mut().find(|(n, _)| n == name) {
                Some(e) => e.1.push(*ms),
                None => self.per_pass.push((name.clone(), vec![*ms])),
            }
        }
        self.totals.push(times.total());
        self.cpu.push(cpu_ms);
        self.host.push(host);
        // Per queue: the time its passes were busy; the union: first begin to last end over both queues
        // (the two queues' timestamps on one device clock; no calibrated timestamps are needed for that).
        use meniscus::device::QueueId;
        use meniscus::timing::is_part;
        let busy = |q: QueueId| {
            let own = spans.iter().filter(|x| x.queue == q && !is_part(&x.name));
            own.map(|x| (x.end_ns - x.begin_ns) * 1e-6).sum::<f64>()
        };
        self.main_ms.push(busy(QueueId::Main));
        self.compute_ms.push(busy(QueueId::Compute));
        let first = spans.iter().map(|x| x.begin_ns).fold(f64::INFINITY, f64::min);
        let last = spans.iter().map(|x| x.end_ns).fold(f64::NEG_INFINITY, f64::max);
        self.union_ms.push(if spans.is_empty() { 0.0 } else { (last - first) * 1e-6 });
        Ok(())
    }

    /// The entry: the timed frames' statistics, and each pass's own work from one more frame that counts it (the
    /// counting sums would cost the timed frames: docs/gpu-frame.md) — a sequence's next frame, a still scene's
    /// same particles.
    fn finish(mut self, r: &mut Renderer, w: &Workload, warmup: u32, frames: u32) -> Result<Entry> {
        self.next_particles(r, w)?;
        let counted = r.submit(FrameRequest::new(&self.view, &self.s).count_work())?;
        r.finish(counted)?;
        let memory: Vec<Mem> =
            r.state().memory().into_iter().map(|(n, b)| Mem { name: n.to_string(), bytes: b }).collect();
        let ran = |pass: &str| self.per_pass.iter().any(|(n, _)| n == pass);
        let work = r.state().work(&self.s, ran)?;
        Ok(Entry {
            scene: w.label.clone(),
            particles: w.particles.len(),
            radius: self.s.radius,
            width: self.view.width,
            height: self.view.height,
            variant: self.variant,
            filter: self.s.filter.method.name().to_string(),
            camera: self.view.camera.to_arg(),
            frames: frames.max(1),
            warmup,
            passes: self.per_pass.into_iter().map(|(n, v)| (n, Stat::of(&v))).collect(),
            gpu_total: Stat::of(&self.totals),
            cpu_frame: Stat::of(&self.cpu),
            cpu_frame_in_flight: self.in_flight_ms,
            memory_images_bytes: memory.iter().map(|m| m.bytes).sum(),
            memory_fluid_images_bytes: memory
                .iter()
                .filter(|m| !matches!(m.name.as_str(), "scene_color" | "scene_depth" | "final"))
                .map(|m| m.bytes)
                .sum(),
            memory,
            memory_particles_bytes: 16 * w.particles.len() as u64,
            rss_after_warmup_bytes: self.rss_after_warmup,
            async_compute: r.async_compute,
            queue_main_ms: Stat::of(&self.main_ms),
            queue_compute_ms: Stat::of(&self.compute_ms),
            union_ms: Stat::of(&self.union_ms),
            pass_queues: self.pass_queues,
            rss_after_frames_bytes: rss_bytes(),
            gpu_memory: r.gpu.memory_report(),
            noise_work: work.noise,
            iso_work: work.iso,
            splat_work: work.splat,
            iso_volume_work: work.iso_volume,
            host_ms: HOST_STAGES
                .iter()
                .enumerate()
                .map(|(k, n)| (n.to_string(), Stat::of(&self.host.iter().map(|h| h[k]).collect::<Vec<_>>())))
                .collect(),
            analysis_ahead_ms: self.ahead.iter().any(|a| a.is_some()).then(|| Stat::of(&self.ahead_ms)),
            invocations: self.invocations,
            effect_images: r.effects.memory().into_iter().map(|(n, _)| n.to_string()).collect(),
        })
    }
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
fn work_table(entries: &[Entry]) -> String {
    let mut s = String::from(
        "\nWork per pass (each pass's own counters, from a frame counted after the timed ones, which run without \
         counting):\n\n| scene | resolution | variant | splat: \
         sphere–pixel tests (spheres) | iso: field samples (rays queued; tiles cast) | iso_volume: deposits (atomics) | noise: \
         texels evaluated (level) |\n|---|---|---|---:|---:|---:|---:|\n",
    );
    let dash = || "–".to_string();
    for e in entries {
        let splat = e.splat_work.map_or_else(dash, |w| format!("{} ({})", w.tests, w.spheres));
        let iso = e.iso_work.map_or_else(dash, |w| format!("{} ({}; {})", w.samples, w.queued + w.fallbacks, w.tiles));
        let vol = e.iso_volume_work.map_or_else(dash, |w| format!("{} ({})", w.deposits, w.atomics));
        let noise = e.noise_work.map_or_else(dash, |w| format!("{} ({})", w.evaluated, w.level));
        s.push_str(&format!(
            "| {} | {}×{} | {} | {splat} | {iso} | {vol} | {noise} |\n",
            e.scene, e.width, e.height, e.variant
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

/// `meniscus bench`.
#[derive(Args, Clone, Debug)]
pub struct BenchArgs {
    /// Settings preset: default, fast, moritz (curvature flow ≤ 60 iterations, SSR stride 8 / 100 steps /
    /// 4 refinements, fluid ≈ ¼ of the screen, Moritz's five workloads at 1920×1080 and 960×540 unless
    /// --scenes/--resolutions say otherwise), table43 (the moritz settings with the five SSR settings of
    /// Moritz table 4.3, wave scene, 1920×1080).
    #[arg(long, default_value = "default")]
    preset: String,
    /// Comma-separated workloads: wave, crown1 (38,146), crown2 (157,944), waterfall (819,417), worst (a block
    /// filling the screen), any built-in scene as NAME or NAME:COUNT, a particle file, or a sequence (a pattern
    /// with {}, a folder or a glob): every rendered frame then takes the sequence's next frame, so the work
    /// done when particles change (grid, iso weights, smoothed field) is in every measured frame.
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// Sequence workloads: frames FIRST..LAST[:STEP] (inclusive, by the numbers in the file names) instead of
    /// the sequence's first warm-up + measured frames; the radius and camera are fitted to its first frame as
    /// `render` fits them.
    #[arg(long = "sequence-frames", value_name = "RANGE")]
    sequence_frames: Option<String>,
    /// Sequence workloads: generate their spray, foam and bubbles (in time order from the sequence's first
    /// frame, before timing) and draw them, so the `diffuse` pass is measured. With --sim: the simulation's
    /// diffuse stages run (on the GPU, timed per frame) and the frames draw their particles.
    #[arg(long, alias = "foam")]
    diffuse: bool,
    /// Comma-separated WIDTHxHEIGHT list.
    #[arg(long, value_delimiter = ',')]
    resolutions: Vec<String>,
    /// Frames rendered before measuring (lavapipe compiles pipelines at first use).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=10_000))]
    warmup: u32,
    /// Measured frames.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    frames: u32,
    /// Then render as many frames again with the renderer's frames in flight (the next frame's upload and
    /// recording overlap the GPU's work on the one before, as `render` runs a sequence) and report their wall
    /// time per frame beside the CPU frame (JSON `cpu_frame_in_flight`): what a sequence or a live view
    /// sustains, the slower of the host and the GPU.
    #[arg(long = "in-flight")]
    in_flight: bool,
    /// Also time each part of a pass on its own (its dispatches: `noise/scan`, `iso/rest`, DFSPH's every recorded
    /// correction, …), in the table and the JSON beside the pass. Every part's timestamps drain the GPU's
    /// pipeline, so the passes themselves read slower: measure parts apart from frame times.
    #[arg(long)]
    parts: bool,
    /// Particle radius for file workloads (default: estimated from the spacing).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true)]
    radius: Option<f32>,
    /// Camera for file workloads, EYE:TARGET[:FOVY] (default: fitted).
    #[arg(long, allow_hyphen_values = true)]
    camera: Option<String>,
    /// Also measure design variants on the first workload and resolution (same run, so ratios compare):
    /// each splat mode (compute, quads/points with gl_FragDepth, conservative depth, MIN blending), each
    /// smoothing filter, curvature flow 1 vs 4 iterations per dispatch.
    #[arg(long)]
    variants: bool,
    /// Write the JSON report here (schema: benches/README.md).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Reuse the static background while the camera stays (as `render` of a sequence does) instead of
    /// re-rendering it every measured frame.
    #[arg(long)]
    cache_background: bool,
    /// Split each frame over the main and the async compute queue (background and thickness beside the fluid
    /// passes): off, on, or both (every configuration measured twice in one run, hidden time reported).
    #[arg(long = "async", value_parser = ["off", "on", "both"], default_value = "off")]
    async_mode: String,
    /// Write the markdown table here too.
    #[arg(long)]
    markdown: Option<PathBuf>,
    /// Scaling sweeps instead of the scene list: `particles` (wave scene, 10k → 4M particles at fixed screen
    /// coverage, first resolution), `pixels` (wave scene, 480p → 4K), or `both`.
    #[arg(long, value_parser = ["particles", "pixels", "both"])]
    sweep: Option<String>,
    /// With --sweep: particle counts (comma-separated) instead of 10k, 40k, 160k, 640k, 2.56M, 4M.
    #[arg(long, value_delimiter = ',')]
    sweep_particles: Vec<usize>,
    /// With --sweep: write the chart (per-pass ms against particles and pixels) as PNG here. With --mesh: the
    /// scaling chart (wall time against threads per cube size, splashsurf and ideal scaling beside it).
    #[arg(long)]
    chart: Option<PathBuf>,
    /// TOML settings over the preset.
    #[arg(long)]
    settings: Option<PathBuf>,
    /// Also measure these presets (comma-separated: default, fast, quality, moritz) on every workload and
    /// resolution, in the same run with their frames interleaved with the main preset's (one renderer each, so
    /// all see the same host), and print each one's frame time as a ratio of the main preset's. PRESET@FILE
    /// takes FILE's settings over that preset instead of --settings (a variant measured against the main
    /// preset, e.g. quality@half-steps.toml). (With --async both, they run one after another.)
    #[arg(long, value_delimiter = ',')]
    also_presets: Vec<String>,
    /// Frame the built-in workloads so the fluid covers about a quarter of the screen (Moritz's framing; implied
    /// by --preset moritz and table43).
    #[arg(long)]
    quarter_framing: bool,
    /// Benchmark the live simulation instead: SCENE or SCENE:PARTICLES (dambreak, drop, waterfall, pool), or a
    /// SPlisHSPlasH scene.json (its set-up and solver settings). Reports
    /// per-stage ms per step and steps/s, then frames that step and render together at the first resolution
    /// (with --async on/both: the step on the async compute queue, and the overlap it buys).
    #[arg(long, value_name = "SCENE[:N]")]
    pub sim: Option<String>,
    /// Benchmark the mesh extraction instead (`meniscus mesh`'s path, Janisz's thread analysis): this particle
    /// file at each --threads count, per phase (grid, blocks, weld, write) wall and thread time, speed-up and
    /// parallel efficiency; splashsurf beside it when installed (SPLASHSURF or ~/.cache/meniscus/splashsurf).
    #[arg(long, value_name = "FILE")]
    pub mesh: Option<PathBuf>,
    /// With --mesh: thread counts (comma-separated; default 1, 2, 4, … up to the cores).
    #[arg(long, value_delimiter = ',')]
    pub threads: Vec<usize>,
    /// With --mesh: cube sizes in particle radii (comma-separated; default 0.5, 1.0).
    #[arg(long = "cube-size", value_parser = crate::args::finite::<f32>, value_delimiter = ',', allow_negative_numbers = true)]
    pub cube_size: Vec<f32>,
    /// With --mesh: extract on the GPU too (`mesh --gpu`), its stages and host part beside the CPU rows.
    #[arg(long = "mesh-gpu")]
    pub mesh_gpu: bool,
    /// With --mesh: cubes per block edge of the CPU extraction (comma-separated; default: chosen from the
    /// particles and the cube size, as `mesh --block` is).
    #[arg(long = "block", value_delimiter = ',')]
    pub block: Vec<u32>,
    /// With --mesh: runs per configuration (the median is reported).
    #[arg(long = "mesh-repeat", default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=20))]
    pub mesh_repeat: u32,
    #[command(flatten)]
    load: LoadArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

impl BenchArgs {
    /// The frames each measurement renders.
    fn plan(&self) -> Plan {
        Plan { warmup: self.warmup, frames: self.frames, in_flight: self.in_flight }
    }
}

/// A workload from its command-line name.
fn workload(name: &str, a: &BenchArgs, base: &Settings, quarter: bool) -> Result<(Workload, Option<Job>)> {
    let dist = if quarter { 2.0 } else { 1.0 };
    let (scene, count, distance, label) = match name {
        "wave" => ("wave", 143_944, dist, "wave".to_string()),
        "crown1" => ("crown", 38_146, dist, "crown 1".to_string()),
        "crown2" => ("crown", 157_944, dist, "crown 2".to_string()),
        "waterfall" => ("waterfall", 819_417, dist, "waterfall".to_string()),
        "worst" => ("block", 143_944, 0.55, "worst case (block fills the screen)".to_string()),
        other => {
            let (n, c) = match other.split_once(':') {
                Some((n, c)) => {
                    (n, Some(c.parse::<usize>().with_context(|| format!("bad particle count in {other:?}"))?))
                }
                None => (other, None),
            };
            if let Some((sn, def, _)) = procedural::SCENES.iter().find(|s| s.0 == n) {
                (*sn, c.unwrap_or(*def), dist, n.to_string())
            } else {
                // A file or sequence: the same Job as `render` and `demo` (radii, camera, load flags).
                let scene_args = SceneArgs {
                    input: other.to_string(),
                    radius: a.radius,
                    particles: None,
                    camera: a.camera.clone(),
                    background_obj: None,
                    no_scene_json: false,
                };
                let range =
                    a.sequence_frames.as_deref().map(meniscus::scene::sequence::FrameRange::parse).transpose()?;
                let job = Job::open(&scene_args, &a.load, base.clone(), Select { range, shard: None })?;
                let mut label = Path::new(&job.label)
                    .file_name()
                    .map(|f| f.to_string_lossy().into_owned())
                    .unwrap_or(job.label.clone());
                // A sequence: its first warm-up + measured frames, each rendered frame a new one.
                let (mut sequence, mut diffuse) = (vec![], vec![]);
                if a.diffuse && job.frames.is_none() {
                    bail!("--diffuse applies to sequence workloads ({other} is one file)");
                }
                let mut walk = if a.diffuse { Some(crate::diffuse::Walk::new(&job)?) } else { None };
                if let Some(frames) = &job.frames {
                    let n = (a.warmup + a.frames.max(1)) as usize;
                    for f in frames.iter().take(n) {
                        let p = meniscus::scene::load_with(&f.path, &job.load)
                            .with_context(|| format!("{}", f.path.display()))?;
                        if let Some(walk) = walk.as_mut() {
                            diffuse.push(walk.advance(f.number, Some(&p))?.to_vec());
                        }
                        sequence.push(p);
                    }
                    let (lo, hi) = (frames[0].number, frames[sequence.len().max(1) - 1].number);
                    label = format!("{label} (frames {lo}…{hi}, a new one every frame)");
                }
                return Ok((
                    Workload {
                        label,
                        particles: job.first.clone(),
                        radius: job.settings.radius,
                        distance: 1.0,
                        camera: job.camera,
                        sequence,
                        diffuse,
                    },
                    Some(job),
                ));
            }
        }
    };
    let g = procedural::generate(scene, count)?;
    Ok((
        Workload {
            label,
            particles: g.particles,
            radius: g.radius,
            distance,
            camera: None,
            sequence: vec![],
            diffuse: vec![],
        },
        None,
    ))
}

/// The async settings `--async` asks for: [false], [true] or both.
fn async_modes(mode: &str) -> Vec<bool> {
    match mode {
        "on" => vec![true],
        "both" => vec![false, true],
        _ => vec![false],
    }
}

/// Per-queue times and the hidden time of `--async both` pairs (same scene, size, preset).
fn overlap_report(entries: &[Entry]) -> String {
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

/// Run the benchmark.
pub fn run(a: &BenchArgs) -> Result<()> {
    note_start_rss();
    let env_parts = std::env::var("MENISCUS_PARTS").is_ok_and(|v| v == "1");
    if env_parts {
        eprintln!("warning: MENISCUS_PARTS=1 is deprecated: it is `bench --parts` now");
    }
    PARTS.store(a.parts || env_parts, std::sync::atomic::Ordering::Relaxed);
    use meniscus::output::FileKind;
    if a.sweep.is_none() && a.mesh.is_none() && a.chart.is_some() {
        bail!("--chart applies to a sweep or --mesh: add --sweep particles (or pixels), or --mesh FILE");
    }
    if a.sweep.is_none() && !a.sweep_particles.is_empty() {
        bail!("--sweep-particles applies to a sweep: add --sweep particles (or pixels)");
    }
    for f in &a.scenes {
        meniscus::input::note(std::path::Path::new(f));
    }
    for (flag, path, kind) in [
        ("--json", &a.json, FileKind::Json),
        ("--markdown", &a.markdown, FileKind::Markdown),
        ("--chart", &a.chart, FileKind::Png),
    ] {
        if let Some(p) = path {
            crate::args::check_report(flag, p, kind)?;
        }
    }
    if let Some(n) = a.threads.iter().find(|n| !(1..=crate::mesh::MAX_THREADS).contains(n)) {
        bail!("--threads {n}: between 1 and {}", crate::mesh::MAX_THREADS);
    }
    if let Some(file) = &a.mesh {
        // The frame flags have no meaning for the mesh extraction's benchmark: refused, not ignored.
        let unused: Vec<&str> = [
            ("--sweep", a.sweep.is_some()),
            ("--scenes", !a.scenes.is_empty()),
            ("--sim", a.sim.is_some()),
            ("--variants", a.variants),
            ("--also-presets", !a.also_presets.is_empty()),
            ("--in-flight", a.in_flight),
        ]
        .into_iter()
        .filter(|(_, on)| *on)
        .map(|(f, _)| f)
        .collect();
        if !unused.is_empty() {
            bail!("{} measure frames; --mesh measures the mesh extraction: run them apart", unused.join(", "));
        }
        let opts = crate::bench_mesh::Options {
            threads: a.threads.clone(),
            cubes: a.cube_size.clone(),
            blocks: a.block.clone(),
            radius: a.radius,
            repeat: a.mesh_repeat,
            gpu: a.mesh_gpu.then(|| a.gpu.clone()),
        };
        return crate::bench_mesh::run(
            file,
            &a.load,
            &opts,
            a.json.as_deref(),
            a.markdown.as_deref(),
            a.chart.as_deref(),
        );
    }
    if !a.threads.is_empty() || !a.cube_size.is_empty() || !a.block.is_empty() || a.mesh_gpu {
        bail!("--threads, --cube-size, --block and --mesh-gpu apply to --mesh FILE");
    }
    let table43 = a.preset == "table43";
    let moritz = a.preset == "moritz" || table43;
    let quarter = moritz || a.quarter_framing;
    let mut base = Settings::preset(if table43 { "moritz" } else { &a.preset })?;
    if let Some(f) = &a.settings {
        base = crate::args::settings_file(&base, f)?;
    }
    let scenes: Vec<String> = if !a.scenes.is_empty() {
        a.scenes.clone()
    } else if table43 {
        vec!["wave".into()]
    } else if moritz {
        ["wave", "crown1", "crown2", "waterfall", "worst"].map(String::from).to_vec()
    } else {
        vec!["wave".into()]
    };
    let resolutions: Vec<(u32, u32)> = if !a.resolutions.is_empty() {
        a.resolutions.iter().map(|r| crate::args::parse_resolution(r)).collect::<Result<_>>()?
    } else if table43 {
        vec![(1920, 1080)]
    } else if moritz {
        vec![(1920, 1080), (960, 540)]
    } else {
        vec![(960, 540)]
    };
    let gpu = a.gpu.open()?;
    eprintln!("device: {} ({}), Vulkan {}", gpu.info.name, gpu.info.driver, gpu.info.api_version);
    if let Some(sim) = &a.sim {
        let modes = async_modes(&a.async_mode);
        let (size, json) = (resolutions[0], a.json.as_deref());
        return crate::bench_sim::run(&gpu, sim, &base, size, a.warmup, a.frames, &modes, json, a.diffuse);
    }
    let mut r = Renderer::new(&gpu)?;
    r.background.always_render = !a.cache_background;
    let mut also = vec![];
    for p in &a.also_presets {
        // PRESET, or PRESET@FILE: that preset with FILE's settings instead of --settings.
        let (name, file) = match p.split_once('@') {
            Some((n, f)) => (n, Some(PathBuf::from(f))),
            None => (p.as_str(), a.settings.clone()),
        };
        let mut s = Settings::preset(name)?;
        if let Some(f) = &file {
            s = crate::args::settings_file(&s, f)?;
        }
        also.push((p.clone(), s));
    }
    let mut variants: Vec<(String, Settings)> = vec![(a.preset.clone(), base.clone())];
    let n_var = if a.variants { 12 } else { 0 };
    let bar = indicatif::ProgressBar::new((scenes.len() * resolutions.len() + n_var) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {msg} [{elapsed}]").expect("valid template"),
    );
    let mut entries = vec![];
    // With --also-presets: one renderer per extra preset (created at the first workload).
    let mut also_renderers: Vec<Renderer> = vec![];
    if let Some(sweep) = &a.sweep {
        bar.finish_and_clear();
        return run_sweep(a, sweep, &gpu, &mut r, &base, resolutions[0]);
    }
    for (k, name) in scenes.iter().enumerate() {
        bar.set_message(format!("generating {name}"));
        let (w, job) = workload(name, a, &base, quarter)?;
        if let Some(job) = &job {
            eprintln!("{}", job.summary(Some(resolutions[0])));
        }
        for (j, &(wd, ht)) in resolutions.iter().enumerate() {
            bar.set_message(format!("{} {}×{}", w.label, wd, ht));
            if table43 {
                // Moritz table 4.3: stride / refinement iterations / max steps.
                for (stride, refine, steps) in [(1, 0, 280), (4, 0, 180), (4, 2, 180), (8, 0, 100), (8, 4, 100)] {
                    let vs = base.with(|s| {
                        s.ssr.stride = stride as f32;
                        s.ssr.refine = refine;
                        s.ssr.max_steps = steps;
                    });
                    let label = format!("ssr stride {stride}, refine {refine}, steps {steps}");
                    entries.push(measure(&mut r, &w, (wd, ht), &vs, &label, a.plan())?);
                }
                bar.inc(1);
                continue;
            }
            if !also.is_empty() && a.async_mode != "both" {
                // The main preset and the others, frames interleaved (one renderer each), so their ratios
                // compare on a drifting host.
                bar.set_message(format!("{} {}×{} presets {} + {} interleaved", w.label, wd, ht, a.preset, also.len()));
                while also_renderers.len() < also.len() {
                    let mut x = Renderer::new(&gpu)?;
                    x.background.always_render = !a.cache_background;
                    also_renderers.push(x);
                }
                r.async_compute = a.async_mode == "on";
                for x in &mut also_renderers {
                    x.async_compute = r.async_compute;
                }
                let mut rs = std::mem::take(&mut also_renderers);
                rs.insert(0, r);
                let mut vs = vec![(a.preset.clone(), base.clone())];
                vs.extend(also.iter().cloned());
                let measured = measure_interleaved(&mut rs, &w, (wd, ht), &vs, a.plan());
                r = rs.remove(0);
                also_renderers = rs;
                entries.extend(measured?);
            } else {
                for split in async_modes(&a.async_mode) {
                    r.async_compute = split;
                    let label = if a.async_mode == "both" {
                        format!("{} async {}", a.preset, if split { "on" } else { "off" })
                    } else {
                        a.preset.clone()
                    };
                    entries.push(measure(&mut r, &w, (wd, ht), &base, &label, a.plan())?);
                }
                r.async_compute = a.async_mode == "on";
                for (label, vs) in &also {
                    bar.set_message(format!("{} {}×{} preset {label}", w.label, wd, ht));
                    entries.push(measure(&mut r, &w, (wd, ht), vs, label, a.plan())?);
                }
            }
            bar.inc(1);
            if a.variants && k == 0 && j == 0 {
                variants.clear();
                for f in [Filter::Bilateral, Filter::NarrowRange, Filter::CurvatureFlow] {
                    variants.push((format!("filter {}", f.name()), base.with(|s| s.filter.method = f)));
                }
                for kk in [1, 4] {
                    variants.push((
                        format!("curvature-flow {kk} it/dispatch"),
                        base.with(|s| {
                            s.filter.method = Filter::CurvatureFlow;
                            s.filter.curvature.iters_per_dispatch = kk;
                        }),
                    ));
                }
                variants.push(("no smoothing".into(), base.with(|s| s.filter.method = Filter::None)));
                for &m in SplatMode::ALL {
                    if r.passes.splat.supports(m) {
                        variants.push((format!("splat {}", m.name()), base.with(|s| s.splat.mode = m)));
                    }
                }
                for (label, vs) in &variants {
                    bar.set_message(format!("variant {label}"));
                    entries.push(measure(&mut r, &w, (wd, ht), vs, label, a.plan())?);
                    bar.inc(1);
                }
            }
        }
    }
    bar.finish_and_clear();
    let table = markdown(&entries);
    println!("{} — {} — preset {} — commit {}\n", gpu.info.name, gpu.info.driver, a.preset, git_commit());
    println!("{table}");
    if a.variants {
        let find = |v: &str| {
            entries
                .iter()
                .find(|e| e.variant == v)
                .map(|e| e.passes.iter().find(|p| p.0 == "filter").map(|p| p.1.median).unwrap_or(0.0))
        };
        if let (Some(k1), Some(k4)) = (find("curvature-flow 1 it/dispatch"), find("curvature-flow 4 it/dispatch")) {
            println!("ratio filter (curvature flow) 1 it/dispatch ÷ 4 it/dispatch: {:.2} (> 1: several per dispatch is faster)", k1 / k4.max(1e-9));
        }
        let splat = |v: &str| {
            entries
                .iter()
                .find(|e| e.variant == v)
                .and_then(|e| e.passes.iter().find(|p| p.0 == "splat").map(|p| p.1.median))
        };
        if let Some(fd) = splat("splat quad-frag-depth") {
            for m in ["compute", "quad-conservative", "quad-min", "point-frag-depth", "point-min"] {
                if let Some(t) = splat(&format!("splat {m}")) {
                    println!("ratio splat quad-frag-depth ÷ {m}: {:.2} (> 1: {m} is faster)", fd / t.max(1e-9));
                }
            }
        }
    }
    if !also.is_empty() {
        println!("\nframe time (union of the queues, median) as a ratio of preset {}:", a.preset);
        for e in entries.iter().filter(|e| also.iter().any(|(l, _)| *l == e.variant)) {
            let base_entry = entries.iter().find(|b| {
                b.scene == e.scene && b.width == e.width && b.height == e.height && b.variant.starts_with(&a.preset)
            });
            if let Some(b) = base_entry {
                println!(
                    "  {} {}×{}: {} {:.2} ms ÷ {} {:.2} ms = {:.2}",
                    e.scene,
                    e.width,
                    e.height,
                    e.variant,
                    e.union_ms.median,
                    b.variant,
                    b.union_ms.median,
                    e.union_ms.median / b.union_ms.median.max(1e-9)
                );
            }
        }
    }
    let overlap = overlap_report(&entries);
    if !overlap.is_empty() {
        let clock = if gpu.info.calibrated_timestamps {
            "one device time domain (calibrated timestamps)"
        } else {
            "per-queue timestamps assumed on one clock (no calibrated timestamps on this device)"
        };
        println!("\n{overlap}({clock})");
    }
    write_reports(a, &gpu, base, entries, &table)?;
    finish(&gpu)
}

/// Write the JSON report (`--json`) and the markdown table (`--markdown`) of a bench run.
fn write_reports(
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
        let text = serde_json::to_string_pretty(&report)?;
        meniscus::output::write_atomic(p, meniscus::output::FileKind::Json, |w| {
            std::io::Write::write_all(w, text.as_bytes())
        })?;
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
fn chart_point(e: &Entry) -> Vec<(String, f64)> {
    let mut v: Vec<(String, f64)> = e.passes.iter().map(|(n, s)| (n.clone(), s.median)).collect();
    v.push(("total".into(), e.gpu_total.median));
    v
}

fn run_sweep(
    a: &BenchArgs,
    sweep: &str,
    gpu: &std::sync::Arc<Gpu>,
    r: &mut Renderer,
    base: &Settings,
    res: (u32, u32),
) -> Result<()> {
    let counts: Vec<usize> = if a.sweep_particles.is_empty() {
        vec![10_000, 40_000, 160_000, 640_000, 2_560_000, 4_000_000]
    } else {
        a.sweep_particles.clone()
    };
    let sizes = [(854u32, 480u32), (1280, 720), (1920, 1080), (2560, 1440), (3840, 2160)];
    let do_particles = sweep == "particles" || sweep == "both";
    let do_pixels = sweep == "pixels" || sweep == "both";
    let total = if do_particles { counts.len() } else { 0 } + if do_pixels { sizes.len() } else { 0 };
    let bar = indicatif::ProgressBar::new(total as u64);
    bar.set_style(indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {msg} [{elapsed}]").expect("template"));
    let mut entries = vec![];
    let mut panels = vec![];
    if do_particles {
        let mut pts = vec![];
        for &n in &counts {
            bar.set_message(format!("{n} particles"));
            // The same pool at every count: the camera fit keeps the screen coverage fixed.
            let g = procedural::generate("wave", n)?;
            let w = Workload {
                label: "wave".into(),
                particles: g.particles,
                radius: g.radius,
                distance: 1.0,
                camera: None,
                sequence: vec![],
                diffuse: vec![],
            };
            let e = measure(r, &w, res, base, "sweep particles", a.plan())?;
            pts.push((e.particles as f64, chart_point(&e)));
            entries.push(e);
            bar.inc(1);
        }
        panels.push(("particles", pts));
    }
    if do_pixels {
        let g = procedural::generate("wave", 143_944)?;
        let w = Workload {
            label: "wave".into(),
            particles: g.particles,
            radius: g.radius,
            distance: 1.0,
            camera: None,
            sequence: vec![],
            diffuse: vec![],
        };
        let mut pts = vec![];
        for &(wd, ht) in &sizes {
            bar.set_message(format!("{wd}×{ht}"));
            let e = measure(r, &w, (wd, ht), base, "sweep pixels", a.plan())?;
            pts.push(((wd * ht) as f64, chart_point(&e)));
            entries.push(e);
            bar.inc(1);
        }
        panels.push(("pixels", pts));
    }
    bar.finish_and_clear();
    let table = markdown(&entries);
    println!("{} — {} — preset {} — sweep {sweep}\n\n{table}", gpu.info.name, gpu.info.driver, a.preset);
    // The measurements first, so a chart that cannot be drawn (no font on a bare GPU machine) loses nothing.
    write_reports(a, gpu, base.clone(), entries, &table)?;
    if let Some(p) = &a.chart {
        let series: Vec<crate::chart::Series> = panels
            .into_iter()
            .map(|(x, points)| crate::chart::Series {
                title: String::new(),
                x_label: if x == "particles" { "particles" } else { "pixels" },
                y_label: "GPU ms (median)",
                points,
            })
            .collect();
        crate::chart::write(p, &format!("meniscus bench --sweep {sweep} — {}", gpu.info.name), &series)?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}
