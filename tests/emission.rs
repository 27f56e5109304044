//! Emissive surfaces are lights for every method (issue #18), on lavapipe with validation on:
//! - a room lit only by an emissive ceiling panel: ISPM (accumulated frames of area-sample
//!   lights) converges to the path tracer (next-event estimation on the panel): relMSE bounded,
//!   mean within 5 %;
//! - one unit rule: a panel of luminance L (nits, KHR_materials_emissive_strength) and a point
//!   light of intensity I (candela) of the same luminous flux (π·L·A = 4π·I lumens) give a
//!   closed room the same mean irradiance (within 2 %);
//! - the effects plan treats emitters as lights, and says so;
//! - the area samples move every accumulated frame and follow a moving emissive instance.
//!
//! `cargo test --test emission -- --nocapture` prints every measured number.

mod common;

use common::golden::rel_mse;
use glam::{Quat, Vec3};
use ispm::config::settings::{Method, RenderSettings};
use ispm::plan::EffectsPlan;
use ispm::reference::{self, RefSettings};
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::authoring::{cornell_room, cuboid, quad, GltfWriter, MaterialSpec};
use ispm::scene::units::candela_to_watts_per_sr;
use ispm::scene::Scene;

/// Image side of the comparison.
const SIZE: u32 = 64;
/// Light-path bounces of both renderers.
const BOUNCES: u32 = 8;

/// The panel's luminance in nits (emissiveFactor 1 × KHR_materials_emissive_strength).
const PANEL_NITS: f32 = 6830.0;

/// The Cornell room (2 m, open towards the camera) lit only by a 0.5 m × 0.5 m emissive panel
/// 1 cm under the ceiling, facing down, with a white box on the floor casting its soft shadow.
fn panel_room() -> Scene {
    let mut w = GltfWriter::default();
    let white = cornell_room(&mut w, 1.0, Vec3::ZERO);
    let lamp = w.material(&MaterialSpec {
        emission: Some(([1.0, 1.0, 1.0], PANEL_NITS)),
        ..MaterialSpec::diffuse("lamp", [0.75, 0.75, 0.75])
    });
    let panel = w.mesh(
        "panel",
        &quad(Vec3::new(0.0, 1.99, 0.0), Vec3::NEG_Y, 0.25, 0.25),
        lamp,
    );
    w.mesh_node("panel", panel, Vec3::ZERO, Quat::IDENTITY);
    let block = w.mesh("block", &cuboid(Vec3::new(0.3, 0.35, 0.3)), white);
    w.mesh_node(
        "block",
        block,
        Vec3::new(0.3, 0.35, -0.2),
        Quat::from_rotation_y(0.4),
    );
    w.camera(
        "camera",
        Vec3::new(0.0, 1.0, 3.4),
        Vec3::new(0.0, 1.0, 0.0),
        40f32.to_radians(),
    );
    let glb = w.glb();
    // For `ispm render` (the cost measured in docs/overview.md, "Emissive surfaces").
    let file = common::image_dir("emission").join("panel-room.glb");
    std::fs::write(file, &glb).expect("write panel-room.glb");
    ispm::scene::load::load_from_slice(&glb, "panel-room", None).expect("panel room")
}

/// The path tracer's image of `scene` at pixel centres, RGBA.
fn path_traced(scene: &Scene, settings: RefSettings) -> Vec<f32> {
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let image =
        reference::render(scene, Method::PathTrace, &settings, None, &cancel).expect("path trace");
    image
        .pixels
        .iter()
        .flat_map(|p| [p[0], p[1], p[2], 1.0])
        .collect()
}

/// Mean of an RGBA image's RGB.
fn mean(image: &[f32]) -> f64 {
    let sum: f64 = image
        .chunks_exact(4)
        .map(|p| f64::from(p[0] + p[1] + p[2]))
        .sum();
    sum / (3 * image.len() / 4) as f64
}

/// The mean of `frames` accumulated ISPM frames of `scene`.
fn ispm_accumulated(scene: &Scene, frames: u32, method: Method) -> FrameImage {
    let gpu = common::gpu();
    let settings = RenderSettings {
        method,
        photons: 20_000,
        bounces: BOUNCES,
        seed: 1,
        width: SIZE,
        height: SIZE,
        shadow_resolution: 256,
        accumulate: true,
        ..Default::default()
    };
    let mut renderer = Renderer::new(&gpu, scene, settings).expect("renderer");
    for _ in 1..frames {
        renderer.submit_frame().expect("frame");
    }
    let image = renderer.render().expect("render");
    common::assert_validation_clean(&gpu);
    assert_eq!(image.stats.accumulated_frames, frames);
    image
}

fn write_exr(name: &str, image: &[f32]) {
    let pixels = image.chunks_exact(4).map(|p| [p[0], p[1], p[2]]).collect();
    let hdr = reference::HdrImage {
        width: SIZE,
        height: SIZE,
        pixels,
    };
    let path = common::image_dir("emission").join(name);
    hdr.write_exr(&path).expect("write exr");
}

#[test]
fn a_room_lit_only_by_an_emissive_panel_matches_the_path_tracer() {
    let scene = panel_room();
    assert!(scene.lights.is_empty(), "no punctual light");
    let reference = path_traced(
        &scene,
        RefSettings {
            width: SIZE,
            height: SIZE,
            spp: 256,
            jitter: false,
            bounces: BOUNCES,
            seed: 3,
            ..Default::default()
        },
    );
    let frames = 64;
    let ispm = ispm_accumulated(&scene, frames, Method::Ispm);
    write_exr("path-trace.exr", &reference);
    write_exr("ispm.exr", &ispm.hdr);
    let error = rel_mse(&ispm.hdr, &reference);
    let ratio = mean(&ispm.hdr) / mean(&reference);
    eprintln!(
        "panel room {SIZE}², {frames} frames × 4 area samples, 20k photons: relMSE {error:.4}, \
         mean ratio ISPM / path tracer {ratio:.4}"
    );
    assert!((ratio - 1.0).abs() < 0.05, "mean ratio {ratio}");
    assert!(error < 0.05, "relMSE {error}");
    // Without the emitter lighting the room, the ISPM image would be black but for the panel.
    let direct = ispm_accumulated(&scene, 1, Method::Direct);
    assert!(mean(&direct.hdr) > 0.3 * mean(&reference));
}

/// A closed 2 m cube of albedo 0.5, the camera at its centre, with a 0.5 m × 0.5 m panel 1 cm
/// under the ceiling (facing down, albedo 0.5): emissive at `nits`, or dark with a point light
/// of `candela` 0.5 m under the ceiling.
fn closed_room(nits: Option<f32>, candela: Option<f32>) -> Scene {
    let mut w = GltfWriter::default();
    let wall = w.material(&MaterialSpec::diffuse("wall", [0.5; 3]));
    let lamp = w.material(&MaterialSpec {
        emission: nits.map(|n| ([1.0, 1.0, 1.0], n)),
        ..MaterialSpec::diffuse("lamp", [0.5; 3])
    });
    for (name, n) in [
        ("floor", Vec3::Y),
        ("ceiling", Vec3::NEG_Y),
        ("left", Vec3::X),
        ("right", Vec3::NEG_X),
        ("back", Vec3::Z),
        ("front", Vec3::NEG_Z),
    ] {
        let mesh = w.mesh(name, &quad(-n, n, 1.0, 1.0), wall);
        w.mesh_node(name, mesh, Vec3::ZERO, Quat::IDENTITY);
    }
    let panel = w.mesh(
        "panel",
        &quad(Vec3::new(0.0, 0.99, 0.0), Vec3::NEG_Y, 0.25, 0.25),
        lamp,
    );
    w.mesh_node("panel", panel, Vec3::ZERO, Quat::IDENTITY);
    if let Some(cd) = candela {
        w.point(
            "bulb",
            Vec3::new(0.0, 0.5, 0.0),
            [1.0; 3],
            candela_to_watts_per_sr(cd),
        );
    }
    w.camera("camera", Vec3::ZERO, Vec3::NEG_Z, 90f32.to_radians());
    ispm::scene::load::load_from_slice(&w.glb(), "closed-room", None).expect("closed room")
}

/// The mean irradiance over the closed room's six walls, from path-traced views of each wall
/// through a 90° camera at the centre (a wall parallel to the image plane maps linearly onto
/// it, so the pixel mean is the area mean): E = π·(L − L_e)/ρ, the panel's own emission
/// subtracted where the pixel sees it.
fn mean_wall_irradiance(scene: &Scene) -> f64 {
    let size = 32u32;
    let emission = scene
        .materials
        .iter()
        .map(|m| m.emission.x)
        .fold(0.0f32, f32::max);
    let mut sum = 0.0f64;
    let faces = [
        (Vec3::X, Vec3::Y),
        (Vec3::NEG_X, Vec3::Y),
        (Vec3::Y, Vec3::Z),
        (Vec3::NEG_Y, Vec3::Z),
        (Vec3::Z, Vec3::Y),
        (Vec3::NEG_Z, Vec3::Y),
    ];
    for (forward, up) in faces {
        let mut view = scene.clone();
        view.camera.transform =
            glam::camera::rh::view::look_to_mat4(Vec3::ZERO, forward, up).inverse();
        view.camera.yfov = 90f32.to_radians();
        let image = path_traced(
            &view,
            RefSettings {
                width: size,
                height: size,
                spp: 16,
                jitter: false,
                bounces: 12,
                seed: 5,
                ..Default::default()
            },
        );
        for (i, p) in image.chunks_exact(4).enumerate() {
            let (x, y) = (i as u32 % size, i as u32 / size);
            // The pixel centre's ray meets the ceiling at (u, v)·1 m: is it on the panel?
            let (u, v) = (
                (x as f32 + 0.5) / size as f32 * 2.0 - 1.0,
                (y as f32 + 0.5) / size as f32 * 2.0 - 1.0,
            );
            let on_panel = forward == Vec3::Y && u.abs() < 0.25 && v.abs() < 0.25;
            let seen = f64::from(p[0] + p[1] + p[2]) / 3.0;
            let emitted = if on_panel { f64::from(emission) } else { 0.0 };
            sum += (seen - emitted) * std::f64::consts::PI / 0.5;
        }
    }
    sum / f64::from(6 * size * size)
}

#[test]
fn a_panel_and_a_point_light_of_equal_luminous_flux_light_a_room_equally() {
    // 100 cd everywhere: 4π·100 ≈ 1257 lm. The panel (0.25 m², one side): π·L·A lumens, so
    // L = 4·100/0.25 = 1600 nits.
    let candela = 100.0;
    let nits = 4.0 * candela / 0.25;
    let panel = closed_room(Some(nits), None);
    let bulb = closed_room(None, Some(candela));
    // One rule for both: W/sr = cd / 683 and W/(m²·sr) = nits / 683.
    let lamp = panel.materials.iter().find(|m| m.name == "lamp").unwrap();
    assert!((lamp.emission.x - nits / 683.0).abs() < 1e-4 * nits / 683.0);
    assert!((bulb.lights[0].intensity.x - candela / 683.0).abs() < 1e-4 * candela / 683.0);
    let (e_panel, e_bulb) = (mean_wall_irradiance(&panel), mean_wall_irradiance(&bulb));
    // Exact in a closed room of one albedo ρ: every watt emitted reaches the walls 1/(1 − ρ)
    // times, whatever the light's shape (Σ E·A = Φ/(1 − ρ)).
    let expected = f64::from(4.0 * std::f32::consts::PI * candela / 683.0) / (24.0 * 0.5);
    eprintln!(
        "closed room, 1257 lm: mean irradiance panel {e_panel:.4} W/m², point light \
         {e_bulb:.4} W/m², ratio {:.4}; Φ/(A(1 − ρ)) = {expected:.4}",
        e_panel / e_bulb
    );
    assert!(
        (e_panel / e_bulb - 1.0).abs() < 0.02,
        "{e_panel} vs {e_bulb}"
    );
    assert!(
        (e_bulb / expected - 1.0).abs() < 0.03,
        "{e_bulb} vs {expected}"
    );
}

#[test]
fn the_effects_plan_treats_an_emitter_as_a_light() {
    let scene = panel_room();
    let settings = RenderSettings {
        photons: 10_000,
        width: 64,
        height: 64,
        accumulate: true,
        ..Default::default()
    };
    let plan = EffectsPlan::analyse(&scene, &settings, &scene.camera);
    let text = plan.to_string();
    eprintln!("{text}");
    assert!(plan.emitters.needed, "{}", plan.emitters.reason);
    assert!(plan.emitters.reason.contains("'lamp'"), "{text}");
    assert!(plan.indirect.needed, "{}", plan.indirect.reason);
    assert_eq!(plan.lights.len(), 4, "four area samples");
    assert!(
        plan.lights.iter().all(|l| l.direct && l.photons > 0),
        "{text}"
    );
    assert_eq!(
        plan.lights.iter().map(|l| l.photons).sum::<usize>(),
        settings.photons
    );
    assert!(plan.accumulate);
    assert!(text.contains("emissive surfaces as lights: yes"), "{text}");
    let shadows = plan
        .passes()
        .into_iter()
        .find(|p| p.name == ispm::timing::pass_id::PassId::ShadowMaps);
    assert!(shadows.is_some_and(|p| p.run));
    // Direct light alone accumulates too: its shadows are sampled anew every frame.
    let direct = EffectsPlan::analyse(
        &scene,
        &RenderSettings {
            method: Method::Direct,
            ..settings.clone()
        },
        &scene.camera,
    );
    assert!(direct.accumulate && !direct.indirect.needed);
    // A room without emission or lights is unlit, and says why.
    let mut dark = scene.clone();
    dark.materials
        .iter_mut()
        .for_each(|m| m.emission = Vec3::ZERO);
    let plan = EffectsPlan::analyse(&dark, &settings, &dark.camera);
    assert!(!plan.emitters.needed && plan.lights.is_empty());
    assert!(!plan.indirect.needed, "{}", plan.indirect.reason);
}

/// The area-sample lights' positions as the renderer's photon views hold them (world space).
fn area_sample_positions(renderer: &Renderer) -> Vec<Vec3> {
    let plan = renderer.photons().expect("photon part").plan();
    let mut lights: Vec<(usize, Vec3)> = plan
        .views
        .iter()
        .zip(&plan.view_lights)
        .map(|(v, &l)| (l, (v.light.truncate().as_dvec3() + plan.origin).as_vec3()))
        .collect();
    lights.dedup_by_key(|(l, _)| *l);
    lights.into_iter().map(|(_, p)| p).collect()
}

#[test]
fn area_samples_move_every_accumulated_frame_and_follow_a_moving_emitter() {
    let scene = panel_room();
    let gpu = common::gpu();
    let settings = RenderSettings {
        photons: 4_000,
        width: 32,
        height: 32,
        shadow_resolution: 64,
        accumulate: true,
        ..Default::default()
    };
    let mut renderer = Renderer::new(&gpu, &scene, settings).expect("renderer");
    let on_panel = |p: Vec3, dx: f32| {
        (p.x - dx).abs() <= 0.25 && p.z.abs() <= 0.25 && (p.y - 1.99).abs() < 1e-2 && p.y < 1.99
    };
    renderer.render().expect("frame 0");
    let first = area_sample_positions(&renderer);
    assert_eq!(first.len(), 4);
    assert!(first.iter().all(|&p| on_panel(p, 0.0)), "{first:?}");
    renderer.render().expect("frame 1");
    let second = area_sample_positions(&renderer);
    assert!(second.iter().all(|&p| on_panel(p, 0.0)), "{second:?}");
    assert!(first.iter().zip(&second).all(|(a, b)| a != b), "new points");
    // The panel moves 0.4 m along x: the accumulation restarts with points on it there.
    let panel = scene.instances.iter().position(|i| i.name == "panel");
    let mut transforms = renderer.instance_transforms();
    transforms[panel.expect("panel")] *= glam::Mat4::from_translation(Vec3::new(0.4, 0.0, 0.0));
    renderer.set_instance_transforms(&transforms).expect("move");
    let moved = renderer.render().expect("frame after the move");
    assert_eq!(moved.stats.accumulated_frames, 1);
    let third = area_sample_positions(&renderer);
    assert!(third.iter().all(|&p| on_panel(p, 0.4)), "{third:?}");
    common::assert_validation_clean(&gpu);
}
