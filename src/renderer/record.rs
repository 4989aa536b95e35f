//! The frame driver: what one submitted frame does on the host — the checks, the preparation of the surface,
//! the effects and the particles, the slot's host-written memory (uniforms, particle staging, read-back), the
//! recording (`record_frame` with the caller's hooks) and the submission on one queue or, split, on two.

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::request::{FrameImages, FrameRequest, HostTimes};
use super::Renderer;
use crate::effect::{EffectPrepare, FrameParticles};
use crate::error::{Error, Result};
use crate::frame::{record_frame, FrameInputs, FrameUniforms};
use crate::gpu::executor::Submitted;
use crate::gpu::recording::Recording;
use crate::gpu::transfer::record_image_copy;
use crate::gpu::{Access, Buffer, FrameCtx, Use};
use crate::passes::filter::Output as Smoothed;
use crate::passes::view::ViewImages;
use crate::passes::FrameInfo;
use crate::surface::Prepare;

impl Renderer {
    /// The frame driver: checks, the effects' and surface's preparation, the slot's uniforms, the staged particle
    /// copy, `record_frame`, the caller's after hook, the final image's read-back; submits (one queue, or the
    /// split frame's segments).
    pub(super) fn record_and_submit(&mut self, req: FrameRequest) -> Result<Submitted> {
        let FrameRequest { view, settings: s, hooks, readback, binary, count_work, time_parts } = req;
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
        let cached = self.prepare(view, s, hooks.produce.is_some())?;
        // The composite's layers, once a frame; too many is the caller's error, found before a slot is begun.
        let layers = self.effects.layers(s)?;
        let split = self.async_compute;
        let d_near = self.particles.nearest_depth(view, s.radius);
        host.prepare = lap();
        // The slot: its previous frame is complete from here on, so its host memory may be rewritten.
        let (k, late) = self.executor.begin()?;
        if late.is_some() {
            self.late_times = late;
        }
        host.slot_wait = lap();
        let gpu = self.gpu.clone();
        let count = self.particles.count();
        let (staged, external) = self.particles.take_pending();
        let need = readback.then(|| self.targets.as_ref().expect("ensured").final_color.bytes());
        let u = FrameUniforms::new(view, s, count);
        fill_slot(&gpu, &mut self.slots[k], &self.particles, &u, staged.as_ref(), need)?;
        let mem = &self.slots[k];
        host.stage = lap();
        let t = self.targets.as_ref().expect("ensured");
        let info = FrameInfo {
            focal_px: view.camera.focal_px(view.height),
            focal_px_fluid: view.camera.focal_px(t.depth.extent.height),
            d_near,
            target_distance: (view.camera.eye - view.camera.target).length().max(view.camera.near),
        };
        let particles = self.particles.buffer();
        let passes = &self.passes;
        let uniforms = mem.uniforms.as_ref().expect("set");
        if split {
            self.executor.begin_split(k)?;
        }
        let slot = self.executor.slot(k);
        slot.split = split;
        // The particles of this frame: a copy at the start of its own (first) command buffer, made visible to
        // compute reads there, before any other queue's part waits for it.
        let upload = |ctx: &mut FrameCtx| {
            if let (Some(st), Some(staging)) = (&staged, mem.staging.as_ref()) {
                ctx.barrier(&[Use::Buffer(particles, Access::TransferDst)]);
                let region =
                    vk::BufferCopy { src_offset: 0, dst_offset: (st.at * 16) as u64, size: (st.len * 16) as u64 };
                if region.size > 0 {
                    unsafe { gpu.device.cmd_copy_buffer(ctx.cmd, staging.raw, particles.raw, &[region]) };
                }
                ctx.barrier(&[Use::buf_read(particles)]);
            }
            if let (true, Some(p)) = (external, hooks.produce) {
                p(ctx, particles);
            }
        };
        // The caller's work after the passes (the demo's views, a window's blit), then the read-back, in the
        // frame's last command buffer.
        let finish_frame = |ctx: &mut FrameCtx, sm: Smoothed| {
            if let Some(h) = hooks.after {
                let images = FrameImages {
                    frame: uniforms,
                    particles: (particles, count),
                    images: ViewImages {
                        depth: &t.depth,
                        smoothed: t.smoothed(sm),
                        thickness: &t.thickness,
                        normals: &t.normals,
                        ssr: &t.ssr,
                        scene_color: &t.scene_color,
                        final_color: &t.final_color,
                    },
                    info,
                };
                h(ctx, &images);
            }
            if readback {
                record_image_copy(ctx, &t.final_color, mem.readback.as_ref().expect("set"));
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
                isolated: self.particles.has_isolated(),
            },
            surface: self.surfaces.get(s.surface),
            effects: &self.effects,
            layers: &layers,
            background: &self.background,
            background_cached: cached,
            settings: s,
            info: &info,
        };
        let upload = |ctx: &mut FrameCtx| {
            upload(ctx);
            if let Some(h) = hooks.before {
                h(ctx);
            }
        };
        let passes = |rec: &mut Recording| Ok(record_frame(rec, &inputs)?.smoothed);
        let (sm, recorded) =
            slot.record(&gpu, crate::gpu::Measure { count_work, time_parts }, upload, passes, |ctx, sm| {
                finish_frame(ctx, *sm)
            })?;
        self.smoothed = sm;
        host.record = lap();
        let sub = self.executor.submit_recorded(k, recorded, &binary);
        host.submit = lap();
        self.host = host;
        sub
    }

    /// Before a frame slot is begun: the request's checks, then the surface, the effects and the particles brought
    /// up to date (host work and allocations). Returns whether the background's images still hold.
    fn prepare(&mut self, view: &crate::view::View, s: &crate::settings::Settings, produces: bool) -> Result<bool> {
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
        let fluid = self.targets.as_ref().expect("ensured").desc.fluid;
        let prep = Prepare { gpu: &self.gpu, executor: &self.executor, particles: &self.particles, settings: s, fluid };
        self.surfaces.get_mut(s.surface).prepare(&prep)?;
        let (width, height) = (view.width, view.height);
        let (gpu, executor, particles) = (&self.gpu, &self.executor, &self.particles);
        self.effects.prepare(&EffectPrepare { gpu, executor, particles, settings: s, width, height })?;
        if self.particles.is_external() && !produces {
            return Err(Error::Invalid("particles uploaded as Upload::Gpu need a frame with Hooks::produce".into()));
        }
        self.particles.prepare(&self.gpu, &self.executor, self.async_compute)?;
        Ok(cached)
    }
}

/// A slot's host-written memory for this frame: the uniform block, the staged particles (their parts copied into
/// its staging buffer, grown to fit) and, when the final image is read back, a buffer of `readback` bytes.
fn fill_slot(
    gpu: &std::sync::Arc<crate::gpu::Gpu>,
    mem: &mut super::SlotMemory,
    particles: &crate::particles::ParticleSet,
    u: &FrameUniforms,
    staged: Option<&crate::particles::Staged>,
    readback: Option<u64>,
) -> Result<()> {
    if mem.uniforms.is_none() {
        mem.uniforms = Some(Buffer::new(
            gpu,
            "frame",
            std::mem::size_of::<FrameUniforms>() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            MemoryLocation::CpuToGpu,
        )?);
    }
    mem.uniforms.as_mut().expect("set").write(0, bytemuck::bytes_of(u))?;
    if let Some(st) = staged {
        let bytes = st.len * 16;
        if mem.staging.as_ref().is_none_or(|b| (b.size as usize) < bytes) {
            mem.staging = Some(Buffer::new(
                gpu,
                "particles staging",
                (bytes as u64).max(16),
                vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::CpuToGpu,
            )?);
        }
        let staging = mem.staging.as_mut().expect("set");
        let mut at = 0;
        for part in particles.staged_parts(st) {
            staging.write(at, bytemuck::cast_slice(part))?;
            at += part.len() * 16;
        }
    }
    if let Some(need) = readback.filter(|&n| mem.readback.as_ref().is_none_or(|b| b.size < n)) {
        mem.readback =
            Some(Buffer::new(gpu, "readback", need, vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu)?);
    }
    Ok(())
}
