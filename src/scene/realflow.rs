//! RealFlow particle `.bin` (Next Limit), versions 3–12, little-endian, packed records. Header: int32 magic
//! 0xFABADA, 250-byte fluid name, int16 version, float scale, fluid type / time / frame / fps (16 bytes), int32
//! count, radius + pressure[3] + speed[3] + temperature[3] (40 bytes), from version 7 emitter
//! position / rotation / scale (36 bytes). Record: position, velocity, force (3 floats each), vorticity (≥ 9),
//! normal (≥ 3), neighbour count int32 (≥ 4), uvw + info int16 (≥ 5), age, isolation time, viscosity, density,
//! pressure, mass, temperature (floats), id (int32; int64 from 12). Layout after the reader in Thinkbox's
//! open-source particle library. RealFlow is left-handed y-up: z is negated to make it right-handed.

use std::path::Path;

use crate::error::Result;
use crate::scene::{Attribute, Raw};

/// The file signature.
pub const MAGIC: i32 = 0x00FA_BADA;

fn header_len(version: i16) -> usize {
    4 + 250 + 2 + 4 + 16 + 4 + 40 + if version >= 7 { 36 } else { 0 }
}

fn record_len(version: i16) -> usize {
    let mut n = 36;
    if version >= 9 {
        n += 12;
    }
    if version >= 3 {
        n += 12;
    }
    if version >= 4 {
        n += 4;
    }
    if version >= 5 {
        n += 14;
    }
    n + 28 + if version >= 12 { 8 } else { 4 }
}

/// Parse RealFlow .bin bytes.
pub fn parse(path: &Path, b: &[u8]) -> Result<Raw> {
    let err = |at: usize, r: String| super::bytes::err_at(path, at, r);
    if b.len() < 4 || i32::from_le_bytes(b[..4].try_into().unwrap()) != MAGIC {
        return Err(err(0, "wrong magic: not a RealFlow .bin particle file (expected 0xFABADA)".into()));
    }
    if b.len() < 256 {
        return Err(err(b.len(), "file truncated in the header".into()));
    }
    let version = i16::from_le_bytes([b[254], b[255]]);
    if !(3..=12).contains(&version) {
        return Err(err(254, format!("unsupported RealFlow .bin version {version} (3 … 12 are read)")));
    }
    let hl = header_len(version);
    if b.len() < hl {
        return Err(err(b.len(), format!("file truncated in the header ({} of {hl} bytes)", b.len())));
    }
    let f = |o: usize| f32::from_le_bytes(b[o..o + 4].try_into().unwrap());
    let scale = f(256);
    let count = i32::from_le_bytes(b[276..280].try_into().unwrap());
    if count < 0 {
        return Err(err(276, format!("negative particle count {count}")));
    }
    let n = count as usize;
    let rl = record_len(version);
    let need = n.checked_mul(rl).ok_or_else(|| err(276, "particle count overflows".into()))?;
    if need > b.len() - hl {
        return Err(err(
            hl,
            format!(
                "header claims {n} particles ({need} bytes of {rl}-byte records) but only {} bytes remain",
                b.len() - hl
            ),
        ));
    }
    let mut positions = Vec::with_capacity(n);
    let mut vel = Vec::with_capacity(3 * n);
    let (mut dens, mut ids, mut age) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
    for k in 0..n {
        let o = hl + k * rl;
        // Left-handed y-up → right-handed y-up.
        positions.push([f(o), f(o + 4), -f(o + 8)]);
        vel.extend_from_slice(&[f(o + 12) as f64, f(o + 16) as f64, -f(o + 20) as f64]);
        let tail = o + rl - if version >= 12 { 8 } else { 4 } - 28;
        age.push(f(tail) as f64);
        dens.push(f(tail + 12) as f64);
        let io = o + rl - if version >= 12 { 8 } else { 4 };
        ids.push(if version >= 12 {
            i64::from_le_bytes(b[io..io + 8].try_into().unwrap()) as f64
        } else {
            i32::from_le_bytes(b[io..io + 4].try_into().unwrap()) as f64
        });
    }
    let arrays = vec![
        Attribute { name: "velocity".into(), components: 3, data: vel },
        Attribute { name: "density".into(), components: 1, data: dens },
        Attribute { name: "id".into(), components: 1, data: ids },
        Attribute { name: "age".into(), components: 1, data: age },
        Attribute { name: "scale".into(), components: 1, data: vec![scale as f64; n] },
    ];
    Ok(Raw { positions, arrays })
}

/// Write a version-11 file (positions, velocity, density, id from `p`'s arrays of those names).
pub fn write(p: &Raw) -> Vec<u8> {
    let version: i16 = 11;
    let n = p.positions.len();
    let get = |name: &str, i: usize, c: usize, k: usize| {
        p.arrays.iter().find(|a| a.name == name && a.components == k).map(|a| a.data[i * k + c]).unwrap_or(0.0)
    };
    let mut o = vec![];
    o.extend_from_slice(&MAGIC.to_le_bytes());
    let mut name = [0u8; 250];
    name[..8].copy_from_slice(b"meniscus");
    o.extend_from_slice(&name);
    o.extend_from_slice(&version.to_le_bytes());
    o.extend_from_slice(&1f32.to_le_bytes());
    o.extend_from_slice(&[0u8; 16]);
    o.extend_from_slice(&(n as i32).to_le_bytes());
    o.extend_from_slice(&[0u8; 40 + 36]);
    for (i, pos) in p.positions.iter().enumerate() {
        let v = [get("velocity", i, 0, 3) as f32, get("velocity", i, 1, 3) as f32, -(get("velocity", i, 2, 3) as f32)];
        for x in [pos[0], pos[1], -pos[2], v[0], v[1], v[2]] {
            o.extend_from_slice(&x.to_le_bytes());
        }
        o.extend_from_slice(&[0u8; 12 + 12 + 12 + 4 + 12 + 2]); // force, vorticity, normal, neighbours, uvw, info
        for x in [0.0f32, 0.0, 0.0, get("density", i, 0, 1) as f32, 0.0, 0.0, 0.0] {
            o.extend_from_slice(&x.to_le_bytes());
        }
        o.extend_from_slice(&(get("id", i, 0, 1) as i32).to_le_bytes());
    }
    o
}

/// This format in the registry ([`super::format::FORMATS`]).
pub struct RealFlow;

impl super::format::ParticleFormat for RealFlow {
    fn key(&self) -> &'static str {
        "realflow"
    }
    fn name(&self) -> &'static str {
        "RealFlow particle .bin"
    }
    fn extensions(&self) -> &'static [&'static str] {
        &["bin"]
    }
    fn sniff(&self, head: &[u8]) -> bool {
        head.len() >= 4 && i32::from_le_bytes([head[0], head[1], head[2], head[3]]) == MAGIC
    }
    fn parse(&self, path: &Path, bytes: &[u8]) -> Result<Raw> {
        parse(path, bytes)
    }
    fn samples(&self, raw: &Raw) -> Vec<(&'static str, Vec<u8>)> {
        vec![("v11", write(raw))]
    }
}
