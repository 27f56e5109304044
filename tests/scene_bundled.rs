//! The bundled scenes: committed files match the generator, and each holds what it promises.

use glam::Vec3;
use ispm::scene::bundled::{bundled, resolve, BUNDLED};
use ispm::scene::{authoring, LightKind, Scene};

fn scene(name: &str) -> Scene {
    resolve(Some(name)).unwrap()
}

#[test]
fn committed_glbs_equal_generator_output() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    for (name, bytes) in authoring::all() {
        let committed = std::fs::read(dir.join(format!("{name}.glb"))).unwrap();
        assert!(
            committed == bytes,
            "assets/{name}.glb is stale: run `cargo run --example make-scenes`"
        );
        assert_eq!(
            bundled(name),
            Some(&bytes[..]),
            "{name} embedded bytes are stale"
        );
        assert!(bytes.len() < 500 * 1024, "{name} is {} bytes", bytes.len());
    }
    let names: Vec<&str> = authoring::all().iter().map(|(n, _)| *n).collect();
    assert_eq!(names, BUNDLED);
}

#[test]
fn every_bundled_scene_loads_with_a_camera_lights_and_sound_meshes() {
    for &name in BUNDLED {
        let s = scene(name);
        assert_eq!(s.cameras.len(), 1, "{name}");
        assert!(!s.lights.is_empty(), "{name}");
        assert!(s.triangle_count() > 100, "{name}");
        for m in &s.meshes {
            assert_eq!(m.normals.len(), m.positions.len());
            assert!(m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
        }
        for m in &s.materials {
            let sum = m.lambertian + m.glossy + m.transmission;
            assert!(sum.max_element() <= 1.0, "{name}/{}", m.name);
        }
    }
}

#[test]
fn no_argument_resolves_to_the_cornell_box() {
    let s = resolve(None).unwrap();
    assert_eq!(s.meshes, scene("cornell-box").meshes);
}

#[test]
fn a_path_argument_loads_that_file_and_a_bad_one_names_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("copy.glb");
    std::fs::write(&path, bundled("glass-sphere").unwrap()).unwrap();
    let s = resolve(Some(path.to_str().unwrap())).unwrap();
    assert_eq!(s.meshes, scene("glass-sphere").meshes);
    let err = format!("{:#}", resolve(Some("no-such-scene")).unwrap_err());
    assert!(
        err.contains("no-such-scene") && err.contains("not found"),
        "{err}"
    );
}

#[test]
fn cornell_box_has_white_and_blue_spots_glass_of_eta_1_3_and_a_glossy_purple_object() {
    let s = scene("cornell-box");
    assert_eq!(s.lights.len(), 2);
    for l in &s.lights {
        assert!(matches!(l.kind, LightKind::Spot { .. }));
        assert!(l.direction.y < -0.99, "aims down");
        assert!(l.position.y > 1.8, "near the ceiling");
        let floor_irradiance = l.intensity.max_element() / l.position.y.powi(2);
        assert!(
            (0.3..3.0).contains(&floor_irradiance),
            "{floor_irradiance} W/m²"
        );
    }
    let white = &s.lights[0].intensity;
    assert!(white.x == white.y && white.y == white.z);
    let blue = &s.lights[1].intensity;
    assert!(blue.z > blue.x && blue.z > blue.y);
    let glass = s.materials.iter().find(|m| m.transmission.x > 0.5).unwrap();
    assert_eq!(glass.ior, 1.3);
    assert!(glass.fresnel && glass.exponent.is_infinite());
    assert!(glass.lambertian.x < 0.05 && glass.glossy.x > 0.0 && glass.glossy.x < 0.1);
    let purple = s
        .materials
        .iter()
        .find(|m| m.name == "glossy-purple")
        .unwrap();
    assert!((50.0..=200.0).contains(&purple.exponent));
    assert!(purple.lambertian.z > purple.lambertian.y && purple.glossy.max_element() > 0.0);
    let red = s.materials.iter().find(|m| m.name == "red").unwrap();
    assert!(red.lambertian.x > 3.0 * red.lambertian.y);
    let b = s.bounds();
    assert!((b.extent() - Vec3::splat(2.0)).length() < 1e-3, "a 2 m box");
    assert!(
        s.camera.position().z > 1.0,
        "camera in front of the open side"
    );
}

#[test]
fn caustic_ring_has_a_double_sided_mirror_ring_and_a_low_sun() {
    let s = scene("caustic-ring");
    assert_eq!(s.lights.len(), 1);
    let sun = &s.lights[0];
    assert_eq!(sun.kind, LightKind::Directional);
    let elevation = (-sun.direction.y).asin().to_degrees();
    assert!((15.0..=25.0).contains(&elevation), "{elevation}°");
    let mirror = s
        .materials
        .iter()
        .find(|m| m.name == "mirror-metal")
        .unwrap();
    assert!(mirror.exponent.is_infinite() && !mirror.fresnel && mirror.double_sided);
    assert!(mirror.glossy.min_element() > 0.8 && mirror.lambertian == Vec3::ZERO);
    assert!(
        s.camera.position().y > 1.0,
        "camera looks down into the ring"
    );
}

#[test]
fn glass_sphere_is_refractive_eta_1_5_under_a_spot() {
    let s = scene("glass-sphere");
    assert!(matches!(s.lights[0].kind, LightKind::Spot { .. }));
    let glass = s.materials.iter().find(|m| m.transmission.x > 0.9).unwrap();
    assert_eq!(glass.ior, 1.5);
    assert!(glass.fresnel && glass.has_delta_lobe());
}

#[test]
fn diffuse_box_is_lambertian_only_so_the_plan_compiles_every_optional_lobe_out() {
    let s = scene("diffuse-box");
    assert_eq!(s.lights.len(), 1);
    let spot = &s.lights[0];
    assert!(matches!(spot.kind, LightKind::Spot { .. }));
    assert!(spot.direction.y < -0.99 && spot.position.y > 1.8);
    for m in &s.materials {
        assert!(m.lambertian.max_element() > 0.0, "{}", m.name);
        assert_eq!(m.glossy, Vec3::ZERO, "{}", m.name);
        assert_eq!(m.transmission, Vec3::ZERO, "{}", m.name);
        assert!(!m.fresnel && !m.has_delta_lobe(), "{}", m.name);
    }
    let names: Vec<&str> = s.instances.iter().map(|i| i.name.as_str()).collect();
    assert!(names.contains(&"tall-block") && names.contains(&"white-sphere"));
    let b = s.bounds();
    assert!((b.extent() - Vec3::splat(2.0)).length() < 1e-3, "a 2 m box");
    let settings = ispm::config::settings::RenderSettings::default();
    let plan = ispm::plan::EffectsPlan::analyse(&s, &settings, &s.camera);
    let none = ispm::photon::bsdf::BsdfVariant {
        glossy: false,
        delta: false,
    };
    assert_eq!(plan.bsdf_variant(), none, "{plan}");
    assert!(!plan.translucent.needed && plan.indirect.needed, "{plan}");
    assert!(
        plan.lights[0].direct && plan.lights[0].photons > 0,
        "{plan}"
    );
}
