//! Hard cases, budgets (issue #8): zero photons, one photon, a photon map split over several
//! buffers, and `--subsample` larger than the image, each rendered end to end with ISPM on
//! lavapipe with validation on (`common::hard`).

mod common;

use common::hard::{self, render_hard};
use ispm::frame::{RenderSettings, Renderer};
use ispm::photon::emit::light_flux;
use ispm::reference::scenes::{cornell, grey_box};

#[test]
fn zero_photons() {
    // No photon at all: the frame is the direct light alone, the same as `--method direct`.
    let scene = cornell(2);
    let f = render_hard("zero_photons", &scene, hard::settings_for(0));
    assert_eq!(f.frame.stats.emitted_photons, 0);
    assert_eq!(f.frame.stats.stored_photons, 0);
    let direct = hard::render_direct(&scene, hard::settings_for(0));
    hard::assert_same_image("zero_photons", &f.frame, &direct, 1e-6);
}

#[test]
fn one_photon() {
    // One photon asked for: each of the point light's six views gets one texel, and the
    // bounce map still carries exactly its flux (walls of albedo 1).
    let scene = grey_box(1.0, 2.0);
    let f = render_hard("one_photon", &scene, hard::settings_for(1));
    let flux = f64::from(light_flux(&scene.lights[0], &scene.bounds()).x);
    let power = f.bounce_map_power().x;
    eprintln!(
        "one_photon: {} texels, bounce map {power:.6} W of {flux:.6} W, {} stored",
        f.frame.stats.emitted_photons, f.frame.stats.stored_photons
    );
    assert_eq!(f.frame.stats.emitted_photons, 6);
    assert!((power - flux).abs() < 1e-4 * flux, "{power} vs {flux}");
    assert!(f.frame.stats.stored_photons > 0);
}

#[test]
fn more_photons_than_fit_in_one_buffer() {
    // The photon map split over buffers of 1000 photons draws the same image as one buffer.
    let scene = cornell(2);
    let case = "more_photons_than_fit_in_one_buffer";
    let one = render_hard(case, &scene, hard::settings_for(20_000));
    let split = render_hard(
        case,
        &scene,
        RenderSettings {
            photons_per_buffer: Some(1000),
            ..hard::settings_for(20_000)
        },
    );
    let stored = split.frame.stats.stored_photons;
    eprintln!(
        "{case}: {stored} photons in {} buffers (one buffer: {})",
        split.frame.stats.photon_buffers, one.frame.stats.photon_buffers
    );
    assert_eq!(one.frame.stats.photon_buffers, 1);
    assert_eq!(split.frame.stats.photon_buffers, stored.div_ceil(1000));
    assert_eq!(stored, one.frame.stats.stored_photons, "the same photons");
    // The GPU value check (which found nothing bad: `render_hard`) read every buffer.
    let checked = |f: &hard::HardFrame| {
        let check = f.frame.stats.value_check.as_ref();
        check.and_then(|c| c.buffer("photon_map")).map(|b| b.values)
    };
    assert_eq!(checked(&split), Some(12 * stored as u64));
    assert_eq!(checked(&one), checked(&split));
    hard::assert_same_image(case, &split.frame, &one.frame, 1e-5);
}

#[test]
fn subsample_larger_than_the_image() {
    // `--subsample 1000` on a 64×64 image: the factor is clamped to 64 (one low-resolution
    // pixel), and the frame keeps its direct light and stays finite.
    let scene = cornell(2);
    let case = "subsample_larger_than_the_image";
    let full = render_hard(case, &scene, hard::settings_for(20_000));
    let coarse = render_hard(
        case,
        &scene,
        RenderSettings {
            subsample: 1000,
            ..hard::settings_for(20_000)
        },
    );
    assert_eq!(coarse.frame.stats.subsample, hard::SIZE);
    let (a, b) = (coarse.mean().element_sum(), full.mean().element_sum());
    eprintln!("{case}: mean radiance {a:.4} at 1×1 indirect, {b:.4} at full resolution");
    assert!(a > 0.5 * b && a < 2.0 * b, "{a} against {b}");
}

#[test]
fn a_bounce_map_beyond_one_buffer_is_an_error_not_a_fault() {
    // 5 M photons from one point light: six views of 913² texels, 160 MB of bounce map, past
    // one storage buffer's reach on lavapipe (128 MiB). The bounce map is not split (yet): the
    // renderer refuses with the sizes, before any GPU work, instead of binding what the device
    // cannot read. (On devices whose reach is larger the frame is made; nothing is rendered.)
    let gpu = common::gpu();
    let reach = u64::from(gpu.properties.max_storage_buffer_range);
    let scene = grey_box(1.0, 1.0);
    let settings = hard::settings_for(5_000_000);
    match Renderer::new(&gpu, &scene, settings) {
        Err(e) => {
            let message = format!("{e:#}");
            eprintln!("{message}");
            assert!(
                message.contains("bounce map") && message.contains("bytes"),
                "{message}"
            );
        }
        Ok(r) => {
            let texels = r.photons().map_or(0, |p| p.plan().texels);
            eprintln!("made: {texels} texels, reach {reach}");
            assert!(
                reach >= 5_000_000 * 32,
                "a {reach}-byte reach accepted 160 MB"
            );
        }
    }
    common::assert_validation_clean(&gpu);
}
