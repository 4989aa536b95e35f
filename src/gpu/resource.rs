//! Images and buffers that remember their last access ([`AccessState`]), so barriers can be derived, and free
//! their memory on drop (each holds an `Arc<Gpu>`, so the device outlives it).

use std::cell::Cell;
use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::{AccessState, Gpu};
use crate::error::{Error, Result, VkContext};

/// A 2D image with one view (and optionally a second view in another 32-bit format of the same class, e.g.
/// an R32_UINT view of an R32_SFLOAT image for atomics).
pub struct Image {
    gpu: Arc<Gpu>,
    /// The image.
    pub raw: vk::Image,
    /// Its main view.
    pub view: vk::ImageView,
    /// A second view in another format (R32_UINT over R32_SFLOAT, for atomics).
    pub alt_view: Option<vk::ImageView>,
    /// Format.
    pub format: vk::Format,
    /// Size in pixels.
    pub extent: vk::Extent2D,
    /// Debug name (also the memory report's).
    pub name: String,
    /// Colour or depth.
    pub aspect: vk::ImageAspectFlags,
    /// Array layers (6 for a cube map).
    pub layers: u32,
    /// What it was created for (empty for an image owned elsewhere: a swapchain image).
    pub usage: vk::ImageUsageFlags,
    pub(crate) state: Cell<AccessState>,
    alloc: Option<Allocation>,
    /// False for images owned by someone else (swapchain images): only the view is destroyed.
    owned: bool,
}

/// Allocate memory for a resource through the GPU's allocator.
fn allocate(
    gpu: &Gpu,
    name: &str,
    requirements: vk::MemoryRequirements,
    location: MemoryLocation,
    linear: bool,
) -> Result<Allocation> {
    gpu.allocator
        .lock()
        .map_err(|_| Error::Invalid("the GPU allocator lock was poisoned by an earlier panic".into()))?
        .allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        })
        .map_err(|e| Error::Alloc { what: format!("{name} ({} bytes)", requirements.size), source: e })
}

/// Bytes per texel of the formats Meniscus uses.
pub fn format_bytes(f: vk::Format) -> u64 {
    match f {
        vk::Format::R8G8B8A8_UNORM | vk::Format::B8G8R8A8_UNORM | vk::Format::R8G8B8A8_SRGB => 4,
        vk::Format::R32_SFLOAT | vk::Format::R32_UINT | vk::Format::D32_SFLOAT => 4,
        vk::Format::R16G16B16A16_SFLOAT | vk::Format::R32G32_SFLOAT | vk::Format::R32G32_UINT => 8,
        vk::Format::R32G32B32A32_SFLOAT | vk::Format::R32G32B32A32_UINT => 16,
        vk::Format::R16_SFLOAT => 2,
        _ => 4,
    }
}

impl Image {
    /// A GPU-only 2D image. `alt_format`: a second view format (the image is created MUTABLE_FORMAT).
    pub fn new(
        gpu: &Arc<Gpu>,
        name: &str,
        extent: vk::Extent2D,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        alt_format: Option<vk::Format>,
    ) -> Result<Image> {
        Self::create(gpu, name, extent, format, usage, alt_format, 1)
    }

    /// A cube map: six square layers, viewed as a cube (`samplerCube`).
    pub fn new_cube(
        gpu: &Arc<Gpu>,
        name: &str,
        size: u32,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
    ) -> Result<Image> {
        Self::create(gpu, name, vk::Extent2D { width: size, height: size }, format, usage, None, 6)
    }

    fn create(
        gpu: &Arc<Gpu>,
        name: &str,
        extent: vk::Extent2D,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        alt_format: Option<vk::Format>,
        layers: u32,
    ) -> Result<Image> {
        let d = &gpu.device;
        let mut flags =
            if alt_format.is_some() { vk::ImageCreateFlags::MUTABLE_FORMAT } else { vk::ImageCreateFlags::empty() };
        if layers == 6 {
            flags |= vk::ImageCreateFlags::CUBE_COMPATIBLE;
        }
        let ci = vk::ImageCreateInfo::default()
            .flags(flags)
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D { width: extent.width.max(1), height: extent.height.max(1), depth: 1 })
            .mip_levels(1)
            .array_layers(layers)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let families = gpu.concurrent_families();
        let ci = if families.is_empty() {
            ci.sharing_mode(vk::SharingMode::EXCLUSIVE)
        } else {
            ci.sharing_mode(vk::SharingMode::CONCURRENT).queue_family_indices(&families)
        };
        let raw = unsafe { d.create_image(&ci, None) }.vk("vkCreateImage")?;
        let req = unsafe { d.get_image_memory_requirements(raw) };
        let alloc = allocate(gpu, name, req, MemoryLocation::GpuOnly, false)
            .inspect_err(|_| unsafe { d.destroy_image(raw, None) })?;
        let mut img = Image::bare(gpu, raw, format, extent, name, layers, true);
        img.usage = usage;
        unsafe { d.bind_image_memory(raw, alloc.memory(), alloc.offset()) }.vk("vkBindImageMemory")?;
        img.alloc = Some(alloc);
        img.view = img.make_view(format)?;
        if let Some(f) = alt_format {
            img.alt_view = Some(img.make_view(f)?);
        }
        gpu.name_object(raw, name);
        Ok(img)
    }

    /// Track an image owned elsewhere (a swapchain image) so barriers can be derived for it; its view is ours.
    pub fn wrap(gpu: &Arc<Gpu>, raw: vk::Image, format: vk::Format, extent: vk::Extent2D, name: &str) -> Result<Image> {
        let mut img = Image::bare(gpu, raw, format, extent, name, 1, false);
        img.view = img.make_view(format)?;
        Ok(img)
    }

    /// The struct around a raw image, before memory and views (no access yet: layout UNDEFINED).
    fn bare(
        gpu: &Arc<Gpu>,
        raw: vk::Image,
        format: vk::Format,
        extent: vk::Extent2D,
        name: &str,
        layers: u32,
        owned: bool,
    ) -> Image {
        Image {
            gpu: gpu.clone(),
            raw,
            view: vk::ImageView::null(),
            alt_view: None,
            format,
            extent,
            name: name.to_string(),
            aspect: if format == vk::Format::D32_SFLOAT {
                vk::ImageAspectFlags::DEPTH
            } else {
                vk::ImageAspectFlags::COLOR
            },
            layers,
            usage: vk::ImageUsageFlags::empty(),
            state: Cell::new(AccessState::default()),
            alloc: None,
            owned,
        }
    }

    fn make_view(&self, format: vk::Format) -> Result<vk::ImageView> {
        let ci = vk::ImageViewCreateInfo::default()
            .image(self.raw)
            .view_type(if self.layers == 6 { vk::ImageViewType::CUBE } else { vk::ImageViewType::TYPE_2D })
            .format(format)
            .subresource_range(self.range());
        unsafe { self.gpu.device.create_image_view(&ci, None) }.vk("vkCreateImageView")
    }

    /// The whole colour subresource.
    pub fn color_range() -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: 1,
        }
    }

    /// The whole image (colour or depth aspect).
    pub fn range(&self) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange { aspect_mask: self.aspect, layer_count: self.layers, ..Self::color_range() }
    }

    /// Size in bytes of the texels (not counting driver padding).
    pub fn bytes(&self) -> u64 {
        self.extent.width as u64 * self.extent.height as u64 * format_bytes(self.format) * self.layers as u64
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        let d = &self.gpu.device;
        unsafe {
            if let Some(v) = self.alt_view.take() {
                d.destroy_image_view(v, None);
            }
            d.destroy_image_view(self.view, None);
            if self.owned {
                d.destroy_image(self.raw, None);
            }
        }
        if let Some(a) = self.alloc.take() {
            if let Ok(mut al) = self.gpu.allocator.lock() {
                let _ = al.free(a);
            }
        }
    }
}

/// A buffer; host-visible ones are persistently mapped.
pub struct Buffer {
    gpu: Arc<Gpu>,
    /// The buffer.
    pub raw: vk::Buffer,
    /// Size in bytes.
    pub size: u64,
    /// Debug name (also the memory report's).
    pub name: String,
    pub(crate) state: Cell<AccessState>,
    alloc: Option<Allocation>,
    /// A texel view of the whole buffer (see [`Buffer::with_texel_view`]), for `Slot::TexelRead` bindings.
    pub texel_view: Option<vk::BufferView>,
}

impl Buffer {
    /// A buffer of `size` bytes in `location`.
    pub fn new(
        gpu: &Arc<Gpu>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Buffer> {
        let d = &gpu.device;
        let families = gpu.concurrent_families();
        let ci = vk::BufferCreateInfo::default().size(size.max(16)).usage(usage);
        let ci = if families.is_empty() {
            ci.sharing_mode(vk::SharingMode::EXCLUSIVE)
        } else {
            ci.sharing_mode(vk::SharingMode::CONCURRENT).queue_family_indices(&families)
        };
        // A size the device refuses is the user's problem size (a cube size, a resolution): say which buffer
        // and how large, not only the Vulkan call.
        let too_large = |why: String| {
            Error::Limit(format!(
                "the GPU buffer {name} would need {size} bytes ({:.2} GB), more than this device gives one buffer \
                 ({why}); make the problem smaller",
                size as f64 / 1e9
            ))
        };
        let raw = unsafe { d.create_buffer(&ci, None) }.map_err(|e| too_large(format!("vkCreateBuffer: {e}")))?;
        let req = unsafe { d.get_buffer_memory_requirements(raw) };
        let alloc = allocate(gpu, name, req, location, true)
            .map_err(|e| if size >= 1 << 30 { too_large(e.to_string()) } else { e })
            .inspect_err(|_| unsafe { d.destroy_buffer(raw, None) })?;
        unsafe { d.bind_buffer_memory(raw, alloc.memory(), alloc.offset()) }.vk("vkBindBufferMemory")?;
        Ok(Buffer {
            gpu: gpu.clone(),
            raw,
            size,
            name: name.to_string(),
            state: Cell::new(AccessState::default()),
            alloc: Some(alloc),
            texel_view: None,
        })
    }

    /// A host-visible buffer filled with `data` (CPU→GPU upload, also used as uniform/storage directly).
    pub fn with_data(gpu: &Arc<Gpu>, name: &str, data: &[u8], usage: vk::BufferUsageFlags) -> Result<Buffer> {
        let mut b = Buffer::new(gpu, name, data.len() as u64, usage, MemoryLocation::CpuToGpu)?;
        b.write(0, data)?;
        Ok(b)
    }

    /// A GPU-only buffer of `size` bytes that `Slot::TexelRead` bindings read as `format` texels: `usage` plus
    /// `UNIFORM_TEXEL_BUFFER`, with its texel view ([`Buffer::with_texel_view`]).
    pub fn texels(
        gpu: &Arc<Gpu>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        format: vk::Format,
    ) -> Result<Buffer> {
        let usage = usage | vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER;
        Buffer::new(gpu, name, size, usage, MemoryLocation::GpuOnly)?.with_texel_view(format)
    }

    /// Give the buffer (created with `UNIFORM_TEXEL_BUFFER` usage) a texel view of its whole size in `format`, so
    /// a `Slot::TexelRead` binding can read it through `texelFetch` (a `samplerBuffer` in GLSL). Why: lavapipe
    /// turns a storage-buffer load at a per-lane index into a loop over the 8 lanes, one branch and one scalar
    /// load per lane and component, while a texel fetch is one branch-free gather; GPUs read both through their
    /// caches. The hot neighbour loops read their particles this way.
    /// A buffer that already has one gets a new one. Fails with `Error::Limit` past the device's
    /// maxTexelBufferElements.
    pub fn with_texel_view(mut self, format: vk::Format) -> Result<Buffer> {
        let texels = self.size / format_bytes(format);
        let limit = self.gpu.info.max_texel_buffer_elements;
        if texels > limit {
            return Err(Error::Limit(format!(
                "{}: {texels} texels exceed this device's texel buffer limit of {limit}",
                self.name
            )));
        }
        if let Some(v) = self.texel_view.take() {
            unsafe { self.gpu.device.destroy_buffer_view(v, None) };
        }
        let ci = vk::BufferViewCreateInfo::default().buffer(self.raw).format(format).offset(0).range(vk::WHOLE_SIZE);
        let view = unsafe { self.gpu.device.create_buffer_view(&ci, None) }.vk("vkCreateBufferView")?;
        self.texel_view = Some(view);
        Ok(self)
    }

    /// Copy `data` into a mapped buffer at `offset`.
    pub fn write(&mut self, offset: usize, data: &[u8]) -> Result<()> {
        let name = self.name.clone();
        let slice = self
            .alloc
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or_else(|| Error::Invalid(format!("buffer {name} is not host-visible")))?;
        let end = offset + data.len();
        if end > slice.len() {
            return Err(Error::Invalid(format!("write of {} bytes past the end of buffer {name}", data.len())));
        }
        slice[offset..end].copy_from_slice(data);
        Ok(())
    }

    /// The mapped bytes of a host-visible buffer.
    pub fn read(&self) -> Result<&[u8]> {
        self.alloc
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .map(|s| &s[..self.size as usize])
            .ok_or_else(|| Error::Invalid(format!("buffer {} is not host-visible", self.name)))
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if let Some(v) = self.texel_view.take() {
            unsafe { self.gpu.device.destroy_buffer_view(v, None) };
        }
        unsafe { self.gpu.device.destroy_buffer(self.raw, None) };
        if let Some(a) = self.alloc.take() {
            if let Ok(mut al) = self.gpu.allocator.lock() {
                let _ = al.free(a);
            }
        }
    }
}
