//! Shared helpers of the GPU integration tests: a validation-enabled device, and images written
//! next to a failing assertion so a person can look at them.
#![allow(dead_code)]

pub mod animated;
pub mod cli;
pub mod golden;
pub mod hard;

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
