//! The `diffuse` effect (Ihmsen et al. 2012; the NVIDIA patent's isolated particles): the diffuse particles
//! (`crate::diffuse`: spray, foam, bubbles) and the fluid particles marked isolated (low density), drawn as billboards by the
//! `diffuse` pass (`crate::passes::diffuse`) into two coverage images, which the composite lays as two
//! layers: bubbles under the surface, foam and spray over everything. The images exist while `[diffuse]
//! enabled` and, once something was to draw, stay while the output size stands (a sequence whose frames come
//! and go without diffuse particles does not reallocate every frame); the pass runs only on frames with
//! something to draw. In: particles (+ diffuse), fluid depth, scene depth. Out: the coverage layers.

use std::sync::Arc;

use super::{Effect, EffectFrame, EffectPrepare};
use crate::error::Result;
use crate::gpu::{FrameCtx, Gpu};
use crate::layer::{Blend, Layer};
use crate::passes::diffuse::{Diffuse, DiffuseImages, DiffuseTargets, NAME, UNITS};
use crate::settings::Settings;

/// The effect: the pass, its images while it has drawn something, and whether it draws the next frame.
pub struct DiffuseEffect {
    pass: Diffuse,
    images: Option<DiffuseTargets>,
    draws: bool,
}

impl DiffuseEffect {
    /// The effect, with no images yet.
    pub fn new(gpu: &Arc<Gpu>) -> Result<DiffuseEffect> {
        Ok(DiffuseEffect { pass: Diffuse::new(gpu)?, images: None, draws: false })
    }

    /// Its images, while they exist.
    pub fn images(&self) -> Option<&DiffuseTargets> {
        self.images.as_ref()
    }
}

impl Effect for DiffuseEffect {
    fn name(&self) -> &'static str {
        NAME
    }

    fn prepare(&mut self, p: &EffectPrepare) -> Result<()> {
        let on = p.settings.diffuse.enabled;
        self.draws = on && (p.particles.diffuse_count() > 0 || p.particles.has_isolated());
        let fits = |d: &DiffuseTargets| d.white.extent.width == p.width && d.white.extent.height == p.height;
        let keep = match &self.images {
            Some(d) => on && fits(d),
            None => !self.draws,
        };
        if !keep {
            let (gpu, w, h, draws) = (p.gpu, p.width, p.height, self.draws);
            p.executor.replace(&mut self.images, || draws.then(|| DiffuseTargets::new(gpu, w, h)).transpose())?;
        }
        Ok(())
    }

    fn record(&self, ctx: &mut FrameCtx, f: &EffectFrame) {
        let Some(own) = self.images.as_ref().filter(|_| self.draws) else { return };
        let (s, q) = (f.settings, f.particles);
        let images = DiffuseImages { depth: f.depth, scene_depth: f.scene_depth, own };
        let drawn = (q.diffuse, q.diffuse_indirect);
        self.pass.record(ctx, f.frame, (q.buffer, q.count), drawn, q.isolated, &images, &s.diffuse, s.radius);
    }

    fn layers(&self, s: &Settings) -> Vec<Layer<'_>> {
        let Some(own) = self.images.as_ref().filter(|_| self.draws) else { return vec![] };
        let color = s.diffuse.color;
        vec![
            Layer {
                image: &own.bubbles,
                color,
                weight: s.diffuse.bubbles,
                blend: Blend::Under { units: UNITS, sun: 0.3 },
            },
            Layer { image: &own.white, color, weight: 1.0, blend: Blend::Over { units: UNITS, sun: 0.5 } },
        ]
    }

    fn memory(&self) -> Vec<(&str, u64)> {
        self.images.as_ref().map(|d| d.memory()).unwrap_or_default()
    }
}
