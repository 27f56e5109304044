//! One test per rule of the effects plan, each on a small scene built to trigger it (and, where
//! a rule could misfire, one built not to).

use super::*;
use crate::config::settings::Method;
use crate::photon::trace::MAX_BOUNCES;
use crate::reference::scenes::{closed_box, cornell, grey_box};
use crate::scene::{Camera, Light, LightKind, Scene};
use crate::timing::pass_id::PassId;
use glam::{Mat4, Vec3};

fn settings() -> RenderSettings {
    RenderSettings {
        photons: 10_000,
        width: 64,
        height: 64,
        ..Default::default()
    }
}

fn plan(scene: &Scene) -> EffectsPlan {
    EffectsPlan::analyse(scene, &settings(), &scene.camera)
}

fn diffuse(name: &str, albedo: f32) -> Material {
    Material {
        name: name.into(),
        lambertian: Vec3::splat(albedo),
        ..Material::default()
    }
}

fn point(name: &str, position: Vec3, intensity: f32) -> Light {
    Light {
        name: name.into(),
        kind: LightKind::Point,
        position,
        direction: Vec3::NEG_Y,
        intensity: Vec3::splat(intensity),
    }
}

fn spot(name: &str, position: Vec3, direction: Vec3, outer: f32) -> Light {
    Light {
        name: name.into(),
        kind: LightKind::Spot {
            inner_cone_angle: outer * 0.5,
            outer_cone_angle: outer,
        },
        position,
        direction,
        intensity: Vec3::ONE,
    }
}

fn look(eye: Vec3, target: Vec3, yfov_degrees: f32) -> Camera {
    Camera {
        transform: glam::camera::rh::view::look_at_mat4(eye, target, Vec3::Y).inverse(),
        yfov: yfov_degrees.to_radians(),
        znear: 0.01,
        zfar: None,
    }
}

/// The closed box `[-1, 1]³` with wall 0 (−X) of `wall0` and white elsewhere, a light at the
/// centre.
fn box_with(wall0: Material) -> Scene {
    let white = diffuse("white", 0.7);
    closed_box(
        [
            wall0,
            white.clone(),
            white.clone(),
            white.clone(),
            white.clone(),
            white,
        ],
        point("centre", Vec3::ZERO, 1.0),
    )
}

fn pass(passes: &[PassPlan], name: PassId) -> &PassPlan {
    passes
        .iter()
        .find(|p| p.name == name)
        .unwrap_or_else(|| panic!("no pass {name}"))
}

#[test]
fn a_diffuse_scene_needs_no_translucent_pass_no_delta_and_no_glossy_code() {
    let p = plan(&cornell(1));
    assert!(!p.translucent.needed && !p.delta.needed && !p.glossy.needed);
    assert!(p.indirect.needed, "{}", p.indirect.reason);
    assert_eq!(
        p.bsdf_variant(),
        BsdfVariant {
            glossy: false,
            delta: false
        }
    );
    let passes = p.passes();
    for name in [PassId::Environment, PassId::Translucent] {
        assert!(!pass(&passes, name).run, "{name} runs");
    }
    for name in [
        PassId::LightGbuffers,
        PassId::BounceMap,
        PassId::PhotonVolumes,
        PassId::Direct,
    ] {
        assert!(pass(&passes, name).run, "{name} skipped");
    }
}

#[test]
fn a_refracting_material_turns_on_the_translucent_pass_and_delta_code_naming_it() {
    let glass = Material {
        name: "glass".into(),
        lambertian: Vec3::ZERO,
        transmission: Vec3::splat(0.9),
        exponent: f32::INFINITY,
        fresnel: true,
        ..Material::default()
    };
    let p = plan(&box_with(glass));
    assert!(p.translucent.needed && p.delta.needed);
    assert!(p.delta.reason.contains("'glass'"), "{}", p.delta.reason);
    assert!(
        p.translucent.reason.contains("'glass'"),
        "{}",
        p.translucent.reason
    );
    assert!(pass(&p.passes(), PassId::Environment).run);
    assert!(p.bsdf_variant().delta);
}

#[test]
fn a_fresnel_mirror_without_base_reflectance_needs_delta_code_but_stays_in_the_gbuffer() {
    // ρS = 0 but Fresnel and σ = ∞: a mirror lobe at grazing angles, which the bounce map and
    // CPU trace take; `has_delta_lobe` keeps the surface in the eye G-buffer.
    let polished = Material {
        name: "polished".into(),
        fresnel: true,
        exponent: f32::INFINITY,
        ..diffuse("polished", 0.5)
    };
    let p = plan(&box_with(polished));
    assert!(p.delta.needed && p.delta.reason.contains("'polished'"));
    assert!(!p.translucent.needed);
    assert!(!p.glossy.needed);
}

#[test]
fn a_glossy_material_turns_on_the_glossy_lobe_and_a_zero_glossy_one_does_not() {
    let glossy = Material {
        name: "satin".into(),
        glossy: Vec3::splat(0.2),
        exponent: 50.0,
        ..diffuse("satin", 0.5)
    };
    let p = plan(&box_with(glossy));
    assert!(p.glossy.needed && p.glossy.reason.contains("'satin'"));
    assert!(!p.delta.needed);
    // An exponent without reflectance (and without Fresnel) is no lobe.
    let dull = Material {
        name: "dull".into(),
        exponent: 50.0,
        ..diffuse("dull", 0.5)
    };
    assert!(!plan(&box_with(dull)).glossy.needed);
    // Fresnel alone makes one (reflectance rises to 1 at grazing angles).
    let varnish = Material {
        name: "varnish".into(),
        fresnel: true,
        ..diffuse("varnish", 0.5)
    };
    let p = plan(&box_with(varnish));
    assert!(p.glossy.needed && p.glossy.reason.contains("Fresnel"));
}

#[test]
fn a_material_no_instance_uses_does_not_count() {
    let mut scene = cornell(1);
    scene.materials.push(Material {
        name: "unused-glass".into(),
        transmission: Vec3::ONE,
        ..Material::default()
    });
    let p = plan(&scene);
    assert!(!p.delta.needed && !p.translucent.needed);
}

#[test]
fn a_zero_power_light_is_skipped_and_its_budget_goes_to_the_others() {
    let mut scene = grey_box(0.5, 1.0);
    scene
        .lights
        .push(point("dark", Vec3::new(0.3, 0.3, 0.3), 0.0));
    scene
        .lights
        .push(point("lamp", Vec3::new(-0.3, 0.3, 0.3), 1.0));
    let p = plan(&scene);
    assert!(!p.lights[1].active());
    assert_eq!(p.lights[1].reason, "zero power");
    assert_eq!(p.lights[0].photons + p.lights[2].photons, 10_000);
    assert_eq!(p.direct_mask(), vec![true, false, true]);
    assert_eq!(p.photon_mask(), vec![true, false, true]);
}

#[test]
fn a_spot_aimed_away_from_the_scene_is_skipped_and_one_aimed_at_it_is_not() {
    // The box without its top, so that light from above can come in.
    let mut scene = grey_box(0.5, 1.0);
    scene.instances.remove(3);
    let above = Vec3::new(0.0, 3.0, 0.0);
    scene.lights.push(spot("away", above, Vec3::Y, 0.4));
    scene.lights.push(spot("down", above, Vec3::NEG_Y, 0.4));
    let p = plan(&scene);
    assert!(!p.lights[1].active(), "{:?}", p.lights[1]);
    assert!(p.lights[1].reason.contains("misses the scene"));
    assert!(p.lights[2].direct && p.lights[2].photons > 0);
    // Each share is rounded on its own.
    assert!((p.lights[0].photons + p.lights[2].photons).abs_diff(10_000) <= 1);
}

#[test]
fn a_spot_on_what_the_camera_cannot_see_emits_photons_but_gets_no_shadow_map() {
    let mut scene = grey_box(0.5, 1.0);
    // A narrow view of the −X wall; a narrow spot on the +X wall behind the camera.
    scene.camera = look(Vec3::new(-0.5, 0.0, 0.0), Vec3::new(-1.0, 0.0, 0.0), 20.0);
    scene
        .lights
        .push(spot("behind", Vec3::new(0.5, 0.0, 0.0), Vec3::X, 0.3));
    let p = plan(&scene);
    let behind = &p.lights[1];
    assert!(!behind.direct && behind.photons > 0, "{behind:?}");
    assert!(behind.reason.contains("misses the visible scene"));
    // Without indirect light it contributes nothing at all.
    let direct_only = EffectsPlan::analyse(
        &scene,
        &RenderSettings {
            method: Method::Direct,
            ..settings()
        },
        &scene.camera,
    );
    assert!(!direct_only.lights[1].active());
    assert!(direct_only.lights[0].direct);
}

/// A closed grey box around the origin (the camera outside, at +Z) on nothing, a light inside
/// it and one outside.
fn lamp_in_a_box() -> Scene {
    let mut scene = grey_box(0.5, 1.0);
    scene.lights[0].name = "inside".into();
    scene
        .lights
        .push(point("outside", Vec3::new(0.0, 3.0, 3.0), 1.0));
    scene.camera = look(Vec3::new(0.5, 0.5, 5.0), Vec3::ZERO, 45.0);
    scene
}

#[test]
fn a_light_in_a_closed_box_the_camera_is_outside_of_is_skipped() {
    let scene = lamp_in_a_box();
    let p = plan(&scene);
    assert!(!p.lights[0].active(), "{:?}", p.lights[0]);
    assert!(
        p.lights[0].reason.contains("enclosed"),
        "{}",
        p.lights[0].reason
    );
    assert!(p.lights[1].direct && p.lights[1].photons == 10_000);
    // From inside the box, it is the outside light that is shut out.
    let inside = EffectsPlan::analyse(
        &scene,
        &settings(),
        &look(Vec3::new(0.2, 0.1, 0.5), Vec3::new(0.0, 0.0, -1.0), 60.0),
    );
    assert!(inside.lights[0].direct && inside.lights[0].photons == 10_000);
    assert!(!inside.lights[1].active());
}

#[test]
fn one_scene_analysis_plans_every_camera_and_set_of_lights_as_a_full_analysis_does() {
    let scene = lamp_in_a_box();
    let analysis = SceneAnalysis::new(&scene, &settings());
    let inside = look(Vec3::new(0.2, 0.1, 0.5), Vec3::new(0.0, 0.0, -1.0), 60.0);
    let elsewhere = look(Vec3::new(-4.0, 1.0, 0.5), Vec3::ZERO, 30.0);
    let mut moved = scene.clone();
    moved.lights[0].position = Vec3::new(0.3, -0.2, 0.1);
    moved.lights[1].intensity = Vec3::ZERO;
    for camera in [scene.camera, inside, elsewhere] {
        for lights in [&scene, &moved] {
            assert_eq!(
                analysis.plan(lights, &camera),
                EffectsPlan::analyse(lights, &settings(), &camera)
            );
        }
    }
    // The cached plans do differ: the camera inside the box sees the lamp, the one outside not.
    assert!(analysis.plan(&scene, &inside).lights[0].active());
    assert!(!analysis.plan(&scene, &scene.camera).lights[0].active());
    let all = RenderSettings {
        effects: Effects::All,
        ..settings()
    };
    assert_eq!(
        SceneAnalysis::new(&scene, &all).plan(&moved, &inside),
        EffectsPlan::analyse(&moved, &all, &inside)
    );
}

#[test]
fn an_open_or_transmissive_box_encloses_nothing() {
    let mut open = lamp_in_a_box();
    open.instances.remove(3);
    assert!(plan(&open).lights[0].active(), "a box without its top");
    let mut glazed = lamp_in_a_box();
    glazed.materials[4] = Material {
        name: "window".into(),
        transmission: Vec3::splat(0.8),
        ..diffuse("window", 0.1)
    };
    assert!(plan(&glazed).lights[0].active(), "a box with a window");
}

#[test]
fn sunlight_does_not_reach_into_a_closed_room() {
    let mut scene = grey_box(0.5, 1.0);
    scene.lights.push(Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        position: Vec3::ZERO,
        direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
        intensity: Vec3::ONE,
    });
    let p = plan(&scene);
    assert!(p.lights[0].active());
    assert!(!p.lights[1].active(), "{:?}", p.lights[1]);
}

#[test]
fn enclosures_need_welded_closed_surfaces_and_a_clear_point() {
    let scene = grey_box(0.5, 1.0);
    let e = Enclosures::new(&scene);
    assert_eq!(e.len(), 1);
    let probe = |x: f32, clearance: f32| Viewpoint {
        position: Vec3::new(x, 0.1, 0.2),
        clearance,
    };
    assert!(e.separating(&probe(0.0, 0.0), &probe(3.0, 0.0)).is_some());
    assert!(e.separating(&probe(0.0, 0.0), &probe(0.5, 0.0)).is_none());
    assert!(e.separating(&probe(3.0, 0.0), &probe(-3.0, 0.0)).is_none());
    // Too close to a wall to tell: never separated.
    assert!(e.separating(&probe(0.99, 0.05), &probe(3.0, 0.0)).is_none());
    // Shifting one wall by a hair opens four seams.
    let mut gap = grey_box(0.5, 1.0);
    gap.instances[0].transform = Mat4::from_translation(Vec3::new(0.0, 1e-4, 0.0));
    assert!(Enclosures::new(&gap).is_empty());
}

#[test]
fn no_indirect_light_without_the_settings_or_surfaces_for_it() {
    let scene = cornell(1);
    let with = |s: RenderSettings| EffectsPlan::analyse(&scene, &s, &scene.camera);
    for (s, why) in [
        (
            RenderSettings {
                method: Method::Direct,
                ..settings()
            },
            "--method direct",
        ),
        (
            RenderSettings {
                bounces: 0,
                ..settings()
            },
            "--bounces 0",
        ),
        (
            RenderSettings {
                photons: 0,
                ..settings()
            },
            "--photons 0",
        ),
    ] {
        let p = with(s);
        assert!(!p.indirect.needed && p.indirect.reason == why, "{why}");
        assert_eq!(p.max_bounces, 0);
        let passes = p.passes();
        for name in [
            PassId::LightGbuffers,
            PassId::BounceMap,
            PassId::Readback,
            PassId::CpuTrace,
            PassId::Upload,
        ] {
            assert!(!pass(&passes, name).run, "{why}: {name} runs");
        }
        for name in [PassId::PhotonVolumes, PassId::Upsample, PassId::Composite] {
            assert!(!pass(&passes, name).run, "{why}: {name} runs");
        }
    }
    let black = grey_box(0.0, 1.0);
    assert!(plan(&black).indirect.reason.contains("black"));
    let mirrors = box_with(Material {
        name: "mirror".into(),
        lambertian: Vec3::ZERO,
        glossy: Vec3::ONE,
        exponent: f32::INFINITY,
        ..Material::default()
    });
    assert!(plan(&mirrors).indirect.needed, "white walls receive");
    let mut all_mirrors = grey_box(0.5, 1.0);
    all_mirrors.materials = vec![
        Material {
            name: "mirror".into(),
            lambertian: Vec3::ZERO,
            glossy: Vec3::ONE,
            exponent: f32::INFINITY,
            ..Material::default()
        };
        6
    ];
    let p = plan(&all_mirrors);
    assert!(!p.indirect.needed && p.indirect.reason.contains("Lambertian or glossy"));
    // One floor quad: light leaving it never returns.
    let mut floor = grey_box(0.5, 1.0);
    floor.instances.retain(|i| i.mesh == 2);
    let p = plan(&floor);
    assert!(!p.indirect.needed && p.indirect.reason.contains("one plane"));
}

#[test]
fn no_indirect_light_when_no_light_emits_photons() {
    let mut scene = cornell(1);
    scene.lights[0].intensity = Vec3::ZERO;
    let p = plan(&scene);
    assert!(!p.indirect.needed, "{}", p.indirect.reason);
    assert!(p
        .passes()
        .iter()
        .all(|q| q.name != PassId::BounceMap || !q.run));
    let p = plan(&Scene {
        lights: Vec::new(),
        ..cornell(1)
    });
    assert_eq!(p.indirect.reason, "the scene has no lights");
    assert!(!pass(&p.passes(), PassId::ShadowMaps).run);
}

#[test]
fn the_bounce_depth_follows_the_brightest_albedo_capped_by_bounces() {
    // a = 0.3: a^(K+1)/(1 − a) < 1e-3 first at K = 6.
    let dark = grey_box(0.3, 1.0);
    let p = plan(&dark);
    assert_eq!(p.max_bounces, 6, "{}", p.max_bounces_reason);
    assert!(p.max_bounces_reason.contains("'grey'"));
    let capped = EffectsPlan::analyse(
        &dark,
        &RenderSettings {
            bounces: 4,
            ..settings()
        },
        &dark.camera,
    );
    assert_eq!(capped.max_bounces, 4);
    assert!(capped
        .max_bounces_reason
        .starts_with("--bounces 4: photons past it carry up to"));
    // A bright box needs many bounces: 0.8^(K+1)/0.2 < 1e-3 first at K = 38 (the old default
    // of 8 bounces cut 13 % of its light).
    assert_eq!(plan(&grey_box(0.8, 1.0)).max_bounces, 38);
    // The brightest material decides, not the average: 0.9^(K+1)/0.1 < 1e-3 at K = 87.
    let mut mixed = grey_box(0.1, 1.0);
    mixed.materials[3] = diffuse("bright", 0.9);
    assert_eq!(plan(&mixed).max_bounces, 87);
    // A white room loses nothing: only the safety cap ends its paths.
    let white = plan(&grey_box(1.0, 1.0));
    assert_eq!(
        white.max_bounces, MAX_BOUNCES,
        "{}",
        white.max_bounces_reason
    );
    assert!(white.max_bounces_reason.contains("safety cap"));
}

#[test]
fn effects_all_forces_every_variant_light_and_photon_pass_on() {
    let mut scene = lamp_in_a_box();
    scene.lights.push(point("dark", Vec3::ZERO, 0.0));
    let all = EffectsPlan::analyse(
        &scene,
        &RenderSettings {
            effects: Effects::All,
            ..settings()
        },
        &scene.camera,
    );
    assert_eq!(all.bsdf_variant(), BsdfVariant::ALL);
    assert!(all.lights.iter().all(|l| l.direct));
    assert_eq!(all.lights[0].photons + all.lights[1].photons, 10_000);
    assert_eq!(all.max_bounces, MAX_BOUNCES);
    let passes = all.passes();
    assert!(pass(&passes, PassId::BounceMap).run);
    // No instance is glass or a mirror: the translucent pass has nothing to draw either way.
    assert!(!pass(&passes, PassId::Translucent).run);
    assert!(all.to_string().starts_with("effects: all\n"));
}

#[test]
fn the_pass_list_covers_every_stage_and_prints_one_line_per_decision() {
    let scene = cornell(1);
    let p = EffectsPlan::analyse(
        &scene,
        &RenderSettings {
            subsample: 4,
            ..settings()
        },
        &scene.camera,
    );
    let passes = p.passes();
    for stage in crate::render::stats::stages() {
        assert!(passes.iter().any(|q| q.name == stage), "{stage} missing");
    }
    assert!(pass(&passes, PassId::Upsample).run);
    let text = p.to_string();
    let lines: Vec<&str> = text.lines().collect();
    // effects, 5 decisions (emitters the last), max bounces, motion, the lights, the passes.
    assert_eq!(
        lines.len(),
        1 + 5 + 1 + 1 + scene.lights.len() + passes.len()
    );
    assert!(text.contains("emissive surfaces as lights: no — no surface emits light"));
    assert!(
        text.contains("motion: static — nothing is animated"),
        "{text}"
    );
    assert!(lines.iter().skip(1).all(|l| l.contains(" — ")), "{text}");
    assert!(text.contains(&format!("light 0 '{}'", scene.lights[0].name)));
}

#[test]
fn a_spot_reaches_a_sphere_its_cone_touches_and_not_one_it_misses() {
    let sphere = (Vec3::ZERO, 1.0);
    // Above the sphere, pointing down: reaches.
    assert!(reach::light_reaches(
        &spot("s", Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y, 0.2),
        sphere
    ));
    // Pointing up, away: misses.
    assert!(!reach::light_reaches(
        &spot("s", Vec3::new(0.0, 5.0, 0.0), Vec3::Y, 0.2),
        sphere
    ));
    // Aimed beside the sphere: the sphere subtends asin(1/5) ≈ 0.201 rad from the apex,
    // the axis is 0.5 rad off the centre; a 0.25 rad cone misses, a 0.35 rad one reaches.
    let off = Vec3::new(0.5f32.sin(), -0.5f32.cos(), 0.0);
    assert!(!reach::light_reaches(
        &spot("s", Vec3::new(0.0, 5.0, 0.0), off, 0.25),
        sphere
    ));
    assert!(reach::light_reaches(
        &spot("s", Vec3::new(0.0, 5.0, 0.0), off, 0.35),
        sphere
    ));
    // Apex inside the sphere: always.
    assert!(reach::light_reaches(
        &spot("s", Vec3::ZERO, Vec3::Y, 0.1),
        sphere
    ));
}

#[test]
fn the_visible_box_follows_the_view() {
    let bounds = Aabb {
        min: Vec3::splat(-1.0),
        max: Vec3::splat(1.0),
    };
    let look = |eye, target| look(eye, target, 0.5f32.to_degrees());
    // Looking at the box from +Z: the whole box.
    let at = reach::visible_box(&look(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO), 1.0, &bounds);
    assert_eq!(at, bounds);
    // Looking away: the frustum box no longer overlaps.
    let away = reach::visible_box(
        &look(Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, 10.0)),
        1.0,
        &bounds,
    );
    assert!(away.is_empty(), "{away:?}");
    // Inside, looking at the +X wall with a narrow view: only part of the box.
    let wall = reach::visible_box(
        &look(Vec3::new(0.5, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0)),
        1.0,
        &bounds,
    );
    assert!(wall.min.x >= 0.49 && wall.max.y < 1.0, "{wall:?}");
    // A far plane short of the box.
    let mut short = look(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO);
    short.zfar = Some(3.0);
    assert!(reach::visible_box(&short, 1.0, &bounds).is_empty());
    assert!(reach::visible_box(&Camera::default(), 1.0, &Aabb::EMPTY).is_empty());
}

#[test]
fn welding_the_static_part_once_finds_the_surfaces_a_full_weld_finds() {
    // The lamp's box moves (its six walls are the moving instances), a second closed box
    // stands still far away.
    let mut scene = lamp_in_a_box();
    let far = grey_box(0.5, 1.0);
    for inst in &far.instances {
        let mut inst = inst.clone();
        inst.transform = Mat4::from_translation(Vec3::new(-6.0, 0.0, 0.0)) * inst.transform;
        inst.name = format!("far {}", inst.name);
        scene.instances.push(inst);
    }
    let moving: Vec<usize> = (0..6).collect();
    let statics = StaticEnclosures::new(&scene, &moving);
    let shifted = |by: Vec3| {
        let mut s = scene.clone();
        for i in &moving {
            s.instances[*i].transform = Mat4::from_translation(by) * s.instances[*i].transform;
        }
        s
    };
    let probes: Vec<Viewpoint> = [
        Vec3::ZERO,
        Vec3::new(0.2, 0.1, 0.3),
        Vec3::new(-6.0, 0.1, 0.2),
        Vec3::new(3.0, 3.0, 3.0),
        Vec3::new(5.1, 0.0, 0.2),
    ]
    .map(|position| Viewpoint {
        position,
        clearance: 0.01,
    })
    .to_vec();
    for by in [
        Vec3::ZERO,
        Vec3::new(0.2, 0.0, 0.0),
        Vec3::new(5.0, 0.0, 0.0),
    ] {
        let moved = shifted(by);
        let (full, fast) = (
            Enclosures::new(&moved),
            Enclosures::with_static(&statics, &moved),
        );
        assert_eq!(full.len(), 2, "{by}");
        assert_eq!(fast.len(), full.len(), "{by}");
        for a in &probes {
            for b in &probes {
                assert_eq!(
                    fast.separating(a, b),
                    full.separating(a, b),
                    "{by}: {a:?} {b:?}"
                );
            }
        }
        let analysis = SceneAnalysis::with_static(&moved, &settings(), &statics);
        assert_eq!(
            analysis.plan(&moved, &moved.camera),
            EffectsPlan::analyse(&moved, &settings(), &moved.camera),
            "{by}"
        );
    }
    // Moved 5 m, the box no longer holds the lamp: the plan follows.
    let away = shifted(Vec3::new(5.0, 0.0, 0.0));
    let analysis = SceneAnalysis::with_static(&away, &settings(), &statics);
    assert!(analysis.plan(&away, &away.camera).lights[0].active());
    assert!(!plan(&scene).lights[0].active());
    // A moving wall that meets the static box exactly: welded again, whole.
    let mut touching = scene.clone();
    touching.instances[0].transform = scene.instances[6].transform;
    let fast = Enclosures::with_static(&statics, &touching);
    let full = Enclosures::new(&touching);
    // The doubled wall opens the far box, and the moved wall the lamp's: nothing is closed
    // (without the fallback the far box would still count).
    assert_eq!(full.len(), 0);
    assert_eq!(fast.len(), full.len());
    assert!(statics.covers([0, 5]) && !statics.covers([6]));
}
