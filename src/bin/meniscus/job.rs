//! The one set-up every subcommand shares: load (a built-in scene, a file or the first frame of a sequence) →
//! radius (flag, scene, or estimated from the particles' number density) → settings validated → bounds →
//! camera (flag, or fitted for the output's aspect) → background extras → upload (isolated flags and per-particle
//! radii, through [`Renderer::set_scene_particles`]) → the end-of-run validation check ([`crate::args::finish`]).
//! `render`, `bench`, `demo` and `info` all start from a [`Job`], so the same file and flags give the same
//! particles, radii and camera everywhere; each prints the same `job:` line, which a CLI test compares.

use std::path::Path;

use anyhow::{bail, Context, Result};

use meniscus::renderer::{Backdrop, Renderer, Upload};
use meniscus::scene::camera::Camera;
use meniscus::scene::geometry::Geometry;
use meniscus::scene::sequence::{self, Frame, FrameRange};
use meniscus::scene::{self, procedural, Bounds, LoadOptions, Particles};
use meniscus::settings::Settings;
use meniscus::view::View;

use crate::args::{LoadArgs, SceneArgs};

/// Which frames of a sequence (render's `--frames` and `--shard`).
#[derive(Default)]
pub struct Select {
    pub range: Option<FrameRange>,
    pub shard: Option<(usize, usize)>,
}

/// Where the radius came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RadiusFrom {
    Flag,
    Scene,
    /// A SPlisHSPlasH `scene.json` beside the files.
    SceneJson,
    Estimated,
}

/// Particles, settings and camera of one run.
pub struct Job {
    /// "scene wave", a file path, or the sequence pattern.
    pub label: String,
    /// The particles of a single input, or the first frame of the whole sequence (what the radius, camera and
    /// background are fitted to, whatever range or shard is rendered).
    pub first: Particles,
    /// The frames of a sequence (`None` for a single file or scene).
    pub frames: Option<Vec<Frame>>,
    /// Every frame of the sequence, whatever `frames` selects (empty for one file or a built-in scene): the
    /// frames before a selected one, for its motion.
    pub whole: Vec<Frame>,
    pub load: LoadOptions,
    /// Settings with the radius resolved; validated.
    pub settings: Settings,
    pub radius_from: RadiusFrom,
    /// 1st–99th percentile bounds of the first frame (camera fit and background scene).
    pub bounds: Bounds,
    /// The `--camera` flag, if given.
    pub camera: Option<Camera>,
    /// `--background-obj`, read and checked before any GPU work.
    pub mesh: Option<Geometry>,
    /// A simulated scene's container walls (drawn as background boxes instead of the default ones), from the
    /// live scene or a `scene.json` beside the files.
    pub walls: Vec<(glam::Vec3, glam::Vec3)>,
    /// The ground height under the walls (the container's floor), when they come with one.
    pub floor: Option<f32>,
    /// The sequence's own frame rate, when its scene.json says it (a movie's default --fps).
    pub fps: Option<f32>,
    /// Spheres frame by frame (a simulation's moving body and sphere colliders: the scene.json `meniscus sim
    /// --export` wrote, or the live scene's), drawn in the background ([`Job::place_bodies`]).
    pub tracks: Vec<meniscus::scene::splishsplash::BodyTrack>,
}

/// The `scene.json` describing the particle file `path`, if any, with one line about what it gives; one that
/// cannot be read is reported and ignored (it only adds the radius and the walls).
/// How far (as a factor either way) a given radius may be from the one the particles' spacing gives.
const RADIUS_RANGE: f32 = 20.0;

fn find_scene_json(path: &Path) -> Option<meniscus::scene::splishsplash::SceneJson> {
    match meniscus::scene::splishsplash::SceneJson::find_for(path) {
        Ok(Some(s)) => {
            let radius = s.radius.map(|r| format!("radius {r}")).unwrap_or("no radius".into());
            eprintln!(
                "{}: {radius}, {} container(s), {} box(es) and {} mesh(es) for the background (--no-scene-json \
                 ignores it)",
                s.path.display(),
                s.containers.len(),
                s.boxes.len(),
                s.meshes.len()
            );
            for k in &s.skipped {
                eprintln!("{}: not drawn: {k}", s.path.display());
            }
            Some(s)
        }
        Ok(None) => None,
        Err(e) => {
            eprintln!("warning: ignoring {e}");
            None
        }
    }
}

impl Job {
    /// Load and resolve everything that does not need the GPU.
    pub fn open(scene_args: &SceneArgs, load: &LoadArgs, settings: Settings, select: Select) -> Result<Job> {
        let load = load.options()?;
        let input = scene_args.input.as_str();
        let builtin = procedural::SCENES.iter().find(|s| s.0 == input);
        let mut scene_json = None;
        let mut whole = vec![];
        let (first, scene_radius, frames, label) = if let Some((name, n, _)) = builtin {
            let g = procedural::generate(name, scene_args.particles.unwrap_or(*n))?;
            (g.particles, Some((g.radius, RadiusFrom::Scene)), None, format!("scene {name}"))
        } else {
            if scene_args.particles.is_some() {
                bail!("--particles applies to built-in scenes only");
            }
            if sequence::is_sequence(input) {
                // Everything fitted to the data (radius, camera, background) comes from the first frame of the
                // WHOLE sequence, never from the first frame a range or shard happens to start with: frame k
                // renders byte-identically however the sequence is split (--frames, --shard, --resume).
                let all = sequence::resolve_all(input)?;
                let gaps = sequence::missing(&all);
                if !gaps.is_empty() {
                    let shown: Vec<String> = gaps.iter().take(10).map(|n| n.to_string()).collect();
                    eprintln!(
                        "warning: {input}: {} frame{} missing from the numbering: {}{}",
                        gaps.len(),
                        if gaps.len() == 1 { " is" } else { "s are" },
                        shown.join(", "),
                        if gaps.len() > 10 { ", …" } else { "" }
                    );
                }
                // The first frame that holds particles (a 0-particle frame is valid, but nothing fits to it).
                let mut first = scene::load_with(&all[0].path, &load)?;
                for f in all.iter().skip(1) {
                    if !first.is_empty() {
                        break;
                    }
                    first = scene::load_with(&f.path, &load)?;
                }
                if first.is_empty() {
                    bail!("{input}: no frame of the sequence holds particles");
                }
                if !scene_args.no_scene_json {
                    scene_json = find_scene_json(&all[0].path);
                }
                whole = all.clone();
                let frames = sequence::select(input, all, select.range, select.shard)?;
                let r = scene_json.as_ref().and_then(|s| s.radius).map(|r| (r, RadiusFrom::SceneJson));
                (first, r, Some(frames), input.to_string())
            } else {
                if select.range.is_some() || select.shard.is_some() {
                    bail!("--frames and --shard apply to sequences (a pattern with {{}}, a folder or a glob)");
                }
                let path = Path::new(input);
                meniscus::input::note(path);
                if !path.exists() {
                    let known: Vec<&str> = procedural::SCENES.iter().map(|s| s.0).collect();
                    bail!("{input}: no such file, and not a built-in scene ({})", known.join(", "));
                }
                if !scene_args.no_scene_json {
                    scene_json = find_scene_json(path);
                }
                let r = scene_json.as_ref().and_then(|s| s.radius).map(|r| (r, RadiusFrom::SceneJson));
                let p = scene::load_with(path, &load)?;
                if p.is_empty() {
                    bail!("{input}: the file holds no particles: nothing to render or mesh (`meniscus info` reads it)");
                }
                (p, r, None, input.to_string())
            }
        };
        // Coordinates whose squares overflow 32-bit floats cannot be rendered or meshed (distances are squared).
        let largest = first.positions.iter().flatten().fold(0f32, |m, x| m.max(x.abs()));
        if largest > 1e15 {
            bail!(
                "{label}: particle coordinates reach {largest:e}, beyond the 1e15 that 32-bit rendering can square; \
                 check the units and --scale"
            );
        }
        let mut settings = settings;
        let (radius, radius_from) = match (scene_args.radius, scene_radius) {
            (Some(r), _) => (r, RadiusFrom::Flag),
            (None, Some(r)) => r,
            (None, None) => {
                let r = match scene::estimate_radius(&first.positions) {
                    Some(r) => r,
                    None => {
                        let b = scene::percentile_bounds(&first.positions, 0.0);
                        let extent = b.map_or(0.0, |b| (b.hi - b.lo).max_element());
                        bail!(
                            "{label}: cannot estimate the particle radius: {} particle{} within {extent:e} of \
                             each other (fewer than two distinct positions a float can tell apart, or too few \
                             particles); pass --radius, and check the units (--scale)",
                            first.len(),
                            if first.len() == 1 { "" } else { "s" }
                        )
                    }
                };
                (r, RadiusFrom::Estimated)
            }
        };
        // A radius given (flag or scene.json) that the spacing of 64 or more particles contradicts by more than 20× would
        // be drawn or meshed as nothing or as one blob (`--scale 1e-5` with a scene.json's radius: a mesh of 126
        // vertices instead of 140k): an error with both numbers, never an empty output.
        if radius_from != RadiusFrom::Estimated && first.len() >= 64 {
            if let Some(est) = scene::estimate_radius(&first.positions) {
                let ratio = radius / est;
                if !(1.0 / RADIUS_RANGE..=RADIUS_RANGE).contains(&ratio) {
                    bail!(
                        "{label}: the radius {radius:e} ({}) is {ratio:.3e}× the radius the particles' spacing gives \
                         ({est:e}): a surface at that radius {}; check the units (--scale scales the positions, \
                         not a scene.json's radius) or pass --radius",
                        if radius_from == RadiusFrom::Flag { "--radius" } else { "from scene.json" },
                        if ratio > 1.0 { "merges everything into one blob" } else { "leaves every particle apart" }
                    );
                }
            }
        }
        settings.radius = radius;
        settings.validate()?;
        let bounds = scene::percentile_bounds(&first.positions, 0.01).context("no finite particle positions")?;
        let camera = scene_args.camera.as_deref().map(Camera::parse).transpose()?;
        camera.unwrap_or_else(|| Camera::fit(&bounds, 16.0 / 9.0)).check()?;
        let mesh = scene_args.background_obj.as_deref().map(Geometry::load_obj).transpose()?;
        if radius_from == RadiusFrom::Estimated {
            eprintln!("radius {radius:.5} estimated from the particles' number density (pass --radius to override)");
        }
        let Scenery { walls, floor, fps, tracks, mesh } = scenery(scene_json, radius, mesh);
        let job = Job {
            label,
            first,
            frames,
            whole,
            load,
            settings,
            radius_from,
            bounds,
            camera,
            mesh,
            walls,
            floor,
            fps,
            tracks,
        };
        Ok(job)
    }

    /// The job of a live simulation (`demo --sim`): the scene's initial particles, its radius, its container as
    /// the bounds and its walls in the background; `mesh`: the `--background-obj` its caller read (and made the
    /// water's collider).
    pub fn simulated(
        scene: &meniscus::sim::scene::SimScene,
        scene_args: &SceneArgs,
        mesh: Option<Geometry>,
        settings: Settings,
    ) -> Result<Job> {
        let mut settings = settings;
        settings.radius = scene.radius();
        settings.validate()?;
        let (lo, hi) = scene.container;
        let camera = scene_args.camera.as_deref().map(Camera::parse).transpose()?;
        Ok(Job {
            label: format!("sim {}", scene.name),
            first: Particles {
                positions: scene.positions.clone(),
                velocities: Some(scene.velocities.clone()),
                ..Default::default()
            },
            frames: None,
            whole: vec![],
            load: LoadOptions::default(),
            settings,
            radius_from: RadiusFrom::Scene,
            bounds: Bounds { lo, hi },
            camera,
            mesh,
            walls: scene.wall_boxes(),
            floor: Some(lo.y),
            fps: None,
            tracks: scene.sphere_tracks(),
        })
    }

    /// The camera for a `width`×`height` output: the flag's, or fitted to the first frame.
    pub fn camera_for(&self, width: u32, height: u32) -> Camera {
        self.camera.unwrap_or_else(|| Camera::fit(&self.bounds, width as f32 / height.max(1) as f32))
    }

    /// The view of a `width`×`height` output (camera and background scene).
    pub fn view(&self, width: u32, height: u32) -> View {
        let mut view = View::around(&self.bounds, self.camera, width, height, &self.settings);
        // The simulated container's (or a scene.json's) walls on its floor instead of the default scenery.
        if !self.walls.is_empty() {
            view.env.boxes = self.walls.clone();
            view.env.ground_y = self.floor.unwrap_or(self.bounds.lo.y);
        }
        view
    }

    /// The spheres of frame `frame` (numbered as the sequence's files) in `view`'s background.
    pub fn place_bodies(&self, view: &mut View, frame: u64) {
        view.env.spheres = meniscus::scene::splishsplash::BodyTrack::spheres_at(&self.tracks, frame);
    }

    /// Upload one frame's particles (isolated flags, per-particle radii) with this job's settings.
    pub fn upload(&self, r: &mut Renderer, p: &Particles) -> Result<()> {
        Ok(r.upload(Upload::scene(p, &self.settings))?)
    }

    /// The sequence's frame rate (its scene.json's), else [`meniscus::motion::DEFAULT_FPS`]: the time between
    /// frames for the particles' motion and the diffuse particles' steps.
    pub fn frame_rate(&self) -> f32 {
        self.fps.unwrap_or(meniscus::motion::DEFAULT_FPS)
    }

    /// The tracker of the particles' motion over this job's frames, in time order (the `noise` pass's
    /// amplitude), at [`Job::frame_rate`].
    pub fn motion(&self) -> meniscus::motion::MotionTracker {
        meniscus::motion::MotionTracker::new(self.frame_rate())
    }

    /// Upload the next frame of a sequence walked in time order, its motion from `tracker`, with the host's
    /// analysis its loader computed ([`Job::analyser`]).
    pub fn upload_next(
        &self,
        r: &mut Renderer,
        p: &Particles,
        tracker: &mut meniscus::motion::MotionTracker,
        ahead: Option<&meniscus::particles::SetAnalysis>,
    ) -> Result<()> {
        let motion = tracker.next(p);
        Ok(r.upload(Upload::Scene { particles: p, settings: &self.settings, motion: Some(&motion), ahead })?)
    }

    /// What a sequence's loader computes for each frame beside its load: the iso surface's analysis of the
    /// particles (`surface::grid::analyse`; none where the job's surface would not use it).
    pub fn analyser(&self) -> impl Fn(&Particles) -> Option<meniscus::particles::SetAnalysis> + Send + 'static {
        Job::analyser_for(&self.settings)
    }

    /// [`Job::analyser`] for settings `s`.
    pub fn analyser_for(
        s: &Settings,
    ) -> impl Fn(&Particles) -> Option<meniscus::particles::SetAnalysis> + Send + 'static {
        let s = s.clone();
        move |p: &Particles| meniscus::surface::grid::analyse(&p.positions, &s)
    }

    /// Add the background mesh, if any, to a renderer.
    pub fn apply_background(&self, r: &mut Renderer) -> Result<()> {
        if let Some(m) = &self.mesh {
            r.set_background(Backdrop::Mesh(m))?;
        }
        Ok(())
    }

    /// One line that identifies what a run sees: the label, the particle count, a hash of the positions and
    /// per-particle radii, the radius and where it came from, and (for an output size) the camera.
    pub fn summary(&self, size: Option<(u32, u32)>) -> String {
        let p = &self.first;
        let mut line = format!(
            "job: {}: {} particles (hash {:016x}), per-particle radii {}, radius {} ({:?})",
            self.label,
            p.len(),
            hash(p),
            if p.radii.is_some() { "yes" } else { "no" },
            self.settings.radius,
            self.radius_from
        );
        if let Some((w, h)) = size {
            line += &format!(", camera --camera {}", self.camera_for(w, h).to_arg());
        }
        line
    }
}

/// FNV-1a over the positions' and radii's bits (enough to tell two loads apart).
fn hash(p: &Particles) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |x: f32| {
        for b in x.to_bits().to_le_bytes() {
            h = (h ^ b as u64).wrapping_mul(0x100_0000_01b3);
        }
    };
    p.positions.iter().flatten().for_each(|&x| eat(x));
    p.radii.iter().flatten().for_each(|&x| eat(x));
    h
}

/// Say where the mesh surface is extracted and why (`[mesh] extraction`, `FluidMesh::path`), once per change:
/// the library chooses, the application says so. `last`: what was said last.
pub fn say_mesh_path(r: &Renderer, s: &Settings, last: &mut Option<String>) {
    if s.surface != meniscus::settings::Surface::Mesh {
        return;
    }
    let mesh = r.state().surfaces().technique::<meniscus::surface::mesh::FluidMesh>();
    if let Some((e, why)) = mesh.and_then(|m| m.path()) {
        let line = match e {
            meniscus::surface::mesh::params::Extraction::Gpu => {
                format!("mesh surface: extracted on the GPU in the frame and rasterised ({why})")
            }
            _ => format!("mesh surface: extracted on the CPU and ray-cast ({why})"),
        };
        if last.as_deref() != Some(line.as_str()) {
            eprintln!("{line}");
            *last = Some(line);
        }
    }
}

/// Warn once per set of particles about the strays the surface left out (particles far from the fluid): the
/// library counts them (`Technique::strays`), the application says so. `last`: the particle generation warned
/// about last.
pub fn warn_strays(r: &Renderer, s: &Settings, last: &mut Option<u64>) {
    if let Some((generation, n)) = r.state().surfaces().get(s.surface).strays() {
        if n > 0 && *last != Some(generation) {
            eprintln!("{}", scene::stray_warning(n, "the iso surface"));
        }
        *last = Some(generation);
    }
}

/// What a scene.json puts around the particles.
struct Scenery {
    /// Its container's walls, in the background.
    walls: Vec<(glam::Vec3, glam::Vec3)>,
    /// The container's floor.
    floor: Option<f32>,
    /// The sequence's frame rate.
    fps: Option<f32>,
    /// Spheres frame by frame.
    tracks: Vec<meniscus::scene::splishsplash::BodyTrack>,
    /// The background mesh: `--background-obj`'s with the scene.json's mesh bodies.
    mesh: Option<Geometry>,
}

/// See [`Scenery`]; `radius`: the particles' (the walls are at least two thick); `mesh`: `--background-obj`'s.
fn scenery(
    scene_json: Option<meniscus::scene::splishsplash::SceneJson>,
    radius: f32,
    mut mesh: Option<Geometry>,
) -> Scenery {
    let Some(sj) = scene_json else { return Scenery { walls: vec![], floor: None, fps: None, tracks: vec![], mesh } };
    // The mesh bodies join the background mesh; one that cannot be read is reported and left out.
    for m in &sj.meshes {
        match m.load() {
            Ok(placed) => mesh.get_or_insert_with(Geometry::default).triangles.extend(placed.triangles),
            Err(e) => eprintln!("{}: not drawn: {e}", sj.path.display()),
        }
    }
    let (walls, floor) = if !sj.containers.is_empty() || !sj.boxes.is_empty() {
        let size = sj.containers.iter().map(|c| (c.1 - c.0).max_element()).fold(0.0, f32::max);
        (sj.background_boxes((0.02 * size).max(2.0 * radius)), sj.floor())
    } else {
        (vec![], None)
    };
    Scenery { walls, floor, fps: sj.fps, tracks: sj.tracks, mesh }
}
