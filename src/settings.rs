//! Every shading and filter parameter in one struct. Widths are in multiples of the particle radius so the
//! defaults carry over between simulations of different scale.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Defines a settings enum whose variants have one kebab-case name each, used everywhere: TOML (serde), the
/// command line (`FromStr` + [`Named::NAMES`], so the library needs no CLI crate), JSON and tables.
macro_rules! named_enum {
    ($(#[$m:meta])* pub enum $T:ident { $($(#[$vm:meta])* $V:ident = $n:literal,)* }) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum $T { $($(#[$vm])* $V,)* }
        impl Named for $T {
            const ALL: &'static [$T] = &[$($T::$V),*];
            const NAMES: &'static [&'static str] = &[$($n),*];
            fn name(self) -> &'static str { match self { $($T::$V => $n),* } }
        }
        impl $T {
            /// Every variant, in declaration order.
            pub const ALL: &'static [$T] = &[$($T::$V),*];
            /// The variant's name (as in TOML and on the command line).
            pub fn name(self) -> &'static str { Named::name(self) }
        }
        impl std::str::FromStr for $T {
            type Err = Error;
            fn from_str(s: &str) -> Result<Self> { from_name(s) }
        }
        impl std::fmt::Display for $T {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result { f.write_str(self.name()) }
        }
        impl Serialize for $T {
            fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
                s.serialize_str(self.name())
            }
        }
        impl<'de> Deserialize<'de> for $T {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
                let s = String::deserialize(d)?;
                from_name(&s).map_err(serde::de::Error::custom)
            }
        }
    };
}

/// An enum whose variants have one name each (settings enums, the demo's view modes).
pub trait Named: Copy + Sized + 'static {
    /// Every variant, in declaration order.
    const ALL: &'static [Self];
    /// Every name, in the same order.
    const NAMES: &'static [&'static str];
    /// This variant's name.
    fn name(self) -> &'static str;
}

/// The variant of `T` called `s`, or an error that lists the names.
pub fn from_name<T: Named>(s: &str) -> Result<T> {
    T::NAMES.iter().position(|n| *n == s).map(|i| T::ALL[i]).ok_or_else(|| {
        let kind = std::any::type_name::<T>().rsplit("::").next().unwrap_or("value");
        Error::Invalid(format!("unknown {kind} {s:?} (expected one of: {})", T::NAMES.join(", ")))
    })
}

named_enum! {
    /// Depth smoothing filter (`--filter`).
    pub enum Filter {
        /// No smoothing: the raw spheres.
        None = "none",
        /// Separable Gaussian (a baseline: merges silhouettes).
        Gaussian = "gaussian",
        /// Separable bilateral.
        Bilateral = "bilateral",
        /// Exact 2D bilateral.
        Bilateral2d = "bilateral2d",
        /// Curvature flow (van der Laan 2009) with depth-adaptive iterations (Bagar 2010).
        CurvatureFlow = "curvature-flow",
        /// Narrow-range filter (Truong & Yuksel 2018); the default: smoothest surface at bilateral cost.
        NarrowRange = "narrow-range",
    }
}

named_enum! {
    /// What the fluid's depth is (`--surface`).
    pub enum Surface {
        /// The nearest particle sphere (van der Laan et al. 2009), smoothed by the filter.
        Spheres = "spheres",
        /// The SPH colour-field iso-surface, ray-cast per pixel from the spheres' depth (`iso` pass), then
        /// filtered like the spheres.
        Iso = "iso",
    }
}

named_enum! {
    /// How the `splat` pass draws (`--splat`): the compute splat, or a rasterised variant kept for measurement.
    pub enum SplatMode {
        /// One thread per particle, atomicMin on the depth bits (default).
        Compute = "compute",
        /// Instanced quads, exact depth through gl_FragDepth (no early depth test).
        QuadFragDepth = "quad-frag-depth",
        /// Quads with conservative depth (depth_less + GREATER test keeps early depth test valid).
        QuadConservative = "quad-conservative",
        /// Quads, no depth buffer, MIN blending of linear depth into R32F.
        QuadMin = "quad-min",
        /// Point sprites with gl_FragDepth (sizes above the device's point size limit are clipped).
        PointFragDepth = "point-frag-depth",
        /// Point sprites with MIN blending.
        PointMin = "point-min",
    }
}

impl SplatMode {
    /// Needs a D32 depth buffer.
    pub fn depth_tested(self) -> bool {
        matches!(self, SplatMode::QuadFragDepth | SplatMode::QuadConservative | SplatMode::PointFragDepth)
    }
}

/// All render settings.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Settings {
    /// Particle radius in world units (set from `--radius` or estimated from the data).
    pub radius: f32,
    pub filter: Filter,
    /// Depth from spheres or from the ray-cast iso-surface.
    pub surface: Surface,
    /// Iso-surface: kernel support in particle radii (splashsurf: 2 × smoothing length 2.0 = 4).
    pub iso_support: f32,
    /// Iso-surface: threshold of the normalised field (splashsurf: 0.6).
    pub iso_threshold: f32,
    /// Iso-surface: smallest march step, particle radii.
    pub iso_step: f32,
    /// Iso-surface: radius of the spheres the march starts from, particle radii (the surface lies inside).
    pub iso_bound: f32,
    /// Iso-surface: most march steps per pixel.
    pub iso_max_steps: u32,
    /// Iso-surface: bisection iterations after the first step past the threshold.
    pub iso_refine: u32,
    /// How the depth splat draws.
    pub splat: SplatMode,
    /// Spray classification by neighbour count within 4 r even when the file has densities.
    pub spray_by_neighbours: bool,
    /// Particles whose density is below this fraction of the median density are spray and left out of the
    /// surface (0 = off). Uses the file's density, else a neighbour count.
    pub spray_density: f32,
    /// The depth splat draws spheres of this many particle radii (1 = the particles themselves).
    pub splat_radius_scale: f32,
    /// Narrow-range filter: background samples are skipped (true) or clamped to centre + μ like any far
    /// sample (false, the paper).
    pub nrf_skip_background: bool,
    /// World radius ρ of the smoothing kernel, in particle radii.
    pub smooth_radius: f32,
    /// Cap of the kernel radius in pixels.
    pub smooth_max_px: u32,
    /// Range σ_r of the bilateral filter, in particle radii.
    pub bilateral_sigma_range: f32,
    /// How many times the (separable) filter runs.
    pub bilateral_iterations: u32,
    /// Curvature flow: time step Δt (Moritz: 0.005); 0 = the largest stable step at each pixel
    /// (λ = Δt·F/(2(d+κ)) = 0.2), which carries over between resolutions and scene scales.
    pub cf_dt: f32,
    /// Curvature flow: iteration cap it_max (Moritz: 60).
    pub cf_it_max: u32,
    /// Curvature flow: world radius ρ in particle radii; a pixel iterates F·ρ/d times (Moritz eq. 3.8).
    pub cf_radius: f32,
    /// Curvature flow: κ stabiliser near the camera, world units (Moritz: 3).
    pub cf_kappa: f32,
    /// Curvature flow: iterations per dispatch (2–4: shared-memory tile; 1: one untiled dispatch per iteration,
    /// the faster on lavapipe, see README's measurements).
    pub cf_iters_per_dispatch: u32,
    /// Depth jump in particle radii that separates surfaces (curvature flow).
    pub cf_edge: f32,
    /// Narrow-range filter: world radius ρ of the kernel, in particle radii.
    pub nrf_radius: f32,
    /// Narrow-range filter: accepted range half-width, in particle radii (paper: 10–10.5).
    pub nrf_threshold: f32,
    /// Narrow-range filter: clamp offset μ behind the centre, in particle radii (paper: 1).
    pub nrf_mu: f32,
    /// Narrow-range filter: window radius of the final 2D pass, pixels.
    pub nrf_2d_px: u32,
    /// Narrow-range filter: how many times the separable + 2D passes run.
    pub nrf_iterations: u32,
    /// Fluid resolution (splat, smooth) relative to the output: 1, 0.5 (half) or 0.25 (quarter); upsampled
    /// to full resolution by the `upsample` pass.
    pub fluid_scale: f32,
    /// Thickness resolution relative to the output (0.5 = half).
    pub thickness_scale: f32,
    /// Thickness blur radius in thickness pixels (0 = none).
    pub thickness_blur_px: u32,
    /// Depth jump, in particle radii, that the normals pass treats as a discontinuity.
    pub normal_edge: f32,
    /// Beer–Lambert extinction of water per metre (Moritz table 3.1) …
    pub extinction: [f32; 3],
    /// … times this scale (scenes are rarely metres thick).
    pub extinction_scale: f32,
    /// Colour I0 of the light scattered out of the fluid.
    pub fluid_color: [f32; 3],
    /// Ambient light on the fluid and the scene.
    pub ambient: f32,
    /// Refraction offset: pixels per world unit of thickness (α) …
    pub refraction_alpha: f32,
    /// … clamped to this many pixels (β).
    pub refraction_beta: f32,
    /// Transparency τ = exp(−γ·T), γ per world unit.
    pub transparency_gamma: f32,
    /// Specular strength k_s and Blinn–Phong exponent c.
    pub specular: f32,
    pub shininess: f32,
    /// Fresnel reflectance at normal incidence (water ≈ 0.02).
    pub f0: f32,
    /// Direction towards the sun (world), normalised on use.
    pub sun_dir: [f32; 3],
    pub sun_intensity: f32,
    /// Reflect the sky.
    pub reflect_sky: bool,
    /// Screen-space reflections of the scene (McGuire & Mara DDA).
    pub ssr: bool,
    /// SSR: pixels per step.
    pub ssr_stride: f32,
    /// SSR: most steps.
    pub ssr_max_steps: u32,
    /// SSR: binary refinement iterations after a hit.
    pub ssr_refine: u32,
    /// SSR: longest reflected ray, in particle radii.
    pub ssr_max_distance: f32,
    /// SSR: depth tolerance of a hit, in particle radii.
    pub ssr_thickness: f32,
    /// Put a few boxes beside the fluid.
    pub scene_boxes: bool,
    /// Draw the ground plane.
    pub ground: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            radius: 0.0,
            filter: Filter::NarrowRange,
            surface: Surface::Spheres,
            iso_support: 4.0,
            iso_threshold: 0.6,
            iso_step: 0.5,
            iso_bound: 2.0,
            iso_max_steps: 512,
            iso_refine: 4,
            splat: SplatMode::Compute,
            spray_by_neighbours: true,
            spray_density: 0.0,
            splat_radius_scale: 1.3,
            nrf_skip_background: true,
            smooth_radius: 4.0,
            smooth_max_px: 24,
            bilateral_sigma_range: 2.0,
            bilateral_iterations: 2,
            cf_dt: 0.0,
            cf_it_max: 60,
            cf_radius: 12.0,
            cf_kappa: 3.0,
            cf_iters_per_dispatch: 1,
            cf_edge: 6.0,
            nrf_radius: 6.0,
            nrf_threshold: 10.0,
            nrf_mu: 1.0,
            nrf_2d_px: 2,
            nrf_iterations: 1,
            fluid_scale: 1.0,
            thickness_scale: 0.5,
            thickness_blur_px: 3,
            normal_edge: 2.0,
            extinction: [0.555, 0.041, 0.0208],
            extinction_scale: 20.0,
            fluid_color: [0.10, 0.36, 0.52],
            ambient: 0.55,
            refraction_alpha: 60.0,
            refraction_beta: 24.0,
            transparency_gamma: 4.0,
            specular: 0.6,
            shininess: 300.0,
            f0: 0.02,
            sun_dir: [0.45, 0.8, 0.35],
            sun_intensity: 1.0,
            reflect_sky: true,
            ssr: true,
            ssr_stride: 8.0,
            ssr_max_steps: 100,
            ssr_refine: 4,
            ssr_max_distance: 400.0,
            ssr_thickness: 40.0,
            scene_boxes: true,
            ground: true,
        }
    }
}

impl Settings {
    /// Named presets.
    pub fn preset(name: &str) -> Result<Settings> {
        let d = Settings::default();
        match name {
            "default" => Ok(d),
            // The SPH iso-surface itself (what splashsurf reconstructs), unfiltered: the closest match to a
            // reconstructed reference surface, at the cost of the `iso` ray cast.
            "quality" => Ok(Settings { surface: Surface::Iso, filter: Filter::None, ..d }),
            "fast" => Ok(Settings { bilateral_iterations: 1, smooth_max_px: 12, thickness_blur_px: 2, ..d }),
            // Moritz 2016 (thesis values): curvature flow, Δt = 0.005, ≤ 60 iterations, κ = 3.
            "moritz" => Ok(Settings {
                filter: Filter::CurvatureFlow,
                cf_dt: 0.005,
                cf_it_max: 60,
                cf_kappa: 3.0,
                ssr_stride: 8.0,
                ssr_max_steps: 100,
                ssr_refine: 4,
                ..d
            }),
            _ => {
                Err(Error::Invalid(format!("unknown settings preset {name:?} (known: default, fast, quality, moritz)")))
            }
        }
    }

    /// Read a TOML file of settings over the defaults.
    pub fn from_toml(path: &std::path::Path) -> Result<Settings> {
        Settings::default().with_toml(path)
    }

    /// These settings with the fields a TOML file sets replaced (unknown keys and wrong types are errors that
    /// name the file and the byte offset).
    pub fn with_toml(&self, path: &std::path::Path) -> Result<Settings> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let parse_err = |offset: u64, reason: String| Error::Parse { path: path.to_path_buf(), offset, reason };
        let table: toml::Table = toml::from_str(&text)
            .map_err(|e| parse_err(e.span().map(|s| s.start as u64).unwrap_or(0), e.message().to_string()))?;
        let mut merged = serde_json::to_value(self).map_err(|e| Error::Invalid(e.to_string()))?;
        let over = serde_json::to_value(&table).map_err(|e| Error::Invalid(e.to_string()))?;
        if let (Some(m), Some(o)) = (merged.as_object_mut(), over.as_object()) {
            for (k, v) in o {
                m.insert(k.clone(), v.clone());
            }
        }
        serde_json::from_value(merged).map_err(|e| parse_err(0, format!("bad settings: {e}")))
    }

    /// The ray-cast parameters in world units.
    pub fn iso_params(&self) -> crate::iso::IsoParams {
        crate::iso::IsoParams {
            threshold: self.iso_threshold,
            step: self.iso_step * self.radius,
            bound: self.iso_bound * self.radius,
            max_steps: self.iso_max_steps,
            refine: self.iso_refine,
        }
    }

    /// Radius scale of the splatted spheres: the bound spheres when the iso-surface is ray-cast from them.
    pub fn splat_scale(&self) -> f32 {
        match self.surface {
            Surface::Spheres => self.splat_radius_scale,
            Surface::Iso => self.iso_bound,
        }
    }

    /// Check values a user could get wrong.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: &str| Err(Error::Invalid(format!("setting {what} is out of range")));
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return bad("radius (must be > 0)");
        }
        if !(self.fluid_scale > 0.0 && self.fluid_scale <= 1.0) {
            return bad("fluid_scale (0 < s ≤ 1)");
        }
        if !(self.splat_radius_scale >= 0.25 && self.splat_radius_scale <= 4.0) {
            return bad("splat_radius_scale (0.25 … 4)");
        }
        if !(self.thickness_scale > 0.0 && self.thickness_scale <= 1.0) {
            return bad("thickness_scale (0 < s ≤ 1)");
        }
        if self.smooth_max_px > 64 {
            return bad("smooth_max_px (≤ 64)");
        }
        if self.thickness_blur_px > 16 {
            return bad("thickness_blur_px (≤ 16)");
        }
        if self.cf_iters_per_dispatch == 0 || self.cf_iters_per_dispatch > 4 {
            return bad("cf_iters_per_dispatch (1 … 4)");
        }
        if self.cf_it_max > 1000 || self.nrf_iterations > 16 || self.nrf_2d_px > 8 {
            return bad("cf_it_max (≤ 1000), nrf_iterations (≤ 16) or nrf_2d_px (≤ 8)");
        }
        if !(self.cf_dt >= 0.0 && self.cf_dt.is_finite()) {
            return bad("cf_dt (≥ 0)");
        }
        let iso_ok = (1.0..=16.0).contains(&self.iso_support)
            && self.iso_threshold > 0.0
            && self.iso_threshold < 1.0
            && (0.01..=4.0).contains(&self.iso_step)
            && (0.5..=self.iso_support).contains(&self.iso_bound)
            && (1..=65536).contains(&self.iso_max_steps)
            && self.iso_refine <= 32;
        if !iso_ok {
            return bad("iso_* (support 1 … 16, 0 < threshold < 1, step 0.01 … 4, 0.5 ≤ bound ≤ support, 1 … 65536 steps, ≤ 32 refinements)");
        }
        if self.bilateral_iterations > 64 {
            return bad("bilateral_iterations (≤ 64)");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        check::<SplatMode>();
        let s: Settings = toml::from_str("filter = \"curvature-flow\"\nsplat = \"quad-min\"").unwrap();
        assert_eq!((s.filter, s.splat), (Filter::CurvatureFlow, SplatMode::QuadMin));
    }

    #[test]
    fn toml_overrides_the_preset_and_rejects_unknown_keys() {
        let dir = std::env::temp_dir().join(format!("meniscus-settings-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("good.toml");
        std::fs::write(&good, "nrf_radius = 8.0\nfilter = \"bilateral\"\n").unwrap();
        let s = Settings::preset("moritz").unwrap().with_toml(&good).unwrap();
        assert_eq!(s.nrf_radius, 8.0);
        assert_eq!(s.filter, Filter::Bilateral);
        assert_eq!(s.ssr_stride, 8.0); // from the preset
        let bad = dir.join("bad.toml");
        std::fs::write(&bad, "nrf_radiu = 8.0\n").unwrap();
        let e = Settings::default().with_toml(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.toml") && e.contains("nrf_radiu"), "{e}");
        let syntax = dir.join("syntax.toml");
        std::fs::write(&syntax, "nrf_radius = = 8\n").unwrap();
        let e = Settings::default().with_toml(&syntax).unwrap_err().to_string();
        assert!(e.contains("syntax.toml") && e.contains("byte"), "{e}");
    }

    #[test]
    fn presets_validate() {
        for p in ["default", "fast", "quality", "moritz"] {
            let s = Settings { radius: 0.01, ..Settings::preset(p).unwrap() };
            s.validate().unwrap();
        }
        assert!(Settings::preset("nope").is_err());
    }
}
