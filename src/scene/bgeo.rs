//! Houdini classic BGEO (version 5), as written by Partio / SPlisHSPlasH; gzip-compressed or plain;
//! big-endian. Layout (../shared/data/splishsplash/README.md): "Bgeo" 'V', nine int32 (version, nPoints,
//! nPrims, nPointGroups, nPrimGroups, nPointAttrib, nVertexAttrib, nPrimAttrib, nDetailAttrib), the point
//! attribute definitions (u16 name length, name, u16 size, int32 type, defaults — or for indexed strings a
//! string table), then nPoints records of x y z w and the attribute values (4 bytes per component).
//! Every count is checked against the bytes that remain before anything is allocated.

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};
use crate::scene::{Attribute, Raw};

/// Houdini attribute types used in point attributes.
const T_FLOAT: i32 = 0;
const T_INT: i32 = 1;
const T_INDEX: i32 = 4;
const T_VECTOR: i32 = 5;

use super::bytes::Cursor as Reader;

struct Attr {
    name: String,
    size: usize,
    ty: i32,
}

/// Parse BGEO bytes (gzip or plain). `path` only names the file in errors.
pub fn parse(path: &Path, bytes: &[u8]) -> Result<Raw> {
    let compressed = bytes.starts_with(&[0x1f, 0x8b]);
    let owned;
    let data: &[u8] = if compressed {
        owned = inflate_bounded(path, bytes)?;
        &owned
    } else {
        bytes
    };
    let mut r =
        Reader::new(path, data).with_note(if compressed { " (offset in the gzip-decompressed data)" } else { "" });
    let (n_points, nprims, attrs) = header(&mut r)?;
    let record = 16 + 4 * attrs.iter().map(|a| a.size).sum::<usize>();
    let need = n_points.checked_mul(record).ok_or_else(|| r.err(5, "point count overflows"))?;
    if need > r.remaining() {
        return Err(r.err(
            r.pos,
            format!(
                "header claims {n_points} points ({need} bytes of {record}-byte records) but only {} bytes remain",
                r.remaining()
            ),
        ));
    }
    // After the points: Partio's end marker (0x00 0xff) and nothing else in a particle file (no primitives).
    let end = r.pos + need;
    let rest = &data[end..];
    if nprims == 0 && rest.len() > TRAILER.len() {
        return Err(r.err(
            end,
            format!(
                "{} bytes follow the {n_points} points the header declares (a header that under-counts them?)",
                rest.len()
            ),
        ));
    }
    let mut offsets = vec![];
    let mut o = 16;
    for a in &attrs {
        offsets.push(o);
        o += 4 * a.size;
    }
    let body = &data[r.pos..r.pos + need];
    let f = |rec: &[u8], off: usize| f32::from_be_bytes(rec[off..off + 4].try_into().unwrap());
    let positions = body.chunks_exact(record).map(|rec| [f(rec, 0), f(rec, 4), f(rec, 8)]).collect();
    let arrays = attrs
        .iter()
        .zip(&offsets)
        .map(|(a, &off)| {
            let mut v = Vec::with_capacity(n_points * a.size);
            for rec in body.chunks_exact(record) {
                for c in 0..a.size {
                    let b: [u8; 4] = rec[off + 4 * c..off + 4 * c + 4].try_into().unwrap();
                    v.push(if a.ty == T_FLOAT || a.ty == T_VECTOR {
                        f32::from_be_bytes(b) as f64
                    } else {
                        i32::from_be_bytes(b) as f64
                    });
                }
            }
            Attribute { name: a.name.clone(), components: a.size, data: v }
        })
        .collect();
    Ok(Raw { positions, arrays })
}

/// Partio's end of a particle file.
const TRAILER: [u8; 2] = [0x00, 0xff];

/// The header: magic, version, counts and the point attribute definitions; returns (points, primitives,
/// attributes) with the cursor at the first point record.
fn header(r: &mut Reader) -> Result<(usize, usize, Vec<Attr>)> {
    let magic = r.take(4, "magic")?;
    if magic != b"Bgeo" {
        return Err(r.err(
            0,
            format!("wrong magic {:?}: not a classic BGEO file (expected \"Bgeo\")", String::from_utf8_lossy(magic)),
        ));
    }
    let v = r.take(1, "version marker")?[0];
    if v != b'V' {
        return Err(r.err(4, format!("expected 'V' after the magic, found byte 0x{v:02x}")));
    }
    let version = r.i32_be("version")?;
    if version != 5 {
        return Err(r.err(5, format!("unsupported BGEO version {version} (only classic version 5 is read)")));
    }
    let names = [
        "nPoints",
        "nPrims",
        "nPointGroups",
        "nPrimGroups",
        "nPointAttrib",
        "nVertexAttrib",
        "nPrimAttrib",
        "nDetailAttrib",
    ];
    let mut h = [0i32; 8];
    for (k, n) in names.iter().enumerate() {
        let at = r.pos;
        h[k] = r.i32_be(n)?;
        if h[k] < 0 {
            return Err(r.err(at, format!("{n} is negative ({})", h[k])));
        }
    }
    let (n_points, nprims) = (h[0] as usize, h[1] as usize);
    let n_attr = h[4] as usize;
    // Each attribute definition takes at least 8 bytes.
    if n_attr > r.remaining() / 8 {
        return Err(r.err(r.pos, format!("header claims {n_attr} point attributes, more than the file can hold")));
    }
    let mut attrs = Vec::with_capacity(n_attr);
    for _ in 0..n_attr {
        let at = r.pos;
        let len = r.u16_be("attribute name length")? as usize;
        let name = String::from_utf8_lossy(r.take(len, "attribute name")?).into_owned();
        let size = r.u16_be("attribute size")? as usize;
        let ty = r.i32_be("attribute type")?;
        match ty {
            T_FLOAT | T_INT | T_VECTOR => {
                r.take(4 * size, "attribute defaults")?;
            }
            T_INDEX => {
                let count = r.i32_be("string count")?;
                if count < 0 || count as usize > r.remaining() / 2 {
                    return Err(r.err(at, format!("attribute {name:?}: bad string count {count}")));
                }
                for _ in 0..count {
                    let l = r.u16_be("string length")? as usize;
                    r.take(l, "string")?;
                }
            }
            other => return Err(r.err(at, format!("attribute {name:?} has unsupported type {other}"))),
        }
        if size == 0 {
            return Err(r.err(at, format!("attribute {name:?} has size 0")));
        }
        attrs.push(Attr { name, size, ty });
    }
    Ok((n_points, nprims, attrs))
}

/// The largest a decompressed file may be before its header is read (the header of a particle file is tiny).
const HEAD_BYTES: u64 = 1 << 20;

/// Inflate a gzip'ed BGEO no further than its header says it holds: the first MiB, then the header's points ×
/// record size plus the end marker. A stream that inflates past that (a gzip bomb: 7 MB that inflate to 7 GiB)
/// is refused at the point where it passes it, without allocating the rest.
fn inflate_bounded(path: &Path, bytes: &[u8]) -> Result<Vec<u8>> {
    let corrupt = |e: std::io::Error, n: usize| Error::Parse {
        path: path.to_path_buf(),
        offset: 0,
        reason: format!("gzip stream is corrupt: {e} ({n} bytes decompressed before the error)"),
    };
    let mut dec = flate2::read::MultiGzDecoder::new(bytes);
    let mut v = Vec::new();
    (&mut dec).take(HEAD_BYTES).read_to_end(&mut v).map_err(|e| corrupt(e, v.len()))?;
    let mut r = Reader::new(path, &v);
    let Ok((n, _, attrs)) = header(&mut r) else {
        return Ok(v); // the parse reports what is wrong with the header
    };
    let record = 16 + 4 * attrs.iter().map(|a| a.size).sum::<usize>();
    let limit = n.checked_mul(record).and_then(|b| b.checked_add(r.pos + TRAILER.len())).unwrap_or(usize::MAX) as u64;
    if limit > v.len() as u64 {
        let at = v.len();
        (&mut dec).take(limit - at as u64 + 1).read_to_end(&mut v).map_err(|e| corrupt(e, v.len()))?;
    }
    if v.len() as u64 > limit {
        return Err(Error::Parse {
            path: path.to_path_buf(),
            offset: limit,
            reason: format!(
                "the gzip stream inflates past the {limit} bytes its header declares ({n} point{} of {record} bytes); \
                 refusing to inflate further (offset in the gzip-decompressed data)",
                if n == 1 { "" } else { "s" }
            ),
        });
    }
    Ok(v)
}

/// Write classic BGEO v5 the way Partio does: every array (`id`, `type` and `source` as int, 3-component ones as vector,
/// others float), plain or gzip.
pub fn write(p: &Raw, gzip: bool) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(b"BgeoV");
    let ty = |a: &Attribute| {
        if a.name == "id" || a.name == "type" || a.name == "source" {
            T_INT
        } else if a.components == 3 {
            T_VECTOR
        } else {
            T_FLOAT
        }
    };
    for v in [5, p.positions.len() as i32, 0, 0, 0, p.arrays.len() as i32, 0, 0, 0] {
        out.extend_from_slice(&v.to_be_bytes());
    }
    for a in &p.arrays {
        out.extend_from_slice(&(a.name.len() as u16).to_be_bytes());
        out.extend_from_slice(a.name.as_bytes());
        out.extend_from_slice(&(a.components as u16).to_be_bytes());
        out.extend_from_slice(&ty(a).to_be_bytes());
        for _ in 0..a.components {
            out.extend_from_slice(&0i32.to_be_bytes());
        }
    }
    for (i, pos) in p.positions.iter().enumerate() {
        for c in pos {
            out.extend_from_slice(&c.to_be_bytes());
        }
        out.extend_from_slice(&1f32.to_be_bytes());
        for a in &p.arrays {
            for c in 0..a.components {
                let x = a.data[i * a.components + c];
                if ty(a) == T_INT {
                    out.extend_from_slice(&((x as i64) as i32).to_be_bytes());
                } else {
                    out.extend_from_slice(&(x as f32).to_be_bytes());
                }
            }
        }
    }
    out.extend_from_slice(&[0x00, 0xff]);
    if gzip {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut e, &out).expect("write to memory");
        e.finish().expect("gzip to memory")
    } else {
        out
    }
}

/// This format in the registry ([`super::format::FORMATS`]).
pub struct Bgeo;

impl super::format::ParticleFormat for Bgeo {
    fn key(&self) -> &'static str {
        "bgeo"
    }
    fn name(&self) -> &'static str {
        "Houdini classic BGEO"
    }
    fn extensions(&self) -> &'static [&'static str] {
        &["bgeo", "gz"]
    }
    fn sniff(&self, head: &[u8]) -> bool {
        head.starts_with(b"Bgeo")
    }
    fn parse(&self, path: &Path, bytes: &[u8]) -> Result<Raw> {
        parse(path, bytes)
    }
    fn samples(&self, raw: &Raw) -> Vec<(&'static str, Vec<u8>)> {
        vec![("plain", write(raw, false)), ("gzip", write(raw, true))]
    }
}
