//! Meniscus — a Vulkan-native, compute-heavy screen-space fluid renderer for SPH particle data
//! (van der Laan, Green & Sainz 2009; Green 2010; Moritz 2016), with a GPU fluid simulation and surface
//! reconstruction beside it.
//!
//! Modules:
//! - rendering: [`renderer`] (the frame driver, its requests and read-back), [`frame`] (the frame's passes in
//!   order), [`passes`] (one struct per pass), [`surface`] (the surface techniques: spheres, iso, mesh),
//!   [`effect`] (effects beside a surface: noise, diffuse particles) and [`layer`] (what an effect hands the frame), [`background`] (the ray-cast scene behind
//!   the water), [`targets`] (the images every surface shares), [`particles`] (the particle set on the GPU),
//!   [`view`] (camera and projection), [`settings`] and [`section`] (the TOML settings and their sections),
//!   [`named`] (names shared by module, shader, label and JSON key), [`shader_constants`] and [`shaders`];
//! - measuring: [`timing`] (GPU timestamps per pass), [`work`] (each pass's work counts), [`inspect`] (what a
//!   frame holds, for the demo and tests), [`quality`] (a surface against a reference, its roughness, flicker);
//! - computing: [`compute`] (the GPU neighbour grid, marching cubes), [`field`] (the SPH colour field on the CPU:
//!   extraction, smoothing, volumes), [`sim`] (PBF and DFSPH on the GPU, scene files, validation), [`diffuse`]
//!   (spray, foam and bubbles), [`motion`] (per-particle motion for the noise);
//! - files: [`scene`] (particles, loaders, camera, procedural scenes), [`input`] (bounded reads), [`output`]
//!   (atomic writers: PNG, NPY, particle caches), [`export`] (USD and OpenVDB);
//! - the device: [`device`] (the device as applications see it; the layer itself, `gpu`, is hidden).

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
pub mod layer;
pub mod motion;
pub mod named;
pub mod output;
pub mod particles;
pub mod passes;
pub mod quality;
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
