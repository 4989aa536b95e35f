//! The renderer, the conductor: owns the passes, the frame's images, the particles, the surface techniques, the
//! effects, the background and the frame executor (N frames in flight, default 2). Its door is small: one
//! particle [`Upload`], one [`FrameRequest`] (`submit`, or `render` to wait for it), the frame's results
//! (`finish`, `spans`, `read_submitted`) and views of what it holds ([`Renderer::state`], [`Renderer::slots`]).
//! Per-frame host-written memory (uniforms, the particle staging buffer, the read-back buffer) is per slot;
//! particle uploads are recorded into the next frame's own command buffer. The frame driver is `record.rs`;
//! what callers pass and get is `request.rs`.

mod record;
mod request;

pub use request::{
    AfterHook, Backdrop, FrameImages, FrameRequest, FrameSlots, Hooks, HostTimes, ProduceHook, RendererState, Upload,
};

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::background::Background;
use crate::effect::{Effect, Effects};
use crate::error::{Error, Result};
use crate::frame::FrameUniforms;
use crate::gpu::executor::{Executor, Span, Submitted};
use crate::gpu::{Buffer, Gpu};
use crate::particles::ParticleSet;
use crate::passes::filter::Output as Smoothed;
use crate::passes::Passes;
use crate::settings::Settings;
use crate::surface::Surfaces;
use crate::targets::{Targets, TargetsDesc};
use crate::timing::PassTimes;
use crate::view::View;

/// Every pass name in frame order (timestamp keys, JSON keys, `--timings` rows).
pub fn pass_names() -> &'static [&'static str] {
    crate::frame::pass_names()
}

/// A pixel of the read-back `normals` buffer (octahedral, 2 × snorm16) as a unit view-space normal.
pub fn unpack_normal(packed: u32) -> [f32; 3] {
    crate::passes::normals::unpack(packed)
}

/// A pixel of the read-back `ssr` buffer: the reflection hit's uv, or None.
pub fn decode_ssr(hit: u32) -> Option<[f32; 2]> {
    crate::passes::ssr::decode(hit)
}

/// Renders frames on one device. Its parts are reached through methods ([`Renderer::targets`],
/// [`Renderer::background_mut`], …): no field is public.
pub struct Renderer {
    /// The device.
    pub(crate) gpu: Arc<Gpu>,
    /// Every pass of the frame.
    pub(crate) passes: Passes,
    /// The frame's images (after the first render).
    pub(crate) targets: Option<Targets>,
    /// The frame uniform block (written by tests that record passes by hand; frames use their slot's own).
    pub(crate) uniforms: Buffer,
    /// The particles on the device (and their host copy).
    particles: ParticleSet,
    executor: Executor,
    /// Per slot: the frame uniform block, the particle staging buffer, the final-colour readback buffer.
    slots: Vec<SlotMemory>,
    smoothed: Smoothed,
    /// Keep the raw splatted depth through smoothing (costs one more screen-sized image); set before rendering
    /// when the raw depth will be read back or viewed.
    pub(crate) keep_raw_depth: bool,
    /// The scene behind the fluid: sky, geometry, and whether its images still hold.
    pub(crate) background: Background,
    /// GPU times of the frame a slot ran before the latest submission (read when the slot was reused).
    late_times: Option<PassTimes>,
    /// Where the host's time went in the latest submission ([`RendererState::host_times`]).
    host: HostTimes,
    /// Split each frame over two queues: the background and the thickness on the async compute queue, beside
    /// the fluid passes on the main queue (on a device with one queue both parts go to it, in order).
    pub(crate) async_compute: bool,
    /// The surface techniques, each with its resources (grids, lattice, mesh).
    pub(crate) surfaces: Surfaces,
    /// The effects (noise, diffuse, any added with [`Renderer::add_effect`]), each with its images.
    pub(crate) effects: Effects,
}

/// The parts of a [`Renderer`] an application changes ([`Renderer::parts_mut`]).
pub struct RendererParts<'a> {
    /// The scene behind the fluid (`always_render`: re-render it every frame, as a timed frame does).
    pub background: &'a mut Background,
    /// The effects (noise, diffuse and any added with [`Renderer::add_effect`]): `effects.get_mut::<T>()`.
    pub effects: &'a mut Effects,
    /// Keep the raw splatted depth through smoothing (one more screen-sized image): set before rendering when
    /// the raw depth will be read back or viewed.
    pub keep_raw_depth: &'a mut bool,
    /// Split each frame over the main and the async compute queue (the background and the thickness beside
    /// the fluid passes; on a device with one queue both parts go to it, in order).
    pub async_compute: &'a mut bool,
    /// The frame uniform block (tests that record passes by hand write it).
    #[doc(hidden)]
    pub uniforms: &'a mut Buffer,
    /// The frame's images (tests that record passes by hand make their own).
    #[doc(hidden)]
    pub targets: &'a mut Option<Targets>,
}

/// Host-written memory of one frame slot.
#[derive(Default)]
pub(super) struct SlotMemory {
    uniforms: Option<Buffer>,
    staging: Option<Buffer>,
    readback: Option<Buffer>,
}

/// Frames in flight of a new renderer.
pub const FRAMES_IN_FLIGHT: usize = 2;

impl Renderer {
    /// Build the passes on `gpu` with [`FRAMES_IN_FLIGHT`] frames in flight; upload particles before rendering.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Renderer> {
        Renderer::with_frames(gpu, FRAMES_IN_FLIGHT)
    }

    /// A renderer with `frames` frames in flight (1: every frame waits for the previous one).
    pub fn with_frames(gpu: &Arc<Gpu>, frames: usize) -> Result<Renderer> {
        let executor = Executor::new(gpu, frames)?;
        let slots = (0..executor.frames()).map(|_| SlotMemory::default()).collect();
        let size = std::mem::size_of::<FrameUniforms>() as u64;
        let uniforms = Buffer::new(gpu, "frame", size, vk::BufferUsageFlags::UNIFORM_BUFFER, MemoryLocation::CpuToGpu)?;
        Ok(Renderer {
            gpu: gpu.clone(),
            passes: Passes::new(gpu)?,
            targets: None,
            uniforms,
            particles: ParticleSet::default(),
            executor,
            slots,
            smoothed: Smoothed::Input,
            surfaces: Surfaces::new(),
            effects: Effects::new(gpu)?,
            background: Background::new(gpu)?,
            async_compute: false,
            late_times: None,
            host: HostTimes::default(),
            keep_raw_depth: false,
        })
    }

    /// Set the particles of the next frames ([`Upload`]: positions, a file's frame, a GPU producer's, or the
    /// diffuse particles). The copy is recorded into the next frame's command buffers.
    pub fn upload(&mut self, u: Upload) -> Result<()> {
        u.apply(&mut self.particles, self.gpu.info.max_storage_buffer_range)
    }

    /// Set what lies behind the fluid besides the settings' ground and boxes ([`Backdrop`]).
    pub fn set_background(&mut self, b: Backdrop) -> Result<()> {
        match b {
            Backdrop::Mesh(g) => self.background.set_geometry(&self.gpu, &self.executor, g),
            Backdrop::Sky { size, faces } => self.background.set_skybox(&self.gpu, &self.executor, size, faces),
        }
    }

    /// Add an effect after the built-in ones (`crate::effect`): it records after them and its layers lie on top.
    pub fn add_effect(&mut self, e: Box<dyn Effect>) {
        self.effects.push(e);
    }

    /// Render one frame of `view` with settings `s` and wait for it; returns the GPU time of each pass.
    /// A surface whose device-sized buffers the frame outgrew (the live mesh's) renders it once more, grown.
    pub fn render(&mut self, view: &View, s: &Settings) -> Result<PassTimes> {
        let sub = self.submit(FrameRequest::new(view, s))?;
        let times = self.finish(sub)?;
        if !self.surfaces.get(s.surface).outgrown() {
            return Ok(times);
        }
        let sub = self.submit(FrameRequest::new(view, s))?;
        self.finish(sub)
    }

    /// Submit one frame and return without waiting for it (N frames may be in flight: starting the frame after
    /// waits only for the frame N back). With `readback`, the frame also copies its final image into host
    /// memory; take it with [`Renderer::read_submitted`] before N more frames are submitted.
    pub fn submit(&mut self, req: FrameRequest) -> Result<Submitted> {
        self.record_and_submit(req)
    }

    /// Wait for a submitted frame and return its GPU times.
    pub fn finish(&mut self, sub: Submitted) -> Result<PassTimes> {
        self.executor.wait_slot(sub.slot)?;
        self.executor.times(sub.slot)
    }

    /// Wait for a submitted frame and return every timed scope with its queue and device-clock begin and end
    /// (per-queue times and the overlap of a split frame).
    pub fn spans(&mut self, sub: Submitted) -> Result<Vec<Span>> {
        self.executor.wait_slot(sub.slot)?;
        self.executor.spans(sub.slot)
    }

    /// The final image of a frame submitted with `readback` (waits for it): the frame copied it into its slot's
    /// read-back buffer, kept from frame to frame (no second submission, no new buffer).
    pub fn read_submitted(&mut self, sub: Submitted) -> Result<image::RgbaImage> {
        self.executor.wait_slot(sub.slot)?;
        let t = self.targets.as_ref().ok_or_else(|| Error::Invalid("nothing rendered yet".into()))?;
        let buf =
            self.slots[sub.slot].readback.as_ref().ok_or_else(|| Error::Invalid("frame had no readback".into()))?;
        let n = t.final_color.bytes() as usize;
        image::RgbaImage::from_raw(t.width, t.height, buf.read()?[..n].to_vec())
            .ok_or_else(|| Error::Invalid("readback size mismatch".into()))
    }

    /// The frame slots: how many, the next, waiting for one or all.
    pub fn slots(&self) -> FrameSlots<'_> {
        FrameSlots(&self.executor)
    }

    /// What the renderer holds after its latest frame: images, particles, surfaces, memory, host times.
    pub fn state(&self) -> RendererState<'_> {
        RendererState {
            gpu: &self.gpu,
            passes: &self.passes,
            uniforms: &self.uniforms,
            background: &self.background,
            keep_raw_depth: self.keep_raw_depth,
            async_compute: self.async_compute,
            targets: self.targets.as_ref(),
            smoothed: self.smoothed,
            particles: &self.particles,
            surfaces: &self.surfaces,
            effects: &self.effects,
            host: self.host,
            late: self.late_times.as_ref(),
        }
    }

    /// The renderer's parts, to change: the scene behind the fluid, the effects, whether the raw depth is kept and
    /// frames are split over two queues (and, for tests that record single passes, its passes' uniform block and
    /// images). What [`Renderer::state`] reads.
    pub fn parts_mut(&mut self) -> RendererParts<'_> {
        RendererParts {
            background: &mut self.background,
            effects: &mut self.effects,
            keep_raw_depth: &mut self.keep_raw_depth,
            async_compute: &mut self.async_compute,
            uniforms: &mut self.uniforms,
            targets: &mut self.targets,
        }
    }

    /// Make sure the images fit `width`×`height` and the settings' scales.
    fn ensure_targets(&mut self, width: u32, height: u32, s: &Settings) -> Result<()> {
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            return Err(Error::Invalid(format!("image size {width}×{height} is out of range (1 … 16384)")));
        }
        let want = TargetsDesc::new(width, height, s, self.keep_raw_depth);
        if self.targets.as_ref().map(|t| t.desc) != Some(want) {
            self.executor.wait_idle()?;
            self.targets = None;
            self.background.invalidate();
            self.targets = Some(Targets::new(&self.gpu, want)?);
        }
        Ok(())
    }
}

impl Drop for Renderer {
    fn drop(&mut self) {
        // Frames in flight still use the images and buffers dropped next.
        let _ = self.executor.wait_idle();
    }
}
