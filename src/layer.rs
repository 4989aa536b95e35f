//! What an effect hands the frame (`crate::effect::Effect`): composite layers ([`Layer`], each an image and a
//! [`Blend`], laid by the `composite` pass over the shaded water) and at most one detail height field
//! ([`Detail`], whose slopes the `normals` pass adds). A leaf module: the effects and the passes both read it, and
//! an effect written outside the library needs nothing else from the renderer's insides.
//! Shaders: composite.comp (the blends, coded by `shader_constants::BLEND_*`), normals.comp (the detail).

use crate::gpu::Image;
use crate::shader_constants::{BLEND_OVER, BLEND_TINT, BLEND_UNDER};

/// How a layer's image changes the shaded colour (shaders_glsl/composite.comp's blends, coded by
/// `shader_constants::BLEND_*`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Blend {
    /// The image holds a signed fixed-point value v = raw / units (raw: the texel as i32); the water (not the
    /// background) mixes toward the layer's colour, lit by the ambient light and `sun` × the sun's Lambert term,
    /// by weight · smoothstep(from, full, |v|).
    Tint {
        /// |v| where the tint starts …
        from: f32,
        /// … and where it is full.
        full: f32,
        /// Image units per unit of v.
        units: f32,
        /// The sun's share of the lighting (× n·l).
        sun: f32,
    },
    /// The image holds fixed-point coverage C = v / units under the surface: the water mixes toward the colour,
    /// lit by the ambient light + `sun` × the sun, by weight · (1 − exp(−C)).
    Under {
        /// Image units per unit of coverage.
        units: f32,
        /// The sun's share of the lighting.
        sun: f32,
    },
    /// As [`Blend::Under`], over everything: water and background.
    Over {
        /// Image units per unit of coverage.
        units: f32,
        /// The sun's share of the lighting.
        sun: f32,
    },
}

/// One layer of the composite: an effect's image (R32_UINT, at least the output's size: read at the output's pixels)
/// and how it blends.
#[derive(Clone, Copy)]
pub struct Layer<'a> {
    /// The image.
    pub image: &'a Image,
    /// Its colour (linear rgb).
    pub color: [f32; 3],
    /// Its weight (0: invisible).
    pub weight: f32,
    /// How it blends.
    pub blend: Blend,
}

impl Layer<'_> {
    /// The layer's two push-constant vectors: (rgb, weight) and (blend, its parameters, the sun's share).
    pub fn packed(&self) -> [[f32; 4]; 2] {
        let [r, g, b] = self.color;
        let mode = match self.blend {
            Blend::Tint { from, full, units, sun } => [BLEND_TINT, from * units, full * units, sun],
            Blend::Under { units, sun } => [BLEND_UNDER, units, 0.0, sun],
            Blend::Over { units, sun } => [BLEND_OVER, units, 0.0, sun],
        };
        [[r, g, b, self.weight], mode]
    }
}

/// A height field an effect adds to the surface as small waves (`crate::effect::Effect::detail`): an R32_UINT
/// image holding signed fixed-point heights, [`DETAIL_UNITS`] per particle radius, read at each pixel of the
/// normals (at least their size; only its texels at the normals' pixels are read).
#[derive(Clone, Copy)]
pub struct Detail<'a> {
    /// The heights.
    pub image: &'a Image,
    /// Scale of their slopes on the normals (1: the heights as they are).
    pub strength: f32,
}

/// Fixed-point units of a detail height field per particle radius (the noise's accumulator's; the shaders'
/// `DETAIL_UNITS`).
pub const DETAIL_UNITS: f32 = crate::shader_constants::DETAIL_UNITS as f32;
