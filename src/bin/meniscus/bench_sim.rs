//! `meniscus bench --sim SCENE[:N]`: the live simulation's cost. First the solver alone (its own submissions):
//! per-stage GPU medians per step, ms per step and steps/s. Then frames that step AND render (the step recorded
//! through `Hooks::produce` into the renderer's particle buffer, as `demo --sim` does) at one resolution, with
//! async compute off and/or on: per-queue busy time, the union over both queues and the time the overlap hid
//!. JSON with --json.

use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result};
use serde::Serialize;

use meniscus::device::QueueId;
use meniscus::device::{Buffer, FrameCtx, Gpu};
use meniscus::renderer::{FrameRequest, Hooks, Renderer, Upload};
use meniscus::scene::camera::Camera;
use meniscus::scene::Bounds;
use meniscus::settings::Settings;
use meniscus::sim::stages::STAGE_NAMES;
use meniscus::sim::Simulation;
use meniscus::timing::median;
use meniscus::timing::PassTimes;
use meniscus::view::Environment;
use meniscus::view::View;

/// DFSPH's corrections per step: performed (dispatches with work) and recorded (indirect, empty once converged).
#[derive(Serialize)]
struct CorrectionsPerStep {
    /// Performed, the mean over the measured steps.
    performed: f64,
    /// The most one step performed (either solve's most, summed).
    most: u32,
    /// Recorded, the mean over the measured frames.
    recorded: f64,
}

/// One render + simulation configuration.
#[derive(Serialize)]
struct Combined {
    async_compute: bool,
    /// Median GPU ms per frame of each timed scope (simulation stages summed over the frame's steps).
    passes: Vec<(String, f64)>,
    queue_main_ms: f64,
    queue_compute_ms: f64,
    union_ms: f64,
}

#[derive(Serialize)]
struct SimReport {
    schema: u32,
    device: meniscus::device::DeviceInfo,
    git_commit: String,
    scene: String,
    particles: u32,
    radius: f32,
    /// Steps per frame (the median over the measured frames; `substeps_range` has the fewest and the most).
    substeps: u32,
    substeps_range: [u32; 2],
    /// Whether the step was re-chosen every frame (`[sim] adaptive_step`).
    adaptive_step: bool,
    /// The pressure solver (`pbf`, `dfsph`).
    solver: String,
    /// PBF's iterations per step.
    iterations: u32,
    /// DFSPH: what its solves did over the measured frames (corrections, the errors they stopped at).
    dfsph: Option<meniscus::sim::dfsph::SolverStats>,
    /// DFSPH, per step: the corrections the two solves performed (each a dispatch with work groups), beside the
    /// ones recorded (dispatched indirectly: those after convergence get zero work groups from the device;
    /// `max_solver_iterations` per solve, or with `[sim] adaptive_corrections` the recent most + a spare).
    /// Performed + 2 (each solve's warm start) dispatches do work.
    dfsph_corrections_per_step: Option<CorrectionsPerStep>,
    /// Simulated seconds per second of the solver's GPU time (1 / fps over the median frame's GPU ms).
    simulated_seconds_per_gpu_second: f64,
    dt_ms: f32,
    warmup_frames: u32,
    frames: u32,
    /// Stage → median GPU ms per step.
    stages_ms_per_step: Vec<(String, f64)>,
    /// The spray, foam and bubble stages (`--diffuse`) → median GPU ms per frame (they run once per frame).
    diffuse_stages_ms_per_frame: Vec<(String, f64)>,
    ms_per_step: f64,
    /// Median GPU ms per frame of the solver's stages (without the diffuse ones).
    ms_per_frame: f64,
    steps_per_second: f64,
    width: u32,
    height: u32,
    combined: Vec<Combined>,
}

/// Run it.
#[allow(clippy::too_many_arguments)]
pub fn run(
    gpu: &Arc<Gpu>,
    spec: &str,
    base: &Settings,
    (width, height): (u32, u32),
    warmup: u32,
    frames: u32,
    modes: &[bool],
    json: Option<&Path>,
    with_diffuse: bool,
) -> Result<()> {
    // NAME, NAME:COUNT or a SPlisHSPlasH scene file (whose settings apply to the solver).
    let (name, count) = match spec.split_once(':').filter(|_| !meniscus::sim::scene_file::is_scene_file(spec)) {
        Some((n, c)) => (n, Some(c.parse::<usize>().with_context(|| format!("--sim {spec}: bad particle count"))?)),
        None => (spec, None),
    };
    let (scene, file) = meniscus::sim::scene_file::resolve(name, count)?;
    let mut base = base.clone();
    if let Some(f) = &file {
        f.apply(&mut base.sim);
        for w in &f.warnings {
            eprintln!("warning: {w}");
        }
    }
    let base = &base;
    let frames = frames.max(1);
    // The solver alone.
    let mut sim = Simulation::new(gpu, scene.clone(), base.sim.clone())?;
    sim.time_parts = crate::bench::parts();
    if with_diffuse {
        sim.set_diffuse(Some(&base.diffuse))?;
    }
    let solver = sim.params.solver_summary();
    eprintln!("sim {name}: {} particles, {}, {solver}", sim.count(), sim.step_summary());
    let bar = indicatif::ProgressBar::new((warmup + frames) as u64 * (1 + modes.len() as u64));
    bar.set_style(indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} frames {msg} [{elapsed}]")?);
    for _ in 0..warmup {
        sim.step_frame()?;
        bar.inc(1);
    }
    let mut runs = vec![];
    let mut solves: Option<meniscus::sim::dfsph::SolverStats> = None;
    // The corrections recorded per step (both solves), per measured frame.
    let mut recorded: Vec<f64> = vec![];
    // Each frame's times, the solver's per step (`sim::per_step`), with its step count (`[sim] adaptive_step`
    // changes it per frame).
    for _ in 0..frames {
        let t = sim.step_frame()?;
        let steps = sim.constants.substeps;
        runs.push((meniscus::sim::per_step(t, steps), steps));
        if let Some(st) = sim.solver_stats()? {
            solves.get_or_insert_with(Default::default).merge(&st);
        }
        if let Some(r) = sim.recorded_corrections() {
            recorded.push((r[0] + r[1]) as f64);
        }
        bar.inc(1);
    }
    let (stages, diffuse, ms_per_step, ms_per_frame) = stage_medians(&runs);
    let mut steps: Vec<f64> = runs.iter().map(|(_, n)| *n as f64).collect();
    let (fewest, most) = steps.iter().fold((f64::MAX, 0f64), |(a, b), &n| (a.min(n), b.max(n)));
    let median_steps = median(&mut steps);
    // Rendering and simulating together.
    let mut combined = vec![];
    let mut r = Renderer::new(gpu)?;
    r.parts_mut().background.always_render = true;
    let mut s = base.clone();
    s.radius = scene.radius();
    s.validate()?;
    let (lo, hi) = scene.container;
    let view = View {
        camera: Camera::fit(&Bounds { lo, hi }, width as f32 / height as f32),
        width,
        height,
        env: Environment {
            boxes: scene.wall_boxes(),
            ground_y: lo.y,
            ..Environment::around(&Bounds { lo, hi }, s.radius, &s)
        },
    };
    for &on in modes {
        combined.push(measure_combined(
            gpu,
            &mut r,
            (&scene, base),
            (&view, &s),
            on,
            (warmup, frames),
            with_diffuse,
            &bar,
        )?);
    }
    bar.finish_and_clear();
    let fps = sim.params.fps;
    let report = SimReport {
        schema: 1,
        device: gpu.info.clone(),
        git_commit: env!("MENISCUS_GIT_COMMIT").to_string(),
        scene: name.to_string(),
        particles: sim.count(),
        radius: scene.radius(),
        substeps: median_steps as u32,
        substeps_range: [fewest as u32, most as u32],
        adaptive_step: sim.params.adapts_step(),
        solver: sim.params.solver.name().to_string(),
        iterations: sim.params.iterations,
        dfsph: solves,
        dfsph_corrections_per_step: solves.map(|st| CorrectionsPerStep {
            performed: (st.divergence.corrections + st.density.corrections) as f64 / st.density.steps.max(1) as f64,
            most: st.divergence.max_corrections + st.density.max_corrections,
            recorded: recorded.iter().sum::<f64>() / recorded.len().max(1) as f64,
        }),
        simulated_seconds_per_gpu_second: 1e3 / (fps as f64 * ms_per_frame),
        dt_ms: 1e3 / sim.params.fps / median_steps as f32,
        warmup_frames: warmup,
        frames,
        stages_ms_per_step: stages,
        diffuse_stages_ms_per_frame: diffuse,
        ms_per_step,
        ms_per_frame,
        steps_per_second: 1e3 / ms_per_step,
        width,
        height,
        combined,
    };
    print_stages(&report, gpu, fps, &solver);
    print_combined(gpu, (width, height), &report.combined);
    if let Some(p) = json {
        meniscus::output::write_json(p, &report)?;
        eprintln!("wrote {}", p.display());
    }
    crate::args::finish(gpu)
}

/// The solver's table: its stages per step, the step and the frame, DFSPH's solves, the diffuse stages.
fn print_stages(r: &SimReport, gpu: &Arc<Gpu>, fps: f32, solver: &str) {
    let steps_line = if r.substeps_range[0] < r.substeps_range[1] {
        format!("adaptive: {}–{} steps per frame, median {}", r.substeps_range[0], r.substeps_range[1], r.substeps)
    } else {
        format!("{} steps per frame, Δt {:.2} ms", r.substeps, r.dt_ms)
    };
    println!("## sim {}: {} particles on {} ({steps_line}, {solver})\n", r.scene, r.particles, gpu.info.name);
    if r.stages_ms_per_step.is_empty() {
        println!(
            "GPU times: not measured — a frame opens more timestamp scopes than the {} one frame can time\n",
            meniscus::timing::MAX_SCOPES
        );
    }
    println!("| stage | ms per step (median of {} frames) |\n|---|---|", r.frames);
    for (n, ms) in &r.stages_ms_per_step {
        println!("| {n} | {ms:.3} |");
    }
    println!("| **step** | **{:.3}** ({:.1} steps/s) |", r.ms_per_step, r.steps_per_second);
    println!(
        "| **frame** ({} s simulated) | **{:.3}** ({:.2} s per simulated second) |\n",
        1.0 / fps,
        r.ms_per_frame,
        r.ms_per_frame * fps as f64 * 1e-3
    );
    println!("{:.3} simulated seconds per second of GPU time\n", r.simulated_seconds_per_gpu_second);
    if let Some(st) = &r.dfsph {
        for (label, s) in st.labelled() {
            println!("DFSPH {label} solve: {}", s.summary());
        }
        if let Some(c) = &r.dfsph_corrections_per_step {
            println!(
                "DFSPH corrections per step: {:.1} performed (most {}; + 2 warm starts: the dispatches with work), \
                 {:.1} recorded (indirect; empty once converged)",
                c.performed, c.most, c.recorded
            );
        }
        println!();
    }
    if !r.diffuse_stages_ms_per_frame.is_empty() {
        println!("| diffuse stage (once per frame) | ms per frame |\n|---|---|");
        for (n, ms) in &r.diffuse_stages_ms_per_frame {
            println!("| {n} | {ms:.3} |");
        }
        println!("| **diffuse** | **{:.3}** |\n", r.diffuse_stages_ms_per_frame.iter().map(|d| d.1).sum::<f64>());
    }
}

/// The solver's stages' medians per step and the diffuse stages' per frame (those that ran, in order), and the
/// step's and the frame's medians (a frame: the steps of a simulated 1/fps s), from each frame's times and
/// step count.
#[allow(clippy::type_complexity)]
fn stage_medians(runs: &[(PassTimes, u32)]) -> (Vec<(String, f64)>, Vec<(String, f64)>, f64, f64) {
    // A solver stage's median per step, a diffuse stage's per frame.
    let median_of = |name: &str| {
        let mut v: Vec<f64> = runs.iter().filter_map(|(t, _)| t.get(name)).collect();
        median(&mut v)
    };
    // The stages that ran (sim_vorticity only with confinement on), in order.
    let stages: Vec<(String, f64)> = STAGE_NAMES
        .iter()
        .chain(meniscus::sim::dfsph::STAGE_NAMES)
        .filter(|n| runs.iter().any(|(t, _)| t.get(n).is_some()))
        .map(|n| (n.to_string(), median_of(n)))
        .collect();
    let diffuse_names = meniscus::sim::diffuse::STAGE_NAMES;
    let diffuse: Vec<(String, f64)> = diffuse_names
        .iter()
        .filter(|n| runs.iter().any(|(t, _)| t.get(n).is_some()))
        .map(|n| (n.to_string(), median_of(n)))
        .collect();
    let step_total = |t: &PassTimes| t.total() - diffuse_names.iter().filter_map(|k| t.get(k)).sum::<f64>();
    let mut totals: Vec<f64> = runs.iter().map(|(t, _)| step_total(t)).collect();
    let ms_per_step = median(&mut totals);
    // Per frame (a simulated 1/fps s): what an adaptive step's cost compares by.
    let mut frame_totals: Vec<f64> = runs.iter().map(|(t, n)| step_total(t) * *n as f64).collect();
    let ms_per_frame = median(&mut frame_totals);
    (stages, diffuse, ms_per_step, ms_per_frame)
}

/// Rendering and simulating together, one async mode: `warmup` + `frames` frames whose particles the
/// simulation writes inside the frame; the passes' and queues' medians.
#[allow(clippy::too_many_arguments)]
fn measure_combined(
    gpu: &Arc<Gpu>,
    r: &mut Renderer,
    (scene, base): (&meniscus::sim::scene::SimScene, &Settings),
    (view, s): (&View, &Settings),
    on: bool,
    (warmup, frames): (u32, u32),
    with_diffuse: bool,
    bar: &indicatif::ProgressBar,
) -> Result<Combined> {
    *r.parts_mut().async_compute = on;
    let mut sim = Simulation::new(gpu, scene.clone(), base.sim.clone())?;
    if with_diffuse {
        sim.set_diffuse(Some(&base.diffuse))?;
    }
    let mut spans_all = vec![];
    for k in 0..warmup + frames {
        r.upload(Upload::Gpu { count: sim.count(), bounds: scene.container, diffuse_slots: sim.diffuse_slots() })?;
        let cell = std::cell::RefCell::new(&mut sim);
        let err = std::cell::RefCell::new(None);
        let step = |ctx: &mut FrameCtx, out: &Buffer| {
            if let Err(e) = cell.borrow_mut().record_frame(ctx, Some(out)) {
                *err.borrow_mut() = Some(e);
            }
        };
        let hooks = Hooks { produce: Some(&step), ..Default::default() };
        let sub = r.submit(FrameRequest::new(view, s).hooks(hooks).time_parts(crate::bench::parts()))?;
        let spans = r.spans(sub)?;
        if let Some(e) = err.into_inner() {
            return Err(e.into());
        }
        if k >= warmup {
            spans_all.push(spans);
        }
        bar.inc(1);
    }
    let mut names: Vec<String> = vec![];
    for sp in spans_all.iter().flatten() {
        if !names.contains(&sp.name) {
            names.push(sp.name.clone());
        }
    }
    let passes = names
        .iter()
        .map(|n| {
            let mut v: Vec<f64> = spans_all
                .iter()
                .map(|f| f.iter().filter(|x| &x.name == n).map(|x| (x.end_ns - x.begin_ns) * 1e-6).sum())
                .collect();
            (n.clone(), median(&mut v))
        })
        .collect();
    let busy = |q: QueueId| {
        let mut v: Vec<f64> = spans_all
            .iter()
            .map(|f| f.iter().filter(|x| x.queue == q).map(|x| (x.end_ns - x.begin_ns) * 1e-6).sum())
            .collect();
        median(&mut v)
    };
    let mut unions: Vec<f64> = spans_all
        .iter()
        .map(|f| {
            let a = f.iter().map(|x| x.begin_ns).fold(f64::INFINITY, f64::min);
            let b = f.iter().map(|x| x.end_ns).fold(f64::NEG_INFINITY, f64::max);
            if f.is_empty() {
                0.0
            } else {
                (b - a) * 1e-6
            }
        })
        .collect();
    Ok(Combined {
        async_compute: on,
        passes,
        queue_main_ms: busy(QueueId::Main),
        queue_compute_ms: busy(QueueId::Compute),
        union_ms: median(&mut unions),
    })
}

/// The render + simulate table, and what the async queue hid.
fn print_combined(gpu: &Arc<Gpu>, (width, height): (u32, u32), combined: &[Combined]) {
    println!("Render + simulate one frame at {width}×{height} (GPU ms per frame, medians):\n");
    println!("| async | main queue | compute queue | union |\n|---|---|---|---|");
    for cb in combined {
        println!(
            "| {} | {:.2} | {:.2} | {:.2} |",
            if cb.async_compute { "on" } else { "off" },
            cb.queue_main_ms.abs(),
            cb.queue_compute_ms.abs(),
            cb.union_ms
        );
    }
    if let (Some(off), Some(on)) =
        (combined.iter().find(|c| !c.async_compute), combined.iter().find(|c| c.async_compute))
    {
        println!(
            "\nhidden by the async queue: {:.2} ms per frame (queues: {})",
            off.union_ms - on.union_ms,
            gpu.queues.describe()
        );
    }
}
