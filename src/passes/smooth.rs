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
}

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
        })
    }

    /// Smooth `depth` using `a` and `b` as ping-pong images; returns the image holding the result
    /// (`depth` itself when the filter is `None`). `depth` is only read.
    pub fn record<'a>(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        depth: &'a Image,
        a: &'a Image,
        b: &'a Image,
        s: &Settings,
    ) -> &'a Image {
        let r = s.radius;
        let (dirs, sigma_range): (&[[i32; 2]], f32) = match s.filter {
            Filter::None => return depth,
            Filter::Gaussian => (&[[1, 0], [0, 1]], 0.0),
            Filter::Bilateral => (&[[1, 0], [0, 1]], s.bilateral_sigma_range * r),
            Filter::Bilateral2d => (&[[0, 0]], s.bilateral_sigma_range * r),
        };
        let mut src = depth;
        let mut targets = [a, b].into_iter().cycle();
        ctx.pass(NAME, &[], |ctx| {
            for _ in 0..s.bilateral_iterations.max(1) {
                for dir in dirs {
                    let dst = targets.next().expect("cycle");
                    ctx.barrier(&[Use::buf_read(frame), Use::read(src), Use::overwrite(dst)]);
                    let push = BilateralPush {
                        dir: *dir,
                        world_radius: s.smooth_radius * r,
                        sigma_range,
                        max_px: s.smooth_max_px as i32,
                    };
                    let g = ComputeProgram::groups_2d(dst.extent.width, dst.extent.height, super::LOCAL_2D);
                    self.bilateral.dispatch(
                        ctx,
                        &[Bind::Uniform(frame), Bind::Storage(src), Bind::Storage(dst)],
                        bytemuck::bytes_of(&push),
                        g,
                    );
                    src = dst;
                }
            }
        });
        src
    }
}
