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

use super::clock::{calibration_choice, ClockSource, DeviceClock};
use super::error::{vk_err, GpuError, GpuResult};
use super::instance::{create_instance, InstanceParts};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, Allocator, AllocatorCreateDesc};
use std::ffi::CStr;
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

/// A Vulkan object whose destruction waits for the GPU.
pub(super) enum Retired {
    Buffer(vk::Buffer, Allocation),
    Image(vk::Image, Allocation, Vec<vk::ImageView>),
    Sampler(vk::Sampler),
    Pipeline(vk::Pipeline, vk::PipelineLayout),
    DescriptorPool(vk::DescriptorPool),
    DescriptorSetLayout(vk::DescriptorSetLayout),
    CommandPool(vk::CommandPool),
    QueryPool(vk::QueryPool),
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
    /// How timestamps are put on the host clock (`clock.rs`).
    pub(super) clock: DeviceClock,
    pub validation: bool,
    /// Dropped last (fields drop after `Drop::drop`, which destroys the device first).
    instance: InstanceParts,
}

/// A logical device and its timeline semaphores, destroyed on drop unless handed to a [`Gpu`]
/// (the error paths of [`Gpu::new`] between device creation and the `Gpu`'s construction).
struct DeviceGuard {
    device: Option<ash::Device>,
    semaphores: Vec<vk::Semaphore>,
}

impl DeviceGuard {
    fn device(&self) -> &ash::Device {
        self.device
            .as_ref()
            .expect("DeviceGuard holds its device until disarmed")
    }

    fn disarm(mut self) -> ash::Device {
        self.semaphores.clear();
        self.device
            .take()
            .expect("DeviceGuard holds its device until disarmed")
    }
}

impl Drop for DeviceGuard {
    fn drop(&mut self) {
        if let Some(device) = self.device.take() {
            // SAFETY: nothing else was created from the device; no work was submitted.
            unsafe {
                for &s in &self.semaphores {
                    device.destroy_semaphore(s, None);
                }
                device.destroy_device(None);
            }
        }
    }
}

/// What `ispm info` prints about the device.
#[derive(Clone, Debug)]
pub struct DeviceProperties {
    pub name: String,
    pub device_type: vk::PhysicalDeviceType,
    pub api_version: u32,
    pub driver_name: String,
    pub driver_info: String,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period: f32,
    pub families: Vec<vk::QueueFamilyProperties>,
    pub calibrated_timestamps: bool,
    /// Most bytes one storage-buffer descriptor reaches (`maxStorageBufferRange`).
    pub max_storage_buffer_range: u32,
    /// Bits of sub-pixel precision the rasteriser snaps vertex positions to
    /// (`subPixelPrecisionBits`, at least 4): a fragment's interpolated attributes belong to a
    /// point up to half a 2^-bits pixel step away from its pixel's centre ray.
    pub sub_pixel_precision_bits: u32,
    /// Whether compute shaders have the subgroup operations the tiled density estimator uses
    /// (basic, vote, arithmetic, ballot, shuffle: `passes/photon_tiles.rs`).
    pub compute_subgroup_gather: bool,
}

impl Gpu {
    /// Creates the instance and device. Validation is on when `options.validation` is set or
    /// `ISPM_VALIDATION=1`.
    pub fn new(options: &GpuOptions) -> anyhow::Result<Arc<Gpu>> {
        let validation = options.validation || super::instance::validation_requested();
        // Every `?` below drops what was created so far: `parts` tears down the instance,
        // `guard` the device and its semaphores.
        let surface_extensions: Vec<&CStr> = match options.display {
            Some(display) => ash_window::enumerate_required_extensions(display)
                .map_err(vk_err("the window system's surface extensions"))?
                .iter()
                // SAFETY: ash-window returns pointers to its static, NUL-terminated names.
                .map(|&p| unsafe { CStr::from_ptr(p) })
                .collect(),
            None => Vec::new(),
        };
        let sync_validation = validation && !options.without_sync_validation;
        let parts = create_instance((validation, sync_validation), &surface_extensions)?;
        let instance = &parts.instance;
        let (physical, properties) = choose_device(instance, options.device_index)?;

        let families = &properties.families;
        let graphics_family = families
            .iter()
            .position(|f| {
                f.queue_flags
                    .contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE)
            })
            .ok_or_else(|| GpuError::NoSuitableDevice("no graphics+compute queue family".into()))?
            as u32;
        let dedicated = |want: vk::QueueFlags, not: vk::QueueFlags| {
            families
                .iter()
                .position(|f| f.queue_flags.contains(want) && !f.queue_flags.intersects(not))
                .map(|i| i as u32)
        };
        let (compute_family, transfer_family) = if options.queues != QueueMode::Auto {
            (graphics_family, graphics_family)
        } else {
            let compute = dedicated(vk::QueueFlags::COMPUTE, vk::QueueFlags::GRAPHICS)
                .unwrap_or(graphics_family);
            let transfer = dedicated(
                vk::QueueFlags::TRANSFER,
                vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE,
            )
            .unwrap_or(graphics_family);
            (compute, transfer)
        };
        let mut distinct: Vec<u32> = vec![graphics_family];
        for f in [compute_family, transfer_family] {
            if !distinct.contains(&f) {
                distinct.push(f);
            }
        }
        let priorities = [1.0f32];
        let queue_infos: Vec<_> = distinct
            .iter()
            .map(|&f| {
                vk::DeviceQueueCreateInfo::default()
                    .queue_family_index(f)
                    .queue_priorities(&priorities)
            })
            .collect();

        let mut f12 = vk::PhysicalDeviceVulkan12Features::default()
            .timeline_semaphore(true)
            .host_query_reset(true)
            .scalar_block_layout(true)
            .separate_depth_stencil_layouts(true);
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
            .synchronization2(true)
            .dynamic_rendering(true)
            .maintenance4(true);
        let mut extensions: Vec<&CStr> = Vec::new();
        let calibration = if options.measured_clock {
            None
        } else {
            calibration_choice(&parts.entry, instance, physical)
        };
        if let Some(c) = calibration {
            extensions.push(c.extension);
        }
        if options.display.is_some() {
            extensions.push(ash::khr::swapchain::NAME);
        }
        let extension_ptrs: Vec<_> = extensions.iter().map(|e| e.as_ptr()).collect();
        let features = vk::PhysicalDeviceFeatures::default().fragment_stores_and_atomics(true);
        let info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_infos)
            .enabled_extension_names(&extension_ptrs)
            .enabled_features(&features)
            .push_next(&mut f12)
            .push_next(&mut f13);
        // SAFETY: `physical` came from this instance; every pointer in `info` refers to locals
        // alive for the call; the requested features were checked in `choose_device`.
        let device = unsafe { instance.create_device(physical, &info, None) }
            .map_err(vk_err("vkCreateDevice"))?;
        let mut guard = DeviceGuard {
            device: Some(device),
            semaphores: Vec::new(),
        };
        let device = guard.device().clone();
        let debug_utils = ash::ext::debug_utils::Device::new(instance, &device);
        let clock = DeviceClock::new(instance, &device, calibration);

        let create_timeline = |guard: &mut DeviceGuard| -> anyhow::Result<vk::Semaphore> {
            let mut type_info = vk::SemaphoreTypeCreateInfo::default()
                .semaphore_type(vk::SemaphoreType::TIMELINE)
                .initial_value(0);
            let sem_info = vk::SemaphoreCreateInfo::default().push_next(&mut type_info);
            // SAFETY: the device is live; timeline semaphores were enabled above.
            let timeline = unsafe { device.create_semaphore(&sem_info, None) }
                .map_err(vk_err("vkCreateSemaphore"))?;
            guard.semaphores.push(timeline);
            Ok(timeline)
        };
        let mut queues = Vec::new();
        for &family in &distinct {
            let timeline = create_timeline(&mut guard)?;
            // SAFETY: one queue of this family was requested at device creation.
            let raw = unsafe { device.get_device_queue(family, 0) };
            let props = &families[family as usize];
            queues.push(Queue {
                raw: Arc::new(Mutex::new(raw)),
                family,
                flags: props.queue_flags,
                timestamp_valid_bits: props.timestamp_valid_bits,
                timeline,
                submitted: AtomicU64::new(0),
            });
        }
        let role_index = |f: u32| distinct.iter().position(|&d| d == f).unwrap_or(0);
        let mut roles = [
            role_index(graphics_family),
            role_index(compute_family),
            role_index(transfer_family),
        ];
        if options.queues == QueueMode::SplitTransfer {
            let timeline = create_timeline(&mut guard)?;
            let graphics = &queues[roles[QueueRole::Graphics as usize]];
            let logical = Queue {
                raw: graphics.raw.clone(),
                family: graphics.family,
                flags: graphics.flags,
                timestamp_valid_bits: graphics.timestamp_valid_bits,
                timeline,
                submitted: AtomicU64::new(0),
            };
            queues.push(logical);
            roles[QueueRole::Transfer as usize] = queues.len() - 1;
        }

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .map_err(|source| GpuError::Allocation {
            name: "allocator".into(),
            source,
        })?;

        let device = guard.disarm();
        let gpu = Arc::new(Gpu {
            debug_utils,
            device,
            properties,
            queues,
            roles,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            graveyard: Mutex::new(Vec::new()),
            clock,
            validation,
            physical,
            instance: parts,
        });
        for (i, q) in gpu.queues.iter().enumerate() {
            gpu.set_name(
                q.timeline,
                &format!("timeline[queue {i}, family {}]", q.family),
            );
        }
        if gpu.clock_source() == ClockSource::MeasuredOffset {
            // Measured now, while the device is idle and the bracket tight.
            if let Err(e) = gpu.clock_calibration() {
                log::warn!("cannot measure the GPU clock offset: {e}");
            }
        }
        Ok(gpu)
    }

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

    /// Hands `object` to the graveyard; it is destroyed once every queue has finished the work
    /// submitted so far.
    pub(super) fn retire(&self, object: Retired) {
        let marks = self.queues.iter().map(Queue::last_submitted).collect();
        if let Ok(mut g) = self.graveyard.lock() {
            g.push((marks, object));
        }
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

    /// Destroys retired objects whose last possible use has completed.
    pub fn collect_garbage(&self) {
        let done: Vec<u64> = (0..self.queues.len()).map(|q| self.completed(q)).collect();
        let ready: Vec<Retired> = {
            let Ok(mut g) = self.graveyard.lock() else {
                return;
            };
            let (ready, waiting): (Vec<_>, Vec<_>) = std::mem::take(&mut *g)
                .into_iter()
                .partition(|(marks, _)| marks.iter().zip(&done).all(|(m, d)| d >= m));
            *g = waiting;
            ready.into_iter().map(|(_, o)| o).collect()
        };
        for object in ready {
            self.destroy(object);
        }
    }

    fn destroy(&self, object: Retired) {
        let d = &self.device;
        // SAFETY (all arms): the object belongs to this device and the GPU has finished every
        // submission that could use it (collect_garbage checked the timelines, or Drop waited
        // for the device to go idle).
        unsafe {
            match object {
                Retired::Buffer(b, a) => {
                    let _ = self.allocator().free(a);
                    d.destroy_buffer(b, None);
                }
                Retired::Image(i, a, views) => {
                    for v in views {
                        d.destroy_image_view(v, None);
                    }
                    let _ = self.allocator().free(a);
                    d.destroy_image(i, None);
                }
                Retired::Sampler(s) => d.destroy_sampler(s, None),
                Retired::Pipeline(p, l) => {
                    d.destroy_pipeline(p, None);
                    d.destroy_pipeline_layout(l, None);
                }
                Retired::DescriptorPool(p) => d.destroy_descriptor_pool(p, None),
                Retired::DescriptorSetLayout(l) => d.destroy_descriptor_set_layout(l, None),
                Retired::CommandPool(p) => d.destroy_command_pool(p, None),
                Retired::QueryPool(p) => d.destroy_query_pool(p, None),
            }
        }
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

impl Drop for Gpu {
    fn drop(&mut self) {
        let _ = self.wait_idle();
        let all: Vec<_> = self
            .graveyard
            .get_mut()
            .map(std::mem::take)
            .unwrap_or_default();
        for (_, object) in all {
            self.destroy(object);
        }
        // SAFETY: the device is idle and every resource was destroyed above (resources hold
        // an Arc<Gpu>, so none outlive it). The allocator is dropped before the device; the
        // instance (the `instance` field) is destroyed after this body, when fields drop.
        unsafe {
            ManuallyDrop::drop(&mut self.allocator);
            for q in &self.queues {
                self.device.destroy_semaphore(q.timeline, None);
            }
            self.device.destroy_device(None);
        }
    }
}

/// The order devices are preferred in (lower first) when none is named.
pub fn device_type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

/// Picks the physical device: the requested index, else the best-ranked suitable one.
fn choose_device(
    instance: &ash::Instance,
    index: Option<usize>,
) -> GpuResult<(vk::PhysicalDevice, DeviceProperties)> {
    // SAFETY: the instance is live.
    let devices = unsafe { instance.enumerate_physical_devices() }
        .map_err(vk_err("vkEnumeratePhysicalDevices"))?;
    if let Some(i) = index {
        let &pd = devices.get(i).ok_or(GpuError::DeviceIndex {
            index: i,
            count: devices.len(),
        })?;
        let props = describe(instance, pd);
        check_suitable(instance, pd, &props)
            .map_err(|why| GpuError::NoSuitableDevice(format!("{}: {why}", props.name)))?;
        return Ok((pd, props));
    }
    let mut reasons = Vec::new();
    let mut candidates: Vec<_> = devices
        .into_iter()
        .map(|pd| (pd, describe(instance, pd)))
        .filter(|(pd, props)| match check_suitable(instance, *pd, props) {
            Ok(()) => true,
            Err(why) => {
                reasons.push(format!("{}: {why}", props.name));
                false
            }
        })
        .collect();
    candidates.sort_by_key(|(_, p)| device_type_rank(p.device_type));
    candidates.into_iter().next().ok_or_else(|| {
        if reasons.is_empty() {
            GpuError::NoSuitableDevice(
                "no Vulkan devices found (on a machine without a GPU install mesa-vulkan-drivers \
                 for lavapipe)"
                    .into(),
            )
        } else {
            GpuError::NoSuitableDevice(reasons.join("; "))
        }
    })
}

fn describe(instance: &ash::Instance, pd: vk::PhysicalDevice) -> DeviceProperties {
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default()
        .push_next(&mut driver)
        .push_next(&mut subgroup);
    // SAFETY: pd came from this instance; props2 chains only structs alive for the call.
    unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
    let p = props2.properties;
    // SAFETY: pd came from this instance.
    let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
    // SAFETY: pd came from this instance.
    let extensions =
        unsafe { instance.enumerate_device_extension_properties(pd) }.unwrap_or_default();
    let has = |name: &CStr| {
        extensions
            .iter()
            .any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == name))
    };
    let text = |s: Result<&CStr, _>| {
        s.map(|c: &CStr| c.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    DeviceProperties {
        name: text(p.device_name_as_c_str()),
        device_type: p.device_type,
        api_version: p.api_version,
        driver_name: text(driver.driver_name_as_c_str()),
        driver_info: text(driver.driver_info_as_c_str()),
        timestamp_period: p.limits.timestamp_period,
        max_storage_buffer_range: p.limits.max_storage_buffer_range,
        sub_pixel_precision_bits: p.limits.sub_pixel_precision_bits,
        families,
        calibrated_timestamps: has(ash::ext::calibrated_timestamps::NAME)
            || has(ash::khr::calibrated_timestamps::NAME),
        compute_subgroup_gather: subgroup
            .supported_stages
            .contains(vk::ShaderStageFlags::COMPUTE)
            && subgroup.supported_operations.contains(
                vk::SubgroupFeatureFlags::BASIC
                    | vk::SubgroupFeatureFlags::VOTE
                    | vk::SubgroupFeatureFlags::ARITHMETIC
                    | vk::SubgroupFeatureFlags::BALLOT
                    | vk::SubgroupFeatureFlags::SHUFFLE,
            ),
    }
}

fn check_suitable(
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
    props: &DeviceProperties,
) -> Result<(), String> {
    if props.api_version < vk::API_VERSION_1_3 {
        return Err(format!(
            "Vulkan {}.{} < 1.3",
            vk::api_version_major(props.api_version),
            vk::api_version_minor(props.api_version)
        ));
    }
    let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
    let base = {
        let mut f2 = vk::PhysicalDeviceFeatures2::default()
            .push_next(&mut f12)
            .push_next(&mut f13);
        // SAFETY: pd came from this instance; f2 chains only structs alive for the call.
        unsafe { instance.get_physical_device_features2(pd, &mut f2) };
        f2.features
    };
    let missing: Vec<&str> = [
        (f13.synchronization2, "synchronization2"),
        (f13.dynamic_rendering, "dynamicRendering"),
        (f13.maintenance4, "maintenance4"),
        (f12.timeline_semaphore, "timelineSemaphore"),
        (f12.host_query_reset, "hostQueryReset"),
        (f12.scalar_block_layout, "scalarBlockLayout"),
        (
            f12.separate_depth_stencil_layouts,
            "separateDepthStencilLayouts",
        ),
        (base.fragment_stores_and_atomics, "fragmentStoresAndAtomics"),
    ]
    .into_iter()
    .filter(|(on, _)| *on == vk::FALSE)
    .map(|(_, n)| n)
    .collect();
    if missing.is_empty() {
        Ok(())
    } else {
        Err(format!("missing features: {}", missing.join(", ")))
    }
}

/// Lists every physical device (for `ispm info`), without creating a logical device.
pub fn list_devices() -> anyhow::Result<Vec<(DeviceProperties, Result<(), String>)>> {
    let parts = create_instance((false, false), &[])?;
    // SAFETY: the instance is live.
    let devices = unsafe { parts.instance.enumerate_physical_devices() }
        .map_err(vk_err("vkEnumeratePhysicalDevices"));
    let out = devices.map(|devices| {
        devices
            .into_iter()
            .map(|pd| {
                let p = describe(&parts.instance, pd);
                let ok = check_suitable(&parts.instance, pd, &p);
                (p, ok)
            })
            .collect()
    });
    Ok(out?)
}
