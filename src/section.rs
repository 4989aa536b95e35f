//! A settings section (`[ssr]`, `[noise]`, …): the type that holds its keys, their defaults (`Default`), their
//! meaning and units (the fields' doc comments) and — here — their ranges: [`Section::check`] names the first
//! key out of range. Every section's type implements it beside its own defaults; `Settings::sections` is THE
//! LIST that walks them (validation, the settings file's byte offsets, the test that sets every key out of
//! range). [`Keys`] is the one range helper, so every error reads the same:
//! `[ssr] stride = 0 is out of range (0 < stride ≤ 256)`.

/// The first key out of range: (key inside the section, dotted for a subsection: `curvature.dt`; the
/// sentence to show).
pub type Checked = std::result::Result<(), (&'static str, String)>;

/// One settings section.
pub trait Section {
    /// Its name in a settings file (`[name]`), JSON and Python.
    fn name(&self) -> &'static str;
    /// The first key whose value is out of range.
    fn check(&self) -> Checked;
}

/// The range checks of one section's keys.
#[derive(Clone, Copy)]
pub struct Keys(pub &'static str);

impl Keys {
    fn out(&self, key: &'static str, value: impl std::fmt::Display, range: String) -> Checked {
        Err((key, format!("{}{key} = {value} is out of range ({range})", self.prefix())))
    }

    /// `[section] ` (nothing for the frame-wide keys, section "").
    fn prefix(&self) -> String {
        if self.0.is_empty() {
            String::new()
        } else {
            format!("[{}] ", self.0)
        }
    }

    /// `lo ≤ v ≤ hi`.
    pub fn within(&self, key: &'static str, v: f32, lo: f32, hi: f32) -> Checked {
        if (lo..=hi).contains(&v) {
            Ok(())
        } else {
            self.out(key, v, format!("{lo} ≤ {key} ≤ {hi}"))
        }
    }

    /// `lo < v ≤ hi`.
    pub fn above(&self, key: &'static str, v: f32, lo: f32, hi: f32) -> Checked {
        if v > lo && v <= hi {
            Ok(())
        } else {
            self.out(key, v, format!("{lo} < {key} ≤ {hi}"))
        }
    }

    /// `lo ≤ v ≤ hi` for a count.
    pub fn count(&self, key: &'static str, v: u32, lo: u32, hi: u32) -> Checked {
        if (lo..=hi).contains(&v) {
            Ok(())
        } else {
            self.out(key, v, format!("{lo} ≤ {key} ≤ {hi}"))
        }
    }

    /// Every component `lo ≤ c ≤ hi`.
    pub fn each(&self, key: &'static str, v: &[f32], lo: f32, hi: f32) -> Checked {
        if v.iter().all(|c| (lo..=hi).contains(c)) {
            Ok(())
        } else {
            self.out(key, format!("{v:?}"), format!("each component {lo} … {hi}"))
        }
    }

    /// A `[min, max]` pair: `lo ≤ min < max ≤ hi`.
    pub fn pair(&self, key: &'static str, v: [f32; 2], lo: f32, hi: f32) -> Checked {
        if lo <= v[0] && v[0] < v[1] && v[1] <= hi {
            Ok(())
        } else {
            self.out(key, format!("{v:?}"), format!("{lo} ≤ min < max ≤ {hi}"))
        }
    }

    /// A rule between keys, with its own sentence.
    pub fn rule(&self, key: &'static str, holds: bool, why: impl FnOnce() -> String) -> Checked {
        if holds {
            Ok(())
        } else {
            Err((key, format!("{}{}", self.prefix(), why())))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each check passes inside its range and names the section, key, value and range outside it (NaN too).
    #[test]
    fn keys_name_the_section_the_key_and_the_range() {
        let k = Keys("ssr");
        assert!(k.above("stride", 1.0, 0.0, 256.0).is_ok() && k.within("x", 0.0, 0.0, 1.0).is_ok());
        assert_eq!(
            k.above("stride", 0.0, 0.0, 256.0).unwrap_err(),
            ("stride", "[ssr] stride = 0 is out of range (0 < stride ≤ 256)".to_string())
        );
        assert!(k.within("x", f32::NAN, 0.0, 1.0).is_err() && k.above("x", f32::INFINITY, 0.0, 1e9).is_err());
        assert!(k.count("n", 0, 1, 4).is_err() && k.count("n", 4, 1, 4).is_ok());
        assert!(k.each("c", &[0.5, 2.0], 0.0, 1.0).is_err() && k.pair("p", [2.0, 1.0], 0.0, 9.0).is_err());
        assert_eq!(k.rule("a", false, || "a must exceed b".into()).unwrap_err().1, "[ssr] a must exceed b");
    }
}
