//! Camera cases (issue #8, docs/stability.md) on the lit box of `tests/common/hard.rs` (2 m,
//! one spot, a block): a camera inside the photon volumes, a surface closer than the near
//! plane, a grazing view, fields of view of 1° and 170°, and 1×1 and 256×1 images. Every frame
//! passes the GPU value check (no NaN, ±Inf or negative value in any buffer) and writes a
//! finite, non-negative EXR, with validation and synchronization validation silent; each case
//! adds the assertion that fits it.

mod common;

use common::hard::{self, Checked};
use glam::Vec3;
use ispm::config::settings::{Method, RenderSettings};
use ispm::gpu::Gpu;
use ispm::scene::{Camera, Scene};
use std::sync::Arc;

/// The lit box seen from `eye` towards `target`.
fn looking(eye: Vec3, target: Vec3, yfov: f32, znear: f32) -> Scene {
    let mut scene = hard::lit_box(1.0, Vec3::ZERO);
    scene.camera = Camera {
        transform: glam::camera::rh::view::look_at_mat4(eye, target, Vec3::Y).inverse(),
        yfov,
        znear,
        zfar: None,
    };
    scene
}

fn render(gpu: &Arc<Gpu>, scene: &Scene, size: (u32, u32), method: Method, name: &str) -> Checked {
    let settings = RenderSettings {
        method,
        ..hard::settings(size.0, size.1)
    };
    hard::render_checked(gpu, scene, settings, name)
}

/// RGB sum of pixel (x, y) of an RGBA image `width` wide.
fn pixel(image: &[f32], width: u32, (x, y): (u32, u32)) -> f32 {
    let i = ((y * width + x) * 4) as usize;
    image[i] + image[i + 1] + image[i + 2]
}

/// The mean RGB sum over the `n`×`n` pixels centred on (x, y).
fn patch(image: &[f32], width: u32, (x, y): (u32, u32), n: u32) -> f32 {
    let h = n / 2;
    let mut sum = 0.0;
    for j in y - h..y - h + n {
        for i in x - h..x - h + n {
            sum += pixel(image, width, (i, j));
        }
    }
    sum / (n * n) as f32
}

/// How far apart the centre pixels of two renders may be in direct light although both pixels'
/// centres are the same ray. The rasteriser snaps vertex positions to 1/2^`bits` of a pixel
/// (`subPixelPrecisionBits`: 8 on lavapipe and NVIDIA, at least 4 by the spec) and interpolates
/// the attributes across the snapped triangle, so the shaded point may lie up to half a step per
/// axis off the ray, in each of the two renders. `coarse_px` is the other render's pixel in
/// pixels of `reference` (a 33×33 render), whose central differences give the direct light's
/// slope per pixel; plus 1e-3 of the value for the arithmetic.
fn snap_tolerance(gpu: &Gpu, reference: &[f32], coarse_px: f32) -> f32 {
    let p = |x, y| pixel(reference, 33, (x, y));
    let slope = ((p(17, 16) - p(15, 16)).abs() + (p(16, 17) - p(16, 15)).abs()) / 2.0;
    let step = (coarse_px + 1.0) / (1u32 << gpu.properties.sub_pixel_precision_bits) as f32;
    1e-3 * p(16, 16) + slope * step / 2.0
}

/// The default view: from the open side, 40° field of view.
const EYE: Vec3 = Vec3::new(0.0, 1.0, 3.6);
const YFOV: f32 = 0.7;

/// A point on the back wall inside the spot's cone, away from the block's shadow.
const WALL_POINT: Vec3 = Vec3::new(0.4, 0.5, -1.0);

#[test]
fn camera_inside_photon_volumes_keeps_the_indirect_light_of_the_wall_it_faces() {
    let gpu = common::gpu();
    let far_scene = looking(EYE, WALL_POINT, YFOV, 0.05);
    // 3 cm from the wall, well inside the kernels of the photons stored on it (r_max is a
    // tenth of the scene's size), with the near plane closer still.
    let near_scene = looking(WALL_POINT + Vec3::Z * 0.03, WALL_POINT, YFOV, 0.005);
    // The wall point's indirect light from both, over three seeds (the near view sees a
    // centimetre of wall: a point estimate, as noisy as the photons in one kernel).
    let (mut near, mut far) = (0.0, 0.0);
    for seed in 0..3 {
        let settings = RenderSettings {
            seed,
            ..hard::settings(48, 48)
        };
        let f = hard::render_checked(&gpu, &far_scene, settings.clone(), "camera-far");
        let n = hard::render_checked(&gpu, &near_scene, settings, "camera-inside-volumes");
        far += patch(&f.indirect, 48, (24, 24), 3) / 3.0;
        near += patch(&n.indirect, 48, (24, 24), 16) / 3.0;
    }
    let ratio = near / far;
    eprintln!("inside volumes: indirect near {near} far {far} ratio {ratio}");
    assert!(far > 0.0);
    assert!(
        (0.75..1.33).contains(&ratio),
        "indirect near ÷ far = {ratio}"
    );
    common::assert_validation_clean(&gpu);
}

#[test]
fn a_surface_closer_than_the_near_plane_is_clipped_and_lights_nothing() {
    let gpu = common::gpu();
    // 3 cm from the back wall with the near plane at 10 cm: the wall is clipped, and behind it
    // the view leaves the box: no surface anywhere, though photon volumes on the wall reach
    // in front of the camera.
    let scene = looking(WALL_POINT + Vec3::Z * 0.03, WALL_POINT, YFOV, 0.1);
    let c = render(
        &gpu,
        &scene,
        (32, 32),
        Method::Ispm,
        "surface-before-near-plane",
    );
    assert!(c.frame.stats.stored_photons > 1000);
    assert!(
        c.frame.hdr.chunks_exact(4).all(|p| p[..3] == [0.0; 3]),
        "a clipped surface or its photon volumes lit a pixel"
    );
    common::assert_validation_clean(&gpu);
}

#[test]
fn a_grazing_view_of_the_floor_keeps_its_radiance() {
    let gpu = common::gpu();
    // The floor is Lambertian: its radiance does not depend on the view. Seen from 2 cm above
    // it, the pixels just below the horizon look at it at 1° to 4°.
    let target = Vec3::new(0.3, 0.02, -1.0);
    let grazing = looking(Vec3::new(0.3, 0.02, 0.95), target, YFOV, 0.005);
    let g = render(&gpu, &grazing, (48, 48), Method::Ispm, "grazing");
    let top = looking(
        Vec3::new(0.3, 1.9, 0.4),
        Vec3::new(0.3, 0.0, -0.2),
        YFOV,
        0.05,
    );
    let t = render(&gpu, &top, (48, 48), Method::Ispm, "grazing-reference");
    // The floor's mean over the rows just below the horizon against its mean seen from above.
    let rows = |c: &Checked, ys: std::ops::Range<u32>| {
        let n = ys.len() as f32 * 48.0;
        ys.flat_map(|y| (0..48).map(move |x| (x, y)))
            .map(|p| pixel(&c.frame.hdr, 48, p))
            .sum::<f32>()
            / n
    };
    let grazing_floor = rows(&g, 25..29);
    let floor = rows(&t, 8..40);
    let ratio = grazing_floor / floor;
    eprintln!("grazing: floor {grazing_floor} from above {floor} ratio {ratio}");
    assert!(
        (0.5..2.0).contains(&ratio),
        "grazing ÷ from above = {ratio}"
    );
    common::assert_validation_clean(&gpu);
}

#[test]
fn fields_of_view_of_1_and_170_degrees_see_the_same_radiance_along_the_axis() {
    let gpu = common::gpu();
    let scene = |degrees: f32| looking(EYE, WALL_POINT, degrees.to_radians(), 0.05);
    let centre = |image: &[f32]| pixel(image, 33, (16, 16));
    let direct = render(
        &gpu,
        &scene(40.0),
        (33, 33),
        Method::Direct,
        "fov-40-direct",
    );
    let ispm = render(&gpu, &scene(40.0), (33, 33), Method::Ispm, "fov-40");
    assert!(centre(&direct.frame.hdr) > 0.0 && centre(&ispm.indirect) > 0.0);
    for degrees in [1.0f32, 170.0] {
        // The centre pixel's ray is the axis whatever the field of view: the same direct light.
        let d = render(
            &gpu,
            &scene(degrees),
            (33, 33),
            Method::Direct,
            &format!("fov-{degrees}-direct"),
        );
        let (a, b) = (centre(&d.frame.hdr), centre(&direct.frame.hdr));
        // Indirect light: the same estimate, within its noise and the footprint floor's blur.
        let c = render(
            &gpu,
            &scene(degrees),
            (33, 33),
            Method::Ispm,
            &format!("fov-{degrees}"),
        );
        let ratio = centre(&c.indirect) / centre(&ispm.indirect);
        // One pixel of this view in pixels of the 40° one, at the centre.
        let coarse = (degrees.to_radians() / 2.0).tan() / (40f32.to_radians() / 2.0).tan();
        let tolerance = snap_tolerance(&gpu, &direct.frame.hdr, coarse);
        eprintln!(
            "fov {degrees}: direct {a} against {b} (tolerance {tolerance}), indirect centre \
             ratio {ratio}"
        );
        assert!(
            (a - b).abs() <= tolerance,
            "fov {degrees}°: direct {a} against {b}, more than {tolerance} apart"
        );
        assert!(
            (0.75..1.33).contains(&ratio),
            "fov {degrees}°: indirect centre ÷ 40° centre = {ratio}"
        );
    }
    common::assert_validation_clean(&gpu);
}

#[test]
fn a_1x1_image_is_the_centre_pixel_of_a_larger_one() {
    let gpu = common::gpu();
    let scene = looking(EYE, WALL_POINT, YFOV, 0.05);
    // Direct light is sampled at the pixel's centre: exact, up to the rasteriser's snapping.
    let one = render(&gpu, &scene, (1, 1), Method::Direct, "1x1-direct");
    let big = render(&gpu, &scene, (33, 33), Method::Direct, "33x33-direct");
    let (a, b) = (
        pixel(&one.frame.hdr, 1, (0, 0)),
        pixel(&big.frame.hdr, 33, (16, 16)),
    );
    // The 1×1 image's pixel is the whole 33×33 view.
    let tolerance = snap_tolerance(&gpu, &big.frame.hdr, 33.0);
    eprintln!("1x1 direct {a} vs {b} (tolerance {tolerance})");
    assert!(
        (a - b).abs() <= tolerance,
        "1×1 {a} against the centre {b}, more than {tolerance} apart"
    );
    // With photons: the same estimate, within its noise and the blur of the kernel's
    // pixel-footprint floor (one pixel is the whole view: the floor is at its ceiling).
    let one = render(&gpu, &scene, (1, 1), Method::Ispm, "1x1");
    let big = render(&gpu, &scene, (33, 33), Method::Ispm, "33x33");
    let (a, b) = (
        pixel(&one.indirect, 1, (0, 0)),
        patch(&big.indirect, 33, (16, 16), 9),
    );
    eprintln!("1x1 indirect {a} vs {b}");
    assert!(
        a > 0.0 && (0.5..2.0).contains(&(a / b)),
        "1×1 indirect {a} against {b}"
    );
    common::assert_validation_clean(&gpu);
}

#[test]
fn a_256x1_image_is_the_centre_row_of_a_tall_one_with_the_same_rays() {
    let gpu = common::gpu();
    // 256×1 at 40° vertical: 179° across, from inside the box so that the row sees the side
    // walls as well as the back. The centre row of a 256×257 image whose vertical field of
    // view is 257 times as tall (in tan) holds the same rays.
    let inside = Vec3::new(0.0, 0.8, 0.9);
    let wide = looking(inside, WALL_POINT, YFOV, 0.05);
    let line = render(&gpu, &wide, (256, 1), Method::Direct, "256x1-direct");
    let tall_fov = 2.0 * (257.0 * (YFOV / 2.0).tan()).atan();
    let tall = looking(inside, WALL_POINT, tall_fov, 0.05);
    let tall = render(&gpu, &tall, (256, 257), Method::Direct, "256x257-direct");
    let row = &tall.frame.hdr[(128 * 256 * 4) as usize..(129 * 256 * 4) as usize];
    assert!(hard::mean(row) > 0.0, "the row sees the lit wall");
    let err = hard::relative_l1(&line.frame.hdr, row);
    eprintln!("256x1 direct against the row: {err}");
    assert!(err < 1e-2, "Σ|Δ|/Σ = {err}");
    let ispm = render(&gpu, &wide, (256, 1), Method::Ispm, "256x1");
    assert!(ispm.frame.stats.stored_photons > 1000);
    assert!(hard::mean(&ispm.indirect) > 0.0);
    common::assert_validation_clean(&gpu);
}
