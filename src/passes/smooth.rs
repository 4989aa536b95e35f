//! `smooth` pass: depth smoothing, one of several filters chosen per run (`Filter`). Kernel widths are in
//! world units (multiples of the particle radius), converted per pixel from depth.
//! Shaders: shaders_glsl/smooth_*.comp.
use std::sync::Arc;

use crate::error::Result;
use crate::gpu::pipeline::bt::*;
use crate::gpu::{Bind, Buffer, ComputeProgram, FrameCtx, Gpu, Image, Use};
use crate::settings::{Filter, Settings};
use crate::shaders;

pub const NAME: &str = "smooth";

pub struct Smooth {
    bilateral: ComputeProgram,
    narrow: ComputeProgram,
    curvature: ComputeProgram,
    curvature1: ComputeProgram,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct NarrowPush {
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
struct CurvaturePush {
    iters: i32,
    first_iter: i32,
    it_max: i32,
    dt: f32,
    world_radius: f32,
    kappa: f32,
    edge: f32,
}

/// Work-group edge of smooth_curvature.comp.
const CURVATURE_LOCAL: u32 = 8;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct BilateralPush {
    dir: [i32; 2],
    world_radius: f32,
    sigma_range: f32,
    max_px: i32,
}

impl Smooth {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Smooth {
            bilateral: ComputeProgram::new(gpu, NAME, shaders::SMOOTH_BILATERAL, &[UBO, IMG, IMG], 20)?,
            narrow: ComputeProgram::new(gpu, NAME, shaders::SMOOTH_NARROW, &[UBO, IMG, IMG], 32)?,
            curvature: ComputeProgram::new(gpu, NAME, shaders::SMOOTH_CURVATURE, &[UBO, IMG, IMG], 28)?,
            curvature1: ComputeProgram::new(gpu, NAME, shaders::SMOOTH_CURVATURE1, &[UBO, IMG, IMG], 28)?,
        })
    }

    /// Smooth `depth` using `a` and `b` as ping-pong images; returns the image holding the result
    /// (`depth` itself when the filter is `None`). `depth` is only read. `cf_iterations_needed`: the largest
    /// adaptive iteration count any pixel can have this frame (F·ρ/d of the nearest particle), see
    /// [`iterations_needed`].
    #[allow(clippy::too_many_arguments)]
    pub fn record<'a>(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        depth: &'a Image,
        a: &'a Image,
        b: &'a Image,
        s: &Settings,
        cf_iterations_needed: u32,
    ) -> &'a Image {
        let r = s.radius;
        // One dispatch: read `src`, write the next ping-pong image, return it.
        let mut targets = [a, b].into_iter().cycle();
        let mut step =
            |ctx: &mut FrameCtx, prog: &ComputeProgram, src: &'a Image, push: &[u8], local: u32| -> &'a Image {
                let dst = targets.next().expect("cycle");
                ctx.barrier(&[Use::buf_read(frame), Use::read(src), Use::overwrite(dst)]);
                let g = ComputeProgram::groups_2d(dst.extent.width, dst.extent.height, local);
                prog.dispatch(ctx, &[Bind::Uniform(frame), Bind::Storage(src), Bind::Storage(dst)], push, g);
                dst
            };
        if s.filter == Filter::None {
            return depth;
        }
        let mut src = depth;
        ctx.pass(NAME, &[], |ctx| match s.filter {
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
                        src = step(ctx, &self.bilateral, src, bytemuck::bytes_of(&push), super::LOCAL_2D);
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
                        src = step(ctx, &self.narrow, src, bytemuck::bytes_of(&push), super::LOCAL_2D);
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
                    src = if iters == 1 {
                        step(ctx, &self.curvature1, src, bytemuck::bytes_of(&push), super::LOCAL_2D)
                    } else {
                        step(ctx, &self.curvature, src, bytemuck::bytes_of(&push), CURVATURE_LOCAL)
                    };
                    first += iters;
                }
            }
        });
        src
    }
}

/// Largest adaptive curvature-flow iteration count of a frame: F·ρ/d for the nearest particle depth `d_near`.
pub fn iterations_needed(s: &Settings, focal_px: f32, d_near: f32) -> u32 {
    let its = focal_px * s.cf_radius * s.radius / d_near.max(1e-6);
    (its.ceil().max(0.0) as u32).min(s.cf_it_max)
}
