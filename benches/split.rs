//! The bounce map and photon map split over several buffers (issue #8, hard case "more photons
//! than fit in one buffer"): the frame time with each map in one buffer against the same maps
//! split over many, in the same run, on the same settings. `cargo bench --bench split` (the
//! Vulkan device the renderer picks: set `VK_DRIVER_FILES` for lavapipe); results in
//! `docs/performance.md`.
//!
//! Scene: the bundled Cornell box at 64×64 with 1 000 000 photons (1.25 M bounce-map records,
//! 40 MB; about 1.9 M stored photons, 93 MB) and `--effects all`, so that every frame draws the
//! light G-buffers, makes, checks nothing of, and reads back the whole bounce map, traces and
//! uploads every photon. Split: `RenderSettings::storage_buffer_range` = 2 MiB, about 20
//! bounce-map buffers and 45 photon buffers. After each benchmark the medians of the stages
//! the split touches are printed.

use divan::Bencher;
use ispm::config::settings::Effects;
use ispm::config::settings::{Method, RenderSettings};
use ispm::gpu::{Gpu, GpuOptions};
use ispm::render::frame::Renderer;
use ispm::timing::pass_id::PassId;

fn main() {
    divan::main();
}

/// Renders frames of the Cornell box with buffers bound with at most `range` bytes.
fn frames(bencher: Bencher, range: Option<u64>) {
    let gpu = Gpu::new(&GpuOptions::default()).expect("a Vulkan 1.3 device");
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("bundled scene");
    let settings = RenderSettings {
        method: Method::Ispm,
        photons: 1_000_000,
        width: 64,
        height: 64,
        shadow_resolution: 256,
        effects: Effects::All,
        storage_buffer_range: range,
        ..Default::default()
    };
    let mut r = Renderer::new(&gpu, &scene, settings).expect("renderer");
    let first = r.render().expect("first frame");
    let buffers = (first.stats.bounce_map_buffers, first.stats.photon_buffers);
    let mut stages: Vec<[f64; 5]> = Vec::new();
    bencher.bench_local(|| {
        let frame = r.render().expect("frame");
        stages.push([
            frame.stats.frame_ms,
            frame.gpu_ms(PassId::BounceMap),
            frame.gpu_ms(PassId::Readback),
            frame.gpu_ms(PassId::Upload),
            frame.gpu_ms(PassId::PhotonVolumes),
        ]);
    });
    let median = |k: usize| {
        let v: Vec<f64> = stages.iter().map(|s| s[k]).collect();
        ispm::tools::bench::quantile(&v, 0.5)
    };
    println!(
        "(bounce map, photon map) in {buffers:?} buffers: median frame {:.1} ms, bounce_map \
         {:.2} ms, readback {:.2} ms, upload {:.2} ms, photon_volumes {:.1} ms ({} frames)",
        median(0),
        median(1),
        median(2),
        median(3),
        median(4),
        stages.len()
    );
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn one_buffer_each(bencher: Bencher) {
    frames(bencher, None);
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn split_over_buffers_of_2_mib(bencher: Bencher) {
    frames(bencher, Some(2 << 20));
}
