//! The depth splat both surfaces start from: the `splat` pass over the particle spheres, in the chosen mode
//! (compute, or a rasterised variant). The spheres surface smooths it; the iso surface marches from it to the
//! bound it writes. Neither technique imports the other: both use this module.

use crate::error::Result;
use crate::gpu::{FrameCtx, Image};
use crate::named::SplatMode;
use crate::passes::splat::BackBound;

use super::SurfaceFrame;

/// The `splat` pass in the chosen mode (compute, or a rasterised variant) over the particle spheres scaled
/// by `splat_scale`; `back`: the far bound's images per pixel and per tile (the iso surface's), which the
/// compute splat writes too; returns where it wrote it (the compute splat only).
pub(super) fn record_splat<'t>(
    ctx: &mut FrameCtx,
    f: &SurfaceFrame<'t>,
    back: Option<(&'t Image, &'t Image)>,
) -> Result<Option<BackBound<'t>>> {
    let (p, t, s) = (f.passes, f.targets, f.settings);
    let (particles, count) = f.particles;
    match s.splat.mode {
        SplatMode::Compute => {
            let spheres = (s.radius, s.splat_scale(), s.splat.lanes);
            let tiles = (&t.depth_tiles, &t.splat_work);
            Ok(p.splat.record(ctx, f.frame, particles, count, &t.depth, back, tiles, spheres, None, f.info))
        }
        mode => {
            p.splat.record_raster(
                ctx,
                f.frame,
                particles,
                count,
                &t.depth,
                t.zbuffer.as_ref(),
                s.splat_scale(),
                mode,
            )?;
            Ok(None)
        }
    }
}
