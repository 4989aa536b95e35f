//! `composite` pass: shades the fluid over the background (Beer–Lambert, refraction, transparency, Fresnel,
//! reflection, Blinn–Phong) into the 8-bit output. Shader: shaders_glsl/composite.comp.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
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

/// The pass: its compute program(s), built once per device, and the 1×1 placeholders bound in place of an
/// effect's images when the effect did not run (the shader does not read them then).
pub struct Composite {
    prog: ComputeProgram<Push>,
    none_f32: Image,
    none_u32: Image,
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
    /// The `noise` pass's N (radii), the foam tint's magnitude, when the pass ran this frame.
    pub noise: Option<&'a Image>,
    /// The `diffuse` pass's coverage of foam and spray and of bubbles, when it ran this frame.
    pub diffuse: Option<&'a crate::passes::diffuse::DiffuseTargets>,
}

/// Push constants of composite.comp: the foam tint (`[noise]`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Push {
    /// Foam colour (rgb) and the full tint's weight (w; 0: none).
    pub foam: [f32; 4],
    /// |N| where the tint starts (x) and is full (y); z: the diffuse images' units per unit of coverage, w: how
    /// much of the bubbles' coverage shows.
    pub range: [f32; 4],
    /// Colour of foam and spray (rgb); w: 1 when the diffuse images hold this frame's particles.
    pub diffuse: [f32; 4],
}

// Slots: frame, scene colour, scene depth, fluid depth, normals, thickness, out, ssr, sky, noise, diffuse white,
// diffuse bubbles.
declare_program!(pub PROGRAM: Push = compute(
    shaders::COMPOSITE,
    [Uniform, Sampled, ImgRead, ImgRead, ImgRead, Sampled, ImgOverwrite, ImgRead, Sampled, ImgRead, ImgRead, ImgRead]
));

impl Composite {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        use ash::vk;
        let one = vk::Extent2D { width: 1, height: 1 };
        let usage = vk::ImageUsageFlags::STORAGE;
        Ok(Composite {
            prog: ComputeProgram::new(gpu, &PROGRAM)?,
            none_f32: Image::new(gpu, "composite_none_f32", one, vk::Format::R32_SFLOAT, usage, None)?,
            none_u32: Image::new(gpu, "composite_none_u32", one, vk::Format::R32_UINT, usage, None)?,
        })
    }

    /// Shade the fluid over the background into `out`, tinted toward foam by the noise (`noise`: its settings),
    /// with the `diffuse` pass's bubbles under the surface and its foam and spray over everything.
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        i: &CompositeInputs,
        noise: &crate::passes::noise::Params,
        diffuse: &crate::diffuse::params::Params,
        out: &Image,
    ) {
        ctx.pass(NAME, |ctx| {
            let c = noise.foam_color;
            let d = diffuse.color;
            let tint = if noise.enabled && i.noise.is_some() { noise.foam } else { 0.0 };
            let push = Push {
                foam: [c[0], c[1], c[2], tint],
                range: [noise.foam_from, noise.foam_full, crate::passes::diffuse::UNITS, diffuse.bubbles],
                diffuse: [d[0], d[1], d[2], if i.diffuse.is_some() { 1.0 } else { 0.0 }],
            };
            let g = groups_2d(out.extent.width, out.extent.height, super::LOCAL_2D);
            let res = [
                frame.into(),
                i.scene_color.into(),
                i.scene_depth.into(),
                i.depth.into(),
                i.normals.into(),
                i.thickness.into(),
                out.into(),
                i.ssr.into(),
                i.sky.into(),
                i.noise.unwrap_or(&self.none_f32).into(),
                i.diffuse.map_or(&self.none_u32, |d| &d.white).into(),
                i.diffuse.map_or(&self.none_u32, |d| &d.bubbles).into(),
            ];
            self.prog.dispatch(ctx, &res, &push, g);
        });
    }
}
