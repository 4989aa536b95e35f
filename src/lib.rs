//! Meniscus — a Vulkan-native, compute-heavy screen-space fluid renderer for SPH particle data
//! (van der Laan, Green & Sainz 2009; Green 2010; Moritz 2016).
//!
//! Layout: [`device`] (the device as applications see it; the device layer itself, `gpu` — resources, access
//! tracking, programs, timestamps — is the library's own and hidden here), [`passes`] (one struct per pass),
//! [`frame`] (the frame's table of contents), [`renderer`] (frame driver and readback), [`scene`]
//! (particles, loaders, camera, procedural scenes), [`settings`], [`output`] (PNG/NPY writers).

#![warn(missing_docs)]

pub mod background;
pub mod compute;
pub mod device;
pub mod diffuse;
pub mod effect;
mod error;
pub mod export;
pub mod field;
pub mod frame;
/// The device layer: the library's own (its integration tests drive single passes through it); applications
/// use [`device`].
#[doc(hidden)]
pub mod gpu;
pub mod input;
pub mod inspect;
pub mod motion;
pub mod named;
pub mod output;
pub mod particles;
pub mod passes;
pub mod renderer;
pub mod scene;
pub mod section;
pub mod settings;
pub mod sim;
pub mod surface;
/// Constants shared by Rust and GLSL, defined once (build.rs passes them to every shader as macros).
pub mod shader_constants {
    include!("shader_constants.rs");
}
pub mod targets;
pub mod timing;
pub mod view;
pub mod work;

/// SPIR-V of every shader in shaders_glsl/, compiled by build.rs.
pub mod shaders {
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

/// The library's error, its `Result`, and the context a Vulkan call's error is given (`.vk("what")`); one path
/// each (the module `error` is private).
pub use error::{Error, Result, VkContext};
