//! Headless renders of the bundled scenes on the GPU, validation on: direct light where the
//! assertions are about direct light, both methods where they hold for any image.

mod common;

use glam::{Vec2, Vec3};
use ispm::config::settings::{Method, RenderSettings};
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::bundled;

const SIZE: u32 = 128;

fn render(scene: &ispm::scene::Scene, method: Method) -> FrameImage {
    let gpu = common::gpu();
    let frame = {
        let mut r = Renderer::new(
            &gpu,
            scene,
            RenderSettings {
                method,
                photons: 20_000,
                width: SIZE,
                height: SIZE,
                shadow_resolution: 512,
                ..Default::default()
            },
        )
        .expect("renderer");
        r.render().expect("render")
    };
    common::assert_validation_clean(&gpu);
    frame
}

/// Mean linear RGB over a 3×3 block around the pixel where world point `p` lands.
fn radiance_at(scene: &ispm::scene::Scene, frame: &FrameImage, p: Vec3) -> Vec3 {
    let px: Vec2 = scene
        .camera
        .project_to_pixel(p, frame.width, frame.height)
        .expect("point in front of the camera");
    let (cx, cy) = (px.x as i32, px.y as i32);
    let mut sum = Vec3::ZERO;
    for dy in -1..=1 {
        for dx in -1..=1 {
            let x = (cx + dx).clamp(0, frame.width as i32 - 1) as usize;
            let y = (cy + dy).clamp(0, frame.height as i32 - 1) as usize;
            let i = (y * frame.width as usize + x) * 4;
            sum += Vec3::new(frame.hdr[i], frame.hdr[i + 1], frame.hdr[i + 2]);
        }
    }
    sum / 9.0
}

fn save(test: &str, frame: &FrameImage) -> std::path::PathBuf {
    let dir = common::image_dir(test);
    let png = dir.join("actual.png");
    ispm::output::write_png(&png, frame.width, frame.height, &frame.ldr).expect("png");
    ispm::output::write_exr(
        &dir.join("actual.exr"),
        frame.width,
        frame.height,
        &frame.hdr,
    )
    .expect("exr");
    png
}

#[test]
fn cornell_box_direct_light_is_validation_clean_lit_where_aimed_and_shadowed_behind_objects() {
    let scene = bundled::resolve(Some("cornell-box")).expect("bundled scene");
    let frame = render(&scene, Method::Direct);
    let path = save("cornell_box_direct", &frame);
    let at = |p| radiance_at(&scene, &frame, p);

    // Under each spot: lit; the blue spot's light is blue.
    let under_white = at(Vec3::new(-0.4, 0.0, 0.1));
    let under_blue = at(Vec3::new(0.55, 0.0, 0.1));
    assert!(
        under_white.min_element() > 0.1,
        "floor under the white spot: {under_white} ({})",
        path.display()
    );
    assert!(
        under_blue.z > 0.1 && under_blue.z > 1.5 * under_blue.x,
        "floor under the blue spot: {under_blue} ({})",
        path.display()
    );

    // Behind the glass sphere, seen from both spots: in shadow.
    let shadowed = at(Vec3::new(0.16, 0.0, 0.42));
    let lit_nearby = at(Vec3::new(-0.4, 0.0, 0.42));
    assert!(
        shadowed.length() < 0.25 * lit_nearby.length(),
        "shadow of the glass sphere {shadowed} vs lit floor {lit_nearby} ({})",
        path.display()
    );

    // Wall colours: the red wall is red, the green wall green.
    let left = at(Vec3::new(-1.0, 0.3, 0.0));
    let right = at(Vec3::new(1.0, 0.3, 0.0));
    assert!(
        left.x > 2.0 * left.y && left.x > 2.0 * left.z,
        "left wall {left} ({})",
        path.display()
    );
    assert!(
        right.y > 1.5 * right.x && right.y > 1.5 * right.z,
        "right wall {right} ({})",
        path.display()
    );
}

#[test]
fn every_bundled_scene_renders_finite_non_negative_radiance_and_round_trips_through_exr() {
    for (name, method) in bundled::BUNDLED
        .iter()
        .flat_map(|n| [(n, Method::Direct), (n, Method::Ispm)])
    {
        let scene = bundled::resolve(Some(name)).expect("bundled scene");
        let frame = render(&scene, method);
        let dir = common::image_dir(&format!("bundled_{name}_{method:?}"));
        let exr = dir.join("actual.exr");
        ispm::output::write_exr(&exr, frame.width, frame.height, &frame.hdr).expect("exr");
        let (w, h, pixels) = ispm::output::read_exr(&exr).expect("read exr");
        assert_eq!((w, h), (SIZE, SIZE));
        let bad = pixels
            .iter()
            .filter(|v| !v.is_finite() || **v < 0.0)
            .count();
        assert_eq!(
            bad,
            0,
            "{name}: {bad} NaN/Inf/negative values in {}",
            exr.display()
        );
        let lit = pixels
            .chunks_exact(4)
            .filter(|p| p[0] + p[1] + p[2] > 1e-3)
            .count();
        assert!(
            lit > (SIZE * SIZE / 10) as usize,
            "{name}: only {lit} lit pixels in {}",
            exr.display()
        );
    }
}
