//! The reference renderers agree with each other, are scale invariant, never produce NaN,
//! stop when cancelled, and write their EXR atomically.

use glam::{Mat4, Vec2, Vec3};
use ispm::config::settings::Method;
use ispm::reference::{
    render,
    scenes::{cornell, furnace_sphere, scaled},
    HdrImage, RefSettings,
};
use ispm::scene::{Instance, Mesh};
use std::sync::atomic::AtomicBool;

fn small(spp: u32, photons: usize) -> RefSettings {
    RefSettings {
        width: 24,
        height: 24,
        spp,
        jitter: true,
        photons,
        bounces: 16,
        iterations: 2,
        radius: None,
        alpha: 2.0 / 3.0,
        seed: 1,
    }
}

fn go(scene: &ispm::scene::Scene, method: Method, s: &RefSettings) -> HdrImage {
    render(scene, method, s, None, &AtomicBool::new(false)).unwrap()
}

/// Mean over pixels of |a − b| / mean(a): the relative L1 difference.
fn relative_l1(a: &HdrImage, b: &HdrImage) -> f64 {
    let diff: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| p.iter().zip(q).map(|(x, y)| (x - y).abs() as f64))
        .sum();
    diff / (a.pixels.len() * 3) as f64 / a.mean()
}

/// Scaling the scene by 1000 (point intensity × 1000²) leaves the radiance unchanged.
/// Path tracing: the random numbers are per pixel, so both renders follow the same paths; only
/// float rounding differs (it can flip a rare path at an edge): 1 % on the mean, 2 % relative
/// L1. Photon gather: photon paths are seeded by where they start, which scales too, so the
/// two photon maps are independent samples; the scaled image must differ from the original no
/// more than a render with another seed does (×1.3), and its mean by less than 3 %.
#[test]
fn scene_scaled_by_1000_renders_the_same_image() {
    let scene = cornell(2);
    let big = scaled(&scene, 1000.0);
    let s = small(2, 0);
    let (a, b) = (
        go(&scene, Method::PathTrace, &s),
        go(&big, Method::PathTrace, &s),
    );
    let l1 = relative_l1(&a, &b);
    eprintln!(
        "path-trace: mean {:.5} vs {:.5}, relative L1 {l1:.5}",
        a.mean(),
        b.mean()
    );
    assert!((b.mean() / a.mean() - 1.0).abs() < 0.01);
    assert!(l1 < 0.02, "path-trace: relative L1 {l1}");

    let s = small(1, 40_000);
    let a = go(&scene, Method::PhotonGather, &s);
    let b = go(&big, Method::PhotonGather, &s);
    let other_seed = go(&scene, Method::PhotonGather, &RefSettings { seed: 99, ..s });
    let (l1, noise) = (relative_l1(&a, &b), relative_l1(&a, &other_seed));
    eprintln!(
        "photon-gather: mean {:.5} vs {:.5}, relative L1 {l1:.4} (seed-to-seed {noise:.4})",
        a.mean(),
        b.mean()
    );
    assert!((b.mean() / a.mean() - 1.0).abs() < 0.03);
    assert!(
        l1 < 1.3 * noise,
        "photon-gather: L1 {l1} vs seed noise {noise}"
    );
}

/// Photon gather (estimator `f·Φ·κ`, no cosine) converges to the path tracer on a Cornell box
/// (flat walls, where the ellipsoid kernel loses no mass except at the corners). With a
/// cosine factor the indirect light would be about 1/3 lower (E[cos] = 2/3 for the
/// cosine-distributed diffuse photons), i.e. the whole image ≈ 10 % darker.
#[test]
fn photon_gather_and_progressive_match_path_trace_on_a_cornell_box() {
    let scene = cornell(2);
    let pt = go(&scene, Method::PathTrace, &small(16, 0));
    let pg = go(&scene, Method::PhotonGather, &small(1, 60_000));
    let ppm = go(
        &scene,
        Method::Progressive,
        &RefSettings {
            iterations: 4,
            ..small(1, 30_000)
        },
    );
    for (name, img) in [("photon-gather", &pg), ("progressive", &ppm)] {
        let ratio = img.mean() / pt.mean();
        eprintln!(
            "{name}: mean {:.5} vs path-trace {:.5} (ratio {ratio:.4}), relative L1 {:.4}",
            img.mean(),
            pt.mean(),
            relative_l1(&pt, img)
        );
        assert!((ratio - 1.0).abs() < 0.03, "{name}: ratio {ratio}");
    }
}

#[test]
fn zero_power_lights_and_degenerate_triangles_render_finite_images() {
    let mut scene = furnace_sphere(2, 0.5, 1.0);
    let p = vec![
        Vec3::splat(0.3),
        Vec3::splat(0.3),
        Vec3::splat(0.5),
        Vec3::new(0.1, 0.2, 0.3),
    ];
    scene.meshes.push(Mesh {
        name: "degenerate".into(),
        normals: vec![Vec3::Y; p.len()],
        uvs: vec![Vec2::ZERO; p.len()],
        positions: p,
        triangles: vec![[0, 1, 2], [0, 0, 3], [3, 3, 3]],
        material: 0,
    });
    scene.instances.push(Instance {
        name: "degenerate".into(),
        mesh: 1,
        transform: Mat4::IDENTITY,
    });
    for intensity in [1.0, 0.0] {
        scene.lights[0].intensity = Vec3::splat(intensity);
        for method in [Method::PathTrace, Method::PhotonGather, Method::Progressive] {
            let img = go(&scene, method, &small(1, 2_000));
            assert!(img
                .pixels
                .iter()
                .flatten()
                .all(|c| c.is_finite() && *c >= 0.0));
            if intensity == 0.0 {
                assert_eq!(img.mean(), 0.0, "{method:?}");
            }
        }
    }
}

#[test]
fn renders_are_deterministic_for_a_seed() {
    let scene = cornell(1);
    for method in [Method::PathTrace, Method::PhotonGather] {
        let s = small(2, 5_000);
        assert_eq!(go(&scene, method, &s), go(&scene, method, &s), "{method:?}");
    }
}

#[test]
fn cancelled_render_stops_without_an_image() {
    let scene = cornell(1);
    let cancel = AtomicBool::new(true);
    let result = render(&scene, Method::PathTrace, &small(4, 0), None, &cancel);
    assert!(result.is_err());
}

#[test]
fn exr_is_written_atomically_and_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.exr");
    let img = HdrImage {
        width: 3,
        height: 2,
        pixels: (0..6).map(|i| [i as f32, 0.5, 2.0]).collect(),
    };
    img.write_exr(&path).unwrap();
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(names.len(), 1, "no temporary file left behind");
    let back = image::open(&path).unwrap().into_rgb32f();
    assert_eq!(back.get_pixel(2, 0).0, [2.0, 0.5, 2.0]);
    // A folder that does not exist: an error, and nothing written.
    assert!(img.write_exr(&dir.path().join("missing/out.exr")).is_err());
}

/// Cancelling after the first pass keeps the complete passes: an image, and fewer rows
/// rendered than asked for.
#[test]
fn cancel_after_first_pass_returns_the_last_complete_image() {
    let scene = cornell(1);
    let settings = small(400, 0);
    let bar = indicatif::ProgressBar::hidden();
    let cancel = AtomicBool::new(false);
    let image = std::thread::scope(|s| {
        s.spawn(|| {
            while bar.position() < settings.height as u64 {
                std::thread::yield_now();
            }
            cancel.store(true, std::sync::atomic::Ordering::Relaxed);
        });
        render(&scene, Method::PathTrace, &settings, Some(&bar), &cancel)
    })
    .unwrap();
    assert!(image.mean() > 0.0 && image.pixels.iter().flatten().all(|c| c.is_finite()));
    assert!(bar.position() < 400 * settings.height as u64);
}
