//! VTK XML (`.vtu` UnstructuredGrid, `.vtp` PolyData): the `<Points>` array and every `<PointData>` array, in
//! every layout VTK's XML writers produce — `ascii`, inline `binary` (base64), `appended` raw or base64 (offsets
//! count characters of the encoded section) — with the block header and the data in one base64 run (VTK without
//! compression) or in separate runs (compressed), compressed by `vtkZLibDataCompressor`,
//! `vtkLZ4DataCompressor` or `vtkLZMADataCompressor`, UInt32 or UInt64 headers, either byte order. Elements VTK
//! nests inside a DataArray (`<InformationKey>` ranges) are skipped. XML by quick-xml, base64 by `base64`,
//! zlib by flate2, LZ4 by lz4_flex, LZMA (.xz) by lzma-rs. Sizes claimed in headers are checked against the
//! bytes present and the point count before anything is allocated or inflated. Fixtures written by VTK itself
//! and by meshio: tests/fixtures/vtk (tools/vtk-fixtures/make_fixtures.py).

use std::io::Read;
use std::path::Path;

use base64::Engine;
use quick_xml::events::Event;

use super::bytes::Scalar;
use crate::error::{Error, Result};
use crate::scene::{Attribute, Raw};

#[derive(Clone, Debug, Default)]
struct ArrayDesc {
    name: String,
    ty: String,
    comps: usize,
    format: String,
    offset: Option<usize>,
    text: String,
    in_points: bool,
    at: usize,
}

/// The block compressors VTK's XML writers use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Compressor {
    None,
    Zlib,
    Lz4,
    Lzma,
}

impl Compressor {
    fn from_attr(name: Option<&str>) -> std::result::Result<Compressor, String> {
        Ok(match name {
            None | Some("") => Compressor::None,
            Some("vtkZLibDataCompressor") => Compressor::Zlib,
            Some("vtkLZ4DataCompressor") => Compressor::Lz4,
            Some("vtkLZMADataCompressor") => Compressor::Lzma,
            Some(c) => return Err(format!("unsupported compressor {c} (known: vtkZLibDataCompressor, vtkLZ4DataCompressor, vtkLZMADataCompressor)")),
        })
    }

    /// Decompress one block into `out`, at most `limit` bytes (the block's uncompressed size).
    fn inflate(self, comp: &[u8], limit: usize, out: &mut Vec<u8>) -> std::result::Result<(), String> {
        match self {
            Compressor::None => out.extend_from_slice(&comp[..comp.len().min(limit)]),
            Compressor::Zlib => {
                flate2::read::ZlibDecoder::new(comp).take(limit as u64).read_to_end(out).map_err(|e| e.to_string())?;
            }
            Compressor::Lz4 => out.extend(lz4_flex::block::decompress(comp, limit).map_err(|e| e.to_string())?),
            Compressor::Lzma => {
                // Into a writer that refuses more than the block holds: no decompression bomb gets far.
                let mut w = Limited { out, left: limit };
                // lzma-rs 0.3 overflows an integer on some corrupt stream footers (a panic where overflow checks
                // are on, as in debug builds; found by tests/properties.rs): that is a corrupt stream too.
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    lzma_rs::xz_decompress(&mut std::io::BufReader::new(comp), &mut w).map_err(|e| e.to_string())
                }))
                .unwrap_or_else(|_| Err("corrupt xz stream".into()))?;
            }
        }
        Ok(())
    }
}

/// A writer that takes at most `left` more bytes.
struct Limited<'a> {
    out: &'a mut Vec<u8>,
    left: usize,
}

impl std::io::Write for Limited<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if buf.len() > self.left {
            return Err(std::io::Error::other("the block inflates past its stated size"));
        }
        self.out.extend_from_slice(buf);
        self.left -= buf.len();
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

struct Ctx<'a> {
    path: &'a Path,
    big: bool,
    header: usize,
    compressor: Compressor,
}

impl Ctx<'_> {
    fn err(&self, at: usize, reason: impl Into<String>) -> Error {
        super::bytes::err_at(self.path, at, reason)
    }
    fn uint(&self, b: &[u8]) -> u64 {
        (if self.header == 8 { Scalar::U64 } else { Scalar::U32 }).read(b, self.big) as u64
    }
    /// Decode one array's bytes from a header-prefixed block; `take(n)` yields the next n bytes of the block.
    fn block(&self, at: usize, want: usize, take: &mut dyn FnMut(usize) -> Option<Vec<u8>>) -> Result<Vec<u8>> {
        let h = self.header;
        let short = || self.err(at, "data block truncated");
        if self.compressor == Compressor::None {
            let n = self.uint(&take(h).ok_or_else(short)?) as usize;
            if n != want {
                return Err(self.err(
                    at,
                    format!(
                        "data block holds {n} bytes, the array needs {want}{}",
                        if n > want { " (NumberOfPoints under-counts the data?)" } else { "" }
                    ),
                ));
            }
            return take(want).ok_or_else(short);
        }
        let head = take(3 * h).ok_or_else(short)?;
        let (nb, bs, last) = (self.uint(&head[..h]), self.uint(&head[h..2 * h]), self.uint(&head[2 * h..]));
        let total =
            if nb == 0 { 0 } else { (nb - 1).saturating_mul(bs).saturating_add(if last == 0 { bs } else { last }) };
        if total != want as u64 || nb > (want as u64 / bs.max(1)) + 2 {
            return Err(self.err(
                at,
                format!("compressed header claims {nb} blocks of {bs} bytes ({total} bytes); the array needs {want}"),
            ));
        }
        let sizes = take(nb as usize * h).ok_or_else(short)?;
        let mut out = Vec::with_capacity(want);
        for k in 0..nb as usize {
            let cs = self.uint(&sizes[k * h..(k + 1) * h]) as usize;
            let comp = take(cs).ok_or_else(short)?;
            let limit = if k + 1 == nb as usize && last != 0 { last } else { bs };
            let before = out.len();
            self.compressor
                .inflate(&comp, limit as usize, &mut out)
                .map_err(|e| self.err(at, format!("{:?} block {k} is corrupt: {e}", self.compressor)))?;
            if out.len() - before != limit as usize && (k + 1 < nb as usize) {
                return Err(self
                    .err(at, format!("block {k} inflates to {} bytes, the header says {limit}", out.len() - before)));
            }
        }
        if out.len() < want {
            return Err(self.err(at, format!("inflated {} bytes, the array needs {want}", out.len())));
        }
        out.truncate(want);
        Ok(out)
    }
}

/// The bytes of base64 text, decoded lazily in order. VTK writes one base64 run per block header and per data
/// (compressed) or one run for header and data together (uncompressed); either way the logical byte sequence is
/// the same. A run ends at a 4-character group that holds '=' padding; runs of a multiple of 3 bytes have none,
/// and then the next run simply continues the group sequence, so decoding group-aligned chunks that end at the
/// next padded group (or earlier) yields exactly the concatenated bytes.
struct B64<'a> {
    text: std::borrow::Cow<'a, [u8]>,
    pos: usize,
    buf: Vec<u8>,
    bpos: usize,
    /// End (exclusive, absolute) of the next 4-character group holding '=' at or after `pos`; found once per run.
    pad_end: Option<usize>,
}

impl<'a> B64<'a> {
    /// Base64 text with whitespace anywhere (inline arrays).
    fn new(text: &str) -> B64<'static> {
        let t: Vec<u8> = text.bytes().filter(|b| !b.is_ascii_whitespace()).collect();
        B64 { text: std::borrow::Cow::Owned(t), pos: 0, buf: vec![], bpos: 0, pad_end: None }
    }

    /// Base64 text already free of whitespace (the appended section, filtered once).
    fn clean(text: &'a [u8]) -> B64<'a> {
        B64 { text: std::borrow::Cow::Borrowed(text), pos: 0, buf: vec![], bpos: 0, pad_end: None }
    }

    /// The next `n` bytes, or None when the text ends first or is not base64.
    fn take(&mut self, n: usize) -> Option<Vec<u8>> {
        let end = self.bpos.checked_add(n)?;
        while self.buf.len() < end {
            if self.pos >= self.text.len() {
                return None;
            }
            let missing = end - self.buf.len();
            // Whole groups up to the next padded group, and no more than the bytes still missing need.
            if self.pad_end.is_none_or(|p| p <= self.pos) {
                let rest = &self.text[self.pos..];
                let rel = rest.iter().position(|&c| c == b'=').map(|k| (k / 4 + 1) * 4).unwrap_or(rest.len());
                self.pad_end = Some(self.pos + rel.min(rest.len()));
            }
            let limit = self.pad_end.unwrap_or(self.text.len());
            let want = missing.div_ceil(3).checked_mul(4)?;
            let stop = limit.min(self.pos.checked_add(want.max(4))?).min(self.text.len());
            let chunk = &self.text[self.pos..stop];
            base64::engine::general_purpose::STANDARD.decode_vec(chunk, &mut self.buf).ok()?;
            self.pos = stop;
        }
        let r = self.buf[self.bpos..end].to_vec();
        self.bpos = end;
        // Keep the buffer small: drop what was handed out.
        if self.bpos > 1 << 20 {
            self.buf.drain(..self.bpos);
            self.bpos = 0;
        }
        Some(r)
    }
}

/// Parse VTU/VTP bytes: the XML scanned for the arrays' descriptions ([`scan`]), then each array decoded
/// ([`values`]) from its inline text or the appended section.
pub fn parse(path: &Path, bytes: &[u8]) -> Result<Raw> {
    let perr = |at: usize, r: String| super::bytes::err_at(path, at, r);
    // Appended data is not XML: cut it off, remember where it starts.
    let (xml, appended, app_b64) = match find(bytes, b"<AppendedData") {
        Some(i) => {
            let tag_end = bytes[i..]
                .iter()
                .position(|&b| b == b'>')
                .map(|k| i + k)
                .ok_or_else(|| perr(i, "unterminated <AppendedData>".into()))?;
            let tag = String::from_utf8_lossy(&bytes[i..tag_end]);
            let us = bytes[tag_end..]
                .iter()
                .position(|&b| b == b'_')
                .map(|k| tag_end + k + 1)
                .ok_or_else(|| perr(tag_end, "appended data lacks the '_' marker".into()))?;
            (&bytes[..i], Some(us), tag.contains("base64"))
        }
        None => (bytes, None, false),
    };
    let Scanned { big, header, compressor, n_points, arrays } = scan(path, xml)?;
    let n = n_points.ok_or_else(|| perr(0, "no <Piece NumberOfPoints=…>".into()))?;
    let ctx = Ctx { path, big, header, compressor };
    // The encoded appended section, whitespace removed once (offsets count its characters).
    let app_text: Option<Vec<u8>> = match (appended, app_b64) {
        (Some(start), true) => {
            let end = find(&bytes[start..], b"<").map(|k| start + k).unwrap_or(bytes.len());
            Some(bytes[start..end].iter().copied().filter(|b| !b.is_ascii_whitespace()).collect())
        }
        _ => None,
    };
    let appended = Appended { bytes, start: appended, text: app_text.as_deref().filter(|_| app_b64) };
    let mut positions = None;
    let mut out = vec![];
    for a in arrays {
        let vals = values(&ctx, &a, n, &appended)?;
        if a.in_points {
            if a.comps != 3 {
                return Err(perr(a.at, format!("<Points> array has {} components, expected 3", a.comps)));
            }
            positions = Some(vals.chunks_exact(3).map(|c| [c[0] as f32, c[1] as f32, c[2] as f32]).collect());
        } else {
            out.push(Attribute { name: a.name, components: a.comps, data: vals });
        }
    }
    let positions = positions.ok_or_else(|| perr(0, "no <Points> DataArray".into()))?;
    Ok(Raw { positions, arrays: out })
}

/// What the XML says: the byte order, the block header's size, the compressor, the point count and the arrays
/// of `<Points>` and `<PointData>`.
struct Scanned {
    big: bool,
    header: usize,
    compressor: Compressor,
    n_points: Option<usize>,
    arrays: Vec<ArrayDesc>,
}

/// Scan the XML part of a VTU/VTP file (the appended data cut off) for its header and arrays.
fn scan(path: &Path, xml: &[u8]) -> Result<Scanned> {
    let perr = |at: usize, r: String| super::bytes::err_at(path, at, r);
    let mut rd = quick_xml::Reader::from_reader(xml);
    rd.config_mut().check_end_names = false;
    let mut buf = vec![];
    let (mut big, mut header, mut compressor) = (false, 4, Compressor::None);
    // Depth of elements nested inside the current DataArray (VTK's <InformationKey> ranges): their text is
    // not array data.
    let mut nested = 0usize;
    let mut n_points: Option<usize> = None;
    let (mut in_points, mut in_point_data) = (false, false);
    let mut arrays: Vec<ArrayDesc> = vec![];
    let mut current: Option<ArrayDesc> = None;
    loop {
        let at = rd.buffer_position() as usize;
        let ev = match rd.read_event_into(&mut buf) {
            Ok(e) => e,
            Err(e) => return Err(perr(at, format!("malformed XML: {e}"))),
        };
        match ev {
            Event::Eof => break,
            Event::Start(ref e) | Event::Empty(ref e) => {
                let empty = matches!(ev, Event::Empty(_));
                let get = |k: &str| -> Option<String> {
                    e.attributes()
                        .flatten()
                        .find(|a| a.key.as_ref() == k.as_bytes())
                        .map(|a| String::from_utf8_lossy(&a.value).into_owned())
                };
                if current.is_some() {
                    if !empty {
                        nested += 1;
                    }
                    buf.clear();
                    continue;
                }
                match e.name().as_ref() {
                    b"VTKFile" => {
                        big = get("byte_order").as_deref() == Some("BigEndian");
                        header = if get("header_type").as_deref() == Some("UInt64") { 8 } else { 4 };
                        compressor = Compressor::from_attr(get("compressor").as_deref()).map_err(|e| perr(at, e))?;
                    }
                    b"Piece" => {
                        if n_points.is_some() {
                            return Err(perr(at, "files with several <Piece>s are not supported".into()));
                        }
                        let n = get("NumberOfPoints").ok_or_else(|| perr(at, "<Piece> lacks NumberOfPoints".into()))?;
                        n_points = Some(n.trim().parse().map_err(|_| perr(at, format!("bad NumberOfPoints {n:?}")))?);
                    }
                    b"Points" => in_points = !empty,
                    b"PointData" => in_point_data = !empty,
                    b"DataArray" if in_points || in_point_data => {
                        let d = ArrayDesc {
                            name: get("Name").unwrap_or_default(),
                            ty: get("type").unwrap_or_default(),
                            comps: get("NumberOfComponents").and_then(|c| c.parse().ok()).unwrap_or(1),
                            format: get("format").unwrap_or_else(|| "ascii".into()),
                            offset: get("offset").and_then(|o| o.trim().parse().ok()),
                            text: String::new(),
                            in_points,
                            at,
                        };
                        if empty {
                            arrays.push(d);
                        } else {
                            current = Some(d);
                        }
                    }
                    _ => {}
                }
            }
            Event::Text(t) => {
                if let (Some(c), 0) = (current.as_mut(), nested) {
                    c.text.push_str(&String::from_utf8_lossy(&t));
                }
            }
            Event::End(_) if nested > 0 => nested -= 1,
            Event::End(ref e) => match e.name().as_ref() {
                b"DataArray" => {
                    if let Some(c) = current.take() {
                        arrays.push(c);
                    }
                }
                b"Points" => in_points = false,
                b"PointData" => in_point_data = false,
                _ => {}
            },
            _ => {}
        }
        buf.clear();
    }
    Ok(Scanned { big, header, compressor, n_points, arrays })
}

/// The appended section: the file's bytes, where the section starts (after its '_'), and its base64 text with
/// whitespace removed when it is base64.
struct Appended<'a> {
    bytes: &'a [u8],
    start: Option<usize>,
    text: Option<&'a [u8]>,
}

/// The values of array `a` of `n` points: its ASCII text, base64 inline blocks or appended blocks, checked
/// against what the file can hold before anything is inflated.
fn values(ctx: &Ctx, a: &ArrayDesc, n: usize, app: &Appended) -> Result<Vec<f64>> {
    let perr = |at: usize, r: String| super::bytes::err_at(ctx.path, at, r);
    let (bytes, appended, big, compressor) = (app.bytes, app.start, ctx.big, ctx.compressor);
    let scalar = Scalar::parse(&a.ty)
        .ok_or_else(|| perr(a.at, format!("DataArray {:?}: unsupported type {:?}", a.name, a.ty)))?;
    let size = scalar.size();
    let count = n.checked_mul(a.comps).ok_or_else(|| perr(a.at, "array size overflows".into()))?;
    let want = count.checked_mul(size).ok_or_else(|| perr(a.at, "array size overflows".into()))?;
    // Bytes that can hold this array: the inline text or the appended section (zlib inflates ≤ 1032×).
    let avail = if a.format == "appended" { appended.map(|s| bytes.len() - s).unwrap_or(0) } else { a.text.len() };
    // zlib inflates ≤ 1032×, LZ4 ≤ 255×; LZMA can exceed that on degenerate data, so it gets a wide bound.
    let ratio = match compressor {
        Compressor::None => 1,
        Compressor::Zlib | Compressor::Lz4 => 1100,
        Compressor::Lzma => 100_000,
    };
    let limit = avail.saturating_mul(ratio).saturating_add(64);
    if a.format != "ascii" && want > limit {
        return Err(perr(
            a.at,
            format!(
                "DataArray {:?}: {n} points × {} components need {want} bytes, more than the file holds",
                a.name, a.comps
            ),
        ));
    }
    let vals: Vec<f64> = match a.format.as_str() {
        "ascii" => {
            let held = a.text.split_ascii_whitespace().count();
            if held > count {
                return Err(perr(
                    a.at,
                    format!(
                        "DataArray {:?}: {held} values, more than the {n} points × {} components declared \
                         (NumberOfPoints under-counts the data?)",
                        a.name, a.comps
                    ),
                ));
            }
            let v: Vec<f64> = a
                .text
                .split_ascii_whitespace()
                .take(count)
                .map(|t| t.parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| perr(a.at, format!("DataArray {:?}: not a number in ascii data", a.name)))?;
            if v.len() < count {
                return Err(perr(
                    a.at,
                    format!(
                        "DataArray {:?}: {n} points × {} components need {count} values, the file has {}",
                        a.name,
                        a.comps,
                        v.len()
                    ),
                ));
            }
            v
        }
        "binary" => {
            let mut b = B64::new(&a.text);
            let raw = ctx.block(a.at, want, &mut |k| b.take(k))?;
            raw.chunks_exact(size).map(|c| scalar.read(c, big)).collect()
        }
        "appended" => {
            let start = appended.ok_or_else(|| perr(a.at, "format=\"appended\" but no <AppendedData>".into()))?;
            let off = a.offset.ok_or_else(|| perr(a.at, format!("DataArray {:?} lacks offset", a.name)))?;
            let raw = if let Some(text) = app.text {
                let mut b = B64::clean(
                    text.get(off..).ok_or_else(|| perr(a.at, format!("offset {off} past the appended data")))?,
                );
                ctx.block(start + off, want, &mut |k| b.take(k))?
            } else {
                let mut p = start
                    .checked_add(off)
                    .filter(|&p| p <= bytes.len())
                    .ok_or_else(|| perr(a.at, format!("offset {off} past the end of the file")))?;
                ctx.block(p, want, &mut |k| {
                    let r = bytes.get(p..p.checked_add(k)?)?.to_vec();
                    p += k;
                    Some(r)
                })?
            };
            raw.chunks_exact(size).map(|c| scalar.read(c, big)).collect()
        }
        f => return Err(perr(a.at, format!("DataArray {:?}: unknown format {f:?}", a.name))),
    };
    Ok(vals)
}

fn find(h: &[u8], needle: &[u8]) -> Option<usize> {
    h.windows(needle.len()).position(|w| w == needle)
}

/// How [`write`] encodes the arrays.
#[derive(Clone, Copy, Debug)]
pub enum Encoding {
    /// Inline ASCII values.
    Ascii,
    /// Inline base64 binary, optionally zlib-compressed.
    Binary {
        /// Compress each block with zlib.
        zlib: bool,
    },
    /// Raw appended data, optionally zlib-compressed.
    AppendedRaw {
        /// Compress each block with zlib.
        zlib: bool,
    },
    /// Appended base64.
    AppendedBase64,
}

/// Write a VTU (UnstructuredGrid of points, no cells) in the given encoding, little-endian, UInt64 headers.
pub fn write(p: &Raw, enc: Encoding) -> Vec<u8> {
    let zlib = matches!(enc, Encoding::Binary { zlib: true } | Encoding::AppendedRaw { zlib: true });
    let b64 = base64::engine::general_purpose::STANDARD;
    let n = p.positions.len();
    let mut arrays: Vec<(String, usize, Vec<f32>, bool)> =
        vec![("Points".into(), 3, p.positions.iter().flatten().copied().collect(), true)];
    for a in &p.arrays {
        arrays.push((a.name.clone(), a.components, a.data.iter().map(|&x| x as f32).collect(), false));
    }
    let block = |data: &[f32]| -> (Vec<u8>, Vec<u8>) {
        let raw: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        if zlib {
            let mut e = flate2::write::ZlibEncoder::new(vec![], flate2::Compression::fast());
            std::io::Write::write_all(&mut e, &raw).unwrap();
            let c = e.finish().unwrap();
            let mut h = vec![];
            for v in [1u64, raw.len().max(1) as u64, raw.len() as u64, c.len() as u64] {
                h.extend_from_slice(&v.to_le_bytes());
            }
            (h, c)
        } else {
            ((raw.len() as u64).to_le_bytes().to_vec(), raw)
        }
    };
    let mut xml = String::from("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\"");
    if zlib {
        xml.push_str(" compressor=\"vtkZLibDataCompressor\"");
    }
    xml.push_str(&format!(">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"{n}\" NumberOfCells=\"0\">\n"));
    let mut appended: Vec<u8> = vec![];
    let mut emit = |xml: &mut String, (name, comps, data, _): &(String, usize, Vec<f32>, bool)| {
        let head = format!("<DataArray type=\"Float32\" Name=\"{name}\" NumberOfComponents=\"{comps}\"");
        match enc {
            Encoding::Ascii => {
                let t: Vec<String> = data.iter().map(|x| x.to_string()).collect();
                xml.push_str(&format!("{head} format=\"ascii\">\n{}\n</DataArray>\n", t.join(" ")));
            }
            Encoding::Binary { .. } => {
                let (h, d) = block(data);
                xml.push_str(&format!("{head} format=\"binary\">\n{}{}\n</DataArray>\n", b64.encode(h), b64.encode(d)));
            }
            Encoding::AppendedRaw { .. } => {
                let (h, d) = block(data);
                xml.push_str(&format!("{head} format=\"appended\" offset=\"{}\"/>\n", appended.len()));
                appended.extend_from_slice(&h);
                appended.extend_from_slice(&d);
            }
            Encoding::AppendedBase64 => {
                let (h, d) = block(data);
                xml.push_str(&format!("{head} format=\"appended\" offset=\"{}\"/>\n", appended.len()));
                appended.extend_from_slice(b64.encode(h).as_bytes());
                appended.extend_from_slice(b64.encode(d).as_bytes());
            }
        }
    };
    xml.push_str("<PointData>\n");
    for a in arrays.iter().filter(|a| !a.3) {
        emit(&mut xml, a);
    }
    xml.push_str("</PointData>\n<Points>\n");
    emit(&mut xml, &arrays[0]);
    xml.push_str("</Points>\n<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\"></DataArray>\n</Cells>\n</Piece>\n</UnstructuredGrid>\n");
    let mut out = xml.into_bytes();
    if !appended.is_empty() {
        let e = if matches!(enc, Encoding::AppendedBase64) { "base64" } else { "raw" };
        out.extend_from_slice(format!("<AppendedData encoding=\"{e}\">\n_").as_bytes());
        out.extend_from_slice(&appended);
        out.extend_from_slice(b"\n</AppendedData>\n");
    }
    out.extend_from_slice(b"</VTKFile>\n");
    out
}

/// This format in the registry ([`super::format::FORMATS`]).
pub struct Vtu;

impl super::format::ParticleFormat for Vtu {
    fn key(&self) -> &'static str {
        "vtu"
    }
    fn name(&self) -> &'static str {
        "VTK XML (VTU/VTP)"
    }
    fn extensions(&self) -> &'static [&'static str] {
        &["vtu", "vtp"]
    }
    fn sniff(&self, head: &[u8]) -> bool {
        {
            let text = String::from_utf8_lossy(head);
            let t = text.trim_start_matches('\u{feff}').trim_start();
            t.starts_with("<?xml") || t.starts_with("<VTKFile")
        }
    }
    fn parse(&self, path: &Path, bytes: &[u8]) -> Result<Raw> {
        parse(path, bytes)
    }
    fn samples(&self, raw: &Raw) -> Vec<(&'static str, Vec<u8>)> {
        vec![
            ("ascii", write(raw, Encoding::Ascii)),
            ("binary", write(raw, Encoding::Binary { zlib: false })),
            ("binary-zlib", write(raw, Encoding::Binary { zlib: true })),
            ("appended-raw", write(raw, Encoding::AppendedRaw { zlib: false })),
            ("appended-raw-zlib", write(raw, Encoding::AppendedRaw { zlib: true })),
            ("appended-base64", write(raw, Encoding::AppendedBase64)),
        ]
    }
}
