//! `composite` pass: shades the fluid over the background (Beer–Lambert, refraction, transparency, Fresnel,
//! reflection, Blinn–Phong) into the 8-bit output. Shader: shaders_glsl/composite.comp.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
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

// Slots: frame, scene colour, scene depth, fluid depth, normals, thickness, out, ssr, sky. No push constants.
declare_program!(pub PROGRAM: () = compute(
    shaders::COMPOSITE,
    [Uniform, Sampled, ImgRead, ImgRead, ImgRead, Sampled, ImgOverwrite, ImgRead, Sampled]
));

impl Composite {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Composite { prog: ComputeProgram::new(gpu, &PROGRAM)? })
    }

    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, i: &CompositeInputs, out: &Image) {
        ctx.pass(NAME, |ctx| {
            let g = groups_2d(out.extent.width, out.extent.height, super::LOCAL_2D);
            let res = [
                frame.into(),
                i.scene_color.into(),
                i.scene_depth.into(),
                i.depth.into(),
                i.normals.into(),
                i.thickness.into(),
                out.into(),
                i.ssr.into(),
                i.sky.into(),
            ];
            self.prog.dispatch(ctx, &res, &(), g);
        });
    }
}
