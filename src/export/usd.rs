//! USD writer: a fluid surface sequence as one stage (`meniscus mesh SEQ --out water.usd`) — one `UsdGeomMesh`
//! (`/water/surface`) whose points, normals, per-vertex velocities (the SPH-interpolated particle velocity, for
//! motion blur), faces and extent are time-sampled at the frames' numbers, and optionally the diffuse particles
//! as a `UsdGeomPoints` (`/water/diffuse`: widths, velocities and an int `primvars:kind`, 0 foam, 1 spray,
//! 2 bubbles, the numbers of `meniscus foam`'s files). The stage states `timeCodesPerSecond` (the sequence's
//! fps), `metersPerUnit` and `upAxis` (Y). The mesh changes topology every frame, so its faces are time-sampled
//! too (USD allows it; renderers then take motion blur from `velocities`).
//!
//! Two encodings of the same stage, by the extension: `.usdc` and `.usd` the binary crate format
//! (`crate::export::usdc`: each frame's arrays appended to the file as they come, the stage's structure written
//! at the end — about the PLY's bytes and time), `.usda` text (human-readable, about 10× larger: each
//! attribute's samples are spooled to a scratch file beside the output, numbers formatted in parallel, and
//! assembled at the end). Written by hand: the Rust USD crates need a newer toolchain than this project's
//! (openusd 0.8 needs Rust 1.96) or only read. Either way the stage appears whole or not at all
//! (`crate::output`'s partial files), and usd-core opens both in the Python tests.

use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::output::{FileKind, Partial};

/// The diffuse particles of one frame for [`UsdWriter::add_points`].
pub struct PointsFrame<'a> {
    /// Positions.
    pub positions: &'a [[f32; 3]],
    /// Velocities.
    pub velocities: &'a [[f32; 3]],
    /// Diameters.
    pub widths: &'a [f32],
    /// Kinds: 0 foam, 1 spray, 2 bubbles.
    pub kinds: &'a [i32],
}

/// One frame's value of a time-sampled attribute.
pub(crate) enum Sample<'a> {
    Vec3(&'a [[f32; 3]]),
    Int(&'a [i32]),
    Float(&'a [f32]),
}

/// A time-sampled attribute of the stage: its prim (0 `surface`, 1 `diffuse`), name, USD type and
/// interpolation metadata.
pub(crate) struct Attr {
    pub(crate) prim: usize,
    pub(crate) name: &'static str,
    pub(crate) type_name: &'static str,
    pub(crate) interpolation: Option<&'static str>,
}

/// The stage's prims under `/water`: name and schema.
pub(crate) const PRIMS: [(&str, &str); 2] = [("surface", "Mesh"), ("diffuse", "Points")];

/// Every time-sampled attribute, mesh first (the order [`UsdWriter::add_mesh`] and `add_points` give samples in).
pub(crate) const ATTRS: [Attr; 11] = [
    Attr { prim: 0, name: "extent", type_name: "float3[]", interpolation: None },
    Attr { prim: 0, name: "faceVertexCounts", type_name: "int[]", interpolation: None },
    Attr { prim: 0, name: "faceVertexIndices", type_name: "int[]", interpolation: None },
    Attr { prim: 0, name: "points", type_name: "point3f[]", interpolation: None },
    Attr { prim: 0, name: "normals", type_name: "normal3f[]", interpolation: Some("vertex") },
    Attr { prim: 0, name: "velocities", type_name: "vector3f[]", interpolation: None },
    Attr { prim: 1, name: "extent", type_name: "float3[]", interpolation: None },
    Attr { prim: 1, name: "points", type_name: "point3f[]", interpolation: None },
    Attr { prim: 1, name: "widths", type_name: "float[]", interpolation: Some("vertex") },
    Attr { prim: 1, name: "velocities", type_name: "vector3f[]", interpolation: None },
    Attr { prim: 1, name: "primvars:kind", type_name: "int[]", interpolation: Some("vertex") },
];
/// Where the diffuse prim's attributes start in [`ATTRS`].
const POINTS_FROM: usize = 6;

/// The mesh's uniform (untimed) attributes: name, USD type, value.
pub(crate) enum Uniform {
    Token(&'static str),
    Bool(bool),
}
pub(crate) const MESH_UNIFORMS: [(&str, &str, Uniform); 3] = [
    ("doubleSided", "bool", Uniform::Bool(false)),
    ("orientation", "token", Uniform::Token("rightHanded")),
    ("subdivisionScheme", "token", Uniform::Token("none")),
];

/// The stage's metadata.
pub(crate) struct StageInfo {
    pub(crate) fps: f64,
    pub(crate) meters_per_unit: f64,
    pub(crate) start: f64,
    pub(crate) end: f64,
    pub(crate) doc: String,
    pub(crate) points: bool,
}

/// How the stage is encoded.
enum Encoder {
    Text(TextSpools),
    Crate(Box<crate::export::usdc::CrateWriter>),
}

/// A stage being written; frames are added in time order, then [`UsdWriter::finish`].
pub struct UsdWriter {
    path: PathBuf,
    info: StageInfo,
    enc: Encoder,
    times: Vec<f64>,
}

/// The [`ATTRS`] index range of a prim.
fn attrs_of(prim: usize) -> std::ops::Range<usize> {
    if prim == 0 {
        0..POINTS_FROM
    } else {
        POINTS_FROM..ATTRS.len()
    }
}

/// The bounding box of points as USD's extent, [(lo), (hi)] ([0, 0] for none).
fn extent(v: &[[f32; 3]]) -> [[f32; 3]; 2] {
    if v.is_empty() {
        return [[0.0; 3]; 2];
    }
    v.par_iter()
        .fold(
            || [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]],
            |[mut a, mut b], p| {
                for k in 0..3 {
                    a[k] = a[k].min(p[k]);
                    b[k] = b[k].max(p[k]);
                }
                [a, b]
            },
        )
        .reduce(
            || [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]],
            |[a, b], [c, d]| [std::array::from_fn(|k| a[k].min(c[k])), std::array::from_fn(|k| b[k].max(d[k]))],
        )
}

impl UsdWriter {
    /// Begin a stage at `path` (`.usd`/`.usdc` binary, `.usda` text; the output checks of `crate::output`),
    /// `fps` frames per second (time codes are frame numbers), with a diffuse-particle prim when `points`.
    pub fn create(path: &Path, fps: f64, meters_per_unit: f64, points: bool, comment: &str) -> Result<UsdWriter> {
        crate::output::check_output(path, FileKind::Usd)?;
        if !(fps.is_finite() && fps > 0.0) {
            return Err(Error::Output {
                path: path.into(),
                reason: format!("the frame rate must be positive ({fps})"),
            });
        }
        if !(meters_per_unit.is_finite() && meters_per_unit > 0.0) {
            return Err(Error::Output {
                path: path.into(),
                reason: format!("metersPerUnit must be positive ({meters_per_unit})"),
            });
        }
        let text = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("usda"));
        let enc = if text {
            Encoder::Text(TextSpools::create(path, points)?)
        } else {
            Encoder::Crate(Box::new(crate::export::usdc::CrateWriter::create(path)?))
        };
        let info = StageInfo {
            fps,
            meters_per_unit,
            start: 0.0,
            end: 0.0,
            doc: comment.replace(['"', '\\', '\n'], " "),
            points,
        };
        Ok(UsdWriter { path: path.to_path_buf(), info, enc, times: vec![] })
    }

    fn sample(&mut self, attr: usize, time: f64, s: Sample) -> Result<()> {
        match &mut self.enc {
            Encoder::Text(t) => t.sample(&self.path, attr, time, s),
            Encoder::Crate(c) => c.sample(attr, time, s),
        }
    }

    /// Add the surface at `time` (a frame number; increasing): vertices, normals, triangles (counter-clockwise
    /// seen from outside) and per-vertex velocities (zero where the input had none).
    pub fn add_mesh(
        &mut self,
        time: f64,
        vertices: &[[f32; 3]],
        normals: &[[f32; 3]],
        triangles: &[[u32; 3]],
        velocities: &[[f32; 3]],
    ) -> Result<()> {
        if self.times.last().is_some_and(|&t| t >= time) || !time.is_finite() {
            return Err(Error::Output {
                path: self.path.clone(),
                reason: format!("time samples must increase ({time} after {})", self.times.last().unwrap_or(&0.0)),
            });
        }
        if triangles.iter().flatten().any(|&i| i as usize >= vertices.len()) || triangles.len() > i32::MAX as usize {
            return Err(Error::Output {
                path: self.path.clone(),
                reason: "a triangle's vertex is out of range".into(),
            });
        }
        let counts = vec![3i32; triangles.len()];
        self.sample(0, time, Sample::Vec3(&extent(vertices)))?;
        self.sample(1, time, Sample::Int(&counts))?;
        self.sample(2, time, Sample::Int(bytemuck::cast_slice::<[u32; 3], i32>(triangles)))?;
        self.sample(3, time, Sample::Vec3(vertices))?;
        self.sample(4, time, Sample::Vec3(normals))?;
        self.sample(5, time, Sample::Vec3(velocities))?;
        self.times.push(time);
        Ok(())
    }

    /// Add the diffuse particles at `time` (the same time as the frame's mesh; after it).
    pub fn add_points(&mut self, time: f64, p: &PointsFrame) -> Result<()> {
        if !self.info.points {
            return Ok(());
        }
        let n = p.positions.len();
        if p.velocities.len() != n || p.widths.len() != n || p.kinds.len() != n {
            return Err(Error::Output {
                path: self.path.clone(),
                reason: "diffuse arrays of different lengths".into(),
            });
        }
        let at = POINTS_FROM;
        self.sample(at, time, Sample::Vec3(&extent(p.positions)))?;
        self.sample(at + 1, time, Sample::Vec3(p.positions))?;
        self.sample(at + 2, time, Sample::Float(p.widths))?;
        self.sample(at + 3, time, Sample::Vec3(p.velocities))?;
        self.sample(at + 4, time, Sample::Int(p.kinds))
    }

    /// Write the stage's structure (and, for text, assemble the spooled samples) and rename it into place.
    pub fn finish(self) -> Result<()> {
        let UsdWriter { path, mut info, enc, times } = self;
        info.start = times.first().copied().unwrap_or(0.0);
        info.end = times.last().copied().unwrap_or(0.0);
        match enc {
            Encoder::Text(t) => t.finish(&path, &info),
            Encoder::Crate(c) => c.finish(&info),
        }
    }
}

// ---- USDA text ----

/// One spooled attribute: its scratch file and the writer into it.
struct Spool {
    file: Partial,
    out: BufWriter<File>,
}

/// The text encoder: a scratch file of samples per attribute.
struct TextSpools {
    spools: Vec<Option<Spool>>,
}

/// Numbers per parallel formatting chunk.
const CHUNK: usize = 1 << 15;

fn fmt_f32(s: &mut String, x: f32) {
    let x = if x.is_finite() { x } else { 0.0 };
    let _ = write!(s, "{x}");
}

/// `[a, b, c]` from chunks each ending in ", ".
fn bracket(parts: Vec<String>) -> String {
    let mut s = String::with_capacity(parts.iter().map(String::len).sum::<usize>() + 2);
    s.push('[');
    for p in parts {
        s.push_str(&p);
    }
    if s.ends_with(", ") {
        s.truncate(s.len() - 2);
    }
    s.push(']');
    s
}

/// A sample as USDA, formatted in parallel chunks.
fn usda_value(v: &Sample) -> String {
    let parts: Vec<String> = match v {
        Sample::Vec3(a) => a
            .par_chunks(CHUNK)
            .map(|c| {
                let mut s = String::with_capacity(c.len() * 36);
                for p in c {
                    s.push('(');
                    fmt_f32(&mut s, p[0]);
                    s.push_str(", ");
                    fmt_f32(&mut s, p[1]);
                    s.push_str(", ");
                    fmt_f32(&mut s, p[2]);
                    s.push_str("), ");
                }
                s
            })
            .collect(),
        Sample::Float(a) => a
            .par_chunks(CHUNK)
            .map(|c| {
                let mut s = String::with_capacity(c.len() * 12);
                for &x in c {
                    fmt_f32(&mut s, x);
                    s.push_str(", ");
                }
                s
            })
            .collect(),
        Sample::Int(a) => a
            .par_chunks(CHUNK)
            .map(|c| {
                let mut s = String::with_capacity(c.len() * 9);
                for x in c {
                    let _ = write!(s, "{x}, ");
                }
                s
            })
            .collect(),
    };
    bracket(parts)
}

/// A time code as USDA writes it.
fn time_code(t: f64) -> String {
    if t.fract() == 0.0 && t.abs() < 1e15 {
        format!("{}", t as i64)
    } else {
        format!("{t}")
    }
}

impl TextSpools {
    fn create(path: &Path, points: bool) -> Result<TextSpools> {
        let spools = ATTRS
            .iter()
            .enumerate()
            .map(|(i, a)| {
                if i >= POINTS_FROM && !points {
                    return Ok(None);
                }
                let tag = format!("{}-{}", PRIMS[a.prim].0, a.name.replace(':', "-"));
                let file = Partial::scratch(path, &tag)?;
                let out =
                    BufWriter::with_capacity(1 << 20, File::create(file.tmp()).map_err(|e| Error::io(file.tmp(), e))?);
                Ok(Some(Spool { file, out }))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(TextSpools { spools })
    }

    fn sample(&mut self, path: &Path, attr: usize, time: f64, v: Sample) -> Result<()> {
        let Some(s) = self.spools[attr].as_mut() else { return Ok(()) };
        let text = usda_value(&v);
        (|| -> std::io::Result<()> {
            write!(s.out, "            {}: ", time_code(time))?;
            s.out.write_all(text.as_bytes())?;
            s.out.write_all(b",\n")
        })()
        .map_err(|e| Error::io(path, e))
    }

    fn finish(self, path: &Path, info: &StageInfo) -> Result<()> {
        let partial = Partial::begin(path, FileKind::Usd)?;
        let mut spools = self.spools;
        let res = (|| -> std::io::Result<()> {
            let mut w = BufWriter::with_capacity(1 << 20, File::create(partial.tmp())?);
            write!(
                w,
                "#usda 1.0\n(\n    defaultPrim = \"water\"\n    doc = \"{}\"\n    endTimeCode = {}\n    \
                 framesPerSecond = {}\n    metersPerUnit = {}\n    startTimeCode = {}\n    \
                 timeCodesPerSecond = {}\n    upAxis = \"Y\"\n)\n\ndef Xform \"water\" (\n    kind = \"component\"\n)\n{{\n",
                info.doc,
                time_code(info.end),
                info.fps,
                info.meters_per_unit,
                time_code(info.start),
                info.fps
            )?;
            for (p, (name, schema)) in PRIMS.iter().enumerate() {
                if p == 1 && !info.points {
                    continue;
                }
                write!(w, "    def {schema} \"{name}\"\n    {{\n")?;
                if p == 0 {
                    for (n, ty, v) in &MESH_UNIFORMS {
                        match v {
                            Uniform::Bool(b) => writeln!(w, "        uniform {ty} {n} = {}", u8::from(*b))?,
                            Uniform::Token(t) => writeln!(w, "        uniform {ty} {n} = \"{t}\"")?,
                        }
                    }
                }
                for i in attrs_of(p) {
                    let a = &ATTRS[i];
                    let Some(Spool { file, out }) = spools[i].take() else { continue };
                    out.into_inner().map_err(|e| e.into_error())?;
                    if let Some(interp) = a.interpolation {
                        write!(
                            w,
                            "        {} {} (\n            interpolation = \"{interp}\"\n        )\n",
                            a.type_name, a.name
                        )?;
                    }
                    writeln!(w, "        {} {}.timeSamples = {{", a.type_name, a.name)?;
                    let mut f = File::open(file.tmp())?;
                    let mut buf = vec![0u8; 1 << 20];
                    loop {
                        let n = f.read(&mut buf)?;
                        if n == 0 {
                            break;
                        }
                        w.write_all(&buf[..n])?;
                    }
                    w.write_all(b"        }\n")?;
                }
                w.write_all(b"    }\n")?;
            }
            w.write_all(b"}\n")?;
            w.flush()?;
            w.into_inner().map_err(|e| e.into_error())?.sync_all()
        })();
        res.map_err(|e| Error::io(path, e))?;
        partial.commit()
    }
}
