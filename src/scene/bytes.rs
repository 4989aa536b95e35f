//! What every binary particle parser shares: ONE table of scalar types (the names PLY, legacy VTK and VTK XML
//! use for them, their sizes, and decoding either byte order to f64), and the positioned parse error.

use std::path::Path;

use crate::error::{Error, Result};

/// A scalar type of a binary array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scalar {
    /// Signed 8-bit integer.
    I8,
    /// Unsigned 8-bit integer.
    U8,
    /// Signed 16-bit integer.
    I16,
    /// Unsigned 16-bit integer.
    U16,
    /// Signed 32-bit integer.
    I32,
    /// Unsigned 32-bit integer.
    U32,
    /// Signed 64-bit integer.
    I64,
    /// Unsigned 64-bit integer.
    U64,
    /// IEEE single.
    F32,
    /// IEEE double.
    F64,
}

impl Scalar {
    /// The type a format's name stands for, case-insensitively: PLY (`char`, `uchar`, `int8` … `float32`,
    /// `double`), legacy VTK (`unsigned_char`, `short`, `long`, `vtktypeint64` …) and VTK XML (`Int8` …
    /// `Float64`). `None` for anything else (VTK's `bit`, unknown names).
    pub fn parse(name: &str) -> Option<Scalar> {
        Some(match name.to_ascii_lowercase().as_str() {
            "char" | "int8" => Scalar::I8,
            "uchar" | "unsigned_char" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "unsigned_short" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "unsigned_int" | "uint32" => Scalar::U32,
            "long" | "int64" | "vtktypeint64" => Scalar::I64,
            "unsigned_long" | "uint64" | "vtktypeuint64" => Scalar::U64,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// Bytes per value.
    pub fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }

    /// Decode the first `size()` bytes of `b` (the caller checked the length).
    pub fn read(self, b: &[u8], big_endian: bool) -> f64 {
        let s = self.size();
        let mut a = [0u8; 8];
        a[..s].copy_from_slice(&b[..s]);
        if big_endian {
            a[..s].reverse();
        }
        let four = [a[0], a[1], a[2], a[3]];
        match self {
            Scalar::I8 => a[0] as i8 as f64,
            Scalar::U8 => a[0] as f64,
            Scalar::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes(four) as f64,
            Scalar::U32 => u32::from_le_bytes(four) as f64,
            Scalar::F32 => f32::from_le_bytes(four) as f64,
            Scalar::I64 => i64::from_le_bytes(a) as f64,
            Scalar::U64 => u64::from_le_bytes(a) as f64,
            Scalar::F64 => f64::from_le_bytes(a),
        }
    }
}

/// THE byte cursor of the parsers: a position in a file's bytes, positioned errors, binary reads (big-endian
/// fields of BGEO) and text tokens and lines (legacy VTK headers and ASCII data).
pub struct Cursor<'a> {
    /// The bytes.
    pub d: &'a [u8],
    /// Current position.
    pub pos: usize,
    path: &'a Path,
    note: &'static str,
}

impl<'a> Cursor<'a> {
    /// At the start of `d`, the bytes of `path`.
    pub fn new(path: &'a Path, d: &'a [u8]) -> Self {
        Cursor { d, pos: 0, path, note: "" }
    }

    /// Append `note` to every error reason (e.g. that offsets count decompressed bytes).
    pub fn with_note(mut self, note: &'static str) -> Self {
        self.note = note;
        self
    }

    /// A parse error at byte `at`.
    pub fn err(&self, at: usize, reason: impl Into<String>) -> Error {
        let mut reason = reason.into();
        reason.push_str(self.note);
        err_at(self.path, at, reason)
    }

    /// Bytes left.
    pub fn remaining(&self) -> usize {
        self.d.len() - self.pos
    }

    /// The next `n` bytes, or an error naming `what` and the bytes that remain.
    pub fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        if self.remaining() < n {
            return Err(
                self.err(self.pos, format!("file truncated: {what} needs {n} bytes, {} remain", self.remaining()))
            );
        }
        let s = &self.d[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// A big-endian i32.
    pub fn i32_be(&mut self, what: &str) -> Result<i32> {
        let b = self.take(4, what)?;
        Ok(i32::from_be_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// A big-endian u16.
    pub fn u16_be(&mut self, what: &str) -> Result<u16> {
        let b = self.take(2, what)?;
        Ok(u16::from_be_bytes([b[0], b[1]]))
    }

    /// Skip ASCII whitespace.
    pub fn skip_ws(&mut self) {
        while self.pos < self.d.len() && self.d[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
    }

    /// Next whitespace-separated token, or None at the end.
    pub fn token(&mut self) -> Option<&'a str> {
        self.skip_ws();
        let s = self.pos;
        while self.pos < self.d.len() && !self.d[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        (self.pos > s).then(|| std::str::from_utf8(&self.d[s..self.pos]).unwrap_or("?"))
    }

    /// Next token, or an error naming `what`.
    pub fn expect_token(&mut self, what: &str) -> Result<&'a str> {
        let at = self.pos;
        self.token().ok_or_else(|| self.err(at, format!("file truncated: expected {what}")))
    }

    /// Next token parsed as `T`, or an error naming `what` and the token.
    pub fn number<T: std::str::FromStr>(&mut self, what: &str) -> Result<T> {
        let at = self.pos;
        let t = self.expect_token(what)?;
        t.parse().map_err(|_| self.err(at, format!("expected {what}, found {t:?}")))
    }

    /// Rest of the current line (and move past its newline).
    pub fn line(&mut self) -> &'a str {
        let s = self.pos;
        while self.pos < self.d.len() && self.d[self.pos] != b'\n' {
            self.pos += 1;
        }
        let l = std::str::from_utf8(&self.d[s..self.pos]).unwrap_or("");
        if self.pos < self.d.len() {
            self.pos += 1;
        }
        l.trim_end_matches('\r')
    }
}

/// A parse error at byte `at` of `path`.
pub fn err_at(path: &Path, at: usize, reason: impl Into<String>) -> Error {
    Error::Parse { path: path.to_path_buf(), offset: at as u64, reason: reason.into() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names from all three vocabularies map to one type; both byte orders decode.
    #[test]
    fn scalar_names_and_byte_orders() {
        assert_eq!(Scalar::parse("Float32"), Some(Scalar::F32));
        assert_eq!(Scalar::parse("float"), Some(Scalar::F32));
        assert_eq!(Scalar::parse("unsigned_char"), Some(Scalar::U8));
        assert_eq!(Scalar::parse("uchar"), Some(Scalar::U8));
        assert_eq!(Scalar::parse("vtktypeint64"), Some(Scalar::I64));
        assert_eq!(Scalar::parse("bit"), None);
        assert_eq!(Scalar::F32.read(&1.5f32.to_be_bytes(), true), 1.5);
        assert_eq!(Scalar::I16.read(&(-7i16).to_le_bytes(), false), -7.0);
        assert_eq!(Scalar::U64.read(&(1u64 << 40).to_be_bytes(), true), (1u64 << 40) as f64);
    }
}
