//! The `scene.json` of a SPlisHSPlasH simulation (the shared sequences ship one beside their `partio/` folder;
//! `meniscus sim --export` writes one in the same format): the particle radius and the static rigid bodies, so
//! `render` of a cache draws the container it was simulated in (issue #13) and needs no `--radius`.
//!
//! Only what rendering needs is read: `Configuration.particleRadius`, and the `RigidBodies`. Unit boxes
//! (`geometryFile` ending in `UnitBox.obj`, a cube of side 1 centred at the origin) with `translation` and
//! `scale` (rotated ones are skipped with a note): `isWall` bodies are containers, whose back and side walls are
//! drawn (the front is left open for the camera); other boxes are drawn as solid blocks. Any other
//! `geometryFile` is an OBJ mesh (its path relative to the scene.json), placed by `scale`, `rotationAxis` /
//! `rotationAngle` (radians) and `translation` in that order, and drawn as part of the background mesh —
//! `meniscus sim --collider` lists its collider this way.
//! Format: <https://splishsplash.readthedocs.io/en/latest/file_format.html> (SPlisHSPlasH, MIT).
use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// What a `scene.json` says about the rendered scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneJson {
    /// The file it came from.
    pub path: PathBuf,
    /// `Configuration.particleRadius`.
    pub radius: Option<f32>,
    /// `Configuration.dataExportFPS`: the frame rate of the exported sequence.
    pub fps: Option<f32>,
    /// Interiors (lo, hi) of the containers (`isWall` unit boxes).
    pub containers: Vec<(Vec3, Vec3)>,
    /// Solid boxes (lo, hi).
    pub boxes: Vec<(Vec3, Vec3)>,
    /// Other meshes: the OBJ file (resolved against the scene.json's folder) and its placement.
    pub meshes: Vec<SceneMesh>,
    /// The first container's restitution and friction (what a dynamic body's contact with it combines with).
    pub container_contact: (f32, f32),
    /// The first container's box for the rigid bodies' contacts (`collisionObjectType` 2 with its
    /// `collisionObjectScale`), when the file gives one: the shared double dam break's is 3 m high where its
    /// mesh, the water's wall, is 3.1 m.
    pub container_collision: Option<(Vec3, Vec3)>,
    /// Bodies that could not be drawn (a rotated box, a non-finite placement), one line each.
    pub skipped: Vec<String>,
    /// Written by `meniscus sim --export` (so a later export may replace it).
    pub by_meniscus: bool,
    /// The simulation's moving bodies, frame by frame (`meniscus sim --export` of a scene with a dynamic sphere).
    pub tracks: Vec<BodyTrack>,
}

/// A sphere's centre at every exported frame, as `meniscus sim --export` writes it beside the cache (the
/// scene.json's `Meniscus.bodies`, which SPlisHSPlasH ignores), so a render of the cache draws it where it was.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BodyTrack {
    /// Radius (m).
    pub radius: f32,
    /// Centre at frame 1, 2, … (the export's numbers).
    pub centres: Vec<Vec3>,
}

impl BodyTrack {
    /// The centre at `frame` (numbered from 1); the last one past the end, `None` before frame 1.
    pub fn centre_at(&self, frame: u64) -> Option<Vec3> {
        let k = (frame as usize).checked_sub(1)?;
        self.centres.get(k.min(self.centres.len().checked_sub(1)?)).copied()
    }

    /// The spheres (centre, radius) `tracks` place at `frame`, as the background draws them.
    pub fn spheres_at(tracks: &[BodyTrack], frame: u64) -> Vec<(Vec3, f32)> {
        tracks.iter().filter_map(|t| Some((t.centre_at(frame)?, t.radius))).collect()
    }
}

/// A rigid body given as a mesh file.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneMesh {
    /// The OBJ file.
    pub file: PathBuf,
    /// Scale, rotation, then translation: world = translation + rotation · (scale ∘ vertex).
    pub scale: Vec3,
    /// Rotation axis (unit) and angle (radians).
    pub rotation: (Vec3, f32),
    /// Translation.
    pub translation: Vec3,
    /// SPlisHSPlasH's `isDynamic` and the properties it comes with, when set.
    pub dynamic: Option<DynamicProps>,
}

/// A dynamic rigid body's properties in a scene file (`isDynamic` true).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DynamicProps {
    /// `density` (kg/m³; SPlisHSPlasH's default 1000).
    pub density: f32,
    /// `velocity` at the start.
    pub velocity: Vec3,
    /// `restitution` (default 0.6).
    pub restitution: f32,
    /// `friction` (default 0.2).
    pub friction: f32,
    /// The contact sphere's radius (`collisionObjectType` 1: `collisionObjectScale[0]`), when given.
    pub sphere_radius: Option<f32>,
}

impl SceneMesh {
    /// Read the file and place its triangles in the world.
    pub fn load(&self) -> Result<crate::scene::geometry::Geometry> {
        let mut m = crate::scene::geometry::Geometry::load_obj(&self.file)?;
        let q = glam::Quat::from_axis_angle(self.rotation.0, self.rotation.1);
        for t in m.triangles.iter_mut() {
            for v in t.iter_mut() {
                *v = self.translation + q * (self.scale * *v);
            }
        }
        Ok(m)
    }
}

#[derive(Serialize, Deserialize, Default)]
#[serde(rename_all = "camelCase")]
struct Configuration {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    particle_radius: Option<f32>,
    /// Frames written per simulated second: a sequence's own frame rate (a movie's default --fps).
    #[serde(rename = "dataExportFPS", default, skip_serializing_if = "Option::is_none")]
    data_export_fps: Option<f32>,
}

#[derive(Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
struct RigidBody {
    geometry_file: String,
    #[serde(default)]
    translation: [f32; 3],
    #[serde(default = "one3")]
    scale: [f32; 3],
    #[serde(default = "x_axis")]
    rotation_axis: [f32; 3],
    #[serde(default)]
    rotation_angle: f32,
    #[serde(default)]
    is_wall: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    is_dynamic: Option<bool>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    density: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    velocity: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    restitution: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    friction: Option<f32>,
    /// SPlisHSPlasH's contact shape: 1 a sphere of radius `collisionObjectScale[0]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    collision_object_type: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    collision_object_scale: Option<[f32; 3]>,
}

fn one3() -> [f32; 3] {
    [1.0; 3]
}

fn x_axis() -> [f32; 3] {
    [1.0, 0.0, 0.0]
}

#[derive(Serialize, Deserialize)]
struct File {
    #[serde(rename = "Configuration", default)]
    configuration: Configuration,
    #[serde(rename = "RigidBodies", default)]
    rigid_bodies: Vec<RigidBody>,
    /// Set by `write_scene_json` (SPlisHSPlasH ignores unknown keys): such a file may be replaced.
    #[serde(rename = "Meniscus", default, skip_serializing_if = "Option::is_none")]
    meniscus: Option<serde_json::Value>,
}

/// Byte offset of a serde_json error's line and column in `text`.
pub(crate) fn offset_of(text: &str, line: usize, column: usize) -> u64 {
    let start: usize = text.split_inclusive('\n').take(line.saturating_sub(1)).map(str::len).sum();
    (start + column.saturating_sub(1)) as u64
}

/// `Meniscus.bodies` of a scene.json meniscus wrote: [{"radius": r, "centres": [[x, y, z], …]}, …].
fn tracks_of(path: &Path, text: &str, m: &serde_json::Value) -> Result<Vec<BodyTrack>> {
    let Some(list) = m.get("bodies") else { return Ok(vec![]) };
    let wrong = |why: &str| Error::Parse {
        path: path.to_path_buf(),
        offset: text.find("\"bodies\"").unwrap_or(0) as u64,
        reason: format!("Meniscus.bodies: {why}"),
    };
    let list = list.as_array().ok_or_else(|| wrong("not a list"))?;
    list.iter()
        .map(|b| {
            let radius = b.get("radius").and_then(|r| r.as_f64()).filter(|r| r.is_finite() && *r > 0.0);
            let radius = radius.ok_or_else(|| wrong("a body without a positive radius"))? as f32;
            let centres = b.get("centres").and_then(|c| c.as_array()).ok_or_else(|| wrong("a body without centres"))?;
            let centres = centres
                .iter()
                .map(|c| {
                    let v: Option<Vec<f32>> =
                        c.as_array().map(|a| a.iter().filter_map(|x| x.as_f64()).map(|x| x as f32).collect());
                    match v.as_deref() {
                        Some([x, y, z]) if x.is_finite() && y.is_finite() && z.is_finite() => Ok(Vec3::new(*x, *y, *z)),
                        _ => Err(wrong("a centre that is not three finite numbers")),
                    }
                })
                .collect::<Result<Vec<_>>>()?;
            Ok(BodyTrack { radius, centres })
        })
        .collect()
}

impl SceneJson {
    /// Parse `text` (the contents of `path`).
    pub fn parse(path: &Path, text: &str) -> Result<SceneJson> {
        let f: File = serde_json::from_str(text).map_err(|e| Error::Parse {
            path: path.to_path_buf(),
            offset: offset_of(text, e.line(), e.column()),
            reason: e.to_string(),
        })?;
        let mut s = SceneJson {
            path: path.to_path_buf(),
            radius: f.configuration.particle_radius,
            fps: f.configuration.data_export_fps.filter(|f| f.is_finite() && *f > 0.0),
            by_meniscus: f.meniscus.is_some(),
            tracks: f.meniscus.as_ref().map_or(Ok(vec![]), |m| tracks_of(path, text, m))?,
            ..Default::default()
        };
        let dir = path.parent().unwrap_or(Path::new(""));
        for b in &f.rigid_bodies {
            if !b.geometry_file.ends_with("UnitBox.obj") {
                let (t, sc, axis) = (Vec3::from(b.translation), Vec3::from(b.scale), Vec3::from(b.rotation_axis));
                if !(t.is_finite() && sc.is_finite() && b.rotation_angle.is_finite() && axis.length() > 1e-6) {
                    s.skipped.push(format!("{} with a non-finite or degenerate placement", b.geometry_file));
                    continue;
                }
                let dynamic = (b.is_dynamic == Some(true)).then(|| DynamicProps {
                    density: b.density.unwrap_or(1000.0),
                    velocity: Vec3::from(b.velocity.unwrap_or([0.0; 3])),
                    restitution: b.restitution.unwrap_or(0.6),
                    friction: b.friction.unwrap_or(0.2),
                    sphere_radius: match (b.collision_object_type, b.collision_object_scale) {
                        (Some(1), Some(sc)) if sc[0].is_finite() && sc[0] > 0.0 => Some(sc[0]),
                        _ => None,
                    },
                });
                s.meshes.push(SceneMesh {
                    file: dir.join(&b.geometry_file),
                    scale: sc,
                    rotation: (axis.normalize(), b.rotation_angle),
                    translation: t,
                    dynamic,
                });
                continue;
            }
            if b.rotation_angle != 0.0 {
                s.skipped.push(format!(
                    "{} rotated by {} (only axis-aligned boxes are drawn)",
                    b.geometry_file, b.rotation_angle
                ));
                continue;
            }
            let (c, half) = (Vec3::from(b.translation), Vec3::from(b.scale).abs() * 0.5);
            if !(c.is_finite() && half.is_finite()) {
                s.skipped.push(format!("{} with a non-finite translation or scale", b.geometry_file));
                continue;
            }
            if b.is_wall {
                if s.containers.is_empty() {
                    s.container_contact = (b.restitution.unwrap_or(0.6), b.friction.unwrap_or(0.2));
                    // The rigid bodies' contact box (SPlisHSPlasH's collision object, type 2), where it differs.
                    s.container_collision = match (b.collision_object_type, b.collision_object_scale) {
                        (Some(2), Some(sc)) if Vec3::from(sc).is_finite() => {
                            Some((c - Vec3::from(sc).abs() * 0.5, c + Vec3::from(sc).abs() * 0.5))
                        }
                        _ => None,
                    };
                }
                s.containers.push((c - half, c + half));
            } else {
                s.boxes.push((c - half, c + half));
            }
        }
        Ok(s)
    }

    /// Whether `path` is a scene.json that `meniscus sim --export` wrote (so an export may replace it). It is
    /// read to be replaced, not as an input of the run: it is not recorded as one.
    pub fn is_ours(path: &Path) -> bool {
        crate::input::check(path).is_ok()
            && std::fs::read_to_string(path).is_ok_and(|t| SceneJson::parse(path, &t).is_ok_and(|s| s.by_meniscus))
    }

    /// Read and parse `path`.
    pub fn load(path: &Path) -> Result<SceneJson> {
        let text = crate::input::read_text(path)?;
        SceneJson::parse(path, &text)
    }

    /// The `scene.json` that describes the particle file `data`: in its folder or the folder above (the
    /// SPlisHSPlasH layout: `scene.json` beside `partio/` and `vtk/`). `None` when there is none; an error when
    /// there is one that cannot be read.
    pub fn find_for(data: &Path) -> Result<Option<SceneJson>> {
        let dir = data.parent().unwrap_or(Path::new("."));
        for d in [Some(dir), dir.parent()].into_iter().flatten() {
            let p = if d.as_os_str().is_empty() { Path::new("scene.json").to_path_buf() } else { d.join("scene.json") };
            if p.is_file() {
                return SceneJson::load(&p).map(Some);
            }
        }
        Ok(None)
    }

    /// The background boxes: each container's back and side walls (thickness `t`), then the solid boxes.
    pub fn background_boxes(&self, t: f32) -> Vec<(Vec3, Vec3)> {
        let mut b: Vec<_> = self.containers.iter().flat_map(|&(lo, hi)| container_walls(lo, hi, t)).collect();
        b.extend(&self.boxes);
        b
    }

    /// The floor: the lowest container's bottom.
    pub fn floor(&self) -> Option<f32> {
        self.containers.iter().map(|c| c.0.y).reduce(f32::min)
    }
}

/// The back (−z) and side (±x) walls of a container with interior `lo`..`hi`, `t` thick, outside it (the front
/// stays open so a camera in front sees in). The live simulation's tank and `render`'s scene.json use them.
pub fn container_walls(lo: Vec3, hi: Vec3, t: f32) -> [(Vec3, Vec3); 3] {
    [
        (Vec3::new(lo.x - t, lo.y, lo.z - t), Vec3::new(hi.x + t, hi.y, lo.z)),
        (Vec3::new(lo.x - t, lo.y, lo.z), Vec3::new(lo.x, hi.y, hi.z)),
        (Vec3::new(hi.x, lo.y, lo.z), Vec3::new(hi.x + t, hi.y, hi.z)),
    ]
}

/// A `scene.json` in SPlisHSPlasH's format for a cache of particles of `radius` simulated in `container`
/// (interior lo, hi) with solid `boxes` and mesh colliders `meshes` (OBJ files in world coordinates, written
/// as given: pass absolute paths): what `render` reads back.
pub fn write_scene_json(
    path: &Path,
    radius: f32,
    container: (Vec3, Vec3),
    boxes: &[(Vec3, Vec3)],
    meshes: &[PathBuf],
    tracks: &[BodyTrack],
) -> Result<()> {
    let body = |file: String, lo: Vec3, hi: Vec3, wall: bool| RigidBody {
        geometry_file: file,
        translation: ((lo + hi) * 0.5).to_array(),
        scale: (hi - lo).to_array(),
        rotation_axis: x_axis(),
        rotation_angle: 0.0,
        is_wall: wall,
        is_dynamic: Some(false),
        density: None,
        velocity: None,
        restitution: None,
        friction: None,
        collision_object_type: None,
        collision_object_scale: None,
    };
    let unit = || "../models/UnitBox.obj".to_string();
    let mut bodies = vec![body(unit(), container.0, container.1, true)];
    bodies.extend(boxes.iter().map(|&(lo, hi)| body(unit(), lo, hi, false)));
    // A mesh in world coordinates: no translation, unit scale.
    bodies.extend(
        meshes.iter().map(|m| body(m.to_string_lossy().into_owned(), Vec3::splat(-0.5), Vec3::splat(0.5), false)),
    );
    let f = File {
        configuration: Configuration { particle_radius: Some(radius), data_export_fps: None },
        rigid_bodies: bodies,
        meniscus: Some(serde_json::json!({
            "writtenBy": concat!("meniscus ", env!("CARGO_PKG_VERSION")),
            "bodies": tracks.iter().map(|t| serde_json::json!({
                "radius": t.radius,
                "centres": t.centres.iter().map(|c| c.to_array()).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
        })),
    };
    crate::output::write_json(path, &f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_shared_layout_and_round_trips() {
        let text = r#"{"Configuration": {"particleRadius": 0.0125, "timeStepSize": 0.005},
            "RigidBodies": [{"geometryFile": "../models/UnitBox.obj", "translation": [0, 1.5, 0],
            "rotationAxis": [1, 0, 0], "rotationAngle": 0, "scale": [4, 3, 1.5], "isWall": true},
            {"geometryFile": "../models/Dragon.obj"}], "FluidBlocks": []}"#;
        let s = SceneJson::parse(Path::new("scene.json"), text).unwrap();
        assert_eq!(s.radius, Some(0.0125));
        assert_eq!(s.containers, vec![(Vec3::new(-2.0, 0.0, -0.75), Vec3::new(2.0, 3.0, 0.75))]);
        assert!(s.skipped.is_empty());
        assert_eq!(s.meshes.len(), 1, "the dragon is a mesh to load");
        assert_eq!(s.meshes[0].file, Path::new("../models/Dragon.obj"));
        assert_eq!(s.floor(), Some(0.0));
        let dir = std::env::temp_dir().join(format!("meniscus-scene-json-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("scene.json");
        let boxes = [(Vec3::new(-2.0, 0.0, -0.75), Vec3::new(-0.8, 1.2, 0.75))];
        let obj = dir.join("block.obj");
        std::fs::write(&obj, "v 0 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let track = BodyTrack { radius: 0.1, centres: vec![Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.1, 0.9, 0.0)] };
        write_scene_json(&p, 0.01, s.containers[0], &boxes, std::slice::from_ref(&obj), std::slice::from_ref(&track))
            .unwrap();
        let back = SceneJson::find_for(&dir.join("partio").join("f_1.bgeo")).unwrap().unwrap();
        assert_eq!((back.radius, back.containers.clone()), (Some(0.01), s.containers.clone()));
        assert!(back.by_meniscus && !s.by_meniscus);
        let (lo, hi) = back.boxes[0];
        assert!(lo.abs_diff_eq(boxes[0].0, 1e-6) && hi.abs_diff_eq(boxes[0].1, 1e-6), "{:?}", back.boxes);
        // The moving body's track: frame 1 first, the last centre past the end, none before frame 1.
        assert_eq!(back.tracks, vec![track.clone()]);
        assert_eq!(
            (track.centre_at(0), track.centre_at(1), track.centre_at(2), track.centre_at(9)),
            (None, Some(Vec3::Y), Some(Vec3::new(0.1, 0.9, 0.0)), Some(Vec3::new(0.1, 0.9, 0.0)))
        );
        // A track that is not one is an error naming the key.
        let e = SceneJson::parse(&p, r#"{"Meniscus": {"bodies": [{"radius": 0.1, "centres": [[0, 1]]}]}}"#);
        assert!(e.unwrap_err().to_string().contains("Meniscus.bodies"));
        // The mesh comes back where it was (identity placement).
        let m = back.meshes[0].load().unwrap();
        assert_eq!(m.triangles, vec![[Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::Y]]);
        // Scale, then rotate (a quarter turn about y), then translate.
        let placed = SceneMesh {
            file: obj.clone(),
            scale: Vec3::splat(2.0),
            rotation: (Vec3::Y, std::f32::consts::FRAC_PI_2),
            translation: Vec3::new(0.0, 1.0, 0.0),
            dynamic: None,
        };
        let t = placed.load().unwrap().triangles[0];
        assert!(t[1].abs_diff_eq(Vec3::new(0.0, 1.0, -4.0), 1e-5), "{t:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_broken_file_names_the_byte() {
        let e = SceneJson::parse(Path::new("s/scene.json"), "{\n  \"RigidBodies\": [1,]\n}").unwrap_err().to_string();
        // Line 2, column 19 (the `1`): 2 + 18 bytes in.
        assert!(e.contains("s/scene.json") && e.contains("byte 20"), "{e}");
    }
}
