//! `composite` pass: shades the fluid over the background (Beer–Lambert, refraction, transparency, Fresnel,
//! reflection, Blinn–Phong) into the 8-bit output. Shader: shaders_glsl/composite.comp.
use std::sync::Arc;

use crate::error::Result;
use crate::gpu::pipeline::bt::*;
use crate::gpu::{Bind, Buffer, ComputeProgram, FrameCtx, Gpu, Image, Use};
use crate::shaders;

pub const NAME: &str = "composite";

pub struct Composite {
    prog: ComputeProgram,
}

/// The images the composite reads.
pub struct CompositeInputs<'a> {
    pub scene_color: &'a Image,
    pub scene_depth: &'a Image,
    pub depth: &'a Image,
    pub normals: &'a Image,
    pub thickness: &'a Image,
    pub ssr: &'a Image,
    /// The sky cube map (placeholder when procedural).
    pub sky: &'a Image,
}

impl Composite {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Composite {
            prog: ComputeProgram::new(
                gpu,
                NAME,
                shaders::COMPOSITE,
                &[UBO, TEX, IMG, IMG, IMG, TEX, IMG, IMG, TEX],
                0,
            )?,
        })
    }

    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, i: &CompositeInputs, out: &Image) {
        let uses = [
            Use::buf_read(frame),
            Use::sampled(i.scene_color),
            Use::read(i.scene_depth),
            Use::read(i.depth),
            Use::read(i.normals),
            Use::sampled(i.thickness),
            Use::overwrite(out),
            Use::read(i.ssr),
            Use::sampled(i.sky),
        ];
        ctx.pass(NAME, &uses, |ctx| {
            let g = ComputeProgram::groups_2d(out.extent.width, out.extent.height, super::LOCAL_2D);
            self.prog.dispatch(
                ctx,
                &[
                    Bind::Uniform(frame),
                    Bind::Linear(i.scene_color),
                    Bind::Storage(i.scene_depth),
                    Bind::Storage(i.depth),
                    Bind::Storage(i.normals),
                    Bind::Linear(i.thickness),
                    Bind::Storage(out),
                    Bind::Storage(i.ssr),
                    Bind::Linear(i.sky),
                ],
                &[],
                g,
            );
        });
    }
}
