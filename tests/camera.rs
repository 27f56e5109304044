//! `Renderer::set_camera` on lavapipe with validation (synchronization validation included) on:
//! a renderer moved to camera B renders what a new renderer made for camera B renders, and a
//! pure camera move re-traces no photons (the photon map does not depend on the camera); a move
//! that changes which lights emit photons traces them.

mod common;

use glam::Vec3;
use ispm::app::camera_control::scripted_pose;
use ispm::config::settings::{Method, RenderSettings};
use ispm::reference::scenes::{cornell, grey_box};
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::{Camera, Scene};

fn settings() -> RenderSettings {
    RenderSettings {
        method: Method::Ispm,
        photons: 6_000,
        width: 64,
        height: 48,
        shadow_resolution: 128,
        ..Default::default()
    }
}

fn looking(eye: Vec3, target: Vec3, yfov_degrees: f32) -> Camera {
    Camera {
        transform: glam::camera::rh::view::look_at_mat4(eye, target, Vec3::Y).inverse(),
        yfov: yfov_degrees.to_radians(),
        znear: 0.01,
        zfar: None,
    }
}

fn bits(frame: &FrameImage) -> Vec<u32> {
    frame.hdr.iter().map(|v| v.to_bits()).collect()
}

/// A new renderer's first frame of `scene` seen from `camera`.
fn fresh(scene: &Scene, camera: Camera) -> FrameImage {
    fresh_with(scene, camera, settings())
}

fn fresh_with(scene: &Scene, camera: Camera, settings: RenderSettings) -> FrameImage {
    let gpu = common::gpu();
    let mut scene = scene.clone();
    scene.camera = camera;
    let frame = Renderer::new(&gpu, &scene, settings)
        .expect("renderer")
        .render()
        .expect("frame");
    common::assert_validation_clean(&gpu);
    frame
}

/// No light at all: every pixel's radiance is zero.
fn black(frame: &FrameImage) -> bool {
    frame.hdr.chunks_exact(4).all(|p| p[..3] == [0.0; 3])
}

fn ran(frame: &FrameImage, pass: &str) -> bool {
    frame.stats.passes_run.iter().any(|p| p == pass)
}

/// Asserts `frame` reused the photon map of frame `from`: the photon passes skipped with that
/// reason, no trace.
fn assert_reused(frame: &FrameImage, from: u64) {
    let why = format!("photon map of frame {from} reused");
    for pass in common::REUSED_PHOTON_MAP_SKIPS {
        let skipped = frame
            .stats
            .passes_skipped
            .iter()
            .find(|s| s.name == *pass)
            .unwrap_or_else(|| panic!("{pass} not skipped: {:?}", frame.stats.passes_skipped));
        assert!(skipped.reason.contains(&why), "{pass}: {}", skipped.reason);
        assert!(!ran(frame, pass), "{pass} ran");
    }
    assert_eq!(frame.stats.cpu_trace_ms, 0.0);
    assert!(ran(frame, common::estimator_pass()) && ran(frame, "composite"));
}

fn assert_traced(frame: &FrameImage) {
    for pass in ["light_gbuffers", "bounce_map", "readback", "upload"] {
        assert!(ran(frame, pass), "{pass} did not run");
    }
    assert!(frame.stats.cpu_trace_ms > 0.0, "no trace");
    assert!(frame.stats.stored_photons > 0, "no photons stored");
}

/// Pixels whose largest channel differs (linear radiance).
fn differing_pixels(a: &FrameImage, b: &FrameImage) -> usize {
    a.hdr
        .chunks_exact(4)
        .zip(b.hdr.chunks_exact(4))
        .filter(|(p, q)| (0..3).any(|c| p[c] != q[c]))
        .count()
}

#[test]
fn a_moved_camera_renders_bit_for_bit_what_a_new_renderer_there_renders_without_a_new_trace() {
    // Diffuse walls and a sphere, the light inside with the camera: nothing the environment
    // map would cache. B differs from A in position, orientation and field of view (the
    // kernel's footprint floor).
    let scene = cornell(1);
    let a = scene.camera;
    let b = looking(Vec3::new(-0.6, 0.3, 0.7), Vec3::new(0.3, -0.5, -0.5), 55.0);
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, &scene, settings()).expect("renderer");
    let first = r.render().expect("frame 0 at A");
    assert_traced(&first);
    let traced_map = r.photons().expect("ispm").photon_map();

    // Frames in flight across the move: frame 1 at A, frames 2 and 3 at B.
    r.submit_frame().expect("frame 1 at A");
    r.set_camera(b).expect("move to B");
    assert_eq!(*r.camera(), b);
    r.submit_frame().expect("frame 2 at B");
    let moved = r.render().expect("frame 3 at B");
    assert_reused(&moved, 0);
    assert_eq!(moved.stats.stored_photons, first.stats.stored_photons);
    // The same photons, only drawn from elsewhere: positions relative to B.
    let drawn = r.photons().expect("ispm").photon_map();
    let offset = (a.position().as_dvec3() - b.position().as_dvec3()).as_vec3();
    for (p, q) in traced_map.iter().zip(&drawn) {
        assert_eq!(p.power, q.power);
        assert!((p.position + offset - q.position).abs().max_element() < 1e-5);
    }
    common::assert_validation_clean(&gpu);
    drop(r);

    let expected = fresh(&scene, b);
    let differ = differing_pixels(&moved, &expected);
    assert!(
        bits(&moved) == bits(&expected),
        "{differ} of {} pixels differ from a new renderer at B",
        moved.width * moved.height
    );
    // And the move is real: B's image is not A's.
    let total = (first.width * first.height) as usize;
    assert!(
        differing_pixels(&first, &moved) > total / 2,
        "the camera did not move"
    );
}

#[test]
fn with_glass_a_moved_camera_keeps_its_cached_environment_map_within_tolerance() {
    // The bundled Cornell box has a glass sphere: the environment cube map is centred on it and
    // rendered once, relative to the camera of its frame (A), so after a move to B it differs
    // from a new renderer's (made relative to B) by f32 rounding only. B is the viewer's
    // scripted pose of frame 60.
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("cornell-box");
    let b = scripted_pose(&scene.camera, &scene.bounds(), 60);
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, &scene, settings()).expect("renderer");
    let first = r.render().expect("frame 0 at A");
    assert_traced(&first);
    r.set_camera(b).expect("move to B");
    let moved = r.render().expect("frame 1 at B");
    assert_reused(&moved, 0);
    assert!(
        !ran(&moved, "environment"),
        "a camera move re-rendered the environment map"
    );
    common::assert_validation_clean(&gpu);
    drop(r);

    let expected = fresh(&scene, b);
    let peak = expected.hdr.iter().fold(0.0f32, |m, v| m.max(*v));
    let worst = moved
        .hdr
        .iter()
        .zip(&expected.hdr)
        .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
    let differ = differing_pixels(&moved, &expected);
    println!(
        "glass: {differ} pixels differ, by at most {:e} of the peak",
        worst / peak
    );
    assert!(
        worst <= 1e-4 * peak,
        "largest difference {:e} of the peak",
        worst / peak
    );
    let total = (moved.width * moved.height) as usize;
    assert!(
        differing_pixels(&first, &moved) > total / 4,
        "the camera did not move"
    );
}

#[test]
fn a_camera_that_enters_a_closed_box_gets_the_photons_of_the_lamp_inside() {
    enter_a_closed_box(settings());
}

/// As above, subsampled: the upsample, made with the photon part of the frame when the camera
/// enters, reads the direct pass's `c_L/π` image, made with the renderer long before.
#[test]
fn a_subsampled_camera_that_enters_a_closed_box_gets_the_photons_of_the_lamp_inside() {
    enter_a_closed_box(RenderSettings {
        subsample: 2,
        ..settings()
    });
}

fn enter_a_closed_box(settings: RenderSettings) {
    // A lamp inside a closed box: from outside (A) the plan skips it (no indirect light at all,
    // so the renderer has no photon part); from inside (B) it lights everything.
    let scene = grey_box(0.5, 1.0);
    let outside = looking(Vec3::new(1.5, 1.5, 5.0), Vec3::ZERO, 45.0);
    let inside = scene.camera;
    let gpu = common::gpu();
    let mut at_outside = scene.clone();
    at_outside.camera = outside;
    let mut r = Renderer::new(&gpu, &at_outside, settings.clone()).expect("renderer");
    assert!(r.photons().is_none(), "{}", r.plan());
    let dark = r.render().expect("frame 0 outside");
    assert!(black(&dark), "the lamp lit the outside");

    r.set_camera(inside).expect("move inside");
    assert!(r.plan().indirect.needed, "{}", r.plan());
    let lit = r.render().expect("frame 1 inside");
    assert_traced(&lit);
    let again = r.render().expect("frame 2 inside");
    assert_reused(&again, 1);

    // Back out: the lamp emits nothing any more; and in again: traced again.
    r.set_camera(outside).expect("move outside");
    let out = r.render().expect("frame 3 outside");
    assert!(black(&out), "the lamp lit the outside");
    r.set_camera(inside).expect("move inside again");
    let back = r.render().expect("frame 4 inside");
    assert_traced(&back);
    common::assert_validation_clean(&gpu);
    drop(r);

    let expected = fresh_with(&scene, inside, settings);
    assert!(bits(&lit) == bits(&expected), "differs from a new renderer");
    assert!(bits(&again) == bits(&expected));
    assert!(bits(&back) == bits(&expected));
}

#[test]
fn a_camera_that_is_not_finite_or_has_no_field_of_view_is_refused() {
    let scene = cornell(1);
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, &scene, settings()).expect("renderer");
    let good = *r.camera();
    let mut nan = good;
    nan.transform.w_axis.x = f32::NAN;
    let flat = Camera { yfov: 0.0, ..good };
    let behind = Camera {
        znear: -1.0,
        ..good
    };
    for (camera, what) in [(nan, "not finite"), (flat, "yfov"), (behind, "znear")] {
        let err = r.set_camera(camera).expect_err(what).to_string();
        assert!(err.contains(what), "{err}");
        assert_eq!(*r.camera(), good, "a refused camera was kept");
    }
    r.render().expect("still renders");
    common::assert_validation_clean(&gpu);
}
