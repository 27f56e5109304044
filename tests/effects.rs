//! Shader variants of the effects plan (issue #9), on lavapipe with validation on: compiling out
//! a lobe no material has leaves the image as it was, and compiling out one a material has
//! changes it (so the specialisation constants really reach the shaders).

mod common;

use ispm::config::settings::Effects;
use ispm::config::settings::{Method, RenderSettings};
use ispm::photon::bsdf::BsdfVariant;
use ispm::plan::EffectsPlan;
use ispm::reference::scenes;
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::{bundled, Scene};

const SIZE: u32 = 96;

/// The largest difference allowed between the two variants' images, relative to the brightest
/// channel of the image: the variants differ only in code that adds exact zeros, so the
/// difference is rounding from the compiler treating the two shaders differently, at most.
/// Measured on lavapipe: 0 (bit-identical) for every case below.
const TOLERANCE: f32 = 1e-5;

fn settings(variant: BsdfVariant, subsample: u32) -> RenderSettings {
    RenderSettings {
        method: Method::Ispm,
        photons: 20_000,
        width: SIZE,
        height: SIZE,
        shadow_resolution: 256,
        subsample,
        bsdf_variant: variant,
        // The variant as given: the plan would otherwise narrow it to what the scene needs.
        effects: Effects::All,
        ..Default::default()
    }
}

fn render(scene: &Scene, settings: RenderSettings) -> FrameImage {
    let gpu = common::gpu();
    let frame = {
        let mut r = Renderer::new(&gpu, scene, settings).expect("renderer");
        r.render().expect("render")
    };
    common::assert_validation_clean(&gpu);
    frame
}

/// Largest per-channel difference of the linear images, relative to `a`'s brightest channel.
fn relative_difference(a: &FrameImage, b: &FrameImage) -> f32 {
    let peak = a.hdr.iter().fold(0.0f32, |m, v| m.max(*v));
    let worst = a
        .hdr
        .iter()
        .zip(&b.hdr)
        .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
    assert!(peak > 0.0, "black image");
    worst / peak
}

fn save(test: &str, name: &str, frame: &FrameImage) -> std::path::PathBuf {
    let png = common::image_dir(test).join(format!("{name}.png"));
    ispm::output::write_png(&png, frame.width, frame.height, &frame.ldr).expect("png");
    png
}

/// Renders `scene` with every lobe and with `reduced`, and asserts the images agree.
fn assert_same_image(test: &str, scene: &Scene, reduced: BsdfVariant, subsample: u32) {
    let all = render(scene, settings(BsdfVariant::ALL, subsample));
    let planned = render(scene, settings(reduced, subsample));
    let diff = relative_difference(&all, &planned);
    println!("{test}: largest relative difference {diff:e}");
    if diff > TOLERANCE {
        save(test, "all", &all);
        let png = save(test, "planned", &planned);
        panic!(
            "{test}: the {reduced:?} image differs from every lobe's by {diff:e} of the peak \
             ({})",
            png.display()
        );
    }
}

#[test]
fn a_scene_without_glossy_materials_renders_the_same_with_the_glossy_lobe_compiled_out() {
    // Glass (mirror + refraction, Fresnel, σ = ∞) on a diffuse floor: no finite glossy lobe;
    // the bounce map, photon volumes, direct, environment and translucent passes all run.
    let scene = bundled::resolve(Some("glass-sphere")).expect("bundled");
    let auto = RenderSettings {
        effects: Effects::Auto,
        ..settings(BsdfVariant::ALL, 1)
    };
    let plan = EffectsPlan::analyse(&scene, &auto, &scene.camera);
    assert_eq!(
        plan.bsdf_variant(),
        BsdfVariant {
            glossy: false,
            delta: true
        },
        "{plan}"
    );
    assert_same_image("effects_glossy_off", &scene, plan.bsdf_variant(), 1);
}

#[test]
fn a_diffuse_scene_renders_the_same_with_glossy_and_delta_lobes_compiled_out() {
    let scene = scenes::cornell(2);
    let auto = RenderSettings {
        effects: Effects::Auto,
        ..settings(BsdfVariant::ALL, 1)
    };
    let plan = EffectsPlan::analyse(&scene, &auto, &scene.camera);
    let none = BsdfVariant {
        glossy: false,
        delta: false,
    };
    assert_eq!(plan.bsdf_variant(), none, "{plan}");
    assert_same_image("effects_diffuse_full_resolution", &scene, none, 1);
    // The subsampled photon volumes and the upsample pass evaluate the lobes too.
    assert_same_image("effects_diffuse_subsampled", &scene, none, 2);
}

#[test]
fn compiling_out_a_lobe_that_a_material_has_changes_the_image() {
    // The Cornell box's purple sphere is glossy: without the lobe it loses its highlight and
    // the light it reflects.
    let scene = bundled::resolve(Some("cornell-box")).expect("bundled");
    let all = render(&scene, settings(BsdfVariant::ALL, 1));
    let no_glossy = render(
        &scene,
        settings(
            BsdfVariant {
                glossy: false,
                delta: true,
            },
            1,
        ),
    );
    let diff = relative_difference(&all, &no_glossy);
    assert!(
        diff > 1e-2,
        "the glossy switch changed nothing ({diff:e}): are the specialisation constants set?"
    );
    // Its glass sphere refracts and reflects: without delta lobes it is nearly black.
    let no_delta = render(
        &scene,
        settings(
            BsdfVariant {
                glossy: true,
                delta: false,
            },
            1,
        ),
    );
    let diff = relative_difference(&all, &no_delta);
    assert!(diff > 1e-2, "the delta switch changed nothing ({diff:e})");
}
