//! Presentation: the swapchain (created for the window's size, recreated on resize, none while minimised),
//! and presenting a frame with frames in flight: acquire (signals a per-slot semaphore, no fence), the blit of
//! the renderer's final image into the swapchain image recorded INTO the frame's own command buffer (its
//! submit waits for the acquire and signals the image's render-finished semaphore), present (waits for it).
//! One submit per frame plus present; no host wait but the frames-in-flight throttle.

use ash::vk;

use meniscus::device::{Access, FrameCtx, Gpu, Image, Use};
use meniscus::{Error, Result, VkContext};

/// The window's swapchain and its images.
pub struct Swapchain {
    loader: ash::khr::swapchain::Device,
    raw: vk::SwapchainKHR,
    images: Vec<Image>,
    pub extent: vk::Extent2D,
    /// Per swapchain image: signalled when the frame that draws into it is done; the present waits for it.
    rendered: Vec<vk::Semaphore>,
}

/// The surface a swapchain is made for.
pub struct Surface<'a> {
    pub loader: &'a ash::khr::surface::Instance,
    pub raw: vk::SurfaceKHR,
    /// The window's inner size (used when the surface does not fix the extent).
    pub size: (u32, u32),
}

/// A new swapchain for `surface` replacing `old` (destroyed), or `None` while the window is minimised.
pub fn recreate(
    gpu: &std::sync::Arc<Gpu>,
    surface: Surface,
    vsync: bool,
    old: Option<Swapchain>,
) -> Result<Option<Swapchain>> {
    unsafe { gpu.device.device_wait_idle() }.vk("vkDeviceWaitIdle")?;
    let caps = unsafe { surface.loader.get_physical_device_surface_capabilities(gpu.physical, surface.raw) }
        .vk("vkGetPhysicalDeviceSurfaceCapabilitiesKHR")?;
    let extent = if caps.current_extent.width != u32::MAX {
        caps.current_extent
    } else {
        vk::Extent2D {
            width: surface.size.0.clamp(caps.min_image_extent.width, caps.max_image_extent.width),
            height: surface.size.1.clamp(caps.min_image_extent.height, caps.max_image_extent.height),
        }
    };
    if extent.width == 0 || extent.height == 0 {
        // Minimised: keep no swapchain until restored.
        if let Some(o) = old {
            destroy(gpu, o);
        }
        return Ok(None);
    }
    let formats = unsafe { surface.loader.get_physical_device_surface_formats(gpu.physical, surface.raw) }
        .vk("vkGetPhysicalDeviceSurfaceFormatsKHR")?;
    let format = formats
        .iter()
        .find(|f| f.format == vk::Format::B8G8R8A8_UNORM || f.format == vk::Format::R8G8B8A8_UNORM)
        .or(formats.first())
        .copied()
        .ok_or_else(|| Error::NoDevice("the surface offers no formats".into()))?;
    let modes = unsafe { surface.loader.get_physical_device_surface_present_modes(gpu.physical, surface.raw) }
        .vk("vkGetPhysicalDeviceSurfacePresentModesKHR")?;
    let mode = if vsync {
        vk::PresentModeKHR::FIFO
    } else if modes.contains(&vk::PresentModeKHR::IMMEDIATE) {
        vk::PresentModeKHR::IMMEDIATE
    } else if modes.contains(&vk::PresentModeKHR::MAILBOX) {
        vk::PresentModeKHR::MAILBOX
    } else {
        vk::PresentModeKHR::FIFO
    };
    let mut count = caps.min_image_count + 1;
    if caps.max_image_count > 0 {
        count = count.min(caps.max_image_count);
    }
    let loader = old
        .as_ref()
        .map(|o| o.loader.clone())
        .unwrap_or_else(|| ash::khr::swapchain::Device::new(&gpu.instance, &gpu.device));
    let ci = vk::SwapchainCreateInfoKHR::default()
        .surface(surface.raw)
        .min_image_count(count)
        .image_format(format.format)
        .image_color_space(format.color_space)
        .image_extent(extent)
        .image_array_layers(1)
        .image_usage(vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::COLOR_ATTACHMENT)
        .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
        .pre_transform(caps.current_transform)
        .composite_alpha(vk::CompositeAlphaFlagsKHR::OPAQUE)
        .present_mode(mode)
        .clipped(true)
        .old_swapchain(old.as_ref().map(|o| o.raw).unwrap_or_default());
    let raw = unsafe { loader.create_swapchain(&ci, None) }.vk("vkCreateSwapchainKHR")?;
    if let Some(o) = old {
        destroy(gpu, o);
    }
    let images = unsafe { loader.get_swapchain_images(raw) }
        .vk("vkGetSwapchainImagesKHR")?
        .into_iter()
        .enumerate()
        .map(|(k, i)| Image::wrap(gpu, i, format.format, extent, &format!("swapchain{k}")))
        .collect::<Result<Vec<_>>>()?;
    let rendered = (0..images.len()).map(|_| semaphore(gpu)).collect::<Result<Vec<_>>>()?;
    Ok(Some(Swapchain { loader, raw, images, extent, rendered }))
}

/// A binary semaphore.
pub fn semaphore(gpu: &Gpu) -> Result<vk::Semaphore> {
    unsafe { gpu.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }.vk("vkCreateSemaphore")
}

/// The next swapchain image, signalling `acquired` when it may be written; `None` when the swapchain is out of
/// date (recreate it). The bool: suboptimal (recreate after this frame).
pub fn acquire(swap: &Swapchain, acquired: vk::Semaphore) -> Result<Option<(u32, bool)>> {
    match unsafe { swap.loader.acquire_next_image(swap.raw, u64::MAX, acquired, vk::Fence::null()) } {
        Ok(r) => Ok(Some(r)),
        Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(None),
        Err(e) => Err(Error::Vulkan { call: "vkAcquireNextImageKHR", result: e }),
    }
}

/// The semaphore the frame drawing into image `index` signals (and the present waits for).
pub fn rendered(swap: &Swapchain, index: u32) -> vk::Semaphore {
    swap.rendered[index as usize]
}

/// Record the blit of `src` into swapchain image `index` and its transition for presenting.
pub fn record_blit(ctx: &mut FrameCtx, swap: &Swapchain, index: u32, src: &Image) {
    let target = &swap.images[index as usize];
    ctx.barrier(&[Use::Image(src, Access::TransferSrc, false), Use::Image(target, Access::TransferDst, true)]);
    let sub = vk::ImageSubresourceLayers {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        mip_level: 0,
        base_array_layer: 0,
        layer_count: 1,
    };
    let corner = |e: vk::Extent2D| {
        [vk::Offset3D { x: 0, y: 0, z: 0 }, vk::Offset3D { x: e.width as i32, y: e.height as i32, z: 1 }]
    };
    let blit = vk::ImageBlit {
        src_subresource: sub,
        src_offsets: corner(src.extent),
        dst_subresource: sub,
        dst_offsets: corner(target.extent),
    };
    unsafe {
        ctx.gpu.device.cmd_blit_image(
            ctx.cmd,
            src.raw,
            Access::TransferSrc.info().layout,
            target.raw,
            Access::TransferDst.info().layout,
            &[blit],
            vk::Filter::NEAREST,
        )
    };
    ctx.barrier(&[Use::Image(target, Access::Present, false)]);
}

/// Present image `index` once its frame signalled its render-finished semaphore. True: the swapchain is out of
/// date or suboptimal (recreate it before the next frame).
pub fn queue_present(gpu: &Gpu, swap: &Swapchain, index: u32) -> Result<bool> {
    let swapchains = [swap.raw];
    let indices = [index];
    let waits = [swap.rendered[index as usize]];
    let pi = vk::PresentInfoKHR::default().wait_semaphores(&waits).swapchains(&swapchains).image_indices(&indices);
    match unsafe { swap.loader.queue_present(gpu.queues.main.queue, &pi) } {
        Ok(stale) => Ok(stale),
        Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(true),
        Err(e) => Err(Error::Vulkan { call: "vkQueuePresentKHR", result: e }),
    }
}

/// Destroy a swapchain (after the device is idle).
pub fn destroy(gpu: &Gpu, s: Swapchain) {
    unsafe {
        let _ = gpu.device.device_wait_idle();
        for &sem in &s.rendered {
            gpu.device.destroy_semaphore(sem, None);
        }
    }
    drop(s.images); // views only
    unsafe { s.loader.destroy_swapchain(s.raw, None) };
}
