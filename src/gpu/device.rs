//! [`Gpu`]: the instance, the chosen physical device, the logical device, its queues (one
//! timeline semaphore each), the memory allocator, and deferred destruction.
//!
//! Device choice: discrete GPUs first, then integrated, virtual and CPU (lavapipe) devices;
//! `--device N` overrides. Required: Vulkan 1.3 with synchronization2, dynamic rendering,
//! maintenance4 (shaderc's SPIR-V 1.6 uses `LocalSizeId`), timeline semaphores and host query
//! reset.
//!
//! Queues: the graphics family serves graphics; a compute-only family (async compute) serves
//! compute when the device has one; a transfer-only family (DMA engine) serves transfers when
//! the device has one. On lavapipe all three roles share one queue, and so one timeline.
//!
//! Lifetimes: a resource dropped while the GPU may still use it is *retired*: it waits in the
//! graveyard, tagged with every queue's last submitted timeline value, and is destroyed by
//! [`Gpu::collect_garbage`] once all those values have completed (or at shutdown).

mod choice;
mod create;
mod graveyard;
mod planned;

pub use choice::{device_type_rank, list_devices, DeviceProperties};
pub(super) use graveyard::Retired;
pub(crate) use planned::{PlannedImage, WaitingWrite};

use super::clock::DeviceClock;
use super::error::{vk_err, GpuResult};
use super::instance::InstanceParts;
use ash::vk;
use gpu_allocator::vulkan::Allocator;
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

/// How to create the [`Gpu`].
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Index into the enumerated physical devices; `None` picks the best.
    pub device_index: Option<usize>,
    /// Enable the Khronos validation layer with synchronization validation.
    pub validation: bool,
    /// With validation: leave synchronization validation out. Layer 1.3.239's synchronization
    /// validation does not retire submissions that complete through timeline semaphores, so its
    /// memory grows with every submission (about 15 kB per frame here); the test of the
    /// renderer's own memory (`tests/motion_memory.rs`) runs core validation only.
    pub without_sync_validation: bool,
    /// Which queues the roles use.
    pub queues: QueueMode,
    /// Put GPU timestamps on the host clock by a measured offset even where calibrated
    /// timestamps are available (tests compare the two).
    pub measured_clock: bool,
    /// The display the renderer will present to (`ispm view`): enables the surface instance
    /// extensions it needs and `VK_KHR_swapchain`.
    pub display: Option<raw_window_handle::RawDisplayHandle>,
}

/// Which device queues serve the [`QueueRole`]s.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum QueueMode {
    /// Dedicated compute and transfer families where the device has them, else the graphics
    /// queue.
    #[default]
    Auto,
    /// The graphics queue for every role.
    Single,
    /// A logical transfer queue: the graphics `VkQueue` again, with its own timeline
    /// semaphore, so one-queue devices (lavapipe) run the multi-queue schedule's separate
    /// submissions, cross-queue waits and release/acquire hand-offs.
    SplitTransfer,
}

pub use crate::timing::QueueRole;

/// A device queue with its own timeline semaphore.
pub struct Queue {
    /// Shared by the logical queues of [`QueueMode::SplitTransfer`]: one lock per `VkQueue`.
    raw: Arc<Mutex<vk::Queue>>,
    pub family: u32,
    pub flags: vk::QueueFlags,
    pub timestamp_valid_bits: u32,
    pub(super) timeline: vk::Semaphore,
    submitted: AtomicU64,
}

impl Queue {
    /// The timeline value of the last submission to this queue.
    pub fn last_submitted(&self) -> u64 {
        self.submitted.load(Ordering::Acquire)
    }

    pub(super) fn raw(&self) -> MutexGuard<'_, vk::Queue> {
        self.raw.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub(super) fn next_value(&self) -> u64 {
        self.submitted.fetch_add(1, Ordering::AcqRel) + 1
    }
}

/// A point on a queue's timeline: "the work submitted up to here".
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimelinePoint {
    pub queue: usize,
    pub value: u64,
}

/// Everything the renderer knows about the Vulkan device.
pub struct Gpu {
    pub(super) debug_utils: ash::ext::debug_utils::Device,
    pub(super) device: ash::Device,
    pub(super) physical: vk::PhysicalDevice,
    pub properties: DeviceProperties,
    /// Distinct queues; roles index into this.
    pub(super) queues: Vec<Queue>,
    roles: [usize; 3],
    allocator: ManuallyDrop<Mutex<Allocator>>,
    graveyard: Mutex<Vec<(Vec<u64>, Retired)>>,
    /// The images planned but not made yet, and the descriptor writes waiting for them.
    planned: Mutex<planned::Planned>,
    /// How timestamps are put on the host clock (`clock.rs`).
    pub(super) clock: DeviceClock,
    pub validation: bool,
    /// Dropped last (fields drop after `Drop::drop`, which destroys the device first).
    instance: InstanceParts,
}

impl Gpu {
    /// The instance and loader (for code inside `gpu/`: surfaces).
    pub(super) fn instance(&self) -> (&ash::Entry, &ash::Instance) {
        (&self.instance.entry, &self.instance.instance)
    }

    /// The raw `ash` device (for code inside `gpu/`).
    pub(super) fn raw(&self) -> &ash::Device {
        &self.device
    }

    /// Index of the queue serving `role` in [`Gpu::queue_list`].
    pub fn queue_index(&self, role: QueueRole) -> usize {
        self.roles[role as usize]
    }

    pub fn queue(&self, role: QueueRole) -> &Queue {
        &self.queues[self.queue_index(role)]
    }

    /// The distinct queues this device uses.
    pub fn queue_list(&self) -> &[Queue] {
        &self.queues
    }

    /// The name of queue `index`'s trace track: the roles it serves, e.g.
    /// `GPU graphics+compute+transfer queue`.
    pub fn queue_label(&self, index: usize) -> String {
        let roles: Vec<&str> = QueueRole::ALL
            .into_iter()
            .filter(|&r| self.queue_index(r) == index)
            .map(QueueRole::name)
            .collect();
        format!("GPU {} queue", roles.join("+"))
    }

    /// Validation messages counted so far (empty when validation is off).
    pub fn validation_messages(&self) -> Vec<String> {
        self.instance.log().messages()
    }

    pub fn validation_message_count(&self) -> usize {
        self.instance.log().count()
    }

    pub(super) fn allocator(&self) -> MutexGuard<'_, Allocator> {
        self.allocator.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Gives a Vulkan object a debug name (shown by validation messages and RenderDoc).
    pub fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        let Ok(name) = std::ffi::CString::new(name) else {
            return;
        };
        let info = vk::DebugUtilsObjectNameInfoEXT::default()
            .object_handle(handle)
            .object_name(&name);
        // SAFETY: the handle belongs to this device and `name` outlives the call. Naming is
        // best-effort: a failure only loses a debug name.
        let _ = unsafe { self.debug_utils.set_debug_utils_object_name(&info) };
    }

    /// Completed timeline value of queue `queue`.
    pub fn completed(&self, queue: usize) -> u64 {
        // SAFETY: the semaphore is a live timeline semaphore of this device.
        unsafe {
            self.device
                .get_semaphore_counter_value(self.queues[queue].timeline)
        }
        .unwrap_or(0)
    }

    /// Blocks until the device is idle. Only for shutdown and one-shot tools.
    pub fn wait_idle(&self) -> GpuResult<()> {
        // vkDeviceWaitIdle needs every queue externally synchronised: hold all their locks.
        // Logical queues sharing one `VkQueue` share its lock: take each lock once.
        let mut distinct: Vec<&Queue> = Vec::new();
        for q in &self.queues {
            if !distinct.iter().any(|d| Arc::ptr_eq(&d.raw, &q.raw)) {
                distinct.push(q);
            }
        }
        let _locks: Vec<_> = distinct.into_iter().map(Queue::raw).collect();
        // SAFETY: the device is live and no queue can be used while the locks are held.
        unsafe { self.device.device_wait_idle() }.map_err(vk_err("vkDeviceWaitIdle"))
    }
}
