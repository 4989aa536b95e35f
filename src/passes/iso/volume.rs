//! The smoothed iso field's buffers on the device (`iso_volume`, shaders_glsl/iso_volume.comp): the sparse
//! lattice's brick table, the pool of allocated bricks and their sums, the deposit's work counts, and the push
//! constants of its dispatches. The field itself is defined by `crate::field::volume` (its CPU reference).
use std::sync::Arc;

use ash::vk;

use super::IsoPush;
use crate::error::Result;
use crate::gpu::{Buffer, Gpu};

/// The smoothed iso field on its sparse lattice (`iso_volume`), read by the volume cast.
pub struct IsoVolume {
    /// The lattice.
    pub shape: crate::field::volume::VolumeShape,
    /// Bricks the pool holds.
    pub capacity: u32,
    /// Per brick of the box: 0, or its pool index + 1 (R32UI texels).
    pub table: Buffer,
    /// {0, 1, 1, bricks}: the bricks allocated.
    pub header: Buffer,
    /// The allocated bricks' coordinates, packed (R32UI texels).
    pub coords: Buffer,
    /// Two fixed-point sums per stored voxel of the pool (10³ per brick: its 8³ and an apron), (B, B c̄): the
    /// field the cast reads (RG32UI texels).
    pub acc: Buffer,
    /// The deposit's work counts: [0] point–voxel deposits ([`IsoVolume::work`]).
    pub work: crate::work::Counters,
    /// Whether the deposit takes one 64-bit atomic per deposit (else two 32-bit ones).
    pub deposit64: bool,
}

impl IsoVolume {
    /// Buffers for the lattice `shape` with a pool of `capacity` bricks.
    pub fn new(gpu: &Arc<Gpu>, shape: crate::field::volume::VolumeShape, capacity: u32) -> Result<IsoVolume> {
        let voxels = capacity.max(1) as u64 * crate::field::volume::STORED_BRICK_VOXELS as u64;
        let limit = gpu.info.max_storage_buffer_range.min(gpu.info.max_texel_buffer_elements * 8);
        if 8 * voxels > limit {
            return Err(crate::error::Error::Limit(format!(
                "the smoothed iso field needs {capacity} bricks of {b}³ voxels ({} MiB of sums with their aprons), more than this \
                 device's largest buffer ({} MiB): set [iso] voxel larger (now {:.4} world units) or smoothing = 0 \
                 (--preset quality: the exact field, no lattice)",
                (8 * voxels) >> 20,
                limit >> 20,
                shape.spacing,
                b = crate::field::volume::BRICK
            )));
        }
        // TRANSFER_DST: zeroed before each build; TRANSFER_SRC: the tests read the field back.
        use vk::BufferUsageFlags as U;
        let usage = U::STORAGE_BUFFER | U::TRANSFER_DST | U::TRANSFER_SRC;
        let table = shape.table_len() as u64;
        Ok(IsoVolume {
            shape,
            capacity,
            table: Buffer::texels(gpu, "iso_volume_table", 4 * table, usage, vk::Format::R32_UINT)?,
            header: Buffer::texels(gpu, "iso_volume_header", 16, usage, vk::Format::R32_UINT)?,
            coords: Buffer::texels(gpu, "iso_volume_coords", 4 * capacity.max(1) as u64, usage, vk::Format::R32_UINT)?,
            acc: Buffer::texels(gpu, "iso_volume_acc", 8 * voxels, usage, vk::Format::R32G32_UINT)?,
            work: crate::work::Counters::new(gpu, "iso_volume_work")?,
            deposit64: gpu.info.int64_atomics,
        })
    }

    /// The last build's deposit (waits for the device: for `bench` and tests, after a frame that built it).
    pub fn work(&self, gpu: &Arc<Gpu>) -> Result<crate::work::IsoVolumeWork> {
        let [deposits, ..] = self.work.read(gpu)?;
        Ok(crate::work::IsoVolumeWork { deposits, atomics: if self.deposit64 { deposits } else { 2 * deposits } })
    }

    /// Whether these buffers hold the lattice `shape` with `bricks` allocated.
    pub fn fits(&self, shape: &crate::field::volume::VolumeShape, bricks: u32) -> bool {
        self.table.size >= 4 * shape.table_len() as u64 && self.capacity >= bricks
    }

    /// `push` with this lattice in `aniso` (origin, spacing), `aniso2.yzw` (bricks per axis) and `volume` (the
    /// bulk ramp), as iso_field.glsl reads it.
    pub fn push(&self, push: IsoPush, p: &crate::field::volume::VolumeParams) -> IsoPush {
        let (o, b) = (self.shape.origin, self.shape.bricks);
        IsoPush {
            aniso: [o.x, o.y, o.z, self.shape.spacing],
            aniso2: [0.0, b[0] as f32, b[1] as f32, b[2] as f32],
            volume: [p.bulk[0], p.bulk[1], p.gradient_bound(), self.shape.empty_reach()],
            ..push
        }
    }

    /// The push constants of iso_volume.comp for `points` points.
    pub fn vol_push(&self, p: &crate::field::volume::VolumeParams, points: u32) -> VolPush {
        let (o, b) = (self.shape.origin, self.shape.bricks);
        VolPush {
            origin: [o.x, o.y, o.z, self.shape.spacing],
            bdims: [b[0], b[1], b[2], self.capacity],
            params: [p.deposit_scale(), p.deposit_radius() / self.shape.spacing, self.shape.taps as f32, 0.0],
            misc: [points, 0, 0, 0],
        }
    }
}

/// Push constants of iso_volume.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VolPush {
    /// xyz: voxel (0, 0, 0), w: spacing (world units).
    pub origin: [f32; 4],
    /// xyz: bricks per axis, w: the pool's capacity (bricks).
    pub bdims: [u32; 4],
    /// x: the deposit's scale I_W h³ / (0.6383 R³), y: R (voxels), z: ⌈R⌉.
    pub params: [f32; 4],
    /// x: points.
    pub misc: [u32; 4],
}
