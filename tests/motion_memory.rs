//! The process's memory stays flat over 1000 frames of a moving scene (an animated glTF whose
//! instance and light move, its lights orbiting as well): every frame re-plans, moves the BVH,
//! re-traces and uploads photons, and nothing of it may accumulate. Alone in its test binary,
//! so that the resident set is this test's only.
//!
//! The validation layer runs without its synchronization part here: layer 1.3.239's
//! synchronization validation never retires submissions that complete through timeline
//! semaphores (the renderer's only completion signal), so the layer's own memory grows by about
//! 15 kB per frame even for a static scene, which would hide the renderer's. Synchronization
//! validation of moving frames is in `tests/motion.rs` and `tests/schedule.rs`.

mod common;

use common::animated::glass_on_a_carousel;
use ispm::config::settings::RenderSettings;
use ispm::gpu::{Gpu, GpuOptions};
use ispm::render::frame::Renderer;
use ispm::scene::load::load_from_slice;
use ispm::scene::FRAME_STEP_SECONDS;

/// The process's resident set size in KiB (`VmRSS` of /proc/self/status).
fn rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status");
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .expect("VmRSS")
}

#[test]
fn process_memory_stays_flat_over_1000_frames_of_a_moving_scene() {
    let gpu = Gpu::new(&GpuOptions {
        validation: true,
        without_sync_validation: true,
        ..Default::default()
    })
    .expect("a Vulkan 1.3 device with the validation layer");
    let mut scene =
        load_from_slice(&glass_on_a_carousel().glb, "carousel.glb", None).expect("scene");
    scene.orbit_lights(3.0).expect("orbit");
    let settings = RenderSettings {
        photons: 500,
        width: 32,
        height: 32,
        shadow_resolution: 64,
        ..Default::default()
    };
    let mut renderer = Renderer::new(&gpu, &scene, settings).expect("renderer");
    const WARM_UP: usize = 100;
    const FRAMES: usize = 1000;
    let mut samples = Vec::new();
    let mut warm = 0;
    let pose = |i: usize| scene.pose_at(i as f32 * FRAME_STEP_SECONDS);
    for i in 0..FRAMES - 1 {
        renderer.set_pose(&pose(i)).expect("pose");
        renderer.submit_frame().expect("frame");
        if i + 1 == WARM_UP {
            renderer.drain().expect("drain");
            warm = rss_kib();
        }
        if (i + 1) % 100 == 0 {
            samples.push(rss_kib());
        }
    }
    renderer.set_pose(&pose(FRAMES - 1)).expect("pose");
    let last = renderer.render().expect("last frame");
    let end = rss_kib();
    common::assert_validation_clean(&gpu);
    assert!(last.stats.cpu_trace_ms > 0.0 && last.stats.stored_photons > 0);
    let growth = (end as f64 - warm as f64) / warm as f64;
    println!(
        "VmRSS after {WARM_UP} frames {warm} KiB, every 100 frames {samples:?} KiB, after \
         {FRAMES}: {end} KiB ({:+.2} %)",
        growth * 100.0
    );
    assert!(
        growth < 0.02,
        "resident memory grew {:.2} % from frame {WARM_UP} to frame {FRAMES}",
        growth * 100.0
    );
}
