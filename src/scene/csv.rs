//! CSV with a header row: columns `x`, `y`, `z` (also `px`/`pos_x`/`position_x` …) give positions; every other
//! numeric column becomes an attribute; `name_x`/`name_y`/`name_z` (or `vx`/`vy`/`vz`) columns are grouped into
//! a 3-component attribute `name` (`velocity` for `vx`…). Parsed with the `csv` crate.

use std::path::Path;

use crate::error::Result;
use crate::scene::{Attribute, Raw};

/// `vx` → (velocity, 0), `n_y` → (n, 1), `x` → (position, 0); None for a plain name.
pub fn split_vector(name: &str) -> Option<(String, usize)> {
    let n = name.trim().to_ascii_lowercase();
    for (k, axis) in ["x", "y", "z"].iter().enumerate() {
        for sep in ["_", ".", ":", ""] {
            if let Some(base) = n.strip_suffix(&format!("{sep}{axis}")) {
                if sep.is_empty() && base.len() > 1 {
                    continue; // "max" is not m·ax; only single-letter prefixes like "vx"
                }
                let base = match base {
                    "" | "p" | "pos" | "position" => "position",
                    "v" | "vel" => "velocity",
                    b => b,
                };
                return Some((base.to_string(), k));
            }
        }
    }
    None
}

/// Parse CSV bytes.
pub fn parse(path: &Path, bytes: &[u8]) -> Result<Raw> {
    let err = |offset: u64, reason: String| super::bytes::err_at(path, offset as usize, reason);
    let mut rd = csv::ReaderBuilder::new().has_headers(true).trim(csv::Trim::All).flexible(false).from_reader(bytes);
    let headers = rd.headers().map_err(|e| err(0, format!("bad CSV header: {e}")))?.clone();
    // Column → (attribute name, component).
    let cols: Vec<(String, usize)> =
        headers.iter().map(|h| split_vector(h).unwrap_or_else(|| (h.trim().to_string(), 0))).collect();
    let pos_col = |k: usize| cols.iter().position(|(n, c)| n == "position" && *c == k);
    let (Some(px), Some(py), Some(pz)) = (pos_col(0), pos_col(1), pos_col(2)) else {
        return Err(err(
            0,
            format!("the header must name x, y and z columns; found {:?}", headers.iter().collect::<Vec<_>>()),
        ));
    };
    let mut names: Vec<(String, usize)> = vec![]; // attribute name, components
    for (n, c) in &cols {
        if n == "position" {
            continue;
        }
        match names.iter_mut().find(|(m, _)| m == n) {
            Some(e) => e.1 = e.1.max(c + 1),
            None => names.push((n.clone(), c + 1)),
        }
    }
    let mut positions = vec![];
    let mut data: Vec<Vec<f64>> = vec![vec![]; names.len()];
    let mut rec = csv::ByteRecord::new();
    loop {
        let offset = rd.position().byte();
        match rd.read_byte_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(err(offset, format!("bad CSV row: {e}"))),
        }
        let num = |i: usize| -> Result<f64> {
            let f = std::str::from_utf8(&rec[i]).unwrap_or("");
            f.parse::<f64>().map_err(|_| err(offset, format!("column {:?}: not a number: {f:?}", &headers[i])))
        };
        positions.push([num(px)? as f32, num(py)? as f32, num(pz)? as f32]);
        for (k, (n, comps)) in names.iter().enumerate() {
            for c in 0..*comps {
                let i = cols.iter().position(|(m, cc)| m == n && *cc == c);
                data[k].push(match i {
                    Some(i) => num(i)?,
                    None => 0.0,
                });
            }
        }
    }
    let arrays =
        names.into_iter().zip(data).map(|((name, components), data)| Attribute { name, components, data }).collect();
    Ok(Raw { positions, arrays })
}

/// Write CSV (x,y,z then every array; vectors as name_x,name_y,name_z).
pub fn write(p: &Raw) -> Vec<u8> {
    let mut w = csv::Writer::from_writer(vec![]);
    let mut header = vec!["x".to_string(), "y".into(), "z".into()];
    for a in &p.arrays {
        if a.components == 1 {
            header.push(a.name.clone());
        } else {
            for c in 0..a.components {
                header.push(format!("{}_{}", a.name, ["x", "y", "z", "w"][c.min(3)]));
            }
        }
    }
    w.write_record(&header).expect("write to memory");
    for (i, pos) in p.positions.iter().enumerate() {
        let mut row: Vec<String> = pos.iter().map(|x| x.to_string()).collect();
        for a in &p.arrays {
            for c in 0..a.components {
                row.push(a.data[i * a.components + c].to_string());
            }
        }
        w.write_record(&row).expect("write to memory");
    }
    w.into_inner().expect("flush to memory")
}

/// This format in the registry ([`super::format::FORMATS`]).
pub struct Csv;

impl super::format::ParticleFormat for Csv {
    fn key(&self) -> &'static str {
        "csv"
    }
    fn name(&self) -> &'static str {
        "CSV"
    }
    fn extensions(&self) -> &'static [&'static str] {
        &["csv"]
    }
    fn sniff_header(&self, first_line: &str) -> bool {
        let first = first_line.to_ascii_lowercase();
        first.contains(',')
            && ["x", "y", "z"].iter().all(|c| first.split(',').any(|f| f.trim().trim_matches('"') == *c))
    }
    fn parse(&self, path: &Path, bytes: &[u8]) -> Result<Raw> {
        parse(path, bytes)
    }
    fn samples(&self, raw: &Raw) -> Vec<(&'static str, Vec<u8>)> {
        vec![("header", write(raw))]
    }
}
