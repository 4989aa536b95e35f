//! The frame's images, built from a [`TargetsDesc`]: the one place that decides which images exist and how
//! big they are (output size, fluid and thickness scales, and the optional images: the raw depth kept for
//! dumps, the rasterised splats' depth buffer, the full-size depth the upsample pass writes). An image that is
//! not needed is `None`, never a 1×1 stand-in. These are the images every surface shares; a technique's own
//! (the iso surface's far bound and queue) are its own (`crate::surface::iso::targets`).

use std::sync::Arc;

use ash::vk;

use crate::error::Result;
use crate::gpu::{Gpu, Image};
use crate::settings::Settings;

/// What the frame's images must be; two equal descriptions give the same images.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TargetsDesc {
    /// Output width.
    pub width: u32,
    /// Output height.
    pub height: u32,
    /// Size of the fluid images (`fluid_scale` of the output).
    pub fluid: vk::Extent2D,
    /// Size of the thickness images (`thickness_scale` of the output).
    pub thickness: vk::Extent2D,
    /// Keep the splatted depth intact through smoothing (a second ping-pong image): dumps, the demo's views.
    pub keep_raw: bool,
    /// The D32 depth buffer of the depth-tested rasterised splats and of the live mesh surface's draw.
    pub zbuffer: bool,
}

impl TargetsDesc {
    /// The images a `width`×`height` frame with settings `s` needs (the effects own theirs: `crate::effect`).
    pub fn new(width: u32, height: u32, s: &Settings, keep_raw: bool) -> TargetsDesc {
        TargetsDesc {
            width,
            height,
            fluid: scaled(width, height, s.fluid_scale),
            thickness: scaled(width, height, s.thickness.scale),
            keep_raw,
            zbuffer: s.splat.mode.depth_tested() || s.surface == crate::settings::Surface::Mesh,
        }
    }

    /// The output size.
    pub fn full(&self) -> vk::Extent2D {
        vk::Extent2D { width: self.width, height: self.height }
    }

    /// Whether the fluid runs at reduced resolution (then `upsample` brings its depth to full size).
    pub fn upsampled(&self) -> bool {
        self.fluid != self.full()
    }
}

/// `scale` of `width`×`height` (clamped to [0.05, 1]; at least 1×1).
pub fn scaled(width: u32, height: u32, scale: f32) -> vk::Extent2D {
    let s = scale.clamp(0.05, 1.0);
    vk::Extent2D {
        width: ((width as f32 * s).round() as u32).max(1),
        height: ((height as f32 * s).round() as u32).max(1),
    }
}

/// The images of one frame description.
pub struct Targets {
    /// What these images were made for.
    pub desc: TargetsDesc,
    /// Output width.
    pub width: u32,
    /// Output height.
    pub height: u32,
    /// Background colour (RGBA16F).
    pub scene_color: Image,
    /// Background linear depth (R32F).
    pub scene_depth: Image,
    /// Raw splatted depth: R32_SFLOAT with an R32_UINT view for atomics.
    pub depth: Image,
    /// First smoothing ping-pong image.
    pub filter_a: Image,
    /// The second ping-pong image when the raw depth is kept (else the raw depth itself is the second one).
    pub filter_b: Option<Image>,
    /// Occlusion bound per 8×8 tile of `depth` (the compute splat's software Hi-Z), R32_UINT float bits.
    pub depth_tiles: Image,
    /// The compute splat's work counts (`crate::work::SplatWork`).
    pub splat_work: crate::work::Counters,
    /// D32 depth buffer of the depth-tested rasterised splat variants.
    pub zbuffer: Option<Image>,
    /// Full-resolution depth upsampled from the fluid resolution (`fluid_scale` < 1).
    pub depth_full: Option<Image>,
    /// Fixed-point thickness accumulator (R32_UINT).
    pub thickness_accum: Image,
    /// Thickness in world units (R32F, sampled).
    pub thickness: Image,
    /// Packed view-space normals (octahedral, R32_UINT).
    pub normals: Image,
    /// SSR hit uv per pixel (R32_UINT).
    pub ssr: Image,
    /// The `composite` pass's output (RGBA8).
    pub final_color: Image,
}

impl Targets {
    /// Allocate the images `d` describes.
    pub fn new(gpu: &Arc<Gpu>, d: TargetsDesc) -> Result<Targets> {
        use vk::ImageUsageFlags as U;
        let full = d.full();
        let fluid = d.fluid;
        let storage = U::STORAGE | U::TRANSFER_SRC | U::TRANSFER_DST;
        let img = |name, ext, fmt, usage, alt| Image::new(gpu, name, ext, fmt, usage, alt);
        let r32 = vk::Format::R32_SFLOAT;
        let bits = Some(vk::Format::R32_UINT);
        let tiles = vk::Extent2D {
            width: fluid.width.div_ceil(crate::shader_constants::SPLAT_TILE),
            height: fluid.height.div_ceil(crate::shader_constants::SPLAT_TILE),
        };
        let made = (|| -> Result<Targets> {
            Ok(Targets {
                desc: d,
                width: d.width,
                height: d.height,
                scene_color: img("scene_color", full, vk::Format::R16G16B16A16_SFLOAT, storage | U::SAMPLED, None)?,
                scene_depth: img("scene_depth", full, r32, storage, None)?,
                depth: img("depth", fluid, r32, storage | U::COLOR_ATTACHMENT, bits)?,
                depth_tiles: img("depth_tiles", tiles, vk::Format::R32_UINT, storage, None)?,
                splat_work: crate::work::Counters::new(gpu, "splat_work")?,
                zbuffer: d
                    .zbuffer
                    .then(|| img("zbuffer", fluid, vk::Format::D32_SFLOAT, U::DEPTH_STENCIL_ATTACHMENT, None))
                    .transpose()?,
                filter_a: img("filter_a", fluid, r32, storage, None)?,
                filter_b: d.keep_raw.then(|| img("filter_b", fluid, r32, storage, None)).transpose()?,
                depth_full: d.upsampled().then(|| img("depth_full", full, r32, storage, None)).transpose()?,
                thickness_accum: img("thickness_accum", d.thickness, vk::Format::R32_UINT, storage, None)?,
                thickness: img("thickness", d.thickness, r32, storage | U::SAMPLED, None)?,
                normals: img("normals", full, vk::Format::R32_UINT, storage, None)?,
                ssr: img("ssr", full, vk::Format::R32_UINT, storage, None)?,
                final_color: img("final", full, vk::Format::R8G8B8A8_UNORM, storage, None)?,
            })
        })();
        // A frame larger than the device holds is the user's size, not a Vulkan failure: say so with the size.
        // 28 bytes per output pixel (scene colour and depth, normals, SSR, final) and about 8 per fluid pixel
        // (depth, smoothing, thickness).
        let px = |e: vk::Extent2D| e.width as u64 * e.height as u64;
        made.map_err(|e| too_large(e, full, 28 * px(full) + 8 * px(fluid)))
    }

    /// The smoothing ping-pong pair: `filter_a`, then `filter_b` or (without it) the raw depth.
    pub fn ping_pong(&self) -> (&Image, &Image) {
        (&self.filter_a, self.filter_b.as_ref().unwrap_or(&self.depth))
    }

    /// The image that holds the smoothed depth ([`crate::passes::filter::Output`]).
    pub fn smoothed(&self, which: crate::passes::filter::Output) -> &Image {
        use crate::passes::filter::Output;
        match which {
            Output::Input => &self.depth,
            Output::First => self.ping_pong().0,
            Output::Second => self.ping_pong().1,
        }
    }

    /// The compute splat's work in the last frame it drew (waits for the device: for `bench` and tests).
    pub fn splat_work(&self, gpu: &Arc<Gpu>) -> Result<crate::work::SplatWork> {
        let [tests, spheres, tiles_skipped, _] = self.splat_work.read(gpu)?;
        Ok(crate::work::SplatWork { tests, spheres, tiles_skipped })
    }

    /// (name, bytes) of every image that exists.
    pub fn memory(&self) -> Vec<(&str, u64)> {
        let always = [
            &self.scene_color,
            &self.scene_depth,
            &self.depth,
            &self.filter_a,
            &self.depth_tiles,
            &self.thickness_accum,
            &self.thickness,
            &self.normals,
            &self.ssr,
            &self.final_color,
        ];
        let optional = [&self.filter_b, &self.depth_full, &self.zbuffer];
        always.into_iter().chain(optional.into_iter().flatten()).map(|i| (i.name.as_str(), i.bytes())).collect()
    }
}

/// An allocation failure of a frame's images, as what it is: a frame of `size` too large for the device (about
/// `bytes` of images), said with its size and what to change. Other errors pass through.
pub fn too_large(e: crate::error::Error, size: vk::Extent2D, bytes: u64) -> crate::error::Error {
    match e {
        crate::error::Error::Alloc { .. } | crate::error::Error::Vulkan { .. } | crate::error::Error::Limit(_) => {
            crate::error::Error::Limit(format!(
                "a {}×{} frame needs about {:.0} MB of images, more than this device could allocate ({e}); choose a \
                 smaller --width/--height or --fluid-scale",
                size.width,
                size.height,
                bytes as f64 / 1e6
            ))
        }
        e => e,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::Surface;

    /// The description alone decides which optional images exist; equal settings give equal descriptions.
    #[test]
    fn optional_images_follow_the_settings() {
        let s = Settings { surface: Surface::Spheres, ..Settings::default() };
        let d = TargetsDesc::new(640, 360, &s, false);
        assert!(!d.zbuffer && !d.keep_raw && !d.upsampled());
        assert_eq!(d, TargetsDesc::new(640, 360, &s.clone(), false));
        let half = Settings { fluid_scale: 0.5, ..s.clone() };
        let d = TargetsDesc::new(640, 360, &half, true);
        assert!(d.upsampled() && d.keep_raw);
        assert_eq!(d.fluid, vk::Extent2D { width: 320, height: 180 });
        let quad = s.with(|s| s.splat.mode = crate::named::SplatMode::QuadFragDepth);
        assert!(TargetsDesc::new(640, 360, &quad, false).zbuffer);
        assert!(
            !TargetsDesc::new(640, 360, &s.with(|s| s.splat.mode = crate::named::SplatMode::QuadMin), false).zbuffer
        );
    }
}
