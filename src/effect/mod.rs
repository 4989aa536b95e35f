//! Effects: what a frame adds on and around the surface it drew — [`noise`] (the NVIDIA patent's small waves
//! and whitecaps) and [`diffuse`] (spray, foam and bubbles, Ihmsen et al. 2012). An effect is a technique like
//! a surface (`crate::surface`): it owns its pipelines and its images (allocated only while it draws: its
//! setting on and something to draw), prepares them on the host, records its passes once the surface's depth is
//! known (before the normals), may give the `normals` pass a detail height field whose slopes it adds
//! ([`Effect::detail`]: the noise's waves), and gives the `composite` pass its layers
//! (`crate::layer::Layer`) — neither pass knows an effect by name. The vocabulary an effect speaks — `Layer`,
//! `Blend`, `Detail` — is `crate::layer`'s (a leaf module both the effects and the passes read), and the device
//! types it records with are `crate::device`'s, so an effect written outside the library (tests/effects.rs)
//! imports neither `passes` nor the device layer. THE LIST is
//! `built_in_effects!`: a new effect is one module and one line there (or one [`Effects::push`] from outside the
//! library: `Renderer::add_effect`).
//!
//! In: the frame's depth, scene depth, particles and settings ([`EffectFrame`]). Out: each effect's own images,
//! read by the normals (at most one detail) and by the composite as layers in list order (at most
//! [`crate::shader_constants::COMPOSITE_LAYERS`] in all).

/// Declares the built-in effects from ONE list, in frame (and layer) order: each entry is the effect's module
/// (named like its pass in `crate::passes`, whose `NAME` it takes) and its type with a `new(gpu)`. It generates
/// the `pub mod`s, [`BUILT_IN`] and the constructor [`Effects::new`] uses. A new effect is one line here.
macro_rules! built_in_effects {
    ($($module:ident: $ty:ident,)*) => {
        $(pub mod $module;)*

        /// The names of the built-in effects, in order (without building them: the timing table's columns).
        pub const BUILT_IN: &[&str] = &[$(crate::passes::$module::NAME,)*];

        fn built_in(gpu: &Arc<Gpu>) -> Result<Vec<Box<dyn Effect>>> {
            Ok(vec![$(Box::new($module::$ty::new(gpu)?),)*])
        }
    };
}

built_in_effects! {
    noise: NoiseEffect,
    diffuse: DiffuseEffect,
}

use std::any::Any;
use std::sync::Arc;

use crate::error::{Error, Result};
use crate::gpu::executor::Executor;
use crate::gpu::{Buffer, FrameCtx, Gpu, Image};
use crate::layer::{Detail, Layer};
use crate::particles::ParticleSet;
use crate::settings::Settings;

/// What an effect prepares with, on the host, before a frame is recorded.
pub struct EffectPrepare<'a> {
    /// The device.
    pub gpu: &'a Arc<Gpu>,
    /// The frames in flight (waited for before an image they use is replaced).
    pub executor: &'a Executor,
    /// The particles of the next frame.
    pub particles: &'a ParticleSet,
    /// The frame's settings.
    pub settings: &'a Settings,
    /// Output width.
    pub width: u32,
    /// Output height.
    pub height: u32,
}

/// The particle buffer as the frame's passes see it: the fluid particles, their motions after them, then the
/// diffuse particles (`crate::shader_constants::ParticleLayout`).
#[derive(Clone, Copy)]
pub struct FrameParticles<'a> {
    /// The buffer.
    pub buffer: &'a Buffer,
    /// Fluid particles.
    pub count: u32,
    /// Diffuse particles after them (at most, when written on the GPU) …
    pub diffuse: u32,
    /// … written on the GPU after a header: a pass that draws them dispatches indirectly.
    pub diffuse_indirect: bool,
    /// Some fluid particles are marked isolated (`[isolated]`).
    pub isolated: bool,
}

/// What an effect records with: the frame's uniforms, particles and images.
pub struct EffectFrame<'a> {
    /// The frame uniform block.
    pub frame: &'a Buffer,
    /// The particles.
    pub particles: FrameParticles<'a>,
    /// Fluid depth at full resolution (the normals are not made yet: an effect changes them through
    /// [`Effect::detail`]).
    pub depth: &'a Image,
    /// Background depth.
    pub scene_depth: &'a Image,
    /// The frame's settings.
    pub settings: &'a Settings,
}

/// One effect.
pub trait Effect: Any {
    /// Its one name: pass, timestamp key, JSON key, settings section.
    fn name(&self) -> &'static str;
    /// Bring its images up to date for the next frame's size, settings and particles: allocated while it draws
    /// (waiting for the frames in flight before replacing any), freed when it is off.
    fn prepare(&mut self, p: &EffectPrepare) -> Result<()>;
    /// Record its passes (in the frame's fluid part, after the surface's depth, before the normals); nothing when
    /// it does not draw.
    fn record(&self, ctx: &mut FrameCtx, f: &EffectFrame);
    /// The height field whose slopes the `normals` pass adds this frame (small waves), if it gives one.
    fn detail(&self, _s: &Settings) -> Option<Detail<'_>> {
        None
    }
    /// Its layers in the composite, in order; none when it does not draw this frame.
    fn layers(&self, s: &Settings) -> Vec<Layer<'_>>;
    /// (name, bytes) of the images and buffers it holds now, for the memory table.
    fn memory(&self) -> Vec<(&str, u64)>;
}

/// The effects a renderer runs, in frame (and layer) order.
pub struct Effects {
    all: Vec<Box<dyn Effect>>,
}

impl Effects {
    /// Every built-in effect, in order (the list: `built_in_effects!`).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Effects> {
        Ok(Effects { all: built_in(gpu)? })
    }

    /// Add an effect after the others (its passes run last, its layers lie on top).
    pub fn push(&mut self, e: Box<dyn Effect>) {
        self.all.push(e);
    }

    /// The effects' names, in order.
    pub fn names(&self) -> Vec<&'static str> {
        self.all.iter().map(|e| e.name()).collect()
    }

    /// Prepare every effect.
    pub fn prepare(&mut self, p: &EffectPrepare) -> Result<()> {
        self.all.iter_mut().try_for_each(|e| e.prepare(p))
    }

    /// Record every effect's passes, in order.
    pub fn record(&self, ctx: &mut FrameCtx, f: &EffectFrame) {
        for e in &self.all {
            e.record(ctx, f);
        }
    }

    /// Every effect's layers, in order; an error when they exceed the composite's
    /// [`crate::shader_constants::COMPOSITE_LAYERS`].
    pub fn layers(&self, s: &Settings) -> Result<Vec<Layer<'_>>> {
        let layers: Vec<Layer> = self.all.iter().flat_map(|e| e.layers(s)).collect();
        let max = crate::shader_constants::COMPOSITE_LAYERS as usize;
        if layers.len() > max {
            return Err(Error::Invalid(format!(
                "the effects {} give {} composite layers; the composite lays at most {max}",
                self.names().join(", "),
                layers.len()
            )));
        }
        Ok(layers)
    }

    /// The detail height field the normals add: the one effect's that gives one; an error when several do (the
    /// normals add one).
    pub fn detail(&self, s: &Settings) -> Result<Option<Detail<'_>>> {
        let mut given = self.all.iter().filter_map(|e| e.detail(s).map(|d| (e.name(), d)));
        let first = given.next();
        if let (Some((a, _)), Some((b, _))) = (&first, given.next()) {
            return Err(Error::Invalid(format!(
                "the effects {a} and {b} both give the normals a detail height field; the normals add one"
            )));
        }
        Ok(first.map(|(_, d)| d))
    }

    /// (name, bytes) of what every effect holds now.
    pub fn memory(&self) -> Vec<(&str, u64)> {
        self.all.iter().flat_map(|e| e.memory()).collect()
    }

    /// The effect of type `T`, if the list has one (tests and tools read its images).
    pub fn get<T: Effect>(&self) -> Option<&T> {
        self.all.iter().find_map(|e| (e.as_ref() as &dyn Any).downcast_ref::<T>())
    }

    /// The effect of type `T`, if the list has one.
    pub fn get_mut<T: Effect>(&mut self) -> Option<&mut T> {
        self.all.iter_mut().find_map(|e| (e.as_mut() as &mut dyn Any).downcast_mut::<T>())
    }
}
