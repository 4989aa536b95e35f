//! How `meniscus bench` measures a workload: warm-up frames, measured frames (GPU timestamps per pass, the
//! host's stages, memory), then optionally as many again with frames in flight; several renderers interleaved
//! frame by frame so their ratios share the host's swings.

use std::time::Instant;

use anyhow::Result;

use meniscus::renderer::{FrameRequest, Renderer, Upload};
use meniscus::scene::{self, camera::Camera};
use meniscus::settings::Settings;
use meniscus::view::{Environment, View};

use crate::bench::Workload;
use crate::bench_report::*;

/// How many frames a measurement renders: warm-up, measured, and whether it then renders as many again with
/// the renderer's frames in flight (`--in-flight`).
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    pub warmup: u32,
    pub frames: u32,
    pub in_flight: bool,
    /// Sequences: their flicker after the measured frames (`--flicker`).
    pub flicker: bool,
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
    series.finish(r, w, plan)
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
    rs.iter_mut().zip(series).map(|(r, x)| x.finish(r, w, plan)).collect()
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
    /// (`surface::grid::analyse`), and how long each took (ms): the upload hands them over.
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
    fn finish(mut self, r: &mut Renderer, w: &Workload, plan: Plan) -> Result<Entry> {
        let (warmup, frames) = (plan.warmup, plan.frames);
        self.next_particles(r, w)?;
        let counted = r.submit(FrameRequest::new(&self.view, &self.s).count_work())?;
        r.finish(counted)?;
        crate::job::say_mesh_path(r, &self.s, &mut None);
        let memory: Vec<Mem> =
            r.state().memory().into_iter().map(|(n, b)| Mem { name: n.to_string(), bytes: b }).collect();
        let ran = |pass: &str| self.per_pass.iter().any(|(n, _)| n == pass);
        let work = r.state().work(&self.s, ran)?;
        let flicker = if plan.flicker && w.sequence.len() > 1 { Some(self.flicker(r, w)?) } else { None };
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
            async_compute: r.state().async_compute(),
            queue_main_ms: Stat::of(&self.main_ms),
            queue_compute_ms: Stat::of(&self.compute_ms),
            union_ms: Stat::of(&self.union_ms),
            pass_queues: self.pass_queues,
            rss_after_frames_bytes: rss_bytes(),
            gpu_memory: r.state().gpu().memory_report(),
            noise_work: work.noise,
            iso_work: work.iso,
            splat_work: work.splat,
            iso_volume_work: work.iso_volume,
            mesh_work: work.mesh,
            host_ms: HOST_STAGES
                .iter()
                .enumerate()
                .map(|(k, n)| (n.to_string(), Stat::of(&self.host.iter().map(|h| h[k]).collect::<Vec<_>>())))
                .collect(),
            analysis_ahead_ms: self.ahead.iter().any(|a| a.is_some()).then(|| Stat::of(&self.ahead_ms)),
            invocations: self.invocations,
            effect_images: r.state().effects().memory().into_iter().map(|(n, _)| n.to_string()).collect(),
            flicker,
        })
    }
}

/// A rendered frame as the flicker meter reads it.
fn picture(f: &crate::quality::Rendered) -> meniscus::quality::Picture<'_> {
    meniscus::quality::Picture { colour: &f.0, depth: &f.1, normals: &f.2 }
}

impl Series {
    /// The sequence's frames rendered once more and read back: their flicker (`meniscus quality`'s measure,
    /// the warping error with the files' velocities where they have them).
    fn flicker(&self, r: &mut Renderer, w: &Workload) -> Result<meniscus::quality::Flicker> {
        let mut meter = meniscus::quality::FlickerMeter::default();
        let mut prev: Option<crate::quality::Rendered> = None;
        for p in &w.sequence {
            r.upload(Upload::Scene { particles: p, settings: &self.s, motion: None, ahead: None })?;
            r.render(&self.view, &self.s)?;
            let now = crate::quality::read_frame(r, self.view.width, self.view.height)?;
            if let Some(before) = &prev {
                let motion = p.velocities.as_ref().map(|v| meniscus::quality::SurfaceMotion {
                    positions: &p.positions,
                    velocities: v,
                    dt: 1.0 / w.fps,
                    camera: &self.view.camera,
                    radius: self.s.radius,
                });
                meter.add(&picture(before), &picture(&now), motion.as_ref());
            }
            prev = Some(now);
        }
        Ok(meter.result())
    }
}
