//! The iso surface's frame resources, sized for the fluid resolution: the march's far bound per pixel and per
//! 8×8 tile (the compute splat writes one of them, the cast stops there) and the cast's queue of unfinished
//! rays. Made by the technique's prepare when the fluid size changes; the images every surface shares stay in
//! `crate::targets`.
use std::sync::Arc;

use ash::vk;

use crate::error::Result;
use crate::gpu::{Gpu, Image};

use super::queue::IsoQueue;

/// The iso surface's images and queue for one fluid size.
pub struct IsoTargets {
    /// The march's far bound per pixel, R32F + R32_UINT view (the compute splat's back depth).
    pub depth_back: Image,
    /// The same per 8×8 tile (written instead when the splat culls).
    pub depth_back_tiles: Image,
    /// The cast's queue of unfinished rays.
    pub queue: IsoQueue,
}

impl IsoTargets {
    /// The resources of a `fluid`-sized frame.
    pub fn new(gpu: &Arc<Gpu>, fluid: vk::Extent2D) -> Result<IsoTargets> {
        use vk::ImageUsageFlags as U;
        let usage = U::STORAGE | U::TRANSFER_SRC | U::TRANSFER_DST;
        let (r32, bits) = (vk::Format::R32_SFLOAT, Some(vk::Format::R32_UINT));
        let tile = crate::shader_constants::SPLAT_TILE;
        let tiles = vk::Extent2D { width: fluid.width.div_ceil(tile), height: fluid.height.div_ceil(tile) };
        let made = (|| {
            Ok(IsoTargets {
                depth_back: Image::new(gpu, "depth_back", fluid, r32, usage, bits)?,
                depth_back_tiles: Image::new(gpu, "depth_back_tiles", tiles, r32, usage, bits)?,
                queue: IsoQueue::new(gpu, fluid.width, fluid.height)?,
            })
        })();
        // 4 bytes of far bound and 16 of queue per fluid pixel: a fluid image too large for the device is the
        // user's size (the fluid's, which is the frame's at the default fluid scale).
        made.map_err(|e| crate::targets::too_large(e, fluid, 20 * fluid.width as u64 * fluid.height as u64))
    }

    /// The fluid size they were made for.
    pub fn size(&self) -> vk::Extent2D {
        self.depth_back.extent
    }

    /// (name, bytes) of each.
    pub fn memory(&self) -> Vec<(&str, u64)> {
        vec![
            (self.depth_back.name.as_str(), self.depth_back.bytes()),
            (self.depth_back_tiles.name.as_str(), self.depth_back_tiles.bytes()),
            (self.queue.entries.name.as_str(), self.queue.entries.size),
        ]
    }
}
