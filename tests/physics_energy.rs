//! The analytic energy balance of a closed room (issue #19): inside a closed room of uniform
//! Lambertian albedo `a` and total area `A`, lit by a point light of flux `Φ`, every joule the
//! light emits is reflected `a + a² + … = a/(1 − a)` times before it is absorbed, so the flux
//! leaving all surfaces together is `aΦ/(1 − a)` and the area-weighted mean outgoing radiance
//! (radiant exitance `M = πL` for a Lambertian surface) is
//!
//! ```text
//!   L̄ = aΦ / ((1 − a)·A·π)
//! ```
//!
//! whatever the room's shape and wherever the light is. Every bounce counts with its full
//! weight, so a renderer that loses a fraction of a percent per bounce, or stops after a fixed
//! number of bounces, is measurably dark at a = 0.95 (about 20 bounces carry the light).
//!
//! **The estimator.** The room is the box `[−1, 1]³` (A = 24 m²), the camera sits at its
//! centre, and six square views with a 90° field of view look along ±X, ±Y, ±Z: each view's
//! frustum ends exactly at the corners of one face, and because the face is parallel to the
//! image plane every pixel covers the same area of it. The mean over the six images' pixels is
//! therefore the area-weighted mean of the radiance leaving the surfaces towards the centre,
//! which for Lambertian walls is `L̄` (the direction does not matter). The measurement goes
//! through the camera model, the light units and the whole pipeline of each method (direct
//! light included), so it catches a bias anywhere on the way. The light is off-centre (the
//! balance does not care) so that no symmetry hides a mistake, with `I = 6(1 − a)/a` W/sr,
//! which makes `L̄ = 1` (`Φ = 4πI`).
//!
//! `cargo test --test physics_energy -- --nocapture` prints every ratio.

mod common;

use glam::{Mat4, Quat, Vec3};
use ispm::config::settings::Method;
use ispm::config::settings::{Method as GpuMethod, RenderSettings};
use ispm::reference::scenes::{grey_box, point_light};
use ispm::reference::{render, RefSettings};
use ispm::render::frame::Renderer;
use ispm::scene::{Camera, Scene};
use std::sync::atomic::AtomicBool;

/// The albedos of the issue.
const ALBEDOS: [f32; 3] = [0.5, 0.8, 0.95];
/// Where the light is (inside the room, off-centre).
const LIGHT: Vec3 = Vec3::new(0.2, 0.3, -0.1);
/// A bounce cap no path in these rooms reaches before Russian roulette ends it
/// (0.95²⁵⁶ ≈ 2·10⁻⁶ of the light is left after it).
const CAP: u32 = 256;

/// The closed grey room of albedo `a` whose exact mean outgoing radiance is 1.
fn room(a: f32) -> Scene {
    let mut scene = grey_box(a, 1.0);
    scene.lights = vec![point_light(LIGHT, Vec3::splat(6.0 * (1.0 - a) / a))];
    scene
}

/// The six 90° views from the centre of the room, one per face.
fn views() -> [Camera; 6] {
    [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ]
    .map(|forward| Camera {
        transform: Mat4::from_quat(Quat::from_rotation_arc(Vec3::NEG_Z, forward)),
        yfov: 90f32.to_radians(),
        znear: 1e-3,
        zfar: None,
    })
}

/// Mean of the six views' pixels: the area-weighted mean outgoing radiance (module docs).
fn mean_of_views(mut view: impl FnMut(&Camera) -> Vec<[f32; 3]>) -> f64 {
    let views = views();
    let sum: f64 = views
        .iter()
        .map(|camera| {
            let pixels = view(camera);
            let s: f64 = pixels.iter().flatten().map(|&c| f64::from(c)).sum::<f64>();
            s / (pixels.len() * 3) as f64
        })
        .sum();
    sum / views.len() as f64
}

fn reference_ratio(method: Method, a: f32, settings: &RefSettings) -> f64 {
    let mut scene = room(a);
    mean_of_views(|camera| {
        scene.camera = *camera;
        render(&scene, method, settings, None, &AtomicBool::new(false))
            .expect("render")
            .pixels
    })
}

fn assert_balanced(what: &str, a: f32, ratio: f64, tolerance: f64) {
    eprintln!("{what}, a = {a}: mean radiance / aΦ/((1−a)Aπ) = {ratio:.4}");
    assert!(
        (ratio - 1.0).abs() < tolerance,
        "{what}, a = {a}: mean outgoing radiance is {ratio:.4} of the energy balance's \
         (tolerance {tolerance})"
    );
}

/// Path tracing with Russian roulette: unbiased, so only noise is allowed (about 0.3 % at
/// a = 0.95 with these samples; the tolerance is 1.5 %). A loss of 0.3 % per bounce would be
/// 6 % at a = 0.95.
#[test]
fn path_trace_balances_the_energy_of_closed_rooms() {
    let settings = RefSettings {
        width: 32,
        height: 32,
        spp: 64,
        bounces: CAP,
        seed: 19,
        ..RefSettings::default()
    };
    for a in ALBEDOS {
        let ratio = reference_ratio(Method::PathTrace, a, &settings);
        assert_balanced("path-trace", a, ratio, 0.015);
    }
}

/// Progressive photon mapping: consistent up to its one-pixel kernel floor; at a finite radius
/// the kernel loses a little of
/// its mass past the room's edges and corners (measured: 1.1 %, 1.7 %, 2.3 % dark at a = 0.5,
/// 0.8, 0.95 with r = 0.1 m; 0.2 %, 0.3 %, 0.4 % with r = 0.05 m, the radius used here). The
/// kernels are at least a pixel's footprint wide (`reference::gather::render_progressive`):
/// 64² views of 90° keep that floor (3 cm a metre away, 5 cm in the far corners) at or under the
/// 5 cm radius; at 24² (8 cm a metre away)
/// the room came out 1.4 % and 2.3 % dark at a = 0.5 and 0.8, at 48² 0.8 %, 1.3 % and 1.7 % at
/// a = 0.5, 0.8 and 0.95.
#[test]
fn progressive_balances_the_energy_of_closed_rooms() {
    let settings = RefSettings {
        width: 64,
        height: 64,
        spp: 1,
        photons: 20_000,
        iterations: 4,
        bounces: CAP,
        radius: Some(0.05),
        seed: 19,
        ..RefSettings::default()
    };
    for a in ALBEDOS {
        let ratio = reference_ratio(Method::Progressive, a, &settings);
        assert_balanced("progressive", a, ratio, 0.015);
    }
}

/// ISPM on the GPU: shadow-mapped direct light plus the photon volumes of the GPU bounce map's
/// photons traced on by the CPU. Its scene-relative kernel (r_max ≈ 0.1 m here) loses mass at
/// the room's edges like progressive's at that radius (measured 1.5 %, 1.2 %, 2.1 % dark).
#[test]
fn ispm_balances_the_energy_of_closed_rooms() {
    let gpu = common::gpu();
    for a in ALBEDOS {
        let scene = room(a);
        let settings = RenderSettings {
            method: GpuMethod::Ispm,
            photons: 40_000,
            bounces: CAP,
            width: 48,
            height: 48,
            shadow_resolution: 256,
            seed: 19,
            ..RenderSettings::default()
        };
        let mut renderer = Renderer::new(&gpu, &scene, settings).expect("renderer");
        let ratio = mean_of_views(|camera| {
            renderer.set_camera(*camera).expect("camera");
            let frame = renderer.render().expect("render");
            frame
                .hdr
                .chunks_exact(4)
                .map(|p| [p[0], p[1], p[2]])
                .collect()
        });
        common::assert_validation_clean(&gpu);
        assert_balanced("ispm", a, ratio, 0.04);
    }
}
