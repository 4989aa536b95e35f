//! The USD binary "crate" encoding (`.usdc`, and `.usd` by default) of the stage `crate::export::usd`
//! describes. Layout (Pixar's crateFile.cpp, file version 0.8.0; the AOUSD core specification's binary parser):
//! an 88-byte bootstrap (`PXR-USDC`, the version, the table of contents' offset), the values — here every frame's
//! arrays, appended as the frames come (u64 count, then the elements) —, then the structure: each attribute's
//! time samples (a DoubleVector of times and a ValueRep per time), the tokens, strings, fields (name token +
//! ValueRep), field sets, the path tree and the specs, and the table of contents. A ValueRep is 64 bits: array,
//! inlined and compressed flags, an 8-bit type, a 48-bit payload (the value, or the file offset of its bytes).
//!
//! The structural sections are always compressed in this version: integers with the crate's delta coding (a
//! common delta, 2-bit codes, 8/16/32-bit deltas), then TfFastCompression's LZ4 framing. The LZ4 blocks here hold
//! literals only (a valid block that stores its bytes as they are): the sections are a few kilobytes, and a
//! literal block needs no compressor. Integer arrays of 16 or more elements get the same integer coding
//! (faces: about 1.5 bytes per index instead of 4); float arrays are written as they are.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::export::usd::{Attr, Sample, StageInfo, Uniform, ATTRS, MESH_UNIFORMS, PRIMS};
use crate::output::{FileKind, Partial};

/// Crate file version written.
const VERSION: [u8; 3] = [0, 8, 0];
/// Bytes of the bootstrap header (Pixar's `_BootStrap`: ident, version, TOC offset, 8 reserved words).
const BOOTSTRAP: u64 = 88;

/// ValueRep type numbers (crateDataTypes.h).
mod ty {
    pub const BOOL: u64 = 1;
    pub const INT: u64 = 3;
    pub const FLOAT: u64 = 8;
    pub const DOUBLE: u64 = 9;
    pub const STRING: u64 = 10;
    pub const TOKEN: u64 = 11;
    pub const VEC3F: u64 = 24;
    pub const TOKEN_VECTOR: u64 = 41;
    pub const SPECIFIER: u64 = 42;
    pub const VARIABILITY: u64 = 44;
    pub const TIME_SAMPLES: u64 = 46;
    pub const DOUBLE_VECTOR: u64 = 48;
}

/// SdfSpecType numbers.
const SPEC_ATTRIBUTE: u32 = 1;
const SPEC_PRIM: u32 = 6;
const SPEC_PSEUDO_ROOT: u32 = 7;

const ARRAY: u64 = 1 << 63;
const INLINED: u64 = 1 << 62;
const COMPRESSED: u64 = 1 << 61;
/// Integer arrays from this length are stored compressed (the crate's `MinCompressedArraySize`).
const MIN_COMPRESSED: usize = 16;
const PAYLOAD: u64 = (1 << 48) - 1;

fn inline(t: u64, payload: u64) -> u64 {
    t << 48 | INLINED | (payload & PAYLOAD)
}

fn heap(t: u64, offset: u64, array: bool) -> u64 {
    t << 48 | if array { ARRAY } else { 0 } | (offset & PAYLOAD)
}

/// TfFastCompression framing (0: one chunk) of an LZ4 block holding `data` as literals.
fn lz4_literals(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len() + data.len() / 255 + 3);
    out.push(0);
    let n = data.len();
    if n < 15 {
        out.push((n as u8) << 4);
    } else {
        out.push(0xF0);
        let mut rest = n - 15;
        while rest >= 255 {
            out.push(255);
            rest -= 255;
        }
        out.push(rest as u8);
    }
    out.extend_from_slice(data);
    out
}

/// The crate's integer coding of 32-bit values (usd/integerCoding.cpp): deltas from the previous value (wrapping),
/// the most common delta stored once, a 2-bit code per value (0 common, 1 i8, 2 i16, 3 i32), then the others.
fn encode_ints(values: &[i32]) -> Vec<u8> {
    if values.is_empty() {
        return vec![];
    }
    let mut prev = 0i32;
    let deltas: Vec<i32> = values
        .iter()
        .map(|&v| {
            let d = v.wrapping_sub(prev);
            prev = v;
            d
        })
        .collect();
    // The common delta from up to 4,096 evenly spread samples (any choice decodes; a frequent one is smallest).
    let mut counts: HashMap<i32, usize> = HashMap::new();
    for &d in deltas.iter().step_by((deltas.len() / 4096).max(1)) {
        *counts.entry(d).or_default() += 1;
    }
    let common = counts.iter().max_by_key(|(v, c)| (**c, std::cmp::Reverse(**v))).map_or(0, |(v, _)| *v);
    let mut out = common.to_le_bytes().to_vec();
    let codes_at = out.len();
    out.resize(codes_at + (values.len() * 2).div_ceil(8), 0);
    for (i, &d) in deltas.iter().enumerate() {
        let code: u8 = if d == common {
            0
        } else if i8::try_from(d).is_ok() {
            out.push(d as i8 as u8);
            1
        } else if i16::try_from(d).is_ok() {
            out.extend_from_slice(&(d as i16).to_le_bytes());
            2
        } else {
            out.extend_from_slice(&d.to_le_bytes());
            3
        };
        out[codes_at + i / 4] |= code << (2 * (i % 4));
    }
    out
}

/// A spec: its path (index), SdfSpecType, and fields (name, ValueRep).
type Spec = (usize, u32, Vec<(&'static str, u64)>);

/// A stage in the crate encoding: frames' arrays go to the file as they come; [`CrateWriter::finish`] writes the
/// structure.
pub(crate) struct CrateWriter {
    path: PathBuf,
    partial: Partial,
    out: BufWriter<File>,
    pos: u64,
    /// Per [`ATTRS`] entry: (time, ValueRep) of each sample.
    samples: Vec<Vec<(f64, u64)>>,
    tokens: Vec<String>,
    token_index: HashMap<String, u32>,
    strings: Vec<u32>,
}

impl CrateWriter {
    pub(crate) fn create(path: &Path) -> Result<CrateWriter> {
        let partial = Partial::begin(path, FileKind::Usd)?;
        let f = File::create(partial.tmp()).map_err(|e| Error::io(path, e))?;
        let mut out = BufWriter::with_capacity(1 << 22, f);
        out.write_all(&[0u8; BOOTSTRAP as usize]).map_err(|e| Error::io(path, e))?;
        let mut w = CrateWriter {
            path: path.to_path_buf(),
            partial,
            out,
            pos: BOOTSTRAP,
            samples: ATTRS.iter().map(|_| vec![]).collect(),
            tokens: vec![],
            token_index: HashMap::new(),
            strings: vec![],
        };
        // Token 0 is never a path element (a property's element is stored as a negative token index).
        w.token("");
        Ok(w)
    }

    fn put(&mut self, bytes: &[u8]) -> Result<()> {
        self.out.write_all(bytes).map_err(|e| Error::io(&self.path, e))?;
        self.pos += bytes.len() as u64;
        Ok(())
    }

    fn token(&mut self, s: &str) -> u32 {
        if let Some(&i) = self.token_index.get(s) {
            return i;
        }
        let i = self.tokens.len() as u32;
        self.tokens.push(s.to_string());
        self.token_index.insert(s.to_string(), i);
        i
    }

    /// An array value: u64 count, then the elements' bytes.
    fn array(&mut self, t: u64, count: usize, bytes: &[u8]) -> Result<u64> {
        let at = self.pos;
        self.put(&(count as u64).to_le_bytes())?;
        self.put(bytes)?;
        Ok(heap(t, at, true))
    }

    pub(crate) fn sample(&mut self, attr: usize, time: f64, s: Sample) -> Result<()> {
        let rep = match s {
            Sample::Vec3(v) => self.array(ty::VEC3F, v.len(), bytemuck::cast_slice(v))?,
            // Integer arrays compressed as the crate does from 16 elements (faces: 3 bytes → about 1.5 per index;
            // the counts, all 3, to 2 bits each).
            Sample::Int(v) if v.len() >= MIN_COMPRESSED => {
                let at = self.pos;
                self.put(&(v.len() as u64).to_le_bytes())?;
                self.put_ints(v)?;
                heap(ty::INT, at, true) | COMPRESSED
            }
            Sample::Int(v) => self.array(ty::INT, v.len(), bytemuck::cast_slice(v))?,
            Sample::Float(v) => self.array(ty::FLOAT, v.len(), bytemuck::cast_slice(v))?,
        };
        self.samples[attr].push((time, rep));
        Ok(())
    }

    fn double(&mut self, x: f64) -> Result<u64> {
        let at = self.pos;
        self.put(&x.to_le_bytes())?;
        Ok(heap(ty::DOUBLE, at, false))
    }

    fn token_vector(&mut self, items: &[&str]) -> Result<u64> {
        let idx: Vec<u32> = items.iter().map(|s| self.token(s)).collect();
        let at = self.pos;
        self.put(&(idx.len() as u64).to_le_bytes())?;
        self.put(bytemuck::cast_slice(&idx))?;
        Ok(heap(ty::TOKEN_VECTOR, at, false))
    }

    fn string(&mut self, s: &str) -> u64 {
        let t = self.token(s);
        let i = self.strings.len() as u64;
        self.strings.push(t);
        inline(ty::STRING, i)
    }

    /// A time-samples record: the times (a DoubleVector), then [i64 8][times ValueRep][i64 8][u64 n][n ValueReps].
    fn time_samples(&mut self, samples: &[(f64, u64)]) -> Result<u64> {
        let times: Vec<f64> = samples.iter().map(|s| s.0).collect();
        let at = self.pos;
        self.put(&(times.len() as u64).to_le_bytes())?;
        self.put(bytemuck::cast_slice(&times))?;
        let times_rep = heap(ty::DOUBLE_VECTOR, at, false);
        let record = self.pos;
        self.put(&8i64.to_le_bytes())?;
        self.put(&times_rep.to_le_bytes())?;
        self.put(&8i64.to_le_bytes())?;
        self.put(&(samples.len() as u64).to_le_bytes())?;
        let reps: Vec<u64> = samples.iter().map(|s| s.1).collect();
        self.put(bytemuck::cast_slice(&reps))?;
        Ok(heap(ty::TIME_SAMPLES, record, false))
    }

    /// Compressed integers: u64 compressed size, then the framed block.
    fn put_ints(&mut self, values: &[i32]) -> Result<()> {
        let block = lz4_literals(&encode_ints(values));
        self.put(&(block.len() as u64).to_le_bytes())?;
        self.put(&block)
    }

    /// The stage's specs, fields and path tree written as the crate's sections (TOKENS, STRINGS, FIELDS,
    /// FIELDSETS, PATHS, SPECS), then the table of contents and the bootstrap; the partial file committed.
    pub(crate) fn finish(mut self, info: &StageInfo) -> Result<()> {
        let (paths, specs) = self.specs(info)?;
        // Fields and field sets.
        let mut fields: Vec<(u32, u64)> = vec![];
        let mut fieldsets: Vec<i32> = vec![];
        let mut spec_rows: Vec<[i32; 3]> = vec![];
        for (path, kind, fs) in &specs {
            spec_rows.push([*path as i32, fieldsets.len() as i32, *kind as i32]);
            for (name, rep) in fs {
                let t = self.token(name);
                fieldsets.push(fields.len() as i32);
                fields.push((t, *rep));
            }
            fieldsets.push(-1);
        }
        // Path elements' tokens (negative for properties), and the tree as the crate walks it: depth first,
        // each entry's jump -1 (child next, no sibling), -2 (leaf, no sibling), 0 (no child, sibling next) or
        // the distance to its sibling (child next).
        let elements: Vec<i32> = (0..paths.len())
            .map(|i| {
                let (parent, name, prop) = paths[i].clone();
                match parent {
                    None => 0,
                    Some(_) if prop => -(self.token(&name) as i32),
                    Some(_) => self.token(&name) as i32,
                }
            })
            .collect();
        let kids: Vec<Vec<usize>> =
            (0..paths.len()).map(|i| (0..paths.len()).filter(|&j| paths[j].0 == Some(i)).collect()).collect();
        let mut order: Vec<(usize, i32)> = vec![];
        fn walk(n: usize, sibling: bool, kids: &[Vec<usize>], order: &mut Vec<(usize, i32)>) {
            let me = order.len();
            order.push((n, 0));
            for (k, &c) in kids[n].iter().enumerate() {
                walk(c, k + 1 < kids[n].len(), kids, order);
            }
            order[me].1 = match (!kids[n].is_empty(), sibling) {
                (true, true) => (order.len() - me) as i32,
                (true, false) => -1,
                (false, true) => 0,
                (false, false) => -2,
            };
        }
        walk(0, false, &kids, &mut order);

        let sections = self.write_sections(&paths, &elements, &order, &fields, &fieldsets, &spec_rows)?;
        // Table of contents, then the bootstrap.
        let toc = self.pos;
        self.put(&(sections.len() as u64).to_le_bytes())?;
        for (name, start, size) in &sections {
            let mut n = [0u8; 16];
            n[..name.len()].copy_from_slice(name.as_bytes());
            self.put(&n)?;
            self.put(&start.to_le_bytes())?;
            self.put(&size.to_le_bytes())?;
        }
        let mut boot = [0u8; BOOTSTRAP as usize];
        boot[..8].copy_from_slice(b"PXR-USDC");
        boot[8..11].copy_from_slice(&VERSION);
        boot[16..24].copy_from_slice(&toc.to_le_bytes());
        let CrateWriter { path, partial, out, .. } = self;
        let res = (|| -> std::io::Result<()> {
            let mut f = out.into_inner().map_err(|e| e.into_error())?;
            f.seek(SeekFrom::Start(0))?;
            f.write_all(&boot)?;
            f.sync_all()
        })();
        res.map_err(|e| Error::io(&path, e))?;
        partial.commit()
    }

    /// The specs (path, kind, fields), in path order, and the paths as (parent, element, is property): the pseudo
    /// root, /water, its prims and their attributes with their time samples.
    #[allow(clippy::type_complexity)]
    fn specs(&mut self, info: &StageInfo) -> Result<(Vec<(Option<usize>, String, bool)>, Vec<Spec>)> {
        let mut paths: Vec<(Option<usize>, String, bool)> = vec![(None, String::new(), false)];
        let mut specs: Vec<Spec> = vec![];
        let mut children: Vec<&str> = vec!["surface"];
        if info.points {
            children.push("diffuse");
        }
        let root_fields = vec![
            ("defaultPrim", inline(ty::TOKEN, self.token("water") as u64)),
            ("documentation", self.string(&info.doc)),
            ("endTimeCode", self.double(info.end)?),
            ("framesPerSecond", self.double(info.fps)?),
            ("metersPerUnit", self.double(info.meters_per_unit)?),
            ("primChildren", self.token_vector(&["water"])?),
            ("startTimeCode", self.double(info.start)?),
            ("timeCodesPerSecond", self.double(info.fps)?),
            ("upAxis", inline(ty::TOKEN, self.token("Y") as u64)),
        ];
        specs.push((0, SPEC_PSEUDO_ROOT, root_fields));
        paths.push((Some(0), "water".into(), false));
        let water_fields = vec![
            ("kind", inline(ty::TOKEN, self.token("component") as u64)),
            ("primChildren", self.token_vector(&children)?),
            ("specifier", inline(ty::SPECIFIER, 0)),
            ("typeName", inline(ty::TOKEN, self.token("Xform") as u64)),
        ];
        specs.push((1, SPEC_PRIM, water_fields));
        for (p, (name, schema)) in PRIMS.iter().enumerate().take(children.len()) {
            let prim_path = paths.len();
            paths.push((Some(1), (*name).into(), false));
            let mut props: Vec<&str> = vec![];
            if p == 0 {
                props.extend(MESH_UNIFORMS.iter().map(|u| u.0));
            }
            let attrs: Vec<(usize, &Attr)> = ATTRS.iter().enumerate().filter(|(_, a)| a.prim == p).collect();
            props.extend(attrs.iter().map(|(_, a)| a.name));
            let prim_fields = vec![
                ("properties", self.token_vector(&props)?),
                ("specifier", inline(ty::SPECIFIER, 0)),
                ("typeName", inline(ty::TOKEN, self.token(schema) as u64)),
            ];
            specs.push((prim_path, SPEC_PRIM, prim_fields));
            if p == 0 {
                for (n, type_name, v) in &MESH_UNIFORMS {
                    let at = paths.len();
                    paths.push((Some(prim_path), (*n).into(), true));
                    let default = match v {
                        Uniform::Bool(b) => inline(ty::BOOL, u64::from(*b)),
                        Uniform::Token(t) => inline(ty::TOKEN, self.token(t) as u64),
                    };
                    let fields = vec![
                        ("default", default),
                        ("typeName", inline(ty::TOKEN, self.token(type_name) as u64)),
                        ("variability", inline(ty::VARIABILITY, 1)),
                    ];
                    specs.push((at, SPEC_ATTRIBUTE, fields));
                }
            }
            for (i, a) in attrs {
                let at = paths.len();
                paths.push((Some(prim_path), a.name.into(), true));
                let samples = std::mem::take(&mut self.samples[i]);
                let mut fields = vec![];
                if let Some(interp) = a.interpolation {
                    fields.push(("interpolation", inline(ty::TOKEN, self.token(interp) as u64)));
                }
                fields.push(("timeSamples", self.time_samples(&samples)?));
                fields.push(("typeName", inline(ty::TOKEN, self.token(a.type_name) as u64)));
                fields.push(("variability", inline(ty::VARIABILITY, 0)));
                specs.push((at, SPEC_ATTRIBUTE, fields));
            }
        }
        Ok((paths, specs))
    }

    /// The sections from TOKENS to SPECS, each (name, start, size).
    fn write_sections(
        &mut self,
        paths: &[(Option<usize>, String, bool)],
        elements: &[i32],
        order: &[(usize, i32)],
        fields: &[(u32, u64)],
        fieldsets: &[i32],
        spec_rows: &[[i32; 3]],
    ) -> Result<Vec<(&'static str, u64, u64)>> {
        let mut sections: Vec<(&'static str, u64, u64)> = vec![];
        // TOKENS: count, bytes, then the compressed null-terminated names.
        let start = self.pos;
        let mut blob = vec![];
        for t in &self.tokens {
            blob.extend_from_slice(t.as_bytes());
            blob.push(0);
        }
        let block = lz4_literals(&blob);
        self.put(&(self.tokens.len() as u64).to_le_bytes())?;
        self.put(&(blob.len() as u64).to_le_bytes())?;
        self.put(&(block.len() as u64).to_le_bytes())?;
        self.put(&block)?;
        sections.push(("TOKENS", start, self.pos - start));
        let start = self.pos;
        let strings = std::mem::take(&mut self.strings);
        self.put(&(strings.len() as u64).to_le_bytes())?;
        self.put(bytemuck::cast_slice(&strings))?;
        sections.push(("STRINGS", start, self.pos - start));
        let start = self.pos;
        self.put(&(fields.len() as u64).to_le_bytes())?;
        self.put_ints(&fields.iter().map(|f| f.0 as i32).collect::<Vec<_>>())?;
        let reps: Vec<u8> = fields.iter().flat_map(|f| f.1.to_le_bytes()).collect();
        let block = lz4_literals(&reps);
        self.put(&(block.len() as u64).to_le_bytes())?;
        self.put(&block)?;
        sections.push(("FIELDS", start, self.pos - start));
        let start = self.pos;
        self.put(&(fieldsets.len() as u64).to_le_bytes())?;
        self.put_ints(fieldsets)?;
        sections.push(("FIELDSETS", start, self.pos - start));
        let start = self.pos;
        self.put(&(paths.len() as u64).to_le_bytes())?;
        self.put(&(order.len() as u64).to_le_bytes())?;
        self.put_ints(&order.iter().map(|o| o.0 as i32).collect::<Vec<_>>())?;
        self.put_ints(&order.iter().map(|o| elements[o.0]).collect::<Vec<_>>())?;
        self.put_ints(&order.iter().map(|o| o.1).collect::<Vec<_>>())?;
        sections.push(("PATHS", start, self.pos - start));
        let start = self.pos;
        self.put(&(spec_rows.len() as u64).to_le_bytes())?;
        for k in 0..3 {
            self.put_ints(&spec_rows.iter().map(|r| r[k]).collect::<Vec<_>>())?;
        }
        sections.push(("SPECS", start, self.pos - start));
        Ok(sections)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The integer coding decodes back (the crate's decoder, written from its description).
    #[test]
    fn integer_coding_round_trips() {
        let values: Vec<i32> = vec![0, 1, 2, 3, 3, 200, -5, 70000, -1, -1, 2, i32::MAX, i32::MIN, 9];
        let enc = encode_ints(&values);
        let common = i32::from_le_bytes(enc[0..4].try_into().unwrap());
        let codes = &enc[4..4 + (values.len() * 2).div_ceil(8)];
        let mut at = 4 + codes.len();
        let (mut prev, mut out) = (0i32, vec![]);
        for i in 0..values.len() {
            let d = match codes[i / 4] >> (2 * (i % 4)) & 3 {
                0 => common,
                1 => {
                    at += 1;
                    enc[at - 1] as i8 as i32
                }
                2 => {
                    at += 2;
                    i16::from_le_bytes(enc[at - 2..at].try_into().unwrap()) as i32
                }
                _ => {
                    at += 4;
                    i32::from_le_bytes(enc[at - 4..at].try_into().unwrap())
                }
            };
            prev = prev.wrapping_add(d);
            out.push(prev);
        }
        assert_eq!(out, values);
        assert_eq!(at, enc.len());
    }

    /// A literal-only LZ4 block: token, length bytes, the data.
    #[test]
    fn lz4_literal_blocks() {
        assert_eq!(lz4_literals(b"abc"), [0, 0x30, b'a', b'b', b'c']);
        let long = vec![7u8; 15 + 255 + 3];
        let b = lz4_literals(&long);
        assert_eq!(&b[..4], &[0, 0xF0, 255, 3]);
        assert_eq!(&b[4..], &long[..]);
    }
}
