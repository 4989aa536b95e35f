//! `view` pass (demo only): replaces the final image with one of the frame's buffers mapped to colour, and
//! `particles` pass: the particles as lit spheres coloured by an attribute. Shaders: shaders_glsl/view.comp,
//! shaders_glsl/particles.comp. Also `overlay`: blends the demo's text overlay (shaders_glsl/overlay.comp).
use std::sync::Arc;

use crate::error::Result;
use crate::frame::Targets;
use crate::gpu::pipeline::bt::*;
use crate::gpu::{Bind, Buffer, ComputeProgram, FrameCtx, Gpu, Image, Use};
use crate::shaders;

pub const NAME: &str = "view";
pub const PARTICLES: &str = "particles";
pub const OVERLAY: &str = "overlay";

/// What the demo shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewMode {
    /// The shaded fluid.
    Final,
    /// Raw splatted depth.
    Depth,
    /// Smoothed depth.
    Smoothed,
    /// Thickness (heat map).
    Thickness,
    /// View-space normals.
    Normals,
    /// Screen-space reflection hits.
    Ssr,
    /// The particles as lit spheres coloured by an attribute.
    Particles,
}

impl ViewMode {
    pub const ALL: [ViewMode; 7] = [
        ViewMode::Final,
        ViewMode::Depth,
        ViewMode::Smoothed,
        ViewMode::Thickness,
        ViewMode::Normals,
        ViewMode::Ssr,
        ViewMode::Particles,
    ];
    pub fn name(self) -> &'static str {
        match self {
            ViewMode::Final => "final",
            ViewMode::Depth => "raw depth",
            ViewMode::Smoothed => "smoothed depth",
            ViewMode::Thickness => "thickness",
            ViewMode::Normals => "normals",
            ViewMode::Ssr => "ssr hits",
            ViewMode::Particles => "particles",
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ViewPush {
    mode: i32,
    d_min: f32,
    d_max: f32,
    t_max: f32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ParticlePush {
    count: u32,
    radius_scale: f32,
    hue: [f32; 2],
}

pub struct View {
    view: ComputeProgram,
    particles: ComputeProgram,
    overlay: ComputeProgram,
}

impl View {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(View {
            view: ComputeProgram::new(gpu, NAME, shaders::VIEW, &[UBO, IMG, IMG, TEX, IMG, IMG, TEX, IMG], 16)?,
            particles: ComputeProgram::new(gpu, PARTICLES, shaders::PARTICLES, &[UBO, SSBO, SSBO, IMG, IMG], 16)?,
            overlay: ComputeProgram::new(gpu, OVERLAY, shaders::OVERLAY, &[UBO, IMG, IMG], 0)?,
        })
    }

    /// Map `mode`'s buffer into `t.final_color` (mode 6 = scene colour only). `smoothed`: the smoothed depth.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        t: &Targets,
        smoothed: &Image,
        mode: i32,
        depth_range: (f32, f32),
        t_max: f32,
    ) {
        let uses = [
            Use::buf_read(frame),
            Use::read(&t.depth),
            Use::read(smoothed),
            Use::sampled(&t.thickness),
            Use::read(&t.normals),
            Use::read(&t.ssr),
            Use::sampled(&t.scene_color),
            Use::overwrite(&t.final_color),
        ];
        ctx.pass(NAME, &uses, |ctx| {
            let push = ViewPush { mode, d_min: depth_range.0, d_max: depth_range.1, t_max };
            let g = ComputeProgram::groups_2d(t.width, t.height, super::LOCAL_2D);
            self.view.dispatch(
                ctx,
                &[
                    Bind::Uniform(frame),
                    Bind::Storage(&t.depth),
                    Bind::Storage(smoothed),
                    Bind::Linear(&t.thickness),
                    Bind::Storage(&t.normals),
                    Bind::Storage(&t.ssr),
                    Bind::Linear(&t.scene_color),
                    Bind::Storage(&t.final_color),
                ],
                bytemuck::bytes_of(&push),
                g,
            );
        });
    }

    /// Draw the particles over the final image (after a mode-6 `record`).
    #[allow(clippy::too_many_arguments)]
    pub fn record_particles(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        particles: &Buffer,
        values: &Buffer,
        count: u32,
        t: &Targets,
        radius_scale: f32,
    ) {
        let uses = [
            Use::buf_read(frame),
            Use::buf_read(particles),
            Use::buf_read(values),
            Use::read(&t.depth),
            Use::write(&t.final_color),
        ];
        ctx.pass(PARTICLES, &uses, |ctx| {
            // Princisgh's two-colour ramp: blue (slow / light / low) to red, interpolated in hue.
            let push = ParticlePush { count, radius_scale, hue: [0.62, 0.0] };
            self.particles.dispatch(
                ctx,
                &[
                    Bind::Uniform(frame),
                    Bind::StorageBuf(particles),
                    Bind::StorageBuf(values),
                    Bind::StorageAlt(&t.depth),
                    Bind::Storage(&t.final_color),
                ],
                bytemuck::bytes_of(&push),
                [count.div_ceil(super::LOCAL_1D), 1, 1],
            );
        });
    }

    /// Blend `overlay` over the top-left of the final image.
    pub fn record_overlay(&self, ctx: &mut FrameCtx, frame: &Buffer, overlay: &Image, out: &Image) {
        ctx.pass(OVERLAY, &[Use::buf_read(frame), Use::read(overlay), Use::write(out)], |ctx| {
            let g = ComputeProgram::groups_2d(overlay.extent.width, overlay.extent.height, super::LOCAL_2D);
            self.overlay.dispatch(ctx, &[Bind::Uniform(frame), Bind::Storage(overlay), Bind::Storage(out)], &[], g);
        });
    }
}
