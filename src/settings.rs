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

/// Settings sections spelled differently before, as (old, new): a file may still use the old spelling (read as
/// the new one, with a note: [`Settings::with_toml_noting`]).
pub const RENAMED_SECTIONS: &[(&str, &str)] = &[("spray", "isolated"), ("smooth", "filter")];

/// Settings keys spelled differently before, as (section, old, new): a file may still use the old spelling
/// (read as the new one, with a note: [`Settings::with_toml_noting`]).
pub const RENAMED_KEYS: &[(&str, &str, &str)] = &[
    ("filter", "filter", "method"),
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
/// in code and in TOML (`[filter] filter = "bilateral"`, `[filter.narrow] radius = 8.0`, `[ssr] stride = 4`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Settings {
    /// Particle radius in world units (set from `--radius` or estimated from the data).
    pub radius: f32,
    /// Depth from spheres or from the ray-cast iso-surface.
    pub surface: Surface,
    /// The iso field's kernel: isotropic, or anisotropic (`[anisotropy]`).
    pub kernel: Kernel,
    /// Fluid resolution (splat, filter) relative to the output: 1, 0.5 (half) or 0.25 (quarter); upsampled
    /// to full resolution by the `upsample` pass.
    pub fluid_scale: f32,
    /// `[background]`: the scene behind the fluid and the sun.
    pub background: crate::passes::background::Params,
    /// `[splat]`: how the depth splat draws.
    pub splat: crate::passes::splat::Params,
    /// `[isolated]`: fluid particles of low density, kept out of the surface and drawn apart.
    #[serde(alias = "spray")]
    pub isolated: IsolatedParams,
    /// `[iso]`: the iso-surface ray cast.
    pub iso: crate::surface::iso::params::Params,
    /// `[anisotropy]`: the anisotropic kernels (with `kernel = "anisotropic"`).
    pub anisotropy: crate::surface::grid::params::Params,
    /// `[mesh]`: the extracted mesh's cube size.
    pub mesh: crate::surface::mesh::params::Params,
    /// `[thickness]`: resolution and blur.
    pub thickness: crate::passes::thickness::Params,
    /// `[filter]`: the depth filter.
    #[serde(alias = "smooth")]
    pub filter: crate::passes::filter::Params,
    /// `[normals]`: discontinuities.
    pub normals: crate::passes::normals::Params,
    /// `[noise]`: the patent's waves and whitecaps tint on the surface (the diffuse particles' foam is `[diffuse]`).
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

/// Isolated particles: the `[isolated]` section of a settings file (`[spray]`: its deprecated spelling).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IsolatedParams {
    /// Particles whose density is below this fraction of the median density are isolated and left out of the
    /// surface (0 = off). Uses the file's density, else a neighbour count.
    pub density: f32,
    /// Isolated particles found by neighbour count within 4 r even when the file has densities.
    pub by_neighbours: bool,
}

impl Default for IsolatedParams {
    fn default() -> Self {
        IsolatedParams { density: 0.0, by_neighbours: true }
    }
}

impl Section for IsolatedParams {
    fn name(&self) -> &'static str {
        "isolated"
    }

    fn check(&self) -> crate::section::Checked {
        Keys("isolated").within("density", self.density, 0.0, 1.0)
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
            isolated: Default::default(),
            iso: Default::default(),
            anisotropy: Default::default(),
            mesh: Default::default(),
            thickness: Default::default(),
            // No screen-space filter on the default iso surface (a filter only blurs it); `--surface spheres`
            // without `--filter` gets narrow-range (src/bin/meniscus/args.rs).
            filter: crate::passes::filter::Params { method: Filter::None, ..Default::default() },
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
                s.filter.method = Filter::None;
                s.iso.smoothing = 0.0;
                s.iso.bound = 1.75;
            }
            // The cheapest picture: the particles' spheres, depth smoothed by the narrow-range filter, fewer
            // filter and blur pixels.
            "fast" => {
                s.surface = Surface::Spheres;
                s.filter.method = Filter::NarrowRange;
                s.filter.bilateral.iterations = 1;
                s.filter.max_px = 12;
                s.thickness.blur_px = 2;
            }
            // The marching-cubes mesh with splashsurf's finishing (25 Laplacian iterations, feature weights):
            // the smooth surface practitioners render (issue #15's quality targets are met by it, not by the
            // iso cast). Offline: the CPU extracts and smooths again whenever the particles change.
            "smooth" => {
                s.surface = Surface::Mesh;
                s.filter.method = Filter::None;
                s.mesh.smoothing_iters = 25;
            }
            // Moritz 2016 (thesis values): curvature flow, Δt = 0.005, ≤ 60 iterations, κ = 3.
            "moritz" => {
                s.surface = Surface::Spheres;
                s.filter.method = Filter::CurvatureFlow;
                s.filter.curvature.dt = 0.005;
                s.filter.curvature.it_max = 60;
                s.filter.curvature.kappa = 3.0;
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
        if surface == Surface::Spheres && self.surface != Surface::Spheres && self.filter.method == Filter::None {
            self.filter.method = Filter::NarrowRange;
        }
        self.surface = surface;
    }

    /// A copy with `f` applied (variants of one base: `base.with(|s| s.filter.method = Filter::None)`).
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
        let mut headers: Vec<(&str, &str)> = vec![];
        for (old, new) in RENAMED_SECTIONS {
            let Some(v) = table.remove(*old) else { continue };
            if table.contains_key(*new) {
                return Err(Error::Parse {
                    path: path.to_path_buf(),
                    offset: text.find(&format!("[{old}")).unwrap_or(0) as u64,
                    reason: format!("sets both [{old}] (deprecated) and [{new}]: keep [{new}]"),
                });
            }
            table.insert(new.to_string(), v);
            headers.push((new, old));
            notes.push(format!("{}: [{old}] is deprecated: it is spelled [{new}] now", path.display()));
        }
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
            // Under the header the file wrote (a deprecated section name, if it used one).
            let written = headers.iter().find(|(new, _)| *new == section).map_or(section, |(_, old)| old);
            let (header, name) = match key.rsplit_once('.') {
                Some((sub, name)) => (format!("{written}.{sub}"), name),
                None => (written.to_string(), key),
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
        let aniso = (self.kernel == Kernel::Anisotropic).then(|| self.anisotropy.world(self.radius, self.iso.support));
        self.iso.world(self.radius, aniso)
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
            &self.isolated,
            &self.iso,
            &self.anisotropy,
            &self.mesh,
            &self.thickness,
            &self.filter,
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
mod tests;
