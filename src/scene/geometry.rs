//! A background mesh from an OBJ file (`--background-obj`): the parser, a bounding volume hierarchy the
//! `background` pass walks on the GPU (shaders_glsl/background.comp), and a brute-force CPU intersection the
//! tests hold the traversal to.
//!
//! OBJ: `v x y z` and `f` with `i`, `i/t`, `i//n`, `i/t/n` (1-based, negative = relative); polygons are
//! fan-triangulated; everything else (normals, texture coordinates, groups, materials) is ignored. Errors
//! name the file, the byte offset of the line and the reason. BVH: binary, split at the median centroid on
//! the longest axis, leaves of at most 4 triangles (a plain, well-known build; fine for background meshes).

use std::path::Path;

use glam::Vec3;

use crate::error::{Error, Result};

/// Leaf size of the BVH.
const LEAF: usize = 4;
/// Depth bound of the BVH (the shader's traversal stack holds this many entries).
pub const MAX_DEPTH: usize = 32;

/// Triangles in world space.
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    /// The triangles, as three corners each (world).
    pub triangles: Vec<[Vec3; 3]>,
}

impl Geometry {
    /// An axis-aligned box lo..hi as 12 triangles (tests and examples).
    pub fn cuboid(lo: Vec3, hi: Vec3) -> Geometry {
        let c = |i: usize| Vec3::new([lo.x, hi.x][i & 1], [lo.y, hi.y][(i >> 1) & 1], [lo.z, hi.z][i >> 2]);
        let quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
        let triangles = quads.iter().flat_map(|q| [[c(q[0]), c(q[1]), c(q[2])], [c(q[0]), c(q[2]), c(q[3])]]).collect();
        Geometry { triangles }
    }

    /// The corners of the box around every triangle (lo > hi without triangles).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.triangles
            .iter()
            .flatten()
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), v| (lo.min(*v), hi.max(*v)))
    }

    /// Read an OBJ file.
    pub fn load_obj(path: &Path) -> Result<Geometry> {
        let bytes = crate::input::read(path)?;
        Geometry::parse_obj(&bytes).map_err(|(offset, reason)| Error::Parse {
            path: path.to_path_buf(),
            offset,
            reason,
        })
    }

    /// Read a triangle mesh: OBJ, or PLY (ASCII or binary little-endian; `vertex` x y z as float or double,
    /// `face` a list of vertex indices, polygons fanned) as `meniscus mesh` and splashsurf write it.
    pub fn load_mesh(path: &Path) -> Result<Geometry> {
        let bytes = crate::input::read(path)?;
        let parsed = if bytes.starts_with(b"ply") { Geometry::parse_ply(&bytes) } else { Geometry::parse_obj(&bytes) };
        parsed.map_err(|(offset, reason)| Error::Parse { path: path.to_path_buf(), offset, reason })
    }

    /// Parse a PLY mesh; errors are (byte offset, reason).
    pub fn parse_ply(bytes: &[u8]) -> std::result::Result<Geometry, (u64, String)> {
        let end =
            bytes.windows(11).position(|w| w == b"end_header\n").ok_or((0, "no end_header line".to_string()))? + 11;
        let header = std::str::from_utf8(&bytes[..end]).map_err(|_| (0, "the header is not text".to_string()))?;
        let (mut format, mut element) = ("", "");
        let (mut nv, mut nf) = (0usize, 0usize);
        // Vertex properties (name, size in bytes); the face list's count and index sizes.
        let mut vprops: Vec<(String, usize)> = vec![];
        let mut list = (1usize, 4usize);
        let size = |t: &str| match t {
            "char" | "uchar" | "int8" | "uint8" => Some(1),
            "short" | "ushort" | "int16" | "uint16" => Some(2),
            "int" | "uint" | "float" | "int32" | "uint32" | "float32" => Some(4),
            "double" | "float64" => Some(8),
            _ => None,
        };
        let mut offset = 0u64;
        for line in header.lines() {
            let at = offset;
            offset += line.len() as u64 + 1;
            let w: Vec<&str> = line.split_whitespace().collect();
            let bad = |why: &str| (at, format!("{why}: {line:?}"));
            match w.as_slice() {
                ["format", f, ..] => format = f,
                ["element", e, n] => {
                    element = e;
                    let n: usize = n.parse().map_err(|_| bad("bad element count"))?;
                    match *e {
                        "vertex" => nv = n,
                        "face" => nf = n,
                        _ if n > 0 => return Err(bad("only vertex and face elements are read")),
                        _ => {}
                    }
                }
                ["property", "list", c, i, _] if element == "face" => {
                    list = (size(c).ok_or_else(|| bad("unknown type"))?, size(i).ok_or_else(|| bad("unknown type"))?);
                }
                ["property", t, name] if element == "vertex" => {
                    vprops.push((name.to_string(), size(t).ok_or_else(|| bad("unknown type"))?));
                }
                _ => {}
            }
        }
        let find = |n: &str| vprops.iter().position(|(p, _)| p == n);
        let (Some(ix), Some(iy), Some(iz)) = (find("x"), find("y"), find("z")) else {
            return Err((0, "the vertex element has no x, y and z".to_string()));
        };
        let body = &bytes[end..];
        let mut verts = Vec::with_capacity(nv.min(body.len()));
        let mut triangles = vec![];
        let short = |at: usize| ((end + at) as u64, "the file ends inside its body".to_string());
        match format {
            "ascii" => {
                let text = std::str::from_utf8(body).map_err(|_| (end as u64, "the body is not text".to_string()))?;
                let mut nums = text.split_whitespace();
                let mut next = || nums.next().and_then(|t| t.parse::<f64>().ok());
                for _ in 0..nv {
                    let v: Vec<f64> =
                        (0..vprops.len()).map(|_| next()).collect::<Option<_>>().ok_or_else(|| short(0))?;
                    verts.push(Vec3::new(v[ix] as f32, v[iy] as f32, v[iz] as f32));
                }
                for _ in 0..nf {
                    let k = next().ok_or_else(|| short(0))? as usize;
                    let idx: Vec<f64> = (0..k).map(|_| next()).collect::<Option<_>>().ok_or_else(|| short(0))?;
                    fan(&verts, &idx.iter().map(|&i| i as usize).collect::<Vec<_>>(), &mut triangles)
                        .ok_or((end as u64, "a face names a vertex past the vertex count".to_string()))?;
                }
            }
            "binary_little_endian" => {
                let read = |at: usize, n: usize, float: bool| -> Option<f64> {
                    let b = body.get(at..at + n)?;
                    Some(match (n, float) {
                        (1, _) => b[0] as f64,
                        (2, _) => u16::from_le_bytes([b[0], b[1]]) as f64,
                        (4, true) => f32::from_le_bytes(b.try_into().ok()?) as f64,
                        (4, false) => u32::from_le_bytes(b.try_into().ok()?) as f64,
                        (8, _) => f64::from_le_bytes(b.try_into().ok()?),
                        _ => return None,
                    })
                };
                let stride: usize = vprops.iter().map(|p| p.1).sum();
                let at_of = |k: usize| vprops[..k].iter().map(|p| p.1).sum::<usize>();
                let (ox, oy, oz) = (at_of(ix), at_of(iy), at_of(iz));
                let fsize = vprops[ix].1;
                for v in 0..nv {
                    let b = v * stride;
                    let c = |o: usize| read(b + o, fsize, true).ok_or_else(|| short(b));
                    verts.push(Vec3::new(c(ox)? as f32, c(oy)? as f32, c(oz)? as f32));
                }
                let mut at = nv * stride;
                for _ in 0..nf {
                    let k = read(at, list.0, false).ok_or_else(|| short(at))? as usize;
                    at += list.0;
                    let idx: Vec<usize> = (0..k)
                        .map(|j| read(at + j * list.1, list.1, false).map(|i| i as usize))
                        .collect::<Option<_>>()
                        .ok_or_else(|| short(at))?;
                    at += k * list.1;
                    fan(&verts, &idx, &mut triangles)
                        .ok_or(((end + at) as u64, "a face names a vertex past the vertex count".to_string()))?;
                }
            }
            f => return Err((0, format!("PLY format {f:?}: ascii or binary_little_endian are read"))),
        }
        if triangles.is_empty() {
            return Err((0, "no faces".to_string()));
        }
        Ok(Geometry { triangles })
    }

    /// Parse OBJ text; errors are (byte offset, reason).
    pub fn parse_obj(bytes: &[u8]) -> std::result::Result<Geometry, (u64, String)> {
        let text = std::str::from_utf8(bytes).map_err(|e| (e.valid_up_to() as u64, "not UTF-8 text".to_string()))?;
        let mut verts: Vec<Vec3> = vec![];
        let mut triangles = vec![];
        let mut offset = 0u64;
        for line in text.split_inclusive('\n') {
            let at = offset;
            offset += line.len() as u64;
            let line = line.split('#').next().unwrap_or("").trim();
            let mut it = line.split_whitespace();
            match it.next() {
                Some("v") => {
                    let mut c = [0f32; 3];
                    for v in c.iter_mut() {
                        let tok = it.next().ok_or((at, "vertex with fewer than 3 coordinates".to_string()))?;
                        *v = tok.parse().map_err(|_| (at, format!("bad vertex coordinate {tok:?}")))?;
                        if !v.is_finite() {
                            return Err((at, format!("non-finite vertex coordinate {tok:?}")));
                        }
                    }
                    verts.push(Vec3::from(c));
                }
                Some("f") => {
                    let mut idx = vec![];
                    for tok in it {
                        let first = tok.split('/').next().unwrap_or("");
                        let i: i64 = first.parse().map_err(|_| (at, format!("bad face index {tok:?}")))?;
                        let n = verts.len() as i64;
                        let k = if i > 0 { i - 1 } else { n + i };
                        if i == 0 || k < 0 || k >= n {
                            return Err((at, format!("face index {i} is outside the {n} vertices defined so far")));
                        }
                        idx.push(k as usize);
                    }
                    if idx.len() < 3 {
                        return Err((at, "face with fewer than 3 vertices".to_string()));
                    }
                    for k in 1..idx.len() - 1 {
                        triangles.push([verts[idx[0]], verts[idx[k]], verts[idx[k + 1]]]);
                    }
                }
                _ => {}
            }
        }
        if triangles.is_empty() {
            return Err((0, "no faces (f lines) in the file".to_string()));
        }
        Ok(Geometry { triangles })
    }

    /// Nearest hit t > 0 of `o + t·d` and the geometric normal facing the ray (brute force, the reference).
    pub fn intersect(&self, o: Vec3, d: Vec3) -> Option<(f32, Vec3)> {
        let mut best: Option<(f32, Vec3)> = None;
        for tri in &self.triangles {
            if let Some(t) = ray_triangle(o, d, tri) {
                if best.is_none_or(|b| t < b.0) {
                    let mut n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize_or_zero();
                    if n.dot(d) > 0.0 {
                        n = -n;
                    }
                    best = Some((t, n));
                }
            }
        }
        best
    }
}

/// Fan polygon `idx` of `verts` into `out`; None when an index is out of range.
fn fan(verts: &[Vec3], idx: &[usize], out: &mut Vec<[Vec3; 3]>) -> Option<()> {
    let v = |i: usize| verts.get(idx[i]).copied();
    for k in 2..idx.len() {
        out.push([v(0)?, v(k - 1)?, v(k)?]);
    }
    Some(())
}

/// Möller–Trumbore; the same arithmetic as `ray_triangle` in background.comp.
pub fn ray_triangle(o: Vec3, d: Vec3, t: &[Vec3; 3]) -> Option<f32> {
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - t[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let tt = e2.dot(q) * inv;
    (tt > 0.0).then_some(tt)
}

/// The BVH flattened for the GPU: nodes as two vec4 (min, w = right child or first triangle as float bits;
/// max, w = triangle count as float bits, 0 for an inner node whose left child follows it), triangles as
/// three vec4 each, in leaf order.
#[derive(Clone, Debug, Default)]
pub struct GpuBvh {
    /// BVH nodes, two vec4 each (bounds, then child or triangle range), for the `background` pass.
    pub nodes: Vec<[f32; 4]>,
    /// Triangles, three vec4 corners each, in BVH leaf order.
    pub triangles: Vec<[f32; 4]>,
}

impl GpuBvh {
    /// Build the BVH of `mesh` and flatten it for the GPU.
    pub fn build(mesh: &Geometry) -> GpuBvh {
        let mut order: Vec<usize> = (0..mesh.triangles.len()).collect();
        let centroid = |i: usize| (mesh.triangles[i][0] + mesh.triangles[i][1] + mesh.triangles[i][2]) / 3.0;
        let mut out = GpuBvh::default();
        fn node(
            mesh: &Geometry,
            order: &mut [usize],
            first: usize,
            depth: usize,
            out: &mut GpuBvh,
            centroid: &dyn Fn(usize) -> Vec3,
        ) {
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for &i in order.iter() {
                for v in mesh.triangles[i] {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
            let me = out.nodes.len();
            out.nodes.push([lo.x, lo.y, lo.z, 0.0]);
            out.nodes.push([hi.x, hi.y, hi.z, 0.0]);
            if order.len() <= LEAF || depth + 1 >= MAX_DEPTH {
                out.nodes[me][3] = f32::from_bits(first as u32);
                out.nodes[me + 1][3] = f32::from_bits(order.len() as u32);
                return;
            }
            let (mut clo, mut chi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for &i in order.iter() {
                clo = clo.min(centroid(i));
                chi = chi.max(centroid(i));
            }
            let ext = chi - clo;
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = order.len() / 2;
            order.select_nth_unstable_by(mid, |a, b| centroid(*a)[axis].total_cmp(&centroid(*b)[axis]));
            let (left, right) = order.split_at_mut(mid);
            node(mesh, left, first, depth + 1, out, centroid);
            let right_index = out.nodes.len() / 2;
            out.nodes[me][3] = f32::from_bits(right_index as u32);
            node(mesh, right, first + mid, depth + 1, out, centroid);
        }
        if !order.is_empty() {
            node(mesh, &mut order, 0, 0, &mut out, &centroid);
        }
        for &i in &order {
            for v in mesh.triangles[i] {
                out.triangles.push([v.x, v.y, v.z, 0.0]);
            }
        }
        out
    }

    /// Node count.
    pub fn len(&self) -> usize {
        self.nodes.len() / 2
    }

    /// Whether the mesh has no triangles.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// CPU walk of the flattened BVH, mirroring the shader's traversal (for tests).
    pub fn intersect(&self, o: Vec3, d: Vec3) -> Option<f32> {
        if self.is_empty() {
            return None;
        }
        let inv = Vec3::ONE / d;
        let mut stack = vec![0usize];
        let mut best = f32::INFINITY;
        while let Some(n) = stack.pop() {
            let a = self.nodes[2 * n];
            let b = self.nodes[2 * n + 1];
            let t0 = (Vec3::new(a[0], a[1], a[2]) - o) * inv;
            let t1 = (Vec3::new(b[0], b[1], b[2]) - o) * inv;
            let tn = t0.min(t1).max_element().max(0.0);
            let tf = t0.max(t1).min_element();
            if tn > tf || tn >= best {
                continue;
            }
            let count = b[3].to_bits() as usize;
            if count > 0 {
                let first = a[3].to_bits() as usize;
                for k in first..first + count {
                    let v = |j: usize| {
                        Vec3::new(
                            self.triangles[3 * k + j][0],
                            self.triangles[3 * k + j][1],
                            self.triangles[3 * k + j][2],
                        )
                    };
                    if let Some(t) = ray_triangle(o, d, &[v(0), v(1), v(2)]) {
                        best = best.min(t);
                    }
                }
            } else {
                stack.push(a[3].to_bits() as usize);
                stack.push(n + 1);
            }
        }
        best.is_finite().then_some(best)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_faces_quads_negative_indices_and_errors() {
        let m = Geometry::parse_obj(
            b"# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -4 -3 -2\n",
        )
        .unwrap();
        assert_eq!(m.triangles.len(), 3);
        assert_eq!(m.triangles[2], [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)]);
        let e = Geometry::parse_obj(b"v 0 0 0\nv 1 0 0\nf 1 2 7\n").unwrap_err();
        assert_eq!(e.0, 16, "{e:?}");
        assert!(e.1.contains("index 7"));
        assert_eq!(Geometry::parse_obj(b"v 0 0 x\n").unwrap_err().0, 0);
        assert!(Geometry::parse_obj(b"v 0 0 0\n").unwrap_err().1.contains("no faces"));
        assert!(Geometry::parse_obj(b"v 0 0 0\nv 1 0 0\nf 1 2\n").is_err());
        assert!(Geometry::parse_obj(&[b'v', b' ', 0xff]).is_err());
    }

    #[test]
    fn bvh_walk_equals_brute_force() {
        // A ring of 300 small random triangles.
        let mut seed = 7u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut tris = vec![];
        for _ in 0..300 {
            let c = Vec3::new(rnd() * 4.0 - 2.0, rnd() * 2.0, rnd() * 4.0 - 2.0);
            tris.push([c, c + Vec3::new(rnd(), rnd(), rnd()) * 0.4, c + Vec3::new(rnd(), rnd(), rnd()) * 0.4]);
        }
        let mesh = Geometry { triangles: tris };
        let bvh = GpuBvh::build(&mesh);
        assert_eq!(bvh.triangles.len(), 900);
        let mut hits = 0;
        for i in 0..2000 {
            let o = Vec3::new(0.1, 1.0, 6.0);
            let d = Vec3::new((i % 50) as f32 / 50.0 - 0.5, (i / 50) as f32 / 40.0 * 0.6 - 0.3, -1.0);
            let want = mesh.intersect(o, d).map(|h| h.0);
            let got = bvh.intersect(o, d);
            assert_eq!(want.is_some(), got.is_some(), "ray {i}");
            if let (Some(a), Some(b)) = (want, got) {
                assert!((a - b).abs() < 1e-5, "ray {i}: {a} vs {b}");
                hits += 1;
            }
        }
        assert!(hits > 100, "{hits} hits");
    }
}
