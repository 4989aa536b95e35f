//! Every shading and filter parameter in one struct. Widths are in multiples of the particle radius so the
//! defaults carry over between simulations of different scale.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::named::{named_enum, Filter, SplatMode};
use crate::section::{Keys, Section};

/// The dotted key of the first non-finite float in a TOML table (inf, nan), if any.
fn non_finite(t: &toml::Table) -> Option<String> {
    fn walk(v: &toml::Value, key: &str) -> Option<String> {
        match v {
            toml::Value::Float(x) if !x.is_finite() => Some(key.to_string()),
            toml::Value::Table(t) => t.iter().find_map(|(k, v)| walk(v, &join(key, k))),
            toml::Value::Array(a) => a.iter().find_map(|v| walk(v, key)),
            _ => None,
        }
    }
    fn join(a: &str, b: &str) -> String {
        if a.is_empty() {
            b.to_string()
        } else {
            format!("{a}.{b}")
        }
    }
    t.iter().find_map(|(k, v)| walk(v, k))
}
/// The byte offset where `name` is assigned in a TOML text (`name =`, a whole key), from the start of
/// `section`'s header when given and present, else 0 (TOML keeps no spans in a Table).
fn key_offset_in(text: &str, section: Option<&str>, name: &str) -> u64 {
    let from = section.and_then(|h| text.find(&format!("[{h}]"))).unwrap_or(0);
    let whole = |i: usize| {
        let before = text[..i].chars().next_back();
        !before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '.')
    };
    text[from..]
        .match_indices(name)
        .map(|(i, _)| from + i)
        .find(|&i| whole(i) && text[i + name.len()..].trim_start().starts_with('='))
        .map_or(0, |i| i as u64)
}

fn key_offset(text: &str, name: &str) -> u64 {
    key_offset_in(text, None, name)
}

/// Replace the leaves of `base` that `over` sets, keeping the rest of every section.
fn merge(base: &mut serde_json::Value, over: serde_json::Value) {
    match (base, over) {
        (serde_json::Value::Object(b), serde_json::Value::Object(o)) => {
            for (k, v) in o {
                match b.get_mut(&k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (slot, v) => *slot = v,
    }
}

/// Settings keys spelled differently before, as (section, old, new): a file may still use the old spelling
/// (read as the new one, with a note: [`Settings::with_toml_noting`]).
pub const RENAMED_KEYS: &[(&str, &str, &str)] = &[
    ("noise", "foam", "whitecaps"),
    ("noise", "foam_from", "whitecaps_from"),
    ("noise", "foam_full", "whitecaps_full"),
    ("noise", "foam_color", "whitecaps_color"),
];

named_enum! {
    /// What the fluid's depth is (`--surface`).
    pub enum Surface {
        /// The nearest particle sphere (van der Laan et al. 2009), smoothed by the filter.
        Spheres = "spheres",
        /// The SPH colour-field iso-surface, ray-cast per pixel from the spheres' depth (`iso` pass; the
        /// default, its field smoothed where the water is calm: `[iso] smoothing`), unfiltered by default.
        Iso = "iso",
        /// The same iso-surface extracted as a triangle mesh (marching cubes, `crate::field::extract`) and ray-cast
        /// through its BVH (`mesh` pass).
        Mesh = "mesh",
    }
}

named_enum! {
    /// The iso field's kernel (`--kernel`).
    pub enum Kernel {
        /// One sphere per particle (splashsurf's field).
        Isotropic = "isotropic",
        /// Ellipsoids from each particle's neighbourhood (Yu & Turk 2013; the `anisotropy` pass).
        Anisotropic = "anisotropic",
    }
}

/// All render settings: a few frame-wide values, then one section per pass (each pass takes only its own),
/// in code and in TOML (`[smooth] filter = "bilateral"`, `[smooth.narrow] radius = 8.0`, `[ssr] stride = 4`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Settings {
    /// Particle radius in world units (set from `--radius` or estimated from the data).
    pub radius: f32,
    /// Depth from spheres or from the ray-cast iso-surface.
    pub surface: Surface,
    /// The iso field's kernel: isotropic, or anisotropic (`[anisotropy]`).
    pub kernel: Kernel,
    /// Fluid resolution (splat, smooth) relative to the output: 1, 0.5 (half) or 0.25 (quarter); upsampled
    /// to full resolution by the `upsample` pass.
    pub fluid_scale: f32,
    /// `[background]`: the scene behind the fluid and the sun.
    pub background: crate::passes::background::Params,
    /// `[splat]`: how the depth splat draws.
    pub splat: crate::passes::splat::Params,
    /// `[spray]`: spray classification.
    pub spray: SprayParams,
    /// `[iso]`: the iso-surface ray cast.
    pub iso: crate::passes::iso::Params,
    /// `[anisotropy]`: the anisotropic kernels (with `kernel = "anisotropic"`).
    pub anisotropy: crate::passes::anisotropy::Params,
    /// `[mesh]`: the extracted mesh's cube size.
    pub mesh: crate::passes::mesh::Params,
    /// `[thickness]`: resolution and blur.
    pub thickness: crate::passes::thickness::Params,
    /// `[smooth]`: the depth filter.
    pub smooth: crate::passes::smooth::Params,
    /// `[normals]`: discontinuities.
    pub normals: crate::passes::normals::Params,
    /// `[noise]`: the patent's waves and foam on the surface.
    pub noise: crate::passes::noise::Params,
    /// `[diffuse]`: spray, foam and bubbles — how they are generated and drawn.
    pub diffuse: crate::diffuse::params::Params,
    /// `[ssr]`: screen-space reflections.
    pub ssr: crate::passes::ssr::Params,
    /// `[composite]`: shading.
    pub composite: crate::passes::composite::Params,
    /// `[sim]`: the live simulation's solver (`meniscus sim`, `demo --sim`, `bench --sim`).
    pub sim: crate::sim::params::Params,
}

/// Spray classification: the `[spray]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SprayParams {
    /// Particles whose density is below this fraction of the median density are spray and left out of the
    /// surface (0 = off). Uses the file's density, else a neighbour count.
    pub density: f32,
    /// Spray classification by neighbour count within 4 r even when the file has densities.
    pub by_neighbours: bool,
}

impl Default for SprayParams {
    fn default() -> Self {
        SprayParams { density: 0.0, by_neighbours: true }
    }
}

impl Section for SprayParams {
    fn name(&self) -> &'static str {
        "spray"
    }

    fn check(&self) -> crate::section::Checked {
        Keys("spray").within("density", self.density, 0.0, 1.0)
    }
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            radius: 0.0,
            // The SPH iso-surface, smoothed in 3D where the water is calm ([iso] smoothing): issue #15's
            // default, as close to splashsurf's smoothed surface as measured (tools/quality.sh) at the cost of
            // the spheres + narrow-range frame (`--preset fast`) for a static set of particles.
            surface: Surface::Iso,
            kernel: Kernel::Isotropic,
            fluid_scale: 1.0,
            background: Default::default(),
            splat: Default::default(),
            spray: Default::default(),
            iso: Default::default(),
            anisotropy: Default::default(),
            mesh: Default::default(),
            thickness: Default::default(),
            // No screen-space filter on the default iso surface (a filter only blurs it); `--surface spheres`
            // without `--filter` gets narrow-range (src/bin/meniscus/args.rs).
            smooth: crate::passes::smooth::Params { filter: Filter::None, ..Default::default() },
            normals: Default::default(),
            noise: Default::default(),
            diffuse: Default::default(),
            ssr: Default::default(),
            composite: Default::default(),
            sim: Default::default(),
        }
    }
}

/// Every preset [`Settings::preset`] knows, in the order the demo's `O` key cycles them (`smooth` last: it
/// re-extracts and smooths the mesh on the CPU whenever the particles change).
pub const PRESETS: &[&str] = &["default", "fast", "quality", "moritz", "smooth"];

impl Settings {
    /// A named preset (one of [`PRESETS`]): `default` (the ray-cast SPH iso-surface, its field smoothed where
    /// the water is calm), `fast` (spheres + narrow-range), `quality` (the exact SPH iso-surface, unsmoothed),
    /// `moritz` (the thesis' curvature flow on spheres) or `smooth` (the smoothed mesh).
    pub fn preset(name: &str) -> Result<Settings> {
        let mut s = Settings::default();
        match name {
            "default" => {}
            // The SPH iso-surface exactly (what splashsurf reconstructs before its mesh smoothing): the field
            // summed over the neighbours at every sample, no 3D smoothing, no filter; and the wider bound spheres
            // (1.75 r), which lose fewer silhouettes than the default's 1.5 r (IoU 0.996 against 0.987 on the
            // shared frame, tools/quality.sh).
            "quality" => {
                s.surface = Surface::Iso;
                s.smooth.filter = Filter::None;
                s.iso.smoothing = 0.0;
                s.iso.bound = 1.75;
            }
            // The cheapest picture: the particles' spheres, depth smoothed by the narrow-range filter, fewer
            // filter and blur pixels.
            "fast" => {
                s.surface = Surface::Spheres;
                s.smooth.filter = Filter::NarrowRange;
                s.smooth.bilateral.iterations = 1;
                s.smooth.max_px = 12;
                s.thickness.blur_px = 2;
            }
            // The marching-cubes mesh with splashsurf's finishing (25 Laplacian iterations, feature weights):
            // the smooth surface practitioners render (issue #15's quality targets are met by it, not by the
            // iso cast). Offline: the CPU extracts and smooths again whenever the particles change.
            "smooth" => {
                s.surface = Surface::Mesh;
                s.smooth.filter = Filter::None;
                s.mesh.smoothing_iters = 25;
            }
            // Moritz 2016 (thesis values): curvature flow, Δt = 0.005, ≤ 60 iterations, κ = 3.
            "moritz" => {
                s.surface = Surface::Spheres;
                s.smooth.filter = Filter::CurvatureFlow;
                s.smooth.curvature.dt = 0.005;
                s.smooth.curvature.it_max = 60;
                s.smooth.curvature.kappa = 3.0;
                s.ssr.stride = 8.0;
                s.ssr.max_steps = 100;
                s.ssr.refine = 4;
            }
            _ => {
                return Err(Error::Invalid(format!("unknown settings preset {name:?} (known: {})", PRESETS.join(", "))))
            }
        }
        Ok(s)
    }

    /// Switch the surface. Spheres unfiltered are bumpy: switching to spheres on unfiltered settings (the
    /// default iso surface's) also turns on their default filter, narrow-range (`--filter none` after this
    /// shows them raw). Used by the CLI's `--surface` and the demo's `I` key.
    pub fn set_surface(&mut self, surface: Surface) {
        if surface == Surface::Spheres && self.surface != Surface::Spheres && self.smooth.filter == Filter::None {
            self.smooth.filter = Filter::NarrowRange;
        }
        self.surface = surface;
    }

    /// A copy with `f` applied (variants of one base: `base.with(|s| s.smooth.filter = Filter::None)`).
    pub fn with(&self, f: impl FnOnce(&mut Settings)) -> Settings {
        let mut s = self.clone();
        f(&mut s);
        s
    }

    /// Read a TOML file of settings over the defaults.
    pub fn from_toml(path: &std::path::Path) -> Result<Settings> {
        Settings::default().with_toml(path)
    }

    /// These settings with the fields a TOML file sets replaced, section by section (unknown keys and
    /// sections, wrong types and bad enum names are errors that name the file and the byte offset).
    pub fn with_toml(&self, path: &std::path::Path) -> Result<Settings> {
        self.with_toml_noting(path, &mut vec![])
    }

    /// [`Settings::with_toml`], with a note in `notes` for every key the file spells the deprecated way
    /// ([`RENAMED_KEYS`]: read as its new name).
    pub fn with_toml_noting(&self, path: &std::path::Path, notes: &mut Vec<String>) -> Result<Settings> {
        let text = crate::input::read_text(path)?;
        let parse_err = |e: toml::de::Error| Error::Parse {
            path: path.to_path_buf(),
            offset: e.span().map(|s| s.start as u64).unwrap_or(0),
            reason: e.message().to_string(),
        };
        let mut table: toml::Table = toml::from_str(&text).map_err(parse_err)?;
        // A deprecated spelling is read as the new one (serde knows both: `alias`); both at once is an error.
        for (section, old, new) in RENAMED_KEYS {
            let Some(sec) = table.get_mut(*section).and_then(|t| t.as_table_mut()) else { continue };
            let Some(v) = sec.remove(*old) else { continue };
            if sec.contains_key(*new) {
                return Err(Error::Parse {
                    path: path.to_path_buf(),
                    offset: key_offset_in(&text, Some(section), old),
                    reason: format!("[{section}] sets both {old} (deprecated) and {new}: keep {new}"),
                });
            }
            sec.insert(new.to_string(), v);
            notes.push(format!("{}: [{section}] {old} is deprecated: it is spelled {new} now", path.display()));
        }
        // The file alone over the defaults: every key and value checked, with its position.
        toml::from_str::<Settings>(&text).map_err(parse_err)?;
        if let Some(key) = non_finite(&table) {
            // The offset of the key's last name where it is assigned (TOML keeps no spans in a Table).
            let name = key.rsplit('.').next().unwrap_or(&key);
            return Err(Error::Parse {
                path: path.to_path_buf(),
                offset: key_offset(&text, name),
                reason: format!("{key}: settings are finite numbers (inf and nan are not)"),
            });
        }
        let mut merged = serde_json::to_value(self).map_err(|e| Error::Invalid(e.to_string()))?;
        let over = serde_json::to_value(&table).map_err(|e| Error::Invalid(e.to_string()))?;
        merge(&mut merged, over);
        let s: Settings = serde_json::from_value(merged).map_err(|e| Error::Parse {
            path: path.to_path_buf(),
            offset: 0,
            reason: e.to_string(),
        })?;
        // Every section's keys in range, an error naming the key's place in the file (the frame-wide `radius`
        // may still be unset here: the data sets it).
        if let Err((section, key, reason)) = s.check_sections() {
            let (header, name) = match key.rsplit_once('.') {
                Some((sub, name)) => (format!("{section}.{sub}"), name),
                None => (section.to_string(), key),
            };
            return Err(Error::Parse {
                path: path.to_path_buf(),
                offset: key_offset_in(&text, Some(&header), name),
                reason,
            });
        }
        Ok(s)
    }

    /// The ray-cast parameters in world units (`near` is the view's: 0 here).
    pub fn iso_params(&self) -> crate::field::iso::IsoParams {
        crate::field::iso::IsoParams {
            threshold: self.iso.threshold,
            step: self.iso.step * self.radius,
            bound: self.iso.bound * self.radius,
            max_steps: self.iso.max_steps,
            refine: self.iso.refine,
            first_steps: self.iso.first_steps,
            rest_lanes: self.iso.rest_lanes,
            radius: self.radius,
            fine_px: self.iso.fine_px,
            aniso: (self.kernel == Kernel::Anisotropic).then(|| self.anisotropy.world(self.radius, self.iso.support)),
            // The view's (the GPU reads it from the frame); CPU references set it.
            near: 0.0,
            volume: (self.iso.smoothing > 0.0 && self.kernel == Kernel::Isotropic).then_some(
                crate::field::volume::VolumeParams {
                    sigma: self.iso.smoothing * self.radius,
                    bulk: self.iso.bulk,
                    spacing: self.iso.voxel * self.radius,
                    support: self.iso.support * self.radius,
                },
            ),
        }
    }

    /// The farthest an iso kernel reaches from its particle (world units): the support, or for anisotropic
    /// kernels `stretch` supports from a centre that moved up to `max_shift`. The iso grid's cells are at
    /// least this wide.
    pub fn iso_reach(&self) -> f32 {
        let h = self.iso.support * self.radius;
        self.iso_params().reach(h)
    }

    /// The compute splat and thickness draw the anisotropic kernels' ellipsoids (`kernel = "anisotropic"` on
    /// spheres): the frame then needs the iso grid and the `anisotropy` pass too.
    pub fn ellipsoid_splats(&self) -> bool {
        self.surface == Surface::Spheres && self.kernel == Kernel::Anisotropic && self.splat.mode == SplatMode::Compute
    }

    /// Radius scale of the splatted spheres: the bound spheres when the iso-surface is ray-cast from them.
    pub fn splat_scale(&self) -> f32 {
        match self.surface {
            Surface::Spheres | Surface::Mesh => self.splat.radius_scale,
            Surface::Iso => self.iso.bound,
        }
    }

    /// THE LIST of settings sections, in file order: each states its keys, defaults and ranges
    /// (`crate::section::Section`). A new section is its type and one line here.
    pub fn sections(&self) -> [&dyn Section; 14] {
        [
            &self.background,
            &self.splat,
            &self.spray,
            &self.iso,
            &self.anisotropy,
            &self.mesh,
            &self.thickness,
            &self.smooth,
            &self.normals,
            &self.noise,
            &self.diffuse,
            &self.ssr,
            &self.composite,
            &self.sim,
        ]
    }

    /// The first key of any section out of range, as (section, key, reason), and the rules between sections.
    pub fn check_sections(&self) -> std::result::Result<(), (&'static str, &'static str, String)> {
        for sec in self.sections() {
            sec.check().map_err(|(key, reason)| (sec.name(), key, reason))?;
        }
        let (a, support) = (&self.anisotropy, self.iso.support);
        Keys("anisotropy")
            .rule("max_shift", a.max_shift <= support, || {
                format!("max_shift = {} must be at most [iso] support = {support}", a.max_shift)
            })
            .map_err(|(key, reason)| ("anisotropy", key, reason))
    }

    /// Check values a user could get wrong: the frame-wide keys, then every section.
    pub fn validate(&self) -> Result<()> {
        let k = Keys("");
        let top = k
            .above("radius", self.radius, 0.0, f32::MAX)
            .and_then(|_| k.above("fluid_scale", self.fluid_scale, 0.0, 1.0));
        top.map_err(|(_, reason)| Error::Invalid(reason))?;
        self.check_sections().map_err(|(_, _, reason)| Error::Invalid(reason))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::named::Named;

    /// Every preset the list names (the demo's `O` key cycles it, `smooth` last) exists and validates; an unknown
    /// name lists them all.
    #[test]
    fn every_listed_preset_exists() {
        for name in PRESETS {
            let mut s = Settings::preset(name).unwrap();
            s.radius = 0.01;
            s.validate().unwrap();
        }
        assert_eq!(PRESETS.last(), Some(&"smooth"));
        let e = Settings::preset("nope").unwrap_err().to_string();
        assert!(PRESETS.iter().all(|p| e.contains(p)), "{e}");
    }

    /// Every enum name parses back to its variant, in TOML and through `FromStr`; a bad name lists the good ones.
    #[test]
    fn enum_names_round_trip() {
        fn check<T: Named + std::fmt::Debug + PartialEq + std::str::FromStr<Err = Error> + Serialize>() {
            for (&v, &n) in T::ALL.iter().zip(T::NAMES) {
                assert_eq!(v.name(), n);
                assert_eq!(n.parse::<T>().unwrap(), v);
                assert_eq!(serde_json::to_string(&v).unwrap(), format!("{n:?}"));
            }
            let e = "nope".parse::<T>().unwrap_err().to_string();
            assert!(e.contains("nope") && e.contains(T::NAMES[0]), "{e}");
        }
        check::<Filter>();
        check::<Surface>();
        check::<Kernel>();
        check::<SplatMode>();
        let s: Settings =
            toml::from_str("[smooth]\nfilter = \"curvature-flow\"\n[splat]\nmode = \"quad-min\"").unwrap();
        assert_eq!((s.smooth.filter, s.splat.mode), (Filter::CurvatureFlow, SplatMode::QuadMin));
    }

    /// Every key of every section is checked: set alone far outside any range (±1e30 for a real number or a
    /// component, u32::MAX for a count, 1e30 for an optional value), the sections' check names that section and
    /// key; the list of sections covers every table of the settings. In a file, the error is the key's byte
    /// offset (a subsection's key under its own header).
    #[test]
    fn every_key_of_every_section_is_checked() {
        use serde_json::{json, Value};
        let base = Settings::default().with(|s| s.radius = 0.01);
        base.validate().unwrap();
        let all = serde_json::to_value(&base).unwrap();
        let tables: Vec<&str> =
            all.as_object().unwrap().iter().filter(|(_, v)| v.is_object()).map(|(k, _)| k.as_str()).collect();
        let mut names: Vec<&str> = base.sections().iter().map(|s| s.name()).collect();
        names.sort();
        assert_eq!(names, tables, "one section per table of the settings");
        // (section, dotted key inside it, the leaf's path, its bad values).
        fn leaves(at: &[String], v: &Value, out: &mut Vec<(Vec<String>, Vec<Value>)>) {
            match v {
                Value::Object(o) => o.iter().for_each(|(k, x)| leaves(&[at, std::slice::from_ref(k)].concat(), x, out)),
                Value::Number(n) if n.is_u64() => out.push((at.to_vec(), vec![json!(u32::MAX)])),
                Value::Number(_) | Value::Null => out.push((at.to_vec(), vec![json!(1e30), json!(-1e30)])),
                Value::Array(a) if a.iter().all(|c| c.is_f64()) => {
                    let with = |x: f64| Value::Array([vec![json!(x)], a[1..].to_vec()].concat());
                    out.push((at.to_vec(), vec![with(1e30), with(-1e30)]))
                }
                _ => {}
            }
        }
        let mut checked = 0;
        for section in &tables {
            let mut found = vec![];
            leaves(&[], &all[section], &mut found);
            for (path, bads) in found {
                let key = path.join(".");
                for bad in bads {
                    let mut j = all.clone();
                    let slot = path.iter().fold(&mut j[section], |v, k| &mut v[k]);
                    *slot = bad.clone();
                    let s: Settings =
                        serde_json::from_value(j).unwrap_or_else(|e| panic!("{section}.{key} = {bad}: {e}"));
                    let (sec, k, reason) = s.check_sections().expect_err(&format!("{section}.{key} = {bad} passes"));
                    assert_eq!((sec, k), (*section, key.as_str()), "{section}.{key} = {bad}: {reason}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 150, "{checked} values checked");
        let dir = std::env::temp_dir().join(format!("meniscus-sections-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (text, key) in [
            ("[ssr]\nrefine = 2\nstride = 0.0\n", "stride"),
            ("[smooth]\nradius = 3.0\n[smooth.curvature]\nkappa = 2.0\ndt = -1.0\n", "dt"),
        ] {
            let f = dir.join("bad.toml");
            std::fs::write(&f, text).unwrap();
            match Settings::from_toml(&f) {
                Err(Error::Parse { offset, reason, .. }) => {
                    assert_eq!(&text[offset as usize..offset as usize + key.len()], key, "{reason}");
                    assert!(reason.contains(key) && reason.contains("out of range"), "{reason}");
                }
                other => panic!("{text}: {other:?}"),
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A settings file is read section by section over the preset; unknown keys or sections, wrong types and
    /// bad names are errors with the file and the byte offset of the offending key or value.
    #[test]
    fn toml_overrides_the_preset_and_rejects_unknown_keys() {
        let dir = std::env::temp_dir().join(format!("meniscus-settings-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("good.toml");
        std::fs::write(&good, "[smooth]\nfilter = \"bilateral\"\n[smooth.narrow]\nradius = 8.0\n").unwrap();
        let s = Settings::preset("moritz").unwrap().with_toml(&good).unwrap();
        assert_eq!(s.smooth.narrow.radius, 8.0);
        assert_eq!(s.smooth.filter, Filter::Bilateral);
        assert_eq!(s.smooth.curvature.dt, 0.005); // from the preset, same section as the file's `filter`
        assert_eq!(s.ssr.stride, 8.0); // from the preset
        let check = |name: &str, text: &str, want_offset: usize, want: &str| {
            let f = dir.join(name);
            std::fs::write(&f, text).unwrap();
            let e = Settings::default().with_toml(&f).unwrap_err().to_string();
            assert!(e.contains(name) && e.contains(&format!("byte {want_offset}:")) && e.contains(want), "{e}");
        };
        check("key.toml", "[smooth.narrow]\nradiu = 8.0\n", 16, "radiu");
        check("section.toml", "[smoth]\nradius = 8.0\n", 1, "smoth");
        check("type.toml", "[ssr]\nstride = \"far\"\n", 15, "");
        check("name.toml", "[smooth]\nfilter = \"gaussien\"\n", 18, "gaussien");
        check("syntax.toml", "[ssr]\nstride = = 8\n", 15, "");
        check("inf.toml", "[iso]\nsmoothing = inf\n", 6, "iso.smoothing: settings are finite numbers");
        check("nan.toml", "[smooth.narrow]\nradius = nan\n", 16, "smooth.narrow.radius");
        // [noise] values out of range name their key where the [noise] section assigns it (not another
        // section's key of the same name).
        check("noise.toml", "[thickness]\nscale = 0.5\n[noise]\nsize = -1.0\n", 32, "[noise] size = -1");
        check(
            "foam.toml",
            "[noise]\nwhitecaps_from = 0.5\nwhitecaps_full = 0.2\n",
            29,
            "whitecaps_full = 0.2 must exceed",
        );
        // The old spelling is read as the new one, with a note; both at once is an error.
        let old = dir.join("old.toml");
        std::fs::write(&old, "[noise]\nfoam = 0.4\nfoam_color = [1.0, 0.5, 0.5]\n").unwrap();
        let mut notes = vec![];
        let s = Settings::default().with_toml_noting(&old, &mut notes).unwrap();
        assert_eq!((s.noise.whitecaps, s.noise.whitecaps_color), (0.4, [1.0, 0.5, 0.5]));
        assert!(
            notes.len() == 2 && notes[0].contains("[noise] foam is deprecated: it is spelled whitecaps now"),
            "{notes:?}"
        );
        check("both.toml", "[noise]\nfoam = 0.4\nwhitecaps = 0.5\n", 8, "sets both foam (deprecated) and whitecaps");
        check("noisekey.toml", "[noise]\nsparkle = 1.0\n", 8, "sparkle");
        check(
            "diffuse.toml",
            "[noise]\nsize = 2.0\n[diffuse]\nsize = 1.0\nlifetime = [3.0, 1.0]\n",
            40,
            "lifetime = [3.0, 1.0] is out of range",
        );
        check("diffusekey.toml", "[diffuse]\nglitter = 1\n", 10, "glitter");
    }

    #[test]
    fn presets_pick_their_surfaces() {
        // #15: the default is the smoothed iso surface; fast keeps spheres + narrow-range; quality the exact field.
        let d = Settings::preset("default").unwrap();
        assert_eq!((d.surface, d.smooth.filter), (Surface::Iso, Filter::None));
        assert!(Settings { radius: 0.01, ..d.clone() }.iso_params().volume.is_some());
        let f = Settings::preset("fast").unwrap();
        assert_eq!((f.surface, f.smooth.filter), (Surface::Spheres, Filter::NarrowRange));
        let q = Settings { radius: 0.01, ..Settings::preset("quality").unwrap() };
        assert_eq!(q.surface, Surface::Iso);
        assert!(q.iso_params().volume.is_none());
        // The smoothed field is isotropic: anisotropic kernels cast the exact field.
        assert!(Settings { kernel: Kernel::Anisotropic, radius: 0.01, ..d.clone() }.iso_params().volume.is_none());
        // Spheres from unfiltered settings get narrow-range; a filter already chosen stays.
        let mut s = d.clone();
        s.set_surface(Surface::Spheres);
        assert_eq!(s.smooth.filter, Filter::NarrowRange);
        let mut s = d.with(|s| s.smooth.filter = Filter::Bilateral);
        s.set_surface(Surface::Spheres);
        assert_eq!(s.smooth.filter, Filter::Bilateral);
    }

    #[test]
    fn presets_validate() {
        for p in ["default", "fast", "quality", "smooth", "moritz"] {
            let s = Settings { radius: 0.01, ..Settings::preset(p).unwrap() };
            s.validate().unwrap();
        }
        assert!(Settings::preset("nope").is_err());
    }

    #[test]
    fn anisotropy_settings_are_checked_and_reach_the_grid() {
        let s = Settings { radius: 0.01, kernel: Kernel::Anisotropic, ..Settings::default() };
        s.validate().unwrap();
        // The grid's cells reach the kernels: h, stretched, plus the centres' move when they move.
        assert!((s.iso_reach() - 0.04).abs() < 1e-7);
        let moved = s.with(|s| (s.anisotropy.centre_blend, s.anisotropy.stretch) = (0.5, 1.5));
        assert!((moved.iso_reach() - (0.06 + 0.01)).abs() < 1e-6, "{}", moved.iso_reach());
        assert!((s.with(|s| s.kernel = Kernel::Isotropic).iso_reach() - 0.04).abs() < 1e-7);
        for bad in [
            s.with(|s| s.anisotropy.ratio = 0.5),
            s.with(|s| s.anisotropy.centre_blend = 1.5),
            s.with(|s| s.anisotropy.stretch = 4.0),
            s.with(|s| s.anisotropy.radius = 3.0),
            s.with(|s| s.anisotropy.max_shift = -1.0),
        ] {
            let e = bad.validate().unwrap_err().to_string();
            assert!(e.contains("[anisotropy]"), "{e}");
        }
    }

    #[test]
    fn mesh_settings_are_checked() {
        let s = Settings { radius: 0.01, ..Settings::preset("smooth").unwrap() };
        s.validate().unwrap();
        assert_eq!((s.surface, s.mesh.smoothing_iters), (Surface::Mesh, 25));
        for bad in [
            s.with(|s| s.mesh.cube = 0.0),
            s.with(|s| s.mesh.cube = f32::NAN),
            s.with(|s| s.mesh.smoothing_iters = 5000),
        ] {
            let e = bad.validate().unwrap_err().to_string();
            assert!(e.contains("[mesh]"), "{e}");
        }
    }
}
