//! Per-light photon reuse (issue #9), on lavapipe with validation (synchronization validation
//! included) on: moving one light re-traces that light's photons only, keeps the others' bit for
//! bit, and renders the image a fresh renderer renders for the moved light; moving geometry or
//! changing a light's power re-traces every light whose photons it changes.

mod common;

use glam::{Mat4, Vec3};
use ispm::config::settings::Effects;
use ispm::config::settings::RenderSettings;
use ispm::layout::shared_constants::BOUNCE_VIEW_CAUSTIC;
use ispm::photon::types::{unpack_normal, Photon};
use ispm::reference::scenes::{cornell, point_light};
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::{Light, Material, Scene};

fn settings(effects: Effects) -> RenderSettings {
    common::small_ispm_settings(effects)
}

/// The Cornell box with a second, dimmer point light low in the left front corner.
fn two_lights() -> Scene {
    let mut scene = cornell(1);
    let mut second = point_light(Vec3::new(-0.5, 0.2, 0.4), Vec3::splat(1.0));
    second.name = "corner".into();
    scene.lights[0].name = "ceiling".into();
    scene.lights.push(second);
    scene
}

fn bits(frame: &FrameImage) -> &[u8] {
    bytemuck::cast_slice(&frame.hdr)
}

fn photon_bits(photons: &[Photon]) -> Vec<u8> {
    bytemuck::cast_slice(photons).to_vec()
}

/// Light `light`'s photons in `r`'s last photon map (bit patterns) and its bounce-map photons.
fn light_photons(r: &Renderer, light: usize) -> (Vec<u8>, usize) {
    let (photons, starts) = r.photons().expect("photon part").light_photons(light);
    (photon_bits(photons), starts)
}

fn reused(frame: &FrameImage) -> Vec<usize> {
    frame.stats.lights_reused.iter().map(|l| l.light).collect()
}

/// Per light: its photons (bit patterns) and its bounce-map photons.
type LightsPhotons = Vec<(Vec<u8>, usize)>;

/// A fresh renderer's first frame of `scene`, and its per-light photons.
fn fresh(scene: &Scene) -> (FrameImage, LightsPhotons) {
    let (frame, lights, _) = fresh_with_bounce_map(scene);
    (frame, lights)
}

/// [`fresh`], and the renderer's bounce map (bit patterns).
fn fresh_with_bounce_map(scene: &Scene) -> (FrameImage, LightsPhotons, Vec<u8>) {
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, scene, settings(Effects::Auto)).expect("renderer");
    let frame = r.render().expect("render");
    let lights = (0..scene.lights.len())
        .map(|l| light_photons(&r, l))
        .collect();
    let bounce_map = bounce_map_bits(&r);
    drop(r);
    common::assert_validation_clean(&gpu);
    (frame, lights, bounce_map)
}

fn bounce_map_bits(r: &Renderer) -> Vec<u8> {
    bytemuck::cast_slice(r.photons().expect("photon part").bounce_map()).to_vec()
}

/// `r`'s last frame against a fresh renderer's first frame of `scene`, bit for bit: the image,
/// every light's photons and bounce-map photons, and the bounce map.
fn assert_as_fresh(r: &Renderer, frame: &FrameImage, scene: &Scene) {
    let lights: Vec<_> = (0..scene.lights.len())
        .map(|l| light_photons(r, l))
        .collect();
    let bounce_map = bounce_map_bits(r);
    let (expected, expected_lights, expected_bounce_map) = fresh_with_bounce_map(scene);
    for (l, (got, want)) in lights.iter().zip(&expected_lights).enumerate() {
        assert!(
            got == want,
            "light {l}'s photons differ from a fresh renderer's ({} vs {} bytes, {} vs {} starts)",
            got.0.len(),
            want.0.len(),
            got.1,
            want.1
        );
    }
    assert!(
        bounce_map == expected_bounce_map,
        "bounce map differs from a fresh renderer's"
    );
    assert!(
        bits(frame) == bits(&expected),
        "image differs from a fresh renderer's"
    );
}

fn moved(lights: &[Light], light: usize, by: Vec3) -> Vec<Light> {
    let mut moved = lights.to_vec();
    moved[light].position += by;
    moved
}

#[test]
fn moving_one_light_retraces_only_that_light() {
    let scene = two_lights();
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, &scene, settings(Effects::Auto)).expect("renderer");
    let first = r.render().expect("frame 0");
    assert_eq!(first.stats.lights_retraced, vec![0, 1]);
    assert!(first.stats.lights_reused.is_empty());
    assert_eq!(
        first.stats.traced_bounce_map_photons,
        first.stats.bounce_map_photons
    );
    let (light0, starts0) = light_photons(&r, 0);
    let (light1, _) = light_photons(&r, 1);

    let lights = moved(&scene.lights, 1, Vec3::new(0.25, -0.05, -0.2));
    r.set_lights(&lights).expect("move light 1");
    let second = r.render().expect("frame 1");
    let s = &second.stats;
    assert_eq!(s.lights_retraced, vec![1], "{:?}", s.lights_reused);
    assert_eq!(reused(&second), vec![0]);
    let reason = &s.lights_reused[0].reason;
    assert!(
        reason.contains("light 0 (ceiling) unchanged"),
        "reason: {reason}"
    );
    // The moved light's views ran on the GPU, and the CPU traced its bounce-map photons only.
    for pass in ["light_gbuffers", "bounce_map", "readback", "upload"] {
        assert!(s.passes_run.iter().any(|p| p == pass), "{pass} did not run");
    }
    assert!(s.cpu_trace_ms > 0.0);
    let (light0_now, starts0_now) = light_photons(&r, 0);
    let (light1_now, starts1_now) = light_photons(&r, 1);
    assert_eq!(s.traced_bounce_map_photons, starts1_now);
    assert_eq!(s.bounce_map_photons, starts0 + starts1_now);
    assert!(
        s.traced_bounce_map_photons < s.bounce_map_photons && starts0 > 0,
        "{} of {} traced",
        s.traced_bounce_map_photons,
        s.bounce_map_photons
    );
    assert!(light0_now == light0 && starts0_now == starts0);
    let json = ispm::render::stats::frame_json(&scene, &second, r.triangles(), 8, 0);
    assert_eq!(json["lights_retraced"], serde_json::json!([1]), "{json}");
    assert_eq!(json["lights_reused"][0]["light"], 0, "{json}");
    assert_eq!(json["traced_bounce_map_photons"], starts1_now, "{json}");
    assert!(light1_now != light1, "light 1 moved, its photons did not");
    drop(r);
    common::assert_validation_clean(&gpu);

    // What a fresh renderer makes for the moved light, bit for bit: the bounce map, each
    // light's photons, the image.
    let mut moved_scene = scene.clone();
    moved_scene.lights = lights;
    let (expected, expected_lights) = fresh(&moved_scene);
    assert!(expected_lights[0] == (light0_now, starts0_now), "light 0");
    assert!(expected_lights[1] == (light1_now, starts1_now), "light 1");
    assert!(
        bits(&second) == bits(&expected),
        "image differs from a fresh renderer's"
    );
    assert!(
        bits(&second) != bits(&first),
        "moving light 1 changed nothing"
    );
}

#[test]
fn the_unmoved_lights_photons_are_kept_bit_for_bit_after_the_moved_ones() {
    // The first light moves: the second's photons are kept, and follow the first's new ones in
    // the photon map (light order).
    let scene = two_lights();
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, &scene, settings(Effects::Auto)).expect("renderer");
    r.render().expect("frame 0");
    let before = r.photons().expect("photon part").photon_map();
    let (light1, starts1) = light_photons(&r, 1);
    let n0 = r.photons().expect("photon part").light_photons(0).0.len();

    r.set_lights(&moved(&scene.lights, 0, Vec3::new(-0.2, -0.1, 0.15)))
        .expect("move light 0");
    let second = r.render().expect("frame 1");
    assert_eq!(second.stats.lights_retraced, vec![0]);
    assert_eq!(reused(&second), vec![1]);
    let photons = r.photons().expect("photon part");
    let after = photons.photon_map();
    let n0_now = photons.light_photons(0).0.len();
    assert_eq!(after.len(), n0_now + light1.len() / size_of::<Photon>());
    assert!(
        light_photons(&r, 1).0 == light1,
        "light 1's photons changed"
    );
    // In the photon map as drawn they follow light 0's new ones, the same records but for
    // their normals' length: the kNN radius, measured over every light's photons (light 0's
    // moved; `assert_as_fresh` below finds the image a fresh renderer's).
    let (kept_before, kept_after) = (&before[n0..], &after[n0_now..]);
    assert_eq!(kept_before.len(), kept_after.len());
    for (a, b) in kept_before.iter().zip(kept_after) {
        let same =
            |v: Vec3, w: Vec3| v.to_array().map(f32::to_bits) == w.to_array().map(f32::to_bits);
        assert!(
            same(a.power, b.power)
                && same(a.direction, b.direction)
                && same(a.position, b.position),
            "light 1's drawn photon changed: {a:?} → {b:?}"
        );
        let (na, nb) = (unpack_normal(a.normal).0, unpack_normal(b.normal).0);
        assert!(na.distance(nb) < 1e-6, "{a:?} → {b:?}");
    }
    assert!(
        photon_bits(&after[..n0_now]) != photon_bits(&before[..n0]),
        "light 0 moved, its photons did not"
    );
    assert_eq!(
        second.stats.traced_bounce_map_photons,
        photons.light_photons(0).1
    );
    assert_eq!(photons.light_photons(1).1, starts1);
    let mut moved_scene = scene.clone();
    moved_scene.lights = moved(&scene.lights, 0, Vec3::new(-0.2, -0.1, 0.15));
    // Light 1's bounce-map records in the same place, and the whole bounce map as a fresh
    // renderer's.
    assert_as_fresh(&r, &second, &moved_scene);
    drop(r);
    common::assert_validation_clean(&gpu);
}

#[test]
fn moving_two_non_adjacent_lights_retraces_both_and_matches_a_fresh_renderer() {
    // Lights 0 and 2 move, light 1 (between them) is kept: two bounce-map dispatches and two
    // readback ranges, the second starting after a gap.
    let frame = move_lights_0_and_2(settings(Effects::Auto));
    assert_eq!(frame.stats.bounce_map_buffers, 1);
}

#[test]
fn with_the_bounce_map_split_over_buffers_moving_two_lights_matches_an_unsplit_fresh_renderer() {
    // The same over a bounce map of buffers of 700 records (views straddle them): the moved
    // lights' records are written and read back buffer by buffer around the kept light's, bit
    // for bit as a fresh renderer with the map in one buffer makes them.
    let frame = move_lights_0_and_2(RenderSettings {
        storage_buffer_range: Some(700 * 32),
        ..settings(Effects::Auto)
    });
    let (records, buffers) = (frame.stats.emitted_photons, frame.stats.bounce_map_buffers);
    eprintln!("{records} records in {buffers} buffers");
    assert!(buffers >= 4, "{records} records in {buffers} buffers");
    assert_eq!(buffers, records.div_ceil(700));
}

/// Three lights with `settings`; lights 0 and 2 move, and the second frame is checked against a
/// fresh (unsplit) renderer's. Returns the second frame.
fn move_lights_0_and_2(settings: RenderSettings) -> FrameImage {
    let mut scene = two_lights();
    let mut third = point_light(Vec3::new(0.5, 0.3, -0.3), Vec3::splat(0.8));
    third.name = "back".into();
    scene.lights.push(third);
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, &scene, settings).expect("renderer");
    r.render().expect("frame 0");
    let kept = light_photons(&r, 1);
    let lights = moved(
        &moved(&scene.lights, 0, Vec3::new(-0.15, -0.1, 0.1)),
        2,
        Vec3::new(-0.2, 0.1, 0.2),
    );
    r.set_lights(&lights).expect("move lights 0 and 2");
    let second = r.render().expect("frame 1");
    assert_eq!(second.stats.lights_retraced, vec![0, 2]);
    assert_eq!(reused(&second), vec![1]);
    assert!(light_photons(&r, 1) == kept, "light 1's photons changed");
    let plan = r.photons().expect("photon part").plan();
    assert!(
        plan.light_views(2).start > plan.light_views(0).end,
        "no gap between lights 0 and 2"
    );
    let mut moved_scene = scene.clone();
    moved_scene.lights = lights;
    assert_as_fresh(&r, &second, &moved_scene);
    drop(r);
    common::assert_validation_clean(&gpu);
    second
}

#[test]
fn moving_an_instance_retraces_every_light() {
    let scene = two_lights();
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, &scene, settings(Effects::Auto)).expect("renderer");
    let first = r.render().expect("frame 0");
    let mut transforms = r.instance_transforms();
    let sphere = transforms.len() - 1;
    transforms[sphere] = Mat4::from_translation(Vec3::new(-0.3, 0.0, 0.1)) * transforms[sphere];
    r.set_instance_transforms(&transforms)
        .expect("move the sphere");
    let second = r.render().expect("frame 1");
    assert_eq!(second.stats.lights_retraced, vec![0, 1]);
    assert!(second.stats.lights_reused.is_empty());
    assert_eq!(
        second.stats.traced_bounce_map_photons,
        second.stats.bounce_map_photons
    );
    assert!(
        bits(&second) != bits(&first),
        "moving the sphere changed nothing"
    );
    // And the next frame reuses every light's photons again.
    let third = r.render().expect("frame 2");
    assert!(third.stats.lights_retraced.is_empty());
    assert_eq!(reused(&third), vec![0, 1]);
    assert!(bits(&third) == bits(&second));
    drop(r);
    common::assert_validation_clean(&gpu);
}

#[test]
fn changing_a_lights_power_retraces_every_light_whose_budget_shifts() {
    // The budget is split by power (N_L = N·Φ_L/Φ_total): doubling light 1 gives it more
    // photons and light 0 fewer, so both lights' views change size and both are re-traced.
    let scene = two_lights();
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, &scene, settings(Effects::Auto)).expect("renderer");
    r.render().expect("frame 0");
    let extents0 = {
        let plan = r.photons().expect("photon part").plan();
        plan.extents[plan.light_views(0)].to_vec()
    };
    let mut lights = scene.lights.clone();
    lights[1].intensity *= 2.0;
    r.set_lights(&lights).expect("brighter light 1");
    let second = r.render().expect("frame 1");
    let plan = r.photons().expect("photon part").plan();
    assert_ne!(
        plan.extents[plan.light_views(0)],
        extents0[..],
        "light 0's budget"
    );
    assert_eq!(second.stats.lights_retraced, vec![0, 1]);
    assert!(second.stats.lights_reused.is_empty());
    drop(r);
    common::assert_validation_clean(&gpu);
    let mut brighter = scene.clone();
    brighter.lights = lights;
    let (expected, _) = fresh(&brighter);
    assert!(
        bits(&second) == bits(&expected),
        "image differs from a fresh renderer's"
    );
}

#[test]
fn effects_all_retraces_every_light_when_one_moves() {
    let scene = two_lights();
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, &scene, settings(Effects::All)).expect("renderer");
    r.render().expect("frame 0");
    r.set_lights(&moved(&scene.lights, 1, Vec3::new(0.1, 0.0, 0.0)))
        .expect("move light 1");
    let second = r.render().expect("frame 1");
    assert_eq!(second.stats.lights_retraced, vec![0, 1]);
    assert!(second.stats.lights_reused.is_empty());
    drop(r);
    common::assert_validation_clean(&gpu);
}

#[test]
fn a_change_that_moves_no_lights_views_retraces_nothing_and_uploads_the_kept_map() {
    // Moving a light that is switched off (zero power: the plan gives it no views) changes the
    // lights (the photon map is not reused whole) but no light's views: every light's photons
    // are kept, nothing is drawn, read back or traced.
    let mut scene = two_lights();
    let mut off = point_light(Vec3::new(0.3, 0.5, 0.0), Vec3::ZERO);
    off.name = "off".into();
    scene.lights.push(off);
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, &scene, settings(Effects::Auto)).expect("renderer");
    let first = r.render().expect("frame 0");
    let off_moved = moved(&scene.lights, 2, Vec3::new(-0.2, 0.0, 0.1));
    r.set_lights(&off_moved)
        .expect("move the light that is off");
    let second = r.render().expect("frame 1");
    let s = &second.stats;
    assert!(s.lights_retraced.is_empty(), "{:?}", s.lights_retraced);
    assert_eq!(reused(&second), vec![0, 1]);
    assert!(s.lights_reused[0]
        .reason
        .contains("light 0 (ceiling) unchanged"));
    for pass in ["light_gbuffers", "bounce_map", "readback", "cpu_trace"] {
        assert!(!s.passes_run.iter().any(|p| p == pass), "{pass} ran");
        assert!(
            s.passes_skipped.iter().any(|p| p.name == pass),
            "{pass} not listed as skipped: {:?}",
            s.passes_skipped
        );
    }
    assert!(s.passes_run.iter().any(|p| p == "upload"));
    assert_eq!(s.stored_photons, first.stats.stored_photons);
    assert!(
        bits(&second) == bits(&first),
        "the kept photon map changed the image"
    );
    // Then a light moves again: traced from the kept records.
    r.set_lights(&moved(&off_moved, 1, Vec3::new(0.1, 0.0, 0.0)))
        .expect("move light 1");
    let third = r.render().expect("frame 2");
    assert_eq!(third.stats.lights_retraced, vec![1]);
    // A new name is a new light to the random numbers (they are keyed by the light's name,
    // `bounce_plan::light_seed`, not its position): that light alone is traced again.
    let mut renamed = moved(&off_moved, 1, Vec3::new(0.1, 0.0, 0.0));
    renamed[0].name = "lamp".into();
    r.set_lights(&renamed).expect("rename light 0");
    let fourth = r.render().expect("frame 3");
    assert_eq!(fourth.stats.lights_retraced, vec![0]);
    drop(r);
    common::assert_validation_clean(&gpu);
}

/// [`two_lights`] with a mirror sphere: every light gets caustic views around it.
fn mirror_ball() -> Scene {
    let mut scene = two_lights();
    scene.materials.push(Material {
        name: "mirror".into(),
        lambertian: Vec3::ZERO,
        glossy: Vec3::ONE,
        exponent: f32::INFINITY,
        ..Material::default()
    });
    let sphere = scene.meshes.len() - 1;
    scene.meshes[sphere].material = scene.materials.len() - 1;
    scene
}

#[test]
fn with_a_mirror_ball_moving_the_first_light_shifts_the_later_lights_records_as_a_fresh_renderer() {
    // Light 0 moves: its caustic window changes size, so light 1's views (after light 0's)
    // move to other bounce-map records, and light 1 is re-traced with them.
    let scene = mirror_ball();
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, &scene, settings(Effects::Auto)).expect("renderer");
    r.render().expect("frame 0");
    let texels1 = {
        let plan = r.photons().expect("photon part").plan();
        plan.texel_range(plan.light_views(1))
    };
    let lights = moved(&scene.lights, 0, Vec3::new(0.3, -0.15, 0.2));
    r.set_lights(&lights).expect("move light 0");
    let second = r.render().expect("frame 1");
    let plan = r.photons().expect("photon part").plan();
    let texels1_now = plan.texel_range(plan.light_views(1));
    assert_ne!(
        texels1_now.start, texels1.start,
        "light 1's records did not shift"
    );
    assert_eq!(second.stats.lights_retraced, vec![0, 1]);
    let mut moved_scene = scene.clone();
    moved_scene.lights = lights;
    assert_as_fresh(&r, &second, &moved_scene);
    drop(r);
    common::assert_validation_clean(&gpu);
}

#[test]
fn with_a_mirror_ball_moving_one_light_retraces_its_main_and_caustic_views_only() {
    // The sphere is a mirror: both lights get caustic views around it (nested in their main
    // views, the parents' indices in the bounce map's views). Light 1 moves, its caustic window
    // with it; light 0's views, before light 1's, keep their places.
    let scene = mirror_ball();
    let gpu = common::gpu();
    let mut r = Renderer::new(&gpu, &scene, settings(Effects::Auto)).expect("renderer");
    r.render().expect("frame 0");
    let lights = moved(&scene.lights, 1, Vec3::new(0.2, -0.1, -0.1));
    r.set_lights(&lights).expect("move light 1");
    let second = r.render().expect("frame 1");
    let plan = r.photons().expect("photon part").plan().clone();
    for light in [0, 1] {
        assert!(
            plan.views[plan.light_views(light)]
                .iter()
                .any(|v| v.kind.y == BOUNCE_VIEW_CAUSTIC),
            "light {light} has no caustic view"
        );
    }
    assert_eq!(second.stats.lights_retraced, vec![1]);
    assert_eq!(reused(&second), vec![0]);
    let kept = light_photons(&r, 0);
    let traced = light_photons(&r, 1);
    drop(r);
    common::assert_validation_clean(&gpu);
    let mut moved_scene = scene.clone();
    moved_scene.lights = lights;
    let (expected, expected_lights) = fresh(&moved_scene);
    assert!(expected_lights[0] == kept, "light 0");
    assert!(expected_lights[1] == traced, "light 1");
    assert!(
        bits(&second) == bits(&expected),
        "image differs from a fresh renderer's"
    );
}
