//! A window's surface and swapchain, and putting a rendered image on it.
//!
//! [`Swapchain::present`] acquires an image, blits the renderer's tonemapped image into it on
//! the graphics queue (scaling to the window with a linear filter) and presents it:
//!
//! ```text
//!  acquire(sem A) ──► graphics: wait A, blit, signal render_done[image] + timeline ──► present(wait render_done[image])
//! ```
//!
//! With an overlay ([`OverlayPass`], `overlay.rs`), egui's triangles are drawn over the blit in
//! the same command buffer, through a view of the image (dynamic rendering).
//!
//! One `render_done` semaphore per swapchain image (an image is only acquired again after the
//! presentation that waited on its semaphore), and acquire semaphores from a pool, each reused
//! only once the submission that waited on it has completed (its timeline point). The renderer
//! writes sRGB-encoded values into an `R8G8B8A8_UNORM` image, so a `UNORM` swapchain format is
//! preferred: the blit copies the encoded values unchanged.

use super::device::{Gpu, QueueRole, TimelinePoint};
use super::error::{vk_err, GpuError, GpuResult};
use super::image::Image;
use super::overlay::{OverlayFrame, OverlayPass};
use super::Access;
use crate::timing::pass_id::PassId;
use ash::vk;
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use std::sync::Arc;

/// What [`Swapchain::present`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Presented {
    /// The image is on its way to the screen.
    Shown,
    /// The swapchain no longer fits the window (resized, or suboptimal): call
    /// [`Swapchain::recreate`]; the frame may not have been shown.
    OutOfDate,
}

/// A surface and its swapchain.
pub struct Swapchain {
    gpu: Arc<Gpu>,
    surface_loader: ash::khr::surface::Instance,
    surface: vk::SurfaceKHR,
    loader: ash::khr::swapchain::Device,
    raw: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    /// A colour view of each image (the overlay draws through them).
    views: Vec<vk::ImageView>,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
    render_done: Vec<vk::Semaphore>,
    /// Acquire semaphores and the submission that last waited on each.
    acquire: Vec<(vk::Semaphore, Option<TimelinePoint>)>,
}

fn binary_semaphore(gpu: &Gpu) -> GpuResult<vk::Semaphore> {
    // SAFETY: the device is live; a default create info makes a binary semaphore.
    unsafe {
        gpu.raw()
            .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
    }
    .map_err(vk_err("vkCreateSemaphore"))
}

impl Swapchain {
    /// A surface for `window` and a swapchain of `extent` (clamped to what the surface allows).
    /// The [`Gpu`] must have been made with `GpuOptions::display` of the same display.
    pub fn new(
        gpu: &Arc<Gpu>,
        window: &(impl HasWindowHandle + HasDisplayHandle),
        extent: (u32, u32),
    ) -> anyhow::Result<Self> {
        let (entry, instance) = gpu.instance();
        let display = window
            .display_handle()
            .map_err(|e| anyhow::anyhow!("no display handle: {e}"))?;
        let handle = window
            .window_handle()
            .map_err(|e| anyhow::anyhow!("no window handle: {e}"))?;
        // SAFETY: the handles come from a live window that outlives the surface (the viewer
        // drops the swapchain before the window); the instance enabled the display's surface
        // extensions (GpuOptions::display).
        let surface = unsafe {
            ash_window::create_surface(entry, instance, display.as_raw(), handle.as_raw(), None)
        }
        .map_err(vk_err("vkCreate*SurfaceKHR"))?;
        let surface_loader = ash::khr::surface::Instance::new(entry, instance);
        let family = gpu.queue(QueueRole::Graphics).family;
        // SAFETY: the physical device, family index and surface are live and belong together.
        let supported = unsafe {
            surface_loader.get_physical_device_surface_support(gpu.physical, family, surface)
        }
        .unwrap_or(false);
        if !supported {
            // SAFETY: the surface was just created and nothing uses it.
            unsafe { surface_loader.destroy_surface(surface, None) };
            anyhow::bail!(
                "the graphics queue of {} cannot present to this window",
                gpu.properties.name
            );
        }
        let loader = ash::khr::swapchain::Device::new(instance, gpu.raw());
        let mut swapchain = Swapchain {
            gpu: gpu.clone(),
            surface_loader,
            surface,
            loader,
            raw: vk::SwapchainKHR::null(),
            images: Vec::new(),
            views: Vec::new(),
            format: vk::Format::UNDEFINED,
            extent: vk::Extent2D::default(),
            render_done: Vec::new(),
            acquire: Vec::new(),
        };
        swapchain.recreate(extent)?;
        Ok(swapchain)
    }

    /// Makes a new swapchain of `extent` (after a resize or an out-of-date present). Waits for
    /// the GPU to go idle first: resizing is rare, and the old images may be in use.
    pub fn recreate(&mut self, extent: (u32, u32)) -> anyhow::Result<()> {
        self.gpu.wait_idle()?;
        let gpu = &self.gpu;
        // SAFETY (the three queries): the physical device and surface are live.
        let caps = unsafe {
            self.surface_loader
                .get_physical_device_surface_capabilities(gpu.physical, self.surface)
        }
        .map_err(vk_err("vkGetPhysicalDeviceSurfaceCapabilitiesKHR"))?;
        let formats = unsafe {
            self.surface_loader
                .get_physical_device_surface_formats(gpu.physical, self.surface)
        }
        .map_err(vk_err("vkGetPhysicalDeviceSurfaceFormatsKHR"))?;
        let format = formats
            .iter()
            .find(|f| {
                matches!(
                    f.format,
                    vk::Format::B8G8R8A8_UNORM | vk::Format::R8G8B8A8_UNORM
                )
            })
            .or(formats.first())
            .copied()
            .ok_or(GpuError::NoSuitableDevice(
                "the surface has no formats".into(),
            ))?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: extent
                    .0
                    .clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: extent
                    .1
                    .clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            // Blitted to, then drawn on by the overlay (every surface supports colour
            // attachment usage).
            .image_usage(vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::COLOR_ATTACHMENT)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(vk::CompositeAlphaFlagsKHR::OPAQUE)
            .present_mode(vk::PresentModeKHR::FIFO)
            .clipped(true)
            .old_swapchain(self.raw);
        // SAFETY: the surface is live and supports these parameters (queried above; FIFO and
        // OPAQUE are always supported... OPAQUE on every platform the viewer runs on).
        let raw = unsafe { self.loader.create_swapchain(&info, None) }
            .map_err(vk_err("vkCreateSwapchainKHR"))?;
        self.destroy_swapchain();
        self.raw = raw;
        // SAFETY: the swapchain was just created.
        self.images = unsafe { self.loader.get_swapchain_images(raw) }
            .map_err(vk_err("vkGetSwapchainImagesKHR"))?;
        self.format = format.format;
        self.extent = extent;
        for &image in &self.images {
            let info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format.format)
                .subresource_range(vk::ImageSubresourceRange {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    base_mip_level: 0,
                    level_count: 1,
                    base_array_layer: 0,
                    layer_count: 1,
                });
            // SAFETY: the image belongs to the swapchain just created, in its format.
            let view = unsafe { self.gpu.raw().create_image_view(&info, None) }
                .map_err(vk_err("vkCreateImageView"))?;
            self.views.push(view);
        }
        for _ in 0..self.images.len() {
            let s = binary_semaphore(&self.gpu)?;
            self.render_done.push(s);
        }
        Ok(())
    }

    /// Destroys the swapchain's images' semaphores and the swapchain (GPU idle).
    fn destroy_swapchain(&mut self) {
        let d = self.gpu.raw();
        // SAFETY: the device is idle (recreate waited, Drop waits) so nothing uses them.
        unsafe {
            for s in self.render_done.drain(..) {
                d.destroy_semaphore(s, None);
            }
            for (s, _) in self.acquire.drain(..) {
                d.destroy_semaphore(s, None);
            }
            for v in self.views.drain(..) {
                d.destroy_image_view(v, None);
            }
            if self.raw != vk::SwapchainKHR::null() {
                self.loader.destroy_swapchain(self.raw, None);
            }
        }
        self.raw = vk::SwapchainKHR::null();
    }

    /// An acquire semaphore no pending submission waits on.
    fn free_acquire_semaphore(&mut self) -> GpuResult<usize> {
        let gpu = &self.gpu;
        if let Some(i) = self
            .acquire
            .iter()
            .position(|(_, point)| point.is_none_or(|p| gpu.is_complete(p)))
        {
            return Ok(i);
        }
        self.acquire.push((binary_semaphore(gpu)?, None));
        Ok(self.acquire.len() - 1)
    }

    /// Shows `image` (the renderer's tonemapped output, last written on the graphics queue):
    /// acquire, blit (scaled to the window), the overlay's draw over it if given, present.
    pub fn present(
        &mut self,
        image: &Image,
        mut overlay: Option<(&mut OverlayPass, &OverlayFrame)>,
    ) -> anyhow::Result<Presented> {
        if let Some((pass, frame)) = &mut overlay {
            pass.prepare(frame)?;
        }
        let slot = self.free_acquire_semaphore()?;
        let semaphore = self.acquire[slot].0;
        // SAFETY: the swapchain and semaphore are live; the semaphore is unsignalled (its last
        // wait completed, or it is new).
        let acquired = unsafe {
            self.loader
                .acquire_next_image(self.raw, u64::MAX, semaphore, vk::Fence::null())
        };
        let index = match acquired {
            Ok((index, _suboptimal)) => index,
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                if let Some((pass, _)) = overlay {
                    pass.submitted(None);
                }
                return Ok(Presented::OutOfDate);
            }
            Err(e) => return Err(vk_err("vkAcquireNextImageKHR")(e).into()),
        };
        let target = self.images[index as usize];
        let rec = self
            .gpu
            .record(QueueRole::Graphics, PassId::Present.name(), None)?;
        {
            let cmd = rec.cmd();
            let _scope = cmd.scope(PassId::Present.name());
            cmd.transition(image, Access::BlitSrc);
            cmd.blit_to_swapchain(image, target, self.extent, overlay.is_none());
            if let Some((pass, frame)) = &mut overlay {
                let view = self.views[index as usize];
                pass.record(&cmd, (target, view, self.extent), frame)?;
            }
        }
        let done = self.render_done[index as usize];
        let point = self.gpu.submit_with_binary(
            rec,
            &[],
            &[(semaphore, vk::PipelineStageFlags2::ALL_TRANSFER)],
            &[done],
        )?;
        self.acquire[slot].1 = Some(point);
        if let Some((pass, _)) = overlay {
            pass.submitted(Some(point));
        }
        let waits = [done];
        let swapchains = [self.raw];
        let indices = [index];
        let info = vk::PresentInfoKHR::default()
            .wait_semaphores(&waits)
            .swapchains(&swapchains)
            .image_indices(&indices);
        let queue = self.gpu.queue(QueueRole::Graphics).raw();
        // SAFETY: the queue is externally synchronised by its lock (held); the image was
        // acquired and its blit submitted to signal `done`.
        let result = unsafe { self.loader.queue_present(*queue, &info) };
        drop(queue);
        match result {
            Ok(false) => Ok(Presented::Shown),
            Ok(true) | Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(Presented::OutOfDate),
            Err(e) => Err(vk_err("vkQueuePresentKHR")(e).into()),
        }
    }
}

impl Drop for Swapchain {
    fn drop(&mut self) {
        let _ = self.gpu.wait_idle();
        self.destroy_swapchain();
        // SAFETY: the swapchain is gone and the surface is no longer used.
        unsafe { self.surface_loader.destroy_surface(self.surface, None) };
    }
}
