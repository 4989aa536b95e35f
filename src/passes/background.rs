//! `background` pass: the scene behind the fluid — ground plane, boxes, an optional OBJ mesh (through its
//! BVH, src/scene/geometry.rs), sky — into colour + linear depth. Shader: shaders_glsl/background.comp.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `background`.
pub const NAME: &str = "background";

/// Settings of the `background` pass: the `[background]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Put a few boxes beside the fluid.
    pub boxes: bool,
    /// Draw the ground plane.
    pub ground: bool,
    /// Direction towards the sun (world), normalised on use.
    pub sun_dir: [f32; 3],
    /// Sun intensity.
    pub sun_intensity: f32,
}

impl Default for Params {
    fn default() -> Self {
        Params { boxes: true, ground: true, sun_dir: [0.45, 0.8, 0.35], sun_intensity: 1.0 }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(NAME);
        k.each("sun_dir", &self.sun_dir, -1e3, 1e3)?;
        k.within("sun_intensity", self.sun_intensity, 0.0, 100.0)
    }
}

/// The pass: its compute programs, built once per device.
pub struct BackgroundCast {
    /// Without a mesh (no BVH walk compiled).
    plain: ComputeProgram<()>,
    /// With the mesh's BVH.
    mesh: ComputeProgram<u32>,
}

// Slots: frame, colour out, depth out, sky.
declare_program!(pub PROGRAM: () = compute(shaders::BACKGROUND, [Uniform, ImgOverwrite, ImgOverwrite, Sampled]));
// The same and the mesh: BVH nodes, triangles. Push: the BVH's node count.
declare_program!(pub PROGRAM_MESH: u32 = compute(
    shaders::BACKGROUND_MESH,
    [Uniform, ImgOverwrite, ImgOverwrite, Sampled, BufRead, BufRead]
));

impl BackgroundCast {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(BackgroundCast { plain: ComputeProgram::new(gpu, &PROGRAM)?, mesh: ComputeProgram::new(gpu, &PROGRAM_MESH)? })
    }

    /// Writes all of `color` and `depth`; `sky` is the cube map (a placeholder when procedural); `mesh`: the
    /// BVH nodes and triangles of the background mesh and its node count (0 = none; the buffers are then
    /// placeholders).
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        sky: &Image,
        mesh: &BvhBuffers,
        color: &Image,
        depth: &Image,
    ) {
        ctx.pass(NAME, |ctx| {
            let g = groups_2d(color.extent.width, color.extent.height, super::LOCAL_2D);
            let res = [frame.into(), color.into(), depth.into(), sky.into()];
            if mesh.node_count == 0 {
                self.plain.dispatch(ctx, &res, &(), g);
            } else {
                let res = [res[0], res[1], res[2], res[3], (&mesh.nodes).into(), (&mesh.triangles).into()];
                self.mesh.dispatch(ctx, &res, &mesh.node_count, g);
            }
        });
    }
}

/// A triangle BVH on the device (the background geometry, or the fluid mesh).
pub struct BvhBuffers {
    /// BVH nodes.
    pub nodes: Buffer,
    /// Triangles in BVH order.
    pub triangles: Buffer,
    /// Node count (0: no mesh).
    pub node_count: u32,
}
