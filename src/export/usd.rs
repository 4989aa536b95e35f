//! USD writer: a fluid surface sequence as one stage (`meniscus mesh SEQ --out water.usda`) — one `UsdGeomMesh`
//! (`/water/surface`) whose points, normals, per-vertex velocities (the SPH-interpolated particle velocity, for
//! motion blur), faces and extent are time-sampled at the frames' numbers, and optionally the diffuse particles
//! as a `UsdGeomPoints` (`/water/diffuse`: widths, velocities and an int `primvars:kind`, 0 foam, 1 spray,
//! 2 bubbles, the numbers of `meniscus foam`'s files); `timeCodesPerSecond` = the sequence's fps, `metersPerUnit` and `upAxis` (Y) stated.
//!
//! USDA (text), written by hand: the Rust USD crates need a newer toolchain than this project's (openusd 0.x
//! needs Rust 1.96) or only read, and the text form is the one every USD reader takes (usdcat converts it to
//! the binary crate form). The mesh changes topology every frame, so faces are time-sampled too (USD allows
//! it; renderers then take motion blur from `velocities`, not from points of neighbouring samples).
//!
//! A stage holds every frame, but a frame's mesh is made after the previous one's: each attribute's samples
//! are spooled to a scratch file beside the output as the frames come (numbers formatted in parallel), and
//! [`UsdWriter::finish`] assembles the stage from them and renames it into place — never a half-written stage.

use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::output::{Kind, Partial};

/// One time-sampled attribute: its declaration (`point3f[] points`), the metadata block (e.g. interpolation)
/// and the scratch file its samples go to.
struct Spool {
    decl: &'static str,
    meta: &'static str,
    file: Partial,
    out: BufWriter<File>,
}

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

/// A stage being written; frames are added in time order, then [`UsdWriter::finish`].
pub struct UsdWriter {
    path: PathBuf,
    fps: f64,
    meters_per_unit: f64,
    mesh: Vec<Spool>,
    points: Vec<Spool>,
    times: Vec<f64>,
    comment: String,
}

const MESH_ATTRS: [(&str, &str); 6] = [
    ("float3[] extent", ""),
    ("int[] faceVertexCounts", ""),
    ("int[] faceVertexIndices", ""),
    ("point3f[] points", ""),
    ("normal3f[] normals", "interpolation = \"vertex\""),
    ("vector3f[] velocities", ""),
];
const POINTS_ATTRS: [(&str, &str); 5] = [
    ("float3[] extent", ""),
    ("point3f[] points", ""),
    ("float[] widths", "interpolation = \"vertex\""),
    ("vector3f[] velocities", ""),
    ("int[] primvars:kind", "interpolation = \"vertex\""),
];

/// Numbers per parallel formatting chunk.
const CHUNK: usize = 1 << 15;

fn fmt_f32(s: &mut String, x: f32) {
    let x = if x.is_finite() { x } else { 0.0 };
    let _ = write!(s, "{x}");
}

/// `[(x, y, z), …]`, formatted in parallel.
fn vec3s(v: &[[f32; 3]]) -> String {
    let parts: Vec<String> = v
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
        .collect();
    bracket(parts)
}

fn floats(v: &[f32]) -> String {
    let parts: Vec<String> = v
        .par_chunks(CHUNK)
        .map(|c| {
            let mut s = String::with_capacity(c.len() * 12);
            for &x in c {
                fmt_f32(&mut s, x);
                s.push_str(", ");
            }
            s
        })
        .collect();
    bracket(parts)
}

fn ints<T: std::fmt::Display + Sync>(v: &[T]) -> String {
    let parts: Vec<String> = v
        .par_chunks(CHUNK)
        .map(|c| {
            let mut s = String::with_capacity(c.len() * 9);
            for x in c {
                let _ = write!(s, "{x}, ");
            }
            s
        })
        .collect();
    bracket(parts)
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

fn extent(v: &[[f32; 3]]) -> String {
    let (lo, hi) = v.iter().fold(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), |(mut a, mut b), p| {
        for k in 0..3 {
            a[k] = a[k].min(p[k]);
            b[k] = b[k].max(p[k]);
        }
        (a, b)
    });
    if v.is_empty() {
        vec3s(&[[0.0; 3], [0.0; 3]])
    } else {
        vec3s(&[lo, hi])
    }
}

/// A time code as USDA writes it.
fn time_code(t: f64) -> String {
    if t.fract() == 0.0 && t.abs() < 1e15 {
        format!("{}", t as i64)
    } else {
        format!("{t}")
    }
}

impl UsdWriter {
    /// Begin a stage at `path` (`.usda` or `.usd`; the output checks of `crate::output`), `fps` frames per
    /// second (time codes are frame numbers), with a diffuse-particle prim when `points`.
    pub fn create(path: &Path, fps: f64, meters_per_unit: f64, points: bool, comment: &str) -> Result<UsdWriter> {
        crate::output::check_output(path, Kind::Usd)?;
        if !(fps.is_finite() && fps > 0.0) {
            return Err(Error::Output { path: path.into(), reason: format!("the frame rate must be positive ({fps})") });
        }
        let spools = |attrs: &[(&'static str, &'static str)], prim: &str| -> Result<Vec<Spool>> {
            attrs
                .iter()
                .map(|&(decl, meta)| {
                    let tag = format!("{prim}-{}", decl.rsplit(' ').next().unwrap_or(decl).replace(':', "-"));
                    let file = Partial::scratch(path, &tag)?;
                    let out = BufWriter::with_capacity(
                        1 << 20,
                        File::create(file.tmp()).map_err(|e| Error::io(file.tmp(), e))?,
                    );
                    Ok(Spool { decl, meta, file, out })
                })
                .collect()
        };
        Ok(UsdWriter {
            path: path.to_path_buf(),
            fps,
            meters_per_unit,
            mesh: spools(&MESH_ATTRS, "surface")?,
            points: if points { spools(&POINTS_ATTRS, "diffuse")? } else { vec![] },
            times: vec![],
            comment: comment.replace(['"', '\\', '\n'], " "),
        })
    }

    fn put(&self, spools: &mut [Spool], time: f64, values: Vec<String>) -> Result<()> {
        let t = time_code(time);
        for (s, v) in spools.iter_mut().zip(values) {
            (|| -> std::io::Result<()> {
                s.out.write_all(b"            ")?;
                s.out.write_all(t.as_bytes())?;
                s.out.write_all(b": ")?;
                s.out.write_all(v.as_bytes())?;
                s.out.write_all(b",\n")
            })()
            .map_err(|e| Error::io(&self.path, e))?;
        }
        Ok(())
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
        if self.times.last().is_some_and(|&t| t >= time) {
            return Err(Error::Output {
                path: self.path.clone(),
                reason: format!("time samples must increase ({time} after {})", self.times.last().unwrap_or(&0.0)),
            });
        }
        let values = vec![
            extent(vertices),
            ints(&vec![3u8; triangles.len()]),
            ints(bytemuck::cast_slice::<[u32; 3], u32>(triangles)),
            vec3s(vertices),
            vec3s(normals),
            vec3s(velocities),
        ];
        let mut mesh = std::mem::take(&mut self.mesh);
        let r = self.put(&mut mesh, time, values);
        self.mesh = mesh;
        r?;
        self.times.push(time);
        Ok(())
    }

    /// Add the diffuse particles at `time` (the same time as the frame's mesh; after it).
    pub fn add_points(&mut self, time: f64, p: &PointsFrame) -> Result<()> {
        if self.points.is_empty() {
            return Ok(());
        }
        let values = vec![
            extent(p.positions),
            vec3s(p.positions),
            floats(p.widths),
            vec3s(p.velocities),
            ints(p.kinds),
        ];
        let mut points = std::mem::take(&mut self.points);
        let r = self.put(&mut points, time, values);
        self.points = points;
        r
    }

    /// Assemble the stage from the spooled samples and rename it into place; the scratch files go.
    pub fn finish(self) -> Result<()> {
        let path = self.path.clone();
        let partial = Partial::begin(&path, Kind::Usd)?;
        let (start, end) = (self.times.first().copied().unwrap_or(0.0), self.times.last().copied().unwrap_or(0.0));
        let res = (|| -> std::io::Result<()> {
            let mut w = BufWriter::with_capacity(1 << 20, File::create(partial.tmp())?);
            write!(
                w,
                "#usda 1.0\n(\n    defaultPrim = \"water\"\n    doc = \"{}\"\n    endTimeCode = {}\n    \
                 framesPerSecond = {}\n    metersPerUnit = {}\n    startTimeCode = {}\n    \
                 timeCodesPerSecond = {}\n    upAxis = \"Y\"\n)\n\ndef Xform \"water\" (\n    kind = \"component\"\n)\n{{\n",
                self.comment,
                time_code(end),
                self.fps,
                self.meters_per_unit,
                time_code(start),
                self.fps
            )?;
            let prim = |w: &mut BufWriter<File>, ty: &str, name: &str, spools: Vec<Spool>, extra: &str| {
                write!(w, "    def {ty} \"{name}\"\n    {{\n{extra}")?;
                for s in spools {
                    let Spool { decl, meta, file, out } = s;
                    out.into_inner().map_err(|e| e.into_error())?;
                    if !meta.is_empty() {
                        write!(w, "        {decl} (\n            {meta}\n        )\n")?;
                    }
                    write!(w, "        {decl}.timeSamples = {{\n")?;
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
                    drop(file);
                }
                w.write_all(b"    }\n")
            };
            let UsdWriter { mesh, points, .. } = self;
            prim(
                &mut w,
                "Mesh",
                "surface",
                mesh,
                "        uniform bool doubleSided = 0\n        uniform token orientation = \"rightHanded\"\n        \
                 uniform token subdivisionScheme = \"none\"\n",
            )?;
            if !points.is_empty() {
                prim(&mut w, "Points", "diffuse", points, "")?;
            }
            w.write_all(b"}\n")?;
            w.flush()?;
            w.into_inner().map_err(|e| e.into_error())?.sync_all()
        })();
        res.map_err(|e| Error::io(&path, e))?;
        partial.commit()
    }
}
