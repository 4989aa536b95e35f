//! `meniscus sim`: run the live solver (`meniscus::sim`, Position Based Fluids on the GPU) headless on a
//! built-in scene and write a particle cache — position, velocity, density and id per particle, as `.bgeo`
//! (what SPlisHSPlasH writes) or `.vtk` — that `meniscus render`, `meniscus info` and splashsurf read.
//! File n holds the state at t = (n − 1)/fps, like the shared sequences.

use anyhow::{bail, Context, Result};
use clap::Args;

use meniscus::sim::{SimScene, Simulation, SCENES};

use crate::args::{finish, GpuArgs, SettingsArgs};

/// `meniscus sim`.
#[derive(Args, Clone, Debug)]
#[command(after_help = "Scenes: dambreak (the shared SPlisHSPlasH set-up), drop, waterfall, pool.\n\
Example: meniscus sim dambreak --frames 51 --export 'out/f_{}.bgeo' && meniscus render 'out/f_{}.bgeo' --out frames/")]
pub struct SimArgs {
    /// The scene: dambreak, drop, waterfall or pool.
    pub scene: String,
    /// Particles (the spacing follows from the water's volume; default: the scene's).
    #[arg(long)]
    pub particles: Option<usize>,
    /// Cache files to write (file 1 is the initial state).
    #[arg(long, default_value_t = 50)]
    pub frames: u32,
    /// Frames per simulated second.
    #[arg(long, allow_negative_numbers = true)]
    pub fps: Option<f32>,
    /// Steps per frame (0: from the CFL bound, at most 5 ms).
    #[arg(long)]
    pub substeps: Option<u32>,
    /// Solver iterations per step.
    #[arg(long)]
    pub iterations: Option<u32>,
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
    #[arg(long, value_name = "PATTERN")]
    pub foam: Option<String>,
    /// Replace files of --export and --foam that exist already (without it, a run whose outputs exist is
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
    /// The scene and the solver settings the flags ask for.
    pub fn resolve(&self) -> Result<(SimScene, meniscus::sim::Params)> {
        let drawing = self.settings.drawing_flags();
        if !drawing.is_empty() {
            bail!(
                "{} set how the water is drawn; `sim` writes particles and draws nothing (pass them to `render` of \
                 the export, or to `demo --sim`)",
                drawing.join(", ")
            );
        }
        let default = SCENES.iter().find(|s| s.0 == self.scene).map_or(10_000, |s| s.1);
        let mut scene = SimScene::new(&self.scene, self.particles.unwrap_or(default))?;
        if let Some(path) = &self.collider {
            let mesh = meniscus::scene::geometry::Geometry::load_obj(path)?;
            let removed = scene.add_mesh_collider(&mesh).with_context(|| format!("--collider {}", path.display()))?;
            eprintln!("{}", collider_line(path, &mesh, &scene, removed));
        }
        let mut p = self.settings.resolve()?.sim;
        if let Some(f) = self.fps {
            p.fps = f;
        }
        if let Some(s) = self.substeps {
            p.substeps = s;
        }
        if let Some(i) = self.iterations {
            p.iterations = i;
        }
        p.validate()?;
        Ok((scene, p))
    }
}

/// Run it.
pub fn run(a: &SimArgs) -> Result<()> {
    let (scene, params) = a.resolve()?;
    if let Some(e) = &a.export {
        let kind = crate::args::out_kind("--export", std::path::Path::new(e), &meniscus::output::PARTICLE_KINDS)?;
        if !e.contains("{}") {
            bail!("--export {e:?}: the pattern needs {{}} where the frame number goes, e.g. 'out/f_{{}}.bgeo'");
        }
        let paths: Vec<std::path::PathBuf> =
            (1..=a.frames.max(1)).map(|n| std::path::PathBuf::from(e.replace("{}", &n.to_string()))).collect();
        for p in &paths {
            crate::args::check_out("--export", p, kind)?;
        }
        crate::args::refuse_existing("--export", &paths, a.overwrite)?;
    }
    if let Some(f) = &a.foam {
        if !f.contains("{}") {
            bail!("--foam {f:?}: the pattern needs {{}} where the frame number goes, e.g. 'foam/f_{{}}.bgeo'");
        }
        let kind = crate::args::out_kind("--foam", std::path::Path::new(f), &meniscus::output::PARTICLE_KINDS)?;
        let paths: Vec<std::path::PathBuf> =
            (1..=a.frames.max(1)).map(|n| std::path::PathBuf::from(f.replace("{}", &n.to_string()))).collect();
        for path in &paths {
            crate::args::check_out("--foam", path, kind)?;
            if a.export.as_ref().is_some_and(|e| meniscus::scene::sequence::would_join(e, path)) {
                bail!("--foam {f}: {} would become a frame of the --export sequence", path.display());
            }
        }
        crate::args::refuse_existing("--foam", &paths, a.overwrite)?;
    }
    if a.frames == 0 {
        bail!("--frames must be at least 1");
    }
    let diffuse = a.settings.resolve()?.diffuse;
    let gpu = a.gpu.open()?;
    let mut sim = Simulation::new(&gpu, scene, params)?;
    let c = sim.constants;
    eprintln!(
        "sim: {} with {} particles (radius {:.5} m, capacity {}), {} steps of {:.2} ms per frame at {} fps, {} iterations, on {}",
        sim.scene.name,
        sim.count(),
        sim.radius(),
        sim.capacity(),
        c.substeps,
        c.dt * 1e3,
        sim.params.fps,
        sim.params.iterations,
        gpu.info.name
    );
    if a.foam.is_some() {
        sim.set_diffuse(Some(&diffuse))?;
    }
    let mut last_counts = [0usize; 3];
    let mut write = |sim: &Simulation, n: u32| -> Result<()> {
        if let Some(e) = &a.export {
            let path = std::path::PathBuf::from(e.replace("{}", &n.to_string()));
            meniscus::scene::write_particles(&path, &sim.read()?)?;
        }
        if let Some(f) = &a.foam {
            let ps = sim.read_diffuse()?;
            last_counts = [0; 3];
            for p in &ps {
                last_counts[p.kind as usize] += 1;
            }
            let path = std::path::PathBuf::from(f.replace("{}", &n.to_string()));
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).with_context(|| format!("--foam: cannot create {}", dir.display()))?;
            }
            meniscus::scene::write_particles(&path, &meniscus::diffuse::to_particles(&ps))?;
        }
        Ok(())
    };
    write(&sim, 1)?;
    if let Some(e) = &a.export {
        // The container beside the cache (SPlisHSPlasH's scene.json), so `render` draws the tank and needs no
        // --radius; a scene.json that meniscus did not write is left alone.
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
            )?;
        } else {
            eprintln!("warning: {} exists and was not written by meniscus: left as it is", path.display());
        }
    }
    let bar = crate::args::progress(a.frames as u64 - 1, "frames");
    let mut runs = vec![];
    for n in 2..=a.frames {
        let t = sim.step_frame()?;
        bar.set_message(format!("{:.1} ms/step", t.total() / c.substeps as f64));
        runs.push(t);
        write(&sim, n)?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    let med = meniscus::gpu::timer::median_times(&runs);
    if !runs.is_empty() {
        // The solver's stages run every step; the diffuse stages once per frame.
        let diffuse = |k: &str| meniscus::sim::diffuse::STAGE_NAMES.contains(&k);
        let (step, frame): (Vec<_>, Vec<_>) = med.0.iter().partition(|(k, _)| !diffuse(k));
        let per_step = step.iter().map(|(_, v)| v).sum::<f64>() / c.substeps as f64;
        eprintln!(
            "{} frames, {} particles at the end; median GPU time per step {:.2} ms ({:.1} steps/s): {}",
            runs.len(),
            sim.count(),
            per_step,
            1e3 / per_step,
            step.iter().map(|(k, v)| format!("{k} {:.2}", v / c.substeps as f64)).collect::<Vec<_>>().join(", ")
        );
        if !frame.is_empty() {
            eprintln!(
                "diffuse stages, median GPU ms per frame: {:.2} ({})",
                frame.iter().map(|(_, v)| v).sum::<f64>(),
                frame.iter().map(|(k, v)| format!("{k} {v:.2}")).collect::<Vec<_>>().join(", ")
            );
        }
    }
    let over = sim.neighbour_overflow()?;
    if over > 0 {
        eprintln!(
            "warning: {over} particle-steps had more than {} neighbours (the extra ones were ignored)",
            meniscus::shader_constants::MAX_NEIGHBOURS
        );
    }
    if let Some(e) = &a.export {
        eprintln!("wrote {} files: {e}", a.frames);
    }
    if let Some(f) = &a.foam {
        let [foam, spray, bubbles] = last_counts;
        eprintln!(
            "wrote {} files of diffuse particles: {f} (the last frame: foam {foam}, spray {spray}, bubbles {bubbles}; \
             {} pool slots)",
            a.frames,
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
