//! Motion through the renderer (headless, lavapipe, validation and synchronization validation
//! on): an orbiting light moves `caustic-ring`'s caustic while the floor's direct light where
//! no shadow can reach stays put; an animated glTF's frame k equals a fresh renderer made with
//! the scene posed at frame k's time, every frame after a move re-traces the photons, and the
//! static BVH is never rebuilt.

mod common;

use common::animated::glass_on_a_carousel;
use glam::{Mat4, Vec2, Vec3, Vec3Swizzles};
use ispm::config::settings::RenderSettings;
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::load::load_from_slice;
use ispm::scene::{bundled, Camera, Scene, FRAME_STEP_SECONDS};

fn bits(frame: &FrameImage) -> Vec<u32> {
    frame.hdr.iter().map(|v| v.to_bits()).collect()
}

fn luminance(rgb: &[f32]) -> f32 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// The centroid of the brightest `fraction` of the pixels (by luminance).
fn bright_centroid(rgba: &[f32], width: u32, fraction: f32) -> Vec2 {
    let mut l: Vec<(f32, usize)> = rgba
        .chunks_exact(4)
        .enumerate()
        .map(|(i, p)| (luminance(p), i))
        .collect();
    l.sort_by(|a, b| b.0.total_cmp(&a.0));
    let n = ((l.len() as f32 * fraction) as usize).max(1);
    let sum: Vec2 = l[..n]
        .iter()
        .map(|&(_, i)| {
            Vec2::new(
                (i as u32 % width) as f32 + 0.5,
                (i as u32 / width) as f32 + 0.5,
            )
        })
        .sum();
    sum / n as f32
}

/// Where the ray through the centre of pixel `i` meets the plane y = 0, if it does.
fn floor_point(camera: &Camera, i: usize, width: u32, height: u32) -> Option<Vec3> {
    let (x, y) = (
        (i as u32 % width) as f32 + 0.5,
        (i as u32 / width) as f32 + 0.5,
    );
    let t = (camera.yfov * 0.5).tan();
    let aspect = width as f32 / height as f32;
    let ndc = Vec2::new(x / width as f32 * 2.0 - 1.0, 1.0 - y / height as f32 * 2.0);
    let local = Vec3::new(ndc.x * t * aspect, ndc.y * t, -1.0);
    let dir = camera.transform.transform_vector3(local);
    let eye = camera.position();
    (dir.y < 0.0).then(|| eye + dir * (-eye.y / dir.y))
}

#[test]
fn orbiting_light_moves_the_ring_caustic_and_leaves_unshadowable_floor_light_steady() {
    let gpu = common::gpu();
    let mut scene = bundled::resolve(Some("caustic-ring")).expect("scene");
    // Half a turn in 120 frames.
    scene
        .orbit_lights(240.0 * FRAME_STEP_SECONDS)
        .expect("orbit");
    let settings = RenderSettings {
        photons: 4_000,
        width: 64,
        height: 64,
        shadow_resolution: 256,
        ..Default::default()
    };
    let (w, h) = (settings.width, settings.height);
    let mut renderer = Renderer::new(&gpu, &scene, settings).expect("renderer");
    // Floor pixels farther from the ring's axis than any shadow of it reaches: the sun is 20°
    // high and the ring (radius 0.5, 15 mm thick) 0.2 m tall, so its shadow ends within
    // 0.5075 + 0.2 / tan 20° = 1.057 m; 0.1 m more for shadow-map filtering.
    let reach = 0.5075 + 0.2 / 20f32.to_radians().tan() + 0.1;
    let far: Vec<usize> = (0..(w * h) as usize)
        .filter(|&i| {
            floor_point(&scene.camera, i, w, h)
                .is_some_and(|p| p.x.abs() < 1.95 && p.z.abs() < 1.95 && p.xz().length() > reach)
        })
        .collect();
    assert!(far.len() > 200, "only {} far floor pixels", far.len());

    let samples = [0, 40, 80, 119];
    let mut caustic = Vec::new();
    let mut ldr = Vec::new();
    let mut direct_far: Vec<Vec<f32>> = Vec::new();
    for i in 0..120 {
        let t = i as f32 * FRAME_STEP_SECONDS;
        renderer.set_pose(&scene.pose_at(t)).expect("pose");
        if !samples.contains(&i) {
            renderer.submit_frame().expect("frame");
            continue;
        }
        let frame = renderer.render().expect("frame");
        assert!(frame.stats.cpu_trace_ms > 0.0, "frame {i} re-traces");
        let indirect = renderer
            .photons()
            .expect("ispm")
            .read_indirect()
            .expect("read");
        // The caustic: the brightest 2 % of the indirect image (the cardioid's cusp and the
        // reflections just outside the ring; the smooth indirect light is far dimmer).
        caustic.push(bright_centroid(&indirect, w, 0.02));
        ldr.push(frame.ldr);
        direct_far.push(
            far.iter()
                .map(|&p| {
                    let (hdr, ind) = (&frame.hdr[4 * p..4 * p + 3], &indirect[4 * p..4 * p + 3]);
                    luminance(&[hdr[0] - ind[0], hdr[1] - ind[1], hdr[2] - ind[2]])
                })
                .collect(),
        );
    }
    common::assert_validation_clean(&gpu);
    let moved: Vec<f32> = caustic.iter().map(|c| c.distance(caustic[0])).collect();
    let flicker = direct_far
        .iter()
        .map(|d| {
            d.iter()
                .zip(&direct_far[0])
                .map(|(a, b)| (a - b).abs() / b.abs().max(1e-6))
                .fold(0.0, f32::max)
        })
        .fold(0.0, f32::max);
    println!(
        "caustic (brightest 2 %) centroid {caustic:?}, moved {moved:?} px; far floor ({} px) direct light: max \
         relative change {flicker:e}",
        far.len()
    );
    let failed =
        !(moved[3] > 15.0 && moved[1] < moved[2] && moved[2] < moved[3]) || flicker >= 1e-5;
    if failed {
        let dir = common::image_dir("orbiting_light");
        for (i, image) in samples.iter().zip(&ldr) {
            let path = dir.join(format!("frame{i}.png"));
            image::save_buffer(path, image, w, h, image::ColorType::Rgba8).expect("png");
        }
    }
    // Half a turn of the sun turns the cardioid half way about the ring's axis: its centroid
    // moves away from where it started at every sample, and 15 px at least (it measured 30.7
    // px on a 64-px image).
    assert!(moved[3] > 15.0, "the caustic moved only {} px", moved[3]);
    assert!(moved[1] < moved[2] && moved[2] < moved[3], "{moved:?}");
    // Where no shadow reaches, the sun's irradiance E·sin 20° does not depend on its azimuth:
    // relative change below 1e-5 (it measured 6e-8, float rounding of the turned direction).
    assert!(flicker < 1e-5, "direct light flickers by {flicker:e}");
}

/// Loads the carousel (see `common::animated`).
fn carousel() -> Scene {
    load_from_slice(&glass_on_a_carousel().glb, "carousel.glb", None).expect("carousel")
}

fn small() -> RenderSettings {
    RenderSettings {
        photons: 3_000,
        width: 64,
        height: 64,
        shadow_resolution: 128,
        ..Default::default()
    }
}

#[test]
fn animated_gltf_frame_k_equals_a_fresh_renderer_posed_at_its_time_and_every_move_retraces() {
    let gpu = common::gpu();
    let scene = carousel();
    let mut renderer = Renderer::new(&gpu, &scene, small()).expect("renderer");
    const K: usize = 12;
    let t = |i: usize| i as f32 * FRAME_STEP_SECONDS * 5.0;
    for i in 0..K {
        renderer.set_pose(&scene.pose_at(t(i))).expect("pose");
        renderer.submit_frame().expect("frame");
    }
    renderer.set_pose(&scene.pose_at(t(K))).expect("pose");
    let moving = renderer.render().expect("frame k");
    let stats = &moving.stats;
    assert!(stats.cpu_trace_ms > 0.0 && stats.stored_photons > 0);
    assert!(stats.passes_run.iter().any(|p| p == "bounce_map"));
    assert!(!stats.passes_skipped.iter().any(|p| p.name == "cpu_trace"));
    let bvh = renderer.photons().expect("ispm").bvh();
    assert_eq!(bvh.static_builds(), 1, "the static BVH was rebuilt");

    let posed = scene.posed(t(K));
    let fresh = Renderer::new(&gpu, &posed, small())
        .expect("fresh")
        .render()
        .expect("fresh frame");
    common::assert_validation_clean(&gpu);
    assert_eq!(stats.stored_photons, fresh.stats.stored_photons);
    assert!(
        bits(&moving) == bits(&fresh),
        "frame {K} of the moving renderer differs from a renderer made at t = {}",
        t(K)
    );
    // The ball really moved: the first frame is another image.
    let first = Renderer::new(&gpu, &scene, small())
        .expect("first")
        .render()
        .expect("first frame");
    assert!(bits(&first) != bits(&fresh), "nothing moved");

    // The same pose again: nothing moved, the photon map is reused.
    renderer.set_pose(&scene.pose_at(t(K))).expect("pose");
    let again = renderer.render().expect("again");
    let reused = again
        .stats
        .passes_skipped
        .iter()
        .find(|p| p.name == "cpu_trace")
        .expect("trace skipped");
    assert!(reused.reason.contains("reused"), "{}", reused.reason);
    assert!(bits(&again) == bits(&moving));
    common::assert_validation_clean(&gpu);
}

#[test]
fn bad_instance_transforms_are_refused_and_change_nothing() {
    let gpu = common::gpu();
    let scene = carousel();
    let mut renderer = Renderer::new(&gpu, &scene, small()).expect("renderer");
    let before = renderer.instance_transforms();
    let err = renderer
        .set_instance_transforms(&before[1..])
        .unwrap_err()
        .to_string();
    assert!(err.contains("instance transforms given"), "{err}");
    let mut singular = before.clone();
    singular[0] = Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0));
    let err = renderer
        .set_instance_transforms(&singular)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("'floor'") && err.contains("invertible"),
        "{err}"
    );
    assert_eq!(renderer.instance_transforms(), before);
    // A static instance may move too: the static BVH is rebuilt once, without it.
    let mut moved = before.clone();
    moved[0] = Mat4::from_translation(Vec3::new(0.0, -0.01, 0.0)) * before[0];
    renderer
        .set_instance_transforms(&moved)
        .expect("move floor");
    let frame = renderer.render().expect("frame");
    assert!(frame.stats.cpu_trace_ms > 0.0);
    assert_eq!(renderer.photons().expect("ispm").bvh().static_builds(), 2);
    common::assert_validation_clean(&gpu);
}
