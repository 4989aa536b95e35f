//! `ssr` pass: screen-space reflections (hit uv per pixel, 4 bytes) of the background scene in the fluid (McGuire & Mara DDA, stride,
//! binary refinement; sky fallback in the composite). Shader: shaders_glsl/ssr.comp.
use std::sync::Arc;

use crate::error::Result;
use crate::gpu::pipeline::bt::*;
use crate::gpu::{Bind, Buffer, ComputeProgram, FrameCtx, Gpu, Image, Use};
use crate::settings::Settings;
use crate::shaders;

pub const NAME: &str = "ssr";

pub struct Ssr {
    prog: ComputeProgram,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    stride: f32,
    max_steps: i32,
    refine: i32,
    max_distance: f32,
    thickness: f32,
}

impl Ssr {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Ssr { prog: ComputeProgram::new(gpu, NAME, shaders::SSR, &[UBO, IMG, IMG, IMG, IMG], 20)? })
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
        let uses =
            [Use::buf_read(frame), Use::read(depth), Use::read(normals), Use::read(scene_depth), Use::overwrite(out)];
        ctx.pass(NAME, &uses, |ctx| {
            let push = Push {
                stride: s.ssr_stride.max(1.0),
                max_steps: if s.ssr { s.ssr_max_steps as i32 } else { 0 },
                refine: s.ssr_refine as i32,
                max_distance: s.ssr_max_distance * s.radius,
                thickness: s.ssr_thickness * s.radius,
            };
            let g = ComputeProgram::groups_2d(out.extent.width, out.extent.height, super::LOCAL_2D);
            self.prog.dispatch(
                ctx,
                &[
                    Bind::Uniform(frame),
                    Bind::Storage(depth),
                    Bind::Storage(normals),
                    Bind::Storage(scene_depth),
                    Bind::Storage(out),
                ],
                bytemuck::bytes_of(&push),
                g,
            );
        });
    }
}

/// Value of an `ssr` pixel whose ray hits nothing (mirrors SSR_MISS in common.glsl).
pub const MISS: u32 = 0xffff_ffff;

/// Decode an `ssr` pixel: the hit's uv, or None.
pub fn decode(v: u32) -> Option<[f32; 2]> {
    (v != MISS).then(|| [(v & 0xffff) as f32 / 65535.0, (v >> 16) as f32 / 65535.0])
}
