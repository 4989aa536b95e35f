//! The clear of a 32-bit storage image, as the device does it fastest: on GPUs every texel set by a dispatch
//! (shaders_glsl/clear.comp), where the image already is in the layout its compute readers and writers use; on CPU
//! drivers (lavapipe) by a transfer clear (`FrameCtx::clear`, vkCmdClearColorImage). What the passes clear their
//! accumulators and depth images with. Why two ways, measured:
//! - on the H100, a transfer clear of the noise atlas took 0.24 ms of the 1080p frame (52 GB/s, with the layout
//!   transitions to and from the transfer layout), where the same bytes written by a dispatch cost what writing
//!   them costs;
//! - on lavapipe the dispatch stores texel by texel (an image store per SIMD lane), where its transfer clear fills
//!   memory: the wave scene at 960×540 (`meniscus bench --parts --scenes wave --quarter-framing
//!   --resolutions 960x540`, three alternated pairs, 2026-11-28) — `noise/clear` 3.9–4.6 → 0.47–0.56 ms,
//!   `splat/clear` 5.0–5.4 → 0.62–0.68 ms (docs/gpu-frame.md).
//!
//! An image made without TRANSFER_DST usage is cleared by the dispatch on every device.
//! In: the image (R32_SFLOAT or R32_UINT) and the value. Out: the image.
use std::sync::Arc;

use ash::vk;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, ComputeProgram, FrameCtx, Gpu, Image};
use crate::shader_constants::{CLEAR_SPAN, LOCAL_2D};
use crate::shaders;

/// Push constant of clear.comp: the value's 32 bits.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ClearPush {
    /// The value (a float's bits for an r32f image).
    pub bits: u32,
}

declare_program!(pub CLEAR_F32: ClearPush = compute(shaders::CLEAR_F32, [ImgOverwrite]));
declare_program!(pub CLEAR_U32: ClearPush = compute(shaders::CLEAR_U32, [ImgOverwrite]));

/// The two clear programs (r32f, r32ui), and whether this device clears by transfer.
pub struct Clear {
    f32: ComputeProgram<ClearPush>,
    u32: ComputeProgram<ClearPush>,
    transfer: bool,
}

impl Clear {
    /// Build the programs.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Clear {
            f32: ComputeProgram::new(gpu, &CLEAR_F32)?,
            u32: ComputeProgram::new(gpu, &CLEAR_U32)?,
            transfer: by_transfer(gpu),
        })
    }

    /// Record the clear of all of `img` to the 32 bits `bits` (barriers derived: the old contents are dropped).
    /// Images of another format are cleared by transfer ([`FrameCtx::clear`], the bits in every channel), and so
    /// is every image that allows it on a CPU driver ([`by_transfer`]).
    pub fn record(&self, ctx: &mut FrameCtx, img: &Image, bits: u32) {
        let transfer = self.transfer && img.usage.contains(vk::ImageUsageFlags::TRANSFER_DST);
        let prog = match img.format {
            _ if transfer => None,
            vk::Format::R32_SFLOAT => Some(&self.f32),
            vk::Format::R32_UINT => Some(&self.u32),
            _ => None,
        };
        let Some(prog) = prog else {
            ctx.clear(img, vk::ClearColorValue { uint32: [bits; 4] });
            return;
        };
        let g = groups_2d(img.extent.width.div_ceil(CLEAR_SPAN), img.extent.height, LOCAL_2D);
        prog.dispatch(ctx, &[img.into()], &ClearPush { bits }, g);
    }
}

/// Whether `gpu` clears storage images faster by transfer than by a dispatch: CPU drivers (lavapipe), whose
/// transfer clear fills memory where a dispatch stores texel by texel.
pub fn by_transfer(gpu: &Gpu) -> bool {
    gpu.info.device_type.contains("CPU")
}
