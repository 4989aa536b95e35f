//! `meniscus bench`: scenes × resolutions under one settings preset, headless. Warm-up frames, then N measured
//! frames; per pass the GPU median, p95 and min (timestamps), the GPU frame total, the CPU frame time
//! (submit → fence), and the bytes of every image and buffer. Prints a markdown table shaped like Moritz
//! tables 4.1–4.4 and returns a JSON-serialisable report (schema: benches/README.md). File workloads start
//! from the same [`Job`] as `render` and `demo`.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;

use meniscus::named::{Filter, SplatMode};
use meniscus::scene::procedural;

use crate::args::{finish, GpuArgs, LoadArgs, SceneArgs};
pub use crate::bench_measure::{measure, measure_interleaved, Plan};
pub use crate::bench_report::*;
use crate::job::{Job, Select};
use meniscus::device::Gpu;
use meniscus::renderer::Renderer;
use meniscus::scene::camera::Camera;
use meniscus::scene::Particles;
use meniscus::settings::Settings;

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
    /// A sequence's frame rate (the flicker's warping error moves the surface by velocity × frame time).
    pub fps: f32,
}

/// `meniscus bench`.
#[derive(Args, Clone, Debug)]
pub struct BenchArgs {
    /// Settings preset: default, fast, moritz (curvature flow ≤ 60 iterations, SSR stride 8 / 100 steps /
    /// 4 refinements, fluid ≈ ¼ of the screen, Moritz's five workloads at 1920×1080 and 960×540 unless
    /// --scenes/--resolutions say otherwise), table43 (the moritz settings with the five SSR settings of
    /// Moritz table 4.3, wave scene, 1920×1080).
    #[arg(long, default_value = "default")]
    pub preset: String,
    /// Comma-separated workloads: wave, crown1 (38,146), crown2 (157,944), waterfall (819,417), worst (a block
    /// filling the screen), any built-in scene as NAME or NAME:COUNT, a particle file, or a sequence (a pattern
    /// with {}, a folder or a glob): every rendered frame then takes the sequence's next frame, so the work
    /// done when particles change (grid, iso weights, smoothed field) is in every measured frame.
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Sequence workloads: frames FIRST..LAST[:STEP] (inclusive, by the numbers in the file names) instead of
    /// the sequence's first warm-up + measured frames; the radius and camera are fitted to its first frame as
    /// `render` fits them.
    #[arg(long = "sequence-frames", value_name = "RANGE")]
    pub sequence_frames: Option<String>,
    /// Sequence workloads: generate their spray, foam and bubbles (in time order from the sequence's first
    /// frame, before timing) and draw them, so the `diffuse` pass is measured. With --sim: the simulation's
    /// diffuse stages run (on the GPU, timed per frame) and the frames draw their particles.
    #[arg(long, alias = "foam")]
    pub diffuse: bool,
    /// Comma-separated WIDTHxHEIGHT list.
    #[arg(long, value_delimiter = ',')]
    pub resolutions: Vec<String>,
    /// Frames rendered before measuring (lavapipe compiles pipelines at first use).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=10_000))]
    pub warmup: u32,
    /// Measured frames.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    pub frames: u32,
    /// Then render as many frames again with the renderer's frames in flight (the next frame's upload and
    /// recording overlap the GPU's work on the one before, as `render` runs a sequence) and report their wall
    /// time per frame beside the CPU frame (JSON `cpu_frame_in_flight`): what a sequence or a live view
    /// sustains, the slower of the host and the GPU.
    #[arg(long = "in-flight")]
    pub in_flight: bool,
    /// Sequence workloads: then render the sequence's frames once more, read each back and report its flicker
    /// (JSON `flicker`, the measure of `meniscus quality` over a sequence: colour and normal change between
    /// consecutive frames where the water stays, and the normals' warping error with the files' velocities).
    #[arg(long)]
    pub flicker: bool,
    /// Also time each part of a pass on its own (its dispatches: `noise/scan`, `iso/rest`, DFSPH's every recorded
    /// correction, …), in the table and the JSON beside the pass. Every part's timestamps drain the GPU's
    /// pipeline, so the passes themselves read slower: measure parts apart from frame times.
    #[arg(long)]
    pub parts: bool,
    /// Particle radius for file workloads (default: estimated from the spacing).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// Camera for file workloads, EYE:TARGET[:FOVY] (default: fitted).
    #[arg(long, allow_hyphen_values = true)]
    pub camera: Option<String>,
    /// Also measure design variants on the first workload and resolution (same run, so ratios compare):
    /// each splat mode (compute, quads/points with gl_FragDepth, conservative depth, MIN blending), each
    /// smoothing filter, curvature flow 1 vs 4 iterations per dispatch.
    #[arg(long)]
    pub variants: bool,
    /// Write the JSON report here (schema: benches/README.md).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Reuse the static background while the camera stays (as `render` of a sequence does) instead of
    /// re-rendering it every measured frame.
    #[arg(long)]
    pub cache_background: bool,
    /// Split each frame over the main and the async compute queue (background and thickness beside the fluid
    /// passes): off, on, or both (every configuration measured twice in one run, hidden time reported).
    #[arg(long = "async", value_parser = ["off", "on", "both"], default_value = "off")]
    pub async_mode: String,
    /// Write the markdown table here too.
    #[arg(long)]
    pub markdown: Option<PathBuf>,
    /// Scaling sweeps instead of the scene list: `particles` (wave scene, 10k → 4M particles at fixed screen
    /// coverage, first resolution), `pixels` (wave scene, 480p → 4K), or `both`.
    #[arg(long, value_parser = ["particles", "pixels", "both"])]
    pub sweep: Option<String>,
    /// With --sweep: particle counts (comma-separated) instead of 10k, 40k, 160k, 640k, 2.56M, 4M.
    #[arg(long, value_delimiter = ',')]
    pub sweep_particles: Vec<usize>,
    /// With --sweep: write the chart (per-pass ms against particles and pixels) as PNG here. With --mesh: the
    /// scaling chart (wall time against threads per cube size, splashsurf and ideal scaling beside it).
    #[arg(long)]
    pub chart: Option<PathBuf>,
    /// TOML settings over the preset.
    #[arg(long)]
    pub settings: Option<PathBuf>,
    /// Fluid depth over the preset and settings: iso, spheres or mesh (`--surface mesh` with `[mesh] extraction
    /// = "gpu"`, the default on a GPU, measures the live mesh: its `mc_*` stages and draw, and its work).
    #[arg(long, value_parser = crate::args::named::<meniscus::settings::Surface>())]
    pub surface: Option<meniscus::settings::Surface>,
    /// Also measure these presets (comma-separated: default, fast, quality, moritz) on every workload and
    /// resolution, in the same run with their frames interleaved with the main preset's (one renderer each, so
    /// all see the same host), and print each one's frame time as a ratio of the main preset's. PRESET@FILE
    /// takes FILE's settings over that preset instead of --settings (a variant measured against the main
    /// preset, e.g. quality@half-steps.toml). (With --async both, they run one after another.)
    #[arg(long, value_delimiter = ',')]
    pub also_presets: Vec<String>,
    /// Frame the built-in workloads so the fluid covers about a quarter of the screen (Moritz's framing; implied
    /// by --preset moritz and table43).
    #[arg(long)]
    pub quarter_framing: bool,
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
    pub load: LoadArgs,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

impl BenchArgs {
    /// The frames each measurement renders.
    fn plan(&self) -> Plan {
        Plan { warmup: self.warmup, frames: self.frames, in_flight: self.in_flight, flicker: self.flicker }
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
                        fps: job.frame_rate(),
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
            fps: meniscus::motion::DEFAULT_FPS,
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

/// Run the benchmark.
pub fn run(a: &BenchArgs) -> Result<()> {
    note_start_rss();
    let env_parts = std::env::var("MENISCUS_PARTS").is_ok_and(|v| v == "1");
    if env_parts {
        eprintln!("warning: MENISCUS_PARTS=1 is deprecated: it is `bench --parts` now");
    }
    PARTS.store(a.parts || env_parts, std::sync::atomic::Ordering::Relaxed);
    check_args(a)?;
    if let Some(file) = &a.mesh {
        return run_mesh(a, file);
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
    if let Some(m) = a.surface {
        base.set_surface(m);
    }
    let (scenes, resolutions) = workloads(a, table43, moritz)?;
    let gpu = a.gpu.open()?;
    eprintln!("device: {} ({}), Vulkan {}", gpu.info.name, gpu.info.driver, gpu.info.api_version);
    if let Some(sim) = &a.sim {
        let modes = async_modes(&a.async_mode);
        let (size, json) = (resolutions[0], a.json.as_deref());
        return crate::bench_sim::run(&gpu, sim, &base, size, a.warmup, a.frames, &modes, json, a.diffuse);
    }
    let mut r = Renderer::new(&gpu)?;
    r.parts_mut().background.always_render = !a.cache_background;
    let also = also_presets(a)?;
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
                    x.parts_mut().background.always_render = !a.cache_background;
                    also_renderers.push(x);
                }
                *r.parts_mut().async_compute = a.async_mode == "on";
                for x in &mut also_renderers {
                    *x.parts_mut().async_compute = r.state().async_compute();
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
                    *r.parts_mut().async_compute = split;
                    let label = if a.async_mode == "both" {
                        format!("{} async {}", a.preset, if split { "on" } else { "off" })
                    } else {
                        a.preset.clone()
                    };
                    entries.push(measure(&mut r, &w, (wd, ht), &base, &label, a.plan())?);
                }
                *r.parts_mut().async_compute = a.async_mode == "on";
                for (label, vs) in &also {
                    bar.set_message(format!("{} {}×{} preset {label}", w.label, wd, ht));
                    entries.push(measure(&mut r, &w, (wd, ht), vs, label, a.plan())?);
                }
            }
            bar.inc(1);
            if a.variants && k == 0 && j == 0 {
                variants = variant_settings(&base, &r);
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
    print_ratios(a, &entries, &also);
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

/// The scenes and resolutions to measure: the flags', else the preset's (`moritz`: five scenes at 1080p and
/// 540p; `table43`: the wave at 1080p), else the wave at 960×540.
#[allow(clippy::type_complexity)]
fn workloads(a: &BenchArgs, table43: bool, moritz: bool) -> Result<(Vec<String>, Vec<(u32, u32)>)> {
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
    Ok((scenes, resolutions))
}

/// `--also-presets`: each PRESET, or PRESET@FILE (that preset with FILE's settings instead of --settings).
fn also_presets(a: &BenchArgs) -> Result<Vec<(String, Settings)>> {
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
    Ok(also)
}

/// The flags `bench` refuses before any work: reports' paths, and the flags of one kind of run given to another.
fn check_args(a: &BenchArgs) -> Result<()> {
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
    Ok(())
}

/// `bench --mesh FILE`: the mesh extraction's benchmark (the frame flags refused, not ignored).
fn run_mesh(a: &BenchArgs, file: &std::path::Path) -> Result<()> {
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
    crate::bench_mesh::run(file, &a.load, &opts, a.json.as_deref(), a.markdown.as_deref(), a.chart.as_deref())
}

/// `--variants`: the filters, the curvature flow's iterations per dispatch, no smoothing and every splat mode the
/// device supports, each a variant of `base`.
fn variant_settings(base: &Settings, r: &Renderer) -> Vec<(String, Settings)> {
    let mut variants = vec![];
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
        if r.state().supports_splat(m) {
            variants.push((format!("splat {}", m.name()), base.with(|s| s.splat.mode = m)));
        }
    }
    variants
}

/// The ratios the run's table implies: the curvature flow's and the splat modes' (`--variants`), and each
/// `--also-presets` preset's frame time against the main preset's.
fn print_ratios(a: &BenchArgs, entries: &[Entry], also: &[(String, Settings)]) {
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
                fps: meniscus::motion::DEFAULT_FPS,
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
            fps: meniscus::motion::DEFAULT_FPS,
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
