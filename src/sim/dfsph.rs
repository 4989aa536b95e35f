//! Divergence-free SPH (Bender & Koschier, SCA 2015 and TVCG 2017, "Divergence-Free SPH for Incompressible and
//! Viscous Fluids"; SPlisHSPlasH's TimeStepDFSPH in its density-ratio form), the simulation's second pressure
//! solver (`[sim] solver = "dfsph"`), on the same grid, neighbour lists, colliders and end of step as PBF.
//!
//! One step, every stage a pass with its own name and GPU timestamp:
//! `sim_dfsph_begin` (the grid is built on x, not on a prediction) → `grid` → `sim_reorder` (grid order; it adds
//! Δt·g to the velocities: gravity is applied before the solves) → `sim_neighbours` → `sim_dfsph_alpha` (ρ̂ and
//! the factor α) → the divergence-free solve → the constant-density solve → `sim_dfsph_integrate` (x + Δt v,
//! collisions) → `sim_velocity` → (`sim_vorticity`) → `sim_viscosity` (XSPH; the state and the renderer's
//! particles), the last three shared with PBF. Each solve (`sim_dfsph_divergence`, `sim_dfsph_density`: one
//! timestamp each, [`SOLVE_NAMES`]) is the warm start's `sim_dfsph_update`, `sim_dfsph_rate` (κ from the density
//! change, the error per work group) and `sim_dfsph_check` (the average error against its bound), then up to
//! `max_solver_iterations` × (`sim_dfsph_update`, `sim_dfsph_rate`, `sim_dfsph_check`) dispatched indirectly:
//! the check writes the next iteration's work groups, 0 once converged, so no iteration waits for the host and
//! a converged solve's remaining dispatches do nothing. The walls of the container enter as PBF's do (their
//! density F and its gradient, sim_common.glsl's wall_density); other colliders are position projections.
//!
//! What each solve used (corrections, the average error when it stopped, the steps that ran out of iterations)
//! accumulates on the GPU ([`SolverStats`], `Simulation::solver_stats`).
use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::params::{ADAPTIVE_SPARE, ADAPTIVE_WINDOW};
use super::stages::Neighbours;
use crate::declare_program;
use crate::error::Result;
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu};
use crate::shader_constants::LOCAL_1D;
use crate::shaders;

/// The DFSPH stages in a step's order (timestamp keys and bench rows), beside [`super::STAGE_NAMES`]'s shared ones.
pub const STAGE_NAMES: &[&str] =
    &["sim_dfsph_begin", "sim_dfsph_alpha", SOLVE_NAMES[0], SOLVE_NAMES[1], "sim_dfsph_integrate"];

/// The two solves' passes, each timed whole (its warm start, its first evaluation and every correction it
/// recorded): the divergence-free solve, then the constant-density solve. With `bench --parts` their
/// dispatches are timed too, as the parts `…/update`, `…/rate` and `…/check` (summed per name): a timestamp per
/// dispatch drains lavapipe's pipeline, about 0.1 ms each, and a solve records 3 × `max_solver_iterations`
/// dispatches, most of which find nothing to do once it converged.
pub const SOLVE_NAMES: [&str; 2] = ["sim_dfsph_divergence", "sim_dfsph_density"];

/// Push constants of sim_dfsph_check.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CheckPush {
    /// Work groups of a per-particle dispatch.
    pub groups: u32,
    /// 1: the solve's first evaluation.
    pub init: u32,
    /// Corrections before convergence may stop the solve.
    pub min_iter: u32,
    /// Corrections at most.
    pub max_iter: u32,
    /// The bound on the average error.
    pub eta: f32,
    /// 0: divergence-free solve, 1: constant-density solve.
    pub solve: u32,
}

declare_program!(pub BEGIN: () = compute(shaders::SIM_DFSPH_BEGIN, [Uniform, TexelRead, BufWrite, TexelRead]));
declare_program!(pub ALPHA: () = compute(shaders::SIM_DFSPH_ALPHA, [Uniform, TexelRead, BufRead, TexelRead, TexelRead, BufWrite, BufWrite, BufWrite, BufWrite, BufWrite, BufWrite, BufWrite, BufWrite]));
declare_program!(pub ALPHA_NBR16: () = compute(shaders::SIM_DFSPH_ALPHA_NBR16, [Uniform, TexelRead, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite, BufWrite, BufWrite, BufWrite, BufWrite, BufWrite, BufWrite]));
declare_program!(pub RATE: () = compute(shaders::SIM_DFSPH_RATE, [Uniform, TexelRead, BufRead, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite, BufRead]));
declare_program!(pub RATE_NBR16: () = compute(shaders::SIM_DFSPH_RATE_NBR16, [Uniform, TexelRead, TexelRead, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite, BufRead]));
declare_program!(pub UPDATE: () = compute(shaders::SIM_DFSPH_UPDATE, [Uniform, TexelRead, BufRead, TexelRead, TexelRead, BufWrite, BufWrite, BufWrite]));
declare_program!(pub UPDATE_NBR16: () = compute(shaders::SIM_DFSPH_UPDATE_NBR16, [Uniform, TexelRead, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite, BufWrite]));
declare_program!(pub CHECK: CheckPush = compute(shaders::SIM_DFSPH_CHECK, [Uniform, BufRead, BufWrite, BufWrite]));
// The dynamic body's step: uniforms, body.
declare_program!(pub BODY: () = compute(shaders::SIM_BODY, [Uniform, BufWrite]));
declare_program!(pub INTEGRATE: () = compute(shaders::SIM_DFSPH_INTEGRATE, [Uniform, TexelRead, TexelRead, BufWrite, BufRead, BufWrite]));

/// What the solves did since the last [`Dfsph::clear_stats`], per solve (read back by `Simulation::solver_stats`).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SolveStats {
    /// Steps (solves run).
    pub steps: u32,
    /// Corrections, summed over the steps.
    pub corrections: u32,
    /// The most corrections one step needed.
    pub max_corrections: u32,
    /// The average error when the last solve stopped (a fraction of ρ0: density error, or density change over
    /// a step).
    pub last_error: f32,
    /// The largest of those over the steps.
    pub max_error: f32,
    /// Their mean over the steps.
    pub mean_error: f32,
    /// Steps that stopped at `max_solver_iterations` above the bound.
    pub unconverged: u32,
}

/// Both solves' statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SolverStats {
    /// The divergence-free solve.
    pub divergence: SolveStats,
    /// The constant-density solve.
    pub density: SolveStats,
}

impl SolveStats {
    /// Add `other`'s steps (a later frame's) to these.
    pub fn merge(&mut self, other: &SolveStats) {
        let steps = self.steps + other.steps;
        self.mean_error =
            (self.mean_error * self.steps as f32 + other.mean_error * other.steps as f32) / steps.max(1) as f32;
        self.steps = steps;
        self.corrections += other.corrections;
        self.max_corrections = self.max_corrections.max(other.max_corrections);
        self.last_error = other.last_error;
        self.max_error = self.max_error.max(other.max_error);
        self.unconverged += other.unconverged;
    }

    /// One line: corrections per step, the errors the solve stopped at (percent of ρ0), the steps at the limit.
    pub fn summary(&self) -> String {
        format!(
            "{:.1} corrections per step (most {}), average error {:.4} % (largest {:.4} %), {} of {} steps at the \
             iteration limit",
            self.corrections as f64 / self.steps.max(1) as f64,
            self.max_corrections,
            100.0 * self.mean_error,
            100.0 * self.max_error,
            self.unconverged,
            self.steps
        )
    }
}

impl SolverStats {
    /// Add `other`'s steps (a later frame's) to these.
    pub fn merge(&mut self, other: &SolverStats) {
        self.divergence.merge(&other.divergence);
        self.density.merge(&other.density);
    }

    /// Both solves, labelled: ("constant-density", its stats), ("divergence-free", its stats).
    pub fn labelled(&self) -> [(&'static str, SolveStats); 2] {
        [("constant-density", self.density), ("divergence-free", self.divergence)]
    }

    fn from_words(w: &[u32]) -> SolverStats {
        let one = |b: usize| {
            let steps = w[b];
            SolveStats {
                steps,
                corrections: w[b + 1],
                max_corrections: w[b + 2],
                last_error: f32::from_bits(w[b + 3]),
                max_error: f32::from_bits(w[b + 4]),
                mean_error: f32::from_bits(w[b + 5]) / steps.max(1) as f32,
                unconverged: w[b + 6],
            }
        };
        SolverStats { divergence: one(0), density: one(8) }
    }
}

/// The list readers for one list format.
struct Listed {
    alpha: ComputeProgram,
    /// By solve: [divergence-free, constant-density].
    rate: [ComputeProgram; 2],
    /// Either solve's correction; it sums the κ it applies (the next step's warm start of that solve).
    update: ComputeProgram,
}

/// The DFSPH programs and their buffers.
pub struct Dfsph {
    begin: ComputeProgram,
    integrate: ComputeProgram,
    body: ComputeProgram,
    check: ComputeProgram<CheckPush>,
    /// By list format: [32-bit, 16-bit].
    listed: [Listed; 2],
    /// Per particle: ρ̂ (density / ρ0), the factor α (vec4 texels).
    factor: Buffer,
    /// Per particle: κ (R32F texels).
    kappa: Buffer,
    /// Per particle: the constant-density solve's warm start, half the κ its last step summed (R32F texels).
    kappa_warm: Buffer,
    /// Per particle: the κ this step's constant-density solve applied, summed (R32F texels; the next step's warm
    /// start, in the order the state is written in).
    kappa_sum: Buffer,
    /// Per particle: the divergence-free solve's warm start — the κ its last solve summed, moved into grid order
    /// by sim_reorder, halved in place by sim_dfsph_alpha (R32F texels).
    kappa_v_warm: Buffer,
    /// Per particle: the κ this step's divergence-free solve applied, summed (R32F texels; what sim_reorder
    /// carries into the next step's `kappa_v_warm`).
    kappa_v_sum: Buffer,
    /// Per work group of sim_dfsph_rate: its particles' summed error.
    partials: Buffer,
    /// The next iteration's indirect dispatch (x: work groups, y, z: 1; w: corrections so far).
    args: Buffer,
    /// [`SolverStats`] as words (host-visible: the adaptive count reads the latest without waiting).
    stats: Buffer,
    /// Corrections recorded per solve [divergence-free, constant-density] for the next frame's steps.
    recorded: std::cell::Cell<[u32; 2]>,
    /// The most corrections each solve performed in a step of each recent frame (newest last).
    window: std::cell::RefCell<std::collections::VecDeque<[u32; 2]>>,
}

/// What a DFSPH step reads and writes of the simulation's buffers.
pub struct StepBuffers<'a> {
    /// The uniform block of this frame.
    pub uniforms: &'a Buffer,
    /// The neighbour lists.
    pub neighbours: &'a Neighbours,
    /// The sorted state (grid order; its v has Δt·g added).
    pub sorted: &'a Buffer,
    /// x in grid order.
    pub x: &'a Buffer,
    /// The new positions.
    pub x_new: &'a Buffer,
    /// The velocities the solves correct.
    pub vel: &'a Buffer,
    /// Densities (kg/m³) for the exports.
    pub density: &'a Buffer,
    /// The mesh collider's distances.
    pub sdf: &'a Buffer,
    /// The dynamic body and the impulses on it (`sim::scene::Body`; 64 unused bytes without one).
    pub body: &'a Buffer,
    /// Whether the scene has a dynamic body (`sim_body` runs after the solves).
    pub body_on: bool,
}

impl Dfsph {
    /// The pipelines (`mesh_collider`: sim_common.glsl's specialization constant 1) and buffers for `capacity`
    /// particles.
    pub fn new(gpu: &Arc<Gpu>, capacity: u64, mesh_collider: bool) -> Result<Dfsph> {
        let m = mesh_collider as u32;
        let listed = |alpha, rate, update| -> Result<Listed> {
            Ok(Listed {
                alpha: ComputeProgram::new(gpu, alpha)?,
                rate: [
                    ComputeProgram::specialized(gpu, rate, &[4, m, 0, 0])?,
                    ComputeProgram::specialized(gpu, rate, &[4, m, 0, 1])?,
                ],
                update: ComputeProgram::specialized(gpu, update, &[4, m])?,
            })
        };
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC;
        let cap = capacity.max(1);
        let groups = cap.div_ceil(LOCAL_1D as u64);
        Ok(Dfsph {
            begin: ComputeProgram::new(gpu, &BEGIN)?,
            integrate: ComputeProgram::specialized(gpu, &INTEGRATE, &[4, m])?,
            body: ComputeProgram::new(gpu, &BODY)?,
            check: ComputeProgram::new(gpu, &CHECK)?,
            listed: [listed(&ALPHA, &RATE, &UPDATE)?, listed(&ALPHA_NBR16, &RATE_NBR16, &UPDATE_NBR16)?],
            factor: Buffer::texels(gpu, "sim_dfsph_factor", 16 * cap, usage, vk::Format::R32G32B32A32_SFLOAT)?,
            kappa: Buffer::texels(gpu, "sim_dfsph_kappa", 4 * cap, usage, vk::Format::R32_SFLOAT)?,
            kappa_warm: Buffer::texels(gpu, "sim_dfsph_kappa_warm", 4 * cap, usage, vk::Format::R32_SFLOAT)?,
            kappa_sum: Buffer::texels(gpu, "sim_dfsph_kappa_sum", 4 * cap, usage, vk::Format::R32_SFLOAT)?,
            kappa_v_warm: Buffer::texels(gpu, "sim_dfsph_kappa_v_warm", 4 * cap, usage, vk::Format::R32_SFLOAT)?,
            kappa_v_sum: Buffer::texels(gpu, "sim_dfsph_kappa_v_sum", 4 * cap, usage, vk::Format::R32_SFLOAT)?,
            partials: Buffer::new(gpu, "sim_dfsph_partials", 4 * groups.max(4), usage, MemoryLocation::GpuOnly)?,
            args: Buffer::new(
                gpu,
                "sim_dfsph_args",
                16,
                usage | vk::BufferUsageFlags::INDIRECT_BUFFER,
                MemoryLocation::GpuOnly,
            )?,
            stats: {
                let mut b = Buffer::new(gpu, "sim_dfsph_stats", 64, usage, MemoryLocation::GpuToCpu)?;
                b.write(0, &[0; 64])?;
                b
            },
            recorded: std::cell::Cell::new([0; 2]),
            window: Default::default(),
        })
    }

    /// Choose the corrections the next frame records per solve (before its `clear_stats`): all of
    /// `max_solver_iterations`, or with `adaptive_corrections` the most either solve performed in a step of the
    /// last [`ADAPTIVE_WINDOW`] frames plus [`ADAPTIVE_SPARE`] — all again after a frame where a step stopped at
    /// the recorded count above its bound. Reads the statistics as the device left them, without waiting: the
    /// latest finished frame's, or part of one in flight (a lower maximum, which the window's older frames cover).
    pub fn adapt(&self, p: &super::params::Params) -> Result<()> {
        let max = p.max_solver_iterations;
        if !p.adaptive_corrections {
            self.recorded.set([max; 2]);
            return Ok(());
        }
        let bytes = self.stats.read()?;
        let w: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes[..64]);
        let mut window = self.window.borrow_mut();
        let before = self.recorded.get();
        let mut next = [max; 2];
        // Steps counted: this reading holds a frame's statistics (zero right after a clear).
        if w[0] > 0 && w[8] > 0 {
            window.push_back([w[2], w[10]]);
            while window.len() > ADAPTIVE_WINDOW {
                window.pop_front();
            }
        }
        for s in 0..2 {
            // A step stopped at the recorded count above its bound: record all again.
            let cut_short = w[8 * s] > 0 && w[8 * s + 6] > 0 && before[s] > 0 && before[s] < max;
            let most = window.iter().map(|m| m[s]).max();
            next[s] = match most {
                Some(m) if !cut_short => (m + ADAPTIVE_SPARE).clamp(2 + ADAPTIVE_SPARE, max),
                _ => max,
            };
        }
        if next.contains(&max) && window.is_empty() {
            next = [max; 2];
        }
        self.recorded.set(next);
        Ok(())
    }

    /// Corrections recorded per solve [divergence-free, constant-density] for the latest frame's steps.
    pub fn recorded(&self) -> [u32; 2] {
        self.recorded.get()
    }

    /// Zero the solver statistics (recorded).
    pub fn clear_stats(&self, ctx: &mut FrameCtx) {
        ctx.fill(&self.stats, 0);
    }

    /// Forget the warm start of particles `from` … `from + count` (recorded): new or reset particles have no
    /// last κ (the others keep theirs: an emitter's new layer does not cool the water already there).
    pub fn clear_warm_start(&self, ctx: &mut FrameCtx, from: u32, count: u32) {
        if count > 0 {
            ctx.fill_range(&self.kappa_sum, 4 * from as u64, 4 * count as u64, 0);
            ctx.fill_range(&self.kappa_v_sum, 4 * from as u64, 4 * count as u64, 0);
        }
    }

    /// What sim_reorder carries for DFSPH: (the divergence-free solve's κ sums in the state's order, where they
    /// go in grid order: the warm start).
    pub fn carried(&self) -> (&Buffer, &Buffer) {
        (&self.kappa_v_sum, &self.kappa_v_warm)
    }

    /// The statistics since the last clear (waits for the device).
    pub fn read_stats(&self, gpu: &Arc<Gpu>) -> Result<SolverStats> {
        let b = crate::gpu::transfer::read_buffer(gpu, &self.stats, 64)?;
        let w: Vec<u32> = bytemuck::pod_collect_to_vec(&b);
        Ok(SolverStats::from_words(&w))
    }

    /// `sim_dfsph_begin`: x of the unsorted state → `pred` (what the grid sorts).
    pub fn begin(&self, ctx: &mut FrameCtx, u: &Buffer, state: &Buffer, pred: &Buffer, n: u32) {
        ctx.pass("sim_dfsph_begin", |ctx| {
            let res = [u.into(), state.into(), pred.into(), (&self.kappa_sum).into()];
            self.begin.dispatch(ctx, &res, &(), [n.div_ceil(LOCAL_1D), 1, 1])
        });
    }

    /// Everything between the neighbour lists and sim_velocity: ρ̂ and α, the two solves, the new positions.
    pub fn solve(&self, ctx: &mut FrameCtx, b: &StepBuffers, p: &super::params::Params, n: u32) {
        let groups = n.div_ceil(LOCAL_1D).max(1);
        let l = &self.listed[b.neighbours.packed as usize];
        ctx.pass("sim_dfsph_alpha", |ctx| {
            let res = b.neighbours.bound(
                b.uniforms,
                &[
                    b.x,
                    b.sorted,
                    &self.factor,
                    b.vel,
                    b.density,
                    &self.kappa_warm,
                    &self.kappa_sum,
                    &self.kappa_v_warm,
                    &self.kappa_v_sum,
                    b.body,
                ],
            );
            l.alpha.dispatch(ctx, &res, &(), [groups, 1, 1]);
        });
        // The divergence-free solve (at least one correction, SPlisHSPlasH's rule), then the constant-density
        // solve (at least two) — their bounds as fractions of ρ0.
        let solves = [(0usize, 1u32, p.max_divergence_error), (1, 2, p.max_density_error)];
        let recorded = self.recorded.get().map(|r| if r == 0 { p.max_solver_iterations } else { r });
        for (solve, min_iter, percent) in solves {
            // The corrections recorded: the check stops the solve there (counted as at its limit when above the
            // bound, which makes the next frame record all).
            let limit = recorded[solve].min(p.max_solver_iterations);
            let rate = b.neighbours.bound(b.uniforms, &[b.x, b.vel, &self.factor, &self.kappa, &self.partials, b.body]);
            let (warm, sum) = [(&self.kappa_v_warm, &self.kappa_v_sum), (&self.kappa_warm, &self.kappa_sum)][solve];
            let update = b.neighbours.bound(b.uniforms, &[b.x, &self.kappa, b.vel, sum, b.body]);
            // The warm start (Bender & Koschier 2017 §4.4): one correction with half the κ each particle's last
            // solve of this kind summed.
            let warm = b.neighbours.bound(b.uniforms, &[b.x, warm, b.vel, sum, b.body]);
            let check_res = [b.uniforms.into(), (&self.partials).into(), (&self.args).into(), (&self.stats).into()];
            let check = |init: u32| CheckPush {
                groups,
                init,
                min_iter,
                max_iter: limit,
                eta: percent * 0.01,
                solve: solve as u32,
            };
            let name = SOLVE_NAMES[solve];
            let (u, r, c) = (format!("{name}/update"), format!("{name}/rate"), format!("{name}/check"));
            ctx.pass(name, |ctx| {
                ctx.part(&u, |ctx| l.update.dispatch(ctx, &warm, &(), [groups, 1, 1]));
                ctx.part(&r, |ctx| l.rate[solve].dispatch(ctx, &rate, &(), [groups, 1, 1]));
                ctx.part(&c, |ctx| self.check.dispatch(ctx, &check_res, &check(1), [1, 1, 1]));
                for _ in 0..limit {
                    ctx.part(&u, |ctx| l.update.dispatch_indirect(ctx, &update, &(), &self.args, 0));
                    ctx.part(&r, |ctx| l.rate[solve].dispatch_indirect(ctx, &rate, &(), &self.args, 0));
                    ctx.part(&c, |ctx| self.check.dispatch(ctx, &check_res, &check(0), [1, 1, 1]));
                }
            });
        }
        ctx.pass("sim_dfsph_integrate", |ctx| {
            let res = [b.uniforms.into(), b.x.into(), b.vel.into(), b.x_new.into(), b.sdf.into(), b.body.into()];
            self.integrate.dispatch(ctx, &res, &(), [groups, 1, 1]);
        });
        if b.body_on {
            ctx.pass("sim_body", |ctx| self.body.dispatch(ctx, &[b.uniforms.into(), b.body.into()], &(), [1, 1, 1]));
        }
    }
}
