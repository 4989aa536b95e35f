//! The particle-format registry: ONE table ([`FORMATS`]) of every format the loaders read. Detection, loading,
//! `meniscus info`, the sequence extensions, the CLI help, the round-trip and malformed-input tests, the fuzz
//! target, the fuzz seeds and the loader benchmark all iterate over it. A new format is one file implementing
//! [`ParticleFormat`] and one line here.

use std::path::Path;

use super::Raw;
use crate::error::Result;

/// What the registry needs of a particle format.
pub trait ParticleFormat: Sync {
    /// Short key (file names of tests and fuzz seeds, the benchmark): `bgeo`, `vtk`, …
    fn key(&self) -> &'static str;
    /// Human name (`meniscus info`, errors, help).
    fn name(&self) -> &'static str;
    /// File extensions, lower case, without the dot; the first is the one writers use.
    fn extensions(&self) -> &'static [&'static str];
    /// Recognise the format from the first bytes of the (gunzipped) content; false where it has no signature.
    fn sniff(&self, _head: &[u8]) -> bool {
        false
    }
    /// A weaker guess from the first text line, tried after the extensions (CSV's header).
    fn sniff_header(&self, _first_line: &str) -> bool {
        false
    }
    /// Parse a whole file into named arrays (errors carry the byte offset).
    fn parse(&self, path: &Path, bytes: &[u8]) -> Result<Raw>;
    /// Every writer variant of this format, as (label, file bytes) — round-trip tests, fuzz seeds, the
    /// benchmark. Empty for read-only formats.
    fn samples(&self, raw: &Raw) -> Vec<(&'static str, Vec<u8>)>;
    /// The format stores positions only (no attributes survive a round trip).
    fn positions_only(&self) -> bool {
        false
    }
}

/// THE registry, in detection order.
pub static FORMATS: &[&dyn ParticleFormat] = &[
    &super::bgeo::Bgeo,
    &super::vtk::Vtk,
    &super::vtu::Vtu,
    &super::ply::Ply,
    &super::realflow::RealFlow,
    &super::xyz::Xyz,
    &super::csv::Csv,
];

/// A format by its key.
pub fn by_key(key: &str) -> Option<&'static dyn ParticleFormat> {
    FORMATS.iter().copied().find(|f| f.key() == key)
}

/// Every extension a sequence folder or glob picks up.
pub fn extensions() -> impl Iterator<Item = &'static str> {
    FORMATS.iter().flat_map(|f| f.extensions().iter().copied())
}

/// "Houdini classic BGEO (.bgeo, .gz), legacy VTK (.vtk), …" for help and error texts.
pub fn describe() -> String {
    FORMATS
        .iter()
        .map(|f| {
            let ext: Vec<String> = f.extensions().iter().map(|e| format!(".{e}")).collect();
            format!("{} ({})", f.name(), ext.join(", "))
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Detect the format: a content signature (gzip is looked through), else the extension, else a header guess.
pub fn detect(path: &Path, bytes: &[u8]) -> Option<&'static dyn ParticleFormat> {
    let head = if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut d = flate2::read::GzDecoder::new(bytes);
        let mut buf = [0u8; 64];
        let n = std::io::Read::read(&mut d, &mut buf).unwrap_or(0);
        buf[..n].to_vec()
    } else {
        bytes[..bytes.len().min(256)].to_vec()
    };
    if let Some(f) = FORMATS.iter().find(|f| f.sniff(&head)) {
        return Some(*f);
    }
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    if let Some(f) = ext.and_then(|e| FORMATS.iter().find(|f| f.extensions().contains(&e.as_str()))) {
        return Some(*f);
    }
    let text = String::from_utf8_lossy(&head);
    let first = text.lines().next().unwrap_or("");
    FORMATS.iter().find(|f| f.sniff_header(first)).copied()
}
