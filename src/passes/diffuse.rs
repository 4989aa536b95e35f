//! `diffuse` pass: draws the diffuse particles ([`crate::diffuse`]: spray, foam and bubbles after Ihmsen et al.
//! 2012) and the isolated fluid particles (low density: kept out of the surface, NVIDIA patent US 8,947,430) as small billboards,
//! stretched along their velocity over the shutter time, sizes varied per particle, fading at the end of their
//! life. Foam and spray show where nothing nearer hides them; bubbles show through the water above them,
//! attenuated by its depth. The coverage goes into two fixed-point images that `composite` lays over the
//! shaded water (bubbles under it, foam and spray on it). Runs after `noise`, before `ssr`; recorded only with
//! `[diffuse] enabled` and something to draw. Shader: shaders_glsl/diffuse.comp.
use std::sync::Arc;

use ash::vk;

use crate::compute::clear::Clear;
use crate::declare_program;
use crate::diffuse::{params::Params, Kind, Particle};
use crate::error::Result;
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key, settings section).
pub const NAME: &str = crate::diffuse::NAME;

/// Fixed-point units of the coverage images per unit of coverage.
pub const UNITS: f32 = crate::shader_constants::DIFFUSE_UNITS;

/// Push constants of diffuse.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Push {
    /// Fluid particles (positions, then motions, come first in the buffer).
    pub count: u32,
    /// Diffuse particles after them (two vec4 each).
    pub diffuse: u32,
    /// 1: draw the fluid particles marked isolated too.
    pub isolated: u32,
    /// Seconds of motion blur.
    pub shutter: f32,
    /// World units below the surface where foam still shows.
    pub foam_depth: f32,
    /// World units of water that attenuate a bubble by 1/e.
    pub bubble_depth: f32,
    /// An isolated fluid particle's billboard radius, in its own radii.
    pub isolated_size: f32,
    /// Coverage at a billboard's centre.
    pub opacity: f32,
    /// 1: the diffuse particles follow a header written on the GPU (their count; the dispatch is indirect).
    pub indirect: u32,
}

// Slots: frame, particles (+ motions, + diffuse), fluid depth, scene depth → white, bubbles (cleared first).
declare_program!(pub PROGRAM: Push = compute(shaders::DIFFUSE, [Uniform, BufRead, ImgRead, ImgRead, ImgWrite, ImgWrite]));

/// The images the pass reads and writes.
pub struct DiffuseImages<'a> {
    /// Fluid depth at full resolution.
    pub depth: &'a Image,
    /// Background depth.
    pub scene_depth: &'a Image,
    /// The pass's own images.
    pub own: &'a DiffuseTargets,
}

/// What the pass owns per frame size, allocated only while it has something to draw (`Targets::diffuse`).
pub struct DiffuseTargets {
    /// Coverage of foam and spray (R32_UINT, [`UNITS`]).
    pub white: Image,
    /// Coverage of bubbles, attenuated by the water above them (R32_UINT).
    pub bubbles: Image,
}

impl DiffuseTargets {
    /// The pass's images for a `width`×`height` output.
    pub fn new(gpu: &Arc<Gpu>, width: u32, height: u32) -> Result<DiffuseTargets> {
        use vk::ImageUsageFlags as U;
        let storage = U::STORAGE | U::TRANSFER_SRC | U::TRANSFER_DST;
        let full = vk::Extent2D { width, height };
        let img = |name| Image::new(gpu, name, full, vk::Format::R32_UINT, storage, None);
        Ok(DiffuseTargets { white: img("diffuse_white")?, bubbles: img("diffuse_bubbles")? })
    }

    /// (name, bytes) of each image, for the memory table.
    pub fn memory(&self) -> Vec<(&str, u64)> {
        vec![(self.white.name.as_str(), self.white.bytes()), (self.bubbles.name.as_str(), self.bubbles.bytes())]
    }
}

/// The pass: its compute program, built once per device.
pub struct Diffuse {
    prog: ComputeProgram<Push>,
    /// The two accumulators' clears.
    clear: Clear,
}

/// The GPU layout of one diffuse particle: (xyz, billboard radius in world units), (velocity, kind + fade)
/// with fade in (0, 1) (1: in full life; rises from 0 over its first `fade_in` seconds and falls to 0 over its
/// last `fade` seconds). shaders_glsl/sim_diffuse_draw.comp does the same on the GPU.
pub fn encode(p: &Particle, s: &Params, radius: f32) -> [[f32; 4]; 2] {
    let u = crate::diffuse::generator::unit(crate::diffuse::generator::hash4(p.id, 0x5eed, 0, 0));
    let size = s.size * radius * (1.0 + s.size_spread * (2.0 * u - 1.0));
    let ramp = |t: f32, over: f32| if over > 0.0 { t / over } else { 1.0 };
    let fade = ramp(p.lifetime, s.fade).min(ramp(p.age, s.fade_in)).clamp(1e-3, 0.999);
    let kind = match p.kind {
        Kind::Foam => 0.0,
        Kind::Spray => 1.0,
        Kind::Bubble => 2.0,
    };
    [p.position.extend(size).to_array(), p.velocity.extend(kind + fade).to_array()]
}

impl Diffuse {
    /// Build the pass's pipeline (its slot list was checked against the shader at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Diffuse { prog: ComputeProgram::new(gpu, &PROGRAM)?, clear: Clear::new(gpu)? })
    }

    /// Draw the `diffuse` particles that follow the `count` fluid particles in `particles` (and, with `isolated`,
    /// the fluid particles marked isolated) into the coverage images. `indirect`: a GPU producer wrote them after a
    /// header vec4 (the dispatch's groups, 1, 1, their count; at most `diffuse`), which the dispatch reads.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        particles: (&Buffer, u32),
        (diffuse, indirect): (u32, bool),
        isolated: bool,
        i: &DiffuseImages,
        s: &Params,
        radius: f32,
    ) {
        ctx.pass(NAME, |ctx| {
            self.clear.record(ctx, &i.own.white, 0);
            self.clear.record(ctx, &i.own.bubbles, 0);
            let (buf, count) = particles;
            let push = Push {
                count,
                diffuse,
                isolated: isolated as u32,
                shutter: s.shutter,
                foam_depth: s.foam_depth * radius,
                bubble_depth: s.bubble_depth * radius,
                isolated_size: s.size,
                opacity: s.opacity,
                indirect: indirect as u32,
            };
            let res = [
                frame.into(),
                buf.into(),
                i.depth.into(),
                i.scene_depth.into(),
                (&i.own.white).into(),
                (&i.own.bubbles).into(),
            ];
            if indirect {
                let layout = crate::shader_constants::ParticleLayout { count, header: true, diffuse };
                self.prog.dispatch_indirect(ctx, &res, &push, buf, 16 * layout.diffuse_header());
            } else {
                let threads = diffuse + if isolated { count } else { 0 };
                self.prog.dispatch(ctx, &res, &push, [threads.div_ceil(super::LOCAL_1D).max(1), 1, 1]);
            }
        });
    }
}

/// A CPU mirror of shaders_glsl/diffuse.comp, for tests: the same billboards, coverage and depth tests.
pub mod reference {
    use super::{Push, UNITS};

    /// One billboard: the view-space ends of its streak (x ∓ v·shutter/2), its world radius, whether it is a
    /// bubble, and its fade.
    pub struct Billboard {
        /// Streak start (view space).
        pub c0: [f32; 3],
        /// Streak end.
        pub c1: [f32; 3],
        /// World radius.
        pub radius: f32,
        /// A bubble (else foam or spray).
        pub bubble: bool,
        /// 0 … 1.
        pub fade: f32,
    }

    /// The white and bubble accumulators of a `w`×`h` image (focal `f` pixels) given the fluid and scene depth.
    pub fn accumulate(
        bs: &[Billboard],
        depth: &[f32],
        scene_depth: &[f32],
        (w, h): (usize, usize),
        f: f32,
        near: f32,
        pc: &Push,
    ) -> (Vec<u32>, Vec<u32>) {
        let (mut white, mut bubbles) = (vec![0u32; w * h], vec![0u32; w * h]);
        let px = |c: [f32; 3]| [0.5 * w as f32 + f * c[0] / -c[2] - 0.5, 0.5 * h as f32 - f * c[1] / -c[2] - 0.5];
        for b in bs {
            if -b.c0[2] <= near || -b.c1[2] <= near {
                continue;
            }
            let (p0, p1) = (px(b.c0), px(b.c1));
            let z = 0.5 * (-b.c0[2] - b.c1[2]);
            let r = (f * b.radius / z).max(0.75);
            let seg = [p1[0] - p0[0], p1[1] - p0[1]];
            let len2 = seg[0] * seg[0] + seg[1] * seg[1];
            let len = len2.sqrt();
            let lo = [(p0[0].min(p1[0]) - r).ceil().max(0.0) as i64, (p0[1].min(p1[1]) - r).ceil().max(0.0) as i64];
            let hi = [
                ((p0[0].max(p1[0]) + r).floor() as i64).min(w as i64 - 1),
                ((p0[1].max(p1[1]) + r).floor() as i64).min(h as i64 - 1),
            ];
            let w0 = pc.opacity * b.fade * r / (r + len);
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    let p = [x as f32, y as f32];
                    let t = if len2 > 1e-6 {
                        (((p[0] - p0[0]) * seg[0] + (p[1] - p0[1]) * seg[1]) / len2).clamp(0.0, 1.0)
                    } else {
                        0.5
                    };
                    let d = [p[0] - (p0[0] + t * seg[0]), p[1] - (p0[1] + t * seg[1])];
                    let q = (d[0] * d[0] + d[1] * d[1]) / (r * r);
                    if q > 1.0 {
                        continue;
                    }
                    let k = y as usize * w + x as usize;
                    let zp = -b.c0[2] + t * (-b.c1[2] + b.c0[2]);
                    if zp > scene_depth[k] {
                        continue;
                    }
                    let fd = depth[k];
                    let mut wt = w0 * (-3.0 * q).exp();
                    let under = fd < 1e30 && zp > fd;
                    if b.bubble && under {
                        wt *= (-(zp - fd) / pc.bubble_depth).exp();
                        bubbles[k] = bubbles[k].wrapping_add((wt * UNITS).round() as u32);
                    } else {
                        if under && zp > fd + pc.foam_depth {
                            continue;
                        }
                        white[k] = white[k].wrapping_add((wt * UNITS).round() as u32);
                    }
                }
            }
        }
        (white, bubbles)
    }
}
