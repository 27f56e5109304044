//! Which physical device the [`Gpu`](super::Gpu) uses: what each offers
//! ([`DeviceProperties`]), whether it has what the renderer needs, and the preference order
//! (module docs of [`crate::gpu::device`], "Device choice"); `ispm info`'s list.

use crate::gpu::error::{vk_err, GpuError, GpuResult};
use crate::gpu::instance::create_instance;
use ash::vk;
use std::ffi::CStr;

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
    /// Most workgroups one compute dispatch may have along x (`maxComputeWorkGroupCount[0]`,
    /// at least 65 535).
    pub max_compute_work_group_count_x: u32,
    /// Bits of sub-pixel precision the rasteriser snaps vertex positions to
    /// (`subPixelPrecisionBits`, at least 4): a fragment's interpolated attributes belong to a
    /// point up to half a 2^-bits pixel step away from its pixel's centre ray.
    pub sub_pixel_precision_bits: u32,
    /// Whether compute shaders have the subgroup operations the tiled density estimator uses
    /// (basic, vote, arithmetic, ballot, shuffle: `passes/photon_tiles.rs`).
    pub compute_subgroup_gather: bool,
}

impl DeviceProperties {
    /// Whether the device runs on the host's own cores (lavapipe): its "GPU" work and the
    /// host's threads then share the same cores.
    pub fn is_cpu(&self) -> bool {
        self.device_type == vk::PhysicalDeviceType::CPU
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
pub(super) fn choose_device(
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
        max_compute_work_group_count_x: p.limits.max_compute_work_group_count[0],
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
