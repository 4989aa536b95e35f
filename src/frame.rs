//! The frame: its uniform block, its images, and `record_frame` — the table of contents of Meniscus.
//! Each pass derives its own barriers from the resources' last accesses; nothing here synchronises by hand.

use std::sync::Arc;

use ash::vk;
use glam::{Mat4, Vec3};

use crate::error::Result;
use crate::gpu::{Buffer, FrameCtx, Gpu, Image};
use crate::passes::composite::CompositeInputs;
use crate::passes::iso::IsoBuffers;
use crate::passes::{Background, Composite, Iso, Normals, Smooth, Splat, Ssr, Thickness, Upsample};
use crate::scene::{Bounds, Camera};
use crate::settings::{Settings, SplatMode, Surface};

/// Maximum number of boxes in the background scene (fixed array in the uniform block).
pub const MAX_BOXES: usize = 8;

/// Mirror of `Frame` in shaders_glsl/common.glsl (std140: only vec4/mat4 members).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FrameUniforms {
    pub view: [f32; 16],
    pub inv_view: [f32; 16],
    pub eye: [f32; 4],
    pub proj: [f32; 4],
    pub fluid: [f32; 4],
    pub sun: [f32; 4],
    pub ground: [f32; 4],
    pub extinction: [f32; 4],
    pub fluid_color: [f32; 4],
    pub shading: [f32; 4],
    pub shading2: [f32; 4],
    pub box_count: [f32; 4],
    pub box_min: [[f32; 4]; MAX_BOXES],
    pub box_max: [[f32; 4]; MAX_BOXES],
}

const _: () = assert!(std::mem::size_of::<FrameUniforms>() == 2 * 64 + 10 * 16 + 2 * 16 * MAX_BOXES);

/// The static scene around the fluid: a ground plane and a few boxes.
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    pub ground_y: f32,
    pub tile: f32,
    pub fog: f32,
    pub ground: bool,
    pub boxes: Vec<(Vec3, Vec3)>,
    /// A sky cube map is loaded in the renderer (see `Renderer::set_skybox`).
    pub sky_cube: bool,
}

impl Environment {
    /// Ground just under the fluid's lower percentile; with `boxes`, two pillars behind the fluid and a
    /// low block beside it, sized from the fluid's extent (so they show in reflections and refraction).
    pub fn around(b: &Bounds, radius: f32, s: &Settings) -> Environment {
        let ext = (b.hi - b.lo).max(Vec3::splat(radius * 4.0));
        let size = ext.max_element();
        let ground_y = b.lo.y - radius;
        let mut boxes = vec![];
        if s.scene_boxes {
            let w = size * 0.06;
            let h = size * 0.3;
            let z0 = b.lo.z - size * 0.15;
            for fx in [0.2f32, 0.75] {
                let x = b.lo.x + fx * ext.x;
                boxes.push((Vec3::new(x, ground_y, z0 - w), Vec3::new(x + w, ground_y + h, z0)));
            }
            let x = b.hi.x + w * 1.5;
            boxes.push((
                Vec3::new(x, ground_y, b.lo.z + ext.z * 0.3),
                Vec3::new(x + 2.0 * w, ground_y + 0.5 * h, b.lo.z + ext.z * 0.3 + 2.0 * w),
            ));
        }
        let tile = (size / 8.0).max(radius * 4.0);
        Environment { ground_y, tile, fog: size * 12.0, ground: s.ground, boxes, sky_cube: false }
    }
}

/// Everything that defines one frame's view.
#[derive(Clone, Debug)]
pub struct View {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub env: Environment,
}

impl FrameUniforms {
    /// Fill the block from the view and the settings.
    pub fn new(v: &View, s: &Settings, count: u32) -> FrameUniforms {
        let view: Mat4 = v.camera.view();
        let inv = view.inverse();
        let sun = Vec3::from(s.sun_dir).normalize_or(Vec3::Y);
        let ext = Vec3::from(s.extinction) * s.extinction_scale;
        let mut u = FrameUniforms {
            view: view.to_cols_array(),
            inv_view: inv.to_cols_array(),
            eye: v.camera.eye.extend(1.0).to_array(),
            proj: [v.camera.focal_px(v.height), v.width as f32, v.height as f32, v.camera.near],
            // Thickness fixed point: 1024 units per particle radius.
            fluid: [s.radius, s.fluid_scale, 1024.0 / s.radius, count as f32],
            sun: sun.extend(s.sun_intensity).to_array(),
            ground: [v.env.ground_y, v.env.tile, v.env.ground as u32 as f32, v.env.fog],
            extinction: ext.extend(0.0).to_array(),
            fluid_color: [s.fluid_color[0], s.fluid_color[1], s.fluid_color[2], s.ambient],
            shading: [s.refraction_alpha, s.refraction_beta, s.transparency_gamma, s.specular],
            shading2: [s.shininess, s.f0, s.reflect_sky as u32 as f32, v.env.sky_cube as u32 as f32],
            box_count: [v.env.boxes.len().min(MAX_BOXES) as f32, 0.0, 0.0, 0.0],
            box_min: [[0.0; 4]; MAX_BOXES],
            box_max: [[0.0; 4]; MAX_BOXES],
        };
        for (k, (lo, hi)) in v.env.boxes.iter().take(MAX_BOXES).enumerate() {
            u.box_min[k] = lo.extend(0.0).to_array();
            u.box_max[k] = hi.extend(0.0).to_array();
        }
        u
    }
}

/// The images of one frame size.
pub struct Targets {
    pub width: u32,
    pub height: u32,
    pub scene_color: Image,
    pub scene_depth: Image,
    /// Raw splatted depth: R32_SFLOAT with an R32_UINT view for atomics.
    pub depth: Image,
    pub smooth_a: Image,
    pub smooth_b: Image,
    /// Farthest exit depth of the splatted spheres (`surface = "iso"` only; 1×1 otherwise), R32F + R32_UINT view.
    pub depth_back: Image,
    /// Occlusion bound per 8×8 tile of `depth` (the compute splat's software Hi-Z), R32_UINT float bits.
    pub depth_tiles: Image,
    /// D32 depth buffer of the rasterised splat variants (1×1 when the compute splat runs).
    pub zbuffer: Image,
    /// Full-resolution depth upsampled from the fluid resolution (unused at fluid scale 1).
    pub depth_full: Image,
    pub thickness_accum: Image,
    pub thickness: Image,
    pub normals: Image,
    pub ssr: Image,
    pub final_color: Image,
}

impl Targets {
    /// `keep_raw`: keep the splatted depth intact through smoothing (for dumps); otherwise it doubles as a
    /// ping-pong image and `smooth_b` is a 1×1 placeholder (saves one screen-sized image).
    pub fn new(gpu: &Arc<Gpu>, width: u32, height: u32, s: &Settings, keep_raw: bool) -> Result<Targets> {
        use vk::ImageUsageFlags as U;
        let full = vk::Extent2D { width, height };
        let ts = s.thickness_scale.clamp(0.05, 1.0);
        let thick = vk::Extent2D {
            width: ((width as f32 * ts).round() as u32).max(1),
            height: ((height as f32 * ts).round() as u32).max(1),
        };
        let storage = U::STORAGE | U::TRANSFER_SRC | U::TRANSFER_DST;
        let fluid = fluid_extent(width, height, s.fluid_scale);
        let tiny = vk::Extent2D { width: 1, height: 1 };
        let upsampled = if fluid == full { tiny } else { full };
        let img = |name, ext, fmt, usage, alt| Image::new(gpu, name, ext, fmt, usage, alt);
        Ok(Targets {
            width,
            height,
            scene_color: img("scene_color", full, vk::Format::R16G16B16A16_SFLOAT, storage | U::SAMPLED, None)?,
            scene_depth: img("scene_depth", full, vk::Format::R32_SFLOAT, storage, None)?,
            depth: img(
                "depth",
                fluid,
                vk::Format::R32_SFLOAT,
                storage | U::COLOR_ATTACHMENT,
                Some(vk::Format::R32_UINT),
            )?,
            depth_back: img(
                "depth_back",
                if s.surface == Surface::Iso { fluid } else { tiny },
                vk::Format::R32_SFLOAT,
                storage,
                Some(vk::Format::R32_UINT),
            )?,
            depth_tiles: img(
                "depth_tiles",
                vk::Extent2D {
                    width: fluid.width.div_ceil(crate::passes::splat::TILE),
                    height: fluid.height.div_ceil(crate::passes::splat::TILE),
                },
                vk::Format::R32_UINT,
                storage,
                None,
            )?,
            zbuffer: img(
                "zbuffer",
                if s.splat.depth_tested() { fluid } else { tiny },
                vk::Format::D32_SFLOAT,
                U::DEPTH_STENCIL_ATTACHMENT,
                None,
            )?,
            smooth_a: img("smooth_a", fluid, vk::Format::R32_SFLOAT, storage, None)?,
            smooth_b: img("smooth_b", if keep_raw { fluid } else { tiny }, vk::Format::R32_SFLOAT, storage, None)?,
            depth_full: img("depth_full", upsampled, vk::Format::R32_SFLOAT, storage, None)?,
            thickness_accum: img("thickness_accum", thick, vk::Format::R32_UINT, storage, None)?,
            thickness: img("thickness", thick, vk::Format::R32_SFLOAT, storage | U::SAMPLED, None)?,
            normals: img("normals", full, vk::Format::R32_UINT, storage, None)?,
            ssr: img("ssr", full, vk::Format::R32_UINT, storage, None)?,
            final_color: img("final", full, vk::Format::R8G8B8A8_UNORM, storage, None)?,
        })
    }

    /// The image that `Smoothed` names.
    pub fn smoothed(&self, which: Smoothed) -> &Image {
        match which {
            Smoothed::Raw => &self.depth,
            Smoothed::A => &self.smooth_a,
            Smoothed::B => &self.smooth_b,
        }
    }

    /// (name, bytes) of every image.
    pub fn memory(&self) -> Vec<(&str, u64)> {
        [
            &self.scene_color,
            &self.scene_depth,
            &self.depth,
            &self.smooth_a,
            &self.smooth_b,
            &self.depth_full,
            &self.zbuffer,
            &self.depth_back,
            &self.depth_tiles,
            &self.thickness_accum,
            &self.thickness,
            &self.normals,
            &self.ssr,
            &self.final_color,
        ]
        .iter()
        .map(|i| (i.name.as_str(), i.bytes()))
        .collect()
    }
}

/// The passes, created once per device.
pub struct Passes {
    pub background: Background,
    pub splat: Splat,
    pub iso: Iso,
    pub thickness: Thickness,
    pub smooth: Smooth,
    pub normals: Normals,
    pub ssr: Ssr,
    pub composite: Composite,
    pub upsample: Upsample,
}

impl Passes {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Passes> {
        Ok(Passes {
            background: Background::new(gpu)?,
            splat: Splat::new(gpu)?,
            iso: Iso::new(gpu)?,
            thickness: Thickness::new(gpu)?,
            smooth: Smooth::new(gpu)?,
            normals: Normals::new(gpu)?,
            ssr: Ssr::new(gpu)?,
            upsample: Upsample::new(gpu)?,
            composite: Composite::new(gpu)?,
        })
    }
}

/// Size of the fluid images at `scale` of `width`×`height` (at least 1×1).
pub fn fluid_extent(width: u32, height: u32, scale: f32) -> vk::Extent2D {
    let s = scale.clamp(0.05, 1.0);
    vk::Extent2D {
        width: ((width as f32 * s).round() as u32).max(1),
        height: ((height as f32 * s).round() as u32).max(1),
    }
}

/// Which image holds the smoothed depth after a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Smoothed {
    Raw,
    A,
    B,
}

/// THE FRAME: every pass in order. (Resources are passed explicitly: each pass declares what it touches.)
#[allow(clippy::too_many_arguments)]
pub fn record_frame(
    ctx: &mut FrameCtx,
    p: &Passes,
    t: &Targets,
    frame: &Buffer,
    particles: &Buffer,
    count: u32,
    iso: Option<&IsoBuffers>,
    s: &Settings,
    (cf_iterations, splat_cull): (u32, bool),
    (sky, mesh): (&Image, &crate::passes::background::MeshBuffers),
    background_cached: bool,
) -> Result<Smoothed> {
    // The background is static: when neither the view nor the scene changed, last frame's images stand.
    if !background_cached {
        p.background.record(ctx, frame, sky, mesh, &t.scene_color, &t.scene_depth);
    }
    match s.splat {
        SplatMode::Compute => {
            let back = s.surface == Surface::Iso && t.depth_back.extent == t.depth.extent;
            p.splat.record(
                ctx,
                frame,
                particles,
                count,
                &t.depth,
                &t.depth_back,
                &t.depth_tiles,
                back,
                splat_cull,
                s.splat_scale(),
            )
        }
        mode => p.splat.record_raster(ctx, frame, particles, count, &t.depth, &t.zbuffer, s.splat_scale(), mode)?,
    }
    if let (Surface::Iso, Some(grid)) = (s.surface, iso) {
        // The rasterised splats do not write the far exit: the march then runs to the grid's box.
        let back = (s.splat == SplatMode::Compute).then_some(&t.depth_back);
        p.iso.record(ctx, frame, grid, &s.iso_params(), &t.depth, back);
    }
    p.thickness.record(
        ctx,
        frame,
        particles,
        count,
        &t.scene_depth,
        &t.thickness_accum,
        &t.thickness,
        s.thickness_blur_px,
    );
    // Without a full-size smooth_b the raw depth is the second ping-pong image.
    let pong = if t.smooth_b.extent == t.smooth_a.extent { &t.smooth_b } else { &t.depth };
    let smoothed = p.smooth.record(ctx, frame, &t.depth, &t.smooth_a, pong, s, cf_iterations);
    let surface = if smoothed.extent == t.normals.extent {
        smoothed
    } else {
        p.upsample.record(ctx, frame, smoothed, &t.depth_full, s.normal_edge * s.radius);
        &t.depth_full
    };
    p.normals.record(ctx, frame, surface, &t.normals, s.normal_edge * s.radius);
    p.ssr.record(ctx, frame, surface, &t.normals, &t.scene_depth, &t.ssr, s);
    let inputs = CompositeInputs {
        scene_color: &t.scene_color,
        scene_depth: &t.scene_depth,
        depth: surface,
        normals: &t.normals,
        thickness: &t.thickness,
        ssr: &t.ssr,
        sky,
    };
    p.composite.record(ctx, frame, &inputs, &t.final_color);
    Ok(if std::ptr::eq(smoothed, &t.smooth_a) {
        Smoothed::A
    } else if std::ptr::eq(smoothed, &t.smooth_b) {
        Smoothed::B
    } else {
        Smoothed::Raw
    })
}
