//! The reader of a scene file's sections, one concern at a time: time and step (`Configuration`), the pressure
//! solve (`Configuration.simulationMethod`, `Configuration.DFSPH`), the materials, the bodies (container, boxes,
//! mesh colliders), the fluid (blocks and models) and the first emitter. Each names the key it refuses and
//! gathers what it ignores as warnings; `SceneFile::load` assembles the scene from them.

use std::path::Path;

use glam::Vec3;
use serde_json::Value;

use super::{checked, fill_block, invalid, num, vec3, MAX_PARTICLES};
use crate::error::Result;
use crate::sim::scene::Collider;
/// What the `Configuration` says of time: the export rate, the end, gravity and the step.
pub(super) struct TimeKeys {
    pub(super) fps: Option<f32>,
    pub(super) stop: Option<f32>,
    pub(super) gravity: Option<Vec3>,
    pub(super) cfl_method: f32,
    pub(super) cfl: Option<f32>,
    pub(super) max_dt: Option<f32>,
    pub(super) substeps: Option<u32>,
}

/// What the `Configuration` says of the pressure solve.
pub(super) struct SolverKeys {
    pub(super) solver: Option<crate::sim::params::Solver>,
    pub(super) max_error: Option<f32>,
    pub(super) max_error_v: Option<f32>,
    pub(super) max_iterations: Option<u32>,
}

/// What the `Materials` say of the fluid.
pub(super) struct MaterialKeys {
    pub(super) rest_density: Option<f32>,
    pub(super) viscosity: Option<f32>,
    pub(super) vorticity: Option<f32>,
    pub(super) max_emitted: usize,
    /// The recycling box (`emitterReuseParticles` true: `emitterBoxMin/Max`, SPlisHSPlasH's default ±1 m).
    pub(super) reuse: Option<(Vec3, Vec3)>,
}

/// The bodies: the container, the solid boxes, and the file's own reading of their placement (its meshes).
pub(super) struct Bodies {
    pub(super) sj: crate::scene::splishsplash::SceneJson,
    pub(super) container: (Vec3, Vec3),
    pub(super) colliders: Vec<Collider>,
}

/// The fluid's particles: positions and velocities.
pub(super) struct Fluid {
    pub(super) positions: Vec<[f32; 3]>,
    pub(super) velocities: Vec<[f32; 3]>,
}

/// Reads a scene file's sections one concern at a time, gathering what it ignores as warnings.
pub(super) struct Reader<'a> {
    pub(super) path: &'a Path,
    pub(super) top: &'a serde_json::Map<String, Value>,
    pub(super) config: &'a serde_json::Map<String, Value>,
    pub(super) warnings: Vec<String>,
}

impl<'a> Reader<'a> {
    /// Note that `key` is not (fully) used, and why.
    pub(super) fn warn(&mut self, key: String, why: &str) {
        self.warnings.push(format!("{}: {key}: {why}", self.path.display()));
    }

    /// A value the file sets outside its range is an error naming the key, never silently the default.
    fn positive(&self, key: &str, v: Option<f32>) -> Result<Option<f32>> {
        match v {
            Some(x) if x.is_nan() || x <= 0.0 => Err(invalid(self.path, key, &format!("{x} is not a positive number"))),
            v => Ok(v),
        }
    }

    /// The export rate, the end time, gravity and the time step (fixed, or the CFL bound).
    pub(super) fn time(&mut self) -> Result<TimeKeys> {
        let (path, config) = (self.path, self.config);
        let fps = self.positive(
            "Configuration.dataExportFPS",
            checked(path, "Configuration.dataExportFPS", config.get("dataExportFPS"), num)?,
        )?;
        let stop =
            self.positive("Configuration.stopAt", checked(path, "Configuration.stopAt", config.get("stopAt"), num)?)?;
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
        let dt = self.positive(
            "Configuration.timeStepSize",
            checked(path, "Configuration.timeStepSize", config.get("timeStepSize"), num)?,
        )?;
        let cfl = self.positive(
            "Configuration.cflFactor",
            checked(path, "Configuration.cflFactor", config.get("cflFactor"), num)?,
        )?;
        let cfl_max = self.positive(
            "Configuration.cflMaxTimeStepSize",
            checked(path, "Configuration.cflMaxTimeStepSize", config.get("cflMaxTimeStepSize"), num)?,
        )?;
        let (max_dt, substeps) = if cfl_method == 0.0 {
            let steps = dt.zip(fps.or(Some(25.0))).map(|(dt, fps)| (1.0 / (fps * dt)).round().max(1.0));
            if let Some(n) = steps.filter(|n| *n > crate::sim::constants::MAX_SUBSTEPS as f32) {
                return Err(invalid(
                    path,
                    "Configuration.timeStepSize",
                    &format!(
                        "{} s makes {n:.3e} steps a frame, more than the {} a frame takes here",
                        dt.unwrap_or(0.0),
                        crate::sim::constants::MAX_SUBSTEPS
                    ),
                ));
            }
            (dt, steps.map(|n| n as u32))
        } else {
            (cfl_max, None)
        };
        Ok(TimeKeys { fps, stop, gravity, cfl_method, cfl, max_dt, substeps })
    }

    /// The pressure solver and DFSPH's bounds and limits; the `Configuration` keys not read, as warnings.
    pub(super) fn solver(&mut self) -> Result<SolverKeys> {
        let (path, config) = (self.path, self.config);
        // The pressure solver: SPlisHSPlasH's simulationMethod (0 WCSPH, 1 PCISPH, 2 PBF, 3 IISPH, 4 DFSPH, 5
        // Projective Fluids, 6 ICSPH); the methods not built here run as DFSPH, the nearest (a pressure solve
        // iterated to an error bound), and say so. Without the key, `[sim] solver` decides.
        let method = checked(path, "Configuration.simulationMethod", config.get("simulationMethod"), num)?;
        let solver = match method.map(|m| m as i64) {
            None => None,
            Some(2) => Some(crate::sim::params::Solver::Pbf),
            Some(4) => Some(crate::sim::params::Solver::Dfsph),
            Some(m) => {
                let name = ["WCSPH", "PCISPH", "PBF", "IISPH", "DFSPH", "Projective Fluids", "ICSPH"]
                    .get(m as usize)
                    .copied()
                    .unwrap_or("an unknown method");
                self.warn(
                    "Configuration.simulationMethod".into(),
                    &format!("{m} ({name}) is not built here: DFSPH runs, the nearest (an iterated pressure solve)"),
                );
                Some(crate::sim::params::Solver::Dfsph)
            }
        };
        // DFSPH's bounds (percent, as here) and its iteration limits (one for both solves here: the larger).
        let (mut max_error, mut max_error_v) = (None, None);
        let mut limits: Vec<(String, u32)> = vec![];
        if let Some(df) = config.get("DFSPH").and_then(Value::as_object) {
            for (key, v) in df {
                let at = format!("Configuration.DFSPH.{key}");
                match key.as_str() {
                    "maxError" => max_error = self.positive(&at, checked(path, &at, Some(v), num)?)?,
                    "maxErrorV" => max_error_v = self.positive(&at, checked(path, &at, Some(v), num)?)?,
                    "maxIterations" | "maxIterationsV" => {
                        let n = checked(path, &at, Some(v), num)?
                            .filter(|n| *n >= 1.0)
                            .ok_or_else(|| invalid(path, &at, "not a positive number"))?;
                        limits.push((at, n.min(u32::MAX as f32) as u32));
                    }
                    "minIterations" | "minIterationsV" => {
                        let least = if key == "minIterations" { 2.0 } else { 1.0 };
                        if num(Some(v)) != Some(least) {
                            self.warn(
                                at,
                                &format!(
                                    "the solves here take at least 2 (density) and 1 (divergence) corrections, \
                                     SPlisHSPlasH's defaults: {least} is used"
                                ),
                            );
                        }
                    }
                    "enableDivergenceSolver" if v.as_bool() == Some(true) => {}
                    "enableDivergenceSolver" => self.warn(at, "the divergence-free solve always runs here: ignored"),
                    _ => self.warn(at, "not supported: ignored"),
                }
            }
        }
        // The solves share one limit here, the larger of the file's two, within what `[sim]` accepts.
        let max_iterations = limits.iter().map(|(_, n)| *n).max().map(|n| {
            let kept = n.clamp(2, 200);
            if kept != n || limits.iter().any(|(_, m)| *m != n) {
                let names: Vec<&str> = limits.iter().map(|(k, _)| k.as_str()).collect();
                self.warn(
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
                "boundaryHandlingMethod" => {
                    "boundaries here are the container's faces and a dynamic sphere's surface as the missing mass of a \
                     plane (a density map in closed form), and collider distances: ignored"
                }
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
            self.warn(format!("Configuration.{key}"), why);
        }
        Ok(SolverKeys { solver, max_error, max_error_v, max_iterations })
    }

    /// The first fluid's density, viscosity and vorticity, and the room for emitted particles.
    pub(super) fn materials(&mut self) -> Result<MaterialKeys> {
        let (path, top) = (self.path, self.top);
        // Materials: the first fluid's density, viscosity and vorticity.
        let (mut rest_density, mut viscosity, mut vorticity) = (None, None, None);
        // SPlisHSPlasH's default room for emitted particles.
        let mut max_emitted: usize = 10_000;
        let (mut reuse, mut box_lo, mut box_hi) = (false, Vec3::NEG_ONE, Vec3::ONE);
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
                        "emitterReuseParticles" => {
                            reuse = v.as_bool().ok_or_else(|| invalid(path, &at, "must be true or false"))?;
                        }
                        "emitterBoxMin" => box_lo = checked(path, &at, Some(v), vec3)?.unwrap_or(box_lo),
                        "emitterBoxMax" => box_hi = checked(path, &at, Some(v), vec3)?.unwrap_or(box_hi),
                        _ => self.warn(at, "not supported: ignored"),
                    }
                }
                if m.get("viscosityMethod").and_then(|v| v.as_f64()).is_some_and(|v| v != 1.0) {
                    viscosity = None;
                }
            }
        }
        if let Some(sim) = top.get("Simulation").and_then(Value::as_object) {
            let keys: Vec<&str> = sim.keys().map(String::as_str).collect();
            self.warn(
                "Simulation".into(),
                &format!("the rigid-body and cloth solver's settings are not used ({})", keys.join(", ")),
            );
        }
        if reuse && box_lo.cmpgt(box_hi).any() {
            return Err(invalid(
                path,
                "Materials[0].emitterBoxMin",
                &format!("the recycling box's corner {box_lo} is above emitterBoxMax {box_hi} on an axis"),
            ));
        }
        let reuse = reuse.then_some((box_lo, box_hi));
        Ok(MaterialKeys { rest_density, viscosity, vorticity, max_emitted, reuse })
    }

    /// The container, the solid boxes and the mesh colliders (`text`: the file, for SceneJson).
    pub(super) fn bodies(&mut self, text: &str) -> Result<Bodies> {
        let (path, top) = (self.path, self.top);
        // Rigid bodies: the container, boxes, one mesh collider (SceneJson reads their placement).
        let sj = crate::scene::splishsplash::SceneJson::parse(path, text)?;
        for s in &sj.skipped {
            self.warn("RigidBodies".into(), &format!("{s}: ignored"));
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
            self.warn(
                "RigidBodies".into(),
                "more than one container: the first bounds the water, the others are ignored",
            );
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
                        // A dynamic sphere's (SceneFile::load reads them; other dynamic bodies are warned there).
                        "isDynamic",
                        "density",
                        "velocity",
                        "restitution",
                        "friction",
                        // The contact shapes: a dynamic sphere's (type 1), the container's box (type 2).
                        "collisionObjectType",
                        "collisionObjectScale",
                    ];
                    if used.contains(&key.as_str()) || seen.contains(key) {
                        continue;
                    }
                    let _ = v;
                    seen.push(key.clone());
                    let why = match key.as_str() {
                        "color" => "drawing colour: ignored",
                        _ => "not supported: ignored",
                    };
                    self.warn(format!("RigidBodies[].{key}"), why);
                }
            }
        }
        Ok(Bodies { sj, container, colliders })
    }

    /// The fluid blocks and models, spaced `d` (particles of `radius`): positions and velocities.
    pub(super) fn fluid(&mut self, radius: f32, d: f32) -> Result<Fluid> {
        let (path, top) = (self.path, self.top);
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
                    self.warn(at("denseMode"), &format!("{mode}: filled as the regular grid (denseMode 0)"));
                }
                for key in b.as_object().map(|o| o.keys().cloned().collect::<Vec<_>>()).unwrap_or_default() {
                    if !["start", "end", "translation", "scale", "initialVelocity", "denseMode", "id"]
                        .contains(&key.as_str())
                    {
                        self.warn(at(&key), "not supported: ignored");
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
                    self.warn(at("rotationAngle"), "not supported (models are placed unrotated): ignored");
                }
            }
        }
        Ok(Fluid { positions, velocities })
    }

    /// The first emitter, its particles spaced `d`.
    pub(super) fn emitter(&mut self, d: f32) -> Result<Option<crate::sim::scene::Emitter>> {
        let (path, top) = (self.path, self.top);
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
                emitter = Some(crate::sim::scene::Emitter {
                    centre,
                    velocity: q * Vec3::X * speed,
                    half: [0.5 * width * d, 0.5 * height * d],
                    width_axis: q * Vec3::Z,
                    start,
                    end,
                    circle: kind == 1.0,
                    reuse: None,
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
                    self.warn(at(key), "not supported: ignored");
                }
            }
            if list.len() > 1 {
                self.warn(
                    "Emitters".into(),
                    &format!("{} emitters: the first emits, the others are ignored", list.len()),
                );
            }
        }
        Ok(emitter)
    }
}
