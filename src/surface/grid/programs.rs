//! The grid's programs on the device: the particles sorted into the grid (the `grid` pass,
//! `crate::compute::grid`, then iso_gather.comp: the sorted points and the cell table) and `iso_density` (each
//! sorted point's weight 1/n_j and neighbour count c_j, iso_density.comp; each cell's empty distance,
//! iso_empty.comp, which the casts skip empty space by). Shaders in shaders_glsl/iso/. CPU reference:
//! `IsoGrid::build`, `IsoGrid::inv_density` in src/field/iso/mod.rs.
//! In: the particle buffer. Out: `IsoBuffers` (points, cells, weighted, counts, cells_empty).
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu};
use crate::passes::LOCAL_1D;
use crate::shaders;

use super::buffers::{IsoBuffers, IsoPush};

/// The weights' pass (shaders_glsl/iso/iso_density.comp), recorded only when the particles changed.
pub const DENSITY_NAME: &str = "iso_density";

/// The grid's programs, built once per device (by whichever technique first needs the grid).
pub struct GridPrograms {
    grid: crate::compute::grid::NeighbourGrid,
    gather: ComputeProgram<GatherPush>,
    density: ComputeProgram<IsoPush>,
    order: ComputeProgram<IsoPush>,
    empty: [ComputeProgram<EmptyPush>; 3],
}

/// Push constants of iso_gather.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GatherPush {
    /// Points.
    pub n: u32,
    /// Cells.
    pub cells: u32,
}

// Gather: particles, order, start, counts → sorted points, cell table.
declare_program!(pub GATHER: GatherPush = compute(shaders::ISO_GATHER, [BufRead, BufRead, BufRead, BufRead, BufRead, BufWrite, BufWrite]));

// Density: frame, grid points, cell table → the weighted points (xyz, 1/n_j), the neighbour counts (c_j, 0),
// the lattice sums (g_j, m_j).
declare_program!(pub DENSITY: IsoPush = compute(shaders::ISO_DENSITY, [Uniform, TexelRead, TexelRead, BufWrite, BufWrite, BufWrite]));
// Order: frame, grid points, cell table, the lattice sums → the counts' o_j.
declare_program!(pub ORDER: IsoPush = compute(shaders::ISO_DENSITY_ORDER, [Uniform, TexelRead, TexelRead, TexelRead, BufWrite]));
// The cells' empty distance, an axis per dispatch: cell table → scratch .x; scratch .x → .y; cell table and
// scratch .y → the casts' cell table.
declare_program!(pub EMPTY_X: EmptyPush = compute(shaders::ISO_EMPTY_X, [Uniform, TexelRead, BufWrite]));
declare_program!(pub EMPTY_Y: EmptyPush = compute(shaders::ISO_EMPTY_Y, [Uniform, BufWrite]));
declare_program!(pub EMPTY_Z: EmptyPush = compute(shaders::ISO_EMPTY_Z, [Uniform, TexelRead, BufRead, BufWrite]));

/// Push constants of iso_empty.comp: cells per axis, and all cells.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct EmptyPush {
    /// xyz: cells per axis; w: cells.
    pub dims: [u32; 4],
}

impl GridPrograms {
    /// Build the programs (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(GridPrograms {
            grid: crate::compute::grid::NeighbourGrid::new(gpu)?,
            gather: ComputeProgram::new(gpu, &GATHER)?,
            density: ComputeProgram::new(gpu, &DENSITY)?,
            order: ComputeProgram::new(gpu, &ORDER)?,
            empty: [
                ComputeProgram::new(gpu, &EMPTY_X)?,
                ComputeProgram::new(gpu, &EMPTY_Y)?,
                ComputeProgram::new(gpu, &EMPTY_Z)?,
            ],
        })
    }

    /// When `b` has a GPU grid due for a rebuild: sort the first `n` particles of `particles` into it (the
    /// `grid` pass) and gather the sorted points and the cell table.
    pub fn record_grid(&self, ctx: &mut FrameCtx, particles: &Buffer, n: u32, b: &IsoBuffers) {
        let Some(g) = &b.gpu else { return };
        if !b.rebuild.replace(false) {
            return;
        }
        ctx.pass(crate::compute::grid::NAME, |ctx| {
            self.grid.record(ctx, particles, n, g);
            let cells = g.shape.cells();
            let (order, start, counts, keys) = (&g.order, &g.start, &g.counts, &g.keys);
            let res = [
                particles.into(),
                order.into(),
                start.into(),
                counts.into(),
                keys.into(),
                (&b.points).into(),
                (&b.cells).into(),
            ];
            self.gather.dispatch(ctx, &res, &GatherPush { n, cells }, [n.max(cells).div_ceil(LOCAL_1D), 1, 1]);
        });
    }

    /// When `b`'s weights are stale: the `iso_density` pass, each sorted point with its weight 1/n_j and its
    /// neighbour count; with `order`, when the counts do not hold them yet, also each point's lattice order (its own
    /// timestamp, so sequences, where it runs every frame, show its cost).
    pub fn record_density(&self, ctx: &mut FrameCtx, frame: &Buffer, b: &IsoBuffers, order: bool) {
        let density = b.weights_stale.replace(false);
        if density {
            b.ordered.set(false);
        }
        let order = order && !b.ordered.get();
        if !density && !order {
            return;
        }
        b.ordered.set(b.ordered.get() || order);
        ctx.pass(DENSITY_NAME, |ctx| {
            let n = b.shape.dims[3];
            let (points, cells) = ((&b.points).into(), (&b.cells).into());
            if density {
                let bufs = [frame.into(), points, cells, (&b.weighted).into(), (&b.counts).into(), (&b.lattice).into()];
                self.density.dispatch(ctx, &bufs, &b.shape, [n.div_ceil(LOCAL_1D), 1, 1]);
            }
            if order {
                let bufs = [frame.into(), points, cells, (&b.lattice).into(), (&b.counts).into()];
                self.order.dispatch(ctx, &bufs, &b.shape, [n.div_ceil(LOCAL_1D), 1, 1]);
            }
            if density {
                let d = b.shape.dims;
                let cells = d[0] * d[1] * d[2];
                let push = EmptyPush { dims: [d[0], d[1], d[2], cells] };
                let g = [cells.div_ceil(LOCAL_1D), 1, 1];
                let (table, scratch) = ((&b.cells).into(), (&b.empty_scratch).into());
                self.empty[0].dispatch(ctx, &[frame.into(), table, scratch], &push, g);
                self.empty[1].dispatch(ctx, &[frame.into(), scratch], &push, g);
                self.empty[2].dispatch(ctx, &[frame.into(), table, scratch, (&b.cells_empty).into()], &push, g);
            }
        });
    }
}
