//! Transfers between host and device outside the frame: a storage buffer filled from host data, images and
//! buffers read back, an image filled from host texels — each a one-shot submission with the barriers its
//! accesses imply — and the copy commands a frame records for its read-back and uploads.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::error::{Error, Result};
use crate::gpu::{Access, Buffer, FrameCtx, Gpu, Image, Use};

/// A GPU-local storage buffer holding `data` (via a staging copy; none for empty data); `reuse` is filled
/// instead of allocating when it is large enough. More than the device's storage buffer range is an error.
pub fn upload_buffer(gpu: &Arc<Gpu>, name: &str, data: &[u8], reuse: Option<Buffer>) -> Result<Buffer> {
    let limit = gpu.info.max_storage_buffer_range;
    if data.len() as u64 > limit {
        return Err(Error::Limit(format!(
            "{name}: {} bytes exceed this device's storage buffer limit of {limit} bytes",
            data.len()
        )));
    }
    let size = (data.len() as u64).max(16);
    let dst = match reuse {
        Some(b) if b.size >= size => b,
        _ => Buffer::new(
            gpu,
            name,
            size,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?,
    };
    if !data.is_empty() {
        let staging = Buffer::with_data(gpu, "staging", data, vk::BufferUsageFlags::TRANSFER_SRC)?;
        gpu.one_shot(|cmd| {
            let mut ctx = FrameCtx::new(gpu, cmd, None);
            ctx.barrier(&[Use::Buffer(&dst, Access::TransferDst)]);
            let region = vk::BufferCopy { src_offset: 0, dst_offset: 0, size: data.len() as u64 };
            unsafe { gpu.device.cmd_copy_buffer(cmd, staging.raw, dst.raw, &[region]) };
            Ok(())
        })?;
    }
    Ok(dst)
}

/// Copy the first `bytes` bytes of a device buffer (made with TRANSFER_SRC usage) into host memory.
pub fn read_buffer(gpu: &Arc<Gpu>, src: &Buffer, bytes: u64) -> Result<Vec<u8>> {
    read_buffer_at(gpu, src, 0, bytes)
}

/// Copy `bytes` bytes of a device buffer (made with TRANSFER_SRC usage) from `offset` on into host memory
/// (clipped to the buffer).
pub fn read_buffer_at(gpu: &Arc<Gpu>, src: &Buffer, offset: u64, bytes: u64) -> Result<Vec<u8>> {
    let bytes = bytes.min(src.size.saturating_sub(offset));
    let buf = read_back(gpu, &[(src, offset, bytes)])?;
    Ok(buf[0].read()?[..bytes as usize].to_vec())
}

/// Copy several ranges `(buffer, offset, bytes)` of device buffers (TRANSFER_SRC usage) into host-visible
/// buffers in one submission; [`host_vec`] takes each out as a vector (one copy, out of the mapped memory).
pub fn read_back(gpu: &Arc<Gpu>, ranges: &[(&Buffer, u64, u64)]) -> Result<Vec<Buffer>> {
    let bufs = ranges
        .iter()
        .map(|&(_, _, bytes)| {
            Buffer::new(gpu, "readback", bytes.max(16), vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu)
        })
        .collect::<Result<Vec<_>>>()?;
    gpu.one_shot(|cmd| {
        let mut ctx = FrameCtx::new(gpu, cmd, None);
        for (&(src, offset, bytes), dst) in ranges.iter().zip(&bufs) {
            ctx.copy_buffer(src, dst, vk::BufferCopy { src_offset: offset, dst_offset: 0, size: bytes });
        }
        let uses: Vec<Use> = bufs.iter().map(|b| Use::Buffer(b, Access::HostRead)).collect();
        ctx.barrier(&uses);
        Ok(())
    })?;
    Ok(bufs)
}

/// The first `n` items of a buffer [`read_back`] filled.
pub fn host_vec<T: bytemuck::Pod>(b: &Buffer, n: usize) -> Result<Vec<T>> {
    Ok(bytemuck::pod_collect_to_vec(&b.read()?[..n * std::mem::size_of::<T>()]))
}

/// Copy a whole image into host memory (tightly packed texels).
pub fn read_image(gpu: &Arc<Gpu>, img: &Image) -> Result<Vec<u8>> {
    let size = img.bytes();
    let buf = Buffer::new(gpu, "readback", size, vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu)?;
    gpu.one_shot(|cmd| {
        let mut ctx = FrameCtx::new(gpu, cmd, None);
        record_image_copy(&mut ctx, img, &buf);
        Ok(())
    })?;
    Ok(buf.read()?.to_vec())
}

/// Record a copy of all of `img` into the host-visible `buf` (tightly packed), made visible to the host.
pub fn record_image_copy(ctx: &mut FrameCtx, img: &Image, buf: &Buffer) {
    ctx.barrier(&[Use::Image(img, Access::TransferSrc, false), Use::Buffer(buf, Access::TransferDst)]);
    let region = vk::BufferImageCopy::default()
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        })
        .image_extent(vk::Extent3D { width: img.extent.width, height: img.extent.height, depth: 1 });
    unsafe {
        ctx.gpu.device.cmd_copy_image_to_buffer(ctx.cmd, img.raw, Access::TransferSrc.info().layout, buf.raw, &[region])
    };
    ctx.barrier(&[Use::Buffer(buf, Access::HostRead)]);
}

/// Read a 32-bit float image.
pub fn read_f32(gpu: &Arc<Gpu>, img: &Image) -> Result<Vec<f32>> {
    Ok(bytemuck::pod_collect_to_vec(&read_image(gpu, img)?))
}

/// Read a 32-bit unsigned integer image (fixed-point accumulators, packed normals).
pub fn read_u32(gpu: &Arc<Gpu>, img: &Image) -> Result<Vec<u32>> {
    Ok(bytemuck::pod_collect_to_vec(&read_image(gpu, img)?))
}

/// Record a copy of tightly packed texels from `src` into the `extent` corner of every layer of `img` (its
/// old contents dropped), after the barrier that makes `img` a transfer destination.
pub fn record_upload(ctx: &mut FrameCtx, src: &Buffer, img: &Image, extent: vk::Extent2D) {
    ctx.barrier(&[Use::Image(img, Access::TransferDst, true)]);
    let region = vk::BufferImageCopy::default()
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: img.layers,
        })
        .image_extent(vk::Extent3D { width: extent.width, height: extent.height, depth: 1 });
    unsafe {
        ctx.gpu.device.cmd_copy_buffer_to_image(ctx.cmd, src.raw, img.raw, Access::TransferDst.info().layout, &[region])
    };
}

/// Fill a whole image from host memory (tightly packed texels); leaves it ready for compute reads.
pub fn upload_image(gpu: &Arc<Gpu>, img: &Image, data: &[u8]) -> Result<()> {
    if data.len() as u64 != img.bytes() {
        return Err(Error::Invalid(format!(
            "upload of {} bytes into {} ({} bytes)",
            data.len(),
            img.name,
            img.bytes()
        )));
    }
    let staging = Buffer::with_data(gpu, "upload", data, vk::BufferUsageFlags::TRANSFER_SRC)?;
    gpu.one_shot(|cmd| {
        let mut ctx = FrameCtx::new(gpu, cmd, None);
        record_upload(&mut ctx, &staging, img, img.extent);
        Ok(())
    })
}
