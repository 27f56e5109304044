//! Temporal stability (issue #8, docs/stability.md "Temporal stability"): a static scene
//! renders bit-identical consecutive frames, re-traced every frame (`Effects::All`) and as
//! planned (its photon map reused); a slowly moving light leaves the room it cannot light
//! untouched and changes the image smoothly.
//!
//! The flicker metric of three consecutive indirect images `I(t−1), I(t), I(t+1)`:
//! `F = Σ|I(t+1) − 2·I(t) + I(t−1)| ÷ Σ I(t)` over the pixels and RGB channels. A light moving
//! at a constant slow speed changes the true image about linearly in time, so its second
//! difference is second order in the step; what F measures is the part of the change that
//! comes and goes from frame to frame: noise drawn anew (flicker). Redrawing all of it (three
//! seeds of a static frame) gives the scale F is compared with.

mod common;

use common::hard;
use ispm::config::settings::Effects;
use ispm::config::settings::RenderSettings;
use ispm::render::frame::Renderer;
use ispm::scene::{Light, LightKind, Scene};

const SIZE: u32 = 48;

/// The flicker metric (module docs) of three consecutive RGBA images.
fn flicker(before: &[f32], now: &[f32], after: &[f32]) -> f64 {
    let (mut change, mut total) = (0.0f64, 0.0f64);
    for (i, ((a, b), c)) in before.iter().zip(now).zip(after).enumerate() {
        if i % 4 == 3 {
            continue; // alpha: volumes per pixel
        }
        change += f64::from((c - 2.0 * b + a).abs());
        total += f64::from(b.abs());
    }
    change / total.max(1e-30)
}

fn settings() -> RenderSettings {
    hard::settings(SIZE, SIZE)
}

fn indirect(renderer: &Renderer) -> Vec<f32> {
    renderer
        .photons()
        .expect("ispm")
        .read_indirect()
        .expect("indirect")
}

#[test]
fn a_static_scene_renders_bit_identical_consecutive_frames_traced_again_or_reused() {
    let gpu = common::gpu();
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("bundled");
    for effects in [Effects::All, Effects::Auto] {
        let mut renderer = Renderer::new(
            &gpu,
            &scene,
            RenderSettings {
                effects,
                ..settings()
            },
        )
        .expect("renderer");
        let first = renderer.render().expect("render");
        let first_indirect = indirect(&renderer);
        hard::assert_frame_clean(&first, "static-first");
        for k in 1..3 {
            let frame = renderer.render().expect("render");
            let traced = frame.stats.cpu_trace_ms > 0.0;
            assert_eq!(traced, effects == Effects::All, "{effects:?}, frame {k}");
            assert!(
                frame.hdr == first.hdr,
                "{effects:?}: frame {k}'s image differs"
            );
            assert!(
                indirect(&renderer) == first_indirect,
                "{effects:?}: frame {k}'s indirect light differs"
            );
            assert_eq!(check_total(&frame), 0);
        }
    }
    common::assert_validation_clean(&gpu);
}

fn check_total(frame: &ispm::render::stats::FrameImage) -> u64 {
    frame
        .stats
        .value_check
        .as_ref()
        .expect("checked")
        .total_bad()
}

/// `scene`'s lights `k` frames into a slow motion: point and spot lights 1 mm a frame along +x,
/// directional lights turned 0.03° a frame about +y (1 mm at 2 m).
fn moved(scene: &Scene, k: u32) -> Vec<Light> {
    let turn = glam::Quat::from_rotation_y((0.03f32 * k as f32).to_radians());
    scene
        .lights
        .iter()
        .map(|l| match l.kind {
            LightKind::Directional => Light {
                direction: turn * l.direction,
                ..l.clone()
            },
            _ => Light {
                position: l.position + glam::Vec3::X * (0.001 * k as f32),
                ..l.clone()
            },
        })
        .collect()
}

/// The indirect images of frames 0, 1, 2 of `scene`'s lights in [`moved`]'s motion, and of
/// three seeds of its first frame.
fn moving_and_reseeded(
    gpu: &std::sync::Arc<ispm::gpu::Gpu>,
    scene: &Scene,
) -> (Vec<Vec<f32>>, Vec<Vec<f32>>) {
    let mut renderer = Renderer::new(gpu, scene, settings()).expect("renderer");
    let mut moving = Vec::new();
    for k in 0..3 {
        renderer.set_lights(&moved(scene, k)).expect("lights");
        let frame = renderer.render().expect("render");
        assert!(frame.stats.cpu_trace_ms > 0.0, "a moved light traces again");
        assert_eq!(check_total(&frame), 0);
        moving.push(indirect(&renderer));
    }
    let reseeded = (0..3)
        .map(|seed| {
            let mut r =
                Renderer::new(gpu, scene, RenderSettings { seed, ..settings() }).expect("renderer");
            r.render().expect("render");
            indirect(&r)
        })
        .collect();
    (moving, reseeded)
}

#[test]
fn a_slowly_moving_light_leaves_the_room_it_cannot_light_untouched() {
    let gpu = common::gpu();
    // The right room's spot slides 1 cm a frame towards the back wall; the left room's stays.
    let scene = hard::two_rooms();
    let mut renderer = Renderer::new(&gpu, &scene, settings()).expect("renderer");
    let mut frames = Vec::new();
    for k in 0..3 {
        let mut lights = scene.lights.clone();
        lights[1].position.z -= 0.01 * k as f32;
        renderer.set_lights(&lights).expect("lights");
        let frame = renderer.render().expect("render");
        assert!(frame.stats.cpu_trace_ms > 0.0);
        hard::assert_frame_clean(&frame, &format!("two-rooms-{k}"));
        frames.push(indirect(&renderer));
    }
    // The left room fills the left third of the image; the gap between the rooms lies on the
    // centre column.
    let left = |image: &[f32]| -> Vec<f32> {
        image
            .chunks_exact(4 * SIZE as usize)
            .flat_map(|row| row[..4 * (SIZE as usize / 2 - 4)].to_vec())
            .collect()
    };
    assert!(
        hard::mean(&left(&frames[0])) > 0.0,
        "the left room has indirect light"
    );
    for k in 1..3 {
        assert!(
            left(&frames[k]) == left(&frames[0]),
            "frame {k}: the left room's indirect light changed"
        );
    }
    let whole = flicker(&frames[0], &frames[1], &frames[2]);
    eprintln!("two rooms, one light moving: F = {whole:.5}");
    assert!(whole < 0.1, "F = {whole}");
    common::assert_validation_clean(&gpu);
}

#[test]
fn slowly_moving_lights_flicker_far_less_than_redrawn_noise_in_every_bundled_scene() {
    let gpu = common::gpu();
    for name in ispm::scene::bundled::BUNDLED {
        let scene = ispm::scene::bundled::resolve(Some(name)).expect("bundled");
        let (moving, reseeded) = moving_and_reseeded(&gpu, &scene);
        let f = flicker(&moving[0], &moving[1], &moving[2]);
        let noise = flicker(&reseeded[0], &reseeded[1], &reseeded[2]);
        eprintln!("{name}: F = {f:.5} moving, {noise:.4} redrawn");
        assert!(noise > 0.05, "{name}: redrawn noise {noise}");
        assert!(
            // 0.10 (it was 0.15 for glass-cube's chaotic refracted paths, 0.084 and 0.119 in two
            // realisations, before the kNN kernels and jittered emission; now at most 0.074,
            // glass-cube; docs/stability.md).
            f < 0.10 && f < 0.4 * noise,
            "{name}: F = {f} moving, {noise} redrawn"
        );
    }
    common::assert_validation_clean(&gpu);
}
