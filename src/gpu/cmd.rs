//! Command recording and submission.
//!
//! A [`Recording`] owns a command pool and one primary command buffer for one queue role.
//! Passes record through [`Cmd`], which wraps every `vkCmd*` the renderer uses, so passes never
//! call ash themselves. [`Gpu::submit`] signals the queue's timeline and returns the
//! [`TimelinePoint`] that other queues and the host wait on.

use super::access::Access;
use super::device::{Gpu, QueueRole, Retired, TimelinePoint};
use super::error::{vk_err, GpuResult};
use super::image::Image;
use super::resources::Buffer;
use super::timestamps::Timestamps;
use super::tracker::{Barrier, Tracker};
use ash::vk;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

mod copy;
mod draw;

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
            (Resource::Image(a), Resource::Image(b)) => a.is(b),
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
        if let Some((pool, query)) = self
            .cmd
            .timestamps
            .zip(self.index)
            .and_then(|(t, i)| t.end(i))
        {
            self.cmd.write_timestamp(pool, query);
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
            .and_then(|t| t.begin(self.role, name, depth))
            .map(|(index, pool, query)| {
                self.write_timestamp(pool, query);
                index
            });
        Scope { cmd: self, index }
    }

    /// Records a timestamp into `query` of `pool` once all earlier commands have completed.
    pub(super) fn write_timestamp(&self, pool: vk::QueryPool, query: u32) {
        // SAFETY: recording state; the caller owns `query` of `pool`, reset on the host since its
        // last use, on a queue whose family has timestampValidBits > 0; synchronization2 is on.
        unsafe {
            self.device().cmd_write_timestamp2(
                self.raw,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                pool,
                query,
            )
        };
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
                assert_eq!(before, to, "one resource used two ways in one batch");
                continue;
            }
            match resource {
                Resource::Image(image) => {
                    // A check that it is made with a usage that covers the access, naming the
                    // image, before the validation layer would report it at the command.
                    image.expect_usage(to.image_usage(), format_args!("{to:?}"));
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
        .image(image.raw())
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
