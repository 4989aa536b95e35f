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
    /// The hand-set limits.
    pub fn limits(&self) -> Limits {
        Limits { trapped_air: self.trapped_air, wave_crest: self.wave_crest, kinetic: self.kinetic }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        super::NAME
    }

    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(super::NAME);
        k.above("size", self.size, 0.0, 16.0)?;
        k.within("size_spread", self.size_spread, 0.0, 1.0)?;
        k.rule("size_spread", self.size_spread < 1.0, || {
            format!("size_spread = {} must be below 1", self.size_spread)
        })?;
        k.within("shutter", self.shutter, 0.0, 1.0)?;
        k.within("opacity", self.opacity, 0.0, 16.0)?;
        k.within("fade", self.fade, 0.0, 60.0)?;
        k.within("fade_in", self.fade_in, 0.0, 60.0)?;
        k.within("foam_depth", self.foam_depth, 0.0, 64.0)?;
        k.above("bubble_depth", self.bubble_depth, 0.0, 1e4)?;
        k.each("color", &self.color, 0.0, 1.0)?;
        k.within("bubbles", self.bubbles, 0.0, 1.0)?;
        k.within("foam_scale", self.foam_scale, 0.0, 1e6)?;
        k.pair("trapped_air", self.trapped_air, 0.0, 1e9)?;
        k.pair("wave_crest", self.wave_crest, 0.0, 1e9)?;
        k.pair("kinetic", self.kinetic, 0.0, 1e9)?;
        k.pair("lifetime", self.lifetime, 0.0, 1e9)?;
        k.within("buoyancy", self.buoyancy, 0.0, 100.0)?;
        k.within("drag", self.drag, 0.0, 1.0)?;
        k.within("air_drag", self.air_drag, 0.0, 100.0)?;
        k.count("spray_below", self.spray_below, 0, 1000)?;
        k.count("bubble_above", self.bubble_above, 0, 1000)?;
        k.rule("bubble_above", self.bubble_above >= self.spray_below, || {
            format!("bubble_above = {} must be at least spray_below = {}", self.bubble_above, self.spray_below)
        })?;
        k.count("min_neighbours", self.min_neighbours, 0, 1000)?;
        k.count("per_particle", self.per_particle, 1, 64)?;
        k.count("max_particles", self.max_particles, 1, 64_000_000)
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
