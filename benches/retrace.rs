//! Per-light photon reuse (issue #9): the frame time when one of two lights moves (its photons
//! re-traced, the other's kept) against when both move (every photon re-traced), in the same
//! run, on the same renderer settings. `cargo bench --bench retrace` (the Vulkan device the
//! renderer picks: set `VK_DRIVER_FILES` for lavapipe); results in `docs/performance.md`.
//!
//! Scene: the Cornell box of `reference::scenes::cornell(3)` (a finer sphere than
//! `tests/retrace.rs`' `cornell(1)`) with a second point light of half the first's power (as in
//! the tests), 128×128, 100 000 photons, 256² shadow maps.
//! Each iteration moves the light(s) between two positions and renders one frame, waiting for
//! it: every iteration traces the moved lights again. After each benchmark the medians of the
//! photon stages it re-ran (host trace, GPU light G-buffers, bounce map, readback) are printed.

use divan::Bencher;
use glam::Vec3;
use ispm::config::settings::{Method, RenderSettings};
use ispm::gpu::{Gpu, GpuOptions};
use ispm::reference::scenes::{cornell, point_light};
use ispm::render::frame::Renderer;
use ispm::scene::{Light, Scene};
use ispm::timing::pass_id::PassId;
use std::sync::Arc;

fn main() {
    divan::main();
}

fn scene() -> Scene {
    let mut scene = cornell(3);
    scene
        .lights
        .push(point_light(Vec3::new(-0.5, 0.2, 0.4), Vec3::splat(1.0)));
    scene
}

fn renderer(gpu: &Arc<Gpu>, scene: &Scene) -> Renderer {
    let settings = RenderSettings {
        method: Method::Ispm,
        photons: 100_000,
        width: 128,
        height: 128,
        shadow_resolution: 256,
        ..Default::default()
    };
    Renderer::new(gpu, scene, settings).expect("renderer")
}

/// Renders frames in which the lights `moving` alternate between their place and one 0.1 m
/// away.
fn frames(bencher: Bencher, moving: &[usize]) {
    let gpu = Gpu::new(&GpuOptions::default()).expect("a Vulkan 1.3 device");
    let scene = scene();
    let mut r = renderer(&gpu, &scene);
    r.render().expect("first frame");
    let mut other: Vec<Light> = scene.lights.clone();
    for &l in moving {
        other[l].position += Vec3::new(0.1, 0.0, 0.0);
    }
    let mut flip = false;
    let mut stages: Vec<[f64; 4]> = Vec::new();
    bencher.bench_local(|| {
        flip = !flip;
        let lights = if flip { &other } else { &scene.lights };
        r.set_lights(lights).expect("move");
        let frame = r.render().expect("frame");
        assert_eq!(frame.stats.lights_retraced, moving);
        stages.push([
            frame.stats.cpu_trace_ms,
            frame.gpu_ms(PassId::LightGbuffers),
            frame.gpu_ms(PassId::BounceMap),
            frame.gpu_ms(PassId::Readback),
        ]);
    });
    let median = |k: usize| {
        let v: Vec<f64> = stages.iter().map(|s| s[k]).collect();
        ispm::tools::bench::quantile(&v, 0.5)
    };
    println!(
        "lights {moving:?} moving: median cpu_trace {:.2} ms, light_gbuffers {:.2} ms, \
         bounce_map {:.2} ms, readback {:.2} ms ({} frames)",
        median(0),
        median(1),
        median(2),
        median(3),
        stages.len()
    );
}

#[divan::bench(sample_count = 20, sample_size = 1)]
fn one_of_two_lights_moves(bencher: Bencher) {
    frames(bencher, &[1]);
}

#[divan::bench(sample_count = 20, sample_size = 1)]
fn both_lights_move(bencher: Bencher) {
    frames(bencher, &[0, 1]);
}
