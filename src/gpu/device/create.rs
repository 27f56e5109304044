//! [`Gpu::new`]: the instance, the physical device's queue families mapped to the roles
//! ([`QueueMode`]), the logical device with the features the renderer needs, one timeline
//! semaphore per queue and the allocator, each torn down again if a later step fails.

use super::choice::choose_device;
use super::{Gpu, GpuOptions, Queue, QueueMode, QueueRole};
use crate::gpu::clock::{calibration_choice, ClockSource, DeviceClock};
use crate::gpu::error::{vk_err, GpuError};
use crate::gpu::instance::create_instance;
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::CStr;
use std::mem::ManuallyDrop;
use std::sync::atomic::AtomicU64;
use std::sync::{Arc, Mutex};

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

impl Gpu {
    /// Creates the instance and device. Validation is on when `options.validation` is set or
    /// `ISPM_VALIDATION=1`.
    pub fn new(options: &GpuOptions) -> anyhow::Result<Arc<Gpu>> {
        let validation = options.validation || crate::gpu::instance::validation_requested();
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
            planned: Mutex::default(),
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
}
