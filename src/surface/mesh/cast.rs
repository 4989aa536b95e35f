//! `mesh` pass (with `surface = "mesh"`): the fluid surface as the triangle mesh marching cubes extracted from the
//! SPH colour field (`crate::field::extract`, built on the CPU when the particles change), ray-cast per pixel through
//! its BVH into the fluid depth instead of the splatted spheres; the rest of the frame is unchanged, so the two
//! techniques of the Janisz thesis compare like with like. Shader: shaders_glsl/mesh/mesh.comp (+ bvh.glsl).
//! In: the frame, the mesh's BVH. Out: the fluid depth.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::passes::background::BvhBuffers;
use crate::shaders;

/// The pass's one name (shader stem, debug label, timestamp key, JSON key): `mesh`.
pub const NAME: &str = "mesh";

// Slots: frame, fluid depth (written), BVH nodes, triangles. Push: the node count.
declare_program!(pub PROGRAM: u32 = compute(shaders::MESH, [Uniform, ImgOverwrite, BufRead, BufRead]));

/// The pass: its compute program, built once per device (by the mesh surface, on its first frame).
pub struct MeshCast {
    prog: ComputeProgram<u32>,
}

impl MeshCast {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(MeshCast { prog: ComputeProgram::new(gpu, &PROGRAM)? })
    }

    /// Write the mesh's linear eye depth into all of `depth` (+inf where the ray misses it).
    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, mesh: &BvhBuffers, depth: &Image) {
        ctx.pass(NAME, |ctx| {
            let g = groups_2d(depth.extent.width, depth.extent.height, crate::passes::LOCAL_2D);
            let res = [frame.into(), depth.into(), (&mesh.nodes).into(), (&mesh.triangles).into()];
            self.prog.dispatch(ctx, &res, &mesh.node_count, g);
        });
    }
}
