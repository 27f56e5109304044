//! The tiled density estimator (`--density tiled`, `passes/photon_tiles.rs`) computes, pixel
//! for pixel, what the photon volumes compute from the same photons: at full resolution and
//! subsampled, on diffuse and caustic light, over a photon map split across buffers, and with
//! the eye inside kernels. Validation on. (Against the CPU gather: `tests/ispm.rs`.)

mod common;

use ispm::config::settings::{Density, Method, RenderSettings, TileOrder};
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::Scene;

fn render(scene: &Scene, settings: RenderSettings) -> (FrameImage, Vec<String>) {
    let gpu = common::gpu();
    let mut renderer = Renderer::new(&gpu, scene, settings).expect("renderer");
    let frame = renderer.render().expect("render");
    common::assert_validation_clean(&gpu);
    let passes = frame.stats.passes_run.clone();
    (frame, passes)
}

fn settings(density: Density) -> RenderSettings {
    RenderSettings {
        method: Method::Ispm,
        photons: 20_000,
        width: 96,
        height: 72,
        shadow_resolution: 256,
        density,
        ..Default::default()
    }
}

/// Renders `scene` with both estimators and checks every pixel of the HDR frames agree to
/// `1e-4` of the brightest pixel (the sums differ in f32 summation order only), writing
/// actual, expected and difference images when they do not.
fn assert_same_estimate(case: &str, scene: &Scene, settings: RenderSettings) {
    let (volumes, ran_v) = render(
        scene,
        RenderSettings {
            density: Density::Volumes,
            ..settings.clone()
        },
    );
    let (tiled, ran_t) = render(
        scene,
        RenderSettings {
            density: Density::Tiled,
            ..settings
        },
    );
    assert!(ran_v.iter().any(|p| p == "photon_volumes"), "{ran_v:?}");
    assert!(!ran_v.iter().any(|p| p == "photon_tiles"), "{ran_v:?}");
    assert!(ran_t.iter().any(|p| p == "photon_tiles"), "{ran_t:?}");
    assert!(!ran_t.iter().any(|p| p == "photon_volumes"), "{ran_t:?}");
    assert!(volumes.stats.stored_photons > 1000, "{case}: no photons");
    assert_eq!(volumes.stats.stored_photons, tiled.stats.stored_photons);
    let peak = volumes.hdr.iter().fold(0.0f32, |a, &v| a.max(v));
    let worst = volumes
        .hdr
        .iter()
        .zip(&tiled.hdr)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    if worst > 1e-4 * peak {
        let dir = common::image_dir(case);
        let diff: Vec<f32> = volumes
            .hdr
            .iter()
            .zip(&tiled.hdr)
            .map(|(a, b)| (a - b).abs())
            .collect();
        for (name, img) in [
            ("actual", &tiled.hdr),
            ("expected", &volumes.hdr),
            ("difference", &diff),
        ] {
            let path = dir.join(format!("{name}.exr"));
            ispm::output::write_exr(&path, volumes.width, volumes.height, img).expect("exr");
            eprintln!("wrote {}", path.display());
        }
    }
    assert!(
        worst <= 1e-4 * peak,
        "{case}: tiled vs volumes differ by {worst} (peak {peak})"
    );
}

fn bundled(name: &str) -> Scene {
    ispm::scene::bundled::resolve(Some(name)).expect("bundled scene")
}

#[test]
fn the_tiled_gather_equals_the_photon_volumes_pixel_for_pixel() {
    // Diffuse interreflection, glossy and Fresnel surfaces, the glass sphere's caustic.
    assert_same_estimate(
        "tiled_cornell",
        &bundled("cornell-box"),
        settings(Density::Auto),
    );
    // Partial tiles at the right and bottom edges.
    assert_same_estimate(
        "tiled_partial_tiles",
        &bundled("cornell-box"),
        RenderSettings {
            width: 90,
            height: 70,
            ..settings(Density::Auto)
        },
    );
    // A caustic of caustic photons only (no same-surface rule, no support normalisation).
    assert_same_estimate(
        "tiled_caustic_ring",
        &bundled("caustic-ring"),
        settings(Density::Auto),
    );
}

#[test]
fn the_tiled_gather_equals_the_photon_volumes_when_subsampled() {
    // 96×72 divides by 2 and 3; 97×71 by neither 3 nor 4, so the low-resolution grid is
    // stretched against the full-resolution one (the photon volumes' billboards must cover the
    // drift).
    for (subsample, width, height) in [(2, 96, 72), (3, 96, 72), (3, 97, 71), (4, 97, 71)] {
        assert_same_estimate(
            &format!("tiled_subsample_{subsample}_{width}x{height}"),
            &bundled("cornell-box"),
            RenderSettings {
                subsample,
                width,
                height,
                ..settings(Density::Auto)
            },
        );
    }
}

#[test]
fn the_tiled_gather_adds_every_buffer_of_a_split_photon_map() {
    // 1000 photons a buffer: the map spans many buffers, one dispatch each, all added.
    let settings = RenderSettings {
        storage_buffer_range: Some(48_000),
        ..settings(Density::Auto)
    };
    let (frame, _) = render(&bundled("cornell-box"), settings.clone());
    assert!(frame.stats.photon_buffers > 3, "{:?}", frame.stats);
    assert_same_estimate("tiled_split", &bundled("cornell-box"), settings);
}

#[test]
fn a_caustic_focus_longer_than_one_dispatch_gathers_every_photon() {
    // glass-sphere's focus at 64²: one tile lists ~200k photons, more than one dispatch
    // gathers (TILE_JOB; lavapipe ends an invocation's loops after 65535 iterations), so its
    // list is gathered in several dispatches that continue each other's sums.
    let settings = RenderSettings {
        photons: 640_000,
        width: 64,
        height: 64,
        ..settings(Density::Auto)
    };
    let (tiled, _) = render(
        &bundled("glass-sphere"),
        RenderSettings {
            density: Density::Tiled,
            ..settings.clone()
        },
    );
    let tiles = tiled.stats.tiles.expect("tile stats");
    assert!(
        tiles.longest > 2 * ispm::layout::shared_constants::TILE_JOB as usize
            && tiles.dispatches > 2,
        "{tiles:?}"
    );
    assert_same_estimate("tiled_long_lists", &bundled("glass-sphere"), settings);
}

/// The order in which the workgroups take the tiles (row-major on a GPU, cost-balanced on a
/// CPU device, `passes/photon_tiles/order.rs`) changes which tiles run side by side, never a
/// pixel's sum: both orders give the same frame bit for bit, at full resolution, subsampled
/// with the fine photons at full resolution, and over a split photon map.
#[test]
fn every_tile_order_gives_the_same_frame_bit_for_bit() {
    let cases = [
        ("cornell-box", settings(Density::Tiled)),
        (
            "glass-sphere",
            RenderSettings {
                subsample: 3,
                ..settings(Density::Tiled)
            },
        ),
        (
            "caustic-ring",
            RenderSettings {
                storage_buffer_range: Some(48_000),
                ..settings(Density::Tiled)
            },
        ),
    ];
    for (name, settings) in cases {
        let scene = bundled(name);
        let [(rows, ran), (balanced, _)] = [TileOrder::Rows, TileOrder::Balanced].map(|order| {
            render(
                &scene,
                RenderSettings {
                    tile_order: order,
                    ..settings.clone()
                },
            )
        });
        assert!(ran.iter().any(|p| p == "photon_tiles"), "{name}: {ran:?}");
        if settings.subsample > 1 {
            assert!(ran.iter().any(|p| p == "fine_photons"), "{name}: {ran:?}");
        }
        assert!(rows.stats.stored_photons > 1000, "{name}: no photons");
        let differ = rows
            .hdr
            .iter()
            .zip(&balanced.hdr)
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        assert_eq!(
            differ, 0,
            "{name}: {differ} values differ between the orders"
        );
    }
}

#[test]
fn auto_picks_the_tiled_gather_wherever_the_device_has_its_subgroup_operations() {
    assert_eq!(Density::Auto.resolve(true), Density::Tiled);
    // Without the subgroup operations the gather needs, the volumes.
    assert_eq!(Density::Auto.resolve(false), Density::Volumes);
    for d in [Density::Volumes, Density::Tiled] {
        assert_eq!(d.resolve(true), d);
        assert_eq!(d.resolve(false), d);
    }
    // The renderer resolves it before planning: its frames name the pass that ran.
    let gpu = common::gpu();
    let expected = Density::Auto.resolve_for_device(&gpu.properties);
    let (_, ran) = render(&bundled("cornell-box"), settings(Density::Auto));
    assert!(ran.iter().any(|p| p == expected.pass().name()), "{ran:?}");
    assert_eq!(common::estimator_pass(), expected.pass().name());
}
