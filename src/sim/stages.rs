//! The simulation's stages: one program each, named like its shader (`sim_predict` ↔
//! shaders_glsl/sim_predict.comp ↔ debug label ↔ timestamp key ↔ JSON key). The neighbour grid between
//! predict and reorder is the shared `grid` pass (src/compute/grid.rs). Binding 0 of every stage is the
//! simulation's uniform block (sim_common.glsl). The stages live in one module because they share that block
//! and the particle layout; each is one declaration and one small record function.
use std::sync::Arc;

use crate::compute::grid::GridBuffers;
use crate::declare_program;
use crate::error::Result;
use crate::gpu::ProgramDecl;
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu, Res};

/// Every particle's neighbour list (sim_neighbours.comp's outputs, read by the later stages at bindings 1, 2).
pub struct Neighbours {
    /// Neighbours per particle.
    pub count: Buffer,
    /// MAX_NEIGHBOURS indices per particle; where 16-bit lists are possible (at most 65,536 particles), with an
    /// RGBA32UI texel view (eight 16-bit indices per texel) for the NBR16 readers.
    pub list: Buffer,
    /// Particles that had more neighbours than fit (one counter).
    pub overflow: Buffer,
    /// The lists' format: 16-bit indices, two per word (the NBR16 programs), or 32-bit ones. 16-bit lists need
    /// at most 65,536 particles; on lavapipe every storage-buffer index load is a loop over the SIMD lanes,
    /// while the 16-bit lists are read eight indices per branch-free texel fetch (docs/simulation.md, commits c680c5d and 434fdd1).
    /// The same visits in the same order either way.
    pub packed: bool,
}

impl Neighbours {
    /// The bindings of a stage that walks the lists: the uniform block `u`, the lists (bindings 1, 2), then
    /// `rest` (PBF's list stages and DFSPH's, src/sim/dfsph.rs).
    pub fn bound<'a>(&'a self, u: &'a Buffer, rest: &[&'a Buffer]) -> Vec<Res<'a>> {
        let mut r: Vec<Res> = vec![u.into(), (&self.count).into(), (&self.list).into()];
        r.extend(rest.iter().map(|&b| Res::from(b)));
        r
    }

    /// Most particles 16-bit lists can index.
    pub const PACKED_MAX: u64 = 1 << 16;

    /// Whether a simulation of `capacity` particles can use 16-bit lists (and its list buffer gets their view).
    pub fn packable(capacity: u64) -> bool {
        capacity <= Self::PACKED_MAX
    }
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

declare_program!(pub PREDICT: () = compute(shaders::SIM_PREDICT, [Uniform, TexelRead, BufWrite, BufRead]));
declare_program!(pub REORDER: () = compute(
    shaders::SIM_REORDER,
    [Uniform, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite, TexelRead, TexelRead, TexelRead]
));
// The reorder that moves one more float per particle with it (then: carry in, carry out).
declare_program!(pub REORDER_CARRY: () = compute(
    shaders::SIM_REORDER_CARRY,
    [Uniform, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite, TexelRead, TexelRead, TexelRead, TexelRead, BufWrite]
));
// The stages that write or read the neighbour lists, each twice: for 32-bit lists, and for 16-bit ones (the
// shader compiled with NBR16, `_NBR16`). sim_neighbours writes either format as a storage buffer;
// the readers get the lists at bindings 1 (counts) and 2 (the lists: a storage buffer of 32-bit indices, or
// the 16-bit lists' texel view, eight indices per texel), then `rest`.
declare_program!(pub NEIGHBOURS: () = compute(
    shaders::SIM_NEIGHBOURS,
    [Uniform, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite, BufWrite]
));
declare_program!(pub NEIGHBOURS_NBR16: () = compute(
    shaders::SIM_NEIGHBOURS_NBR16,
    [Uniform, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite, BufWrite]
));
macro_rules! list_reader {
    (($name:ident, $nbr16:ident) = compute($shader:ident, $shader16:ident, [$($slot:ident),*])) => {
        declare_program!(pub $name: () = compute(shaders::$shader, [Uniform, TexelRead, BufRead, $($slot),*]));
        declare_program!(pub $nbr16: () = compute(shaders::$shader16, [Uniform, TexelRead, TexelRead, $($slot),*]));
    };
}
list_reader!((DENSITY, DENSITY_NBR16) = compute(SIM_DENSITY, SIM_DENSITY_NBR16, [TexelRead, BufWrite, BufWrite]));
list_reader!((SOLVE, SOLVE_NBR16) = compute(SIM_SOLVE, SIM_SOLVE_NBR16, [TexelRead, BufWrite, BufRead]));
declare_program!(pub VELOCITY: () = compute(shaders::SIM_VELOCITY, [Uniform, TexelRead, TexelRead, BufWrite]));
list_reader!(
    (VORTICITY, VORTICITY_NBR16) = compute(SIM_VORTICITY, SIM_VORTICITY_NBR16, [TexelRead, TexelRead, BufWrite])
);
list_reader!(
    (VISCOSITY, VISCOSITY_NBR16) = compute(
        SIM_VISCOSITY,
        SIM_VISCOSITY_NBR16,
        [TexelRead, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite, BufWrite]
    )
);

/// The programs of the list stages for one list format.
struct Listed {
    neighbours: ComputeProgram,
    density: ComputeProgram,
    solve: ComputeProgram,
    vorticity: ComputeProgram,
    viscosity: ComputeProgram,
}

impl Listed {
    /// The pipelines of `[neighbours, density, solve, vorticity, viscosity]`; `spec`: sim_solve's and
    /// sim_viscosity's specialization constants ([`Stages::new`]).
    fn new(
        gpu: &Arc<Gpu>,
        [nb, density, solve, vorticity, viscosity]: [&ProgramDecl<()>; 5],
        spec: &[u32],
    ) -> Result<Listed> {
        Ok(Listed {
            neighbours: ComputeProgram::new(gpu, nb)?,
            density: ComputeProgram::new(gpu, density)?,
            solve: ComputeProgram::specialized(gpu, solve, spec)?,
            vorticity: ComputeProgram::new(gpu, vorticity)?,
            viscosity: ComputeProgram::specialized(gpu, viscosity, spec)?,
        })
    }
}

/// The stages' programs.
pub struct Stages {
    predict: ComputeProgram,
    reorder: ComputeProgram,
    /// The reorder with one more value carried ([`Stages::reorder`]'s `carry`).
    reorder_carry: ComputeProgram,
    velocity: ComputeProgram,
    /// By list format: [32-bit, 16-bit].
    listed: [Listed; 2],
}

fn groups(n: u32) -> [u32; 3] {
    [n.div_ceil(LOCAL_1D), 1, 1]
}

impl Stages {
    /// Build the pipelines, with what stays fixed for a simulation's life built into them as specialization
    /// constants (sim_common.glsl): 0, the s_corr exponent ([`super::params::Params::scorr_n`], sim_solve); 1, whether
    /// the scene has a mesh collider (sim_predict, sim_solve); 2, whether vorticity confinement is on
    /// (sim_viscosity).
    pub fn new(gpu: &Arc<Gpu>, scorr_n: u32, mesh_collider: bool, confine: bool) -> Result<Stages> {
        let spec = [scorr_n, mesh_collider as u32, confine as u32];
        Ok(Stages {
            predict: ComputeProgram::specialized(gpu, &PREDICT, &spec)?,
            reorder: ComputeProgram::new(gpu, &REORDER)?,
            reorder_carry: ComputeProgram::new(gpu, &REORDER_CARRY)?,
            velocity: ComputeProgram::new(gpu, &VELOCITY)?,
            listed: [
                Listed::new(gpu, [&NEIGHBOURS, &DENSITY, &SOLVE, &VORTICITY, &VISCOSITY], &spec)?,
                Listed::new(
                    gpu,
                    [&NEIGHBOURS_NBR16, &DENSITY_NBR16, &SOLVE_NBR16, &VORTICITY_NBR16, &VISCOSITY_NBR16],
                    &spec,
                )?,
            ],
        })
    }

    /// One stage: `program` over the `n` particles with `res` bound in order, in a pass named `name` (its debug
    /// label and timestamp key).
    fn run(&self, ctx: &mut FrameCtx, name: &str, program: &ComputeProgram, res: &[Res], n: u32) {
        ctx.pass(name, |ctx| program.dispatch(ctx, res, &(), groups(n)));
    }

    /// The list stages' programs for `g`'s format.
    fn listed(&self, g: &Neighbours) -> &Listed {
        &self.listed[g.packed as usize]
    }

    /// A stage that walks the neighbour lists: the uniform block, the lists (bindings 1, 2), then `rest`; its
    /// program for `g`'s format.
    #[allow(clippy::too_many_arguments)]
    fn run_listed(
        &self,
        ctx: &mut FrameCtx,
        name: &str,
        program: fn(&Listed) -> &ComputeProgram,
        u: &Buffer,
        g: &Neighbours,
        rest: &[&Buffer],
        n: u32,
    ) {
        self.run(ctx, name, program(self.listed(g)), &g.bound(u, rest), n);
    }

    /// `sim_predict`: state → pred (x* from v + Δt g, which sim_reorder stores); `sdf`: the mesh collider's
    /// distances.
    pub fn predict(&self, ctx: &mut FrameCtx, u: &Buffer, state: &Buffer, pred: &Buffer, sdf: &Buffer, n: u32) {
        self.run(ctx, "sim_predict", &self.predict, &[u.into(), state.into(), pred.into(), sdf.into()], n);
    }

    /// `sim_reorder`: state (its v + Δt g) and pred moved into grid order (ascending index within a cell).
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
        carry: Option<(&Buffer, &Buffer)>,
        n: u32,
    ) {
        let mut res: Vec<Res> = vec![
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
        let program = match carry {
            Some((from, to)) => {
                res.extend([Res::from(from), Res::from(to)]);
                &self.reorder_carry
            }
            None => &self.reorder,
        };
        self.run(ctx, "sim_reorder", program, &res, n);
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
        self.run(ctx, "sim_neighbours", &self.listed(nb).neighbours, &res, n);
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
        self.run_listed(ctx, "sim_density", |l| &l.density, u, g, &[pred, lambda, density], n);
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
        self.run_listed(ctx, "sim_solve", |l| &l.solve, u, g, &[pos_lambda, next, sdf], n);
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
        self.run_listed(ctx, "sim_vorticity", |l| &l.vorticity, u, g, &[pred, vel, omega], n);
    }

    /// `sim_viscosity`: confinement + XSPH → the new state and the render particles; the largest speed into
    /// `speed` (a max over the frame's steps).
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
        speed: &Buffer,
        n: u32,
    ) {
        let rest = [pred, vel, omega, sorted, state, out, speed];
        self.run_listed(ctx, "sim_viscosity", |l| &l.viscosity, u, g, &rest, n);
    }
}
