//! The `[anisotropy]` section of a settings file: the anisotropic kernels' parameters (Yu & Turk 2013, §4), in
//! particle radii, its check, and its world units (`crate::field::iso::AnisoParams`, the one type the pass and
//! the CPU reference read). A leaf: it imports nothing of the renderer, so `settings` can hold it.

/// The section's name.
const NAME: &str = "anisotropy";

/// Settings of the `anisotropy` pass: the `[anisotropy]` section of a settings file (used with
/// `kernel = "anisotropic"`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Largest ratio of the kernel's longest to its shortest axis (Yu & Turk's k_r = 4).
    pub ratio: f32,
    /// Particles with fewer neighbours within the kernel support keep a sphere (Yu & Turk's N_ε; a particle
    /// inside the fluid has about 32 within 4 r).
    pub min_neighbours: u32,
    /// Blend λ of each kernel's centre towards its neighbours' weighted mean (Yu & Turk eq. 6: 0.9; 0 keeps
    /// the particle positions). A blend above 0 widens the grid's cells by `max_shift`.
    pub centre_blend: f32,
    /// Longest move of a kernel centre, in particle radii.
    pub max_shift: f32,
    /// Longest axis of a kernel in units of the support (≥ 1): the kernels keep the sphere's volume up to this
    /// stretch; the grid's cells are this many supports wide, so the iso cast's cost grows with its cube.
    pub stretch: f32,
    /// Radius of the neighbourhood in supports (1 … 2; Yu & Turk use 2): its covariance shapes the kernel and
    /// its mean moves the centre. 2 visits about 8× the neighbours.
    pub radius: f32,
}

impl Default for Params {
    fn default() -> Self {
        Params { ratio: 4.0, min_neighbours: 20, centre_blend: 0.0, max_shift: 1.0, stretch: 1.0, radius: 1.0 }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    /// (`max_shift` is also at most `[iso] support`: `Settings::check`.)
    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(NAME);
        k.within("ratio", self.ratio, 1.0, 16.0)?;
        k.count("min_neighbours", self.min_neighbours, 0, 1000)?;
        k.within("centre_blend", self.centre_blend, 0.0, 1.0)?;
        k.within("max_shift", self.max_shift, 0.0, 16.0)?;
        k.within("stretch", self.stretch, 1.0, 3.0)?;
        k.within("radius", self.radius, 1.0, 2.0)
    }
}

impl Params {
    /// In world units for particles of `radius` and a kernel support of `support` radii.
    pub fn world(&self, radius: f32, support: f32) -> crate::field::iso::AnisoParams {
        crate::field::iso::AnisoParams {
            ratio: self.ratio,
            min_neighbours: self.min_neighbours,
            centre_blend: self.centre_blend,
            max_shift: if self.centre_blend > 0.0 { self.max_shift * radius } else { 0.0 },
            stretch: self.stretch,
            radius: self.radius.max(1.0) * support * radius,
        }
    }
}
