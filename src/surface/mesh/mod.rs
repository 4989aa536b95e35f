//! The mesh surface: the marching-cubes mesh of the iso field (`extract`, on the CPU; the `mc` pass on the
//! GPU), optionally smoothed (`smooth`), ray-cast through its BVH by the `mesh` pass.

pub mod extract;
pub mod smooth;
