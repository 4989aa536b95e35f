//! `background` pass: the scene behind the fluid — ground plane, boxes, an optional OBJ mesh (through its
//! BVH, src/mesh.rs), sky — into colour + linear depth. Shader: shaders_glsl/background.comp.
use std::sync::Arc;

use crate::error::Result;
use crate::gpu::pipeline::bt::*;
use crate::gpu::{Bind, Buffer, ComputeProgram, FrameCtx, Gpu, Image, Use};
use crate::shaders;

pub const NAME: &str = "background";

pub struct Background {
    prog: ComputeProgram,
}

impl Background {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Background {
            prog: ComputeProgram::new(gpu, NAME, shaders::BACKGROUND, &[UBO, IMG, IMG, TEX, SSBO, SSBO], 4)?,
        })
    }

    /// Writes all of `color` and `depth`; `sky` is the cube map (a placeholder when procedural); `mesh`: the
    /// BVH nodes and triangles of the background mesh and its node count (0 = none; the buffers are then
    /// placeholders).
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        sky: &Image,
        mesh: &MeshBuffers,
        color: &Image,
        depth: &Image,
    ) {
        let uses = [
            Use::buf_read(frame),
            Use::sampled(sky),
            Use::buf_read(&mesh.nodes),
            Use::buf_read(&mesh.triangles),
            Use::overwrite(color),
            Use::overwrite(depth),
        ];
        ctx.pass(NAME, &uses, |ctx| {
            let g = ComputeProgram::groups_2d(color.extent.width, color.extent.height, super::LOCAL_2D);
            self.prog.dispatch(
                ctx,
                &[
                    Bind::Uniform(frame),
                    Bind::Storage(color),
                    Bind::Storage(depth),
                    Bind::Linear(sky),
                    Bind::StorageBuf(&mesh.nodes),
                    Bind::StorageBuf(&mesh.triangles),
                ],
                bytemuck::bytes_of(&mesh.node_count),
                g,
            );
        });
    }
}

/// The background mesh on the device.
pub struct MeshBuffers {
    pub nodes: Buffer,
    pub triangles: Buffer,
    pub node_count: u32,
}
