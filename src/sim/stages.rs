//! The simulation's stages: one program each, named like its shader (`sim_predict` ↔
//! shaders_glsl/sim_predict.comp ↔ debug label ↔ timestamp key ↔ JSON key). The neighbour grid between
//! predict and reorder is the shared `grid` pass (src/passes/grid.rs). Binding 0 of every stage is the
//! simulation's uniform block (sim_common.glsl). The stages live in one module because they share that block
//! and the particle layout; each is one declaration and one small record function.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu, Res};
use crate::passes::grid::GridBuffers;

/// Every particle's neighbour list (sim_neighbours.comp's outputs, read by the later stages at bindings 1, 2).
pub struct Neighbours {
    /// Neighbours per particle.
    pub count: Buffer,
    /// MAX_NEIGHBOURS indices per particle.
    pub list: Buffer,
    /// Particles that had more neighbours than fit (one counter).
    pub overflow: Buffer,
}
use crate::shader_constants::LOCAL_1D;
use crate::shaders;

/// Every stage of a step, in order (timestamp keys and bench rows).
pub const STAGE_NAMES: &[&str] = &[
    "sim_predict",
    "grid",
    "sim_reorder",
    "sim_neighbours",
    "sim_density",
    "sim_solve",
    "sim_velocity",
    "sim_vorticity",
    "sim_viscosity",
];

declare_program!(pub PREDICT: () = compute(shaders::SIM_PREDICT, [Uniform, BufWrite, BufWrite, BufRead]));
declare_program!(pub REORDER: () = compute(
    shaders::SIM_REORDER,
    [Uniform, TexelRead, BufRead, BufRead, BufWrite, BufWrite, BufRead, BufRead, BufRead]
));
declare_program!(pub NEIGHBOURS: () = compute(
    shaders::SIM_NEIGHBOURS,
    [Uniform, BufRead, BufRead, TexelRead, BufWrite, BufWrite, BufWrite]
));
declare_program!(pub DENSITY: () = compute(shaders::SIM_DENSITY, [Uniform, BufRead, BufRead, TexelRead, BufWrite, BufWrite]));
declare_program!(pub SOLVE: () = compute(shaders::SIM_SOLVE, [Uniform, BufRead, BufRead, TexelRead, BufWrite, BufRead]));
declare_program!(pub VELOCITY: () = compute(shaders::SIM_VELOCITY, [Uniform, BufRead, BufRead, BufWrite]));
declare_program!(pub VORTICITY: () = compute(shaders::SIM_VORTICITY, [Uniform, BufRead, BufRead, TexelRead, TexelRead, BufWrite]));
declare_program!(pub VISCOSITY: () = compute(
    shaders::SIM_VISCOSITY,
    [Uniform, BufRead, BufRead, TexelRead, TexelRead, TexelRead, BufRead, BufWrite, BufWrite]
));

/// The stages' programs.
pub struct Stages {
    predict: ComputeProgram,
    reorder: ComputeProgram,
    neighbours: ComputeProgram,
    density: ComputeProgram,
    solve: ComputeProgram,
    velocity: ComputeProgram,
    vorticity: ComputeProgram,
    viscosity: ComputeProgram,
}

fn groups(n: u32) -> [u32; 3] {
    [n.div_ceil(LOCAL_1D), 1, 1]
}

impl Stages {
    /// Build the pipelines.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Stages> {
        Ok(Stages {
            predict: ComputeProgram::new(gpu, &PREDICT)?,
            reorder: ComputeProgram::new(gpu, &REORDER)?,
            neighbours: ComputeProgram::new(gpu, &NEIGHBOURS)?,
            density: ComputeProgram::new(gpu, &DENSITY)?,
            solve: ComputeProgram::new(gpu, &SOLVE)?,
            velocity: ComputeProgram::new(gpu, &VELOCITY)?,
            vorticity: ComputeProgram::new(gpu, &VORTICITY)?,
            viscosity: ComputeProgram::new(gpu, &VISCOSITY)?,
        })
    }

    /// One stage: `program` over the `n` particles with `res` bound in order, in a pass named `name` (its debug
    /// label and timestamp key).
    fn run(&self, ctx: &mut FrameCtx, name: &str, program: &ComputeProgram, res: &[Res], n: u32) {
        ctx.pass(name, |ctx| program.dispatch(ctx, res, &(), groups(n)));
    }

    /// A stage that walks the neighbour lists: the uniform block, the lists (bindings 1, 2), then `rest`.
    #[allow(clippy::too_many_arguments)]
    fn run_listed(
        &self,
        ctx: &mut FrameCtx,
        name: &str,
        program: &ComputeProgram,
        u: &Buffer,
        g: &Neighbours,
        rest: &[&Buffer],
        n: u32,
    ) {
        let mut res: Vec<Res> = vec![u.into(), (&g.count).into(), (&g.list).into()];
        res.extend(rest.iter().map(|&b| Res::from(b)));
        self.run(ctx, name, program, &res, n);
    }

    /// `sim_predict`: state (v += Δt g) → pred (x*); `sdf`: the mesh collider's distances.
    pub fn predict(&self, ctx: &mut FrameCtx, u: &Buffer, state: &Buffer, pred: &Buffer, sdf: &Buffer, n: u32) {
        self.run(ctx, "sim_predict", &self.predict, &[u.into(), state.into(), pred.into(), sdf.into()], n);
    }

    /// `sim_reorder`: state and pred moved into grid order (ascending index within a cell).
    #[allow(clippy::too_many_arguments)]
    pub fn reorder(
        &self,
        ctx: &mut FrameCtx,
        u: &Buffer,
        g: &GridBuffers,
        state: &Buffer,
        pred: &Buffer,
        state_out: &Buffer,
        pred_out: &Buffer,
        n: u32,
    ) {
        let res = [
            u.into(),
            (&g.order).into(),
            state.into(),
            pred.into(),
            state_out.into(),
            pred_out.into(),
            (&g.keys).into(),
            (&g.start).into(),
            (&g.counts).into(),
        ];
        self.run(ctx, "sim_reorder", &self.reorder, &res, n);
    }

    /// `sim_neighbours`: grid, pred → the neighbour lists.
    pub fn neighbours(&self, ctx: &mut FrameCtx, u: &Buffer, g: &GridBuffers, pred: &Buffer, nb: &Neighbours, n: u32) {
        let res = [
            u.into(),
            (&g.counts).into(),
            (&g.start).into(),
            pred.into(),
            (&nb.count).into(),
            (&nb.list).into(),
            (&nb.overflow).into(),
        ];
        self.run(ctx, "sim_neighbours", &self.neighbours, &res, n);
    }

    /// `sim_density`: pred → pos_lambda (x*, λ), density.
    #[allow(clippy::too_many_arguments)]
    pub fn density(
        &self,
        ctx: &mut FrameCtx,
        u: &Buffer,
        g: &Neighbours,
        pred: &Buffer,
        lambda: &Buffer,
        density: &Buffer,
        n: u32,
    ) {
        self.run_listed(ctx, "sim_density", &self.density, u, g, &[pred, lambda, density], n);
    }

    /// `sim_solve`: pos_lambda (and the mesh collider's distances) → the next iterate.
    #[allow(clippy::too_many_arguments)]
    pub fn solve(
        &self,
        ctx: &mut FrameCtx,
        u: &Buffer,
        g: &Neighbours,
        pos_lambda: &Buffer,
        next: &Buffer,
        sdf: &Buffer,
        n: u32,
    ) {
        self.run_listed(ctx, "sim_solve", &self.solve, u, g, &[pos_lambda, next, sdf], n);
    }

    /// `sim_velocity`: (x* − x)/Δt → vel.
    pub fn velocity(&self, ctx: &mut FrameCtx, u: &Buffer, state: &Buffer, pred: &Buffer, vel: &Buffer, n: u32) {
        self.run(ctx, "sim_velocity", &self.velocity, &[u.into(), state.into(), pred.into(), vel.into()], n);
    }

    /// `sim_vorticity`: vel → omega.
    #[allow(clippy::too_many_arguments)]
    pub fn vorticity(
        &self,
        ctx: &mut FrameCtx,
        u: &Buffer,
        g: &Neighbours,
        pred: &Buffer,
        vel: &Buffer,
        omega: &Buffer,
        n: u32,
    ) {
        self.run_listed(ctx, "sim_vorticity", &self.vorticity, u, g, &[pred, vel, omega], n);
    }

    /// `sim_viscosity`: confinement + XSPH → the new state and the render particles.
    #[allow(clippy::too_many_arguments)]
    pub fn viscosity(
        &self,
        ctx: &mut FrameCtx,
        u: &Buffer,
        g: &Neighbours,
        pred: &Buffer,
        vel: &Buffer,
        omega: &Buffer,
        sorted: &Buffer,
        state: &Buffer,
        out: &Buffer,
        n: u32,
    ) {
        self.run_listed(ctx, "sim_viscosity", &self.viscosity, u, g, &[pred, vel, omega, sorted, state, out], n);
    }
}
