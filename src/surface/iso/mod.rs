//! The iso surface (the default): the SPH colour field — splashsurf's: cubic spline of support 4 r,
//! per-particle volume normalisation, threshold 0.6 — ray-cast per pixel on the GPU from the splatted bound
//! spheres to their farthest exit; with `[iso] smoothing` > 0 the field is first smoothed in 3D where the water
//! is bulk (`iso_volume`: a sparse lattice where the particles are). It owns the particles' grid and the smoothed field's lattice, rebuilt when
//! the particles or the kernel change. A new set's host work (its box, the lattice's bricks) may come computed ahead
//! by its loader (`super::grid::analyse`). `crate::field::iso` is the CPU reference of all of it.

use crate::error::Result;
use crate::gpu::recording::{Part, Recording};
use crate::gpu::FrameCtx;
use crate::passes::iso::IsoBuffers;

use super::grid::IsoResources;
use super::splat::record_splat;
use super::{Kernels, Prepare, SurfaceFrame, Technique};

/// The iso-surface technique.
#[derive(Default)]
pub struct IsoSurface {
    /// The particles' grid, weights, kernels and smoothed field.
    pub grid: IsoResources,
}

impl IsoSurface {
    /// Its particle grid, weights, kernels and smoothed field on the device, once built (for tests and the
    /// work counts).
    pub fn grid(&self) -> Option<&IsoBuffers> {
        self.grid.buffers()
    }
}

impl Technique for IsoSurface {
    fn prepare(&mut self, p: &Prepare) -> Result<()> {
        self.grid.prepare(p, true)
    }

    fn record_kernels<'a>(&'a self, rec: &mut Recording, f: &SurfaceFrame<'a>) -> Option<Kernels<'a>> {
        self.grid.record(rec.part(Part::Fluid), f, true);
        None
    }

    fn strays(&self) -> Option<(u64, usize)> {
        self.grid.strays()
    }

    fn record_depth(&self, ctx: &mut FrameCtx, f: &SurfaceFrame, _: Option<Kernels>) -> Result<()> {
        let back = record_splat(ctx, f)?;
        let t = f.targets;
        if let (Some(grid), Some(queue), Some(params)) = (self.grid.buffers(), &t.iso_queue, self.grid.params()) {
            // The rasterised splats do not write a far bound: the march then runs to the grid's box.
            f.passes.iso.record(ctx, f.frame, grid, params, &t.depth, back, queue, f.info);
        }
        Ok(())
    }
}
