//! SPlisHSPlasH scene files as simulation input (`meniscus sim path/scene.json`, `demo --sim`, `bench --sim`,
//! Python's `Simulation`): the set-up SPlisHSPlasH would run, solved by this project's solver.
//!
//! Read: `Configuration` — `particleRadius` (the spacing is its double), `gravitation`, `dataExportFPS` (frames
//! per second), `stopAt` (the frame count: stopAt × fps + 1, file 1 the initial state), `cflFactor` and
//! `cflMaxTimeStepSize` (the automatic step, re-chosen every frame from the largest speed as `cflMethod` 1 and 2
//! do: `[sim] adaptive_step`; with `cflMethod` 0 the fixed `timeStepSize`), `simulationMethod`
//! (2 PBF, 4 DFSPH; the others run as DFSPH, warned) and `DFSPH.maxError` / `maxErrorV`; `Materials` —
//! `density0`, and with `viscosityMethod` 1 ("Standard") its `viscosity` as the kinematic viscosity, with
//! `vorticityMethod` 1 ("Vorticity confinement") its `vorticity`; `FluidBlocks` — `start`, `end`, `translation`,
//! `scale`, `denseMode` 0 and `initialVelocity`, filled as SPlisHSPlasH does (per axis round(width / 2r) − 1
//! particles, 2r apart, the first 2r in from `start`); `RigidBodies` — a `UnitBox.obj` that `isWall` (or
//! `mapInvert`) is the container, another box a solid box, any other OBJ a mesh collider (one per scene), with
//! their translation, rotation and scale. Everything else is named in one warning per key (per section for the
//! rigid-body and cloth solver's `Simulation` section), never silently dropped. `Emitters` — the first: its
//! `width` × `height` particles, `translation`, `rotationAxis`/`rotationAngle`, `velocity`, `type` (box or
//! circle), `emitStartTime`/`emitEndTime`, with `Materials.maxEmitterParticles` the room (default 10,000); a scene that cannot be run
//! (no radius, no fluid, no container) is an error naming the key.

use std::path::Path;

use glam::Vec3;
use serde_json::Value;

use super::scene::SimScene;
use crate::error::{Error, Result};

/// A scene file's set-up: the scene and what it says of the solver.
#[derive(Clone, Debug)]
pub struct SceneFile {
    /// The particles, container and colliders.
    pub scene: SimScene,
    /// `dataExportFPS`.
    pub fps: Option<f32>,
    /// Frames to write: `stopAt` × fps + 1.
    pub frames: Option<u32>,
    /// `gravitation`.
    pub gravity: Option<[f32; 3]>,
    /// Kinematic viscosity of a "Standard" viscosity material.
    pub viscosity: Option<f32>,
    /// Vorticity confinement strength.
    pub vorticity: Option<f32>,
    /// `density0`.
    pub rest_density: Option<f32>,
    /// `cflFactor`.
    pub cfl: Option<f32>,
    /// `cflMaxTimeStepSize` (or the fixed `timeStepSize` when `cflMethod` is 0).
    pub max_dt: Option<f32>,
    /// The pressure solver `simulationMethod` names (PBF for 2, DFSPH for 4 and, the nearest, for the methods
    /// not built here); None without the key.
    pub solver: Option<super::params::Solver>,
    /// `DFSPH.maxError` (percent).
    pub max_error: Option<f32>,
    /// `DFSPH.maxErrorV` (percent).
    pub max_error_v: Option<f32>,
    /// `DFSPH.maxIterations` and `maxIterationsV`: the larger, one limit for both solves here
    /// (`[sim] max_solver_iterations`, 2 … 200).
    pub max_iterations: Option<u32>,
    /// Steps per frame when the step is fixed (`cflMethod` 0).
    pub substeps: Option<u32>,
    /// Whether the step follows the largest speed every frame (`cflMethod` 1 or 2, SPlisHSPlasH's default).
    pub adaptive_step: bool,
    /// What the file says that the solver does not do: one line per key.
    pub warnings: Vec<String>,
}

/// A scene argument resolved: a SPlisHSPlasH scene file (`*.json` or an existing file; `particles` must be
/// None: the file's particleRadius sets the spacing) or a built-in scene with `particles` (default: its own
/// count). With the file's settings for [`SceneFile::apply`] and its warnings.
pub fn resolve(spec: &str, particles: Option<usize>) -> Result<(SimScene, Option<SceneFile>)> {
    if is_scene_file(spec) {
        if particles.is_some() {
            return Err(Error::Invalid(format!(
                "{spec}: a scene file's particleRadius sets the spacing; a particle count does not apply"
            )));
        }
        let f = SceneFile::load(Path::new(spec))?;
        Ok((f.scene.clone(), Some(f)))
    } else {
        let default = super::scene::SCENES.iter().find(|s| s.0 == spec).map_or(10_000, |s| s.1);
        Ok((SimScene::new(spec, particles.unwrap_or(default))?, None))
    }
}

/// Most particles a scene file may lay out (the simulation's state is 32 bytes a particle, and more).
pub const MAX_PARTICLES: usize = 50_000_000;

/// Whether a scene argument names a scene file rather than a built-in scene.
pub fn is_scene_file(spec: &str) -> bool {
    spec.ends_with(".json") || Path::new(spec).is_file()
}

fn invalid(path: &Path, key: &str, why: &str) -> Error {
    Error::Invalid(format!("{}: {key}: {why}", path.display()))
}

fn vec3(v: Option<&Value>) -> Option<Vec3> {
    let a = v?.as_array()?;
    if a.len() != 3 {
        return None;
    }
    let f: Vec<f32> = a.iter().filter_map(|x| x.as_f64().map(|x| x as f32)).collect();
    (f.len() == 3 && f.iter().all(|x| x.is_finite())).then(|| Vec3::new(f[0], f[1], f[2]))
}

fn num(v: Option<&Value>) -> Option<f32> {
    v?.as_f64().map(|x| x as f32).filter(|x| x.is_finite())
}

/// A number or vector value read (or missing): a present key with a wrong type is an error.
fn checked<T>(
    path: &Path,
    key: &str,
    v: Option<&Value>,
    read: impl Fn(Option<&Value>) -> Option<T>,
) -> Result<Option<T>> {
    match v {
        None => Ok(None),
        Some(x) => read(Some(x)).map(Some).ok_or_else(|| invalid(path, key, &format!("cannot read {x}"))),
    }
}

/// SPlisHSPlasH's regular fill of a block (denseMode 0): per axis round(width / d) − 1 particles, d apart,
/// the first d in from `lo`.
pub fn fill_block(lo: Vec3, hi: Vec3, d: f32) -> Vec<[f32; 3]> {
    let w = hi - lo;
    let n = ((w / d).round() - 1.0).max(Vec3::ZERO).as_uvec3();
    let mut out = Vec::with_capacity((n.x * n.y * n.z) as usize);
    for i in 0..n.x {
        for j in 0..n.y {
            for k in 0..n.z {
                out.push((lo + Vec3::new(i as f32 + 1.0, j as f32 + 1.0, k as f32 + 1.0) * d).to_array());
            }
        }
    }
    out
}

mod reader;
use reader::{Bodies, Fluid, MaterialKeys, Reader, SolverKeys, TimeKeys};

impl SceneFile {
    /// Read `path` and lay out its scene.
    pub fn load(path: &Path) -> Result<SceneFile> {
        let text = crate::input::read_text(path)?;
        // A UTF-8 byte-order mark (editors on Windows write one) is not JSON, but it is not an error either.
        let text = text.strip_prefix('\u{feff}').map(str::to_string).unwrap_or(text);
        let root: Value = serde_json::from_str(&text).map_err(|e| Error::Parse {
            path: path.to_path_buf(),
            offset: crate::scene::splishsplash::offset_of(&text, e.line(), e.column()),
            reason: e.to_string(),
        })?;
        let Some(top) = root.as_object() else {
            return Err(invalid(path, "(top level)", "expected a JSON object"));
        };
        let empty = serde_json::Map::new();
        let config = top.get("Configuration").and_then(Value::as_object).unwrap_or(&empty);
        let mut r = Reader { path, top, config, warnings: vec![] };
        for key in top.keys() {
            if !["Configuration", "Materials", "Simulation", "RigidBodies", "FluidBlocks", "FluidModels", "Emitters"]
                .contains(&key.as_str())
            {
                r.warn(key.clone(), "not supported: ignored");
            }
        }
        let radius = checked(path, "Configuration.particleRadius", config.get("particleRadius"), num)?
            .filter(|r| *r > 0.0)
            .ok_or_else(|| invalid(path, "Configuration.particleRadius", "missing or not a positive number"))?;
        let d = 2.0 * radius;
        let TimeKeys { fps, stop, gravity, cfl_method, cfl, max_dt, substeps } = r.time()?;
        let SolverKeys { solver, max_error, max_error_v, max_iterations } = r.solver()?;
        let MaterialKeys { rest_density, viscosity, vorticity, max_emitted, reuse } = r.materials()?;
        let Bodies { sj, container, colliders } = r.bodies(&text)?;
        let Fluid { mut positions, mut velocities } = r.fluid(radius, d)?;
        let emitter = r.emitter(d)?.map(|e| crate::sim::scene::Emitter { reuse, ..e });
        // Water outside the container is dropped, as SPlisHSPlasH's boundary would push it in.
        let keep: Vec<bool> = positions
            .iter()
            .map(|p| Vec3::from(*p).cmpge(container.0).all() && Vec3::from(*p).cmple(container.1).all())
            .collect();
        let outside = keep.iter().filter(|k| !**k).count();
        if outside > 0 {
            r.warn("FluidBlocks".into(), &format!("{outside} particles outside the container: left out"));
            let mut k = keep.iter();
            positions.retain(|_| *k.next().unwrap_or(&true));
            let mut k = keep.iter();
            velocities.retain(|_| *k.next().unwrap_or(&true));
        }
        if positions.len() < 8 && emitter.is_none() {
            return Err(invalid(
                path,
                "FluidBlocks",
                &format!("{} particles and no emitter: a simulation needs at least 8", positions.len()),
            ));
        }
        let n = positions.len();
        if emitter.is_some() && n + max_emitted == 0 {
            return Err(invalid(
                path,
                "Materials[0].maxEmitterParticles",
                "0 and no fluid blocks: nothing to simulate",
            ));
        }
        let mut scene = SimScene {
            name: "scene.json",
            container,
            colliders,
            spacing: d,
            positions,
            velocities,
            capacity: if emitter.is_some() { n + max_emitted } else { n },
            emitter,
            viscosity: viscosity.unwrap_or(0.01),
            mesh_collider: None,
            body: None,
        };
        let fixed = dynamic_bodies(&mut r, &sj, &mut scene, d)?;
        match fixed.as_slice() {
            [] => {}
            [m, rest @ ..] => {
                let mesh = m.load()?;
                let removed = scene.add_mesh_collider(&mesh)?;
                if removed > 0 {
                    r.warn("RigidBodies".into(), &format!("{removed} particles inside {} left out", m.file.display()));
                }
                for other in rest {
                    r.warn(
                        "RigidBodies".into(),
                        &format!("{}: one mesh collider per scene: ignored", other.file.display()),
                    );
                }
            }
        }
        let frames = stop.zip(fps).map(|(t, f)| (t * f).round() as u32 + 1);
        Ok(SceneFile {
            scene,
            fps,
            frames,
            gravity: gravity.map(|g| g.to_array()),
            viscosity,
            vorticity,
            rest_density,
            cfl,
            max_dt,
            substeps,
            adaptive_step: cfl_method != 0.0,
            solver,
            max_error,
            max_error_v,
            max_iterations,
            warnings: r.warnings,
        })
    }

    /// `params` with what the file sets.
    pub fn apply(&self, params: &mut super::params::Params) {
        if let Some(f) = self.fps {
            params.fps = f;
        }
        if let Some(g) = self.gravity {
            params.gravity = g;
        }
        if let Some(v) = self.viscosity {
            params.viscosity = Some(v);
        }
        if let Some(v) = self.vorticity {
            params.vorticity = v;
        }
        if let Some(r) = self.rest_density {
            params.rest_density = r;
        }
        if let Some(c) = self.cfl {
            params.cfl = c;
        }
        if let Some(t) = self.max_dt {
            params.max_dt = t;
        }
        if let Some(s) = self.substeps {
            params.substeps = s;
        }
        params.adaptive_step = self.adaptive_step;
        if let Some(s) = self.solver {
            params.solver = s;
        }
        if let Some(e) = self.max_error {
            params.max_density_error = e;
        }
        if let Some(e) = self.max_error_v {
            params.max_divergence_error = e;
        }
        if let Some(n) = self.max_iterations {
            params.max_solver_iterations = n;
        }
    }
}

/// The scene file's dynamic bodies: a sphere becomes `scene.body` (DFSPH moves it, `sim::scene::Body`; the
/// particles inside it are left out), any other dynamic body — or a second sphere — stands still as a collider
/// (warned). Returns the meshes that stay colliders.
fn dynamic_bodies(
    r: &mut reader::Reader,
    sj: &crate::scene::splishsplash::SceneJson,
    scene: &mut SimScene,
    d: f32,
) -> Result<Vec<crate::scene::splishsplash::SceneMesh>> {
    let mut fixed = vec![];
    for m in &sj.meshes {
        let Some(props) = m.dynamic else {
            fixed.push(m.clone());
            continue;
        };
        let mesh = m.load()?;
        let (lo, hi) = mesh.bounds();
        let half = 0.5 * (hi - lo);
        let round = half.min_element() > 0.0 && half.max_element() / half.min_element() < 1.05;
        if !round || scene.body.is_some() {
            let why = if round { "one dynamic body per scene" } else { "only a dynamic sphere moves here" };
            r.warn("RigidBodies".into(), &format!("{}: {why}: it stands still as a collider", m.file.display()));
            fixed.push(m.clone());
            continue;
        }
        // The contact sphere's radius where the file gives one (SPlisHSPlasH's collision object), else the
        // mesh's: the tessellated sphere's extremes lie a little inside its nominal radius.
        let (centre, radius) = (0.5 * (lo + hi), props.sphere_radius.unwrap_or((half.x + half.y + half.z) / 3.0));
        // SPlisHSPlasH's contact between two bodies: restitutions multiplied, frictions added.
        let (e, mu) = sj.container_contact;
        let body = crate::sim::scene::Body {
            centre,
            radius,
            density: props.density,
            velocity: props.velocity,
            restitution: props.restitution * e,
            friction: props.friction + mu,
            contact_box: sj.container_collision,
        };
        let before = scene.positions.len();
        let keep: Vec<bool> =
            scene.positions.iter().map(|p| (Vec3::from(*p) - centre).length() >= radius + 0.5 * d).collect();
        let mut k = keep.iter();
        scene.positions.retain(|_| *k.next().unwrap_or(&true));
        let mut k = keep.iter();
        scene.velocities.retain(|_| *k.next().unwrap_or(&true));
        let removed = before - scene.positions.len();
        if removed > 0 {
            r.warn("RigidBodies".into(), &format!("{removed} particles inside {} left out", m.file.display()));
        }
        scene.capacity -= removed;
        scene.body = Some(body);
    }
    Ok(fixed)
}
