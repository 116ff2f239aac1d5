//! Presentation on raykit's own Vulkan device: a `VkSurfaceKHR` for the window
//! (ash-window, from winit's raw handles), a swapchain of
//! `B8G8R8A8_UNORM` (or `R8G8B8A8_UNORM`) images, and per frame one command
//! buffer that copies the display pass's device-local pixel buffer into the
//! acquired image, submitted and presented on raykit's queue under its lock
//! ([`raykit::Context::with_raw_queue`]).
//!
//! The pixels are sRGB-encoded by the display pass, so the image format is UNORM
//! and the copy moves bytes unchanged: the window shows exactly the bytes a
//! screenshot writes. The copy is waited for before the next display pass may
//! write the buffer again (one frame in flight, as the launches are).

use std::sync::Arc;

use raykit::ash::{self, vk};
use raykit::Context;
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::Window;

use crate::display::{DisplayPass, PixelFormat};
use crate::error::{Result, ViewerError};
use crate::present::Presented;

/// How long an image acquisition may wait before the frame is skipped.
const ACQUIRE_TIMEOUT_NS: u64 = 1_000_000_000;

/// A window's surface and swapchain on raykit's device.
pub struct SwapchainPresenter {
    ctx: Context,
    device: ash::Device,
    surface_fns: ash::khr::surface::Instance,
    swapchain_fns: ash::khr::swapchain::Device,
    physical: vk::PhysicalDevice,
    surface: vk::SurfaceKHR,
    swapchain: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    extent: vk::Extent2D,
    format: vk::SurfaceFormatKHR,
    present_mode: vk::PresentModeKHR,
    pool: vk::CommandPool,
    commands: vk::CommandBuffer,
    /// Signalled by the acquisition, waited for by the copy.
    acquired: vk::Semaphore,
    /// One per swapchain image: signalled by the copy, waited for by the presentation.
    copied: Vec<vk::Semaphore>,
    /// Signalled when the copy has finished.
    done: vk::Fence,
    out_of_date: bool,
    /// Outlives the surface (fields drop after `Drop::drop` destroyed it).
    window: Arc<Window>,
}

/// Something made and not yet owned: destroyed on an early return.
struct Made<'a, T: Copy>(T, &'a dyn Fn(T), bool);

impl<T: Copy> Made<'_, T> {
    fn keep(mut self) -> T {
        self.2 = false;
        self.0
    }
}

impl<T: Copy> Drop for Made<'_, T> {
    fn drop(&mut self) {
        if self.2 {
            (self.1)(self.0);
        }
    }
}

impl SwapchainPresenter {
    /// A surface and a swapchain for `window` on `ctx`'s device, and the pixel
    /// format of its images. [`ViewerError::Presentation`] when the device cannot
    /// present to the window.
    pub fn new(ctx: &Context, window: Arc<Window>) -> Result<(SwapchainPresenter, PixelFormat)> {
        let presentation = |why: &str| ViewerError::Presentation(why.to_owned());
        if !ctx.supports_presentation() {
            return Err(presentation("the loader has no surface extension or the device no VK_KHR_swapchain"));
        }
        let (Some(entry), Some(instance), Some(device), Some(physical), Some(queue_family)) =
            (ctx.raw_entry(), ctx.raw_instance(), ctx.raw_device(), ctx.raw_physical_device(), ctx.queue_family())
        else {
            return Err(presentation("not a Vulkan context"));
        };
        let display = window.display_handle().map_err(|e| ViewerError::Window(e.to_string()))?;
        let handle = window.window_handle().map_err(|e| ViewerError::Window(e.to_string()))?;
        let surface_fns = ash::khr::surface::Instance::new(entry, instance);
        // SAFETY: the handles are the live window's, which this presenter keeps
        // alive longer than the surface; the instance has the window system's
        // surface extension (`supports_presentation`).
        let surface = unsafe { ash_window::create_surface(entry, instance, display.as_raw(), handle.as_raw(), None) }
            .map_err(|e| ViewerError::Presentation(format!("vkCreate*SurfaceKHR returned {e}")))?;
        // SAFETY: the surface was made on this instance and is not in use.
        let destroy_surface = |s| unsafe { surface_fns.destroy_surface(s, None) };
        let surface = Made(surface, &destroy_surface, true);
        // SAFETY: valid physical device, queue family and surface.
        let supported = unsafe { surface_fns.get_physical_device_surface_support(physical, queue_family, surface.0) }
            .map_err(ViewerError::vk("vkGetPhysicalDeviceSurfaceSupportKHR"))?;
        if !supported {
            return Err(presentation("raykit's queue family cannot present to this surface"));
        }
        // SAFETY: as above.
        let formats = unsafe { surface_fns.get_physical_device_surface_formats(physical, surface.0) }
            .map_err(ViewerError::vk("vkGetPhysicalDeviceSurfaceFormatsKHR"))?;
        let pick = |want: vk::Format| formats.iter().copied().find(|f| f.format == want);
        let (format, pixel_format) = match (pick(vk::Format::B8G8R8A8_UNORM), pick(vk::Format::R8G8B8A8_UNORM)) {
            (Some(f), _) => (f, PixelFormat::BGRA8),
            (None, Some(f)) => (f, PixelFormat::RGBA8),
            _ => return Err(presentation("the surface offers neither B8G8R8A8_UNORM nor R8G8B8A8_UNORM")),
        };
        // SAFETY: as above.
        let modes = unsafe { surface_fns.get_physical_device_surface_present_modes(physical, surface.0) }
            .map_err(ViewerError::vk("vkGetPhysicalDeviceSurfacePresentModesKHR"))?;
        // Mailbox shows the newest frame without waiting for vertical blank; FIFO is always there.
        let present_mode = if modes.contains(&vk::PresentModeKHR::MAILBOX) {
            vk::PresentModeKHR::MAILBOX
        } else {
            vk::PresentModeKHR::FIFO
        };

        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid device and create info.
        let pool =
            unsafe { device.create_command_pool(&pool_info, None) }.map_err(ViewerError::vk("vkCreateCommandPool"))?;
        // SAFETY: the pool is unused.
        let destroy_pool = |p| unsafe { device.destroy_command_pool(p, None) };
        let pool = Made(pool, &destroy_pool, true);
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool.0)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: valid pool; freed with it.
        let commands =
            unsafe { device.allocate_command_buffers(&alloc) }.map_err(ViewerError::vk("vkAllocateCommandBuffers"))?[0];
        // SAFETY: valid device.
        let acquired = unsafe { device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
            .map_err(ViewerError::vk("vkCreateSemaphore"))?;
        // SAFETY: unused.
        let destroy_semaphore = |s| unsafe { device.destroy_semaphore(s, None) };
        let acquired = Made(acquired, &destroy_semaphore, true);
        let fence_info = vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED);
        // SAFETY: valid device.
        let done = unsafe { device.create_fence(&fence_info, None) }.map_err(ViewerError::vk("vkCreateFence"))?;
        ctx.set_debug_name(pool.0, "viewer command pool");
        ctx.set_debug_name(acquired.0, "viewer acquire semaphore");
        ctx.set_debug_name(done, "viewer copy fence");
        let mut presenter = SwapchainPresenter {
            ctx: ctx.clone(),
            device: device.clone(),
            swapchain_fns: ash::khr::swapchain::Device::new(instance, device),
            surface_fns: surface_fns.clone(),
            physical,
            acquired: acquired.keep(),
            pool: pool.keep(),
            surface: surface.keep(),
            swapchain: vk::SwapchainKHR::null(),
            images: Vec::new(),
            extent: vk::Extent2D::default(),
            format,
            present_mode,
            commands,
            copied: Vec::new(),
            done,
            out_of_date: true,
            window,
        };
        presenter.recreate()?;
        Ok((presenter, pixel_format))
    }

    /// The swapchain is recreated before the next frame.
    pub fn mark_out_of_date(&mut self) {
        self.out_of_date = true;
    }

    /// Waits until the queue has finished the copies and presentations submitted.
    fn wait_queue(&self) -> Result<()> {
        // SAFETY: the queue is raykit's, used under its lock.
        let waited = self.ctx.with_raw_queue(|queue| unsafe { self.device.queue_wait_idle(queue) });
        waited.unwrap_or(Ok(())).map_err(ViewerError::vk("vkQueueWaitIdle"))
    }

    /// A swapchain for the window's size now (none while it has no area).
    fn recreate(&mut self) -> Result<()> {
        self.wait_queue()?;
        // SAFETY: valid physical device and surface.
        let caps = unsafe { self.surface_fns.get_physical_device_surface_capabilities(self.physical, self.surface) }
            .map_err(ViewerError::vk("vkGetPhysicalDeviceSurfaceCapabilitiesKHR"))?;
        let size = self.window.inner_size();
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: size.width.clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: size.height.clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        self.destroy_swapchain();
        self.extent = extent;
        if extent.width == 0 || extent.height == 0 {
            // Minimised: no swapchain until the window has an area again.
            return Ok(());
        }
        if !caps.supported_usage_flags.contains(vk::ImageUsageFlags::TRANSFER_DST) {
            return Err(ViewerError::Presentation("the swapchain's images cannot be copied to".into()));
        }
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let alpha = [vk::CompositeAlphaFlagsKHR::OPAQUE, vk::CompositeAlphaFlagsKHR::INHERIT]
            .into_iter()
            .find(|a| caps.supported_composite_alpha.contains(*a))
            .unwrap_or(vk::CompositeAlphaFlagsKHR::from_raw(caps.supported_composite_alpha.as_raw() & 0xf));
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(count)
            .image_format(self.format.format)
            .image_color_space(self.format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::TRANSFER_DST)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(alpha)
            .present_mode(self.present_mode)
            .clipped(true);
        // SAFETY: valid create info; the surface has no other swapchain.
        self.swapchain = unsafe { self.swapchain_fns.create_swapchain(&info, None) }
            .map_err(ViewerError::vk("vkCreateSwapchainKHR"))?;
        self.ctx.set_debug_name(self.swapchain, "viewer swapchain");
        // SAFETY: the swapchain is valid.
        self.images = unsafe { self.swapchain_fns.get_swapchain_images(self.swapchain) }
            .map_err(ViewerError::vk("vkGetSwapchainImagesKHR"))?;
        for _ in 0..self.images.len() {
            // SAFETY: valid device.
            let semaphore = unsafe { self.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
                .map_err(ViewerError::vk("vkCreateSemaphore"))?;
            self.copied.push(semaphore);
        }
        self.out_of_date = false;
        Ok(())
    }

    /// Destroys the swapchain and its semaphores (the queue is idle).
    fn destroy_swapchain(&mut self) {
        for semaphore in self.copied.drain(..) {
            // SAFETY: the queue is idle: no submission or presentation uses it.
            unsafe { self.device.destroy_semaphore(semaphore, None) };
        }
        if self.swapchain != vk::SwapchainKHR::null() {
            // SAFETY: as above; its images go with it.
            unsafe { self.swapchain_fns.destroy_swapchain(self.swapchain, None) };
            self.swapchain = vk::SwapchainKHR::null();
        }
        self.images.clear();
    }

    /// Copies the display pass's pixels into the next image and presents it.
    pub fn present(&mut self, display: &DisplayPass) -> Result<Presented> {
        if self.out_of_date {
            self.recreate()?;
        }
        if self.swapchain == vk::SwapchainKHR::null() {
            return Ok(Presented::Skipped);
        }
        let (width, height) = display.size();
        if (width, height) != (self.extent.width, self.extent.height) {
            return Ok(Presented::Resize(self.extent.width, self.extent.height));
        }
        let Some(buffer) = display.pixels().raw_buffer() else {
            return Err(ViewerError::Presentation("the display pass's pixels are not in a Vulkan buffer".into()));
        };
        // SAFETY: valid swapchain and semaphore; the semaphore is unsignalled (the
        // copy that waited for it has finished: `done` was waited for).
        let acquired = unsafe {
            self.swapchain_fns.acquire_next_image(self.swapchain, ACQUIRE_TIMEOUT_NS, self.acquired, vk::Fence::null())
        };
        let index = match acquired {
            Ok((index, suboptimal)) => {
                self.out_of_date |= suboptimal;
                index
            }
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.out_of_date = true;
                return Ok(Presented::Skipped);
            }
            Err(vk::Result::TIMEOUT | vk::Result::NOT_READY) => return Ok(Presented::Skipped),
            Err(e) => return Err(ViewerError::vk("vkAcquireNextImageKHR")(e)),
        };
        let image = self.images[index as usize];
        self.record_copy(buffer, image)?;
        let wait_stages = [vk::PipelineStageFlags::TRANSFER];
        let waits = [self.acquired];
        let signals = [self.copied[index as usize]];
        let commands = [self.commands];
        let submit = vk::SubmitInfo::default()
            .wait_semaphores(&waits)
            .wait_dst_stage_mask(&wait_stages)
            .command_buffers(&commands)
            .signal_semaphores(&signals);
        let swapchains = [self.swapchain];
        let indices = [index];
        let present =
            vk::PresentInfoKHR::default().wait_semaphores(&signals).swapchains(&swapchains).image_indices(&indices);
        // SAFETY: the fence is signalled and not in use (waited for after the last submission).
        unsafe { self.device.reset_fences(&[self.done]) }.map_err(ViewerError::vk("vkResetFences"))?;
        let outcome = self.ctx.with_raw_queue(|queue| {
            // SAFETY: the queue is raykit's, under its lock; everything submitted is valid
            // and the command buffer is recorded.
            unsafe { self.device.queue_submit(queue, &[submit], self.done) }
                .map_err(ViewerError::vk("vkQueueSubmit"))?;
            // SAFETY: as above; the image was acquired and is copied to before `copied` signals.
            Ok::<_, ViewerError>(unsafe { self.swapchain_fns.queue_present(queue, &present) })
        });
        let presented = outcome.unwrap_or(Ok(Ok(false)))?;
        // The next display pass writes the pixel buffer: the copy must be over.
        // SAFETY: the fence was submitted above.
        unsafe { self.device.wait_for_fences(&[self.done], true, u64::MAX) }
            .map_err(ViewerError::vk("vkWaitForFences"))?;
        match presented {
            Ok(suboptimal) => self.out_of_date |= suboptimal,
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => self.out_of_date = true,
            Err(e) => return Err(ViewerError::vk("vkQueuePresentKHR")(e)),
        }
        Ok(Presented::Shown)
    }

    /// Records: wait for earlier writes of the pixel buffer, move the image to a
    /// transfer layout, copy, move it to the presentation layout.
    fn record_copy(&self, buffer: vk::Buffer, image: vk::Image) -> Result<()> {
        let device = &self.device;
        let cb = self.commands;
        let range =
            vk::ImageSubresourceRange::default().aspect_mask(vk::ImageAspectFlags::COLOR).level_count(1).layer_count(1);
        // The display pass wrote the buffer in an earlier submission on this queue.
        let written = vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::MEMORY_WRITE)
            .dst_access_mask(vk::AccessFlags::TRANSFER_READ);
        let to_transfer = vk::ImageMemoryBarrier::default()
            .old_layout(vk::ImageLayout::UNDEFINED)
            .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .src_access_mask(vk::AccessFlags::empty())
            .dst_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(range);
        let to_present = vk::ImageMemoryBarrier::default()
            .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .new_layout(vk::ImageLayout::PRESENT_SRC_KHR)
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::empty())
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(range);
        let region = vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1),
            )
            .image_extent(vk::Extent3D { width: self.extent.width, height: self.extent.height, depth: 1 });
        let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: the command buffer is not in use (its last submission's fence was
        // waited for); buffer and image are live and large enough (the buffer holds
        // extent.width × extent.height pixels: checked by the caller).
        unsafe {
            device.begin_command_buffer(cb, &begin).map_err(ViewerError::vk("vkBeginCommandBuffer"))?;
            device.cmd_pipeline_barrier(
                cb,
                vk::PipelineStageFlags::ALL_COMMANDS,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[written],
                &[],
                &[to_transfer],
            );
            device.cmd_copy_buffer_to_image(cb, buffer, image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &[region]);
            device.cmd_pipeline_barrier(
                cb,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[to_present],
            );
            device.end_command_buffer(cb).map_err(ViewerError::vk("vkEndCommandBuffer"))?;
        }
        Ok(())
    }
}

impl Drop for SwapchainPresenter {
    fn drop(&mut self) {
        // Errors cannot be returned from drop; a lost device has nothing running.
        let _ = self.wait_queue();
        self.destroy_swapchain();
        // SAFETY: the queue is idle: nothing uses these objects; the surface's
        // swapchain is gone and the window is still alive (a field, dropped later).
        unsafe {
            self.device.destroy_fence(self.done, None);
            self.device.destroy_semaphore(self.acquired, None);
            self.device.destroy_command_pool(self.pool, None);
            self.surface_fns.destroy_surface(self.surface, None);
        }
    }
}
