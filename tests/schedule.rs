//! The frame schedule (`src/render/frame.rs`): frames in flight with a moving light stay
//! validation-clean (synchronization validation included) and end on the image a serial render
//! of the same frame gives; the logical transfer queue (the multi-queue path on a one-queue
//! device) renders the same image as the single queue.

mod common;

use ispm::config::settings::Effects;
use ispm::config::settings::{Method, RenderSettings, Schedule};
use ispm::gpu::{Gpu, GpuOptions, QueueMode, QueueRole};
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::{bundled, Light, Scene};
use std::sync::{Arc, Mutex, MutexGuard};

/// The tests of this file run one at a time: the trace capture is process-wide, and another
/// test's frames would land in it.
fn exclusive() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

fn settings(schedule: Schedule) -> RenderSettings {
    RenderSettings {
        method: Method::Ispm,
        photons: 3_000,
        width: 48,
        height: 48,
        shadow_resolution: 64,
        schedule,
        ..Default::default()
    }
}

fn gpu(queues: QueueMode) -> Arc<Gpu> {
    Gpu::new(&GpuOptions {
        validation: true,
        queues,
        ..Default::default()
    })
    .expect("a Vulkan 1.3 device with the validation layer")
}

/// The scene's lights with the first one moved along a small circle (frame `i` of `n`).
fn orbit(scene: &Scene, i: usize, n: usize) -> Vec<Light> {
    let mut lights = scene.lights.clone();
    let angle = std::f32::consts::TAU * i as f32 / n as f32;
    let size = scene.bounds().extent().length();
    lights[0].position += glam::Vec3::new(angle.cos(), 0.0, angle.sin()) * (0.05 * size);
    lights
}

fn bits(frame: &FrameImage) -> Vec<u32> {
    frame.hdr.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn moving_light_frames_in_flight_stay_validation_clean_and_match_a_serial_render() {
    let _one_at_a_time = exclusive();
    let scene = bundled::resolve(Some("cornell-box")).expect("scene");
    const FRAMES: usize = 100;
    // The logical transfer queue: readbacks and uploads are separate submissions on their own
    // timeline, with cross-queue waits (the single-queue path runs in every other test).
    let gpu = gpu(QueueMode::SplitTransfer);
    let mut renderer = Renderer::new(&gpu, &scene, settings(Schedule::Overlapped)).expect("new");
    for i in 0..FRAMES - 1 {
        renderer
            .set_lights(&orbit(&scene, i, FRAMES))
            .expect("move");
        renderer.submit_frame().expect("frame");
    }
    let last_lights = orbit(&scene, FRAMES - 1, FRAMES);
    renderer.set_lights(&last_lights).expect("move");
    let overlapped = renderer.render().expect("last frame");
    common::assert_validation_clean(&gpu);
    assert!(overlapped.stats.stored_photons > 0);

    let mut moved = scene.clone();
    moved.lights = last_lights;
    let serial = Renderer::new(&gpu, &moved, settings(Schedule::Serial))
        .expect("new")
        .render()
        .expect("serial");
    common::assert_validation_clean(&gpu);
    assert_eq!(overlapped.stats.stored_photons, serial.stats.stored_photons);
    assert!(
        bits(&overlapped) == bits(&serial),
        "the 100th overlapped frame differs from a serial render of the same lights"
    );
    // The light really moved: frame 0's image is another one.
    let mut first = scene.clone();
    first.lights = orbit(&scene, 0, FRAMES);
    let frame0 = Renderer::new(&gpu, &first, settings(Schedule::Serial))
        .expect("new")
        .render()
        .expect("frame 0");
    assert!(bits(&frame0) != bits(&serial), "the light did not move");
}

#[test]
fn logical_transfer_queue_renders_what_the_single_queue_renders() {
    let _one_at_a_time = exclusive();
    let scene = bundled::resolve(Some("glass-sphere")).expect("scene");
    let mut images = Vec::new();
    for mode in [QueueMode::Single, QueueMode::SplitTransfer] {
        let gpu = gpu(mode);
        let split = gpu.queue_index(QueueRole::Transfer) != gpu.queue_index(QueueRole::Graphics);
        assert_eq!(split, mode == QueueMode::SplitTransfer, "{mode:?}");
        // Every frame traces and uploads (a planned frame would reuse the static photon map).
        let all = RenderSettings {
            effects: Effects::All,
            ..settings(Schedule::Overlapped)
        };
        let mut renderer = Renderer::new(&gpu, &scene, all).expect("renderer");
        for _ in 0..3 {
            renderer.submit_frame().expect("frame");
        }
        let frame = renderer.render().expect("render");
        common::assert_validation_clean(&gpu);
        assert!(frame.stats.stored_photons > 0, "{mode:?}: no photons");
        let names: Vec<&str> = frame.gpu_spans.iter().map(|s| s.name.as_str()).collect();
        for pass in ["readback", "upload", common::estimator_pass()] {
            assert!(names.contains(&pass), "{mode:?}: no {pass} in {names:?}");
        }
        images.push(bits(&frame));
    }
    assert!(
        images[0] == images[1],
        "the logical transfer queue changed the image"
    );
}

#[test]
fn renderer_refuses_lights_it_was_not_made_for() {
    let _one_at_a_time = exclusive();
    let scene = bundled::resolve(Some("cornell-box")).expect("scene");
    let gpu = common::gpu();
    let mut renderer = Renderer::new(&gpu, &scene, settings(Schedule::Overlapped)).expect("new");
    let err = renderer.set_lights(&scene.lights[..1]).unwrap_err();
    assert!(err.to_string().contains("lights given"), "{err}");
    common::assert_validation_clean(&gpu);
}

/// One capture (the only one in this process) of `frames` frames of the Cornell box.
fn captured_frames(schedule: Schedule, frames: u64) -> Vec<ispm::timing::Span> {
    let scene = bundled::resolve(Some("cornell-box")).expect("scene");
    let gpu = common::gpu();
    let settings = RenderSettings {
        photons: 20_000,
        width: 192,
        height: 192,
        shadow_resolution: 512,
        schedule,
        // Every frame traces (a planned frame would reuse the static photon map).
        effects: Effects::All,
        ..Default::default()
    };
    let mut renderer = Renderer::new(&gpu, &scene, settings).expect("renderer");
    ispm::timing::start_capture();
    let rendered = (0..frames).try_for_each(|_| renderer.submit_frame());
    let last = renderer.finish();
    let capture = ispm::timing::finish_capture();
    rendered.expect("frames");
    last.expect("last frame");
    common::assert_validation_clean(&gpu);
    capture.spans
}

/// Whether `a` and `b` overlap in time.
fn overlap(a: &ispm::timing::Span, b: &ispm::timing::Span) -> bool {
    a.begin_ns < b.end_ns && b.begin_ns < a.end_ns
}

/// A box B at least this long (GPU time) overlaps the trace in a schedule that does not wait for
/// it: the host starts the trace within a fraction of a millisecond of box B's submission.
const BOX_B_LONG_MS: f64 = 2.0;

/// The paper's Figure 3: in the overlapped schedule the CPU trace of a frame runs while the GPU
/// draws (lavapipe's GPU work runs on its own threads); in the serial one nothing on the GPU
/// runs during any CPU trace. The default (`auto`) overlaps them only where the device does
/// not run on the host's cores: on a CPU device (lavapipe) the trace waits for box B, and the
/// trace says so with a `box B wait: CPU device` span per traced frame. Frame 0 (cold caches)
/// is left out. On a GPU that finishes box B before the host has its bounce map back there is
/// nothing to overlap: the overlap is required only of a box B that takes `BOX_B_LONG_MS`.
#[test]
fn cpu_trace_overlaps_gpu_work_only_where_the_schedule_lets_it() {
    let _one_at_a_time = exclusive();
    const FRAMES: u64 = 4;
    let cpu_device = common::gpu().properties.is_cpu();
    for schedule in [Schedule::Overlapped, Schedule::Serial, Schedule::Auto] {
        let spans = captured_frames(schedule, FRAMES);
        let gpu: Vec<_> = spans.iter().filter(|s| s.is_gpu()).collect();
        let traces: Vec<_> = spans
            .iter()
            .filter(|s| !s.is_gpu() && s.name == "cpu_trace")
            .collect();
        assert_eq!(traces.len(), FRAMES as usize, "{schedule:?}");
        let beside = schedule.trace_beside_box_b(cpu_device);
        let waits = spans
            .iter()
            .filter(|s| !s.is_gpu() && s.name == "box B wait: CPU device")
            .count();
        let expected_waits = if beside || schedule == Schedule::Serial {
            0
        } else {
            FRAMES as usize
        };
        assert_eq!(waits, expected_waits, "{schedule:?}: box B waits");
        for t in traces.iter().filter(|t| t.frame != Some(0)) {
            let during: Vec<&str> = gpu
                .iter()
                .filter(|g| overlap(g, t) && g.depth == 0)
                .map(|g| g.name.as_str())
                .collect();
            // Box B's length on the GPU this frame: on a fast GPU (an H100 draws it in a
            // fraction of a millisecond at this size) it may end before the host has its
            // bounce map back, with nothing left to overlap. Only a box B long enough that the
            // trace cannot have started after it without waiting for it must overlap the trace.
            let box_b: Vec<_> = (gpu.iter())
                .filter(|g| g.frame == t.frame && g.depth == 0)
                .filter(|g| ["shadow_maps", "eye_gbuffer", "direct"].contains(&g.name.as_str()))
                .collect();
            let begin = box_b.iter().map(|g| g.begin_ns).min().unwrap_or(0);
            let end = box_b.iter().map(|g| g.end_ns).max().unwrap_or(0);
            let box_b_ms = end.saturating_sub(begin) as f64 * 1e-6;
            if beside && box_b_ms >= BOX_B_LONG_MS {
                assert!(
                    !during.is_empty(),
                    "{schedule:?} frame {:?}: no GPU pass ran during the CPU trace, though box \
                     B took {box_b_ms:.2} ms",
                    t.frame
                );
            } else if beside {
                eprintln!(
                    "{schedule:?} frame {:?}: box B took {box_b_ms:.3} ms, too short to need \
                     overlapping the trace",
                    t.frame
                );
            } else {
                assert!(
                    during.is_empty(),
                    "{schedule:?} frame {:?}: yet {during:?} ran during the CPU trace",
                    t.frame
                );
            }
            eprintln!(
                "{schedule:?} frame {:?}: during the trace: {during:?}",
                t.frame
            );
        }
    }
}

/// Which schedules run the trace beside box B, by device type.
#[test]
fn the_default_schedule_keeps_the_trace_off_a_cpu_devices_cores() {
    // (schedule, the device runs on the host's cores, the trace runs beside box B)
    for (schedule, cpu_device, beside) in [
        (Schedule::Auto, true, false),
        (Schedule::Auto, false, true),
        (Schedule::Overlapped, true, true),
        (Schedule::Overlapped, false, true),
        (Schedule::Serial, true, false),
        (Schedule::Serial, false, false),
    ] {
        assert_eq!(
            schedule.trace_beside_box_b(cpu_device),
            beside,
            "{schedule:?}, CPU device {cpu_device}"
        );
    }
    assert_eq!(Schedule::default(), Schedule::Auto);
}

/// Lights going dark and coming back between frames in flight: the dark frames draw no photons
/// (the photon buffer's queue hand-offs stay paired) and the lit ones after them are the same
/// as before.
#[test]
fn lights_going_dark_and_back_between_frames_stay_validation_clean() {
    let _one_at_a_time = exclusive();
    let scene = bundled::resolve(Some("glass-sphere")).expect("scene");
    let gpu = common::gpu();
    let mut renderer = Renderer::new(&gpu, &scene, settings(Schedule::Overlapped)).expect("new");
    let lit = renderer.render().expect("lit");
    let mut dark = scene.lights.clone();
    for l in &mut dark {
        l.intensity = glam::Vec3::ZERO;
    }
    renderer.set_lights(&dark).expect("dark");
    renderer.submit_frame().expect("dark frame");
    let black = renderer.render().expect("dark frame");
    assert_eq!(black.stats.stored_photons, 0);
    renderer.set_lights(&scene.lights).expect("lit again");
    renderer.submit_frame().expect("lit frame");
    let again = renderer.render().expect("lit frame");
    common::assert_validation_clean(&gpu);
    assert!(
        bits(&lit) == bits(&again),
        "the relit frame differs from the first"
    );
}
