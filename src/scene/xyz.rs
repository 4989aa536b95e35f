//! Raw XYZ: little-endian f32 triplets with no header (binary), or text with three numbers per line (ASCII;
//! extra columns ignored, `#` comments). No signature: chosen by extension (.xyz, .raw, .f32).

use std::path::Path;

use crate::error::{Error, Result};
use crate::scene::Raw;

/// Parse binary or ASCII XYZ.
pub fn parse(path: &Path, bytes: &[u8]) -> Result<Raw> {
    let err = |offset: usize, reason: String| Error::Parse { path: path.to_path_buf(), offset: offset as u64, reason };
    let is_text = !bytes.is_empty()
        && bytes.iter().take(4096).all(|b| b.is_ascii_graphic() || b.is_ascii_whitespace())
        && bytes.iter().take(4096).any(|b| b.is_ascii_digit());
    if is_text {
        let mut positions = vec![];
        let mut offset = 0;
        for line in bytes.split(|&b| b == b'\n') {
            let text = String::from_utf8_lossy(line);
            let t = text.split('#').next().unwrap_or("").trim();
            if !t.is_empty() {
                let v: Vec<&str> = t.split(|c: char| c.is_whitespace() || c == ',').filter(|s| !s.is_empty()).collect();
                if v.len() < 3 {
                    return Err(err(offset, format!("expected three numbers x y z, found {t:?}")));
                }
                let mut p = [0f32; 3];
                for k in 0..3 {
                    p[k] = v[k].parse().map_err(|_| err(offset, format!("not a number: {:?}", v[k])))?;
                }
                positions.push(p);
            }
            offset += line.len() + 1;
        }
        return Ok(Raw { positions, arrays: vec![] });
    }
    if !bytes.len().is_multiple_of(12) {
        return Err(err(
            bytes.len() - bytes.len() % 12,
            format!(
                "binary XYZ must be a multiple of 12 bytes (3 × f32 per particle); {} bytes left over",
                bytes.len() % 12
            ),
        ));
    }
    let positions = bytes
        .chunks_exact(12)
        .map(|c| {
            let f = |k: usize| f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap());
            [f(0), f(1), f(2)]
        })
        .collect();
    Ok(Raw { positions, arrays: vec![] })
}

/// Write binary XYZ.
pub fn write(p: &Raw) -> Vec<u8> {
    p.positions.iter().flatten().flat_map(|x| x.to_le_bytes()).collect()
}

/// This format in the registry ([`super::format::FORMATS`]).
pub struct Xyz;

impl super::format::ParticleFormat for Xyz {
    fn key(&self) -> &'static str {
        "xyz"
    }
    fn name(&self) -> &'static str {
        "raw XYZ (f32 triplets or text)"
    }
    fn extensions(&self) -> &'static [&'static str] {
        &["xyz", "raw", "f32"]
    }
    fn positions_only(&self) -> bool {
        true
    }
    fn parse(&self, path: &Path, bytes: &[u8]) -> Result<Raw> {
        parse(path, bytes)
    }
    fn samples(&self, raw: &Raw) -> Vec<(&'static str, Vec<u8>)> {
        vec![("f32", write(raw)), ("text", b"0 1 2\n3.5 4 5\n".to_vec())]
    }
}
