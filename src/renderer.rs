//! The renderer: owns the passes, the frame's images, the particle buffer and the frame executor (N frames
//! in flight, default 2); renders a frame synchronously (`render`) or submits it and returns
//! (`submit`), reads results back (final colour as PNG-ready RGBA, any float image for dumps and tests).
//! Per-frame host-written memory (uniforms, the particle staging buffer, the readback buffer) is per slot;
//! particle uploads are recorded into the next frame's own command buffer.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::background::Background;
use crate::effect::{Effect, EffectPrepare, Effects, FrameParticles};
use crate::error::{Error, Result};
use crate::frame::{record_frame, FrameInputs, FrameUniforms, Passes, Recording, View};
use crate::gpu::executor::{Executor, Submitted};
use crate::gpu::{Access, Buffer, FrameCtx, Gpu, Image, PassTimes, Use};
use crate::particles::{Motion, ParticleSet};
use crate::passes::smooth::Output as Smoothed;
use crate::passes::FrameInfo;
use crate::settings::Settings;
use crate::surface::{Prepare, Surfaces};
use crate::targets::{Targets, TargetsDesc};

// The transfers between host and device live in `gpu::transfer`; the renderer's callers find them here too.
use crate::gpu::transfer::record_image_copy;
pub use crate::gpu::transfer::{
    read_buffer, read_buffer_at, read_f32, read_image, read_u32, record_upload, upload_buffer, upload_image,
};

/// Every frame pass name, in frame order (timestamp keys, JSON keys, `--timings` rows).
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

/// Renders frames on one device.
pub struct Renderer {
    /// The device.
    pub gpu: Arc<Gpu>,
    /// Every pass of the frame.
    pub passes: Passes,
    /// The frame's images (after the first render).
    pub targets: Option<Targets>,
    /// The frame uniform block.
    pub uniforms: Buffer,
    /// The particles on the device (and their host copy).
    particles: ParticleSet,
    executor: Executor,
    /// Per slot: the frame uniform block, the particle staging buffer, the final-colour readback buffer.
    slots: Vec<SlotMemory>,
    smoothed: Smoothed,
    /// Keep the raw splatted depth through smoothing (costs one more screen-sized image); set before rendering
    /// when the raw depth will be read back.
    pub keep_raw_depth: bool,
    /// The scene behind the fluid: sky, geometry, and whether its images still hold.
    pub background: Background,
    /// The demo's passes: debug views, the particle view and the text overlay.
    demo_passes: DemoPasses,
    /// GPU times of the frame a slot ran before the latest submission (read when the slot was reused).
    late_times: Option<PassTimes>,
    /// Where the host's time went in the latest submission ([`Renderer::host_times`]).
    host: HostTimes,
    /// Split each frame over two queues: the background and the thickness on the async compute queue, beside
    /// the fluid passes on the main queue (on a device with one queue both parts go to it, in order).
    pub async_compute: bool,
    /// The surface techniques, each with its resources (grids, lattice, mesh).
    pub surfaces: Surfaces,
    /// The effects (noise, diffuse, any added with [`Renderer::add_effect`]), each with its images.
    pub effects: Effects,
}

/// Recording work given the frame context and the frame's final image.
pub type AfterHook<'h> = &'h dyn Fn(&mut FrameCtx, &Image);

/// Recording work that writes a frame's particle buffer (given) on the GPU.
pub type ProduceHook<'h> = &'h dyn Fn(&mut FrameCtx, &Buffer);

/// Work a caller records into a frame's command buffer: `before` the passes (after the particle upload) and
/// `after` them (given the final image).
#[derive(Default, Clone, Copy)]
pub struct Hooks<'h> {
    /// Recorded before the frame's passes.
    pub before: Option<&'h dyn Fn(&mut FrameCtx)>,
    /// Recorded after the frame's passes, with the final image.
    pub after: Option<AfterHook<'h>>,
    /// Writes this frame's particles into the given buffer on the GPU (a simulation), after
    /// [`Renderer::set_gpu_particles`]; recorded where the particle upload goes (the async queue's first part in
    /// a split frame, so the step for this frame overlaps the previous frame's passes).
    pub produce: Option<ProduceHook<'h>>,
}

/// Host-written memory of one frame slot.
#[derive(Default)]
struct SlotMemory {
    uniforms: Option<Buffer>,
    staging: Option<Buffer>,
    readback: Option<Buffer>,
}

/// Frames in flight of a new renderer.
pub const FRAMES_IN_FLIGHT: usize = 2;

/// The demo's passes (built with the renderer; recorded only by `render_view`).
struct DemoPasses {
    view: crate::passes::view::View,
    particles: crate::passes::particles::Particles,
    overlay: crate::passes::overlay::Overlay,
}

impl Renderer {
    /// Build the passes on `gpu`; upload particles before rendering.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Renderer> {
        Renderer::with_frames(gpu, FRAMES_IN_FLIGHT)
    }

    /// A renderer with `frames` frames in flight (1: every frame waits for the previous one).
    pub fn with_frames(gpu: &Arc<Gpu>, frames: usize) -> Result<Renderer> {
        let executor = Executor::new(gpu, frames)?;
        let slots = (0..executor.frames()).map(|_| SlotMemory::default()).collect();
        let uniforms = Buffer::new(
            gpu,
            "frame",
            std::mem::size_of::<FrameUniforms>() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
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
            demo_passes: DemoPasses {
                view: crate::passes::view::View::new(gpu)?,
                particles: crate::passes::particles::Particles::new(gpu)?,
                overlay: crate::passes::overlay::Overlay::new(gpu)?,
            },
        })
    }

    /// Upload particles: 16 bytes each (world xyz + w), GPU-local. w = the particle's radius from `radii`, else 0
    /// (the frame's radius); negated for particles marked in `spray` (kept out of the surface). The copy is
    /// recorded into the next frame's command buffers.
    pub fn set_particles_with(
        &mut self,
        positions: &[[f32; 3]],
        radii: Option<&[f32]>,
        spray: Option<&[bool]>,
    ) -> Result<()> {
        self.particles.set(self.gpu.info.max_storage_buffer_range, positions, radii, spray, None)
    }

    /// [`Renderer::set_particles_with`] with each particle's [`Motion`] (its id and how fast its velocity
    /// changes: the `noise` pass's amplitude), e.g. from a [`crate::motion::MotionTracker`] over a sequence.
    pub fn set_particles_moving(
        &mut self,
        positions: &[[f32; 3]],
        radii: Option<&[f32]>,
        spray: Option<&[bool]>,
        motion: &[Motion],
    ) -> Result<()> {
        self.particles.set(self.gpu.info.max_storage_buffer_range, positions, radii, spray, Some(motion))
    }

    /// Upload a frame of particles the way every application does: spray flags from `s` (`spray_density`,
    /// `spray_by_neighbours`), the per-particle radii the file carries (`pscale`/`radius`, when mapped), and
    /// the particles' ids (a single frame's velocity does not change: the noise's calm amplitude).
    /// The one place `render`, `bench` and `demo` upload through, so they see the same particles.
    pub fn set_scene_particles(&mut self, p: &crate::scene::Particles, s: &Settings) -> Result<()> {
        self.set_scene_particles_moving(p, s, &crate::motion::still(p))
    }

    /// [`Renderer::set_scene_particles`] for a frame of a sequence whose motion is known (a
    /// [`crate::motion::MotionTracker`] walked the frames before it in time order).
    pub fn set_scene_particles_moving(
        &mut self,
        p: &crate::scene::Particles,
        s: &Settings,
        motion: &[Motion],
    ) -> Result<()> {
        let spray = crate::scene::spray_mask_with(p, s.radius, s.spray.density, s.spray.by_neighbours);
        self.set_particles_moving(&p.positions, p.radii.as_deref(), Some(&spray), motion)
    }

    /// The next frame's `count` particles are written on the GPU by the frame's `Hooks::produce` (xyz, w = 0:
    /// the frame radius), e.g. by `sim::Simulation::record_frame`; no host copy. `bounds` (lo, hi) contain them
    /// (the near plane and the iso surface's GPU grid are fitted to it). The mesh surface needs host positions:
    /// use [`Renderer::set_particles`] for it.
    pub fn set_gpu_particles(&mut self, count: u32, bounds: (glam::Vec3, glam::Vec3)) -> Result<()> {
        self.particles.set_gpu(self.gpu.info.max_storage_buffer_range, count, bounds)
    }

    /// [`Renderer::set_gpu_particles`] with `slots` diffuse particles the producer writes after the fluid (a
    /// simulation's spray, foam and bubbles: `sim::Simulation::set_diffuse`, `diffuse_slots`).
    pub fn set_gpu_particles_with_diffuse(
        &mut self,
        count: u32,
        bounds: (glam::Vec3, glam::Vec3),
        slots: u32,
    ) -> Result<()> {
        self.particles.set_gpu_with_diffuse(self.gpu.info.max_storage_buffer_range, count, bounds, slots)
    }

    /// Set the diffuse particles (spray, foam, bubbles: [`crate::diffuse`]) drawn by the `diffuse` pass from the
    /// next frame on, sized and faded by `s.diffuse`; they stay until set again (an empty slice removes them).
    pub fn set_diffuse(&mut self, particles: &[crate::diffuse::Particle], s: &Settings) -> Result<()> {
        let encoded = particles.iter().map(|p| crate::passes::diffuse::encode(p, &s.diffuse, s.radius)).collect();
        self.particles.set_diffuse(self.gpu.info.max_storage_buffer_range, encoded)
    }

    /// Diffuse particles set for the next frames.
    pub fn diffuse_count(&self) -> u32 {
        self.particles.diffuse_count()
    }

    /// Upload particles (no per-particle radius, no spray); see [`Renderer::set_particles_with`].
    pub fn set_particles(&mut self, positions: &[[f32; 3]], radii: Option<&[f32]>) -> Result<()> {
        self.set_particles_with(positions, radii, None)
    }

    /// Add a triangle mesh (world coordinates) to the background scene.
    pub fn set_background_mesh(&mut self, g: &crate::scene::geometry::Geometry) -> Result<()> {
        self.background.set_geometry(&self.gpu, &self.executor, g)
    }

    /// Load a sky cube map: six RGBA8 faces of `size`², order +X −X +Y −Y +Z −Z (see `crate::scene::sky`). Set
    /// `Environment::sky_cube` to use it.
    pub fn set_skybox(&mut self, size: u32, faces: &[u8]) -> Result<()> {
        self.background.set_skybox(&self.gpu, &self.executor, size, faces)
    }

    /// Particles on the device.
    pub fn particle_count(&self) -> u32 {
        self.particles.count()
    }

    /// Make sure the images fit `width`×`height` and the settings' scales.
    pub fn ensure_targets(&mut self, width: u32, height: u32, s: &Settings) -> Result<()> {
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

    /// Add an effect after the built-in ones (`crate::effect`): it records after them and its layers lie on top.
    pub fn add_effect(&mut self, e: Box<dyn Effect>) {
        self.effects.push(e);
    }

    /// Write the frame uniform block.
    pub fn write_uniforms(&mut self, view: &View, s: &Settings) -> Result<()> {
        let u = FrameUniforms::new(view, s, self.particles.count());
        self.uniforms.write(0, bytemuck::bytes_of(&u))
    }

    /// Render one frame and wait for it; returns the GPU time of each pass.
    pub fn render(&mut self, view: &View, s: &Settings) -> Result<PassTimes> {
        let sub = self.record_and_submit(view, s, None, false)?;
        self.finish(sub)
    }

    /// Render one frame and wait for it; returns its final image — copied into host memory by the frame itself
    /// (the slot's read-back buffer, kept from frame to frame: no second submission, no new buffer) — and the
    /// GPU time of each pass. What the Python package's `render` returns.
    pub fn render_image(&mut self, view: &View, s: &Settings, hooks: Hooks) -> Result<(image::RgbaImage, PassTimes)> {
        let sub = self.record_and_submit_with(view, s, None, true, hooks, Default::default())?;
        let slot = sub.slot;
        let img = self.read_submitted(sub)?;
        Ok((img, self.executor.times(slot)?))
    }

    /// [`Renderer::render`] with caller hooks (e.g. a simulation's particles copied in through `Hooks::produce`).
    pub fn render_with(&mut self, view: &View, s: &Settings, hooks: Hooks) -> Result<PassTimes> {
        let sub = self.record_and_submit_with(view, s, None, false, hooks, Default::default())?;
        self.finish(sub)
    }

    /// Render one frame, wait, and return every timed scope with its queue and device-clock begin and end (for
    /// per-queue times and the overlap of a split frame).
    pub fn render_spans(&mut self, view: &View, s: &Settings) -> Result<Vec<crate::gpu::executor::Span>> {
        let sub = self.record_and_submit(view, s, None, false)?;
        self.executor.wait_slot(sub.slot)?;
        self.executor.spans(sub.slot)
    }

    /// [`Renderer::render_spans`] with caller hooks (e.g. a simulation step through `Hooks::produce`).
    pub fn render_spans_with(
        &mut self,
        view: &View,
        s: &Settings,
        hooks: Hooks,
    ) -> Result<Vec<crate::gpu::executor::Span>> {
        let sub = self.record_and_submit_with(view, s, None, false, hooks, Default::default())?;
        self.executor.wait_slot(sub.slot)?;
        self.executor.spans(sub.slot)
    }

    /// Submit one frame and return without waiting for it (N frames may be in flight: starting the frame
    /// after waits only for the frame N back). With `readback`, the frame also copies its final image into
    /// host memory; take it with [`Renderer::read_submitted`] before N more frames are submitted.
    pub fn submit(&mut self, view: &View, s: &Settings, readback: bool) -> Result<Submitted> {
        self.record_and_submit(view, s, None, readback)
    }

    /// Wait for a submitted frame and return its GPU times.
    pub fn finish(&mut self, sub: Submitted) -> Result<PassTimes> {
        self.executor.wait_slot(sub.slot)?;
        self.executor.times(sub.slot)
    }

    /// The final image of a frame submitted with `readback` (waits for it).
    pub fn read_submitted(&mut self, sub: Submitted) -> Result<image::RgbaImage> {
        self.executor.wait_slot(sub.slot)?;
        let t = self.targets.as_ref().ok_or_else(|| Error::Invalid("nothing rendered yet".into()))?;
        let buf =
            self.slots[sub.slot].readback.as_ref().ok_or_else(|| Error::Invalid("frame had no readback".into()))?;
        let n = t.final_color.bytes() as usize;
        image::RgbaImage::from_raw(t.width, t.height, buf.read()?[..n].to_vec())
            .ok_or_else(|| Error::Invalid("readback size mismatch".into()))
    }

    /// Wait for every frame in flight.
    pub fn wait_idle(&self) -> Result<()> {
        self.executor.wait_idle()
    }

    /// Frames in flight.
    pub fn frames_in_flight(&self) -> usize {
        self.executor.frames()
    }

    /// Submit one frame for a window without waiting: the full pipeline, the chosen view, the text `overlay`,
    /// with `hooks` recorded before the frame's passes (after the particle upload: e.g. the overlay's upload)
    /// and after them (e.g. the blit into a swapchain image), and the binary semaphores of `binary` (acquire /
    /// render-finished). Returns the frame and the GPU times of the frame this slot ran before (a frame late).
    #[allow(clippy::too_many_arguments)]
    pub fn submit_view(
        &mut self,
        view: &View,
        s: &Settings,
        mode: crate::view::ViewMode,
        values: Option<&Buffer>,
        overlay: Option<&Image>,
        hooks: Hooks,
        binary: crate::gpu::executor::Binary,
    ) -> Result<(Submitted, Option<PassTimes>)> {
        self.keep_raw_depth = true;
        let sub = self.record_and_submit_with(view, s, Some((mode, values, overlay)), false, hooks, binary)?;
        Ok((sub, self.late_times.take()))
    }

    /// The slot the next frame will use (per-slot host memory of a caller, e.g. the demo's overlay staging).
    pub fn next_slot(&self) -> usize {
        self.executor.next_slot()
    }

    /// Wait until slot `k`'s last frame is done (before reusing what the caller keeps per slot).
    pub fn wait_slot(&self, k: usize) -> Result<()> {
        self.executor.wait_slot(k)
    }

    /// Render one frame for the demo: the full pipeline, then the chosen view, then the text `overlay`.
    /// `values`: per-particle attribute in [0, 1] for the particle view.
    pub fn render_view(
        &mut self,
        view: &View,
        s: &Settings,
        mode: crate::view::ViewMode,
        values: Option<&Buffer>,
        overlay: Option<&Image>,
    ) -> Result<PassTimes> {
        // The raw depth view and the particle view read the splatted depth after smoothing.
        self.keep_raw_depth = true;
        let sub = self.record_and_submit(view, s, Some((mode, values, overlay)), false)?;
        self.finish(sub)
    }

    /// The frame driver: checks, the slot's uniforms, the staged particle copy, record_frame, then (demo only)
    /// the view and overlay passes, then (with `readback`) the copy of the final image; submits.
    fn record_and_submit(
        &mut self,
        view: &View,
        s: &Settings,
        demo: Option<(crate::view::ViewMode, Option<&Buffer>, Option<&Image>)>,
        readback: bool,
    ) -> Result<Submitted> {
        self.record_and_submit_with(view, s, demo, readback, Hooks::default(), Default::default())
    }

    /// [`Renderer::record_and_submit`] with caller hooks and binary semaphores.
    fn record_and_submit_with(
        &mut self,
        view: &View,
        s: &Settings,
        demo: Option<(crate::view::ViewMode, Option<&Buffer>, Option<&Image>)>,
        readback: bool,
        hooks: Hooks,
        binary: crate::gpu::executor::Binary,
    ) -> Result<Submitted> {
        use crate::view::ViewMode;
        let t0 = std::time::Instant::now();
        let mut host = HostTimes::default();
        let mut lap = {
            let mut last = t0;
            move || {
                let now = std::time::Instant::now();
                let ms = (now - last).as_secs_f64() * 1e3;
                last = now;
                ms
            }
        };
        s.validate()?;
        if !self.passes.splat.supports(s.splat.mode) {
            return Err(Error::Invalid(format!(
                "splat mode {} is not supported on {}",
                s.splat.mode.name(),
                self.gpu.info.name
            )));
        }
        self.ensure_targets(view.width, view.height, s)?;
        let cached = self.background.cached(view, s);
        // The surface brings its resources up to date (grids, lattice, mesh) for these particles and settings.
        let prep = Prepare { gpu: &self.gpu, executor: &self.executor, particles: &self.particles, settings: s };
        self.surfaces.get_mut(s.surface).prepare(&prep)?;
        let (width, height) = (view.width, view.height);
        let (gpu, executor, particles) = (&self.gpu, &self.executor, &self.particles);
        self.effects.prepare(&EffectPrepare { gpu, executor, particles, settings: s, width, height })?;
        // Too many layers for the composite is the caller's error, found before a frame slot is begun.
        self.effects.layers(s)?;
        let split = self.async_compute;
        if self.particles.is_external() && hooks.produce.is_none() {
            return Err(Error::Invalid("set_gpu_particles needs a frame with Hooks::produce".into()));
        }
        self.particles.prepare(&self.gpu, &self.executor, split)?;
        let d_near = self.particles.nearest_depth(view, s.radius);
        host.prepare = lap();
        // The slot: its previous frame is complete from here on, so its host memory may be rewritten.
        let (k, late) = self.executor.begin()?;
        self.late_times = late;
        host.slot_wait = lap();
        let gpu = self.gpu.clone();
        let mem = &mut self.slots[k];
        let count = self.particles.count();
        let u = FrameUniforms::new(view, s, count);
        if mem.uniforms.is_none() {
            mem.uniforms = Some(Buffer::new(
                &gpu,
                "frame",
                std::mem::size_of::<FrameUniforms>() as u64,
                vk::BufferUsageFlags::UNIFORM_BUFFER,
                MemoryLocation::CpuToGpu,
            )?);
        }
        mem.uniforms.as_mut().expect("set").write(0, bytemuck::bytes_of(&u))?;
        let (staged, external) = self.particles.take_pending();
        if let Some((data, _)) = &staged {
            let bytes: &[u8] = bytemuck::cast_slice(data);
            if mem.staging.as_ref().is_none_or(|b| (b.size as usize) < bytes.len()) {
                mem.staging = Some(Buffer::new(
                    &gpu,
                    "particles staging",
                    (bytes.len() as u64).max(16),
                    vk::BufferUsageFlags::TRANSFER_SRC,
                    MemoryLocation::CpuToGpu,
                )?);
            }
            mem.staging.as_mut().expect("set").write(0, bytes)?;
        }
        let need = self.targets.as_ref().expect("ensured").final_color.bytes();
        if readback && mem.readback.as_ref().is_none_or(|b| b.size < need) {
            mem.readback = Some(Buffer::new(
                &gpu,
                "readback",
                need,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?);
        }
        host.stage = lap();
        let t = self.targets.as_ref().expect("ensured");
        let info = FrameInfo {
            focal_px: view.camera.focal_px(view.height),
            focal_px_fluid: view.camera.focal_px(t.depth.extent.height),
            d_near,
            target_distance: (view.camera.eye - view.camera.target).length().max(view.camera.near),
        };
        let particles = self.particles.buffer();
        let (passes, views) = (&self.passes, &self.demo_passes);
        let uniforms = mem.uniforms.as_ref().expect("set");
        if split {
            self.executor.begin_split(k)?;
        }
        let slot = self.executor.slot(k);
        slot.split = split;
        // The particles of this frame: a copy at the start of its own (first) command buffer, made visible to
        // compute reads there, before any other queue's part waits for it.
        let upload = |ctx: &mut FrameCtx| {
            if let (Some((data, at)), Some(staging)) = (&staged, mem.staging.as_ref()) {
                ctx.barrier(&[Use::Buffer(particles, Access::TransferDst)]);
                let region =
                    vk::BufferCopy { src_offset: 0, dst_offset: (*at * 16) as u64, size: (data.len() * 16) as u64 };
                if region.size > 0 {
                    unsafe { gpu.device.cmd_copy_buffer(ctx.cmd, staging.raw, particles.raw, &[region]) };
                }
                ctx.barrier(&[Use::buf_read(particles)]);
            }
            if let (true, Some(p)) = (external, hooks.produce) {
                p(ctx, particles);
            }
        };
        // The demo's views and overlay, then the readback: after the shading, in its command buffer.
        let finish_frame = |ctx: &mut FrameCtx, sm: Smoothed| {
            if let Some((mode, values, overlay)) = demo {
                let images = crate::passes::view::ViewImages {
                    depth: &t.depth,
                    smoothed: t.smoothed(sm),
                    thickness: &t.thickness,
                    normals: &t.normals,
                    ssr: &t.ssr,
                    scene_color: &t.scene_color,
                    final_color: &t.final_color,
                };
                let range = (d_near, d_near + (view.camera.eye - view.camera.target).length() * 1.5);
                let t_max = 60.0 * s.radius;
                match mode {
                    ViewMode::Final => {}
                    ViewMode::Particles => {
                        views.view.record(ctx, uniforms, &images, 6, range, t_max);
                        if let Some(v) = values {
                            let out = (&t.depth, &t.final_color);
                            views.particles.record(ctx, uniforms, particles, v, count, out, s.splat.radius_scale);
                        }
                    }
                    m => {
                        let k = ViewMode::ALL.iter().position(|x| *x == m).unwrap_or(0) as i32;
                        views.view.record(ctx, uniforms, &images, k, range, t_max);
                    }
                }
                if let Some(o) = overlay {
                    views.overlay.record(ctx, uniforms, o, &t.final_color);
                }
            }
            if readback {
                record_image_copy(ctx, &t.final_color, mem.readback.as_ref().expect("set"));
            }
            if let Some(h) = hooks.after {
                h(ctx, &t.final_color);
            }
        };
        let inputs = FrameInputs {
            passes,
            targets: t,
            frame: uniforms,
            particles: FrameParticles {
                buffer: particles,
                count,
                diffuse: self.particles.diffuse_count(),
                diffuse_indirect: self.particles.diffuse_on_gpu(),
                spray: self.particles.has_spray(),
            },
            surface: self.surfaces.get(s.surface),
            effects: &self.effects,
            background: &self.background,
            background_cached: cached,
            settings: s,
            info: &info,
        };
        if !split {
            let mut ctx = FrameCtx::new(&gpu, slot.cmd, Some(&mut slot.timer));
            upload(&mut ctx);
            if let Some(h) = hooks.before {
                h(&mut ctx);
            }
            let sm = record_frame(&mut Recording::One(&mut ctx), &inputs)?.smoothed;
            finish_frame(&mut ctx, sm);
            let touches = std::mem::take(&mut ctx.touches);
            drop(ctx);
            self.smoothed = sm;
            host.record = lap();
            let sub = self.executor.submit_one(k, &binary, touches);
            host.submit = lap();
            self.host = host;
            return sub;
        }
        // A split frame: the particle upload (async) ‖ the previous frame's passes; background + thickness
        // (async) ‖ the fluid passes (main); shading (main) after both. The waits between the queues — within
        // this frame and against the frame before — come from what each segment touched.
        use crate::gpu::executor::Segment;
        use crate::gpu::schedule::QueueId;
        let (main_cmds, compute_cmds) = (slot.main_cmds, slot.compute_cmds);
        let [ta, tf, tsh] = &mut slot.segment_timers;
        // The first main command buffer only resets the main timer (it began with the slot).
        let mut first = FrameCtx::new(&gpu, main_cmds[0], Some(&mut slot.timer));
        // The async part's timer starts in the upload's command buffer (it runs first on that queue), so a
        // simulation step recorded there (`Hooks::produce`) is timed with the async passes.
        let mut up = FrameCtx::new(&gpu, compute_cmds[0], Some(ta));
        upload(&mut up);
        if let Some(h) = hooks.before {
            h(&mut up);
        }
        let up_touches = std::mem::take(&mut up.touches);
        let ta = up.timer.take().expect("given");
        drop(up);
        let mut a = FrameCtx::continuing(&gpu, compute_cmds[1], Some(ta));
        let mut f = FrameCtx::new(&gpu, main_cmds[1], Some(tf));
        let mut sh = FrameCtx::new(&gpu, main_cmds[2], Some(tsh));
        let sm = record_frame(&mut Recording::Split { async_part: &mut a, fluid: &mut f, shade: &mut sh }, &inputs)?
            .smoothed;
        finish_frame(&mut sh, sm);
        let segments = vec![
            Segment { queue: QueueId::Main, cmd: main_cmds[0], touches: std::mem::take(&mut first.touches) },
            Segment { queue: QueueId::Compute, cmd: compute_cmds[0], touches: up_touches },
            Segment { queue: QueueId::Compute, cmd: compute_cmds[1], touches: std::mem::take(&mut a.touches) },
            Segment { queue: QueueId::Main, cmd: main_cmds[1], touches: std::mem::take(&mut f.touches) },
            Segment { queue: QueueId::Main, cmd: main_cmds[2], touches: std::mem::take(&mut sh.touches) },
        ];
        drop((first, a, f, sh));
        self.smoothed = sm;
        host.record = lap();
        let sub = self.executor.submit_segments(k, segments, &binary);
        host.submit = lap();
        self.host = host;
        sub
    }

    /// Where the host's time went in the latest submission, ms: the frame's preparation (targets, the surface's
    /// resources, the particle set, the nearest depth), the wait for its slot (the frame that used it before),
    /// the staging (uniforms, the particle upload into host-visible memory), the recording and the submission.
    pub fn host_times(&self) -> HostTimes {
        self.host
    }

    /// The iso surface's grid and kernels on the device (after a frame with `surface = "iso"`), for tests.
    pub fn iso_buffers(&self) -> Option<&crate::passes::iso::IsoBuffers> {
        self.surfaces.get(crate::settings::Surface::Iso).grid()
    }

    /// Seconds (CPU) the last extraction of the fluid mesh took with its BVH, and its vertex and triangle counts
    /// (`surface = "mesh"`).
    pub fn fluid_mesh_stats(&self) -> Option<(f64, usize, usize)> {
        self.surfaces.get(crate::settings::Surface::Mesh).mesh_stats()
    }

    /// Linear depth of the nearest particle surface in front of the camera (at least the near plane).
    pub fn nearest_depth(&self, view: &View, s: &Settings) -> f32 {
        self.particles.nearest_depth(view, s.radius)
    }

    /// (name, bytes) of every image and buffer the frame holds now: its targets', then its effects'.
    pub fn memory(&self) -> Vec<(&str, u64)> {
        let targets = self.targets.iter().flat_map(|t| t.memory());
        targets.chain(self.effects.memory()).collect()
    }

    /// The image that holds the smoothed depth of the last frame.
    pub fn smoothed_depth(&self) -> Option<&Image> {
        Some(self.targets.as_ref()?.smoothed(self.smoothed))
    }

    /// Read the final colour of the last frame.
    pub fn read_final(&self) -> Result<image::RgbaImage> {
        let t = self.targets.as_ref().ok_or_else(|| Error::Invalid("nothing rendered yet".into()))?;
        let bytes = read_image(&self.gpu, &t.final_color)?;
        image::RgbaImage::from_raw(t.width, t.height, bytes)
            .ok_or_else(|| Error::Invalid("readback size mismatch".into()))
    }
}

/// The host's stages of one submitted frame, ms ([`Renderer::host_times`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct HostTimes {
    /// Targets ensured, the surface's resources prepared (grids, lattice), the particle set, the nearest depth.
    pub prepare: f64,
    /// Waiting for the frame slot (its previous frame to finish on the GPU).
    pub slot_wait: f64,
    /// The frame uniforms and the particle staging copy written to host-visible memory.
    pub stage: f64,
    /// Recording the command buffers.
    pub record: f64,
    /// Submitting them.
    pub submit: f64,
}

impl HostTimes {
    /// The stages together: the host's part of a frame up to its submission (what `bench` and Python's
    /// `host_timings` take from a frame's wall time to leave the wait for the GPU).
    pub fn total(&self) -> f64 {
        self.prepare + self.slot_wait + self.stage + self.record + self.submit
    }
}

impl Drop for Renderer {
    fn drop(&mut self) {
        // Frames in flight still use the images and buffers dropped next.
        let _ = self.executor.wait_idle();
    }
}
