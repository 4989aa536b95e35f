//! The iso surface (the default): the SPH colour field — splashsurf's: cubic spline of support 4 r,
//! per-particle volume normalisation, threshold 0.6 — ray-cast per pixel on the GPU from the splatted bound
//! spheres to their farthest exit; with `[iso] smoothing` > 0 the field is first smoothed in 3D where the water
//! is bulk (`iso_volume`: a sparse lattice where the particles are). A new set's host work (its box, the
//! lattice's bricks) may come computed ahead by its loader (`super::grid::analyse`). `crate::field::iso` and
//! `crate::field::volume` are the CPU reference of all of it.
//!
//! Everything the technique is lives in this folder, its shaders in shaders_glsl/iso/: [`params`] (the `[iso]`
//! section, its check and world units), [`cast`] (the `iso` pass), [`volume`] (the `iso_volume` pass and its
//! lattice), [`queue`] (the cast's queue of unfinished rays), [`targets`] (its frame resources: the far bound
//! and the queue). The particles' grid and weights it shares with the spheres' ellipsoids (`super::grid`), the
//! depth splat with the spheres (`super::splat`).

pub mod cast;
pub mod params;
pub mod queue;
pub mod targets;
pub mod volume;

use crate::error::Result;
use crate::gpu::recording::{Part, Recording};
use crate::gpu::FrameCtx;

use super::grid::{IsoBuffers, IsoResources};
use super::splat::record_splat;
use super::{Kernels, Prepare, SurfaceFrame, Technique};
use cast::IsoCast;
use queue::IsoQueue;
use targets::IsoTargets;
use volume::{IsoVolume, VolumePrograms};

/// The iso-surface technique: its grid, its smoothed field, its frame resources and its programs.
#[derive(Default)]
pub struct IsoSurface {
    /// The particles' grid, weights and kernels.
    grid: IsoResources,
    /// The smoothed field's lattice (`[iso] smoothing` > 0).
    volume: Option<IsoVolume>,
    /// The far bound and the queue, for the fluid size of the latest frame.
    targets: Option<IsoTargets>,
    /// The cast's and the lattice's programs, built on the first prepare.
    programs: Option<(IsoCast, VolumePrograms)>,
}

impl IsoSurface {
    /// Its particle grid, weights and kernels on the device, once built (for tests and the work counts).
    pub fn grid(&self) -> Option<&IsoBuffers> {
        self.grid.buffers()
    }

    /// The smoothed field's lattice, while `[iso] smoothing` asks for one.
    pub fn volume(&self) -> Option<&IsoVolume> {
        self.volume.as_ref()
    }

    /// The cast's queue of unfinished rays (its work counts: [`IsoQueue::work`]), after a frame.
    pub fn queue(&self) -> Option<&IsoQueue> {
        self.targets.as_ref().map(|t| &t.queue)
    }
}

impl Technique for IsoSurface {
    fn prepare(&mut self, p: &Prepare) -> Result<()> {
        if self.programs.is_none() {
            self.programs = Some((IsoCast::new(p.gpu)?, VolumePrograms::new(p.gpu)?));
        }
        self.grid.prepare(p)?;
        if let Some(b) = self.grid.buffers() {
            volume::ensure(&mut self.volume, b, p, self.grid.params().and_then(|q| q.volume))?;
        }
        if self.targets.as_ref().is_none_or(|t| t.size() != p.fluid) {
            let (gpu, fluid) = (p.gpu, p.fluid);
            p.executor.replace(&mut self.targets, || IsoTargets::new(gpu, fluid).map(Some))?;
        }
        Ok(())
    }

    fn record_kernels<'a>(&'a self, rec: &mut Recording, f: &SurfaceFrame<'a>) -> Option<Kernels<'a>> {
        let ctx = rec.part(Part::Fluid);
        let b = self.grid.record(ctx, f, true)?;
        let smoothed = self.grid.params().and_then(|q| q.volume.as_ref());
        if let (Some(v), Some(p), Some((_, programs))) = (&self.volume, smoothed, &self.programs) {
            programs.record(ctx, f.frame, b, v, p);
        }
        None
    }

    fn strays(&self) -> Option<(u64, usize)> {
        self.grid.strays()
    }

    fn record_depth(&self, ctx: &mut FrameCtx, f: &SurfaceFrame, _: Option<Kernels>) -> Result<()> {
        let own = self.targets.as_ref().map(|t| (&t.depth_back, &t.depth_back_tiles));
        let back = record_splat(ctx, f, own)?;
        let ready = (self.grid.buffers(), &self.targets, self.grid.params(), &self.programs);
        if let (Some(grid), Some(t), Some(params), Some((cast, _))) = ready {
            // The rasterised splats do not write a far bound: the march then runs to the grid's box.
            let depth = &f.targets.depth;
            cast.record(ctx, f.frame, grid, params, depth, self.volume.as_ref(), back, &t.queue, f.info);
        }
        Ok(())
    }

    fn memory(&self) -> Vec<(&str, u64)> {
        self.targets.as_ref().map(|t| t.memory()).unwrap_or_default()
    }
}
