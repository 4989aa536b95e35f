//! Looking inside a frame (the demo's views): one of the frame's images mapped to colour over the final image
//! (raw or smoothed depth, thickness, normals, SSR hits), the particles as lit spheres coloured by an attribute,
//! and a text overlay — recorded after the frame's passes through `Hooks::after`, so the renderer knows none of
//! them. Passes: `view`, `particles`, `overlay` (crate::passes).

use std::sync::Arc;

use crate::error::Result;
use crate::gpu::{Buffer, FrameCtx, Gpu, Image};
use crate::renderer::FrameImages;
use crate::settings::Settings;
use crate::view::ViewMode;

/// The views' passes, built once per device.
pub struct Inspector {
    view: crate::passes::view::Viewer,
    particles: crate::passes::particles::LitParticles,
    overlay: crate::passes::overlay::Overlay,
}

impl Inspector {
    /// Build the passes' pipelines.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Inspector> {
        Ok(Inspector {
            view: crate::passes::view::Viewer::new(gpu)?,
            particles: crate::passes::particles::LitParticles::new(gpu)?,
            overlay: crate::passes::overlay::Overlay::new(gpu)?,
        })
    }

    /// Over the frame `f`'s final image: `mode`'s view (the particle view colours each particle by `values`,
    /// one float in [0, 1] per particle), then the text `overlay` (RGBA8, drawn at the top left). The frame must
    /// keep its raw depth (`Renderer::keep_raw_depth`) for the raw depth and particle views.
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        f: &FrameImages,
        mode: ViewMode,
        values: Option<&Buffer>,
        overlay: Option<&Image>,
        s: &Settings,
    ) {
        let images = &f.images;
        let range = (f.info.d_near, f.info.d_near + f.info.target_distance * 1.5);
        let t_max = 60.0 * s.radius;
        match mode {
            ViewMode::Final => {}
            ViewMode::Particles => {
                self.view.record(ctx, f.frame, images, 6, range, t_max);
                if let Some(v) = values {
                    let (buf, count) = f.particles;
                    let out = (images.depth, images.final_color);
                    self.particles.record(ctx, f.frame, buf, v, count, out, s.splat.radius_scale);
                }
            }
            m => {
                let k = ViewMode::ALL.iter().position(|x| *x == m).unwrap_or(0) as i32;
                self.view.record(ctx, f.frame, images, k, range, t_max);
            }
        }
        if let Some(o) = overlay {
            self.overlay.record(ctx, f.frame, o, images.final_color);
        }
    }
}
