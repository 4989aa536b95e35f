//! What a caller gives the renderer and gets back: one particle [`Upload`], one [`FrameRequest`] (with its
//! [`Hooks`]: work recorded before and after the frame's passes, the simulation that writes its particles), the
//! [`FrameImages`] an after hook sees, the [`Backdrop`] behind the fluid, and the views of what the renderer
//! holds ([`FrameSlots`], [`RendererState`]).

use crate::error::{Error, Result};
use crate::gpu::executor::{Binary, Executor};
use crate::gpu::{Buffer, FrameCtx, Image};
use crate::motion::Motion;
use crate::particles::ParticleSet;
use crate::passes::FrameInfo;
use crate::settings::Settings;
use crate::surface::Surfaces;
use crate::targets::Targets;
use crate::timing::PassTimes;
use crate::view::View;

/// The particles of the next frames.
pub enum Upload<'a> {
    /// Positions (world), with per-particle radii (None: the frame's radius), isolated marks (kept out of the
    /// surface) and motions (ids and changes of velocity: the noise's amplitude; None: still).
    Points {
        /// World positions.
        positions: &'a [[f32; 3]],
        /// Per-particle radii.
        radii: Option<&'a [f32]>,
        /// Particles marked isolated (low density).
        isolated: Option<&'a [bool]>,
        /// Each particle's motion.
        motion: Option<&'a [Motion]>,
    },
    /// A frame of particles the way every application uploads it: isolated flags from the settings
    /// (`[isolated]`), the radii the file carries, and the motion (None: a single frame's velocity does not
    /// change — the particles' ids alone).
    Scene {
        /// The frame.
        particles: &'a crate::scene::Particles,
        /// The settings the isolated-particle classification reads.
        settings: &'a Settings,
        /// Each particle's motion over a sequence ([`crate::motion::MotionTracker`]).
        motion: Option<&'a [Motion]>,
        /// The host's analysis of these positions, computed ahead by their loader
        /// ([`crate::surface::grid::analyse`]; a sequence's prefetch): the frame's prepare then does not walk them.
        ahead: Option<&'a crate::particles::SetAnalysis>,
    },
    /// `count` particles written on the GPU by each frame's `Hooks::produce` (xyz, w = 0), inside `bounds`
    /// (the near plane and the iso surface's grid are fitted to it), followed by `diffuse_slots` diffuse
    /// particles the producer writes too (a simulation's spray, foam and bubbles). No host copy: the mesh
    /// surface extracts them on the GPU (`[mesh] extraction = "auto"` or `"gpu"`).
    Gpu {
        /// Fluid particles.
        count: u32,
        /// (lo, hi) containing them.
        bounds: (glam::Vec3, glam::Vec3),
        /// Diffuse particles after them (0: none).
        diffuse_slots: u32,
    },
    /// Diffuse particles (spray, foam, bubbles: [`crate::diffuse`]) drawn by the `diffuse` effect from the
    /// next frame on, sized and faded by `settings.diffuse`; they stay until set again (empty: none). The fluid
    /// particles stay.
    Diffuse {
        /// The particles.
        particles: &'a [crate::diffuse::Particle],
        /// The settings that size and fade them.
        settings: &'a Settings,
    },
}

impl<'a> Upload<'a> {
    /// Positions alone.
    pub fn points(positions: &'a [[f32; 3]]) -> Upload<'a> {
        Upload::Points { positions, radii: None, isolated: None, motion: None }
    }

    /// A frame of a file, still ([`Upload::Scene`]).
    pub fn scene(particles: &'a crate::scene::Particles, settings: &'a Settings) -> Upload<'a> {
        Upload::Scene { particles, settings, motion: None, ahead: None }
    }

    /// Bring the particle set up to date (`limit`: the device's storage buffer range).
    pub(super) fn apply(self, set: &mut ParticleSet, limit: u64) -> Result<()> {
        match self {
            Upload::Points { positions, radii, isolated, motion } => set.set(limit, positions, radii, isolated, motion),
            Upload::Scene { particles: p, settings: s, motion, ahead } => {
                let isolated =
                    crate::scene::isolated_mask_with(p, s.radius, s.isolated.density, s.isolated.by_neighbours);
                let still;
                let motion = match motion {
                    Some(m) => m,
                    None => {
                        still = crate::motion::still(p);
                        &still
                    }
                };
                set.set(limit, &p.positions, p.radii.as_deref(), Some(&isolated), Some(motion))?;
                set.set_analysis(ahead);
                Ok(())
            }
            Upload::Gpu { count, bounds, diffuse_slots } => {
                set.set_gpu_with_diffuse(limit, count, bounds, diffuse_slots)
            }
            Upload::Diffuse { particles, settings: s } => {
                let encoded =
                    particles.iter().map(|p| crate::passes::diffuse::encode(p, &s.diffuse, s.radius)).collect();
                set.set_diffuse(limit, encoded)
            }
        }
    }
}

/// The scene behind the fluid that a caller sets (the ground and boxes come from the settings and the view).
pub enum Backdrop<'a> {
    /// A triangle mesh (world coordinates) added to the background scene.
    Mesh(&'a crate::scene::geometry::Geometry),
    /// A sky cube map: six RGBA8 faces of `size`², order +X −X +Y −Y +Z −Z (`crate::scene::sky`); set
    /// `Environment::sky_cube` to use it.
    Sky {
        /// Face edge in pixels.
        size: u32,
        /// The six faces' pixels.
        faces: &'a [u8],
    },
}

/// The frame's resources as work recorded after its passes sees them (`Hooks::after`).
pub struct FrameImages<'a> {
    /// The frame uniform block.
    pub frame: &'a Buffer,
    /// The particle buffer and its fluid particle count.
    pub particles: (&'a Buffer, u32),
    /// Its images: the raw splatted depth (intact only with `Renderer::keep_raw_depth`), the smoothed depth,
    /// thickness, normals, SSR hits, the background's colour and the shaded output (RGBA8) — what the `view`
    /// pass maps to colour.
    pub images: crate::passes::view::ViewImages<'a>,
    /// Facts about the frame's camera.
    pub info: FrameInfo,
}

/// Recording work given the frame context and the frame's resources.
pub type AfterHook<'h> = &'h dyn Fn(&mut FrameCtx, &FrameImages);

/// Recording work that writes a frame's particle buffer (given) on the GPU.
pub type ProduceHook<'h> = &'h dyn Fn(&mut FrameCtx, &Buffer);

/// Work a caller records into a frame's command buffer: `before` the passes (after the particle upload) and
/// `after` them (given the frame's images; before the final image's read-back).
#[derive(Default, Clone, Copy)]
pub struct Hooks<'h> {
    /// Recorded before the frame's passes.
    pub before: Option<&'h dyn Fn(&mut FrameCtx)>,
    /// Recorded after the frame's passes.
    pub after: Option<AfterHook<'h>>,
    /// Writes this frame's particles into the given buffer on the GPU (a simulation), after an
    /// [`Upload::Gpu`]; recorded where the particle upload goes (the async queue's first part in a split
    /// frame, so the step for this frame overlaps the previous frame's passes).
    pub produce: Option<ProduceHook<'h>>,
}

/// One frame to render.
pub struct FrameRequest<'a> {
    /// The camera, size and scene around the fluid.
    pub view: &'a View,
    /// The settings.
    pub settings: &'a Settings,
    /// Work recorded before and after the passes.
    pub hooks: Hooks<'a>,
    /// Copy the final image into host memory ([`super::Renderer::read_submitted`]).
    pub readback: bool,
    /// Binary semaphores to wait for and signal (a window's acquire and present).
    pub binary: Binary,
    /// The passes count their own work ([`RendererState::work`] reads it after the frame): off by default,
    /// because the counting sums cost the frame (15–20 % of the noise splat on lavapipe; docs/gpu-frame.md).
    pub count_work: bool,
    /// Each part of a pass (its dispatches: `noise/scan`, `iso/rest`, …) is timed on its own scope, beside the
    /// pass; off by default (every part's timestamps drain the pipeline). `bench --parts`.
    pub time_parts: bool,
}

impl<'a> FrameRequest<'a> {
    /// A frame of `view` with settings `s`: no hooks, no read-back, no semaphores.
    pub fn new(view: &'a View, settings: &'a Settings) -> FrameRequest<'a> {
        FrameRequest {
            view,
            settings,
            hooks: Hooks::default(),
            readback: false,
            binary: Binary::default(),
            count_work: false,
            time_parts: false,
        }
    }

    /// With these hooks.
    pub fn hooks(self, hooks: Hooks<'a>) -> FrameRequest<'a> {
        FrameRequest { hooks, ..self }
    }

    /// With the passes counting their own work (for [`RendererState::work`]).
    pub fn count_work(self) -> FrameRequest<'a> {
        FrameRequest { count_work: true, ..self }
    }

    /// With each part of a pass timed on its own ([`FrameRequest::time_parts`]).
    pub fn time_parts(self, on: bool) -> FrameRequest<'a> {
        FrameRequest { time_parts: on, ..self }
    }

    /// With the final image copied into host memory.
    pub fn readback(self) -> FrameRequest<'a> {
        FrameRequest { readback: true, ..self }
    }
}

/// The frame slots (frames in flight) of a renderer: per-slot memory of a caller is reused once its slot's last
/// frame is done.
pub struct FrameSlots<'a>(pub(super) &'a Executor);

impl FrameSlots<'_> {
    /// How many frames may be in flight.
    pub fn count(&self) -> usize {
        self.0.frames()
    }

    /// The slot the next frame will use.
    pub fn next(&self) -> usize {
        self.0.next_slot()
    }

    /// Wait until slot `k`'s last frame is done.
    pub fn wait(&self, k: usize) -> Result<()> {
        self.0.wait_slot(k)
    }

    /// Wait for every frame in flight.
    pub fn wait_all(&self) -> Result<()> {
        self.0.wait_idle()
    }
}

/// What a renderer holds after its latest frame: the images, the particles, the surface's resources, where the
/// host's time went.
pub struct RendererState<'a> {
    pub(super) gpu: &'a std::sync::Arc<crate::gpu::Gpu>,
    pub(super) passes: &'a crate::passes::Passes,
    pub(super) uniforms: &'a crate::gpu::Buffer,
    pub(super) background: &'a crate::background::Background,
    pub(super) keep_raw_depth: bool,
    pub(super) async_compute: bool,
    pub(super) targets: Option<&'a Targets>,
    pub(super) smoothed: crate::passes::filter::Output,
    pub(super) particles: &'a ParticleSet,
    pub(super) surfaces: &'a Surfaces,
    pub(super) effects: &'a crate::effect::Effects,
    pub(super) host: HostTimes,
    pub(super) late: Option<&'a PassTimes>,
}

impl<'a> RendererState<'a> {
    /// The device.
    pub fn gpu(&self) -> &'a std::sync::Arc<crate::gpu::Gpu> {
        self.gpu
    }

    /// The scene behind the fluid.
    pub fn background(&self) -> &'a crate::background::Background {
        self.background
    }

    /// The effects, each with its images.
    pub fn effects(&self) -> &'a crate::effect::Effects {
        self.effects
    }

    /// Whether the raw splatted depth is kept through smoothing.
    pub fn keeps_raw_depth(&self) -> bool {
        self.keep_raw_depth
    }

    /// Whether frames are split over two queues.
    pub fn async_compute(&self) -> bool {
        self.async_compute
    }

    /// Whether the depth splat can draw in `mode` on this device (the rasterised variants need what the device
    /// offers).
    pub fn supports_splat(&self, mode: crate::named::SplatMode) -> bool {
        self.passes.splat.supports(mode)
    }

    /// Every pass, for the library's integration tests that record single passes by hand.
    #[doc(hidden)]
    pub fn passes(&self) -> &'a crate::passes::Passes {
        self.passes
    }

    /// The frame uniform block, for the same tests.
    #[doc(hidden)]
    pub fn uniforms(&self) -> &'a crate::gpu::Buffer {
        self.uniforms
    }

    /// The frame's images (after the first frame).
    pub fn targets(&self) -> Option<&'a Targets> {
        self.targets
    }

    /// Each pass's own count of its work in the latest frame that ran it (waits for the device): `ran(pass)`
    /// says which passes the frames asked about ran (a pass's counters keep the last frame that ran it); the
    /// splat counts only in its compute variant (`settings.splat.mode`). The passes count only in a frame
    /// requested with [`FrameRequest::count_work`] (a frame without it leaves their counts at 0), except
    /// `iso_volume`'s deposits, counted at every build of the field. What `meniscus bench` reports as "Work per
    /// pass" (from a counted frame after the timed ones) and Python's `Renderer.work()`.
    pub fn work(&self, settings: &Settings, ran: impl Fn(&str) -> bool) -> Result<crate::work::FrameWork> {
        let Some(t) = self.targets else { return Ok(crate::work::FrameWork::default()) };
        let compute = settings.splat.mode == crate::named::SplatMode::Compute;
        let splat = (ran(crate::passes::splat::NAME) && compute).then(|| t.splat_work(self.gpu)).transpose()?;
        let iso_surface = self.surfaces.technique::<crate::surface::iso::IsoSurface>();
        let iso = match (ran(crate::surface::iso::cast::NAME), iso_surface.and_then(|i| i.queue())) {
            (true, Some(q)) => Some(q.work(self.gpu)?),
            _ => None,
        };
        let iso_volume = match (ran(crate::surface::iso::volume::NAME), iso_surface.and_then(|i| i.volume())) {
            (true, Some(v)) => Some(v.work(self.gpu)?),
            _ => None,
        };
        let noise = match self.effects.get::<crate::effect::noise::NoiseEffect>() {
            Some(n) if ran(crate::passes::noise::NAME) => n.work()?,
            _ => None,
        };
        let mesh = self.surfaces.technique::<crate::surface::mesh::FluidMesh>().and_then(|m| m.live_work());
        let mesh = mesh.filter(|_| settings.surface == crate::settings::Surface::Mesh);
        Ok(crate::work::FrameWork { splat, iso, iso_volume, noise, mesh })
    }

    /// The image that holds the last frame's smoothed depth.
    pub fn smoothed_depth(&self) -> Option<&'a Image> {
        Some(self.targets?.smoothed(self.smoothed))
    }

    /// The last frame's final colour, read back (waits for nothing: finish the frame first).
    pub fn read_final(&self) -> Result<image::RgbaImage> {
        let t = self.targets.ok_or_else(|| Error::Invalid("nothing rendered yet".into()))?;
        let bytes = crate::gpu::transfer::read_image(self.gpu, &t.final_color)?;
        image::RgbaImage::from_raw(t.width, t.height, bytes)
            .ok_or_else(|| Error::Invalid("readback size mismatch".into()))
    }

    /// The texels of one of the frame's images (any 32-bit or RGBA format), tightly packed: dumps, tests.
    pub fn read_image(&self, img: &Image) -> Result<Vec<u8>> {
        crate::gpu::transfer::read_image(self.gpu, img)
    }

    /// The texels of a 32-bit float image (depth, thickness).
    pub fn read_f32(&self, img: &Image) -> Result<Vec<f32>> {
        crate::gpu::transfer::read_f32(self.gpu, img)
    }

    /// The particles on the device (and their host copy).
    pub fn particles(&self) -> &'a ParticleSet {
        self.particles
    }

    /// The surface techniques and their resources (`surfaces.technique::<IsoSurface>()` for its grid, `FluidMesh::mesh_stats`).
    pub fn surfaces(&self) -> &'a Surfaces {
        self.surfaces
    }

    /// (name, bytes) of every image and buffer the frame holds now: its targets', its surfaces', its effects'.
    pub fn memory(&self) -> Vec<(&'a str, u64)> {
        let targets = self.targets.into_iter().flat_map(|t| t.memory());
        targets.chain(self.surfaces.memory()).chain(self.effects.memory()).collect()
    }

    /// Where the host's time went in the latest submission.
    pub fn host_times(&self) -> HostTimes {
        self.host
    }

    /// The GPU times of the frame the latest submission's slot ran before it (a frame late, no wait).
    pub fn late_times(&self) -> Option<&'a PassTimes> {
        self.late
    }
}

/// The host's stages of one submitted frame, ms (`RendererState::host_times`).
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
