//! Glass and mirrors: the environment cube map and the translucent forward pass, on lavapipe
//! with validation on.

mod common;

use glam::{Vec2, Vec3};
use ispm::config::settings::{Method, RenderSettings};
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::{bundled, Scene};

const WIDTH: u32 = 160;
const HEIGHT: u32 = 120;

fn settings(method: Method) -> RenderSettings {
    RenderSettings {
        method,
        photons: 20_000,
        width: WIDTH,
        height: HEIGHT,
        shadow_resolution: 512,
        ..Default::default()
    }
}

/// Renders `frames` frames of `scene` and returns them, checking validation at the end.
fn render(scene: &Scene, method: Method, frames: usize) -> Vec<FrameImage> {
    let gpu = common::gpu();
    let images = {
        let mut r = Renderer::new(&gpu, scene, settings(method)).expect("renderer");
        (0..frames).map(|_| r.render().expect("render")).collect()
    };
    common::assert_validation_clean(&gpu);
    images
}

fn save(test: &str, frame: &FrameImage) -> std::path::PathBuf {
    let png = common::image_dir(test).join("actual.png");
    ispm::output::write_png(&png, frame.width, frame.height, &frame.ldr).expect("png");
    png
}

/// Mean linear RGB over the (2r+1)² block around the pixel where world point `p` lands.
fn radiance_at(scene: &Scene, frame: &FrameImage, p: Vec3, r: i32) -> Vec3 {
    let px: Vec2 = scene
        .camera
        .project_to_pixel(p, frame.width, frame.height)
        .expect("point in front of the camera");
    let (cx, cy) = (px.x as i32, px.y as i32);
    let mut sum = Vec3::ZERO;
    for dy in -r..=r {
        for dx in -r..=r {
            let x = (cx + dx).clamp(0, frame.width as i32 - 1) as usize;
            let y = (cy + dy).clamp(0, frame.height as i32 - 1) as usize;
            let i = (y * frame.width as usize + x) * 4;
            sum += Vec3::new(frame.hdr[i], frame.hdr[i + 1], frame.hdr[i + 2]);
        }
    }
    sum / ((2 * r + 1) * (2 * r + 1)) as f32
}

fn assert_finite_and_non_negative(frame: &FrameImage, what: &str) {
    let bad = frame
        .hdr
        .iter()
        .filter(|v| !v.is_finite() || **v < 0.0)
        .count();
    assert_eq!(
        bad, 0,
        "{what}: {bad} NaN, infinite or negative radiance values"
    );
}

fn ran(frame: &FrameImage, pass: &str) -> bool {
    frame.stats.passes_run.iter().any(|p| p == pass)
}

#[test]
fn glass_sphere_shows_its_surroundings_instead_of_black() {
    let scene = bundled::resolve(Some("glass-sphere")).expect("bundled scene");
    for method in [Method::Ispm, Method::Direct] {
        let frames = render(&scene, method, 1);
        let frame = &frames[0];
        let path = save(&format!("glass_sphere_{method:?}"), frame);
        assert_finite_and_non_negative(frame, "glass-sphere");
        assert!(
            ran(frame, "environment") && ran(frame, "translucent"),
            "passes run: {:?}",
            frame.stats.passes_run
        );
        let glass = radiance_at(&scene, frame, Vec3::new(0.0, 0.5, 0.0), 6);
        let floor = radiance_at(&scene, frame, Vec3::new(0.0, 0.0, 0.9), 2);
        assert!(
            floor.length() > 0.05,
            "lit floor {floor} ({})",
            path.display()
        );
        assert!(
            glass.length() > 0.1 * floor.length(),
            "{method:?}: glass sphere {glass} vs lit floor {floor} ({})",
            path.display()
        );
    }
}

#[test]
fn caustic_ring_mirror_reflects_the_floor() {
    let scene = bundled::resolve(Some("caustic-ring")).expect("bundled scene");
    let frames = render(&scene, Method::Ispm, 1);
    let frame = &frames[0];
    let path = save("caustic_ring_mirror", frame);
    assert_finite_and_non_negative(frame, "caustic-ring");
    assert!(ran(frame, "translucent"), "{:?}", frame.stats.passes_run);
    // The ring (radius 0.5, 0.2 high, at the origin) halfway up its wall, all the way round.
    let steps = 24;
    let ring: Vec3 = (0..steps)
        .map(|i| {
            let a = i as f32 / steps as f32 * std::f32::consts::TAU;
            radiance_at(
                &scene,
                frame,
                Vec3::new(0.5 * a.cos(), 0.1, 0.5 * a.sin()),
                0,
            )
        })
        .sum::<Vec3>()
        / steps as f32;
    let floor = radiance_at(&scene, frame, Vec3::new(0.9, 0.0, 0.6), 2);
    assert!(
        ring.length() > 0.1 * floor.length(),
        "mirror ring {ring} vs floor {floor} ({})",
        path.display()
    );
}

#[test]
fn environment_map_is_rendered_once_and_reused() {
    let scene = bundled::resolve(Some("caustic-ring")).expect("bundled scene");
    let frames = render(&scene, Method::Direct, 2);
    assert!(ran(&frames[0], "environment"), "{:?}", frames[0].stats);
    assert!(
        !ran(&frames[1], "environment") && ran(&frames[1], "translucent"),
        "second frame: {:?}",
        frames[1].stats.passes_run
    );
    assert_eq!(
        frames[0].hdr, frames[1].hdr,
        "the cached cube map renders the same frame"
    );
}

#[test]
fn scene_without_delta_materials_runs_no_translucent_pass() {
    let scene = ispm::reference::scenes::grey_box(0.5, 1.0);
    for method in [Method::Ispm, Method::Direct] {
        let frames = render(&scene, method, 1);
        let frame = &frames[0];
        assert_finite_and_non_negative(frame, "grey box");
        assert!(
            !ran(frame, "translucent") && !ran(frame, "environment"),
            "{method:?}: passes run: {:?}",
            frame.stats.passes_run
        );
        assert!(ran(frame, "direct"), "{:?}", frame.stats.passes_run);
    }
}
