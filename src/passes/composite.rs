//! `composite` pass: shades the fluid over the background (Beer–Lambert, refraction, transparency, Fresnel,
//! reflection, Blinn–Phong) into the 8-bit output, then lays the layers it is given over it ([`Layer`]: the effects'
//! images, `crate::effect`; it knows no effect by name). Shader: shaders_glsl/composite.comp.
use std::sync::Arc;

use crate::declare_program;
use crate::error::{Error, Result};
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::layer::Layer;
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `composite`.
pub const NAME: &str = "composite";

/// Settings of the `composite` pass: the `[composite]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Beer–Lambert extinction of water per metre (Moritz table 3.1) …
    pub extinction: [f32; 3],
    /// … times this scale (scenes are rarely metres thick).
    pub extinction_scale: f32,
    /// Colour I0 of the light scattered out of the fluid.
    pub fluid_color: [f32; 3],
    /// Ambient light on the fluid and the scene.
    pub ambient: f32,
    /// Refraction offset: pixels per world unit of thickness (α) …
    pub refraction_alpha: f32,
    /// … clamped to this many pixels (β).
    pub refraction_beta: f32,
    /// Transparency τ = exp(−γ·T), γ per world unit.
    pub transparency_gamma: f32,
    /// Specular strength k_s.
    pub specular: f32,
    /// Blinn–Phong exponent c.
    pub shininess: f32,
    /// Fresnel reflectance at normal incidence (water ≈ 0.02).
    pub f0: f32,
    /// Reflect the sky.
    pub reflect_sky: bool,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            extinction: [0.555, 0.041, 0.0208],
            extinction_scale: 20.0,
            fluid_color: [0.10, 0.36, 0.52],
            ambient: 0.55,
            refraction_alpha: 60.0,
            refraction_beta: 24.0,
            transparency_gamma: 4.0,
            specular: 0.6,
            shininess: 300.0,
            f0: 0.02,
            reflect_sky: true,
        }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(NAME);
        k.each("extinction", &self.extinction, 0.0, 1e3)?;
        k.within("extinction_scale", self.extinction_scale, 0.0, 1e4)?;
        k.each("fluid_color", &self.fluid_color, 0.0, 1.0)?;
        k.within("ambient", self.ambient, 0.0, 4.0)?;
        k.within("refraction_alpha", self.refraction_alpha, 0.0, 1e4)?;
        k.within("refraction_beta", self.refraction_beta, 0.0, 1024.0)?;
        k.within("transparency_gamma", self.transparency_gamma, 0.0, 1e4)?;
        k.within("specular", self.specular, 0.0, 100.0)?;
        k.within("shininess", self.shininess, 0.0, 1e5)?;
        k.within("f0", self.f0, 0.0, 1.0)
    }
}

/// The pass: one program per layer count (composite.comp's variants), built once per device.
pub struct Composite {
    plain: ComputeProgram<()>,
    layered: [ComputeProgram<Push>; LAYERS],
}

/// The images the composite reads.
pub struct CompositeInputs<'a> {
    /// Background colour (sampled).
    pub scene_color: &'a Image,
    /// Background depth.
    pub scene_depth: &'a Image,
    /// Fluid depth at full resolution.
    pub depth: &'a Image,
    /// Packed normals.
    pub normals: &'a Image,
    /// Thickness (sampled).
    pub thickness: &'a Image,
    /// SSR hits.
    pub ssr: &'a Image,
    /// The sky cube map (placeholder when procedural).
    pub sky: &'a Image,
}

/// The most layers the composite lays (one binding each in composite.comp).
pub const LAYERS: usize = crate::shader_constants::COMPOSITE_LAYERS as usize;
const _: () = assert!(LAYERS == 4, "composite.comp has a variant and a binding per layer, four");

/// Push constants of composite.comp: the layers ([`Layer::packed`]; zero past the last: no layer).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Push {
    /// Per layer: colour (rgb) and weight.
    pub color: [[f32; 4]; LAYERS],
    /// Per layer: blend, its parameters, the sun's share.
    pub blend: [[f32; 4]; LAYERS],
}

// Slots: frame, scene colour, scene depth, fluid depth, normals, thickness, out, ssr, sky, then one per layer.
declare_program!(pub PLAIN: () = compute(
    shaders::COMPOSITE_L0,
    [Uniform, Sampled, ImgRead, ImgRead, ImgRead, Sampled, ImgOverwrite, ImgRead, Sampled]
));
declare_program!(pub LAYERS_1: Push = compute(
    shaders::COMPOSITE_L1,
    [Uniform, Sampled, ImgRead, ImgRead, ImgRead, Sampled, ImgOverwrite, ImgRead, Sampled, ImgRead]
));
declare_program!(pub LAYERS_2: Push = compute(
    shaders::COMPOSITE_L2,
    [Uniform, Sampled, ImgRead, ImgRead, ImgRead, Sampled, ImgOverwrite, ImgRead, Sampled, ImgRead, ImgRead]
));
declare_program!(pub LAYERS_3: Push = compute(
    shaders::COMPOSITE_L3,
    [Uniform, Sampled, ImgRead, ImgRead, ImgRead, Sampled, ImgOverwrite, ImgRead, Sampled, ImgRead, ImgRead, ImgRead]
));
declare_program!(pub LAYERS_4: Push = compute(
    shaders::COMPOSITE_L4,
    [Uniform, Sampled, ImgRead, ImgRead, ImgRead, Sampled, ImgOverwrite, ImgRead, Sampled, ImgRead, ImgRead, ImgRead, ImgRead]
));

impl Composite {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Composite {
            plain: ComputeProgram::new(gpu, &PLAIN)?,
            layered: [
                ComputeProgram::new(gpu, &LAYERS_1)?,
                ComputeProgram::new(gpu, &LAYERS_2)?,
                ComputeProgram::new(gpu, &LAYERS_3)?,
                ComputeProgram::new(gpu, &LAYERS_4)?,
            ],
        })
    }

    /// Shade the fluid over the background into `out`, then lay the effects' `layers` in order (at most
    /// [`LAYERS`]: `Effects::layers` checks it; more are an error here too). No layers: the program without any.
    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, i: &CompositeInputs, layers: &[Layer], out: &Image) -> Result<()> {
        if layers.len() > LAYERS {
            return Err(Error::Invalid(format!("{} composite layers; the composite lays at most {LAYERS}", layers.len())));
        }
        ctx.pass(NAME, |ctx| {
            let g = groups_2d(out.extent.width, out.extent.height, super::LOCAL_2D);
            let mut res = vec![
                frame.into(),
                i.scene_color.into(),
                i.scene_depth.into(),
                i.depth.into(),
                i.normals.into(),
                i.thickness.into(),
                out.into(),
                i.ssr.into(),
                i.sky.into(),
            ];
            if layers.is_empty() {
                self.plain.dispatch(ctx, &res, &(), g);
                return;
            }
            let mut push = Push { color: [[0.0; 4]; LAYERS], blend: [[0.0; 4]; LAYERS] };
            for (k, l) in layers.iter().enumerate() {
                [push.color[k], push.blend[k]] = l.packed();
                res.push(l.image.into());
            }
            self.layered[layers.len() - 1].dispatch(ctx, &res, &push, g);
        });
        Ok(())
    }
}
