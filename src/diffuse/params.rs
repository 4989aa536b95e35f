//! The `[diffuse]` settings section and the potentials' limits (Ihmsen et al. 2012 eq. 1; Bender et al. 2019's
//! automatic limits). In: settings. Out: `Params`, `Limits`.

/// The `[diffuse]` section of a settings file: how diffuse particles are generated and moved (this module), and
/// how the `diffuse` pass draws them (`crate::passes::diffuse`). Lengths in particle radii.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Draw diffuse particles and the low-density spray (false: the `diffuse` pass is not recorded).
    pub enabled: bool,
    /// Billboard radius (radii).
    pub size: f32,
    /// Sizes vary per particle by ± this fraction.
    pub size_spread: f32,
    /// Motion blur: billboards stretch along the velocity over this many seconds.
    pub shutter: f32,
    /// Coverage at a billboard's centre.
    pub opacity: f32,
    /// The last seconds of a particle's life, over which it fades out.
    pub fade: f32,
    /// The first seconds of a particle's life, over which it fades in (no popping up at birth).
    pub fade_in: f32,
    /// Depth below the fluid surface (radii) where foam still shows.
    pub foam_depth: f32,
    /// Depth of water (radii) that attenuates a bubble by 1/e.
    pub bubble_depth: f32,
    /// Colour of foam and spray (lit by the ambient light and the sun).
    pub color: [f32; 3],
    /// How much of the bubbles' coverage shows (0 … 1).
    pub bubbles: f32,
    /// Diffuse particles spawned per unit of potential and second (FoamGenerator's `foamscale`).
    pub foam_scale: f32,
    /// Calibrate the limits from the sequence (Bender 2019); false: use the limits below.
    pub automatic: bool,
    /// Trapped-air potential limits (min, max).
    pub trapped_air: [f32; 2],
    /// Wave-crest potential limits.
    pub wave_crest: [f32; 2],
    /// Kinetic-energy limits.
    pub kinetic: [f32; 2],
    /// Lifetime in seconds (min, max; the kinetic energy picks within).
    pub lifetime: [f32; 2],
    /// Bubbles' buoyancy (× gravity).
    pub buoyancy: f32,
    /// Bubbles' drag toward the fluid velocity (fraction per step).
    pub drag: f32,
    /// Spray's air drag (per second).
    pub air_drag: f32,
    /// Fewer fluid neighbours than this: spray.
    pub spray_below: u32,
    /// More fluid neighbours than this: bubble.
    pub bubble_above: u32,
    /// Only fluid particles with at least this many neighbours spawn.
    pub min_neighbours: u32,
    /// At most this many diffuse particles live at once (spawns beyond it are dropped, in order).
    pub max_particles: u32,
    /// At most this many living diffuse particles per fluid particle that spawned them (spawns beyond it are
    /// dropped): bounds the memory of the live simulation's pool (this many slots per fluid particle).
    pub per_particle: u32,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            enabled: true,
            size: 0.5,
            size_spread: 0.5,
            shutter: 0.01,
            opacity: 0.35,
            fade: 0.5,
            fade_in: 0.12,
            foam_depth: 1.5,
            bubble_depth: 4.0,
            color: [0.95, 0.97, 1.0],
            bubbles: 0.6,
            foam_scale: 400.0,
            automatic: true,
            trapped_air: [5.0, 20.0],
            wave_crest: [2.0, 8.0],
            kinetic: [5.0, 50.0],
            lifetime: [1.0, 3.0],
            buoyancy: 2.0,
            drag: 0.8,
            air_drag: 0.5,
            spray_below: 6,
            bubble_above: 20,
            min_neighbours: 15,
            max_particles: 2_000_000,
            per_particle: 8,
        }
    }
}

impl Params {
    /// The first value out of range, as (key, reason).
    pub fn check(&self) -> std::result::Result<(), (&'static str, String)> {
        let range = |k: &'static str, v: [f32; 2]| {
            if v[0].is_finite() && v[1].is_finite() && 0.0 <= v[0] && v[0] < v[1] {
                Ok(())
            } else {
                Err((k, format!("[diffuse] {k} = [{}, {}] must be 0 ≤ min < max", v[0], v[1])))
            }
        };
        let non_neg = |k: &'static str, v: f32, max: f32| {
            if (0.0..=max).contains(&v) {
                Ok(())
            } else {
                Err((k, format!("[diffuse] {k} = {v} is out of range (0 ≤ {k} ≤ {max})")))
            }
        };
        let pos = |k: &'static str, v: f32, max: f32| {
            if v > 0.0 && v <= max {
                Ok(())
            } else {
                Err((k, format!("[diffuse] {k} = {v} is out of range (0 < {k} ≤ {max})")))
            }
        };
        pos("size", self.size, 16.0)?;
        if !(0.0..1.0).contains(&self.size_spread) {
            return Err((
                "size_spread",
                format!("[diffuse] size_spread = {} is out of range (0 ≤ size_spread < 1)", self.size_spread),
            ));
        }
        non_neg("shutter", self.shutter, 1.0)?;
        non_neg("opacity", self.opacity, 16.0)?;
        non_neg("fade", self.fade, 60.0)?;
        non_neg("fade_in", self.fade_in, 60.0)?;
        non_neg("foam_depth", self.foam_depth, 64.0)?;
        pos("bubble_depth", self.bubble_depth, 1e4)?;
        if self.color.iter().any(|c| !(0.0..=1.0).contains(c)) {
            return Err(("color", "[diffuse] color components are 0 … 1".into()));
        }
        non_neg("bubbles", self.bubbles, 1.0)?;
        non_neg("foam_scale", self.foam_scale, 1e6)?;
        range("trapped_air", self.trapped_air)?;
        range("wave_crest", self.wave_crest)?;
        range("kinetic", self.kinetic)?;
        range("lifetime", self.lifetime)?;
        non_neg("buoyancy", self.buoyancy, 100.0)?;
        non_neg("drag", self.drag, 1.0)?;
        non_neg("air_drag", self.air_drag, 100.0)?;
        if self.bubble_above < self.spray_below {
            return Err((
                "bubble_above",
                format!(
                    "[diffuse] bubble_above = {} must be at least spray_below = {}",
                    self.bubble_above, self.spray_below
                ),
            ));
        }
        if self.per_particle == 0 || self.per_particle > 64 {
            return Err((
                "per_particle",
                format!("[diffuse] per_particle = {} is out of range (1 … 64)", self.per_particle),
            ));
        }
        if self.max_particles == 0 || self.max_particles > 64_000_000 {
            return Err((
                "max_particles",
                format!("[diffuse] max_particles = {} is out of range (1 … 64000000)", self.max_particles),
            ));
        }
        Ok(())
    }

    /// The hand-set limits.
    pub fn limits(&self) -> Limits {
        Limits { trapped_air: self.trapped_air, wave_crest: self.wave_crest, kinetic: self.kinetic }
    }
}

/// The potentials' limits (min, max) of eq. 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Trapped air.
    pub trapped_air: [f32; 2],
    /// Wave crest.
    pub wave_crest: [f32; 2],
    /// Kinetic energy.
    pub kinetic: [f32; 2],
}

/// Eq. 1: `v` clamped to the limits and normalised to 0 … 1.
pub fn clamp_normalise(v: f32, [lo, hi]: [f32; 2]) -> f32 {
    if hi <= lo {
        return 0.0;
    }
    (v.min(hi) - v.min(lo)) / (hi - lo)
}
