//! Live fluid: a Position Based Fluids solver (Macklin & Müller, SIGGRAPH 2013)
//! as compute passes on the GPU, feeding the renderer's particle buffer directly (no CPU copy per frame); beside
//! it, Divergence-free SPH on the same grid, lists and end of step ([`dfsph`], `[sim] solver = "dfsph"`). What
//! follows describes PBF's step, the live default.
//!
//! One step (Δt = frame time / substeps), every stage a pass with its own name and GPU timestamp:
//! `sim_predict` (gravity, x* = x + Δt v, collisions) → `grid` (THE GPU neighbour grid, `compute::grid`: a
//! counting sort of x* into cells one kernel radius wide) → `sim_reorder` (particles moved into grid order, by
//! index within a cell: deterministic) → `iterations` × (`sim_density`: ρ, λ; `sim_solve`: Δp with the
//! tensile-instability term, collisions) → `sim_velocity` (v = (x* − x)/Δt, static friction on the container's
//! faces) → `sim_vorticity` (ω; recorded only with confinement on) → `sim_viscosity` (vorticity confinement,
//! XSPH, x = x*, and the renderer's particles).
//!
//! Why PBF: it is unconditionally stable at the renderer's frame rate with a fixed small iteration count, so a
//! frame's cost is known in advance (the live demo needs that); the density error it leaves is measured by
//! the resting-pool test. Constants (see [`Params`]): h = 4 r = 2 d, 4 iterations, relaxation ε = 1 % of the
//! lattice's Σ|∇C|², s_corr k = 0.02 (in units of that sum), n = 4, Δq = 0.2 h, viscosity ν = 0.02 m²/s (dam
//! break, pool; 0.001 for the splash scenes) as XSPH (c = 22 ν Δt / h²: 0.84 at the 59k dam break), no vorticity
//! confinement (ε = 0; the shared SPlisHSPlasH set-up has none either), static friction μ_s = 1 on the
//! container's faces (commit 14600b6: water at rest stops creeping along the floor; flows slide freely); the
//! particle mass makes the initial lattice exactly ρ0 = 1000. Why these: the resting pool's fastest particles (docs/simulation.md, commit 2944c1b). The time
//! step follows a CFL bound from the free-fall speed of the scene's height (dam break 59k: 8 substeps of 5 ms per
//! 25 fps frame), or with `[sim] adaptive_step` from the largest speed of the frame before, re-chosen every frame
//! (`sim_viscosity` keeps each frame's largest speed; [`constants::cfl_substeps`]).

pub mod body;
pub mod constants;
pub mod dfsph;
pub mod diffuse;
mod emit;
pub mod observe;
pub mod params;
pub mod reference;
pub mod scene;
pub mod scene_file;
pub mod sdf;
pub mod stages;
pub mod validate;

use std::sync::Arc;

use ash::vk;
use glam::Vec3;
use gpu_allocator::MemoryLocation;

use crate::compute::grid::{GridBuffers, GridShape, NeighbourGrid};
use crate::error::{Error, Result};
use crate::gpu::{Buffer, FrameCtx, Gpu, Timer};
use crate::shader_constants::ParticleLayout;
use crate::shader_constants::MAX_COLLIDERS;
use crate::timing::PassTimes;
use constants::{Constants, SimUniforms};
use params::{Params, Solver};
use scene::{Collider, SimScene};

/// A frame's stage times ([`Simulation::step_frame`]) with the solver's stages per step — divided by `steps`, the
/// frame's step count, which an adaptive step changes from frame to frame — and the diffuse stages
/// ([`diffuse::STAGE_NAMES`]), which run once per frame, as they are.
pub fn per_step(times: PassTimes, steps: u32) -> PassTimes {
    let steps = steps.max(1) as f64;
    PassTimes(
        times
            .0
            .into_iter()
            .map(|(k, v)| if diffuse::STAGE_NAMES.contains(&k.as_str()) { (k, v) } else { (k, v / steps) })
            .collect(),
    )
}

/// Frames a simulation keeps host memory for (uniforms, emission staging): more than the renderer's frames in
/// flight, so a frame never rewrites memory a running frame reads.
const RING: usize = 3;

/// A running simulation on one device.
pub struct Simulation {
    gpu: Arc<Gpu>,
    stages: stages::Stages,
    grid_pass: NeighbourGrid,
    /// The scene (initial state, container, colliders, emitter).
    pub scene: SimScene,
    /// Solver settings.
    pub params: Params,
    /// Derived constants (of the last recorded frame: with `[sim] adaptive_step` its step changes per frame).
    pub constants: Constants,
    /// Time each part of a stage on its own in [`Simulation::step_frame`] (DFSPH's every recorded correction:
    /// `bench --sim … --parts`); off by default.
    pub time_parts: bool,
    /// The constants with the step chosen at the start (the free-fall bound, or `substeps`).
    initial: Constants,
    /// Per ring slot: the frame's largest speed (f32 bits, host-visible; sim_viscosity's max over its steps).
    speed: Vec<Buffer>,
    /// The largest speed of the frame [`Simulation::step_frame`] last waited for.
    speed_known: Option<f32>,
    uniforms: Vec<Buffer>,
    staging: Vec<Option<Buffer>>,
    ring: usize,
    /// State in the order of the last step (A) and in grid order during a step (B).
    state: [Buffer; 2],
    /// Predicted positions: the predict output, then the two iterates.
    pred: [Buffer; 2],
    /// The iterate and λ per particle (sim_density → sim_solve).
    pos_lambda: Buffer,
    density: Buffer,
    vel: Buffer,
    omega: Buffer,
    /// Render particles (vec4, w = 0) when no renderer buffer is given.
    particles: Buffer,
    /// The mesh collider's signed distances (16 unused bytes without one).
    sdf: Buffer,
    /// The dynamic body's buffers (`body`).
    body: body::BodyBuffers,
    grid: GridBuffers,
    neighbours: stages::Neighbours,
    n: u32,
    /// Particles to upload at the next recorded frame (the initial state, or emitted ones) at this index.
    pending: Option<Pending>,
    /// Particles the emitter has recycled since the start.
    reused: u64,
    /// The host-visible buffer [`Simulation::read`] and [`Simulation::read_positions`] copy the state into, kept
    /// between calls (a new 36 MB buffer per call cost a 1M-particle read-back most of its time).
    readback: std::sync::Mutex<Option<Buffer>>,
    next_id: u32,
    /// Simulated time (s).
    pub time: f64,
    /// Frames simulated.
    pub frames: u64,
    /// A sphere collider the user moves (the demo's mouse), in addition to the scene's.
    pub pusher: Option<(Vec3, f32)>,
    timer: Option<Timer>,
    /// The spray, foam and bubbles stages (`set_diffuse`).
    diffuse: Option<diffuse::DiffuseStages>,
    /// The DFSPH stages and buffers (`[sim] solver = "dfsph"`).
    dfsph: Option<dfsph::Dfsph>,
}

/// State rows (position, id bits, velocity) to upload at the next recorded frame: rows[0] goes to particle `at`;
/// particles from `fresh` on are new (the initial state, emitted ones), the ones before it rewritten (recycled).
struct Pending {
    at: u32,
    fresh: u32,
    rows: Vec<[f32; 8]>,
}

impl Simulation {
    /// Set up `scene` on `gpu` with `params` (nothing is recorded until the first frame).
    pub fn new(gpu: &Arc<Gpu>, scene: SimScene, params: Params) -> Result<Simulation> {
        params.validate()?;
        let mut scene = scene;
        if params.solver == Solver::Pbf {
            body::for_pbf(&mut scene);
        }
        if scene.colliders.len() + 1 > MAX_COLLIDERS as usize {
            return Err(Error::Limit(format!("a scene has at most {} colliders", MAX_COLLIDERS - 1)));
        }
        let constants = Constants::new(&scene, &params);
        // A viscosity set by the user that the explicit XSPH step cannot apply is refused (the step would clamp
        // it without a word: 250× the default moved the dam break's front by 0.4 %); a scene's own default is
        // clamped (finer resolutions than it was set for get less viscosity; `sim` prints the reach).
        constants.check_step(&params)?;
        let solver = params.solver;
        let cap = scene.capacity.max(1) as u64;
        if cap * 32 > gpu.info.max_storage_buffer_range {
            return Err(Error::Limit(format!(
                "{cap} particles need {} bytes of state, more than this device's storage buffer limit of {} bytes",
                cap * 32,
                gpu.info.max_storage_buffer_range
            )));
        }
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC;
        let buf = |name: &str, bytes: u64| Buffer::new(gpu, name, bytes, usage, MemoryLocation::GpuOnly);
        // What the neighbour loops read at a per-lane index (Slot::TexelRead).
        let vec4s = |name: &str| Buffer::texels(gpu, name, 16 * cap, usage, vk::Format::R32G32B32A32_SFLOAT);
        let state = |name: &str| Buffer::texels(gpu, name, 32 * cap, usage, vk::Format::R32G32B32A32_UINT);
        let (lo, hi) = scene.container;
        let shape = GridShape::covering(lo, hi, constants.h);
        let uniforms = (0..RING)
            .map(|_| {
                Buffer::new(
                    gpu,
                    "sim",
                    std::mem::size_of::<SimUniforms>() as u64,
                    vk::BufferUsageFlags::UNIFORM_BUFFER,
                    MemoryLocation::CpuToGpu,
                )
            })
            .collect::<Result<Vec<_>>>()?;
        let mut sim = Simulation {
            time_parts: false,
            gpu: gpu.clone(),
            stages: stages::Stages::new(gpu, params.scorr_n, scene.mesh_collider.is_some(), params.vorticity > 0.0)?,
            grid_pass: NeighbourGrid::new(gpu)?,
            params,
            constants,
            initial: constants,
            speed: (0..RING)
                .map(|_| {
                    Buffer::new(
                        gpu,
                        "sim_speed",
                        16,
                        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                        MemoryLocation::GpuToCpu,
                    )
                })
                .collect::<Result<Vec<_>>>()?,
            speed_known: None,
            uniforms,
            staging: (0..RING).map(|_| None).collect(),
            ring: 0,
            // Read as RGBA32UI texels (two per particle, the id bits unchanged) by sim_reorder and sim_velocity.
            state: [state("sim_state")?, state("sim_state_sorted")?],
            pred: [vec4s("sim_pred")?, vec4s("sim_pred_next")?],
            pos_lambda: vec4s("sim_pos_lambda")?,
            density: buf("sim_density", 4 * cap)?,
            vel: vec4s("sim_vel")?,
            omega: vec4s("sim_omega")?,
            particles: buf("sim_particles", crate::shader_constants::BYTES_PER_PARTICLE * cap)?,
            sdf: match &scene.mesh_collider {
                Some(m) => crate::gpu::transfer::upload_buffer(gpu, "sim_sdf", bytemuck::cast_slice(&m.values), None)?,
                None => buf("sim_sdf", 16)?,
            },
            body: body::BodyBuffers::new(gpu, &scene, cap, usage)?,
            grid: GridBuffers::new(gpu, "sim", shape, cap as u32)?,
            neighbours: stages::Neighbours {
                count: Buffer::texels(gpu, "sim_nbr_count", 4 * cap, usage, vk::Format::R32_UINT)?,
                list: {
                    let bytes = 4 * cap * crate::shader_constants::MAX_NEIGHBOURS as u64;
                    // With the 16-bit readers' texel view where 16-bit lists are possible; none past 65,536
                    // particles (a view of millions could pass the device's texel-buffer limit).
                    if stages::Neighbours::packable(cap) {
                        Buffer::texels(gpu, "sim_nbrs", bytes, usage, vk::Format::R32G32B32A32_UINT)?
                    } else {
                        buf("sim_nbrs", bytes)?
                    }
                },
                overflow: buf("sim_nbr_overflow", 16)?,
                packed: stages::Neighbours::packable(cap),
            },
            n: 0,
            pending: None,
            reused: 0,
            readback: std::sync::Mutex::new(None),
            next_id: 0,
            time: 0.0,
            frames: 0,
            pusher: None,
            timer: Some(Timer::new(gpu)?),
            diffuse: None,
            dfsph: match solver {
                Solver::Dfsph => Some(dfsph::Dfsph::new(gpu, cap, scene.mesh_collider.is_some())?),
                Solver::Pbf => None,
            },
            scene,
        };
        sim.reset();
        Ok(sim)
    }

    /// Back to the scene's initial state (uploaded with the next frame).
    pub fn reset(&mut self) {
        let init: Vec<[f32; 8]> = self
            .scene
            .positions
            .iter()
            .zip(&self.scene.velocities)
            .enumerate()
            .map(|(i, (p, v))| [p[0], p[1], p[2], f32::from_bits(i as u32), v[0], v[1], v[2], 0.0])
            .collect();
        self.n = 0;
        self.next_id = init.len() as u32;
        self.pending = Some(Pending { at: 0, fresh: 0, rows: init });
        self.reused = 0;
        self.time = 0.0;
        self.frames = 0;
        if let Some(d) = self.diffuse.as_mut() {
            d.reset();
        }
    }

    /// Generate the water's spray, foam and bubbles on the GPU after every frame ([`diffuse::DiffuseStages`],
    /// `params`: the `[diffuse]` settings), or stop (`None`). Their pool starts empty. A renderer fed by
    /// [`Simulation::record_frame`] needs room for [`Simulation::diffuse_slots`] after the fluid
    /// (`Renderer::set_gpu_particles_with_diffuse`).
    pub fn set_diffuse(&mut self, params: Option<&crate::diffuse::params::Params>) -> Result<()> {
        self.diffuse = match params {
            Some(p) => Some(diffuse::DiffuseStages::new(&self.gpu, p, self.capacity())?),
            None => None,
        };
        let layout = ParticleLayout { count: self.capacity().max(1), header: true, diffuse: self.diffuse_slots() };
        let need = layout.bytes();
        if self.particles.size < need {
            self.particles = Buffer::new(
                &self.gpu,
                "sim_particles",
                need,
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )?;
        }
        Ok(())
    }

    /// The most diffuse particles a frame draws (0 without the stages): the renderer's buffer holds a header vec4
    /// and two vec4 per particle after the fluid's positions and motions.
    pub fn diffuse_slots(&self) -> u32 {
        self.diffuse.as_ref().map_or(0, |d| d.draw_cap())
    }

    /// The living diffuse particles after the last frame (waits for the device); empty without the stages.
    pub fn read_diffuse(&self) -> Result<Vec<crate::diffuse::Particle>> {
        match &self.diffuse {
            Some(d) if self.frames > 0 => d.read(&self.gpu),
            _ => Ok(vec![]),
        }
    }

    /// Particles after the next frame's uploads (the count the renderer draws).
    pub fn count(&self) -> u32 {
        self.pending.as_ref().map_or(self.n, |p| self.n.max(p.at + p.rows.len() as u32))
    }

    /// Whether the neighbour lists hold 16-bit indices, two per word (the default up to 65,536 particles; see
    /// [`stages::Neighbours::packed`]).
    pub fn packed_neighbours(&self) -> bool {
        self.neighbours.packed
    }

    /// Choose the neighbour lists' format for the next steps: 16-bit lists need a capacity of at most 65,536
    /// particles. The step's result is the same either way (test `sixteen_bit_neighbour_lists_change_nothing`).
    pub fn set_packed_neighbours(&mut self, packed: bool) -> Result<()> {
        if packed && !stages::Neighbours::packable(self.capacity() as u64) {
            return Err(Error::Invalid(format!(
                "16-bit neighbour lists hold at most 65,536 particles (this simulation holds {})",
                self.capacity()
            )));
        }
        self.neighbours.packed = packed;
        Ok(())
    }

    /// Most particles.
    pub fn capacity(&self) -> u32 {
        self.scene.capacity as u32
    }

    /// Particle radius (m).
    pub fn radius(&self) -> f32 {
        self.scene.radius()
    }

    /// Record one frame (`substeps` steps) into `ctx`, each stage in its own pass scope; the renderer's particles
    /// (xyz, w = 0) go to `out`, or to the simulation's own buffer. Advances `time` by one frame.
    pub fn record_frame(&mut self, ctx: &mut FrameCtx, out: Option<&Buffer>) -> Result<()> {
        self.emit()?;
        let k = self.ring;
        self.ring = (self.ring + 1) % RING;
        if self.params.adapts_step() {
            // The frame before's largest speed (known when the caller waited for it), else this slot's last
            // frame's (RING frames back: done, as its uniform block is rewritten below); gravity may add g × a
            // frame's time before this one ends.
            let last = self.speed_known.take().or_else(|| (self.frames >= RING as u64).then(|| self.speed_of(k)));
            if let Some(v) = last {
                let g = Vec3::from(self.params.gravity).length() / self.params.fps;
                let n = constants::cfl_substeps(&self.params, self.scene.spacing, v + g);
                self.constants = self.initial.with_substeps(n, &self.params);
            }
        }
        if let Some(Pending { at, fresh, rows }) = self.pending.take() {
            let bytes: &[u8] = bytemuck::cast_slice(&rows);
            if self.staging[k].as_ref().is_none_or(|b| (b.size as usize) < bytes.len()) {
                self.staging[k] = Some(Buffer::new(
                    &self.gpu,
                    "sim_staging",
                    (bytes.len() as u64).max(16),
                    vk::BufferUsageFlags::TRANSFER_SRC,
                    MemoryLocation::CpuToGpu,
                )?);
            }
            let staging = self.staging[k].as_mut().expect("set");
            staging.write(0, bytes)?;
            let region = vk::BufferCopy { src_offset: 0, dst_offset: at as u64 * 32, size: bytes.len() as u64 };
            ctx.copy_buffer(staging, &self.state[0], region);
            if self.n == 0 {
                ctx.fill(&self.neighbours.overflow, 0);
                // The body starts again with the water.
                self.body.reset(ctx);
            }
            let end = at + rows.len() as u32;
            if let Some(d) = &self.dfsph {
                d.clear_warm_start(ctx, fresh, end - fresh);
            }
            self.n = end;
        }
        let u = self.uniforms_now();
        self.uniforms[k].write(0, bytemuck::bytes_of(&u))?;
        let out = out.unwrap_or(&self.particles);
        if let Some(d) = &self.dfsph {
            d.adapt(&self.params)?;
            d.clear_stats(ctx);
        }
        ctx.fill(&self.speed[k], 0);
        for _ in 0..self.constants.substeps {
            self.record_step(ctx, k, out);
        }
        // The host reads the frame's largest speed once the frame is done (the next frame's adaptive step).
        ctx.barrier(&[crate::gpu::Use::Buffer(&self.speed[k], crate::gpu::Access::HostRead)]);
        if let Some(d) = self.diffuse.as_mut() {
            let f = diffuse::FluidBuffers {
                uniforms: &self.uniforms[k],
                grid: &self.grid,
                state: &self.state[0],
                n: self.n,
                radius: self.scene.radius(),
                dt: 1.0 / self.params.fps,
                frame: self.frames,
            };
            d.record(ctx, &f, out);
        }
        self.time += 1.0 / self.params.fps as f64;
        self.frames += 1;
        Ok(())
    }

    /// The uniform block for the current count, pusher and constants.
    pub fn uniforms_now(&self) -> SimUniforms {
        let c = &self.constants;
        let r = self.radius();
        let (lo, hi) = self.scene.container;
        let mut colliders = [[0f32; 4]; 2 * MAX_COLLIDERS as usize];
        let mut all = self.scene.colliders.clone();
        if let Some((centre, radius)) = self.pusher {
            all.push(Collider::Sphere { centre, radius });
        }
        for (i, col) in all.iter().enumerate() {
            let [a, b] = col.encode();
            colliders[2 * i] = a;
            colliders[2 * i + 1] = b;
        }
        let pi = std::f32::consts::PI;
        SimUniforms {
            grid: self.grid.shape,
            lo_dt: (lo + r).extend(c.dt).to_array(),
            hi_h: (hi - r).extend(c.h).to_array(),
            gravity_mass: Vec3::from(self.params.gravity).extend(c.mass).to_array(),
            solver: [self.params.rest_density, c.eps, c.scorr_k, c.inv_w_dq],
            visc: [c.xsph, self.params.vorticity, r, c.dt / (c.dt + 1.0 / self.params.fps)],
            kern: [c.h * c.h, 315.0 / (64.0 * pi * c.h.powi(9)), -45.0 / (pi * c.h.powi(6)), c.volume],
            counts: [self.n, all.len() as u32, (self.neighbours.count.size / 4) as u32, self.params.scorr_n],
            sdf_lo: self.scene.mesh_collider.as_ref().map_or([0.0; 4], |m| m.origin.extend(m.cell).to_array()),
            sdf_dims: self.scene.mesh_collider.as_ref().map_or([0; 4], |m| m.dims.extend(1).to_array()),
            wall: [self.params.wall_friction, self.body.on() as u32 as f32, 0.0, 0.0],
            colliders,
            nozzle: self.scene.emitter.map_or([[0.0; 4]; 5], |e| e.nozzle(self.scene.spacing, self.time)),
        }
    }

    /// One step: the positions the grid sorts (PBF's prediction x*, DFSPH's x), the grid, the reorder and the
    /// neighbour lists; the solver's iterations; then the end both share (velocity from the positions with the
    /// static friction, vorticity confinement when on, XSPH, the state and the renderer's particles).
    fn record_step(&self, ctx: &mut FrameCtx, k: usize, out: &Buffer) {
        let n = self.n;
        let u = &self.uniforms[k];
        let [a, b] = &self.state;
        let (g, s) = (&self.stages, &self.grid);
        match &self.dfsph {
            Some(d) => d.begin(ctx, u, a, &self.pred[0], n),
            None => g.predict(ctx, u, a, &self.pred[0], &self.sdf, n),
        }
        ctx.pass(crate::compute::grid::NAME, |ctx| self.grid_pass.record(ctx, &self.pred[0], n, s));
        let carry = self.dfsph.as_ref().map(|d| d.carried());
        g.reorder(ctx, u, s, a, &self.pred[0], b, &self.pred[1], carry, n);
        let nb = &self.neighbours;
        g.neighbours(ctx, u, s, &self.pred[1], nb, n);
        // The positions the step ends at.
        let x = match &self.dfsph {
            Some(d) => {
                let bufs = dfsph::StepBuffers {
                    uniforms: u,
                    neighbours: nb,
                    sorted: b,
                    x: &self.pred[1],
                    x_new: &self.pred[0],
                    vel: &self.vel,
                    density: &self.density,
                    sdf: &self.sdf,
                    body: &self.body.body,
                    body_on: self.body.on(),
                };
                d.solve(ctx, &bufs, &self.params, n);
                &self.pred[0]
            }
            None => {
                let mut cur = 1;
                for _ in 0..self.params.iterations {
                    g.density(ctx, u, nb, &self.pred[cur], &self.pos_lambda, &self.density, n);
                    g.solve(ctx, u, nb, &self.pos_lambda, &self.pred[1 - cur], &self.sdf, n);
                    cur = 1 - cur;
                }
                &self.pred[cur]
            }
        };
        g.velocity(ctx, u, b, x, &self.vel, n);
        // Without confinement (ε = 0, the default) nothing reads ω: the stage is not recorded.
        if self.params.vorticity > 0.0 {
            g.vorticity(ctx, u, nb, x, &self.vel, &self.omega, n);
        }
        g.viscosity(ctx, u, nb, x, &self.vel, &self.omega, b, a, out, &self.speed[k], n);
    }

    /// The largest speed (m/s) ring slot `k`'s last frame reached (its frame must be done).
    fn speed_of(&self, k: usize) -> f32 {
        self.speed[k].read().map_or(0.0, |b| f32::from_bits(u32::from_le_bytes([b[0], b[1], b[2], b[3]])))
    }

    /// The step in words, for the log lines: "8 steps of 5.00 ms per frame", or with `[sim] adaptive_step` the
    /// rule and the first frame's.
    pub fn step_summary(&self) -> String {
        let c = &self.constants;
        let fixed = format!("{} steps of {:.2} ms per frame", c.substeps, c.dt * 1e3);
        if self.params.adapts_step() {
            format!(
                "the step re-chosen every frame from the largest speed (cfl {}, at most {} ms; the first frame {fixed})",
                self.params.cfl,
                self.params.max_dt * 1e3
            )
        } else {
            fixed
        }
    }

    /// The largest speed (m/s) of the last frame [`Simulation::step_frame`] simulated (None before the first, or
    /// after frames recorded into a caller's submission).
    pub fn last_speed(&self) -> Option<f32> {
        self.speed_known
    }

    /// The dynamic body's centre, velocity and angular velocity after the frames recorded so far (waits for the
    /// device); None without one (or with PBF, where it stands still as a collider).
    pub fn body_state(&self) -> Result<Option<body::BodyState>> {
        self.body.state(&self.gpu)
    }

    /// The corrections DFSPH's solves recorded per step in the latest frame [divergence-free, constant-density]
    /// (`[sim] adaptive_corrections`; None for PBF).
    pub fn recorded_corrections(&self) -> Option<[u32; 2]> {
        self.dfsph.as_ref().map(|d| d.recorded())
    }

    /// The DFSPH solves' statistics over the last recorded frame (None for PBF; waits for the device).
    pub fn solver_stats(&self) -> Result<Option<dfsph::SolverStats>> {
        match &self.dfsph {
            Some(d) if self.frames > 0 => Ok(Some(d.read_stats(&self.gpu)?)),
            _ => Ok(None),
        }
    }

    /// Simulate one frame in its own submission and wait for it; per-stage GPU times (summed over the steps).
    pub fn step_frame(&mut self) -> Result<PassTimes> {
        let mut timer = self.timer.take().expect("timer");
        let gpu = self.gpu.clone();
        let parts = self.time_parts;
        let r = gpu.one_shot(|cmd| {
            let mut ctx = FrameCtx::new(&gpu, cmd, Some(&mut timer));
            ctx.time_parts = parts;
            self.record_frame(&mut ctx, None)
        });
        let times = r.and_then(|_| timer.read());
        self.timer = Some(timer);
        self.speed_known = Some(self.speed_of((self.ring + RING - 1) % RING));
        times
    }

    /// Particle-steps whose neighbours did not all fit in the list (MAX_NEIGHBOURS) since the last reset
    /// (waits for the device).
    pub fn neighbour_overflow(&self) -> Result<u32> {
        if self.frames == 0 {
            return Ok(0);
        }
        let b = crate::gpu::transfer::read_buffer(&self.gpu, &self.neighbours.overflow, 4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// The particles' motions (id, |Δv|/Δt low-passed over about a frame: sim_viscosity.comp) in the
    /// simulation's own render buffer, in its order (written by frames recorded without a target; waits for the
    /// device).
    pub fn read_motion(&self) -> Result<Vec<crate::motion::Motion>> {
        if self.frames == 0 {
            return Ok(vec![]);
        }
        let n = self.n as u64;
        let b = crate::gpu::transfer::read_buffer_at(&self.gpu, &self.particles, 16 * n, 16 * n)?;
        Ok(b.chunks_exact(16)
            .map(|c| crate::motion::Motion {
                id: u32::from_le_bytes([c[0], c[1], c[2], c[3]]),
                accel: f32::from_le_bytes([c[4], c[5], c[6], c[7]]),
            })
            .collect())
    }

    /// The simulation's own render particles (vec4, w = 0), written by frames recorded without a target.
    pub fn particle_buffer(&self) -> &Buffer {
        &self.particles
    }

    /// Read the state back (waits for the device): positions, velocities, densities and ids, in the order of
    /// the last step.
    pub fn read(&self) -> Result<crate::scene::Particles> {
        if self.frames == 0 {
            let n = self.scene.positions.len();
            return Ok(crate::scene::Particles {
                positions: self.scene.positions.clone(),
                velocities: Some(self.scene.velocities.clone()),
                densities: Some(vec![self.params.rest_density; n]),
                ids: Some((0..n as i64).collect()),
                ..Default::default()
            });
        }
        let n = self.n as u64;
        let held = self.read_back_state(true)?;
        let rb = held.as_ref().expect("read back");
        let bytes = rb.read()?;
        let state: &[[f32; 8]] = bytemuck::cast_slice(&bytes[..32 * n as usize]);
        let density: Vec<f32> = bytemuck::cast_slice::<u8, f32>(&bytes[32 * n as usize..36 * n as usize]).to_vec();
        Ok(crate::scene::Particles {
            positions: state.iter().map(|s| [s[0], s[1], s[2]]).collect(),
            velocities: Some(state.iter().map(|s| [s[4], s[5], s[6]]).collect()),
            densities: Some(density),
            ids: Some(state.iter().map(|s| s[3].to_bits() as i64).collect()),
            ..Default::default()
        })
    }

    /// The particles' positions only (what Python's `Simulation.positions()` returns): the state copied into the
    /// kept read-back buffer, the positions taken out of it by every thread.
    pub fn read_positions(&self) -> Result<Vec<[f32; 3]>> {
        use rayon::prelude::*;
        if self.frames == 0 {
            return Ok(self.scene.positions.clone());
        }
        let held = self.read_back_state(false)?;
        let bytes = held.as_ref().expect("read back").read()?;
        let state: &[[f32; 8]] = bytemuck::cast_slice(&bytes[..32 * self.n as usize]);
        Ok(state.par_iter().with_min_len(4096).map(|s| [s[0], s[1], s[2]]).collect())
    }

    /// Copy the state (and with `density` the densities after it) into the kept read-back buffer, grown when too
    /// small; returns it locked.
    fn read_back_state(&self, density: bool) -> Result<std::sync::MutexGuard<'_, Option<Buffer>>> {
        let n = self.n as u64;
        let mut held = self.readback.lock().unwrap_or_else(|e| e.into_inner());
        if held.as_ref().is_none_or(|b| b.size < 36 * n) {
            *held = None;
            let usage = vk::BufferUsageFlags::TRANSFER_DST;
            *held = Some(Buffer::new(&self.gpu, "sim_readback", (36 * n).max(16), usage, MemoryLocation::GpuToCpu)?);
        }
        let rb = held.as_ref().expect("set");
        self.gpu.one_shot(|cmd| {
            let mut ctx = FrameCtx::new(&self.gpu, cmd, None);
            ctx.copy_buffer(&self.state[0], rb, vk::BufferCopy { src_offset: 0, dst_offset: 0, size: 32 * n });
            if density {
                let region = vk::BufferCopy { src_offset: 0, dst_offset: 32 * n, size: 4 * n };
                ctx.copy_buffer(&self.density, rb, region);
            }
            ctx.barrier(&[crate::gpu::Use::Buffer(rb, crate::gpu::Access::HostRead)]);
            Ok(())
        })?;
        Ok(held)
    }
}

#[cfg(test)]
mod tests;
