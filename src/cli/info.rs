//! `ispm info`: the Vulkan devices, the driver and the queues the renderer uses.

use super::{check_validation, gpu};
use anyhow::Context;

pub fn info(device: Option<usize>) -> anyhow::Result<()> {
    let devices = ispm::gpu::list_devices().context("cannot start Vulkan")?;
    println!("Vulkan devices:");
    for (i, (p, ok)) in devices.iter().enumerate() {
        let v = p.api_version;
        println!(
            "  [{i}] {} ({:?}), Vulkan {}.{}.{}, driver {} {}{}",
            p.name,
            p.device_type,
            ispm::gpu::vk::api_version_major(v),
            ispm::gpu::vk::api_version_minor(v),
            ispm::gpu::vk::api_version_patch(v),
            p.driver_name,
            p.driver_info,
            match ok {
                Ok(()) => String::new(),
                Err(why) => format!(" — unusable: {why}"),
            }
        );
        for (f, q) in p.families.iter().enumerate() {
            println!(
                "      queue family {f}: {} queue(s), {:?}, timestamp bits {}",
                q.queue_count, q.queue_flags, q.timestamp_valid_bits
            );
        }
    }
    let gpu = gpu(device)?;
    let p = &gpu.properties;
    println!("Using: {} ({})", p.name, p.driver_name);
    for role in ispm::gpu::QueueRole::ALL {
        let q = gpu.queue(role);
        println!(
            "  {:>8}: queue family {} (queue {} of the renderer's {})",
            role.name(),
            q.family,
            gpu.queue_index(role),
            gpu.queue_list().len()
        );
    }
    println!(
        "  timestamps: {} ns/tick, on the host clock by {}",
        p.timestamp_period,
        gpu.clock_source()
    );
    let density = ispm::config::settings::Density::Auto.resolve_for_device(p);
    println!(
        "  --density auto: {density:?}, compute subgroup ops for the tiled gather: {} (measured \
         on lavapipe and an NVIDIA H100, docs/performance.md \"Density estimators\")",
        if p.compute_subgroup_gather {
            "yes"
        } else {
            "no"
        }
    );
    println!(
        "  validation: {}",
        if gpu.validation {
            "on"
        } else {
            "off (ISPM_VALIDATION=1 turns it on)"
        }
    );
    check_validation(&gpu)
}
