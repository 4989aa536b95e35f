//! Legacy VTK ("# vtk DataFile Version x.y"), ASCII or BINARY (big-endian), any dataset whose points come
//! from a `POINTS` section (POLYDATA, UNSTRUCTURED_GRID, ...). Cells are skipped (legacy lists and the 5.x
//! OFFSETS/CONNECTIVITY form); `POINT_DATA` arrays from SCALARS, VECTORS, NORMALS and FIELD sections are read
//! and mapped by name (velocity, density, id). Counts are checked against the bytes that remain before any
//! allocation; errors name the byte offset.

use std::path::Path;

use super::bytes::Scalar;
use crate::error::Result;
use crate::scene::{Attribute, Raw};

use super::bytes::Cursor;

/// `count` values of VTK type `ty`, as f64.
fn values(c: &mut Cursor, binary: bool, count: usize, ty: &str, what: &str) -> Result<Vec<f64>> {
    let at = c.pos;
    let scalar = Scalar::parse(ty).ok_or_else(|| c.err(at, format!("{what}: unsupported data type {ty:?}")))?;
    let size = scalar.size();
    if binary {
        // The binary block starts after the newline that ends the header line.
        c.line();
        let start = c.pos;
        let need = count.checked_mul(size).ok_or_else(|| c.err(at, format!("{what}: count overflows")))?;
        if need > c.d.len() - start {
            return Err(c.err(
                start,
                format!("{what}: {count} values of {ty} need {need} bytes but only {} remain", c.d.len() - start),
            ));
        }
        let b = &c.d[start..start + need];
        // Legacy VTK binary data is big-endian.
        let v: Vec<f64> = b.chunks_exact(size).map(|c| scalar.read(c, true)).collect();
        c.pos = start + need;
        Ok(v)
    } else {
        // Each ASCII value takes at least two bytes (digit + separator).
        if count > (c.d.len() - c.pos) / 2 + 1 {
            return Err(
                c.err(at, format!("{what}: {count} values cannot fit in the {} bytes that remain", c.d.len() - c.pos))
            );
        }
        let mut v = Vec::with_capacity(count);
        for _ in 0..count {
            v.push(c.number::<f64>(what)?);
        }
        Ok(v)
    }
}

/// Parse legacy VTK bytes. `path` only names the file in errors.
pub fn parse(path: &Path, bytes: &[u8]) -> Result<Raw> {
    let mut c = Cursor::new(path, bytes);
    let first = c.line();
    if !first.starts_with("# vtk DataFile") {
        return Err(c.err(0, "wrong magic: not a legacy VTK file (expected \"# vtk DataFile Version\")"));
    }
    let _title = c.line();
    let at = c.pos;
    let mode = c.line().trim().to_ascii_uppercase();
    let binary = match mode.as_str() {
        "ASCII" => false,
        "BINARY" => true,
        m => return Err(c.err(at, format!("expected ASCII or BINARY, found {m:?}"))),
    };
    let mut positions: Option<Vec<[f32; 3]>> = None;
    let mut arrays: Vec<(String, usize, Vec<f64>)> = vec![];
    let mut in_point_data = false;
    let mut n_point_data = 0usize;
    let mut n_cell_data = 0usize;
    // The last section read, with its count: what a stray token after it most likely means.
    let mut last: Option<(String, usize)> = None;
    while let Some(kw) = c.token() {
        let at = c.pos - kw.len();
        let upper = kw.to_ascii_uppercase();
        match upper.as_str() {
            "DATASET" => {
                let t = c.expect_token("dataset type")?;
                if t.eq_ignore_ascii_case("STRUCTURED_POINTS") || t.eq_ignore_ascii_case("RECTILINEAR_GRID") {
                    return Err(c.err(at, format!("dataset {t} has no particle positions")));
                }
            }
            "POINTS" => {
                let n: usize = c.number("point count")?;
                let ty = c.expect_token("point type")?;
                let n3 = n.checked_mul(3).ok_or_else(|| c.err(at, "point count overflows"))?;
                let v = values(&mut c, binary, n3, ty, "POINTS")?;
                positions = Some(v.chunks_exact(3).map(|p| [p[0] as f32, p[1] as f32, p[2] as f32]).collect());
            }
            "VERTICES" | "LINES" | "POLYGONS" | "TRIANGLE_STRIPS" | "CELLS" => cells(&mut c, binary, kw)?,
            "CELL_TYPES" => {
                let n: usize = c.number("cell type count")?;
                values(&mut c, binary, n, "int", "CELL_TYPES")?;
            }
            "POINT_DATA" => {
                n_point_data = c.number("point data count")?;
                in_point_data = true;
            }
            "CELL_DATA" => {
                n_cell_data = c.number("cell data count")?;
                in_point_data = false;
            }
            "SCALARS" => {
                let name = c.expect_token("scalar name")?.to_string();
                let ty = c.expect_token("scalar type")?;
                let ncomp = scalars_components(&mut c)?;
                let n = if in_point_data { n_point_data } else { n_cell_data };
                let total = n.checked_mul(ncomp).ok_or_else(|| c.err(at, "SCALARS size overflows"))?;
                let v = values(&mut c, binary, total, ty, "SCALARS")?;
                if in_point_data {
                    arrays.push((name, ncomp, v));
                }
            }
            "VECTORS" | "NORMALS" => {
                let name = c.expect_token("array name")?.to_string();
                let ty = c.expect_token("array type")?;
                let n = if in_point_data { n_point_data } else { n_cell_data };
                let total = n.checked_mul(3).ok_or_else(|| c.err(at, format!("{kw} size overflows")))?;
                let v = values(&mut c, binary, total, ty, kw)?;
                if in_point_data {
                    arrays.push((name, 3, v));
                }
            }
            "FIELD" => {
                c.expect_token("field name")?;
                let k: usize = c.number("field array count")?;
                for _ in 0..k {
                    let name = c.expect_token("array name")?.to_string();
                    let ncomp: usize = c.number("component count")?;
                    let nt: usize = c.number("tuple count")?;
                    let ty = c.expect_token("array type")?;
                    let total = ncomp.checked_mul(nt).ok_or_else(|| c.err(at, "array size overflows"))?;
                    let v = values(&mut c, binary, total, ty, "FIELD array")?;
                    if in_point_data && nt == n_point_data {
                        arrays.push((name, ncomp, v));
                    }
                }
            }
            "LOOKUP_TABLE" => {
                c.expect_token("table name")?;
                let n: usize = c.number("table size")?;
                let total = n.checked_mul(4).ok_or_else(|| c.err(at, "LOOKUP_TABLE size overflows"))?;
                values(&mut c, binary, total, if binary { "unsigned_char" } else { "float" }, "LOOKUP_TABLE")?;
            }
            "METADATA" => {
                // Skip to the blank line that ends the block.
                c.line();
                while c.pos < c.d.len() && !c.line().trim().is_empty() {}
            }
            _ => {
                let reason = stray(kw, last.as_ref());
                return Err(c.err(at, reason));
            }
        }
        let count = match upper.as_str() {
            "POINTS" => positions.as_ref().map_or(0, |p| p.len()),
            "DATASET" | "METADATA" => continue,
            _ if in_point_data => n_point_data,
            _ => n_cell_data,
        };
        last = Some((upper, count));
    }
    let positions = positions.ok_or_else(|| c.err(c.d.len(), "no POINTS section"))?;
    let n = positions.len();
    let arrays = arrays
        .into_iter()
        .filter(|(_, k, v)| n.checked_mul(*k) == Some(v.len()))
        .map(|(name, components, data)| Attribute { name, components, data })
        .collect();
    Ok(Raw { positions, arrays })
}

/// A cell section (`kw`: VERTICES, LINES, POLYGONS, TRIANGLE_STRIPS, CELLS) read past: its legacy list of ints,
/// or VTK 5's OFFSETS and CONNECTIVITY arrays.
fn cells(c: &mut Cursor, binary: bool, kw: &str) -> Result<()> {
    let _n: usize = c.number("cell count")?;
    let size: usize = c.number("cell list size")?;
    // VTK 5.x: OFFSETS/CONNECTIVITY follow; legacy: `size` ints.
    let save = c.pos;
    match c.token() {
        Some(t) if t.eq_ignore_ascii_case("OFFSETS") => {
            let ty = c.expect_token("offsets type")?;
            values(c, binary, _n, ty, "OFFSETS")?;
            let t2 = c.expect_token("CONNECTIVITY")?;
            if !t2.eq_ignore_ascii_case("CONNECTIVITY") {
                return Err(c.err(c.pos, format!("expected CONNECTIVITY, found {t2:?}")));
            }
            let ty = c.expect_token("connectivity type")?;
            values(c, binary, size, ty, "CONNECTIVITY")?;
        }
        _ => {
            c.pos = save;
            values(c, binary, size, "int", kw)?;
        }
    }
    Ok(())
}

/// A SCALARS line's optional component count and LOOKUP_TABLE, after its name and type.
fn scalars_components(c: &mut Cursor) -> Result<usize> {
    // Optional component count, then LOOKUP_TABLE.
    let save = c.pos;
    let mut ncomp = 1usize;
    match c.token() {
        Some(t) if t.eq_ignore_ascii_case("LOOKUP_TABLE") => {
            c.expect_token("lookup table name")?;
        }
        Some(t) => {
            ncomp = t.parse().map_err(|_| c.err(save, format!("bad component count {t:?}")))?;
            let s2 = c.pos;
            match c.token() {
                Some(t) if t.eq_ignore_ascii_case("LOOKUP_TABLE") => {
                    c.expect_token("lookup table name")?;
                }
                _ => c.pos = s2,
            }
        }
        None => return Err(c.err(save, "file truncated after SCALARS")),
    }
    Ok(ncomp)
}

/// What a token that starts no section means, after the section `last` (name, count) if any.
fn stray(kw: &str, last: Option<&(String, usize)>) -> String {
    let what = if kw.parse::<f64>().is_ok() { "a number" } else { "not a section keyword" };
    match last {
        // More data than the section's count says: the count is too small (or the file damaged).
        Some((sec, n)) => format!(
            "{kw:?} is {what}, found where the next section should start: the data of {sec} is longer \
             than its count ({n}) says (the count is too small, or the file is damaged)"
        ),
        None => {
            format!("{kw:?} is {what}, found where a section (POINTS, CELLS, POINT_DATA, …) should start")
        }
    }
}

/// Write legacy VTK like SPlisHSPlasH (UNSTRUCTURED_GRID of vertex cells; `id` as SCALARS int, the other
/// arrays in one FIELD block as float).
pub fn write(p: &Raw, binary: bool) -> Vec<u8> {
    let n = p.positions.len();
    let mut o: Vec<u8> = Vec::new();
    o.extend_from_slice(b"# vtk DataFile Version 4.1\nmeniscus particles\n");
    o.extend_from_slice(if binary { b"BINARY\n" } else { b"ASCII\n" });
    o.extend_from_slice(b"DATASET UNSTRUCTURED_GRID\n");
    o.extend_from_slice(format!("POINTS {n} float\n").as_bytes());
    let put_f = |o: &mut Vec<u8>, xs: &mut dyn Iterator<Item = f32>| {
        for x in xs {
            if binary {
                o.extend_from_slice(&x.to_be_bytes());
            } else {
                o.extend_from_slice(format!("{x} ").as_bytes());
            }
        }
        o.push(b'\n');
    };
    let put_i = |o: &mut Vec<u8>, xs: &mut dyn Iterator<Item = i64>| {
        for x in xs {
            if binary {
                o.extend_from_slice(&(x as i32).to_be_bytes());
            } else {
                o.extend_from_slice(format!("{x} ").as_bytes());
            }
        }
        o.push(b'\n');
    };
    put_f(&mut o, &mut p.positions.iter().flatten().copied());
    o.extend_from_slice(format!("CELLS {n} {}\n", 2 * n).as_bytes());
    put_i(&mut o, &mut (0..n as i64).flat_map(|i| [1, i]));
    o.extend_from_slice(format!("CELL_TYPES {n}\n").as_bytes());
    put_i(&mut o, &mut (0..n).map(|_| 1));
    o.extend_from_slice(format!("POINT_DATA {n}\n").as_bytes());
    let (ids, fields): (Vec<&Attribute>, Vec<&Attribute>) =
        p.arrays.iter().partition(|a| a.name == "id" && a.components == 1);
    for a in ids {
        o.extend_from_slice(b"SCALARS id int 1\nLOOKUP_TABLE id_table\n");
        put_i(&mut o, &mut a.data.iter().map(|&x| x as i64));
    }
    if !fields.is_empty() {
        o.extend_from_slice(format!("FIELD FieldData {}\n", fields.len()).as_bytes());
        for a in fields {
            o.extend_from_slice(format!("{} {} {n} float\n", a.name, a.components).as_bytes());
            put_f(&mut o, &mut a.data.iter().map(|&x| x as f32));
        }
    }
    o
}

/// This format in the registry ([`super::format::FORMATS`]).
pub struct Vtk;

impl super::format::ParticleFormat for Vtk {
    fn key(&self) -> &'static str {
        "vtk"
    }
    fn name(&self) -> &'static str {
        "legacy VTK"
    }
    fn extensions(&self) -> &'static [&'static str] {
        &["vtk"]
    }
    fn sniff(&self, head: &[u8]) -> bool {
        head.starts_with(b"# vtk DataFile")
    }
    fn parse(&self, path: &Path, bytes: &[u8]) -> Result<Raw> {
        parse(path, bytes)
    }
    fn samples(&self, raw: &Raw) -> Vec<(&'static str, Vec<u8>)> {
        vec![("ascii", write(raw, false)), ("binary", write(raw, true))]
    }
}
