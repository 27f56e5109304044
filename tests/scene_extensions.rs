//! Every glTF scene lit (issue #18), the loader's side: the default key light, the material
//! extensions viewers support (unlit, specular-glossiness, variants, clearcoat and sheen),
//! empty scenes, exporters' light units and bad emissive data. No GPU: `tests/cli_lighting.rs`
//! renders the same files.

mod common;

use common::gltf_doc::{add_light, blender_material, object_on_floor, GltfDoc, FLOOR, OBJECT};
use glam::{Quat, Vec3};
use ispm::scene::default_light::{DEFAULT_LIGHT_IRRADIANCE, DEFAULT_LIGHT_NAME};
use ispm::scene::load::{load_from_slice, load_from_slice_with, LoadOptions};
use ispm::scene::{LightKind, Material, Scene, MAX_EMISSION};
use serde_json::json;

const FILE: &str = "export.gltf";

fn load(gltf: &GltfDoc) -> anyhow::Result<Scene> {
    load_from_slice(&gltf.gltf(), FILE, None)
}

fn load_with(gltf: &GltfDoc, options: &LoadOptions) -> anyhow::Result<Scene> {
    load_from_slice_with(&gltf.gltf(), FILE, None, options)
}

fn lit() -> LoadOptions {
    LoadOptions {
        default_light: true,
        ..LoadOptions::default()
    }
}

fn variant(name: &str) -> LoadOptions {
    LoadOptions {
        variant: Some(name.to_string()),
        ..LoadOptions::default()
    }
}

/// Asserts a one-line error naming the file and containing every word.
fn assert_error(r: anyhow::Result<Scene>, words: &[&str]) {
    let e = match r {
        Ok(_) => panic!("expected an error mentioning {words:?}"),
        Err(e) => format!("{e:#}"),
    };
    assert!(
        e.starts_with(&format!("{FILE}: ")),
        "{e:?} does not name {FILE}"
    );
    assert!(!e.contains('\n'), "{e:?} is not one line");
    for w in words {
        assert!(e.contains(w), "{e:?} lacks {w:?}");
    }
}

fn material<'a>(scene: &'a Scene, name: &str) -> &'a Material {
    scene
        .materials
        .iter()
        .find(|m| m.name == name)
        .unwrap_or_else(|| panic!("no material {name}"))
}

/// The material the box's instance is drawn with.
fn box_material(scene: &Scene) -> &Material {
    let inst = scene
        .instances
        .iter()
        .find(|i| i.name == "box")
        .expect("box");
    &scene.materials[scene.meshes[inst.mesh].material]
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-4
}

#[test]
fn a_scene_without_lights_or_emitters_gets_the_default_key_light_only_when_asked() {
    let gltf = object_on_floor();
    let plain = load(&gltf).expect("loads");
    assert!(plain.lights.is_empty() && !plain.default_light);

    let scene = load_with(&gltf, &lit()).expect("loads");
    assert!(scene.default_light);
    assert_eq!(scene.lights.len(), 1);
    let light = &scene.lights[0];
    assert_eq!(light.name, DEFAULT_LIGHT_NAME);
    assert!(matches!(light.kind, LightKind::Spot { .. }));
    // Above the camera, aiming where the camera looks (the box, at the scene's centre), with
    // an irradiance of π W/m² there.
    assert!(light.position.y > scene.camera.position().y);
    let target = Vec3::new(0.0, 0.4, 0.0);
    assert!(light.direction.dot((target - light.position).normalize()) > 0.9999);
    let irradiance = light.intensity.x / light.position.distance_squared(target);
    assert!(
        (irradiance - DEFAULT_LIGHT_IRRADIANCE).abs() < 1e-3,
        "{light:?}"
    );
}

#[test]
fn emissive_surfaces_are_light_enough_but_an_unlit_colour_is_not() {
    let mut gltf = object_on_floor();
    gltf.doc["materials"][OBJECT]["emissiveFactor"] = json!([1.0, 0.9, 0.8]);
    let scene = load_with(&gltf, &lit()).expect("loads");
    assert!(
        scene.lights.is_empty() && !scene.default_light,
        "an emitter"
    );

    let mut gltf = object_on_floor();
    gltf.doc["materials"][OBJECT]["extensions"] = json!({"KHR_materials_unlit": {}});
    gltf.uses("KHR_materials_unlit", true);
    let scene = load_with(&gltf, &lit()).expect("loads");
    assert!(scene.default_light, "unlit is no light source");

    // An emissive material no mesh uses lights nothing.
    let mut gltf = object_on_floor();
    let materials = gltf.doc["materials"].as_array_mut().expect("materials");
    materials.push(json!({"name": "unused lamp", "emissiveFactor": [1, 1, 1]}));
    assert!(load_with(&gltf, &lit()).expect("loads").default_light);
}

#[test]
fn blender_lights_in_watt_based_candela_and_lux_keep_their_watts() {
    // Blender's exporter (lighting mode "Standard"): a point light of P watts is written as
    // P/(4π) · 683 cd, a sun of S W/m² as S · 683 lx.
    let mut gltf = object_on_floor();
    let watts = 1000.0f32;
    add_light(
        &mut gltf,
        json!({"name": "Point", "type": "point", "color": [1, 1, 1],
               "intensity": watts / (4.0 * std::f32::consts::PI) * 683.0}),
        Vec3::new(1.0, 3.0, 2.0),
        Quat::IDENTITY,
    );
    add_light(
        &mut gltf,
        json!({"name": "Sun", "type": "directional", "color": [1, 0.9, 0.8], "intensity": 3.0 * 683.0}),
        Vec3::ZERO,
        Quat::from_rotation_x(-1.0),
    );
    let scene = load_with(&gltf, &lit()).expect("loads");
    assert!(!scene.default_light, "the file has lights");
    assert_eq!(scene.lights.len(), 2);
    let point = &scene.lights[0];
    assert!((point.intensity.x - watts / (4.0 * std::f32::consts::PI)).abs() < 1e-2);
    assert_eq!(point.position, Vec3::new(1.0, 3.0, 2.0));
    let sun = &scene.lights[1];
    assert!(close(sun.intensity, Vec3::new(3.0, 2.7, 2.4)), "{sun:?}");
    assert!(sun.direction.y < -0.5, "shines down");
}

#[test]
fn unlit_material_shows_its_base_colour_and_reflects_nothing() {
    let mut gltf = object_on_floor();
    gltf.doc["materials"][OBJECT] = json!({"name": "sign",
        "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.2, 0.1, 1.0]},
        "emissiveFactor": [1, 1, 1],
        "extensions": {"KHR_materials_unlit": {}}});
    gltf.uses("KHR_materials_unlit", true);
    let scene = load(&gltf).expect("a file requiring KHR_materials_unlit loads");
    let m = material(&scene, "sign");
    assert!(m.unlit && !m.is_emitter());
    assert_eq!(
        m.emission,
        Vec3::new(0.9, 0.2, 0.1),
        "base colour, emissive ignored"
    );
    assert_eq!(m.lambertian + m.glossy + m.transmission, Vec3::ZERO);
    assert_eq!(m.lambertian_texture, None);

    // A textured unlit material shows its factor times the texture's mean linear colour.
    let mut png = Vec::new();
    image::RgbaImage::from_fn(2, 1, |x, _| {
        image::Rgba(if x == 0 {
            [255, 0, 0, 255]
        } else {
            [0, 0, 255, 255]
        })
    })
    .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
    .expect("png");
    let view = gltf.view(&png);
    gltf.doc["images"] = json!([{"bufferView": view, "mimeType": "image/png"}]);
    gltf.doc["textures"] = json!([{"source": 0}]);
    gltf.doc["materials"][OBJECT]["pbrMetallicRoughness"] =
        json!({"baseColorFactor": [1.0, 1.0, 0.5, 1.0], "baseColorTexture": {"index": 0}});
    let scene = load(&gltf).expect("loads");
    assert!(close(
        material(&scene, "sign").emission,
        Vec3::new(0.5, 0.0, 0.25)
    ));
    assert!(scene.textures.is_empty(), "the texture is not kept");
}

#[test]
fn an_emissive_texture_scales_the_emission_by_its_mean_colour() {
    // Blender exports an emission map as emissiveFactor 1 and an emissiveTexture: the surface
    // must emit (as its mean colour), not stay dark.
    let mut gltf = object_on_floor();
    let mut png = Vec::new();
    image::RgbaImage::from_fn(2, 1, |x, _| {
        image::Rgba(if x == 0 {
            [255, 255, 255, 255]
        } else {
            [0, 0, 0, 255]
        })
    })
    .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
    .expect("png");
    let view = gltf.view(&png);
    gltf.doc["images"] = json!([{"bufferView": view, "mimeType": "image/png"}]);
    gltf.doc["textures"] = json!([{"source": 0}]);
    gltf.doc["materials"][OBJECT]["emissiveFactor"] = json!([1.0, 0.5, 1.0]);
    gltf.doc["materials"][OBJECT]["emissiveTexture"] = json!({"index": 0});
    let scene = load(&gltf).expect("loads");
    let m = material(&scene, "box");
    // (1, 0.5, 1) × the mean of white and black, / 683 (nits → W/(m²·sr)).
    let expected = Vec3::new(0.5, 0.25, 0.5) / 683.0;
    assert!(close(m.emission, expected), "{} vs {expected}", m.emission);
    assert!(m.is_emitter());
}

#[test]
fn specular_glossiness_converts_to_metallic_roughness_by_the_published_formula() {
    let mut gltf = object_on_floor();
    let sg = |diffuse: [f32; 4], specular: [f32; 3], gloss: f32| {
        json!({"KHR_materials_pbrSpecularGlossiness":
            {"diffuseFactor": diffuse, "specularFactor": specular, "glossinessFactor": gloss}})
    };
    gltf.doc["materials"] = json!([
        {"name": "plastic", "extensions": sg([0.5, 0.5, 0.5, 1.0], [0.04; 3], 0.3),
         // Exporters write a metallic-roughness fallback; the extension wins.
         "pbrMetallicRoughness": {"baseColorFactor": [0.1, 0.1, 0.1, 1.0], "metallicFactor": 1.0}},
        {"name": "gold", "extensions": sg([0.0, 0.0, 0.0, 1.0], [1.0, 0.766, 0.336], 1.0)},
        {"name": "mixed", "extensions": sg([0.6, 0.4, 0.2, 1.0], [0.2; 3], 0.5)},
    ]);
    gltf.uses("KHR_materials_pbrSpecularGlossiness", true);
    let scene = load(&gltf).expect("a file requiring the extension loads");

    // A dielectric stays one: base colour = diffuse, metallic 0, roughness = 1 − glossiness;
    // its Lambertian part is (1 − F0)·0.5 (glTF's fresnel_mix, and the extension's own
    // c_diff = diffuse·(1 − max specular)).
    let plastic = material(&scene, "plastic");
    assert!(close(plastic.lambertian, Vec3::splat(0.48)));
    assert!(close(plastic.glossy, Vec3::splat(0.04)) && plastic.fresnel);
    let alpha = 0.7f32 * 0.7;
    assert!((plastic.exponent - (2.0 / (alpha * alpha) - 2.0)).abs() < 1e-3);
    // A metal: base colour = specular, metallic 1, glossiness 1 ⇒ a mirror.
    let gold = material(&scene, "gold");
    assert!(close(gold.glossy, Vec3::new(1.0, 0.766, 0.336)) && !gold.fresnel);
    assert!(close(gold.lambertian, Vec3::ZERO) && gold.exponent.is_infinite());
    // In between: the values of the extension's reference conversion (convert-between-workflows,
    // babylon.pbrUtilities.js), computed independently: base colour (0.71063, 0.49177, 0.27290),
    // metallic 0.31319.
    let (base, metallic) = (Vec3::new(0.710_632, 0.491_766, 0.272_900), 0.313_194);
    let mixed = material(&scene, "mixed");
    assert!(
        close(mixed.lambertian, (1.0 - metallic) * 0.96 * base),
        "{mixed:?}"
    );
    assert!(close(
        mixed.glossy,
        metallic * base + Vec3::splat((1.0 - metallic) * 0.04)
    ));
    assert!(mixed.fresnel);
}

#[test]
fn specular_glossiness_diffuse_texture_is_the_base_colour_texture() {
    let mut gltf = object_on_floor();
    let mut png = Vec::new();
    image::RgbaImage::from_pixel(1, 1, image::Rgba([200, 100, 50, 255]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .expect("png");
    let view = gltf.view(&png);
    gltf.doc["images"] = json!([{"bufferView": view, "mimeType": "image/png"}]);
    gltf.doc["textures"] = json!([{"source": 0}]);
    gltf.doc["materials"][OBJECT] = json!({"name": "wood", "extensions": {
        "KHR_materials_pbrSpecularGlossiness": {"diffuseTexture": {"index": 0},
            "specularFactor": [0.04, 0.04, 0.04], "glossinessFactor": 0.2,
            "specularGlossinessTexture": {"index": 0}}}});
    gltf.uses("KHR_materials_pbrSpecularGlossiness", false);
    let scene = load(&gltf).expect("loads");
    assert_eq!(material(&scene, "wood").lambertian_texture, Some(0));
    assert_eq!(scene.textures[0].rgba8, vec![200, 100, 50, 255]);
}

/// The box with a red default material and KHR_materials_variants "green" and "blue".
fn with_variants() -> GltfDoc {
    let mut gltf = object_on_floor();
    gltf.doc["materials"] = json!([
        blender_material("floor", [0.8; 3]),
        blender_material("red", [0.8, 0.1, 0.1]),
        blender_material("green", [0.1, 0.8, 0.1]),
        blender_material("blue", [0.1, 0.1, 0.8]),
    ]);
    let box_mesh = gltf.doc["meshes"]
        .as_array()
        .expect("meshes")
        .iter()
        .position(|m| m["name"] == "box")
        .expect("box mesh");
    gltf.doc["meshes"][box_mesh]["primitives"][0]["extensions"] = json!({
        "KHR_materials_variants": {"mappings": [{"material": 2, "variants": [0]},
                                                {"material": 3, "variants": [1, 2]}]}});
    gltf.doc["extensions"] = json!({"KHR_materials_variants": {"variants": [
        {"name": "green"}, {"name": "blue"}, {"name": "navy"}]}});
    gltf.uses("KHR_materials_variants", false);
    gltf
}

#[test]
fn variants_show_the_default_materials_or_the_one_named() {
    let gltf = with_variants();
    assert_eq!(box_material(&load(&gltf).expect("loads")).name, "red");
    for (name, shown) in [("green", "green"), ("blue", "blue"), ("navy", "blue")] {
        let scene = load_with(&gltf, &variant(name)).expect("loads");
        assert_eq!(box_material(&scene).name, shown, "--variant {name}");
        assert_eq!(
            scene.materials[FLOOR].name, "floor",
            "unmapped primitives keep theirs"
        );
    }
    assert_error(
        load_with(&gltf, &variant("purple")),
        &["\"purple\"", "green, blue, navy"],
    );
    assert_error(
        load_with(&object_on_floor(), &variant("green")),
        &["no material variants"],
    );
    let mut bad = with_variants();
    bad.doc["meshes"][1]["primitives"][0]["extensions"]["KHR_materials_variants"]["mappings"][0]
        ["material"] = json!(9);
    assert_error(load(&bad), &["invalid glTF", "names material 9 of 4"]);
    let mut bad = with_variants();
    bad.doc["meshes"][1]["primitives"][0]["extensions"]["KHR_materials_variants"]["mappings"][0]
        ["variants"] = json!([5]);
    assert_error(load(&bad), &["invalid glTF", "names variant 5 of 3"]);
}

#[test]
fn clearcoat_and_sheen_files_load_as_their_base_material() {
    let mut gltf = object_on_floor();
    gltf.doc["materials"][OBJECT]["extensions"] = json!({
        "KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.0},
        "KHR_materials_sheen": {"sheenColorFactor": [1.0, 1.0, 1.0], "sheenRoughnessFactor": 0.5}});
    let plain = load(&object_on_floor()).expect("loads");
    gltf.uses("KHR_materials_clearcoat", true);
    gltf.uses("KHR_materials_sheen", true);
    let coated = load(&gltf).expect("a file requiring clearcoat and sheen loads");
    assert_eq!(box_material(&coated), box_material(&plain));
}

#[test]
fn a_scene_without_nodes_or_scenes_is_empty_not_an_error() {
    let cases = [
        ("a scene without nodes", json!({"scene": 0, "scenes": [{}]})),
        (
            "a scene with an empty node list",
            json!({"scenes": [{"nodes": []}]}),
        ),
        ("no scenes, no nodes", json!({})),
        (
            "nodes without meshes",
            json!({"scenes": [{"nodes": [0]}], "nodes": [{"name": "empty"}]}),
        ),
    ];
    for (what, doc) in cases {
        let mut gltf =
            json!({"asset": {"version": "2.0", "generator": "Khronos glTF Blender I/O"}});
        for (k, v) in doc.as_object().expect("object") {
            gltf[k] = v.clone();
        }
        let bytes = gltf.to_string().into_bytes();
        let scene = load_from_slice(&bytes, FILE, None).unwrap_or_else(|e| panic!("{what}: {e:#}"));
        assert!(
            scene.instances.is_empty() && scene.lights.is_empty(),
            "{what}"
        );
        let scene = load_from_slice_with(&bytes, FILE, None, &lit()).expect("loads");
        let light = &scene.lights[0];
        assert!(
            light.position.is_finite() && light.intensity.is_finite(),
            "{what}"
        );
    }
    // Genuinely malformed files are still errors.
    assert_error(
        load_from_slice(
            br#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": [3]}]}"#,
            FILE,
            None,
        ),
        &["invalid glTF"],
    );
    assert_error(
        load_from_slice(
            br#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": "x"}]}"#,
            FILE,
            None,
        ),
        &["malformed JSON"],
    );
}

#[test]
fn bad_emissive_data_is_an_error_when_non_finite_and_clamped_when_out_of_range() {
    let emissive = |factor: serde_json::Value, strength: Option<serde_json::Value>| {
        let mut gltf = object_on_floor();
        let m = &mut gltf.doc["materials"][OBJECT];
        m["name"] = json!("lamp");
        m["emissiveFactor"] = factor;
        if let Some(s) = strength {
            m["extensions"] = json!({"KHR_materials_emissive_strength": {"emissiveStrength": s}});
        }
        load(&gltf)
    };
    // JSON has no NaN: a number past f32's range is the non-finite value a file can hold.
    assert_error(
        emissive(json!([1e39, 0, 0]), None),
        &["material lamp", "non-finite emissiveFactor"],
    );
    assert_error(
        emissive(json!([1, 1, 1]), Some(json!(1e39))),
        &["material lamp", "non-finite emissiveStrength"],
    );
    let lamp = |s: anyhow::Result<Scene>| material(&s.expect("loads"), "lamp").emission;
    let watts = |nits: f32| nits / 683.0;
    assert!(close(
        lamp(emissive(json!([-1, 0.5, 0.5]), None)),
        Vec3::new(0.0, watts(0.5), watts(0.5))
    ));
    assert_eq!(
        lamp(emissive(json!([1, 1, 1]), Some(json!(-5)))),
        Vec3::ZERO
    );
    // Absurdly bright: scaled down to MAX_EMISSION, its colour kept.
    let bright = lamp(emissive(json!([1, 0.5, 0]), Some(json!(1e30))));
    assert!(
        close(bright / MAX_EMISSION, Vec3::new(1.0, 0.5, 0.0)),
        "{bright}"
    );
    let mut gltf = object_on_floor();
    gltf.doc["materials"][OBJECT] =
        json!({"name": "lamp", "extras": {"ispm": {"emission": [1e9, 1e9, 1e9]}}});
    assert_eq!(lamp(load(&gltf)), Vec3::splat(MAX_EMISSION));
}

#[test]
fn the_default_light_follows_the_camera_the_scene_is_seen_from() {
    let mut gltf = object_on_floor();
    let (eye, target) = (Vec3::new(3.0, 1.0, -1.0), Vec3::new(0.0, 0.4, 0.0));
    let rotation = ispm::scene::authoring::look_rotation(target - eye);
    let nodes = gltf.doc["nodes"].as_array_mut().expect("nodes");
    nodes.push(
        json!({"name": "side", "camera": 0, "translation": eye.to_array(),
                      "rotation": rotation.to_array()}),
    );
    let node = nodes.len() - 1;
    gltf.doc["scenes"][0]["nodes"]
        .as_array_mut()
        .expect("roots")
        .push(json!(node));
    let mut scene = load_with(&gltf, &lit()).expect("loads");
    let front = scene.lights[0].clone();
    scene.camera = scene.cameras[1];
    scene.aim_default_light();
    let side = &scene.lights[0];
    assert!(
        side.position.x > 1.0 && front.position.x.abs() < 2.0,
        "{side:?}"
    );
    assert!(side.direction.dot((target - side.position).normalize()) > 0.999);
    let irradiance = side.intensity.x / side.position.distance_squared(target);
    assert!((irradiance - DEFAULT_LIGHT_IRRADIANCE).abs() < 1e-3);
}
