//! `ssr` pass: screen-space reflections (hit uv per pixel, 4 bytes) of the background scene in the fluid (McGuire & Mara DDA, stride,
//! binary refinement; sky fallback in the composite). Shader: shaders_glsl/ssr.comp.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::settings::Settings;
use crate::shaders;

pub const NAME: &str = "ssr";

pub struct Ssr {
    prog: ComputeProgram<Push>,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Push {
    stride: f32,
    max_steps: i32,
    refine: i32,
    max_distance: f32,
    thickness: f32,
}

declare_program!(pub PROGRAM: Push = compute(shaders::SSR, [Uniform, ImgRead, ImgRead, ImgRead, ImgOverwrite]));

impl Ssr {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Ssr { prog: ComputeProgram::new(gpu, &PROGRAM)? })
    }

    /// Writes all of `out` (alpha 0 where nothing is hit, everywhere when SSR is off).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        depth: &Image,
        normals: &Image,
        scene_depth: &Image,
        out: &Image,
        s: &Settings,
    ) {
        ctx.pass(NAME, |ctx| {
            let push = Push {
                stride: s.ssr_stride.max(1.0),
                max_steps: if s.ssr { s.ssr_max_steps as i32 } else { 0 },
                refine: s.ssr_refine as i32,
                max_distance: s.ssr_max_distance * s.radius,
                thickness: s.ssr_thickness * s.radius,
            };
            let g = groups_2d(out.extent.width, out.extent.height, super::LOCAL_2D);
            self.prog.dispatch(
                ctx,
                &[frame.into(), depth.into(), normals.into(), scene_depth.into(), out.into()],
                &push,
                g,
            );
        });
    }
}

/// Value of an `ssr` pixel whose ray hits nothing (`SSR_MISS` in the shaders).
pub const MISS: u32 = crate::shader_constants::SSR_MISS;

/// Decode an `ssr` pixel: the hit's uv, or None.
pub fn decode(v: u32) -> Option<[f32; 2]> {
    (v != MISS).then(|| [(v & 0xffff) as f32 / 65535.0, (v >> 16) as f32 / 65535.0])
}
