//! `smooth` pass: depth smoothing, one of several filters chosen per run (`Filter`). Kernel widths are in
//! world units (multiples of the particle radius), converted per pixel from depth.
//! Shaders: shaders_glsl/smooth_*.comp.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::frame::FrameInfo;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::settings::{Filter, Settings};
use crate::shaders;

pub const NAME: &str = "smooth";

/// Which image holds the smoothed depth after the pass: its input (no filter), or the first or the second
/// ping-pong image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Output {
    Input,
    First,
    Second,
}

pub struct Smooth {
    bilateral: ComputeProgram<BilateralPush>,
    narrow: ComputeProgram<NarrowPush>,
    curvature: ComputeProgram<CurvaturePush>,
    curvature1: ComputeProgram<CurvaturePush>,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct NarrowPush {
    dir: [i32; 2],
    world_radius: f32,
    threshold: f32,
    mu: f32,
    max_px: i32,
    radius_2d: i32,
    skip_background: i32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CurvaturePush {
    iters: i32,
    first_iter: i32,
    it_max: i32,
    dt: f32,
    world_radius: f32,
    kappa: f32,
    edge: f32,
}

/// Work-group edge of smooth_curvature.comp.
use crate::shader_constants::CURVATURE_LOCAL;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BilateralPush {
    dir: [i32; 2],
    world_radius: f32,
    sigma_range: f32,
    max_px: i32,
}

// Every smoothing program reads one depth image and writes the next ping-pong image in full.
declare_program!(pub BILATERAL: BilateralPush = compute(shaders::SMOOTH_BILATERAL, [Uniform, ImgRead, ImgOverwrite]));
declare_program!(pub NARROW: NarrowPush = compute(shaders::SMOOTH_NARROW, [Uniform, ImgRead, ImgOverwrite]));
declare_program!(pub CURVATURE: CurvaturePush = compute(shaders::SMOOTH_CURVATURE, [Uniform, ImgRead, ImgOverwrite]));
declare_program!(pub CURVATURE1: CurvaturePush = compute(shaders::SMOOTH_CURVATURE1, [Uniform, ImgRead, ImgOverwrite]));

/// One dispatch of `prog`: read `src`, write `dst`.
fn step<P: bytemuck::Pod>(
    ctx: &mut FrameCtx,
    prog: &ComputeProgram<P>,
    frame: &Buffer,
    (src, dst): (&Image, &Image),
    push: &P,
    local: u32,
) {
    let g = groups_2d(dst.extent.width, dst.extent.height, local);
    prog.dispatch(ctx, &[frame.into(), src.into(), dst.into()], push, g);
}

impl Smooth {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Smooth {
            bilateral: ComputeProgram::new(gpu, &BILATERAL)?,
            narrow: ComputeProgram::new(gpu, &NARROW)?,
            curvature: ComputeProgram::new(gpu, &CURVATURE)?,
            curvature1: ComputeProgram::new(gpu, &CURVATURE1)?,
        })
    }

    /// Smooth `depth` using `a` and `b` as ping-pong images; returns the image holding the result
    /// (`depth` itself when the filter is `None`). `depth` is only read. `cf_iterations_needed`: the largest
    /// adaptive iteration count any pixel can have this frame (F·ρ/d of the nearest particle), see
    /// [`iterations_needed`].
    /// Smooth `depth` with `s.filter`, ping-ponging between `pong.0` and `pong.1` (the second may be `depth`
    /// itself when the raw depth need not survive); returns which image holds the result. The pass decides its
    /// own dispatch count: curvature flow stops where no pixel iterates any more (`iterations_needed` from the
    /// frame's focal length and nearest fluid depth).
    pub fn record<'a>(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        depth: &'a Image,
        pong: (&'a Image, &'a Image),
        s: &Settings,
        info: &FrameInfo,
    ) -> Output {
        self.record_iterations(ctx, frame, depth, pong, s, iterations_needed(s, info.focal_px, info.d_near))
    }

    /// [`Smooth::record`] with the curvature-flow iteration count given (tests drive it directly).
    pub fn record_iterations<'a>(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        depth: &'a Image,
        pong: (&'a Image, &'a Image),
        s: &Settings,
        cf_iterations_needed: u32,
    ) -> Output {
        let (a, b) = pong;
        let r = s.radius;
        // Each dispatch reads `src` and writes the next ping-pong image, which becomes `src`; `out` counts.
        let mut out = Output::Input;
        let mut src = depth;
        let mut next = |src: &mut &'a Image| -> (&'a Image, &'a Image) {
            let (dst, o) = if out == Output::First { (b, Output::Second) } else { (a, Output::First) };
            out = o;
            let pair = (*src, dst);
            *src = dst;
            pair
        };
        if s.filter == Filter::None {
            return Output::Input;
        }
        ctx.pass(NAME, |ctx| match s.filter {
            Filter::None => {}
            Filter::Gaussian | Filter::Bilateral | Filter::Bilateral2d => {
                let sigma_range = if s.filter == Filter::Gaussian { 0.0 } else { s.bilateral_sigma_range * r };
                let dirs: &[[i32; 2]] = if s.filter == Filter::Bilateral2d { &[[0, 0]] } else { &[[1, 0], [0, 1]] };
                for _ in 0..s.bilateral_iterations.max(1) {
                    for dir in dirs {
                        let push = BilateralPush {
                            dir: *dir,
                            world_radius: s.smooth_radius * r,
                            sigma_range,
                            max_px: s.smooth_max_px as i32,
                        };
                        step(ctx, &self.bilateral, frame, next(&mut src), &push, super::LOCAL_2D);
                    }
                }
            }
            Filter::NarrowRange => {
                for _ in 0..s.nrf_iterations.max(1) {
                    for dir in [[1, 0], [0, 1], [0, 0]] {
                        let push = NarrowPush {
                            dir,
                            world_radius: s.nrf_radius * r,
                            threshold: s.nrf_threshold * r,
                            mu: s.nrf_mu * r,
                            max_px: s.smooth_max_px as i32,
                            radius_2d: s.nrf_2d_px as i32,
                            skip_background: s.nrf_skip_background as i32,
                        };
                        step(ctx, &self.narrow, frame, next(&mut src), &push, super::LOCAL_2D);
                    }
                }
            }
            Filter::CurvatureFlow => {
                let k = s.cf_iters_per_dispatch.clamp(1, 4);
                // No pixel iterates more than F·ρ/d_near times: stop dispatching there.
                let total = s.cf_it_max.min(cf_iterations_needed);
                let mut first = 0;
                while first < total {
                    let iters = k.min(total - first);
                    let push = CurvaturePush {
                        iters: iters as i32,
                        first_iter: first as i32,
                        it_max: s.cf_it_max as i32,
                        dt: s.cf_dt,
                        world_radius: s.cf_radius * r,
                        kappa: s.cf_kappa,
                        edge: s.cf_edge * r,
                    };
                    // K = 1: the untiled shader (no shared memory, no halo recomputation).
                    if iters == 1 {
                        step(ctx, &self.curvature1, frame, next(&mut src), &push, super::LOCAL_2D)
                    } else {
                        step(ctx, &self.curvature, frame, next(&mut src), &push, CURVATURE_LOCAL)
                    }
                    first += iters;
                }
            }
        });
        out
    }
}

/// Largest adaptive curvature-flow iteration count of a frame: F·ρ/d for the nearest particle depth `d_near`.
pub fn iterations_needed(s: &Settings, focal_px: f32, d_near: f32) -> u32 {
    let its = focal_px * s.cf_radius * s.radius / d_near.max(1e-6);
    (its.ceil().max(0.0) as u32).min(s.cf_it_max)
}
