//! `ssr` pass: screen-space reflections (hit uv per pixel, 4 bytes) of the background scene in the fluid (McGuire & Mara DDA, stride,
//! binary refinement; sky fallback in the composite). Shader: shaders_glsl/ssr.comp.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `ssr`.
pub const NAME: &str = "ssr";

/// Settings of the `ssr` pass: the `[ssr]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Screen-space reflections of the scene (McGuire & Mara DDA).
    pub enabled: bool,
    /// SSR: pixels per step.
    pub stride: f32,
    /// SSR: most steps.
    pub max_steps: u32,
    /// SSR: binary refinement iterations after a hit.
    pub refine: u32,
    /// SSR: longest reflected ray, in particle radii.
    pub max_distance: f32,
    /// SSR: depth tolerance of a hit, in particle radii.
    pub thickness: f32,
}

impl Default for Params {
    fn default() -> Self {
        Params { enabled: true, stride: 8.0, max_steps: 100, refine: 4, max_distance: 400.0, thickness: 40.0 }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(NAME);
        k.above("stride", self.stride, 0.0, 256.0)?;
        k.count("max_steps", self.max_steps, 1, 4096)?;
        k.count("refine", self.refine, 0, 32)?;
        k.within("max_distance", self.max_distance, 0.0, 1e5)?;
        k.within("thickness", self.thickness, 0.0, 1e5)
    }
}

/// The pass: its compute program(s), built once per device.
pub struct Ssr {
    prog: ComputeProgram<Push>,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
/// Push constants of ssr.comp.
pub struct Push {
    stride: f32,
    max_steps: i32,
    refine: i32,
    max_distance: f32,
    thickness: f32,
}

declare_program!(pub PROGRAM: Push = compute(shaders::SSR, [Uniform, ImgRead, ImgRead, ImgRead, ImgOverwrite]));

impl Ssr {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
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
        p: &Params,
        radius: f32,
    ) {
        ctx.pass(NAME, |ctx| {
            let push = Push {
                stride: p.stride.max(1.0),
                max_steps: if p.enabled { p.max_steps as i32 } else { 0 },
                refine: p.refine as i32,
                max_distance: p.max_distance * radius,
                thickness: p.thickness * radius,
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
