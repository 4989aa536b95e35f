//! Presentation: the swapchain (created for the window's size, recreated on resize, none while minimised),
//! and presenting a frame: acquire, blit the renderer's final image into the swapchain image, present.

use ash::vk;

use meniscus::error::{Error, Result, VkContext};
use meniscus::gpu::{Access, FrameCtx, Gpu, Image, Use};

/// The window's swapchain and its images.
pub struct Swapchain {
    loader: ash::khr::swapchain::Device,
    raw: vk::SwapchainKHR,
    images: Vec<Image>,
    pub extent: vk::Extent2D,
    fence: vk::Fence,
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
    let fence = unsafe { gpu.device.create_fence(&vk::FenceCreateInfo::default(), None) }.vk("vkCreateFence")?;
    Ok(Some(Swapchain { loader, raw, images, extent, fence }))
}

/// Show `src` in the window: acquire an image, blit, present. Returns true when the swapchain is out of date
/// or suboptimal (recreate it before the next frame).
pub fn present(gpu: &std::sync::Arc<Gpu>, swap: &Swapchain, src: &Image) -> Result<bool> {
    let mut stale = false;
    let acquired = unsafe { swap.loader.acquire_next_image(swap.raw, u64::MAX, vk::Semaphore::null(), swap.fence) };
    let index = match acquired {
        Ok((i, suboptimal)) => {
            stale |= suboptimal;
            i
        }
        Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => return Ok(true),
        Err(e) => return Err(Error::Vulkan { call: "vkAcquireNextImageKHR", result: e }),
    };
    unsafe {
        gpu.device.wait_for_fences(&[swap.fence], true, u64::MAX).vk("vkWaitForFences")?;
        gpu.device.reset_fences(&[swap.fence]).vk("vkResetFences")?;
    }
    let target = &swap.images[index as usize];
    gpu.one_shot(|cmd| {
        let mut ctx = FrameCtx::new(gpu, cmd, None);
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
            gpu.device.cmd_blit_image(
                cmd,
                src.raw,
                Access::TransferSrc.info().layout,
                target.raw,
                Access::TransferDst.info().layout,
                &[blit],
                vk::Filter::NEAREST,
            )
        };
        ctx.barrier(&[Use::Image(target, Access::Present, false)]);
        Ok(())
    })?;
    let swapchains = [swap.raw];
    let indices = [index];
    let pi = vk::PresentInfoKHR::default().swapchains(&swapchains).image_indices(&indices);
    match unsafe { swap.loader.queue_present(gpu.queue, &pi) } {
        Ok(false) => {}
        Ok(true) | Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => stale = true,
        Err(e) => return Err(Error::Vulkan { call: "vkQueuePresentKHR", result: e }),
    }
    Ok(stale)
}

/// Destroy a swapchain (after the device is idle).
pub fn destroy(gpu: &Gpu, s: Swapchain) {
    unsafe {
        let _ = gpu.device.device_wait_idle();
        gpu.device.destroy_fence(s.fence, None);
    }
    drop(s.images); // views only
    unsafe { s.loader.destroy_swapchain(s.raw, None) };
}
