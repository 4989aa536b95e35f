//! The `noise` effect (NVIDIA patent US 8,947,430): small waves on the normals and, as the
//! composite's `tint` layer, whitecaps where the noise is strong. It owns the `noise` pass
//! (`crate::passes::noise`: splat, resolve) and the pass's images, which exist only while `[noise] enabled`.
//! In: fluid depth, particles (+ motions). Out: N (level 0 of its accumulator atlas, fixed point): the normals'
//! detail height field ([`Effect::detail`], × `[noise] strength`) and its layer.

use std::sync::Arc;

use super::{Effect, EffectFrame, EffectPrepare};
use crate::error::Result;
use crate::gpu::{FrameCtx, Gpu};
use crate::layer::{Blend, Layer};
use crate::passes::noise::{Noise, NoiseImages, NoiseTargets, NAME, UNITS};
use crate::layer::Detail;
use crate::settings::Settings;
use crate::work::NoiseWork;

/// The effect: the pass and, while it is on, its images.
pub struct NoiseEffect {
    pass: Noise,
    images: Option<NoiseTargets>,
}

impl NoiseEffect {
    /// The effect with the splat the device suits (tiled on GPUs, one thread per sprite on CPU drivers).
    pub fn new(gpu: &Arc<Gpu>) -> Result<NoiseEffect> {
        Ok(NoiseEffect { pass: Noise::new(gpu)?, images: None })
    }

    /// Choose the splat: tiled or one thread per sprite (the same sums; the tests compare them). Drops the
    /// images (the next frame makes them again; call between frames, with none in flight).
    pub fn set_tiled(&mut self, gpu: &Arc<Gpu>, tiled: bool) -> Result<()> {
        self.pass = Noise::with_variant(gpu, tiled)?;
        self.images = None;
        Ok(())
    }

    /// Whether the splat is the tiled one.
    pub fn is_tiled(&self) -> bool {
        self.pass.is_tiled()
    }

    /// Its images, while it is on.
    pub fn images(&self) -> Option<&NoiseTargets> {
        self.images.as_ref()
    }

    /// The last frame's work (read once that frame has finished), while it is on.
    pub fn work(&self) -> Result<Option<NoiseWork>> {
        self.images.as_ref().map(|n| n.work()).transpose()
    }
}

impl Effect for NoiseEffect {
    fn name(&self) -> &'static str {
        NAME
    }

    fn prepare(&mut self, p: &EffectPrepare) -> Result<()> {
        let on = p.settings.noise.enabled;
        let fits = |n: &NoiseTargets| n.size() == (p.width, p.height);
        if on != self.images.is_some() || !self.images.as_ref().is_none_or(fits) {
            let gpu = p.gpu;
            let (w, h) = (p.width, p.height);
            p.executor.replace(&mut self.images, || on.then(|| NoiseTargets::new(gpu, w, h)).transpose())?;
        }
        // The splat's lists follow the particle count.
        let (count, tiled) = (p.particles.count(), self.pass.is_tiled());
        if let Some(n) = self.images.as_mut().filter(|n| n.needs(count, tiled)) {
            p.executor.wait_idle()?;
            n.reserve(p.gpu, count, tiled)?;
        }
        Ok(())
    }

    fn record(&self, ctx: &mut FrameCtx, f: &EffectFrame) {
        if let Some(own) = &self.images {
            let s = f.settings;
            let images = NoiseImages { depth: f.depth, own };
            let particles = (f.particles.buffer, f.particles.count);
            self.pass.record(ctx, f.frame, particles, &images, &s.noise);
        }
    }

    fn detail(&self, s: &Settings) -> Option<Detail<'_>> {
        self.images.as_ref().map(|own| Detail { image: &own.accum, strength: s.noise.strength })
    }

    fn layers(&self, s: &Settings) -> Vec<Layer<'_>> {
        let p = &s.noise;
        let Some(own) = &self.images else { return vec![] };
        vec![Layer {
            image: &own.accum,
            color: p.whitecaps_color,
            weight: p.whitecaps,
            blend: Blend::Tint { from: p.whitecaps_from, full: p.whitecaps_full, units: UNITS, sun: 0.6 },
        }]
    }

    fn memory(&self) -> Vec<(&str, u64)> {
        self.images.as_ref().map(|n| n.memory()).unwrap_or_default()
    }
}
