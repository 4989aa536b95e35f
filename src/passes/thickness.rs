//! `thickness` pass: additive chord length of every sphere at reduced resolution, cut by the scene depth,
//! then a 2D Gaussian blur. Shaders: shaders_glsl/thickness.comp, shaders_glsl/thickness_blur.comp.
use std::sync::Arc;

use crate::compute::clear::Clear;
use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `thickness`.
pub const NAME: &str = "thickness";

/// Settings of the `thickness` pass: the `[thickness]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Thickness resolution relative to the output (0.5 = half).
    pub scale: f32,
    /// Thickness blur radius in thickness pixels (0 = none).
    pub blur_px: u32,
}

impl Default for Params {
    fn default() -> Self {
        Params { scale: 0.5, blur_px: 3 }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(NAME);
        k.above("scale", self.scale, 0.0, 1.0)?;
        k.count("blur_px", self.blur_px, 0, 16)
    }
}

/// The pass: its compute program(s), built once per device.
pub struct Thickness {
    accumulate: ComputeProgram<AccumulatePush>,
    blur: ComputeProgram<BlurPush>,
    /// The accumulator's clear.
    clear: Clear,
}

/// Push constants of thickness.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct AccumulatePush {
    /// Particles.
    pub count: u32,
    /// 1: the particles are the iso grid's points, each its anisotropic kernel's ellipsoid.
    pub ellipsoid: u32,
    /// The kernels' longest axis relative to ∛det M.
    pub stretch: f32,
}

/// Push constants of thickness_blur.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BlurPush {
    /// Blur radius in pixels (0: conversion only).
    pub radius: u32,
    /// Gaussian σ in pixels.
    pub sigma: f32,
}

// Accumulate: frame, particles, scene depth → accum (atomic adds into the cleared image); the anisotropic
// kernels (read with `ellipsoid`).
declare_program!(pub ACCUMULATE: AccumulatePush = compute(shaders::THICKNESS, [Uniform, BufRead, ImgRead, ImgWrite, BufRead]));
// Blur: frame, accum → out.
declare_program!(pub BLUR: BlurPush = compute(shaders::THICKNESS_BLUR, [Uniform, ImgRead, ImgOverwrite]));

impl Thickness {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Thickness {
            accumulate: ComputeProgram::new(gpu, &ACCUMULATE)?,
            blur: ComputeProgram::new(gpu, &BLUR)?,
            clear: Clear::new(gpu)?,
        })
    }

    /// `accum` (R32_UINT) is cleared and filled; `out` (R32_SFLOAT, world units) receives the blurred result.
    /// With `ellipsoids` (the `anisotropy` pass's kernels of these particles, the iso grid's points, and their
    /// `stretch`) each particle adds the chord through its ellipsoid of the same volume.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        particles: &Buffer,
        count: u32,
        scene_depth: &Image,
        accum: &Image,
        out: &Image,
        blur_radius: u32,
        ellipsoids: Option<(&Buffer, f32)>,
    ) {
        ctx.pass(NAME, |ctx| {
            self.clear.record(ctx, accum, 0);
            let (kernels, stretch) = ellipsoids.unwrap_or((particles, 1.0));
            let push = AccumulatePush { count, ellipsoid: ellipsoids.is_some() as u32, stretch };
            let res = [frame.into(), particles.into(), scene_depth.into(), accum.into(), kernels.into()];
            self.accumulate.dispatch(ctx, &res, &push, [count.div_ceil(super::LOCAL_1D), 1, 1]);
            let push = BlurPush { radius: blur_radius, sigma: (blur_radius as f32 * 0.5).max(0.5) };
            let g = groups_2d(out.extent.width, out.extent.height, super::LOCAL_2D);
            self.blur.dispatch(ctx, &[frame.into(), accum.into(), out.into()], &push, g);
        });
    }
}
