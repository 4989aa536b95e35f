//! The `iso` cast's queue of unfinished rays (iso_cast.glsl): the first dispatch appends the rays still marching
//! after `[iso] first_steps` samples, the second dispatches finish them, indirectly, from its header; and the
//! tiles of the screen that hold fluid, which the first dispatch runs on (iso_tiles.comp).
use std::sync::Arc;

use crate::error::Result;
use crate::gpu::{Buffer, Gpu};

/// Bytes of the queue's header (IsoQueue::header); the wide dispatches' arguments (8 and 32 lanes per ray) and
/// the first dispatch's (a work group per listed tile) at these offsets.
const HEADER_BYTES: u64 = 80;
pub(super) const WIDE8_ARGS: u64 = 32;
pub(super) const WIDE32_ARGS: u64 = 48;
pub(super) const TILES_ARGS: u64 = 64;

/// The cast's queue of unfinished rays, sized for one fluid resolution (in the frame's targets).
pub struct IsoQueue {
    /// One entry (pixel, march state: 16 bytes) per pixel.
    pub entries: Buffer,
    /// Two rounds of {groups x, 1, 1, count}: the `rest` dispatches' indirect arguments and entry counts
    /// (round 0: the first dispatch's unfinished rays; round 1: the fine dispatch's fallbacks), then round 0's
    /// indirect arguments with 8 and with 32 lanes per ray, {groups x, 1, 1} and a word of padding each; then the
    /// first dispatch's, {tiles listed, 1, 1} and a word of padding.
    pub header: Buffer,
    /// The tiles (LOCAL_2D × LOCAL_2D pixels) whose bound spheres' depth holds fluid, x | y << 16 each
    /// (iso_tiles.comp lists them, the first dispatch runs a work group on each).
    pub tiles: Buffer,
    /// The cast's work counts: [0] field samples (iso_cast.glsl's `iso_work`), zeroed with the header.
    pub work: crate::work::Counters,
}

impl IsoQueue {
    /// A queue for a `width`×`height` output.
    pub fn new(gpu: &Arc<Gpu>, width: u32, height: u32) -> Result<IsoQueue> {
        use ash::vk::BufferUsageFlags as U;
        use gpu_allocator::MemoryLocation;
        let pixels = width as u64 * height as u64;
        let local = crate::shader_constants::LOCAL_2D;
        let tiles = width.div_ceil(local) as u64 * height.div_ceil(local) as u64;
        Ok(IsoQueue {
            entries: Buffer::new(gpu, "iso_queue", 16 * pixels.max(1), U::STORAGE_BUFFER, MemoryLocation::GpuOnly)?,
            header: Buffer::new(
                gpu,
                "iso_queue_header",
                HEADER_BYTES,
                U::STORAGE_BUFFER | U::INDIRECT_BUFFER | U::TRANSFER_DST | U::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )?,
            tiles: Buffer::new(gpu, "iso_tiles", 4 * tiles.max(1), U::STORAGE_BUFFER, MemoryLocation::GpuOnly)?,
            work: crate::work::Counters::new(gpu, "iso_work")?,
        })
    }

    /// The last frame's queued rays and field samples (waits for the device: for `bench` and tests, after a frame).
    pub fn work(&self, gpu: &Arc<Gpu>) -> Result<crate::work::IsoWork> {
        // The header and the counters in one read-back.
        let counted = 4 * crate::work::Counters::WORDS as u64;
        let host =
            crate::gpu::transfer::read_back(gpu, &[(&self.header, 0, HEADER_BYTES), (&self.work.buffer, 0, counted)])?;
        let w: Vec<u32> = crate::gpu::transfer::host_vec(&host[0], HEADER_BYTES as usize / 4)?;
        let [samples, ..] = crate::work::Counters::words(&host[1])?;
        Ok(crate::work::IsoWork { queued: w[3] as u64, fallbacks: w[7] as u64, tiles: w[19] as u64, samples })
    }
}
