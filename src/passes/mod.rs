//! The passes, in frame order. Each is a plain struct that owns its compute program(s) and binding table and
//! has one `record`; the name is the same everywhere: module, shader stem, debug label, timestamp key, JSON key.

/// Declares the frame's passes from ONE list, in frame order: each entry is the module (its name is the pass
/// name) and the pass type. It generates the `pub mod`, the [`Passes`] struct (one field per
/// pass, named like the module), its constructor, and [`PASS_NAMES`]. Adding a pass is one line here.
macro_rules! frame_passes {
    ($($(#[$doc:meta])* $module:ident: $ty:ident,)*) => {
        $(pub mod $module;)*

        /// The frame's passes, created once per device (field = module = pass name).
        pub struct Passes {
            $($(#[$doc])* pub $module: $module::$ty,)*
        }

        impl Passes {
            /// Build every pass's pipelines.
            pub fn new(gpu: &std::sync::Arc<crate::gpu::Gpu>) -> crate::error::Result<Passes> {
                Ok(Passes { $($module: $module::$ty::new(gpu)?,)* })
            }
        }

        /// The shared frame passes' names, in frame order (timestamp keys, JSON keys, `--timings` rows): the
        /// surface techniques' own (`crate::surface::PASS_NAMES`) run after `splat`, the effects' before
        /// `normals` (`crate::frame::pass_names` has them all). `upsample` runs only when the fluid is rendered at reduced resolution.
        pub const PASS_NAMES: &[&str] = &[$($module::NAME,)*];
    };
}

frame_passes! {
    /// Ground, boxes, mesh and sky behind the fluid (async compute part).
    background: BackgroundCast,
    /// Additive chord length, blurred (async compute part).
    thickness: Thickness,
    /// Nearest sphere depth of every particle.
    splat: Splat,
    /// The screen-space depth filter (the spheres' surface; `[filter]`).
    filter: DepthFilter,
    /// Reduced-resolution depth back to full size.
    upsample: Upsample,
    /// View-space normals.
    normals: Normals,
    /// Screen-space reflections.
    ssr: Ssr,
    /// Shading over the background.
    composite: Composite,
}

// The effects' passes (`crate::effect` owns and records them, before `normals`).
pub mod diffuse;
pub mod noise;

// The demo's passes (not part of the frame function).
pub mod overlay;
pub mod particles;
pub mod view;

pub(crate) use crate::shader_constants::{LOCAL_1D, LOCAL_2D};

/// Facts about this frame's camera that passes base their own per-frame decisions on (the smoothing's
/// dispatch count, the splat's occlusion pre-pass).
#[derive(Clone, Copy, Debug)]
pub struct FrameInfo {
    /// Focal length in output pixels.
    pub focal_px: f32,
    /// Focal length in fluid pixels (`fluid_scale` < 1 makes it smaller).
    pub focal_px_fluid: f32,
    /// Nearest eye depth of any particle (bounded below by the near plane).
    pub d_near: f32,
    /// Distance from the eye to the camera's target.
    pub target_distance: f32,
}
