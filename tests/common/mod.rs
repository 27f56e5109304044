//! Shared helpers of the GPU integration tests: a validation-enabled device, and images written
//! next to a failing assertion so a person can look at them.
#![allow(dead_code)]

pub mod animated;
pub mod cli;
pub mod gltf_doc;
pub mod golden;
pub mod hard;

use ispm::config::settings::Effects;
use ispm::config::settings::{Method, RenderSettings};
use ispm::gpu::{Gpu, GpuOptions};
use std::path::PathBuf;
use std::sync::Arc;

/// The passes a frame that reuses the photon map skips (the tests' own statement of it, not
/// the renderer's list).
pub const REUSED_PHOTON_MAP_SKIPS: &[&str] = &[
    "light_gbuffers",
    "bounce_map",
    "readback",
    "cpu_trace",
    "upload",
];

/// The density estimator's pass (GPU scope, stats stage, plan entry) that the default
/// `--density auto` runs on the test device: `photon_tiles` on lavapipe.
pub fn estimator_pass() -> &'static str {
    ispm::config::settings::Density::Auto
        .resolve_for(None)
        .pass()
        .name()
}

/// A device with the validation layer and synchronization validation on (always, in tests).
pub fn gpu() -> Arc<Gpu> {
    Gpu::new(&GpuOptions {
        validation: true,
        ..Default::default()
    })
    .expect("a Vulkan 1.3 device with the validation layer (run through .ci/run or the README)")
}

/// Fails the test when validation reported anything.
pub fn assert_validation_clean(gpu: &Gpu) {
    let messages = gpu.validation_messages();
    assert!(
        messages.is_empty(),
        "{} validation message(s):\n{}",
        messages.len(),
        messages.join("\n")
    );
}

/// Where a test writes images for people to look at: `target/test-images/<test>/`.
pub fn image_dir(test: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("test-images")
        .join(test);
    std::fs::create_dir_all(&dir).expect("create test image dir");
    dir
}

/// The effects tests' frame: ISPM at 64×64, 8 000 photons, 128² shadow maps.
pub fn small_ispm_settings(effects: Effects) -> RenderSettings {
    RenderSettings {
        method: Method::Ispm,
        photons: 8_000,
        width: 64,
        height: 64,
        shadow_resolution: 128,
        effects,
        ..Default::default()
    }
}

/// An IEEE half float (a G-buffer channel read back) as f32.
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((h >> 10) & 0x1f);
    let mant = f32::from(h & 0x3ff);
    match exp {
        0 => sign * mant * 2f32.powi(-24),
        31 => sign * f32::INFINITY,
        e => sign * (1.0 + mant / 1024.0) * 2f32.powi(e - 15),
    }
}
