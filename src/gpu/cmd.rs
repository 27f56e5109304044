//! Command recording and submission.
//!
//! A [`Recording`] owns a command pool and one primary command buffer for one queue role.
//! Passes record through [`Cmd`], which wraps every `vkCmd*` the renderer uses, so passes never
//! call ash themselves. [`Gpu::submit`] signals the queue's timeline and returns the
//! [`TimelinePoint`] that other queues and the host wait on.

use super::access::Access;
use super::device::{Gpu, QueueRole, Retired, TimelinePoint};
use super::error::{vk_err, GpuResult};
use super::pipeline::{DescriptorSet, Pipeline};
use super::resources::{aspect_of, Buffer, Image};
use super::timestamps::Timestamps;
use super::tracker::{Barrier, Tracker};
use ash::vk;
use std::ops::Range;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

/// A command buffer being recorded for one queue role.
pub struct Recording {
    gpu: Arc<Gpu>,
    pool: vk::CommandPool,
    raw: vk::CommandBuffer,
    pub role: QueueRole,
    timestamps: Option<Arc<Timestamps>>,
    /// Scopes open in this command buffer.
    depth: AtomicU32,
    /// The states of the resources this recording touched; handed back on submission.
    tracker: Mutex<Tracker>,
}

/// How a colour attachment starts.
#[derive(Clone, Copy, Debug)]
pub enum Load {
    Clear([f32; 4]),
    Keep,
}

/// A colour or depth attachment of a rendering scope.
pub struct Attachment<'a> {
    pub image: &'a Image,
    pub layer: u32,
    pub load: Load,
}

/// A host wait or a cross-queue wait on a timeline point, before `stage`.
#[derive(Clone, Copy, Debug)]
pub struct Wait {
    pub point: TimelinePoint,
    pub stage: vk::PipelineStageFlags2,
}

impl Gpu {
    /// Starts recording commands for `role`. With `timestamps`, every [`Cmd::scope`] also
    /// writes GPU timestamps, tagged with this queue and the scope's nesting depth.
    pub fn record(
        self: &Arc<Self>,
        role: QueueRole,
        name: &str,
        timestamps: Option<Arc<Timestamps>>,
    ) -> GpuResult<Recording> {
        let family = self.queue(role).family;
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(family)
            .flags(vk::CommandPoolCreateFlags::TRANSIENT);
        // SAFETY: the device is live and `family` is one of its queue families.
        let pool = unsafe { self.raw().create_command_pool(&info, None) }
            .map_err(vk_err("vkCreateCommandPool"))?;
        self.set_name(pool, &format!("{name}.pool"));
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool is live and owned by this recording.
        let raw = match unsafe { self.raw().allocate_command_buffers(&alloc) } {
            Ok(v) => v[0],
            Err(e) => {
                self.retire(Retired::CommandPool(pool));
                return Err(vk_err("vkAllocateCommandBuffers")(e));
            }
        };
        self.set_name(raw, name);
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: the command buffer was just allocated and is in the initial state.
        if let Err(e) = unsafe { self.raw().begin_command_buffer(raw, &begin) } {
            self.retire(Retired::CommandPool(pool));
            return Err(vk_err("vkBeginCommandBuffer")(e));
        }
        Ok(Recording {
            gpu: self.clone(),
            pool,
            raw,
            role,
            timestamps,
            depth: AtomicU32::new(0),
            tracker: Mutex::new(Tracker::default()),
        })
    }

    /// Ends `rec`, submits it to its queue after `waits`, and returns the timeline point its
    /// completion signals. A CPU span `submit` covers the call (the GPU cannot start the work
    /// before it does).
    pub fn submit(&self, rec: Recording, waits: &[Wait]) -> GpuResult<TimelinePoint> {
        self.submit_with_binary(rec, waits, &[], &[])
    }

    /// [`Gpu::submit`] that also waits for binary semaphores (`(semaphore, stage)`, e.g. a
    /// swapchain image's acquisition) and signals binary ones (e.g. for presentation).
    pub(super) fn submit_with_binary(
        &self,
        mut rec: Recording,
        waits: &[Wait],
        binary_waits: &[(vk::Semaphore, vk::PipelineStageFlags2)],
        binary_signals: &[vk::Semaphore],
    ) -> GpuResult<TimelinePoint> {
        let _span = crate::timing::span("submit");
        let queue_index = self.queue_index(rec.role);
        let queue = &self.queues[queue_index];
        // SAFETY: the buffer is in the recording state (Recording's invariant).
        unsafe { self.raw().end_command_buffer(rec.raw) }.map_err(vk_err("vkEndCommandBuffer"))?;
        let wait_infos: Vec<_> = waits
            .iter()
            .map(|w| {
                vk::SemaphoreSubmitInfo::default()
                    .semaphore(self.queues[w.point.queue].timeline)
                    .value(w.point.value)
                    .stage_mask(w.stage)
            })
            .chain(binary_waits.iter().map(|&(semaphore, stage)| {
                vk::SemaphoreSubmitInfo::default()
                    .semaphore(semaphore)
                    .stage_mask(stage)
            }))
            .collect();
        let cmd_infos = [vk::CommandBufferSubmitInfo::default().command_buffer(rec.raw)];
        let guard = queue.raw();
        let value = queue.next_value();
        let signal: Vec<_> = std::iter::once(
            vk::SemaphoreSubmitInfo::default()
                .semaphore(queue.timeline)
                .value(value)
                .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS),
        )
        .chain(binary_signals.iter().map(|&semaphore| {
            vk::SemaphoreSubmitInfo::default()
                .semaphore(semaphore)
                .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
        }))
        .collect();
        let submit = vk::SubmitInfo2::default()
            .wait_semaphore_infos(&wait_infos)
            .command_buffer_infos(&cmd_infos)
            .signal_semaphore_infos(&signal);
        // SAFETY: the queue is externally synchronised by its mutex (held); the command buffer
        // is executable; the semaphores are live timelines; `value` increases monotonically
        // because next_value is called under the queue lock.
        let result = unsafe {
            self.raw()
                .queue_submit2(*guard, &[submit], vk::Fence::null())
        };
        drop(guard);
        // The pool (and its buffer) is destroyed once this submission completes.
        let pool = std::mem::replace(&mut rec.pool, vk::CommandPool::null());
        self.retire(Retired::CommandPool(pool));
        result.map_err(vk_err("vkQueueSubmit2"))?;
        // Submitted: the states this recording leaves are the resources' states at rest.
        rec.tracker
            .get_mut()
            .unwrap_or_else(|e| e.into_inner())
            .commit();
        Ok(TimelinePoint {
            queue: queue_index,
            value,
        })
    }

    /// Blocks the host until `point` has completed.
    pub fn wait(&self, point: TimelinePoint) -> GpuResult<()> {
        let sems = [self.queues[point.queue].timeline];
        let values = [point.value];
        let info = vk::SemaphoreWaitInfo::default()
            .semaphores(&sems)
            .values(&values);
        // SAFETY: the semaphore is a live timeline of this device.
        unsafe { self.raw().wait_semaphores(&info, u64::MAX) }.map_err(vk_err("vkWaitSemaphores"))
    }

    /// Whether `point` has completed (no blocking).
    pub fn is_complete(&self, point: TimelinePoint) -> bool {
        self.completed(point.queue) >= point.value
    }

    /// Records with `f`, submits to `role`, and waits: for set-up and one-shot tools only.
    pub fn one_shot(
        self: &Arc<Self>,
        role: QueueRole,
        name: &str,
        f: impl FnOnce(&Cmd),
    ) -> GpuResult<()> {
        let rec = self.record(role, name, None)?;
        f(&rec.cmd());
        let point = self.submit(rec, &[])?;
        self.wait(point)
    }
}

impl Drop for Recording {
    fn drop(&mut self) {
        // Dropped without submitting (an error path): nothing of it reached the GPU.
        if self.pool != vk::CommandPool::null() {
            self.gpu.retire(Retired::CommandPool(self.pool));
        }
    }
}

impl Recording {
    /// The recorder for this command buffer.
    pub fn cmd(&self) -> Cmd<'_> {
        Cmd {
            gpu: &self.gpu,
            raw: self.raw,
            role: self.role,
            timestamps: self.timestamps.as_deref(),
            family: self.gpu.queue(self.role).family,
            depth: &self.depth,
            tracker: &self.tracker,
        }
    }
}

/// Records commands into a [`Recording`]. Every method is one `vkCmd*` (or a barrier derived
/// from the [`Access`] table); the command buffer is always in the recording state.
pub struct Cmd<'a> {
    gpu: &'a Gpu,
    raw: vk::CommandBuffer,
    role: QueueRole,
    timestamps: Option<&'a Timestamps>,
    /// The queue family the command buffer is recorded for.
    family: u32,
    depth: &'a AtomicU32,
    tracker: &'a Mutex<Tracker>,
}

/// A buffer or an image, as one entry of a batch of barriers ([`Cmd::barriers`]).
#[derive(Clone, Copy)]
pub enum Resource<'a> {
    Buffer(&'a Buffer),
    Image(&'a Image),
}

impl Resource<'_> {
    fn same(&self, other: &Resource) -> bool {
        match (self, other) {
            (Resource::Buffer(a), Resource::Buffer(b)) => a.raw == b.raw,
            (Resource::Image(a), Resource::Image(b)) => a.raw == b.raw,
            _ => false,
        }
    }
}

/// An open debug label / timestamp scope; closes when dropped.
pub struct Scope<'c, 'a> {
    cmd: &'c Cmd<'a>,
    index: Option<usize>,
}

impl Drop for Scope<'_, '_> {
    fn drop(&mut self) {
        if let (Some(t), Some(i)) = (self.cmd.timestamps, self.index) {
            t.write_end(self.cmd, i);
        }
        self.cmd.depth.fetch_sub(1, Ordering::Relaxed);
        // SAFETY: the label was opened by `Cmd::scope` on this command buffer.
        unsafe {
            self.cmd
                .gpu
                .debug_utils
                .cmd_end_debug_utils_label(self.cmd.raw)
        };
    }
}

impl<'a> Cmd<'a> {
    pub(super) fn raw(&self) -> vk::CommandBuffer {
        self.raw
    }

    pub(super) fn device(&self) -> &ash::Device {
        self.gpu.raw()
    }

    /// Opens a named scope: a debug label and, when timing, a pair of GPU timestamps. The
    /// name is the pass's name, so a RenderDoc capture and a trace read like the code.
    pub fn scope(&self, name: &str) -> Scope<'_, 'a> {
        let cname = std::ffi::CString::new(name).unwrap_or_default();
        let label = vk::DebugUtilsLabelEXT::default().label_name(&cname);
        // SAFETY: recording state; the label string outlives the call.
        unsafe {
            self.gpu
                .debug_utils
                .cmd_begin_debug_utils_label(self.raw, &label)
        };
        let depth = self.depth.fetch_add(1, Ordering::Relaxed);
        let index = self
            .timestamps
            .and_then(|t| t.write_begin(self, self.role, name, depth));
        Scope { cmd: self, index }
    }

    /// Makes the next use of each resource in `uses` wait for what came before it (and
    /// changes image layouts, and acquires buffers handed over by another queue family): one
    /// `vkCmdPipelineBarrier2` for the whole batch, none when no use needs one. The "from"
    /// state is this recording's (`tracker.rs`).
    pub fn barriers(&self, uses: &[(Resource, Access)]) {
        let mut tracker = self.tracker.lock().unwrap_or_else(|e| e.into_inner());
        let mut images = Vec::new();
        let mut buffers = Vec::new();
        for (i, &(resource, to)) in uses.iter().enumerate() {
            // A resource bound twice (e.g. one image for two bindings) waits once.
            if let Some(&(_, before)) = uses[..i].iter().find(|(r, _)| r.same(&resource)) {
                debug_assert_eq!(before, to, "one resource used two ways in one batch");
                continue;
            }
            match resource {
                Resource::Image(image) => {
                    if let Some(b) = tracker.state(&image.resting).next(to, self.family, true) {
                        images.push(image_barrier(image, &b));
                    }
                }
                Resource::Buffer(buffer) => {
                    if let Some(b) = tracker.state(&buffer.resting).next(to, self.family, false) {
                        buffers.push(buffer_barrier(buffer, &b));
                    }
                }
            }
        }
        self.pipeline_barrier(&images, &buffers);
    }

    /// Records one `vkCmdPipelineBarrier2` of `images` and `buffers` (nothing when both are
    /// empty).
    fn pipeline_barrier(
        &self,
        images: &[vk::ImageMemoryBarrier2],
        buffers: &[vk::BufferMemoryBarrier2],
    ) {
        if images.is_empty() && buffers.is_empty() {
            return;
        }
        let dep = vk::DependencyInfo::default()
            .image_memory_barriers(images)
            .buffer_memory_barriers(buffers);
        // SAFETY: recording state, outside a rendering scope; the resources are live (borrowed
        // by the caller); synchronization2 is enabled; a barrier naming two queue families is
        // one half of an ownership transfer, recorded on the family that holds the buffer (a
        // release) or that it was released to (an acquire, after a semaphore wait on it).
        unsafe { self.device().cmd_pipeline_barrier2(self.raw, &dep) };
    }

    /// Makes the next `to` access of `image` wait for its last access, changing its layout.
    pub fn transition(&self, image: &Image, to: Access) {
        self.barriers(&[(Resource::Image(image), to)]);
    }

    /// Makes the next `to` access of `buffer` wait for its last access.
    pub fn transition_buffer(&self, buffer: &Buffer, to: Access) {
        self.barriers(&[(Resource::Buffer(buffer), to)]);
    }

    /// Begins dynamic rendering into `colors` (+ `depth`), with viewport and scissor set to the
    /// full extent of the first attachment. Transitions the attachments first.
    pub fn begin_rendering(&self, colors: &[Attachment], depth: Option<&Attachment>) {
        let extent = colors
            .first()
            .or(depth)
            .map(|a| a.image.extent())
            .unwrap_or_default();
        // Read-write: a blending pipeline reads the attachment even after a clear.
        let uses: Vec<_> = colors
            .iter()
            .map(|c| (Resource::Image(c.image), Access::ColorAttachmentBlend))
            .chain(depth.map(|d| (Resource::Image(d.image), Access::DepthAttachmentWrite)))
            .collect();
        self.barriers(&uses);
        let color_infos: Vec<_> = colors
            .iter()
            .map(|c| {
                let (load_op, clear) = match c.load {
                    Load::Clear(v) => (vk::AttachmentLoadOp::CLEAR, v),
                    Load::Keep => (vk::AttachmentLoadOp::LOAD, [0.0; 4]),
                };
                vk::RenderingAttachmentInfo::default()
                    .image_view(c.image.layer_view(c.layer))
                    .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                    .load_op(load_op)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .clear_value(vk::ClearValue {
                        color: vk::ClearColorValue { float32: clear },
                    })
            })
            .collect();
        let depth_info = depth.map(|d| {
            let (load_op, clear) = match d.load {
                Load::Clear(v) => (vk::AttachmentLoadOp::CLEAR, v[0]),
                Load::Keep => (vk::AttachmentLoadOp::LOAD, 0.0),
            };
            vk::RenderingAttachmentInfo::default()
                .image_view(d.image.layer_view(d.layer))
                .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .load_op(load_op)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue {
                    depth_stencil: vk::ClearDepthStencilValue {
                        depth: clear,
                        stencil: 0,
                    },
                })
        });
        let area = vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent,
        };
        let mut info = vk::RenderingInfo::default()
            .render_area(area)
            .layer_count(1)
            .color_attachments(&color_infos);
        if let Some(d) = &depth_info {
            info = info.depth_attachment(d);
        }
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: extent.width as f32,
            height: extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        // SAFETY: recording state, outside any rendering scope; attachments are live and in
        // the layouts named (transitioned above); dynamic rendering is enabled.
        unsafe {
            self.device().cmd_begin_rendering(self.raw, &info);
            self.device().cmd_set_viewport(self.raw, 0, &[viewport]);
            self.device().cmd_set_scissor(self.raw, 0, &[area]);
        }
    }

    /// Restricts drawing to the top-left `width`×`height` texels of the attachments.
    pub fn set_viewport(&self, width: u32, height: u32) {
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: width as f32,
            height: height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        let scissor = vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent: vk::Extent2D { width, height },
        };
        // SAFETY: recording state inside a rendering scope; viewport and scissor are dynamic
        // states of every graphics pipeline (pipeline.rs).
        unsafe {
            self.device().cmd_set_viewport(self.raw, 0, &[viewport]);
            self.device().cmd_set_scissor(self.raw, 0, &[scissor]);
        }
    }

    pub fn end_rendering(&self) {
        // SAFETY: paired with begin_rendering by the caller.
        unsafe { self.device().cmd_end_rendering(self.raw) };
    }

    pub fn bind_pipeline(&self, pipeline: &Pipeline) {
        // SAFETY: recording state; the pipeline is live.
        unsafe {
            self.device()
                .cmd_bind_pipeline(self.raw, pipeline.bind_point, pipeline.raw)
        };
    }

    pub fn bind_sets(&self, pipeline: &Pipeline, first: u32, sets: &[DescriptorSet]) {
        let raw: Vec<_> = sets.iter().map(|s| s.0).collect();
        // SAFETY: recording state; sets are compatible with the pipeline's layout by
        // construction (created from the same DescriptorLayouts).
        unsafe {
            self.device().cmd_bind_descriptor_sets(
                self.raw,
                pipeline.bind_point,
                pipeline.layout,
                first,
                &raw,
                &[],
            )
        };
    }

    pub fn push_constants<T: bytemuck::Pod>(&self, pipeline: &Pipeline, value: &T) {
        assert_eq!(
            size_of::<T>() as u32,
            pipeline.push_size,
            "push constants of the wrong size for this pipeline"
        );
        // SAFETY: recording state; the pipeline layout declares a push range of exactly
        // size_of::<T>() bytes for these stages (asserted above).
        unsafe {
            self.device().cmd_push_constants(
                self.raw,
                pipeline.layout,
                pipeline.push_stages,
                0,
                bytemuck::bytes_of(value),
            )
        };
    }

    pub fn bind_vertex_buffer(&self, buffer: &Buffer) {
        // SAFETY: recording state; the buffer is live with VERTEX_BUFFER usage.
        unsafe {
            self.device()
                .cmd_bind_vertex_buffers(self.raw, 0, &[buffer.raw], &[0])
        };
    }

    pub fn bind_index_buffer(&self, buffer: &Buffer) {
        // SAFETY: recording state; the buffer is live with INDEX_BUFFER usage.
        unsafe {
            self.device()
                .cmd_bind_index_buffer(self.raw, buffer.raw, 0, vk::IndexType::UINT32)
        };
    }

    pub fn draw(&self, vertices: u32, instances: u32) {
        // SAFETY: recording state inside a rendering scope with a graphics pipeline bound.
        unsafe { self.device().cmd_draw(self.raw, vertices, instances, 0, 0) };
    }

    pub fn draw_indexed(&self, indices: u32, first_index: u32, vertex_offset: i32) {
        // SAFETY: recording state inside a rendering scope; index/vertex buffers bound.
        unsafe {
            self.device()
                .cmd_draw_indexed(self.raw, indices, 1, first_index, vertex_offset, 0)
        };
    }

    /// Draws `instances` instances of the bound index buffer's first `indices` indices.
    pub fn draw_indexed_instanced(&self, indices: u32, instances: u32) {
        // SAFETY: recording state inside a rendering scope; index/vertex buffers bound.
        unsafe {
            self.device()
                .cmd_draw_indexed(self.raw, indices, instances, 0, 0, 0)
        };
    }

    pub fn dispatch(&self, x: u32, y: u32, z: u32) {
        // SAFETY: recording state with a compute pipeline bound.
        unsafe { self.device().cmd_dispatch(self.raw, x, y, z) };
    }

    /// Copies the first layer of `image` into `buffer` (tightly packed rows).
    pub fn copy_image_to_buffer(&self, image: &Image, buffer: &Buffer) {
        self.barriers(&[
            (Resource::Image(image), Access::TransferSrc),
            (Resource::Buffer(buffer), Access::TransferDst),
        ]);
        let region = vk::BufferImageCopy::default()
            .image_subresource(vk::ImageSubresourceLayers {
                aspect_mask: aspect_of(image.format),
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            })
            .image_extent(vk::Extent3D {
                width: image.width,
                height: image.height,
                depth: 1,
            });
        // SAFETY: recording state; the image is in TRANSFER_SRC_OPTIMAL (transitioned above);
        // the buffer is large enough (checked by the caller that sized it).
        unsafe {
            self.device().cmd_copy_image_to_buffer(
                self.raw,
                image.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buffer.raw,
                &[region],
            )
        };
    }

    /// Copies `buffer` (tightly packed rows, layer after layer) into every layer of `image`.
    pub fn copy_buffer_to_image(&self, buffer: &Buffer, image: &Image) {
        let region = vk::BufferImageCopy::default()
            .image_subresource(Self::layers(image, image.layers))
            .image_extent(vk::Extent3D {
                width: image.width,
                height: image.height,
                depth: 1,
            });
        // The buffer holds the whole image (checked by the caller that sized it).
        self.copy_to_image(buffer, image, region);
    }

    /// Copies one texel, at `offset` of `buffer`, into texel (`x`, `y`) of the first layer of
    /// `image` (the value check's injected bad values, `passes/value_check.rs`).
    pub fn copy_buffer_to_texel(
        &self,
        buffer: &Buffer,
        offset: u64,
        image: &Image,
        (x, y): (u32, u32),
    ) {
        assert!(
            x < image.width && y < image.height && offset < buffer.size,
            "copy_buffer_to_texel: ({x}, {y}) outside {} ({}x{}) or {offset} outside {}",
            image.name,
            image.width,
            image.height,
            buffer.name
        );
        let region = vk::BufferImageCopy::default()
            .buffer_offset(offset)
            .image_subresource(Self::layers(image, 1))
            .image_offset(vk::Offset3D {
                x: x as i32,
                y: y as i32,
                z: 0,
            })
            .image_extent(vk::Extent3D {
                width: 1,
                height: 1,
                depth: 1,
            });
        self.copy_to_image(buffer, image, region);
    }

    /// The first `count` layers of `image`'s only mip level.
    fn layers(image: &Image, count: u32) -> vk::ImageSubresourceLayers {
        vk::ImageSubresourceLayers {
            aspect_mask: aspect_of(image.format),
            mip_level: 0,
            base_array_layer: 0,
            layer_count: count,
        }
    }

    /// Transitions `buffer` and `image` and records the copy of `region` between them.
    fn copy_to_image(&self, buffer: &Buffer, image: &Image, region: vk::BufferImageCopy) {
        self.barriers(&[
            (Resource::Image(image), Access::TransferDst),
            (Resource::Buffer(buffer), Access::TransferSrc),
        ]);
        // SAFETY: recording state; the image is in TRANSFER_DST_OPTIMAL (transitioned above);
        // the region lies inside the image and the buffer (the public callers' checks).
        unsafe {
            self.device().cmd_copy_buffer_to_image(
                self.raw,
                buffer.raw,
                image.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
    }

    /// Copies all of `src` into the start of `dst`.
    pub fn copy_buffer(&self, src: &Buffer, dst: &Buffer) {
        self.barriers(&[
            (Resource::Buffer(src), Access::TransferSrc),
            (Resource::Buffer(dst), Access::TransferDst),
        ]);
        let region = vk::BufferCopy {
            src_offset: 0,
            dst_offset: 0,
            size: src.size.min(dst.size),
        };
        // SAFETY: recording state; both buffers are live and the region fits both.
        unsafe {
            self.device()
                .cmd_copy_buffer(self.raw, src.raw, dst.raw, &[region])
        };
    }

    /// Copies each byte range `r` of `src` to `dst`, starting at `at` there, for every
    /// `(r, at)` of `regions` (empty ranges are left out; each must lie in both buffers).
    pub fn copy_buffer_regions(&self, src: &Buffer, dst: &Buffer, regions: &[(Range<u64>, u64)]) {
        let regions: Vec<vk::BufferCopy> = regions
            .iter()
            .filter(|(r, _)| r.end > r.start)
            .map(|(r, at)| {
                assert!(
                    r.end <= src.size && at + (r.end - r.start) <= dst.size,
                    "copy of {r:?} from {} ({} bytes) to {at} of {} ({} bytes) overflows",
                    src.name,
                    src.size,
                    dst.name,
                    dst.size
                );
                vk::BufferCopy {
                    src_offset: r.start,
                    dst_offset: *at,
                    size: r.end - r.start,
                }
            })
            .collect();
        if regions.is_empty() {
            return;
        }
        self.barriers(&[
            (Resource::Buffer(src), Access::TransferSrc),
            (Resource::Buffer(dst), Access::TransferDst),
        ]);
        // SAFETY: recording state; both buffers are live and every region lies in both
        // (asserted above).
        unsafe {
            self.device()
                .cmd_copy_buffer(self.raw, src.raw, dst.raw, &regions)
        };
    }

    /// Fills `buffer` with the 32-bit `value`.
    pub fn fill_buffer(&self, buffer: &Buffer, value: u32) {
        self.transition_buffer(buffer, Access::TransferDst);
        // SAFETY: recording state; the buffer is live with TRANSFER_DST usage and its size is
        // a multiple of 4 (Buffer::new rounds up to at least 4; WHOLE_SIZE rounds down).
        unsafe {
            self.device()
                .cmd_fill_buffer(self.raw, buffer.raw, 0, vk::WHOLE_SIZE, value)
        };
    }

    /// Writes `bytes` at `offset` of `buffer` from the command stream (`vkCmdUpdateBuffer`, in
    /// chunks of 64 KiB), then makes them visible to every shader stage. Per-frame constants
    /// travel this way so the host never writes memory an earlier frame in flight still reads.
    pub fn update_buffer(&self, buffer: &Buffer, offset: u64, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        assert!(
            offset % 4 == 0 && bytes.len() % 4 == 0 && offset + bytes.len() as u64 <= buffer.size,
            "update_buffer: {} bytes at {offset} of {} ({} bytes)",
            bytes.len(),
            buffer.name,
            buffer.size
        );
        self.transition_buffer(buffer, Access::TransferDst);
        for (i, chunk) in bytes.chunks(65536).enumerate() {
            // SAFETY: recording state, outside a render pass; the buffer is live with
            // TRANSFER_DST usage; offset and size are multiples of 4, the chunk is ≤ 65536 bytes
            // and fits the buffer (asserted above).
            unsafe {
                self.device().cmd_update_buffer(
                    self.raw,
                    buffer.raw,
                    offset + i as u64 * 65536,
                    chunk,
                )
            };
        }
        self.transition_buffer(buffer, Access::AnyShaderUniformRead);
    }

    /// Hands `buffer` over to the queue of `to`: a queue-family release barrier when this
    /// queue's family holds it and `to`'s differs; nothing otherwise (one family: the timeline
    /// semaphore the other queue waits on orders and makes visible everything before it). The
    /// first use on the receiving family acquires it ([`Cmd::barriers`]), in a submission that
    /// must wait for this one.
    pub fn release_buffer(&self, buffer: &Buffer, to: QueueRole) {
        let to = self.gpu.queue(to).family;
        let mut tracker = self.tracker.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(b) = tracker.state(&buffer.resting).release(self.family, to) {
            drop(tracker);
            self.pipeline_barrier(&[], &[buffer_barrier(buffer, &b)]);
        }
    }

    /// Blits all of `src` (in [`Access::BlitSrc`]) onto the swapchain image `dst` of `extent`,
    /// scaled with a linear filter, leaving `dst` ready to present (`then_present`) or in
    /// TRANSFER_DST_OPTIMAL for the overlay to draw on (`overlay.rs`). The submission waits for
    /// the image's acquisition at the transfer stages.
    pub(super) fn blit_to_swapchain(
        &self,
        src: &Image,
        dst: vk::Image,
        extent: vk::Extent2D,
        then_present: bool,
    ) {
        let range = vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: 1,
        };
        let to_dst = vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::ALL_TRANSFER)
            .src_access_mask(vk::AccessFlags2::NONE)
            .dst_stage_mask(vk::PipelineStageFlags2::BLIT)
            .dst_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .old_layout(vk::ImageLayout::UNDEFINED)
            .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(dst)
            .subresource_range(range);
        let barriers = [to_dst];
        let dep = vk::DependencyInfo::default().image_memory_barriers(&barriers);
        // SAFETY: recording state; `dst` is an acquired swapchain image whose acquisition the
        // submission waits for at ALL_TRANSFER (chained by this barrier's source scope).
        unsafe { self.device().cmd_pipeline_barrier2(self.raw, &dep) };
        let e = src.extent();
        let corner = |w: u32, h: u32| {
            [
                vk::Offset3D { x: 0, y: 0, z: 0 },
                vk::Offset3D {
                    x: w as i32,
                    y: h as i32,
                    z: 1,
                },
            ]
        };
        let layers = vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        };
        let region = vk::ImageBlit {
            src_subresource: layers,
            src_offsets: corner(e.width, e.height),
            dst_subresource: layers,
            dst_offsets: corner(extent.width, extent.height),
        };
        // SAFETY: recording state; `src` is in TRANSFER_SRC_OPTIMAL (BlitSrc), `dst` in
        // TRANSFER_DST_OPTIMAL; both regions lie inside their images; both formats support
        // linear blits (8-bit UNORM colour formats).
        unsafe {
            self.device().cmd_blit_image(
                self.raw,
                src.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                dst,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
                vk::Filter::LINEAR,
            )
        };
        if !then_present {
            return;
        }
        let to_present = vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::BLIT)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::NONE)
            .dst_access_mask(vk::AccessFlags2::NONE)
            .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .new_layout(vk::ImageLayout::PRESENT_SRC_KHR)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(dst)
            .subresource_range(range);
        let barriers = [to_present];
        let dep = vk::DependencyInfo::default().image_memory_barriers(&barriers);
        // SAFETY: recording state; the image was just written by the blit above.
        unsafe { self.device().cmd_pipeline_barrier2(self.raw, &dep) };
    }
}

/// The family indices of a barrier: the transfer's, or none.
fn families(b: &Barrier) -> (u32, u32) {
    b.families
        .unwrap_or((vk::QUEUE_FAMILY_IGNORED, vk::QUEUE_FAMILY_IGNORED))
}

fn image_barrier(image: &Image, b: &Barrier) -> vk::ImageMemoryBarrier2<'static> {
    let (src_family, dst_family) = families(b);
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(b.src_stage)
        .src_access_mask(b.src_access)
        .dst_stage_mask(b.dst_stage)
        .dst_access_mask(b.dst_access)
        .old_layout(b.old_layout)
        .new_layout(b.new_layout)
        .src_queue_family_index(src_family)
        .dst_queue_family_index(dst_family)
        .image(image.raw)
        .subresource_range(vk::ImageSubresourceRange {
            aspect_mask: image.aspect(),
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: image.layers,
        })
}

fn buffer_barrier(buffer: &Buffer, b: &Barrier) -> vk::BufferMemoryBarrier2<'static> {
    let (src_family, dst_family) = families(b);
    vk::BufferMemoryBarrier2::default()
        .src_stage_mask(b.src_stage)
        .src_access_mask(b.src_access)
        .dst_stage_mask(b.dst_stage)
        .dst_access_mask(b.dst_access)
        .src_queue_family_index(src_family)
        .dst_queue_family_index(dst_family)
        .buffer(buffer.raw)
        .offset(0)
        .size(vk::WHOLE_SIZE)
}
