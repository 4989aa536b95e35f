//! The iso surface: the SPH colour field (splashsurf's: cubic spline of support 4 r, per-particle volume
//! normalisation, threshold 0.6), ray-cast per pixel on the GPU; `field` is its CPU reference.

pub mod field;
