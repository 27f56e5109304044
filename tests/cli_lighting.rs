//! Every glTF scene lit (issue #18), as a user runs `ispm`: a file with no light renders lit by
//! the default key light (and black, with a warning, under `--no-default-light`); exporters'
//! files with unlit, specular-glossiness, variant, clearcoat and sheen materials render lit;
//! an empty scene renders; bad variants and emission fail with one line. Small frames (64×48,
//! 4 000 photons, one frame) keep it fast.

mod common;

use common::cli::{assert_clean_failure, ispm};
use common::gltf_doc::{add_light, blender_material, object_on_floor, GltfDoc, OBJECT};
use glam::{Quat, Vec3};
use serde_json::json;
use std::path::Path;
use std::process::Output;

/// Renders `scene` with `ispm render` (ISPM unless `extra` says otherwise) into `out`; returns
/// the process output after asserting success.
fn render(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        scene.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
        "--size",
        "64x48",
        "--photons",
        "4000",
        "--frames",
        "1",
        "--shadow-resolution",
        "256",
    ];
    args.extend(extra);
    let o = ispm(&args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// Mean of the PNG's R, G and B channels (0–255).
fn mean_rgb(png: &Path) -> Vec3 {
    let img = image::open(png).expect("png").to_rgb8();
    let n = (img.width() * img.height()) as f32;
    img.pixels().fold(Vec3::ZERO, |s, p| {
        s + Vec3::new(f32::from(p[0]), f32::from(p[1]), f32::from(p[2]))
    }) / n
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A well-exposed object-on-a-floor frame: the mean sRGB value of a black frame is 0, the
/// default light's frame of this scene about 100.
const LIT: f32 = 30.0;

#[test]
fn a_file_without_lights_renders_lit_by_the_default_light_and_black_without_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = object_on_floor().write(dir.path(), "no-lights");
    let s = scene.to_str().expect("utf8");

    let lit = dir.path().join("lit.png");
    let o = render(&scene, &lit, &[]);
    let announce = format!(
        "ispm: {s} has no lights; adding a default key light (--no-default-light turns it off)"
    );
    assert!(stderr(&o).contains(&announce), "{}", stderr(&o));
    let mean = mean_rgb(&lit).element_sum() / 3.0;
    assert!(mean > LIT && mean < 200.0, "mean {mean}: not well exposed");

    // Every method sees the same light.
    let direct = dir.path().join("direct.png");
    render(&scene, &direct, &["--method", "direct"]);
    assert!(mean_rgb(&direct).element_sum() / 3.0 > LIT);
    let traced = dir.path().join("traced.exr");
    render(&scene, &traced, &["--method", "path-trace", "--spp", "2"]);
    let hdr = image::open(&traced).expect("exr").to_rgb32f().into_raw();
    assert!(hdr.iter().sum::<f32>() / hdr.len() as f32 > 0.05);

    let dark = dir.path().join("dark.png");
    let o = render(&scene, &dark, &["--no-default-light"]);
    assert!(
        stderr(&o).contains(&format!(
            "ispm: warning: {s} has no lights and --no-default-light"
        )),
        "{}",
        stderr(&o)
    );
    assert_eq!(mean_rgb(&dark), Vec3::ZERO, "nothing is lit");

    let plan = |extra: &[&str]| {
        let mut args = vec!["plan", s];
        args.extend(extra);
        let o = ispm(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let with = plan(&[]);
    assert!(
        with.contains("light 0 'default key light': direct + "),
        "{with}"
    );
    assert!(with.contains("default light: yes — "), "{with}");
    let without = plan(&["--no-default-light"]);
    assert!(!without.contains("light 0"), "{without}");
    assert!(
        without.contains("default light: no — --no-default-light"),
        "{without}"
    );
}

/// The box's mean colour stands out: `(red, green)` of the frame's mean.
fn red_green(png: &Path) -> (f32, f32) {
    let m = mean_rgb(png);
    (m.x, m.y)
}

#[test]
fn exporters_files_with_viewer_material_extensions_render_lit_with_ispm() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut cases: Vec<(&str, GltfDoc, Vec<&str>)> = Vec::new();

    let mut unlit = object_on_floor();
    unlit.doc["materials"][OBJECT] = json!({"name": "sign",
        "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.2, 0.1, 1.0]},
        "extensions": {"KHR_materials_unlit": {}}});
    unlit.uses("KHR_materials_unlit", true);
    cases.push(("unlit", unlit, vec![]));

    let mut spec_gloss = object_on_floor();
    spec_gloss.doc["materials"][OBJECT] = json!({"name": "jade", "extensions": {
        "KHR_materials_pbrSpecularGlossiness": {"diffuseFactor": [0.2, 0.7, 0.3, 1.0],
            "specularFactor": [0.05, 0.05, 0.05], "glossinessFactor": 0.4}}});
    spec_gloss.uses("KHR_materials_pbrSpecularGlossiness", true);
    cases.push(("spec-gloss", spec_gloss, vec![]));

    let mut coated = object_on_floor();
    coated.doc["materials"][OBJECT]["extensions"] = json!({
        "KHR_materials_clearcoat": {"clearcoatFactor": 1.0},
        "KHR_materials_sheen": {"sheenColorFactor": [1.0, 1.0, 1.0]}});
    coated.uses("KHR_materials_clearcoat", true);
    coated.uses("KHR_materials_sheen", true);
    cases.push(("clearcoat-sheen", coated, vec![]));

    let mut blender = object_on_floor();
    add_light(
        &mut blender,
        json!({"name": "Light", "type": "point", "color": [1, 1, 1],
               "intensity": 200.0 / (4.0 * std::f32::consts::PI) * 683.0}),
        Vec3::new(1.0, 2.5, 1.5),
        Quat::IDENTITY,
    );
    cases.push(("blender-point-light", blender, vec![]));

    let variants = || {
        let mut v = object_on_floor();
        v.doc["materials"] = json!([
            blender_material("floor", [0.8; 3]),
            blender_material("red", [0.8, 0.05, 0.05]),
            blender_material("green", [0.05, 0.8, 0.05]),
        ]);
        v.doc["meshes"][1]["primitives"][0]["extensions"] = json!({
            "KHR_materials_variants": {"mappings": [{"material": 2, "variants": [0]}]}});
        v.doc["extensions"] = json!({"KHR_materials_variants": {"variants": [{"name": "green"}]}});
        v.uses("KHR_materials_variants", false);
        v
    };
    cases.push(("variant-default", variants(), vec![]));
    cases.push(("variant-green", variants(), vec!["--variant", "green"]));

    let mut rendered = Vec::new();
    for (name, gltf, extra) in &cases {
        let scene = gltf.write(dir.path(), name);
        let png = dir.path().join(format!("{name}.png"));
        let o = render(&scene, &png, extra);
        let mean = mean_rgb(&png).element_sum() / 3.0;
        assert!(mean > LIT, "{name}: mean {mean}\n{}", stderr(&o));
        rendered.push((name, png, stderr(&o)));
    }
    let err = |case: &str| &rendered.iter().find(|r| *r.0 == case).expect("case").2;
    assert!(
        err("clearcoat-sheen")
            .contains("KHR_materials_clearcoat, KHR_materials_sheen approximated"),
        "{}",
        err("clearcoat-sheen")
    );
    assert!(
        !err("blender-point-light").contains("default key light"),
        "the file has a light"
    );
    // The unlit box shows its red; the variant shows its green instead of the default red.
    let (r, g) = red_green(&dir.path().join("unlit.png"));
    assert!(r > g + 5.0, "unlit red box: {r} {g}");
    let (r, g) = red_green(&dir.path().join("variant-default.png"));
    assert!(r > g + 5.0, "default red box: {r} {g}");
    let (r, g) = red_green(&dir.path().join("variant-green.png"));
    assert!(g > r + 5.0, "--variant green: {r} {g}");
}

#[test]
fn an_empty_scene_and_an_absurd_emitter_render_without_error_or_nan() {
    let dir = tempfile::tempdir().expect("tempdir");
    let empty = dir.path().join("empty.gltf");
    std::fs::write(
        &empty,
        r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{}]}"#,
    )
    .expect("write");
    let png = dir.path().join("empty.png");
    let o = render(&empty, &png, &[]);
    assert!(
        stderr(&o).contains("no triangle geometry"),
        "{}",
        stderr(&o)
    );
    assert_eq!(mean_rgb(&png), Vec3::ZERO, "the background");

    let mut bright = object_on_floor();
    let m = &mut bright.doc["materials"][OBJECT];
    m["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    m["extensions"] = json!({"KHR_materials_emissive_strength": {"emissiveStrength": 1e30}});
    let scene = bright.write(dir.path(), "bright");
    let exr = dir.path().join("bright.exr");
    let o = render(&scene, &exr, &[]);
    assert!(stderr(&o).contains("scaled down"), "{}", stderr(&o));
    let hdr = image::open(&exr).expect("exr").to_rgb32f().into_raw();
    assert!(hdr.iter().all(|v| v.is_finite()), "a non-finite pixel");
    assert!(hdr.iter().any(|&v| v > 1.0), "the emitter shows");
}

#[test]
fn an_unknown_variant_and_a_non_finite_emission_fail_with_one_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("out.png");
    let scene = object_on_floor().write(dir.path(), "plain");
    let o = ispm(&[
        "render",
        scene.to_str().expect("utf8"),
        "--variant",
        "purple",
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert_clean_failure(
        &o,
        "plain.gltf: no material variant \"purple\": the file has no material variants",
        &out,
    );
    let mut bad = object_on_floor();
    bad.doc["materials"][OBJECT]["emissiveFactor"] = json!([1e39, 0, 0]);
    let scene = bad.write(dir.path(), "bad");
    let o = ispm(&[
        "render",
        scene.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert_clean_failure(
        &o,
        "bad.gltf: material box: non-finite emissiveFactor",
        &out,
    );
}

#[test]
fn a_picture_that_comes_out_black_says_which_exposure_shows_it() {
    // The default light's frame at −10 EV is black as a PNG; `render` names the exposure that
    // brings it back (about +1 of the default exposure's mean, 0 ± 1.5 stops here), and a
    // well-exposed frame gets no note.
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = object_on_floor().write(dir.path(), "dim");
    let dark = dir.path().join("dark.png");
    let o = render(&scene, &dark, &["--exposure", "-10"]);
    assert!(mean_rgb(&dark).element_sum() / 3.0 < 2.0);
    let err = stderr(&o);
    let note = err
        .lines()
        .find(|l| l.starts_with("note: ") && l.contains("came out nearly black"))
        .unwrap_or_else(|| panic!("no exposure note: {err}"));
    let ev: f32 = note
        .split("; --exposure ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no exposure in {note:?}"));
    assert!(ev.abs() <= 1.5, "{note}");
    let shown = dir.path().join("shown.png");
    let o = render(&scene, &shown, &["--exposure", &ev.to_string()]);
    assert!(mean_rgb(&shown).element_sum() / 3.0 > LIT);
    assert!(!stderr(&o).contains("nearly black"), "{}", stderr(&o));
}
