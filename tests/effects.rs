//! An effect from outside the library: `tint`, one module here and one line to register it
//! (`Renderer::add_effect`). It owns a pass (a compute clear of its image to one value each frame), an image
//! allocated with the frame's size, and one composite layer over everything. The picture it gives is checked
//! against the composite's blend computed here from the picture without it; the composite's layer limit is an
//! error, not a panic. Given as a detail height field too (`Effect::detail`), its constant height leaves the
//! normals as they are, and a second detail beside the noise's is an error naming both. It imports neither
//! `meniscus::passes` nor the device layer `meniscus::gpu` (tests/layout.rs holds it to that): the effect
//! vocabulary is `meniscus::layer`'s, the device types `meniscus::device`'s.

mod common;

use common::*;
use meniscus::renderer::Renderer;

/// The example effect.
mod tint {
    use std::sync::Arc;

    use ash::vk;
    use meniscus::compute::clear::Clear;
    use meniscus::device::{FrameCtx, Gpu, Image};
    use meniscus::effect::{Effect, EffectFrame, EffectPrepare};
    use meniscus::layer::{Blend, Detail, Layer};
    use meniscus::settings::Settings;

    /// A coverage of `value` units everywhere, laid over the picture in `color` with `weight`.
    pub struct Tint {
        clear: Clear,
        image: Option<Image>,
        /// Coverage units written to every pixel (one unit of coverage = one unit here).
        pub value: u32,
        /// Linear colour.
        pub color: [f32; 3],
        /// The layer's weight.
        pub weight: f32,
        /// Its image is also the normals' detail height field.
        pub detail: bool,
    }

    impl Tint {
        pub fn new(gpu: &Arc<Gpu>, value: u32, color: [f32; 3], weight: f32) -> meniscus::Result<Tint> {
            Ok(Tint { clear: Clear::new(gpu)?, image: None, value, color, weight, detail: false })
        }
    }

    impl Effect for Tint {
        fn name(&self) -> &'static str {
            "tint"
        }

        fn prepare(&mut self, p: &EffectPrepare) -> meniscus::Result<()> {
            let fits =
                self.image.as_ref().is_some_and(|i| i.extent == vk::Extent2D { width: p.width, height: p.height });
            if !fits {
                let extent = vk::Extent2D { width: p.width, height: p.height };
                let usage = vk::ImageUsageFlags::STORAGE;
                p.executor.replace(&mut self.image, || {
                    Image::new(p.gpu, "tint", extent, vk::Format::R32_UINT, usage, None).map(Some)
                })?;
            }
            Ok(())
        }

        fn record(&self, ctx: &mut FrameCtx, _: &EffectFrame) {
            if let Some(image) = &self.image {
                ctx.pass("tint", |ctx| self.clear.record(ctx, image, self.value));
            }
        }

        fn detail(&self, _: &Settings) -> Option<Detail<'_>> {
            self.image.as_ref().filter(|_| self.detail).map(|image| Detail { image, strength: 1.0 })
        }

        fn layers(&self, _: &Settings) -> Vec<Layer<'_>> {
            let blend = Blend::Over { units: 1.0, sun: 0.0 };
            self.image.iter().map(|image| Layer { image, color: self.color, weight: self.weight, blend }).collect()
        }

        fn memory(&self) -> Vec<(&str, u64)> {
            self.image.iter().map(|i| (i.name.as_str(), i.bytes())).collect()
        }
    }
}

fn decode(c: u8) -> f64 {
    (c as f64 / 255.0).powf(2.2)
}

fn encode(x: f64) -> f64 {
    x.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0
}

/// The tint registered in one line lays its layer over every pixel, water and background, as the composite's
/// `over` blend says: c' = mix(c, colour · ambient, weight · (1 − exp(−coverage))), in linear light.
#[test]
fn an_effect_registered_in_one_line_lays_its_layer() {
    let gpu = gpu();
    let r = 0.1f32;
    let v = view([0.4, 1.6, 2.4], [0.0, 0.0, 0.0], 80, 56, 40.0);
    let s = settings(r);
    let p: Vec<[f32; 3]> =
        (0..400).map(|k| [(k % 20) as f32 * 0.06 - 0.6, 0.0, (k / 20) as f32 * 0.06 - 0.6]).collect();
    let mut rr = Renderer::new(&gpu).unwrap();
    rr.upload(meniscus::renderer::Upload::points(&p)).unwrap();
    rr.render(&v, &s).unwrap();
    let plain = rr.state().read_final().unwrap();
    let (value, color, weight) = (1u32, [0.9f32, 0.3, 0.1], 0.5f32);

    rr.add_effect(Box::new(tint::Tint::new(&gpu, value, color, weight).unwrap()));

    let times = rr.render(&v, &s).unwrap();
    let tinted = rr.state().read_final().unwrap();
    assert!(times.get("tint").is_some(), "the effect's pass is timed: {times:?}");
    assert!(rr.state().memory().iter().any(|(n, _)| *n == "tint"), "the effect's image is in the memory table");
    let a = weight as f64 * (1.0 - (-(value as f64)).exp());
    let ambient = s.composite.ambient as f64;
    let mut worst = 0f64;
    for (q, t) in plain.pixels().zip(tinted.pixels()) {
        for c in 0..3 {
            let want = encode(decode(q[c]) * (1.0 - a) + color[c] as f64 * ambient * a);
            worst = worst.max((want - t[c] as f64).abs());
        }
    }
    // The plain picture is 8-bit: its rounding (half a step) passes through the blend.
    assert!(worst <= 1.5, "the tint differs from the composite's blend by {worst:.2} steps");
    assert!(plain != tinted, "the tint changed nothing");
    assert_clean(&gpu);
}

/// More layers than the composite lays is an error naming the limit and the effects (no panic, no frame).
#[test]
fn more_layers_than_the_composite_lays_is_an_error() {
    let gpu = gpu();
    let v = view([0.0, 1.0, 2.0], [0.0, 0.0, 0.0], 32, 24, 40.0);
    let s = settings(0.1);
    let mut rr = Renderer::new(&gpu).unwrap();
    rr.upload(meniscus::renderer::Upload::points(&[[0.0, 0.0, 0.0]])).unwrap();
    let max = meniscus::shader_constants::COMPOSITE_LAYERS;
    for _ in 0..max {
        rr.add_effect(Box::new(tint::Tint::new(&gpu, 1, [1.0; 3], 0.1).unwrap()));
    }
    rr.render(&v, &s).expect("as many layers as the composite lays");
    rr.add_effect(Box::new(tint::Tint::new(&gpu, 1, [1.0; 3], 0.1).unwrap()));
    let e = rr.render(&v, &s).expect_err("one layer too many").to_string();
    assert!(e.contains(&format!("at most {max}")) && e.contains("tint"), "{e}");
    assert_clean(&gpu);
}

/// An effect's detail height field goes to the normals' detailed variant: a constant height has no slope, so
/// the normals stay the plain ones, bit for bit (the noise tests check the slopes of a real one); a second detail beside the noise's is an error naming both effects, not
/// a panic (the normals add one).
#[test]
fn a_constant_detail_leaves_the_normals_and_two_details_are_an_error() {
    let gpu = gpu();
    let r = 0.1f32;
    let v = view([0.4, 1.6, 2.4], [0.0, 0.0, 0.0], 80, 56, 40.0);
    let mut s = settings(r);
    s.noise.enabled = false;
    let p: Vec<[f32; 3]> =
        (0..400).map(|k| [(k % 20) as f32 * 0.06 - 0.6, 0.0, (k / 20) as f32 * 0.06 - 0.6]).collect();
    let mut rr = Renderer::new(&gpu).unwrap();
    rr.upload(meniscus::renderer::Upload::points(&p)).unwrap();
    rr.render(&v, &s).unwrap();
    let words = |rr: &Renderer| -> Vec<u32> {
        let st = rr.state();
        bytemuck::pod_collect_to_vec(&st.read_image(&st.targets().unwrap().normals).unwrap())
    };
    let plain = words(&rr);
    let mut t = tint::Tint::new(&gpu, 3 << 16, [1.0; 3], 0.0).unwrap();
    t.detail = true;
    rr.add_effect(Box::new(t));
    rr.render(&v, &s).unwrap();
    let detailed = words(&rr);
    assert!(plain.iter().filter(|n| **n != 0).count() > 100, "too little water to test");
    // No slope: normalize(n − 0) is n, packed to the same bits.
    assert!(detailed == plain, "a constant height changed the normals");
    s.noise.enabled = true;
    let e = rr.render(&v, &s).expect_err("two detail height fields").to_string();
    assert!(e.contains("noise") && e.contains("tint") && e.contains("detail"), "{e}");
    assert_clean(&gpu);
}
