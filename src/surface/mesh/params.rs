//! The `[mesh]` section of a settings file: the mesh surface's marching-cubes lattice, its smoothing (also
//! `meniscus mesh`'s defaults) and where it is extracted, its check. A leaf: it imports nothing of the renderer,
//! so `settings` can hold it.

/// The section's name.
const NAME: &str = "mesh";

crate::named::named_enum! {
    /// Where the mesh surface is extracted (`[mesh] extraction`).
    pub enum Extraction {
        /// On the GPU where the device is one or the particles are GPU-written, on the CPU where the Vulkan
        /// device is a CPU driver (lavapipe: its emulated marching cubes is slower than the CPU's).
        Auto = "auto",
        /// On the CPU (rayon), its BVH ray-cast per pixel (`mesh` pass), again whenever the particles change.
        Cpu = "cpu",
        /// On the GPU inside the frame, smoothed there, drawn by a raster pass from the device's buffers (no
        /// read-back): live with a simulation (`demo --sim --surface mesh`).
        Gpu = "gpu",
    }
}

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
    /// Where the mesh is extracted: `auto`, `cpu` or `gpu` ([`Extraction`]).
    pub extraction: Extraction,
    /// The live mesh's triangle buffer at first holds this many triangles per cube of the occupied blocks (the
    /// vertices half as many): the 6,859 dam break at 0.5 r needs 0.088. A frame that needs more draws what fits,
    /// and the buffers grow for the next (a one-frame render renders again).
    pub live_triangles_per_cube: f32,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            cube: 0.5,
            smoothing_iters: 0,
            smoothing_weights: true,
            extraction: Extraction::Auto,
            live_triangles_per_cube: 1.0 / 6.0,
        }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(NAME);
        k.above("cube", self.cube, 0.05, 8.0)?;
        k.count("smoothing_iters", self.smoothing_iters, 0, 1000)?;
        k.above("live_triangles_per_cube", self.live_triangles_per_cube, 0.0, 5.0)
    }
}
