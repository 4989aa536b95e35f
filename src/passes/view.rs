//! `view` pass (demo only): replaces the final image with one of the frame's buffers mapped to colour (raw or
//! smoothed depth, thickness, normals, SSR hits, or the scene colour under the `particles` pass).
//! Shader: shaders_glsl/view.comp.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `view`.
pub const NAME: &str = "view";

/// Push constants of view.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ViewPush {
    /// Which buffer (ViewMode index).
    pub mode: i32,
    /// Depth mapped to white …
    pub d_min: f32,
    /// … and to black.
    pub d_max: f32,
    /// Thickness mapped to full red.
    pub t_max: f32,
}

// Slots: frame, raw depth, smoothed depth, thickness, normals, ssr, scene colour, out.
declare_program!(pub PROGRAM: ViewPush = compute(
    shaders::VIEW,
    [Uniform, ImgRead, ImgRead, Sampled, ImgRead, ImgRead, Sampled, ImgOverwrite]
));

/// The pass: its compute program(s), built once per device.
pub struct Viewer {
    prog: ComputeProgram<ViewPush>,
}

impl Viewer {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Viewer { prog: ComputeProgram::new(gpu, &PROGRAM)? })
    }

    /// Map `mode`'s buffer into `t.final_color` (mode 6 = scene colour only).
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        t: &ViewImages,
        mode: i32,
        depth_range: (f32, f32),
        t_max: f32,
    ) {
        ctx.pass(NAME, |ctx| {
            let push = ViewPush { mode, d_min: depth_range.0, d_max: depth_range.1, t_max };
            let e = t.final_color.extent;
            let g = groups_2d(e.width, e.height, super::LOCAL_2D);
            let res = [
                frame.into(),
                t.depth.into(),
                t.smoothed.into(),
                t.thickness.into(),
                t.normals.into(),
                t.ssr.into(),
                t.scene_color.into(),
                t.final_color.into(),
            ];
            self.prog.dispatch(ctx, &res, &push, g);
        });
    }
}

/// The frame's images the debug views read, and the final image they write.
pub struct ViewImages<'a> {
    /// The raw splatted depth.
    pub depth: &'a Image,
    /// The smoothed depth.
    pub smoothed: &'a Image,
    /// The thickness.
    pub thickness: &'a Image,
    /// The packed normals.
    pub normals: &'a Image,
    /// The SSR hits.
    pub ssr: &'a Image,
    /// The background's colour.
    pub scene_color: &'a Image,
    /// The output.
    pub final_color: &'a Image,
}
