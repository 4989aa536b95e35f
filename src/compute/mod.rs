//! Compute primitives shared beyond the frame: THE neighbour grid (`grid`: a counting sort of points into cells
//! on the GPU, used by the `iso` surface, the simulation and the marching cubes), the GPU marching cubes (`mc`:
//! `meniscus mesh --gpu`, the Python package), the meshes' Laplacian smoothing and normals (`smooth`) and the
//! compute clear of 32-bit storage images (`clear`: the
//! passes' accumulators and depth images). Below the passes, the surfaces and the simulation, which all use
//! them; they use only `gpu`, `field` and the shaders.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::error::Result;
use crate::gpu::{Buffer, Gpu};

pub mod clear;
pub mod grid;
pub mod mc;
pub mod smooth;

/// Work groups for `n` of them, as (x, y) with x at most 32,768 (the shaders flatten them back): more than a
/// dispatch's x may hold on some devices.
pub(crate) fn groups_2d(n: u32) -> [u32; 3] {
    let x = n.clamp(1, 32_768);
    [x, n.div_ceil(x).max(1), 1]
}

/// A device-local storage buffer of at least `bytes` (16 at least) that transfers may fill and read back.
pub(crate) fn device_buffer(gpu: &Arc<Gpu>, name: &str, bytes: u64) -> Result<Buffer> {
    let usage =
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST;
    Buffer::new(gpu, name, bytes.max(16), usage, MemoryLocation::GpuOnly)
}
