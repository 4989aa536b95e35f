//! The SPH colour field on the CPU and the meshes made of it: `iso` (the field splashsurf reconstructs — cubic
//! spline of support 4 r, per-particle volume normalisation — its grid and its ray cast), `volume` (the
//! smoothed field),
//! `extract` (marching cubes in blocks, rayon) and `smooth` (splashsurf's feature-weighted Laplacian). They are
//! the references the surfaces' GPU passes are tested against, and the CPU path of `meniscus mesh`. They sit
//! below the passes and the surface techniques (both read their types), so the modules form no cycle.

pub mod export;
pub mod extract;
pub mod iso;
pub mod smooth;
pub mod volume;
