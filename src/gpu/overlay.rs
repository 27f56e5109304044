//! The viewer's overlay pass: egui's triangles drawn over the swapchain image, after the blit,
//! by `egui-ash-renderer` (its pipeline made for dynamic rendering into the swapchain's format).
//!
//! ```text
//!  present (graphics queue, one command buffer):
//!   blit renderer image ─► swapchain image (TRANSFER_DST) ─► COLOR_ATTACHMENT ─► begin_rendering(load)
//!                                                          egui meshes (alpha blended, scissored)
//!                                                         end_rendering ─► PRESENT_SRC
//! ```
//!
//! egui-ash-renderer keeps one vertex/index buffer pair per frame in flight and writes the next
//! pair from the host in `cmd_draw`, so [`OverlayPass::record`] first waits for the present that
//! last drew with that pair ([`IN_FLIGHT`] presents back). Font-atlas uploads
//! (`set_textures`) submit and wait on the graphics queue themselves; they run only after every
//! earlier overlay draw has completed (they may rewrite a texture those draws read), under the
//! queue's lock. Textures egui frees are freed once the present that last used them completed.

use super::device::{Gpu, QueueRole, TimelinePoint};
use super::error::vk_err;
use super::Cmd;
use crate::timing::pass_id::PassId;
use ash::vk;
use std::collections::VecDeque;
use std::sync::Arc;

/// Presents whose overlay meshes may be in flight at once (the renderer's mesh buffer pairs).
const IN_FLIGHT: usize = 3;

/// What egui made for one frame: triangles and texture changes.
pub struct OverlayFrame {
    pub primitives: Vec<egui::ClippedPrimitive>,
    pub pixels_per_point: f32,
    pub textures: egui::TexturesDelta,
}

/// egui-ash-renderer and what keeps its buffers and textures safe to rewrite.
pub struct OverlayPass {
    // Field order is drop order: the renderer's objects go before the pool (both after the
    // GPU went idle, `Drop`).
    renderer: Option<egui_ash_renderer::Renderer>,
    gpu: Arc<Gpu>,
    /// For egui-ash-renderer's one-shot texture uploads (graphics queue family).
    pool: vk::CommandPool,
    /// The presents that drew the overlay, oldest first (at most [`IN_FLIGHT`]).
    draws: VecDeque<TimelinePoint>,
    /// Textures egui no longer uses, freed once the present that last drew completed.
    to_free: Vec<(Option<TimelinePoint>, Vec<egui::TextureId>)>,
    /// The textures of the frame being recorded that egui frees after it.
    frees: Vec<egui::TextureId>,
}

impl OverlayPass {
    /// An overlay drawing into images of `format` (the swapchain's).
    pub fn new(gpu: &Arc<Gpu>, format: vk::Format) -> anyhow::Result<Self> {
        let (_, instance) = gpu.instance();
        let family = gpu.queue(QueueRole::Graphics).family;
        let info = vk::CommandPoolCreateInfo::default()
            .flags(vk::CommandPoolCreateFlags::TRANSIENT)
            .queue_family_index(family);
        // SAFETY: the device is live; the family index is one of its queue families.
        let pool = unsafe { gpu.raw().create_command_pool(&info, None) }
            .map_err(vk_err("vkCreateCommandPool"))?;
        gpu.set_name(pool, "overlay.uploads");
        let renderer = egui_ash_renderer::Renderer::with_default_allocator(
            instance,
            gpu.physical,
            gpu.raw().clone(),
            egui_ash_renderer::DynamicRendering {
                color_attachment_format: format,
                depth_attachment_format: None,
            },
            egui_ash_renderer::Options {
                in_flight_frames: IN_FLIGHT,
                enable_depth_test: false,
                enable_depth_write: false,
                // The swapchain is UNORM holding sRGB-encoded values (swapchain.rs): the
                // shader encodes egui's colours itself.
                srgb_framebuffer: false,
            },
        );
        let renderer = match renderer {
            Ok(r) => r,
            Err(e) => {
                // SAFETY: the pool was just created and nothing uses it.
                unsafe { gpu.raw().destroy_command_pool(pool, None) };
                anyhow::bail!("cannot create the overlay's egui renderer: {e}");
            }
        };
        Ok(Self {
            renderer: Some(renderer),
            gpu: gpu.clone(),
            pool,
            draws: VecDeque::new(),
            to_free: Vec::new(),
            frees: Vec::new(),
        })
    }

    fn renderer(&mut self) -> &mut egui_ash_renderer::Renderer {
        self.renderer
            .as_mut()
            .expect("the egui renderer lives until drop")
    }

    /// Before recording a frame's overlay: applies egui's texture changes (font atlas) and frees
    /// the textures whose last draw completed.
    pub fn prepare(&mut self, frame: &OverlayFrame) -> anyhow::Result<()> {
        let gpu = self.gpu.clone();
        let mut kept = Vec::new();
        for (point, ids) in std::mem::take(&mut self.to_free) {
            if point.is_none_or(|p| gpu.is_complete(p)) {
                self.renderer()
                    .free_textures(&ids)
                    .map_err(|e| anyhow::anyhow!("overlay: cannot free textures: {e}"))?;
            } else {
                kept.push((point, ids));
            }
        }
        self.to_free = kept;
        if !frame.textures.set.is_empty() {
            // The upload may rewrite (part of) a texture that earlier draws read.
            for &point in &self.draws {
                gpu.wait(point)?;
            }
            let pool = self.pool;
            let queue = gpu.queue(QueueRole::Graphics).raw();
            // The renderer submits its copy and waits for the queue to go idle, holding the
            // queue's lock (the queue is externally synchronised).
            let result = self
                .renderer
                .as_mut()
                .expect("the egui renderer lives until drop")
                .set_textures(*queue, pool, &frame.textures.set);
            drop(queue);
            result.map_err(|e| anyhow::anyhow!("overlay: cannot upload textures: {e}"))?;
        }
        self.frees = frame.textures.free.clone();
        Ok(())
    }

    /// Draws `frame` into `view` of `image` (an acquired swapchain image of `extent`, just
    /// written by the blit, in TRANSFER_DST_OPTIMAL) and leaves the image in PRESENT_SRC_KHR.
    pub fn record(
        &mut self,
        cmd: &Cmd,
        (image, view, extent): (vk::Image, vk::ImageView, vk::Extent2D),
        frame: &OverlayFrame,
    ) -> anyhow::Result<()> {
        if self.draws.len() >= IN_FLIGHT {
            if let Some(oldest) = self.draws.pop_front() {
                // The mesh buffers cmd_draw is about to rewrite were last drawn by it.
                self.gpu.wait(oldest)?;
            }
        }
        let _scope = cmd.scope(PassId::Overlay.name());
        let range = vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: 1,
        };
        let barrier =
            |src: (vk::PipelineStageFlags2, vk::AccessFlags2, vk::ImageLayout),
             dst: (vk::PipelineStageFlags2, vk::AccessFlags2, vk::ImageLayout)| {
                vk::ImageMemoryBarrier2::default()
                    .src_stage_mask(src.0)
                    .src_access_mask(src.1)
                    .old_layout(src.2)
                    .dst_stage_mask(dst.0)
                    .dst_access_mask(dst.1)
                    .new_layout(dst.2)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .image(image)
                    .subresource_range(range)
            };
        let attachment = (
            vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
            vk::AccessFlags2::COLOR_ATTACHMENT_READ | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
            vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
        );
        let to_attachment = [barrier(
            (
                vk::PipelineStageFlags2::BLIT,
                vk::AccessFlags2::TRANSFER_WRITE,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            ),
            attachment,
        )];
        let device = cmd.device();
        // SAFETY: recording state; the image was written by the blit recorded before this.
        unsafe {
            device.cmd_pipeline_barrier2(
                cmd.raw(),
                &vk::DependencyInfo::default().image_memory_barriers(&to_attachment),
            )
        };
        let color = [vk::RenderingAttachmentInfo::default()
            .image_view(view)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::LOAD)
            .store_op(vk::AttachmentStoreOp::STORE)];
        let info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D {
                offset: vk::Offset2D::default(),
                extent,
            })
            .layer_count(1)
            .color_attachments(&color);
        // SAFETY: recording state; the view is of `image`, in COLOR_ATTACHMENT_OPTIMAL (the
        // barrier above); dynamic rendering is enabled on this device.
        unsafe { device.cmd_begin_rendering(cmd.raw(), &info) };
        let ppp = frame.pixels_per_point;
        let drawn = self
            .renderer()
            .cmd_draw(cmd.raw(), extent, ppp, &frame.primitives);
        // SAFETY: rendering was begun above on this command buffer.
        unsafe { device.cmd_end_rendering(cmd.raw()) };
        let to_present = [barrier(
            attachment,
            (
                vk::PipelineStageFlags2::NONE,
                vk::AccessFlags2::NONE,
                vk::ImageLayout::PRESENT_SRC_KHR,
            ),
        )];
        // SAFETY: recording state; the overlay's writes end here, before presentation (which
        // waits for the submission's semaphore).
        unsafe {
            device.cmd_pipeline_barrier2(
                cmd.raw(),
                &vk::DependencyInfo::default().image_memory_barriers(&to_present),
            )
        };
        drawn.map_err(|e| anyhow::anyhow!("overlay: cannot record egui's draw: {e}"))?;
        Ok(())
    }

    /// After the present that drew the overlay was submitted (`point`, `None` when it was not
    /// submitted).
    pub fn submitted(&mut self, point: Option<TimelinePoint>) {
        if let Some(p) = point {
            self.draws.push_back(p);
        }
        let frees = std::mem::take(&mut self.frees);
        if !frees.is_empty() {
            let last = point.or(self.draws.back().copied());
            self.to_free.push((last, frees));
        }
    }
}

impl Drop for OverlayPass {
    fn drop(&mut self) {
        let _ = self.gpu.wait_idle();
        // The renderer destroys its pipeline, buffers and textures at once: the GPU is idle.
        drop(self.renderer.take());
        // SAFETY: the GPU is idle; the pool's command buffers are no longer in use.
        unsafe { self.gpu.raw().destroy_command_pool(self.pool, None) };
    }
}
