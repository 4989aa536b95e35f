//! `meniscus sim`: run the live solver (`meniscus::sim`, Position Based Fluids on the GPU) headless on a
//! built-in scene and write a particle cache — position, velocity, density and id per particle, as `.bgeo`
//! (what SPlisHSPlasH writes) or `.vtk` — that `meniscus render`, `meniscus info` and splashsurf read.
//! File n holds the state at t = (n − 1)/fps, like the shared sequences.

use anyhow::{bail, Context, Result};
use clap::Args;

use meniscus::sim::scene::SimScene;
use meniscus::sim::Simulation;

use crate::args::{finish, GpuArgs, SettingsArgs};

/// `meniscus sim`.
#[derive(Args, Clone, Debug)]
#[command(after_help = "Scenes: dambreak (the shared SPlisHSPlasH set-up), drop, waterfall, pool, or a SPlisHSPlasH \
scene.json.\n\
Example: meniscus sim dambreak --frames 51 --export 'out/f_{}.bgeo' && meniscus render 'out/f_{}.bgeo' --out frames/")]
pub struct SimArgs {
    /// The scene: dambreak, drop, waterfall or pool; `validate` (the dam break against Martin & Moyce 1952 and
    /// Koshizuka & Oka 1996: the surge front per measured point; --particles sets the size, default 12,000); or
    /// a SPlisHSPlasH scene file (path/scene.json: its
    /// particle radius, fluid blocks and models, container, colliders, gravity, frame rate, stopAt and
    /// viscosity; what it says that this solver does not do is named in one warning per key).
    pub scene: String,
    /// Particles (the spacing follows from the water's volume; default: the scene's). Not for a scene file,
    /// whose particleRadius sets the spacing.
    #[arg(long)]
    pub particles: Option<usize>,
    /// Cache files to write (file 1 is the initial state). Default: a scene file's stopAt × fps + 1, else 50.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub frames: Option<u32>,
    /// Frames per simulated second.
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true)]
    pub fps: Option<f32>,
    /// Steps per frame (0: from the CFL bound, at most 5 ms).
    #[arg(long)]
    pub substeps: Option<u32>,
    /// Re-choose the step every frame from the largest speed of the frame before (the CFL bound `[sim] cfl` ×
    /// spacing / speed, at most `[sim] max_dt`; SPlisHSPlasH's cflMethod 1), instead of once from the free-fall
    /// speed of the scene's height; also `[sim] adaptive_step`.
    #[arg(long)]
    pub adaptive_step: bool,
    /// Solver iterations per step (PBF).
    #[arg(long)]
    pub iterations: Option<u32>,
    /// The pressure solver: pbf (Position Based Fluids, the default) or dfsph (Divergence-free SPH, iterated to
    /// `[sim] max_density_error` and `max_divergence_error`); also `[sim] solver` in a settings file.
    #[arg(long, value_parser = crate::args::named::<meniscus::sim::params::Solver>())]
    pub solver: Option<meniscus::sim::params::Solver>,
    /// A closed triangle mesh (OBJ, world coordinates) the water cannot enter; water that starts inside it is
    /// removed. The export's scene.json lists it, so `render` of the export draws it.
    #[arg(long, value_name = "FILE.obj")]
    pub collider: Option<std::path::PathBuf>,
    /// Output pattern: {} is the frame number (1, 2, …); .bgeo or .vtk. Without it nothing is written (a dry run
    /// that reports the times).
    #[arg(long)]
    pub export: Option<String>,
    /// Also generate the water's spray, foam and bubbles as it runs (`meniscus::diffuse`'s model as stages of
    /// the simulation on the GPU, timed with the others; `[diffuse]` in a settings file) and write them here: {}
    /// is the frame number; .bgeo or .vtk with position, velocity, lifetime, age, source, type (0 foam, 1 spray,
    /// 2 bubbles) and id.
    #[arg(long, alias = "foam", value_name = "PATTERN")]
    pub diffuse: Option<String>,
    /// Replace files of --export and --diffuse that exist already (without it, a run whose outputs exist is
    /// refused: a sequence write is a new cache, and the files there belong to another run).
    #[arg(long)]
    pub overwrite: bool,
    /// Settings (the `[sim]` section holds the solver's constants).
    #[command(flatten)]
    pub settings: SettingsArgs,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

impl SimArgs {
    /// `--fps`, `--substeps` and `--iterations` over `p`, then `p` validated.
    fn solver_flags(&self, p: &mut meniscus::sim::params::Params) -> Result<()> {
        if let Some(f) = self.fps {
            p.fps = f;
        }
        if let Some(s) = self.substeps {
            p.substeps = s;
        }
        if let Some(i) = self.iterations {
            p.iterations = i;
        }
        if self.adaptive_step {
            p.adaptive_step = true;
        }
        if let Some(solver) = self.solver {
            p.solver = solver;
        }
        if self.iterations.is_some() && p.solver == meniscus::sim::params::Solver::Dfsph {
            bail!(
                "--iterations is PBF's fixed iteration count; DFSPH iterates each solve to its error bound (set its \
                 limit with [sim] max_solver_iterations, its bounds with max_density_error and max_divergence_error)"
            );
        }
        Ok(p.validate()?)
    }

    /// Flags that set how the water is drawn (`--filter`, `--surface`, … and a `--preset` other than the default)
    /// are refused: `sim` writes particles and draws nothing.
    fn refuse_drawing_flags(&self) -> Result<()> {
        let mut drawing = self.settings.drawing_flags();
        if self.settings.preset != "default" {
            drawing.push("--preset");
        }
        if !drawing.is_empty() {
            bail!(
                "{} set how the water is drawn; `sim` writes particles and draws nothing (pass them to `render` of \
                 the export, or to `demo --sim`; the solver's settings are [sim] in --settings)",
                drawing.join(", ")
            );
        }
        Ok(())
    }

    /// The scene, the solver settings and the frame count the flags ask for.
    pub fn resolve(&self) -> Result<(SimScene, meniscus::sim::params::Params, u32)> {
        self.refuse_drawing_flags()?;
        let (mut scene, file) = meniscus::sim::scene_file::resolve(&self.scene, self.particles)?;
        for w in file.iter().flat_map(|f| &f.warnings) {
            eprintln!("warning: {w}");
        }
        if let Some(path) = &self.collider {
            let mesh = meniscus::scene::geometry::Geometry::load_obj(path)?;
            let removed = scene.add_mesh_collider(&mesh).with_context(|| format!("--collider {}", path.display()))?;
            eprintln!("{}", collider_line(path, &mesh, &scene, removed));
        }
        let mut p = self.settings.resolve()?.sim;
        if let Some(f) = &file {
            f.apply(&mut p);
        }
        self.solver_flags(&mut p)?;
        let frames = self.frames.or(file.and_then(|f| f.frames)).unwrap_or(50);
        Ok((scene, p, frames))
    }
}

/// `meniscus sim validate`: the dam break against Martin & Moyce (1952) and Koshizuka & Oka (1996)
/// (`meniscus::sim::validate`): the surge front Z/L per measured point up to T = 3, with the error.
fn validate(a: &SimArgs) -> Result<()> {
    if a.export.is_some() || a.diffuse.is_some() || a.collider.is_some() || a.frames.is_some() {
        bail!(
            "sim validate writes no files, takes no collider and runs to T = 3.2: drop --export, --diffuse, --collider \
             and --frames"
        );
    }
    a.refuse_drawing_flags()?;
    let particles = a.particles.unwrap_or(12_000);
    if !(100..=20_000_000).contains(&particles) {
        bail!("sim validate --particles {particles}: between 100 and 20,000,000");
    }
    let scene = meniscus::sim::validate::column_for(particles);
    let mut p = a.settings.resolve()?.sim;
    p.fps = 200.0;
    a.solver_flags(&mut p)?;
    let gpu = a.gpu.open()?;
    let mut sim = Simulation::new(&gpu, scene, p)?;
    eprintln!(
        "sim validate: a column {:.3} m wide, 2× high, {} particles (spacing {:.4} m, 6 deep, free-slip walls), \
         {} steps of {:.2} ms per frame at {} fps, {}, on {}",
        meniscus::sim::validate::L,
        sim.count(),
        sim.scene.spacing,
        sim.constants.substeps,
        sim.constants.dt * 1e3,
        sim.params.fps,
        sim.params.solver_summary(),
        gpu.info.name
    );
    let series = meniscus::sim::validate::front(&mut sim, 3.2)?;
    use meniscus::sim::validate::{judge, worst, GATE_OPENING};
    let points = judge(&series, 3.0);
    println!("| measured | T | Z/L measured | Z/L simulated | error (bound) | at T − ΔT | error (bound) | |");
    println!("|---|---:|---:|---:|---:|---:|---:|---|");
    for p in &points {
        println!(
            "| {} | {:.3} | {:.3} | {:.3} | {:+.1} % (±{:.0} %) | {:.3} (ΔT {:.2}) | {:+.1} % (±{:.0} %) | {} |",
            p.source,
            p.t,
            p.z,
            p.simulated.0,
            100.0 * p.simulated.1,
            100.0 * p.bounds.as_measured,
            p.shifted.1,
            p.shifted.0,
            100.0 * p.shifted.2,
            100.0 * p.bounds.shifted,
            if p.passes() { "ok" } else { "OUTSIDE" }
        );
    }
    println!(
        "\nT = t·√(2g/L), L = {} m; ΔT: each experiment's gate opening, fitted once and frozen.",
        meniscus::sim::validate::L
    );
    for (name, d) in GATE_OPENING {
        let (raw, shifted) = worst(&points, Some(name));
        println!("{name}: largest error {:.1} % as measured, {:.1} % at T − {d:.2}", 100.0 * raw, 100.0 * shifted);
    }
    let outside = points.iter().filter(|p| !p.passes()).count();
    finish(&gpu)?;
    if outside > 0 {
        bail!("sim validate: {outside} of {} measured points outside their bounds (the table above)", points.len());
    }
    Ok(())
}

/// Run it.
pub fn run(a: &SimArgs) -> Result<()> {
    if a.scene == "validate" {
        return validate(a);
    }
    let (scene, params, frames) = a.resolve()?;
    check_outputs(a, frames)?;
    if frames == 0 {
        bail!("--frames must be at least 1");
    }
    let diffuse = a.settings.resolve()?.diffuse;
    let gpu = a.gpu.open()?;
    let mut sim = Simulation::new(&gpu, scene, params)?;
    let solver = sim.params.solver_summary();
    eprintln!(
        "sim: {} with {} particles (radius {:.5} m, capacity {}), {} at {} fps, {solver}, on {}",
        sim.scene.name,
        sim.count(),
        sim.radius(),
        sim.capacity(),
        sim.step_summary(),
        sim.params.fps,
        gpu.info.name
    );
    if a.diffuse.is_some() {
        sim.set_diffuse(Some(&diffuse))?;
    }
    let mut last_counts = [0usize; 3];
    let mut write = |sim: &Simulation, n: u32| -> Result<()> {
        if let Some(e) = &a.export {
            let path = std::path::PathBuf::from(e.replace("{}", &n.to_string()));
            meniscus::scene::write_particles(&path, &sim.read()?)?;
        }
        if let Some(f) = &a.diffuse {
            let ps = sim.read_diffuse()?;
            last_counts = [0; 3];
            for p in &ps {
                last_counts[p.kind as usize] += 1;
            }
            let path = std::path::PathBuf::from(f.replace("{}", &n.to_string()));
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).with_context(|| format!("--diffuse: cannot create {}", dir.display()))?;
            }
            meniscus::scene::write_particles(&path, &meniscus::diffuse::io::to_particles(&ps))?;
        }
        Ok(())
    };
    write(&sim, 1)?;
    // The scene's spheres for the scene.json beside the cache: the still ones, and the moving body's centre at
    // every exported frame (the last track).
    let mut tracks = sim.scene.sphere_tracks();
    let moving = sim.scene.body.is_some();
    if let Some(e) = &a.export {
        write_scene_json(a, &sim, e, &tracks[..tracks.len() - moving as usize])?;
    }
    let bar = crate::args::progress(frames as u64 - 1, "frames");
    let mut runs = vec![];
    let mut solves: Option<meniscus::sim::dfsph::SolverStats> = None;
    // The solver's stages are kept per step (`sim::per_step`), the diffuse stages, which run once, per frame.
    let diffuse = |k: &str| meniscus::sim::diffuse::STAGE_NAMES.contains(&k);
    let (mut fewest, mut most, mut fastest) = (u32::MAX, 0u32, 0f32);
    for n in 2..=frames {
        let t = sim.step_frame()?;
        if moving && a.export.is_some() {
            if let (Some(b), Some(t)) = (sim.body_state()?, tracks.last_mut()) {
                t.centres.push(b.centre);
            }
        }
        let steps = sim.constants.substeps;
        (fewest, most) = (fewest.min(steps), most.max(steps));
        fastest = fastest.max(sim.last_speed().unwrap_or(0.0));
        let t = meniscus::sim::per_step(t, steps);
        let mut msg =
            format!("{steps} steps, {:.1} ms/step", t.0.iter().filter(|(k, _)| !diffuse(k)).map(|e| e.1).sum::<f64>());
        if let Some(st) = sim.solver_stats()? {
            msg += &format!(
                ", density error {:.3} %, {:.1} corrections/step",
                100.0 * st.density.max_error,
                st.density.corrections as f64 / st.density.steps.max(1) as f64
            );
            solves.get_or_insert_with(Default::default).merge(&st);
        }
        bar.set_message(msg);
        runs.push(t);
        write(&sim, n)?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    // Per step: the corrections each solve took, the average error it stopped at.
    for (name, s) in solves.iter().flat_map(|st| st.labelled()) {
        eprintln!("DFSPH {name} solve: {}", s.summary());
    }
    if sim.params.adapts_step() {
        eprintln!(
            "adaptive step: {fewest}–{most} steps per frame (the largest speed {fastest:.2} m/s, CFL {} × spacing / \
             speed, at most {} ms)",
            sim.params.cfl,
            sim.params.max_dt * 1e3
        );
    }
    report_times(&runs, &sim);
    if let Some(b) = sim.body_state()? {
        eprintln!(
            "dynamic sphere: centre ({:.3}, {:.3}, {:.3}) m, velocity ({:.3}, {:.3}, {:.3}) m/s at the end",
            b.centre.x, b.centre.y, b.centre.z, b.velocity.x, b.velocity.y, b.velocity.z
        );
    }
    if let Some((lo, hi)) = sim.scene.emitter.and_then(|e| e.reuse) {
        eprintln!(
            "emitter: {} particles at the end of a room of {}, {} recycled after leaving the box {lo}–{hi}",
            sim.count(),
            sim.capacity(),
            sim.reused()
        );
    }
    let over = sim.neighbour_overflow()?;
    if over > 0 {
        eprintln!(
            "warning: {over} particle-steps had more than {} neighbours (the extra ones were ignored)",
            meniscus::shader_constants::MAX_NEIGHBOURS
        );
    }
    if let Some(e) = &a.export {
        if moving {
            // Again, now with the body's track (a run stopped early leaves the scene.json without it).
            write_scene_json(a, &sim, e, &tracks)?;
        }
        eprintln!("wrote {} files: {e}", frames);
    }
    if let Some(f) = &a.diffuse {
        let [foam, spray, bubbles] = last_counts;
        eprintln!(
            "wrote {} files of diffuse particles: {f} (the last frame: foam {foam}, spray {spray}, bubbles {bubbles}; \
             {} pool slots)",
            frames,
            sim.diffuse_slots()
        );
    }
    finish(&gpu)
}

/// The log line for a mesh collider (`sim --collider`, `demo --sim --background-obj`).
pub fn collider_line(
    path: &std::path::Path,
    mesh: &meniscus::scene::geometry::Geometry,
    scene: &SimScene,
    removed: usize,
) -> String {
    let lattice = scene.mesh_collider.as_ref().map_or(String::new(), |m| m.describe());
    format!(
        "mesh collider {}: {} triangles, {lattice}; {removed} particles that started inside it removed",
        path.display(),
        mesh.triangles.len()
    )
}

/// `--export` and `--diffuse` may be written: patterns with {}, names of a particle kind, not over inputs or
/// (without --overwrite) existing files, the diffuse files not joining the export's sequence.
fn check_outputs(a: &SimArgs, frames: u32) -> Result<()> {
    if let Some(e) = &a.export {
        let kind = crate::args::out_kind("--export", std::path::Path::new(e), &meniscus::output::PARTICLE_KINDS)?;
        if !e.contains("{}") {
            bail!("--export {e:?}: the pattern needs {{}} where the frame number goes, e.g. 'out/f_{{}}.bgeo'");
        }
        let paths: Vec<std::path::PathBuf> =
            (1..=frames.max(1)).map(|n| std::path::PathBuf::from(e.replace("{}", &n.to_string()))).collect();
        for p in &paths {
            crate::args::check_out("--export", p, kind)?;
        }
        crate::args::refuse_existing("--export", &paths, a.overwrite)?;
    }
    if let Some(f) = &a.diffuse {
        if !f.contains("{}") {
            bail!("--diffuse {f:?}: the pattern needs {{}} where the frame number goes, e.g. 'foam/f_{{}}.bgeo'");
        }
        let kind = crate::args::out_kind("--diffuse", std::path::Path::new(f), &meniscus::output::PARTICLE_KINDS)?;
        let paths: Vec<std::path::PathBuf> =
            (1..=frames.max(1)).map(|n| std::path::PathBuf::from(f.replace("{}", &n.to_string()))).collect();
        for path in &paths {
            crate::args::check_out("--diffuse", path, kind)?;
            if a.export.as_ref().is_some_and(|e| meniscus::scene::sequence::would_join(e, path)) {
                bail!("--diffuse {f}: {} would become a frame of the --export sequence", path.display());
            }
        }
        crate::args::refuse_existing("--diffuse", &paths, a.overwrite)?;
    }
    Ok(())
}

/// The container beside the cache `e` (SPlisHSPlasH's scene.json), so `render` draws the tank and needs no
/// --radius, and the moving body's `tracks`; a scene.json that meniscus did not write is left alone.
fn write_scene_json(
    a: &SimArgs,
    sim: &Simulation,
    e: &str,
    tracks: &[meniscus::scene::splishsplash::BodyTrack],
) -> Result<()> {
    let dir = std::path::Path::new(e).parent().unwrap_or(std::path::Path::new(""));
    let path = dir.join("scene.json");
    let ours = !path.exists() || meniscus::scene::splishsplash::SceneJson::is_ours(&path);
    if ours {
        let s = &sim.scene;
        // The collider mesh by its absolute path, so `render` of the export draws it from any folder.
        let meshes: Vec<std::path::PathBuf> =
            a.collider.iter().map(|c| std::fs::canonicalize(c).unwrap_or_else(|_| c.clone())).collect();
        meniscus::scene::splishsplash::write_scene_json(
            &path,
            s.radius(),
            s.container,
            &s.box_colliders(),
            &meshes,
            tracks,
        )?;
    } else {
        eprintln!("warning: {} exists and was not written by meniscus: left as it is", path.display());
    }
    Ok(())
}

/// The step's median GPU time per stage (and the diffuse stages' per frame), or why there is none.
fn report_times(runs: &[meniscus::timing::PassTimes], sim: &Simulation) {
    // The solver's stages are kept per step (`sim::per_step`), the diffuse stages, which run once, per frame.
    let diffuse = |k: &str| meniscus::sim::diffuse::STAGE_NAMES.contains(&k);
    let med = meniscus::timing::median_times(runs);
    if !runs.is_empty() && med.0.is_empty() {
        eprintln!(
            "GPU times: not measured — a frame opens more timestamp scopes than the {} one frame can time (with \
             with parts timed DFSPH times every correction it may need; fewer [sim] max_solver_iterations or substeps \
             fit)",
            meniscus::timing::MAX_SCOPES
        );
    } else if !runs.is_empty() {
        let (step, frame): (Vec<_>, Vec<_>) = med.0.iter().partition(|(k, _)| !diffuse(k));
        let per_step = step.iter().map(|(_, v)| v).sum::<f64>();
        eprintln!(
            "{} frames, {} particles at the end; median GPU time per step {:.2} ms ({:.1} steps/s): {}",
            runs.len(),
            sim.count(),
            per_step,
            1e3 / per_step,
            step.iter().map(|(k, v)| format!("{k} {v:.2}")).collect::<Vec<_>>().join(", ")
        );
        if !frame.is_empty() {
            eprintln!(
                "diffuse stages, median GPU ms per frame: {:.2} ({})",
                frame.iter().map(|(_, v)| v).sum::<f64>(),
                frame.iter().map(|(k, v)| format!("{k} {v:.2}")).collect::<Vec<_>>().join(", ")
            );
        }
    }
}
