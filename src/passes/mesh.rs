//! `mesh` pass (with `surface = "mesh"`): the fluid surface as the triangle mesh marching cubes extracted from the
//! SPH colour field (`crate::field::extract`, built on the CPU when the particles change), ray-cast per pixel through
//! its BVH into the fluid depth instead of the splatted spheres; the rest of the frame is unchanged, so the two
//! techniques of the Janisz thesis compare like with like. Shader: shaders_glsl/mesh.comp (+ bvh.glsl).
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::passes::background::BvhBuffers;
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `mesh`.
pub const NAME: &str = "mesh";

/// Settings of the `mesh` pass: the `[mesh]` section of a settings file.
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

// Slots: frame, fluid depth (written), BVH nodes, triangles. Push: the node count.
declare_program!(pub PROGRAM: u32 = compute(shaders::MESH, [Uniform, ImgOverwrite, BufRead, BufRead]));

/// The pass: its compute program, built once per device.
pub struct Mesh {
    prog: ComputeProgram<u32>,
}

impl Mesh {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Mesh { prog: ComputeProgram::new(gpu, &PROGRAM)? })
    }

    /// Write the mesh's linear eye depth into all of `depth` (+inf where the ray misses it).
    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, mesh: &BvhBuffers, depth: &Image) {
        ctx.pass(NAME, |ctx| {
            let g = groups_2d(depth.extent.width, depth.extent.height, super::LOCAL_2D);
            let res = [frame.into(), depth.into(), (&mesh.nodes).into(), (&mesh.triangles).into()];
            self.prog.dispatch(ctx, &res, &mesh.node_count, g);
        });
    }
}
