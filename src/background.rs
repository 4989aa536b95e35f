//! The scene behind the fluid on the device, in one place: the sky cube map, the background geometry's BVH
//! (`--background-obj`, a scene.json's bodies), and what the background images last showed — the `background`
//! pass is skipped while the camera, size, scene and settings stand (a sequence re-renders only the fluid).

use std::sync::Arc;

use ash::vk;

use crate::error::Result;
use crate::gpu::executor::Executor;
use crate::gpu::transfer::{upload_buffer, upload_image};
use crate::gpu::{Gpu, Image};
use crate::passes::background::BvhBuffers;
use crate::scene::geometry::{Geometry, GpuBvh};
use crate::settings::Settings;
use crate::view::View;

/// The background's device resources and cache key.
pub struct Background {
    /// Sky cube map (a 1×1 placeholder until [`Background::set_skybox`]).
    pub sky: Image,
    /// The geometry's BVH (placeholders and node count 0 without one).
    geometry: BvhBuffers,
    /// What the background images show; the pass is skipped while it holds.
    key: Option<String>,
    /// Re-render the background every frame even when nothing changed (for measuring the pass).
    pub always_render: bool,
}

impl Background {
    /// The procedural sky's placeholder cube and no geometry.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Background> {
        let sky = Image::new_cube(
            gpu,
            "sky",
            1,
            vk::Format::R8G8B8A8_UNORM,
            vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
        )?;
        upload_image(gpu, &sky, &[150, 190, 235, 255].repeat(6))?;
        Ok(Background {
            sky,
            // Never read (node count 0): empty placeholders, no upload at start-up.
            geometry: BvhBuffers {
                nodes: upload_buffer(gpu, "bvh_nodes", &[], None)?,
                triangles: upload_buffer(gpu, "bvh_triangles", &[], None)?,
                node_count: 0,
            },
            key: None,
            always_render: false,
        })
    }

    /// The geometry's buffers (placeholders when none is set).
    pub fn geometry(&self) -> &BvhBuffers {
        &self.geometry
    }

    /// Set the background geometry (world coordinates), after the frames in flight.
    pub fn set_geometry(&mut self, gpu: &Arc<Gpu>, executor: &Executor, g: &Geometry) -> Result<()> {
        executor.wait_idle()?;
        let bvh = GpuBvh::build(g);
        self.geometry = BvhBuffers {
            nodes: upload_buffer(gpu, "bvh_nodes", bytemuck::cast_slice(&bvh.nodes), None)?,
            triangles: upload_buffer(gpu, "bvh_triangles", bytemuck::cast_slice(&bvh.triangles), None)?,
            node_count: bvh.len() as u32,
        };
        self.key = None;
        Ok(())
    }

    /// Load a sky cube map: six RGBA8 faces of `size`², order +X −X +Y −Y +Z −Z (see `crate::scene::sky`). Set
    /// `Environment::sky_cube` to use it.
    pub fn set_skybox(&mut self, gpu: &Arc<Gpu>, executor: &Executor, size: u32, faces: &[u8]) -> Result<()> {
        executor.wait_idle()?;
        let sky = Image::new_cube(
            gpu,
            "sky",
            size,
            vk::Format::R8G8B8A8_UNORM,
            vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
        )?;
        upload_image(gpu, &sky, faces)?;
        self.sky = sky;
        self.key = None;
        Ok(())
    }

    /// The images were reallocated: the next frame renders the background.
    pub fn invalidate(&mut self) {
        self.key = None;
    }

    /// Whether this frame can reuse the last frame's background, and remember this frame's.
    pub fn cached(&mut self, view: &View, s: &Settings) -> bool {
        let key = format!(
            "{:?}|{}x{}|{:?}|{:?}|{:?}|{}",
            view.camera,
            view.width,
            view.height,
            view.env,
            s.background.sun_dir,
            s.background.sun_intensity,
            s.composite.ambient
        );
        let hit = !self.always_render && self.key.as_deref() == Some(key.as_str());
        self.key = Some(key);
        hit
    }
}
