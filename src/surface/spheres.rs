//! The spheres surface (`--preset fast`): the nearest particle sphere per pixel (the `splat` pass: compute,
//! or a rasterised variant), or with `kernel = "anisotropic"` each particle's ellipsoid (Yu & Turk 2013: the
//! grid and the `anisotropy` pass first, on the async part, since `thickness` draws them too); the depth is then
//! smoothed in screen space by the chosen filter (van der Laan et al. 2009; Truong & Yuksel's narrow-range).

use crate::error::Result;
use crate::gpu::recording::{Part, Recording};
use crate::gpu::FrameCtx;

use super::grid::IsoResources;
use super::splat::record_splat;
use super::{Kernels, Prepare, SurfaceFrame, Technique};

/// The spheres technique; its grid exists only for ellipsoids.
#[derive(Default)]
pub struct Spheres {
    /// The particles' grid and kernels (ellipsoids only).
    pub grid: IsoResources,
}

impl Technique for Spheres {
    fn prepare(&mut self, p: &Prepare) -> Result<()> {
        let s = p.settings;
        if s.ellipsoid_splats() {
            self.grid.prepare(p)?;
        }
        Ok(())
    }

    fn record_kernels<'a>(&'a self, rec: &mut Recording, f: &SurfaceFrame<'a>) -> Option<Kernels<'a>> {
        if !f.settings.ellipsoid_splats() {
            return None;
        }
        let b = self.grid.record(rec.part(Part::Async), f, false)?;
        Some(Kernels {
            points: &b.points,
            count: b.shape.dims[3],
            aniso: &b.aniso,
            stretch: f.settings.anisotropy.stretch.max(1.0),
            all_particles: b.gpu.is_some(),
        })
    }

    fn record_depth(&self, ctx: &mut FrameCtx, f: &SurfaceFrame, kernels: Option<Kernels>) -> Result<()> {
        let s = f.settings;
        match kernels {
            Some(k) => {
                let t = f.targets;
                let spheres = (s.radius, s.splat_scale(), s.splat.lanes);
                let kernel = Some((k.aniso, k.stretch));
                f.passes.splat.record(
                    ctx,
                    f.frame,
                    k.points,
                    k.count,
                    &t.depth,
                    None,
                    (&t.depth_tiles, &t.splat_work),
                    spheres,
                    kernel,
                    f.info,
                );
            }
            None => {
                record_splat(ctx, f, None)?;
            }
        }
        Ok(())
    }
}
