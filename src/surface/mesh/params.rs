//! The `[mesh]` section of a settings file: the mesh surface's marching-cubes lattice and its smoothing (also
//! `meniscus mesh`'s defaults), its check. A leaf: it imports nothing of the renderer, so `settings` can hold it.

/// The section's name.
const NAME: &str = "mesh";

/// Settings of the `mesh` surface: the `[mesh]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Marching-cubes edge length in particle radii (the field, support and threshold are the `[iso]` ones).
    pub cube: f32,
    /// Laplacian smoothing iterations of the extracted mesh (`crate::field::smooth`; splashsurf's finishing: 25).
    pub smoothing_iters: u32,
    /// Smoothing with feature weights (isolated droplets keep their shape).
    pub smoothing_weights: bool,
}

impl Default for Params {
    fn default() -> Self {
        Params { cube: 0.5, smoothing_iters: 0, smoothing_weights: true }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(NAME);
        k.above("cube", self.cube, 0.05, 8.0)?;
        k.count("smoothing_iters", self.smoothing_iters, 0, 1000)
    }
}
