//! The live simulation's spray, foam and bubbles on the GPU: [`crate::diffuse`]'s model (Ihmsen et al. 2012 with
//! Bender et al. 2019's automatic limits, as a live run calibrates them: the running maxima) as six stages after
//! a frame's last step, each timed like the solver's stages and named like its shader:
//! `sim_diffuse_density` (ρ and the neighbour count), `sim_diffuse_normals` (colour-field normals),
//! `sim_diffuse_potentials` (trapped air, wave crest, kinetic energy, their running maxima), `sim_diffuse_advect`
//! (classify and move the pool's particles), `sim_diffuse_spawn` (into each fluid particle's own slots), and
//! `sim_diffuse_draw` (the living ones in the `diffuse` pass's layout, appended to the renderer's particle buffer
//! after the fluid's with a header the pass dispatches indirectly from).
//! The pool: `per_particle` slots per fluid particle id, three vec4 each (shaders_glsl/sim_diffuse.glsl); a
//! fluid particle only ever spawns into its own slots, so nothing is placed by atomics and the pool is the same
//! on every run. The CPU model with the same `per_particle` is the reference the tests compare against.
use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::compute::grid::GridBuffers;
use crate::declare_program;
use crate::diffuse::{params::Params, Kind, Particle};
use crate::error::Result;
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu, Res};
use crate::shader_constants::LOCAL_1D;
use crate::shaders;

/// The stages, in order (timestamp keys).
pub const STAGE_NAMES: &[&str] = &[
    "sim_diffuse_density",
    "sim_diffuse_normals",
    "sim_diffuse_potentials",
    "sim_diffuse_advect",
    "sim_diffuse_spawn",
    "sim_diffuse_draw",
];

/// Push constants of every stage (sim_diffuse.glsl's `DiffusePush`, 128 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Push {
    /// Kernel support h = 4 r.
    pub h: f32,
    /// The model's particle mass.
    pub mass: f32,
    /// Cubic spline coefficient 8 / (π h³).
    pub kk: f32,
    /// Its derivative's 48 / (π h³).
    pub kl: f32,
    /// Particle radius.
    pub radius: f32,
    /// A frame (s).
    pub dt: f32,
    /// [`Params::foam_scale`].
    pub foam_scale: f32,
    /// The least kinetic energy that spawns.
    pub ke_floor: f32,
    /// [`Params::lifetime`].
    pub life: [f32; 2],
    /// [`Params::buoyancy`].
    pub buoyancy: f32,
    /// [`Params::drag`].
    pub drag: f32,
    /// [`Params::air_drag`].
    pub air_drag: f32,
    /// [`Params::spray_below`].
    pub spray_below: u32,
    /// [`Params::bubble_above`].
    pub bubble_above: u32,
    /// [`Params::min_neighbours`].
    pub min_neighbours: u32,
    /// [`Params::per_particle`].
    pub per_particle: u32,
    /// The frame number (the spawns' hash).
    pub frame: u32,
    /// [`Params::automatic`].
    pub automatic: u32,
    /// Slots in the pool.
    pub slots: u32,
    /// Hand-set limits: trapped air, wave crest.
    pub manual_ta_wc: [f32; 4],
    /// Hand-set kinetic-energy limits.
    pub manual_ke: [f32; 2],
    /// [`Params::size`].
    pub size: f32,
    /// [`Params::size_spread`].
    pub size_spread: f32,
    /// [`Params::fade`].
    pub fade: f32,
    /// [`Params::fade_in`].
    pub fade_in: f32,
    /// The vec4 index of the diffuse header in the renderer's particle buffer (2 × the fluid count).
    pub out_offset: u32,
    /// At most this many are appended for drawing.
    pub draw_cap: u32,
}

const _: () = assert!(std::mem::size_of::<Push>() == 128);

declare_program!(pub DENSITY: Push = compute(
    shaders::SIM_DIFFUSE_DENSITY,
    [Uniform, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite]
));
declare_program!(pub NORMALS: Push = compute(
    shaders::SIM_DIFFUSE_NORMALS,
    [Uniform, TexelRead, TexelRead, TexelRead, BufRead, BufWrite]
));
declare_program!(pub POTENTIALS: Push = compute(
    shaders::SIM_DIFFUSE_POTENTIALS,
    [Uniform, TexelRead, TexelRead, TexelRead, BufRead, BufRead, BufWrite, BufWrite]
));
declare_program!(pub ADVECT: Push = compute(
    shaders::SIM_DIFFUSE_ADVECT,
    [Uniform, TexelRead, TexelRead, TexelRead, BufRead, BufWrite]
));
declare_program!(pub SPAWN: Push = compute(shaders::SIM_DIFFUSE_SPAWN, [Uniform, TexelRead, BufRead, BufRead, BufWrite]));
declare_program!(pub DRAW: Push = compute(shaders::SIM_DIFFUSE_DRAW, [Uniform, BufRead, BufWrite]));

/// The stages' programs and buffers for one simulation.
pub struct DiffuseStages {
    params: Params,
    density: ComputeProgram<Push>,
    normals: ComputeProgram<Push>,
    potentials: ComputeProgram<Push>,
    advect: ComputeProgram<Push>,
    spawn: ComputeProgram<Push>,
    draw: ComputeProgram<Push>,
    /// Per fluid particle: (ρ, neighbours, 0, 0).
    aux: Buffer,
    /// Per fluid particle: the surface normal.
    normal_buf: Buffer,
    /// Per fluid particle: (trapped air, wave crest, kinetic energy, may spawn).
    pot: Buffer,
    /// The running maxima's bits (3 used).
    run: Buffer,
    /// The frame's lowest particle (sortable bits).
    floor: Buffer,
    /// The pool: three vec4 per slot.
    pool: Buffer,
    slots: u32,
    /// The pool and the maxima must be cleared before the next frame (a new run).
    clear: bool,
}

/// What the stages read of the simulation.
pub struct FluidBuffers<'a> {
    /// The uniform block of this frame.
    pub uniforms: &'a Buffer,
    /// The last step's grid.
    pub grid: &'a GridBuffers,
    /// The state after the last step (grid order).
    pub state: &'a Buffer,
    /// Particles.
    pub n: u32,
    /// Particle radius.
    pub radius: f32,
    /// A frame (s).
    pub dt: f32,
    /// The frame number.
    pub frame: u64,
}

impl DiffuseStages {
    /// The stages for a simulation of `capacity` particles (ids below it): a pool of `per_particle` slots each.
    pub fn new(gpu: &Arc<Gpu>, params: &Params, capacity: u32) -> Result<DiffuseStages> {
        crate::section::Section::check(params).map_err(|(_, reason)| crate::error::Error::Invalid(reason))?;
        let slots = capacity.max(1) * params.per_particle;
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC;
        let buf = |name: &str, bytes: u64| Buffer::new(gpu, name, bytes.max(16), usage, MemoryLocation::GpuOnly);
        let cap = capacity.max(1) as u64;
        Ok(DiffuseStages {
            params: params.clone(),
            density: ComputeProgram::new(gpu, &DENSITY)?,
            normals: ComputeProgram::new(gpu, &NORMALS)?,
            potentials: ComputeProgram::new(gpu, &POTENTIALS)?,
            advect: ComputeProgram::new(gpu, &ADVECT)?,
            spawn: ComputeProgram::new(gpu, &SPAWN)?,
            draw: ComputeProgram::new(gpu, &DRAW)?,
            aux: buf("sim_diffuse_aux", 16 * cap)?,
            normal_buf: buf("sim_diffuse_normals", 16 * cap)?,
            pot: buf("sim_diffuse_pot", 16 * cap)?,
            run: buf("sim_diffuse_run", 16)?,
            floor: buf("sim_diffuse_floor", 16)?,
            pool: buf("sim_diffuse_pool", 48 * slots as u64)?,
            slots,
            clear: true,
        })
    }

    /// Slots in the pool.
    pub fn slots(&self) -> u32 {
        self.slots
    }

    /// The most diffuse particles drawn (the pool's slots, at most `max_particles`): the renderer's buffer holds a
    /// header vec4 and two vec4 per particle after the fluid's.
    pub fn draw_cap(&self) -> u32 {
        self.slots.min(self.params.max_particles)
    }

    /// The settings in use.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Start again (a reset simulation): the pool and the running maxima are cleared before the next frame.
    pub fn reset(&mut self) {
        self.clear = true;
    }

    /// The push constants of a frame.
    fn push(&self, f: &FluidBuffers, out_offset: u32) -> Push {
        let p = &self.params;
        let h = 4.0 * f.radius;
        let (kk, kl) = crate::diffuse::potentials::CubicSpline::new(h).coefficients();
        let mass = crate::diffuse::potentials::model_mass(f.radius);
        Push {
            h,
            mass,
            kk,
            kl,
            radius: f.radius,
            dt: f.dt,
            foam_scale: p.foam_scale,
            ke_floor: crate::diffuse::potentials::kinetic_floor(mass, h),
            life: p.lifetime,
            buoyancy: p.buoyancy,
            drag: p.drag,
            air_drag: p.air_drag,
            spray_below: p.spray_below,
            bubble_above: p.bubble_above,
            min_neighbours: p.min_neighbours,
            per_particle: p.per_particle,
            frame: (f.frame ^ (f.frame >> 32)) as u32,
            automatic: p.automatic as u32,
            slots: self.slots,
            manual_ta_wc: [p.trapped_air[0], p.trapped_air[1], p.wave_crest[0], p.wave_crest[1]],
            manual_ke: p.kinetic,
            size: p.size,
            size_spread: p.size_spread,
            fade: p.fade,
            fade_in: p.fade_in,
            out_offset,
            draw_cap: self.draw_cap(),
        }
    }

    /// Record the six stages for the state after a frame's last step, drawing into `out` after its `2 n` vec4.
    pub fn record(&mut self, ctx: &mut FrameCtx, f: &FluidBuffers, out: &Buffer) {
        if self.clear {
            ctx.fill(&self.pool, 0);
            ctx.fill(&self.run, 0);
            self.clear = false;
        }
        ctx.fill(&self.floor, u32::MAX);
        let layout = crate::shader_constants::ParticleLayout { count: f.n, header: true, diffuse: self.slots };
        let push = self.push(f, layout.diffuse_header() as u32);
        let (u, g, s) = (f.uniforms, f.grid, f.state);
        let fluid = [f.n.div_ceil(LOCAL_1D).max(1), 1, 1];
        let pool = [self.slots.div_ceil(LOCAL_1D).max(1), 1, 1];
        fn cells<'b>(u: &'b Buffer, g: &'b GridBuffers, s: &'b Buffer, rest: &[&'b Buffer]) -> Vec<Res<'b>> {
            let mut r: Vec<Res> = vec![u.into(), (&g.counts).into(), (&g.start).into(), s.into()];
            r.extend(rest.iter().map(|&b| Res::from(b)));
            r
        }
        let run = |ctx: &mut FrameCtx, name: &str, p: &ComputeProgram<Push>, res: &[Res], groups: [u32; 3]| {
            ctx.pass(name, |ctx| p.dispatch(ctx, res, &push, groups));
        };
        run(ctx, STAGE_NAMES[0], &self.density, &cells(u, g, s, &[&self.aux, &self.floor]), fluid);
        run(ctx, STAGE_NAMES[1], &self.normals, &cells(u, g, s, &[&self.aux, &self.normal_buf]), fluid);
        run(
            ctx,
            STAGE_NAMES[2],
            &self.potentials,
            &cells(u, g, s, &[&self.aux, &self.normal_buf, &self.pot, &self.run]),
            fluid,
        );
        run(ctx, STAGE_NAMES[3], &self.advect, &cells(u, g, s, &[&self.floor, &self.pool]), pool);
        let res = [u.into(), s.into(), (&self.pot).into(), (&self.run).into(), (&self.pool).into()];
        run(ctx, STAGE_NAMES[4], &self.spawn, &res, fluid);
        // The header (indirect dispatch groups, 1, 1, count) is zeroed, then the draw stage appends.
        ctx.fill_range(out, 16 * layout.diffuse_header(), 16, 0);
        run(ctx, STAGE_NAMES[5], &self.draw, &[u.into(), (&self.pool).into(), out.into()], pool);
    }

    /// The living diffuse particles (waits for the device), in slot order: by their source's id, then slot.
    pub fn read(&self, gpu: &Arc<Gpu>) -> Result<Vec<Particle>> {
        let bytes = crate::gpu::transfer::read_buffer(gpu, &self.pool, 48 * self.slots as u64)?;
        let v: &[[f32; 12]] = bytemuck::cast_slice(&bytes);
        Ok(v.iter()
            .filter(|s| s[3] > 0.0)
            .map(|s| Particle {
                id: s[8].to_bits(),
                source: s[10].to_bits(),
                kind: Kind::from_code(s[9] as f64).unwrap_or(Kind::Foam),
                position: glam::Vec3::new(s[0], s[1], s[2]),
                velocity: glam::Vec3::new(s[4], s[5], s[6]),
                lifetime: s[3],
                age: s[7],
            })
            .collect())
    }
}
