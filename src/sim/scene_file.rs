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

use super::scene::{Collider, SimScene};
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
        let mut warnings = vec![];
        let mut warn = |key: String, why: &str| warnings.push(format!("{}: {key}: {why}", path.display()));
        for key in top.keys() {
            if !["Configuration", "Materials", "Simulation", "RigidBodies", "FluidBlocks", "FluidModels", "Emitters"]
                .contains(&key.as_str())
            {
                warn(key.clone(), "not supported: ignored");
            }
        }
        let empty = serde_json::Map::new();
        let config = top.get("Configuration").and_then(Value::as_object).unwrap_or(&empty);
        let radius = checked(path, "Configuration.particleRadius", config.get("particleRadius"), num)?
            .filter(|r| *r > 0.0)
            .ok_or_else(|| invalid(path, "Configuration.particleRadius", "missing or not a positive number"))?;
        let d = 2.0 * radius;
        // A value the file sets outside its range is an error naming the key, never silently the default.
        let positive = |key: &str, v: Option<f32>| -> Result<Option<f32>> {
            match v {
                Some(x) if x.is_nan() || x <= 0.0 => Err(invalid(path, key, &format!("{x} is not a positive number"))),
                v => Ok(v),
            }
        };
        let fps = positive(
            "Configuration.dataExportFPS",
            checked(path, "Configuration.dataExportFPS", config.get("dataExportFPS"), num)?,
        )?;
        let stop = positive("Configuration.stopAt", checked(path, "Configuration.stopAt", config.get("stopAt"), num)?)?;
        if let (Some(t), f) = (stop, fps.unwrap_or(25.0)) {
            if t * f > 1e6 {
                return Err(invalid(
                    path,
                    "Configuration.stopAt",
                    &format!("{t} s at {f} frames/s is {:.3e} frames, more than the 1,000,000 a run writes", t * f),
                ));
            }
        }
        let gravity = checked(path, "Configuration.gravitation", config.get("gravitation"), vec3)?;
        let cfl_method = checked(path, "Configuration.cflMethod", config.get("cflMethod"), num)?.unwrap_or(1.0);
        if ![0.0, 1.0, 2.0].contains(&cfl_method) {
            return Err(invalid(
                path,
                "Configuration.cflMethod",
                &format!("{cfl_method} is not 0 (fixed step), 1 or 2 (the CFL step)"),
            ));
        }
        let dt = positive(
            "Configuration.timeStepSize",
            checked(path, "Configuration.timeStepSize", config.get("timeStepSize"), num)?,
        )?;
        let cfl = positive(
            "Configuration.cflFactor",
            checked(path, "Configuration.cflFactor", config.get("cflFactor"), num)?,
        )?;
        let cfl_max = positive(
            "Configuration.cflMaxTimeStepSize",
            checked(path, "Configuration.cflMaxTimeStepSize", config.get("cflMaxTimeStepSize"), num)?,
        )?;
        let (max_dt, substeps) = if cfl_method == 0.0 {
            let steps = dt.zip(fps.or(Some(25.0))).map(|(dt, fps)| (1.0 / (fps * dt)).round().max(1.0));
            if let Some(n) = steps.filter(|n| *n > super::constants::MAX_SUBSTEPS as f32) {
                return Err(invalid(
                    path,
                    "Configuration.timeStepSize",
                    &format!(
                        "{} s makes {n:.3e} steps a frame, more than the {} a frame takes here",
                        dt.unwrap_or(0.0),
                        super::constants::MAX_SUBSTEPS
                    ),
                ));
            }
            (dt, steps.map(|n| n as u32))
        } else {
            (cfl_max, None)
        };
        // The pressure solver: SPlisHSPlasH's simulationMethod (0 WCSPH, 1 PCISPH, 2 PBF, 3 IISPH, 4 DFSPH, 5
        // Projective Fluids, 6 ICSPH); the methods not built here run as DFSPH, the nearest (a pressure solve
        // iterated to an error bound), and say so. Without the key, `[sim] solver` decides.
        let method = checked(path, "Configuration.simulationMethod", config.get("simulationMethod"), num)?;
        let solver = match method.map(|m| m as i64) {
            None => None,
            Some(2) => Some(super::params::Solver::Pbf),
            Some(4) => Some(super::params::Solver::Dfsph),
            Some(m) => {
                let name = ["WCSPH", "PCISPH", "PBF", "IISPH", "DFSPH", "Projective Fluids", "ICSPH"]
                    .get(m as usize)
                    .copied()
                    .unwrap_or("an unknown method");
                warn(
                    "Configuration.simulationMethod".into(),
                    &format!("{m} ({name}) is not built here: DFSPH runs, the nearest (an iterated pressure solve)"),
                );
                Some(super::params::Solver::Dfsph)
            }
        };
        // DFSPH's bounds (percent, as here) and its iteration limits (one for both solves here: the larger).
        let (mut max_error, mut max_error_v) = (None, None);
        let mut limits: Vec<(String, u32)> = vec![];
        if let Some(df) = config.get("DFSPH").and_then(Value::as_object) {
            for (key, v) in df {
                let at = format!("Configuration.DFSPH.{key}");
                match key.as_str() {
                    "maxError" => max_error = positive(&at, checked(path, &at, Some(v), num)?)?,
                    "maxErrorV" => max_error_v = positive(&at, checked(path, &at, Some(v), num)?)?,
                    "maxIterations" | "maxIterationsV" => {
                        let n = checked(path, &at, Some(v), num)?
                            .filter(|n| *n >= 1.0)
                            .ok_or_else(|| invalid(path, &at, "not a positive number"))?;
                        limits.push((at, n.min(u32::MAX as f32) as u32));
                    }
                    "minIterations" | "minIterationsV" => {
                        let least = if key == "minIterations" { 2.0 } else { 1.0 };
                        if num(Some(v)) != Some(least) {
                            warn(
                                at,
                                &format!(
                                    "the solves here take at least 2 (density) and 1 (divergence) corrections, \
                                     SPlisHSPlasH's defaults: {least} is used"
                                ),
                            );
                        }
                    }
                    "enableDivergenceSolver" if v.as_bool() == Some(true) => {}
                    "enableDivergenceSolver" => warn(at, "the divergence-free solve always runs here: ignored"),
                    _ => warn(at, "not supported: ignored"),
                }
            }
        }
        // The solves share one limit here, the larger of the file's two, within what `[sim]` accepts.
        let max_iterations = limits.iter().map(|(_, n)| *n).max().map(|n| {
            let kept = n.clamp(2, 200);
            if kept != n || limits.iter().any(|(_, m)| *m != n) {
                let names: Vec<&str> = limits.iter().map(|(k, _)| k.as_str()).collect();
                warn(
                    names.join(" and "),
                    &format!("one limit for both solves here (2 … 200): {kept} corrections per solve"),
                );
            }
            kept
        });
        const READ: [&str; 10] = [
            "particleRadius",
            "gravitation",
            "dataExportFPS",
            "stopAt",
            "cflMethod",
            "cflFactor",
            "cflMaxTimeStepSize",
            "timeStepSize",
            "simulationMethod",
            "DFSPH",
        ];
        for key in config.keys().filter(|k| !READ.contains(&k.as_str())) {
            let why = match key.as_str() {
                "WCSPH" | "PCISPH" | "PBF" | "IISPH" | "DFSPHSolver" => {
                    "another solver's settings (the solvers here: PBF and DFSPH, docs/simulation.md): ignored"
                }
                "boundaryHandlingMethod" => "boundaries here are the container's faces and collider distances: ignored",
                "enablePartioExport"
                | "enableVTKExport"
                | "particleAttributes"
                | "numberOfStepsPerRenderUpdate"
                | "enableRigidBodyExport"
                | "enableStateExport"
                | "pause"
                | "pauseAt"
                | "cameraPosition"
                | "cameraLookat" => "an export or GUI setting of SPlisHSPlasH (`--export` writes here): ignored",
                _ => "not supported: ignored",
            };
            warn(format!("Configuration.{key}"), why);
        }
        // Materials: the first fluid's density, viscosity and vorticity.
        let (mut rest_density, mut viscosity, mut vorticity) = (None, None, None);
        // SPlisHSPlasH's default room for emitted particles.
        let mut max_emitted: usize = 10_000;
        if let Some(mats) = top.get("Materials").and_then(Value::as_array) {
            for (i, m) in mats.iter().enumerate() {
                let Some(m) = m.as_object() else { continue };
                for (key, v) in m {
                    let at = format!("Materials[{i}].{key}");
                    match key.as_str() {
                        "id" | "colorMapType" | "colorField" | "renderMinValue" | "renderMaxValue" => {}
                        "density0" => rest_density = checked(path, &at, Some(v), num)?,
                        "viscosityMethod" if num(Some(v)) == Some(1.0) => {}
                        "Standard viscosity" => {
                            viscosity = checked(path, &format!("{at}.viscosity"), v.get("viscosity"), num)?;
                        }
                        "vorticityMethod" if num(Some(v)) == Some(1.0) => {}
                        "Vorticity confinement" => {
                            vorticity = checked(path, &format!("{at}.vorticity"), v.get("vorticity"), num)?;
                        }
                        "maxEmitterParticles" => {
                            let n = checked(path, &at, Some(v), num)?.unwrap_or(0.0);
                            if !(0.0..=50e6).contains(&n) {
                                return Err(invalid(path, &at, "must be 0 … 50,000,000"));
                            }
                            max_emitted = n as usize;
                        }
                        "emitterReuseParticles" if v.as_bool() != Some(true) => {}
                        "emitterReuseParticles" | "emitterBoxMin" | "emitterBoxMax" => warn(
                            at,
                            "emitted particles are not recycled here (they stay until the room is used up): ignored",
                        ),
                        _ => warn(at, "not supported: ignored"),
                    }
                }
                if m.get("viscosityMethod").and_then(|v| v.as_f64()).is_some_and(|v| v != 1.0) {
                    viscosity = None;
                }
            }
        }
        if let Some(sim) = top.get("Simulation").and_then(Value::as_object) {
            let keys: Vec<&str> = sim.keys().map(String::as_str).collect();
            warn(
                "Simulation".into(),
                &format!("the rigid-body and cloth solver's settings are not used ({})", keys.join(", ")),
            );
        }
        // Rigid bodies: the container, boxes, one mesh collider (SceneJson reads their placement).
        let sj = crate::scene::splishsplash::SceneJson::parse(path, &text)?;
        for s in &sj.skipped {
            warn("RigidBodies".into(), &format!("{s}: ignored"));
        }
        let Some(&container) = sj.containers.first() else {
            // Say what the file has instead: a wall given as another mesh, or one whose file is missing.
            let bodies = top.get("RigidBodies").and_then(Value::as_array).map(Vec::as_slice).unwrap_or(&[]);
            for (i, b) in bodies.iter().enumerate() {
                let wall = b.get("isWall").and_then(Value::as_bool) == Some(true)
                    || b.get("mapInvert").and_then(Value::as_bool) == Some(true);
                let Some(file) = b.get("geometryFile").and_then(Value::as_str).filter(|_| wall) else { continue };
                let on_disk = path.parent().unwrap_or(Path::new("")).join(file);
                let why = if on_disk.exists() {
                    format!("the wall {file} is not a UnitBox.obj: only an axis-aligned box container is read here")
                } else {
                    format!(
                        "the wall {file} does not exist ({}), and only a UnitBox.obj container is read here",
                        on_disk.display()
                    )
                };
                return Err(invalid(path, &format!("RigidBodies[{i}].geometryFile"), &why));
            }
            return Err(invalid(path, "RigidBodies", "no container (a UnitBox.obj with isWall or mapInvert)"));
        };
        if sj.containers.len() > 1 {
            warn("RigidBodies".into(), "more than one container: the first bounds the water, the others are ignored");
        }
        let colliders: Vec<Collider> = sj
            .boxes
            .iter()
            .map(|(lo, hi)| Collider::Box { centre: 0.5 * (*lo + *hi), half: 0.5 * (*hi - *lo) })
            .collect();
        if let Some(bodies) = top.get("RigidBodies").and_then(Value::as_array) {
            let mut seen: Vec<String> = vec![];
            for b in bodies.iter().filter_map(Value::as_object) {
                for (key, v) in b {
                    let used = [
                        "geometryFile",
                        "translation",
                        "rotationAxis",
                        "rotationAngle",
                        "scale",
                        "isWall",
                        "mapInvert",
                        "invertSDF",
                    ];
                    if used.contains(&key.as_str()) || seen.contains(key) {
                        continue;
                    }
                    if key == "isDynamic" && v.as_bool() != Some(true) {
                        continue;
                    }
                    seen.push(key.clone());
                    let why = match key.as_str() {
                        "isDynamic" => "a dynamic body stands still here (no rigid-body solver)",
                        "color" => "drawing colour: ignored",
                        _ => "not supported (static colliders only): ignored",
                    };
                    warn(format!("RigidBodies[].{key}"), why);
                }
            }
        }
        // Fluid.
        let mut positions: Vec<[f32; 3]> = vec![];
        let mut velocities: Vec<[f32; 3]> = vec![];
        if let Some(blocks) = top.get("FluidBlocks").and_then(Value::as_array) {
            for (i, b) in blocks.iter().enumerate() {
                let at = |k: &str| format!("FluidBlocks[{i}].{k}");
                let get = |k: &str| b.get(k);
                let start = checked(path, &at("start"), get("start"), vec3)?
                    .ok_or_else(|| invalid(path, &at("start"), "missing"))?;
                let end =
                    checked(path, &at("end"), get("end"), vec3)?.ok_or_else(|| invalid(path, &at("end"), "missing"))?;
                let t = checked(path, &at("translation"), get("translation"), vec3)?.unwrap_or(Vec3::ZERO);
                let s = checked(path, &at("scale"), get("scale"), vec3)?.unwrap_or(Vec3::ONE);
                let v0 = checked(path, &at("initialVelocity"), get("initialVelocity"), vec3)?.unwrap_or(Vec3::ZERO);
                let mode = num(get("denseMode")).unwrap_or(0.0);
                if mode != 0.0 {
                    warn(at("denseMode"), &format!("{mode}: filled as the regular grid (denseMode 0)"));
                }
                for key in b.as_object().map(|o| o.keys().cloned().collect::<Vec<_>>()).unwrap_or_default() {
                    if !["start", "end", "translation", "scale", "initialVelocity", "denseMode", "id"]
                        .contains(&key.as_str())
                    {
                        warn(at(&key), "not supported: ignored");
                    }
                }
                let (lo, hi) = ((start * s + t).min(end * s + t), (start * s + t).max(end * s + t));
                // Counted before anything is allocated: a tiny radius in a large block is refused, not filled.
                let count = ((hi - lo) / d).round().max(Vec3::ONE) - 1.0;
                let count = count.x as f64 * count.y as f64 * count.z as f64;
                if count + positions.len() as f64 > MAX_PARTICLES as f64 {
                    return Err(invalid(
                        path,
                        &at("end"),
                        &format!("{count:.3e} particles at radius {radius}: more than {MAX_PARTICLES} in all"),
                    ));
                }
                let block = fill_block(lo, hi, d);
                velocities.extend(std::iter::repeat_n(v0.to_array(), block.len()));
                positions.extend(block);
            }
        }
        if let Some(models) = top.get("FluidModels").and_then(Value::as_array) {
            let dir = path.parent().unwrap_or(Path::new(""));
            for (i, m) in models.iter().enumerate() {
                let at = |k: &str| format!("FluidModels[{i}].{k}");
                let Some(file) = m.get("particleFile").and_then(Value::as_str) else {
                    return Err(invalid(path, &at("particleFile"), "missing"));
                };
                let t = checked(path, &at("translation"), m.get("translation"), vec3)?.unwrap_or(Vec3::ZERO);
                let s = checked(path, &at("scale"), m.get("scale"), vec3)?.unwrap_or(Vec3::ONE);
                let p = crate::scene::load(&dir.join(file))?;
                for q in &p.positions {
                    positions.push((Vec3::from(*q) * s + t).to_array());
                    velocities.push([0.0; 3]);
                }
                if m.get("rotationAngle").and_then(Value::as_f64).is_some_and(|a| a != 0.0) {
                    warn(at("rotationAngle"), "not supported (models are placed unrotated): ignored");
                }
            }
        }
        // Emitters: the first one (a rectangle of width × height particles, or the disc in it, emitting along its
        // rotated x axis, its width along the rotated z axis, as SPlisHSPlasH's do).
        let mut emitter = None;
        if let Some(list) = top.get("Emitters").and_then(Value::as_array) {
            if let Some(e) = list.first().and_then(Value::as_object) {
                let at = |k: &str| format!("Emitters[0].{k}");
                let get = |k: &str| checked(path, &at(k), e.get(k), num);
                let width = get("width")?.unwrap_or(5.0).round();
                let height = get("height")?.unwrap_or(5.0).round();
                if !(1.0..=10_000.0).contains(&width) || !(1.0..=10_000.0).contains(&height) {
                    return Err(invalid(path, &at("width"), "width and height must be 1 … 10,000 particles"));
                }
                let centre = checked(path, &at("translation"), e.get("translation"), vec3)?.unwrap_or(Vec3::ZERO);
                let axis = checked(path, &at("rotationAxis"), e.get("rotationAxis"), vec3)?.unwrap_or(Vec3::Z);
                let angle = get("rotationAngle")?.unwrap_or(0.0);
                let q = glam::Quat::from_axis_angle(axis.normalize_or(Vec3::Z), angle);
                let speed = get("velocity")?.unwrap_or(1.0);
                let kind = get("type")?.unwrap_or(0.0);
                if kind != 0.0 && kind != 1.0 {
                    return Err(invalid(path, &at("type"), "0 (box) or 1 (circle)"));
                }
                let start = get("emitStartTime")?.unwrap_or(0.0) as f64;
                let end = get("emitEndTime")?.map_or(f64::INFINITY, |t| t as f64);
                emitter = Some(super::scene::Emitter {
                    centre,
                    velocity: q * Vec3::X * speed,
                    half: [0.5 * width * d, 0.5 * height * d],
                    width_axis: q * Vec3::Z,
                    start,
                    end,
                    circle: kind == 1.0,
                });
                let known = [
                    "width",
                    "height",
                    "translation",
                    "rotationAxis",
                    "rotationAngle",
                    "velocity",
                    "type",
                    "emitStartTime",
                    "emitEndTime",
                    "id",
                ];
                for key in e.keys().filter(|k| !known.contains(&k.as_str())) {
                    warn(at(key), "not supported: ignored");
                }
            }
            if list.len() > 1 {
                warn("Emitters".into(), &format!("{} emitters: the first emits, the others are ignored", list.len()));
            }
        }
        // Water outside the container is dropped, as SPlisHSPlasH's boundary would push it in.
        let keep: Vec<bool> = positions
            .iter()
            .map(|p| Vec3::from(*p).cmpge(container.0).all() && Vec3::from(*p).cmple(container.1).all())
            .collect();
        let outside = keep.iter().filter(|k| !**k).count();
        if outside > 0 {
            warn("FluidBlocks".into(), &format!("{outside} particles outside the container: left out"));
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
        };
        match sj.meshes.as_slice() {
            [] => {}
            [m, rest @ ..] => {
                let mesh = m.load()?;
                let removed = scene.add_mesh_collider(&mesh)?;
                if removed > 0 {
                    warn("RigidBodies".into(), &format!("{removed} particles inside {} left out", m.file.display()));
                }
                for r in rest {
                    warn("RigidBodies".into(), &format!("{}: one mesh collider per scene: ignored", r.file.display()));
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
            warnings,
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
