//! PLY (Turk 1994): ASCII, binary little- and big-endian. The `vertex` element's `x y z` give positions; its
//! other scalar properties become attributes (`nx ny nz`-style triples and `vx vy vz` are grouped by the CSV
//! rules). Elements before `vertex` (and list properties) are skipped properly. Hand-written: the PLY crates on
//! crates.io are unmaintained (ply-rs: last release 2020) and none bounds its allocations by the file size.

use std::path::Path;

use super::bytes::Scalar;
use crate::error::Result;
use crate::scene::{Attribute, Raw};

#[derive(Clone, Copy, Debug, PartialEq)]
enum Enc {
    Ascii,
    Le,
    Be,
}

#[derive(Clone, Debug)]
enum Prop {
    Scalar { name: String, ty: Scalar },
    List { count_ty: Scalar, item_ty: Scalar },
}

struct Element {
    name: String,
    count: usize,
    props: Vec<Prop>,
}

/// Parse PLY bytes: the header ([`header`]), every element's values in order ([`Body`]: only the vertices' are
/// kept, and nothing may follow the last element), the vertex columns grouped into positions and attributes
/// ([`columns`]).
pub fn parse(path: &Path, bytes: &[u8]) -> Result<Raw> {
    let err = |offset: usize, reason: String| super::bytes::err_at(path, offset, reason);
    let (enc, elements, pos) = header(path, bytes)?;
    let vi = elements.iter().position(|e| e.name == "vertex").ok_or_else(|| err(0, "no vertex element".into()))?;
    // Bound allocations: every vertex takes at least one byte per property (two in ASCII).
    let v = &elements[vi];
    let min_bytes = v.props.len().max(1) * if enc == Enc::Ascii { 2 } else { 1 };
    if v.count > (bytes.len() - pos) / min_bytes + 1 {
        return Err(err(
            pos,
            format!("header claims {} vertices, more than the {} bytes of data can hold", v.count, bytes.len() - pos),
        ));
    }
    let mut body = Body { path, bytes, pos, enc, tokens: (enc == Enc::Ascii).then_some(AsciiTokens { b: bytes, pos }) };
    let mut values: Vec<Vec<f64>> = vec![];
    // Every element is read (only the vertices are kept), so that data beyond what the header declares shows.
    for (k, el) in elements.iter().enumerate() {
        let keep = k == vi;
        if keep {
            values = vec![Vec::with_capacity(el.count); el.props.len()];
        }
        for _ in 0..el.count {
            for (j, prop) in el.props.iter().enumerate() {
                match prop {
                    Prop::Scalar { ty, .. } => {
                        let x = body.num(*ty, &el.name)?;
                        if keep {
                            values[j].push(x);
                        }
                    }
                    Prop::List { count_ty, item_ty } => {
                        let n = body.num(*count_ty, &el.name)?;
                        if !(0.0..1e9).contains(&n) {
                            return Err(err(body.pos, format!("bad list length {n}")));
                        }
                        for _ in 0..n as usize {
                            body.num(*item_ty, "a list")?;
                        }
                    }
                }
            }
        }
    }
    // Nothing may follow the last element (a header that under-counts its vertices or faces).
    let rest = body.end();
    if rest < bytes.len() {
        return Err(err(
            rest,
            format!(
                "{} bytes follow the {} vertices{} the header declares (a header that under-counts them?)",
                bytes.len() - rest,
                v.count,
                if vi + 1 < elements.len() { " and the elements after them" } else { "" }
            ),
        ));
    }
    columns(path, v, &values)
}

/// The header's lines up to "end_header": the encoding, the elements with their properties, and where the data
/// starts.
fn header(path: &Path, bytes: &[u8]) -> Result<(Enc, Vec<Element>, usize)> {
    let err = |offset: usize, reason: String| super::bytes::err_at(path, offset, reason);
    let mut pos = 0;
    let mut enc = None;
    let mut elements: Vec<Element> = vec![];
    loop {
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .ok_or_else(|| err(pos, "header has no end_header line".into()))?;
        let line = String::from_utf8_lossy(&bytes[pos..pos + end]).trim().to_string();
        let at = pos;
        pos += end + 1;
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.first().copied() {
            Some("ply") | Some("comment") | Some("obj_info") | None => {}
            Some("format") => {
                enc = Some(match w.get(1).copied() {
                    Some("ascii") => Enc::Ascii,
                    Some("binary_little_endian") => Enc::Le,
                    Some("binary_big_endian") => Enc::Be,
                    other => return Err(err(at, format!("unknown PLY format {other:?}"))),
                })
            }
            Some("element") => {
                let count: usize = w
                    .get(2)
                    .and_then(|c| c.parse().ok())
                    .ok_or_else(|| err(at, format!("bad element line {line:?}")))?;
                elements.push(Element { name: w.get(1).unwrap_or(&"").to_string(), count, props: vec![] });
            }
            Some("property") => {
                let el = elements.last_mut().ok_or_else(|| err(at, "property before any element".into()))?;
                if w.get(1) == Some(&"list") {
                    let (Some(c), Some(i)) =
                        (w.get(2).and_then(|t| Scalar::parse(t)), w.get(3).and_then(|t| Scalar::parse(t)))
                    else {
                        return Err(err(at, format!("bad list property {line:?}")));
                    };
                    el.props.push(Prop::List { count_ty: c, item_ty: i });
                } else {
                    let ty = w
                        .get(1)
                        .and_then(|t| Scalar::parse(t))
                        .ok_or_else(|| err(at, format!("unknown property type in {line:?}")))?;
                    let name = w.get(2).ok_or_else(|| err(at, format!("property without a name: {line:?}")))?;
                    el.props.push(Prop::Scalar { name: name.to_string(), ty });
                }
            }
            Some("end_header") => break,
            Some(other) => return Err(err(at, format!("unexpected header keyword {other:?}"))),
        }
    }
    let enc = enc.ok_or_else(|| err(0, "header has no format line".into()))?;
    Ok((enc, elements, pos))
}

/// The data after the header, read value by value: ASCII tokens or binary scalars.
struct Body<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    /// The next binary value's offset.
    pos: usize,
    enc: Enc,
    tokens: Option<AsciiTokens<'a>>,
}

impl Body<'_> {
    /// The next value, of type `ty` in a binary file; `within` names where it is for the error.
    fn num(&mut self, ty: Scalar, within: &str) -> Result<f64> {
        if let Some(t) = self.tokens.as_mut() {
            return t.next_num().map_err(|(o, r)| super::bytes::err_at(self.path, o, r));
        }
        let s = ty.size();
        if self.bytes.len() - self.pos < s {
            return Err(super::bytes::err_at(self.path, self.pos, format!("file truncated in element {within:?}")));
        }
        let x = ty.read(&self.bytes[self.pos..], self.enc == Enc::Be);
        self.pos += s;
        Ok(x)
    }

    /// Where the data read so far ends (trailing whitespace of an ASCII file included).
    fn end(&self) -> usize {
        match &self.tokens {
            Some(t) => t.pos + t.b[t.pos..].iter().take_while(|b| b.is_ascii_whitespace()).count(),
            None => self.pos,
        }
    }
}

/// The vertex element's columns: x, y, z as positions, the other scalar properties grouped like CSV columns
/// (vx vy vz → velocity, nx ny nz → n).
fn columns(path: &Path, v: &Element, values: &[Vec<f64>]) -> Result<Raw> {
    let err = |offset: usize, reason: String| super::bytes::err_at(path, offset, reason);
    let names: Vec<Option<&str>> =
        v.props.iter().map(|p| if let Prop::Scalar { name, .. } = p { Some(name.as_str()) } else { None }).collect();
    let col = |n: &str| names.iter().position(|m| *m == Some(n));
    let (Some(x), Some(y), Some(z)) = (col("x"), col("y"), col("z")) else {
        return Err(err(0, "the vertex element has no x, y and z properties".into()));
    };
    let positions = (0..v.count).map(|i| [values[x][i] as f32, values[y][i] as f32, values[z][i] as f32]).collect();
    let mut arrays: Vec<Attribute> = vec![];
    for (j, n) in names.iter().enumerate() {
        let Some(n) = n else { continue };
        if [x, y, z].contains(&j) {
            continue;
        }
        let grouped = super::csv_split(n);
        let (base, comp) = grouped.unwrap_or_else(|| (n.to_string(), 0));
        match arrays.iter_mut().find(|a| a.name == base) {
            Some(a) if comp == a.components => {
                // Append a component: interleave.
                let old = std::mem::take(&mut a.data);
                let k = a.components;
                a.data =
                    (0..v.count).flat_map(|i| old[i * k..i * k + k].iter().copied().chain([values[j][i]])).collect();
                a.components += 1;
            }
            _ => arrays.push(Attribute {
                name: if comp == 0 { base } else { n.to_string() },
                components: 1,
                data: values[j].clone(),
            }),
        }
    }
    Ok(Raw { positions, arrays })
}

struct AsciiTokens<'a> {
    b: &'a [u8],
    pos: usize,
}

impl AsciiTokens<'_> {
    fn next_num(&mut self) -> std::result::Result<f64, (usize, String)> {
        while self.pos < self.b.len() && self.b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let s = self.pos;
        while self.pos < self.b.len() && !self.b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        if s == self.pos {
            return Err((s, "file truncated: expected a number".into()));
        }
        let t = String::from_utf8_lossy(&self.b[s..self.pos]);
        t.parse::<f64>().map_err(|_| (s, format!("not a number: {t:?}")))
    }
}

/// Write PLY with `x y z` and every array as float properties (vectors as name_x …); `enc`: "ascii",
/// "binary_little_endian" or "binary_big_endian".
pub fn write(p: &Raw, enc: &str) -> Vec<u8> {
    let mut o = format!("ply\nformat {enc} 1.0\ncomment meniscus\nelement vertex {}\n", p.positions.len()).into_bytes();
    let mut props = vec!["x".to_string(), "y".into(), "z".into()];
    for a in &p.arrays {
        if a.components == 1 {
            props.push(a.name.clone());
        } else {
            for c in 0..a.components {
                props.push(format!("{}_{}", a.name, ["x", "y", "z", "w"][c.min(3)]));
            }
        }
    }
    for n in &props {
        o.extend_from_slice(format!("property float {n}\n").as_bytes());
    }
    o.extend_from_slice(b"element face 1\nproperty list uchar int vertex_indices\nend_header\n");
    for (i, pos) in p.positions.iter().enumerate() {
        let mut row: Vec<f32> = pos.to_vec();
        for a in &p.arrays {
            row.extend(a.data[i * a.components..(i + 1) * a.components].iter().map(|&x| x as f32));
        }
        match enc {
            "ascii" => {
                let line: Vec<String> = row.iter().map(|x| x.to_string()).collect();
                o.extend_from_slice(line.join(" ").as_bytes());
                o.push(b'\n');
            }
            "binary_big_endian" => row.iter().for_each(|x| o.extend_from_slice(&x.to_be_bytes())),
            _ => row.iter().for_each(|x| o.extend_from_slice(&x.to_le_bytes())),
        }
    }
    // One face, to exercise list skipping in readers.
    match enc {
        "ascii" => o.extend_from_slice(b"3 0 0 0\n"),
        "binary_big_endian" => {
            o.push(3);
            (0..3).for_each(|_| o.extend_from_slice(&0i32.to_be_bytes()));
        }
        _ => {
            o.push(3);
            (0..3).for_each(|_| o.extend_from_slice(&0i32.to_le_bytes()));
        }
    }
    o
}

/// This format in the registry ([`super::format::FORMATS`]).
pub struct Ply;

impl super::format::ParticleFormat for Ply {
    fn key(&self) -> &'static str {
        "ply"
    }
    fn name(&self) -> &'static str {
        "PLY"
    }
    fn extensions(&self) -> &'static [&'static str] {
        &["ply"]
    }
    fn sniff(&self, head: &[u8]) -> bool {
        head.starts_with(b"ply") && head.get(3).is_some_and(|c| *c == b'\n' || *c == b'\r')
    }
    fn parse(&self, path: &Path, bytes: &[u8]) -> Result<Raw> {
        parse(path, bytes)
    }
    fn samples(&self, raw: &Raw) -> Vec<(&'static str, Vec<u8>)> {
        vec![
            ("ascii", write(raw, "ascii")),
            ("binary-le", write(raw, "binary_little_endian")),
            ("binary-be", write(raw, "binary_big_endian")),
        ]
    }
}
