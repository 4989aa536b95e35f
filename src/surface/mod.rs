//! The fluid's surface techniques, one module each: `spheres` (the splatted particle spheres, smoothed in
//! screen space), `iso` (the SPH colour field ray-cast per pixel, exact or smoothed in 3D), `mesh` (the
//! marching-cubes mesh of the same field, ray-cast through its BVH). Each owns its resources and their
//! staleness and records the passes that write the fluid depth; the CPU references live beside each.

pub mod iso;
pub mod mesh;
