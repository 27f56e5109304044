//! glTF animations (no GPU): authored files load into `Scene::animations`, `Scene::pose_at`
//! interpolates (STEP, LINEAR with slerp, CUBICSPLINE) through nested node hierarchies for
//! meshes and lights, the timeline loops, the light orbit turns, the motion bounds cover the
//! whole animation, the effects plan records what moves, and malformed animation data is a
//! one-line error naming the file.

mod common;

use common::animated::{edit_json, glass_on_a_carousel};
use glam::{Mat4, Quat, Vec3};
use ispm::config::settings::RenderSettings;
use ispm::plan::EffectsPlan;
use ispm::scene::authoring::{quad, AnimationChannel, GltfWriter, MaterialSpec};
use ispm::scene::load::load_from_slice;
use ispm::scene::{bundled, Scene};
use serde_json::json;
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, FRAC_PI_8, PI};

const FILE: &str = "carousel.glb";

fn load(glb: &[u8]) -> anyhow::Result<Scene> {
    load_from_slice(glb, FILE, None)
}

fn instance(scene: &Scene, name: &str) -> usize {
    scene
        .instances
        .iter()
        .position(|i| i.name == name)
        .unwrap_or_else(|| panic!("no instance {name}"))
}

fn origin(m: Mat4) -> Vec3 {
    m.transform_point3(Vec3::ZERO)
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

/// Asserts `r` is a one-line error naming [`FILE`] and containing `word`.
fn assert_error(r: anyhow::Result<Scene>, word: &str) {
    let e = match r {
        Ok(_) => panic!("expected an error mentioning {word:?}"),
        Err(e) => format!("{e:#}"),
    };
    assert!(
        e.starts_with(FILE),
        "{e:?} does not start with the file name"
    );
    assert!(e.contains(word), "{e:?} lacks {word:?}");
    assert!(!e.contains('\n'), "{e:?} is not one line");
}

/// A floor and one box whose node carries `channels` (node 1 is the box).
fn one_box(channels: &[(&'static str, &'static str, &[f32], &[f32])]) -> Vec<u8> {
    let mut w = GltfWriter::default();
    let white = w.material(&MaterialSpec::diffuse("white", [0.5; 3]));
    let floor = w.mesh("floor", &quad(Vec3::ZERO, Vec3::Y, 1.0, 1.0), white);
    w.mesh_node("floor", floor, Vec3::ZERO, Quat::IDENTITY);
    let cube = w.mesh(
        "box",
        &ispm::scene::authoring::cuboid(Vec3::splat(0.1)),
        white,
    );
    let node = w.mesh_node("box", cube, Vec3::new(0.0, 0.1, 0.0), Quat::IDENTITY);
    let channels: Vec<AnimationChannel> = channels
        .iter()
        .map(|&(path, interpolation, times, values)| AnimationChannel {
            node,
            path,
            interpolation,
            times,
            values,
        })
        .collect();
    w.animation("box", &channels);
    w.glb()
}

#[test]
fn linear_translation_interpolates_and_step_scale_holds_between_keys() {
    let glb = one_box(&[
        (
            "translation",
            "LINEAR",
            &[0.0, 1.0, 2.0],
            &[0.0, 0.1, 0.0, 2.0, 0.1, 0.0, 2.0, 2.1, 0.0],
        ),
        (
            "scale",
            "STEP",
            &[0.0, 1.0],
            &[1.0, 1.0, 1.0, 3.0, 3.0, 3.0],
        ),
    ]);
    let scene = load(&glb).expect("load");
    let b = instance(&scene, "box");
    assert_eq!(scene.moving_instances(), vec![b], "the floor does not move");
    let at = |t: f32| scene.pose_at(t).instances[b];
    assert!(close(origin(at(0.5)), Vec3::new(1.0, 0.1, 0.0)));
    assert!(close(origin(at(1.5)), Vec3::new(2.0, 1.1, 0.0)));
    let scale = |t: f32| at(t).to_scale_rotation_translation().0;
    assert!(close(scale(0.99), Vec3::ONE), "STEP holds the first key");
    assert!(close(scale(1.0), Vec3::splat(3.0)));
    assert!(close(scale(1.7), Vec3::splat(3.0)));
    // The file is returned posed at t = 0.
    assert!(close(
        origin(scene.instances[b].transform),
        Vec3::new(0.0, 0.1, 0.0)
    ));
}

#[test]
fn timeline_loops_at_the_longest_clip_and_shorter_channels_hold_their_last_key() {
    let glb = one_box(&[
        (
            "translation",
            "LINEAR",
            &[0.0, 2.0],
            &[0.0, 0.0, 0.0, 4.0, 0.0, 0.0],
        ),
        (
            "scale",
            "LINEAR",
            &[0.0, 1.0],
            &[1.0, 1.0, 1.0, 2.0, 2.0, 2.0],
        ),
    ]);
    let scene = load(&glb).expect("load");
    assert_eq!(scene.animations.duration(), 2.0);
    let b = instance(&scene, "box");
    let at = |t: f32| scene.pose_at(t).instances[b];
    assert!(at(2.5).abs_diff_eq(at(0.5), 1e-6), "loops with period 2 s");
    let scale = |t: f32| at(t).to_scale_rotation_translation().0;
    assert!(close(scale(1.5), Vec3::splat(2.0)), "holds its last key");
    assert!(close(origin(at(1.5)), Vec3::new(3.0, 0.0, 0.0)));
}

#[test]
fn rotation_slerps_and_cubic_spline_follows_its_tangents_through_a_nested_hierarchy() {
    let carousel = glass_on_a_carousel();
    let scene = load(&carousel.glb).expect("load");
    let ball = instance(&scene, "ball");
    assert_eq!(scene.moving_instances(), vec![ball]);
    assert_eq!(scene.moving_lights(), vec![0], "the lamp rides the carrier");
    assert_eq!(scene.animations.clips.len(), 1);
    // t = 0.25 s: the carrier has turned π/8 (slerp, a quarter of the way to π/2); the ball's
    // height is the Hermite spline between 0.35 m (out-tangent 1.5 m/s) and 0.6 m (in-tangent
    // 0) at s = 1/2 over dt = 0.5 s: ½·0.35 + ⅛·0.5·1.5 + ½·0.6 = 0.56875 m.
    let local = Vec3::new(0.6, 0.56875, 0.0);
    let at = |t: f32| origin(scene.pose_at(t).instances[ball]);
    assert!(close(at(0.25), Quat::from_rotation_y(FRAC_PI_8) * local));
    // t = 0.5 s: π/4, top of the bob.
    let top = Vec3::new(0.6, 0.6, 0.0);
    assert!(close(at(0.5), Quat::from_rotation_y(FRAC_PI_4) * top));
    // t = 1.5 s: the bob (1 s long) holds its last key while the carrier goes on.
    let rest = Vec3::new(0.6, 0.35, 0.0);
    assert!(close(
        at(1.5),
        Quat::from_rotation_y(3.0 * FRAC_PI_4) * rest
    ));
    // The lamp sits on the axis: its position stays, its direction turns with the carrier.
    let lamp0 = scene.pose_at(0.0).lights[0].clone();
    let lamp1 = scene.pose_at(1.0).lights[0].clone();
    assert!(close(lamp1.position, lamp0.position));
    assert!(close(
        lamp1.direction,
        Quat::from_rotation_y(FRAC_PI_2) * lamp0.direction
    ));
    assert!(lamp0.direction.x > 0.1, "aims off-axis, so the turn shows");
    // The camera is not animated.
    assert_eq!(scene.pose_at(1.0).camera, None);
    assert_eq!(scene.pose_at(1.0).cameras, scene.cameras);
}

#[test]
fn a_posed_scene_keeps_its_animation_and_poses_like_the_original() {
    let scene = load(&glass_on_a_carousel().glb).expect("load");
    let posed = scene.posed(0.7);
    assert_eq!(posed.pose_at(1.3), scene.pose_at(1.3));
    let ball = instance(&scene, "ball");
    assert_eq!(
        posed.instances[ball].transform,
        scene.pose_at(0.7).instances[ball]
    );
    assert_eq!(posed.lights, scene.pose_at(0.7).lights);
    assert_eq!(posed.motion_bounds(), scene.motion_bounds());
}

#[test]
fn motion_bounds_cover_every_pose_and_equal_the_bounds_of_a_static_scene() {
    let ring = bundled::resolve(Some("caustic-ring")).expect("ring");
    assert_eq!(ring.motion_bounds(), ring.bounds());
    let scene = load(&glass_on_a_carousel().glb).expect("load");
    let bounds = scene.motion_bounds();
    for k in 0..200 {
        let posed = scene.posed(k as f32 * 0.0137);
        let b = posed.bounds();
        assert!(
            bounds.min.cmple(b.min).all() && bounds.max.cmpge(b.max).all(),
            "t = {}: {b:?} is outside {bounds:?}",
            k as f32 * 0.0137
        );
    }
    // The ball sweeps a half circle of radius 0.6 about the axis: the envelope reaches past
    // the floor's static extent in +y only (the floor spans ±1.5 in x and z).
    assert!(bounds.max.y > 0.6 + 0.25);
}

#[test]
fn orbit_turns_every_light_about_the_vertical_axis_through_the_centre() {
    let mut ring = bundled::resolve(Some("caustic-ring")).expect("ring");
    let sun = ring.lights[0].clone();
    ring.orbit_lights(4.0).expect("orbit");
    assert!(ring.is_animated());
    assert_eq!(ring.moving_lights(), vec![0]);
    assert!(ring.moving_instances().is_empty());
    let quarter = ring.pose_at(1.0).lights[0].clone();
    assert!(close(
        quarter.direction,
        Quat::from_rotation_y(FRAC_PI_2) * sun.direction
    ));
    let half = ring.pose_at(2.0).lights[0].direction;
    assert!(close(half, Quat::from_rotation_y(PI) * sun.direction));
    assert!((ring.pose_at(4.0).lights[0].direction - sun.direction).length() < 1e-5);
    // The elevation stays: only the azimuth turns.
    assert!((quarter.direction.y - sun.direction.y).abs() < 1e-6);
    // A posed scene orbits from the same rest, not from where it was posed.
    assert_eq!(ring.posed(1.0).pose_at(3.0), ring.pose_at(3.0));
    assert!(ring.orbit_lights(0.0).is_err());
    assert!(ring.orbit_lights(f32::NAN).is_err());
}

#[test]
fn the_effects_plan_records_what_moves_and_that_static_geometry_is_never_rebuilt() {
    let scene = load(&glass_on_a_carousel().glb).expect("load");
    let plan = EffectsPlan::analyse(&scene, &RenderSettings::default(), &scene.camera);
    assert_eq!(plan.motion.instances, vec![instance(&scene, "ball")]);
    assert_eq!(plan.motion.lights, vec![0]);
    let text = plan.to_string();
    let line = text
        .lines()
        .find(|l| l.starts_with("motion: "))
        .expect("a motion line");
    assert!(
        line.starts_with("motion: moving — 1 instance(s) move ('ball')"),
        "{line}"
    );
    assert!(line.contains("never rebuilt"), "{line}");
    let ring = bundled::resolve(Some("caustic-ring")).expect("ring");
    let plan = EffectsPlan::analyse(&ring, &RenderSettings::default(), &ring.camera);
    assert!(!plan.motion.moves());
    assert!(plan
        .to_string()
        .contains("motion: static — nothing is animated"));
}

// ---- malformed animation data --------------------------------------------------------------

#[test]
fn a_channel_naming_a_missing_node_is_an_error_not_a_panic() {
    let glb = edit_json(&glass_on_a_carousel().glb, |d| {
        d["animations"][0]["channels"][0]["target"]["node"] = json!(99);
    });
    assert_error(load(&glb), "targets node 99");
}

#[test]
fn an_unknown_channel_path_is_an_error_not_a_panic() {
    let glb = edit_json(&glass_on_a_carousel().glb, |d| {
        d["animations"][0]["channels"][0]["target"]["path"] = json!("position");
    });
    assert_error(load(&glb), "target.path");
}

#[test]
fn a_missing_sampler_or_unknown_interpolation_is_invalid_gltf() {
    let glb = edit_json(&glass_on_a_carousel().glb, |d| {
        d["animations"][0]["channels"][1]["sampler"] = json!(7);
    });
    assert_error(load(&glb), "invalid glTF");
    let glb = edit_json(&glass_on_a_carousel().glb, |d| {
        d["animations"][0]["samplers"][0]["interpolation"] = json!("QUADRATIC");
    });
    assert_error(load(&glb), "invalid glTF");
}

#[test]
fn keyframe_values_of_the_wrong_count_or_type_are_errors_naming_the_channel() {
    let carousel = glass_on_a_carousel();
    // Two times for three LINEAR values.
    let glb = edit_json(&carousel.glb, |d| {
        let input = d["animations"][0]["samplers"][0]["input"].as_u64().unwrap() as usize;
        d["accessors"][input]["count"] = json!(2);
        d["accessors"][input]["max"] = json!([1.0]);
    });
    assert_error(load(&glb), "3 keyframe values for 2 keyframe times");
    // The bob's VEC3 translations given to the rotation channel.
    let glb = edit_json(&carousel.glb, |d| {
        d["animations"][0]["samplers"][0]["output"] =
            d["animations"][0]["samplers"][1]["output"].clone();
    });
    assert_error(load(&glb), "animation carousel: channel 0");
}

#[test]
fn times_that_do_not_increase_or_are_negative_and_non_finite_values_are_errors() {
    let glb = one_box(&[("translation", "LINEAR", &[0.0, 1.0, 1.0], &[0.0; 9])]);
    assert_error(load(&glb), "increase strictly");
    let glb = one_box(&[("translation", "LINEAR", &[-1.0, 1.0], &[0.0; 6])]);
    assert_error(load(&glb), "≥ 0");
    let glb = one_box(&[(
        "scale",
        "STEP",
        &[0.0, 1.0],
        &[1.0, 1.0, 1.0, f32::NAN, 1.0, 1.0],
    )]);
    assert_error(load(&glb), "non-finite keyframe value");
    let glb = one_box(&[("rotation", "LINEAR", &[0.0], &[0.0; 4])]);
    assert_error(load(&glb), "zero quaternion");
}

#[test]
fn an_animated_node_with_a_matrix_is_an_error() {
    let carousel = glass_on_a_carousel();
    let glb = edit_json(&carousel.glb, |d| {
        let node = &mut d["nodes"][carousel.carrier];
        let node = node.as_object_mut().unwrap();
        node.remove("translation");
        node.remove("rotation");
        node.insert(
            "matrix".into(),
            json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]),
        );
    });
    assert_error(load(&glb), "is animated but has a matrix");
}

#[test]
fn morph_weight_channels_are_ignored_and_the_rest_still_plays() {
    let carousel = glass_on_a_carousel();
    let glb = edit_json(&carousel.glb, |d| {
        let channel = json!({"sampler": 1, "target": {"node": carousel.ball, "path": "weights"}});
        d["animations"][0]["channels"]
            .as_array_mut()
            .unwrap()
            .push(channel);
    });
    let scene = load(&glb).expect("weights are skipped");
    assert_eq!(scene.animations.clips[0].channels.len(), 2);
}

#[test]
fn an_animated_zero_scale_keeps_the_instance_with_an_invertible_transform() {
    let glb = one_box(&[(
        "scale",
        "LINEAR",
        &[0.0, 1.0],
        &[0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
    )]);
    let scene = load(&glb).expect("load");
    let b = instance(&scene, "box");
    let m = scene.pose_at(0.0).instances[b];
    assert!(m.determinant() != 0.0 && m.inverse().is_finite());
}
