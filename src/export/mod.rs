//! Writers for the formats other tools finish shots and papers in: USD stages (`usd`, a time-sampled mesh and
//! points for Blender, Houdini, Omniverse and usdview; binary in `usdc`) and OpenVDB volumes (`vdb`, a level set and a fog volume).
//! Both go through `crate::output`'s checks and partial files (never over an input, never half-written); the
//! volumes and per-vertex velocities they write come from `crate::field::export`.

pub mod usd;
mod usdc;
pub mod vdb;
