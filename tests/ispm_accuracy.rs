//! How accurate ISPM is (issue #4), on lavapipe with validation on:
//! - the GPU bounce map is statistically the CPU emitter's first bounce (power per light, where
//!   the photons land, where they go, which lobes they took), over several seeds;
//! - against the CPU path tracer the indirect light converges as photons grow and kernels
//!   shrink (the curve is printed and recorded in `docs/accuracy.md`);
//! - renders are bit-identical frame to frame, and match checked-in goldens
//!   (`tests/goldens/*.exr`, `ISPM_BLESS=1` rewrites them);
//! - the Cornell box bleeds colour where it should.
//!
//! `cargo test --test ispm_accuracy -- --nocapture` prints every measured number.

mod common;
mod ispm_accuracy {
    pub mod bounce_stats;
    pub mod references;
}

use common::golden::{assert_matches_golden, rel_mse};
use glam::Vec3;
use ispm::config::settings::{Method, RenderSettings};
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::Scene;
use ispm_accuracy::bounce_stats::{compare, cpu_bounces, gpu_bounces, histograms, Tally};
use ispm_accuracy::references::{
    block_means, first_hits, mean, path_traced, progressive_indirect, Reference,
    CONVERGENCE_BOUNCES, CONVERGENCE_SIZE, PROGRESSIVE_ITERATIONS, REFERENCE_PASSES,
};

pub(crate) fn settings(width: u32, height: u32, photons: usize, seed: u32) -> RenderSettings {
    RenderSettings {
        method: Method::Ispm,
        photons,
        seed,
        width,
        height,
        shadow_resolution: 256,
        ..Default::default()
    }
}

pub(crate) fn render(scene: &Scene, settings: RenderSettings) -> (Renderer, FrameImage) {
    let gpu = common::gpu();
    let mut renderer = Renderer::new(&gpu, scene, settings).expect("renderer");
    let frame = renderer.render().expect("render");
    common::assert_validation_clean(&gpu);
    (renderer, frame)
}

fn bundled(name: &str) -> Scene {
    ispm::scene::bundled::resolve(Some(name)).expect("bundled scene")
}

// ---------------------------------------------------------------------------------------------
// Determinism and goldens
// ---------------------------------------------------------------------------------------------

const GOLDEN_SIZE: u32 = 96;
const GOLDEN_PHOTONS: usize = 20_000;
const GOLDEN_SEED: u32 = 7;
/// relMSE allowed against a golden. The pipeline is bit-deterministic on one driver (relMSE 0
/// on lavapipe); this leaves room for another driver's rounding while still catching a changed
/// estimate: two different seeds already differ by ~10⁻² on these scenes (photon noise).
const GOLDEN_THRESHOLD: f64 = 2e-3;

#[test]
fn static_scene_renders_bit_identical_frames() {
    let scene = bundled("cornell-box");
    let (mut renderer, first) = render(&scene, settings(48, 48, 8_000, 3));
    let second = renderer.render().expect("second frame");
    let (_, fresh) = render(&scene, settings(48, 48, 8_000, 3));
    let bits = |f: &FrameImage| f.hdr.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert!(first.stats.stored_photons > 1_000, "{:?}", first.stats);
    assert_eq!(first.stats.stored_photons, second.stats.stored_photons);
    assert!(
        bits(&first) == bits(&second),
        "the same renderer drew two different frames"
    );
    assert!(
        bits(&first) == bits(&fresh),
        "two renderers drew different frames"
    );
    assert_eq!(first.ldr, fresh.ldr);
    // A different seed is a different (equally valid) image: the seed reaches the photons.
    let (_, other) = render(&scene, settings(48, 48, 8_000, 4));
    let noise = rel_mse(&other.hdr, &first.hdr);
    eprintln!("cornell-box 48², 8k photons: relMSE between seeds 3 and 4 = {noise:.3e}");
    assert!(noise > 0.0, "the seed changes nothing");
}

fn golden(name: &str) {
    let scene = bundled(name);
    let (_, frame) = render(
        &scene,
        settings(GOLDEN_SIZE, GOLDEN_SIZE, GOLDEN_PHOTONS, GOLDEN_SEED),
    );
    assert!(
        frame.hdr.iter().all(|v| v.is_finite()),
        "{name}: non-finite"
    );
    assert_matches_golden(
        &format!("ispm-{name}"),
        GOLDEN_SIZE,
        GOLDEN_SIZE,
        &frame.hdr,
        GOLDEN_THRESHOLD,
    );
}

#[test]
fn golden_cornell_box() {
    golden("cornell-box");
}

#[test]
fn golden_caustic_ring() {
    golden("caustic-ring");
}

#[test]
fn golden_glass_sphere() {
    golden("glass-sphere");
}

/// The glass sphere's golden frame shows the focused caustic: the brightest indirect light lies
/// where the ball lens's axis (from the spot through the sphere's centre) meets the plane, in
/// front of the sphere, and focused there it outshines the spot's direct light on the plane
/// (measured at 96², 20k photons: 0.2 px from the axis, 32× the lit plane).
#[test]
fn glass_sphere_focuses_its_caustic_where_the_ball_lens_axis_meets_the_plane() {
    let scene = bundled("glass-sphere");
    let size = GOLDEN_SIZE;
    let (renderer, frame) = render(&scene, settings(size, size, GOLDEN_PHOTONS, GOLDEN_SEED));
    let indirect = renderer
        .photons()
        .expect("ispm")
        .read_indirect()
        .expect("indirect");
    let luminance = |p: &[f32]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    let mut order: Vec<(f32, usize)> = indirect
        .chunks_exact(4)
        .map(luminance)
        .enumerate()
        .map(|(i, l)| (l, i))
        .collect();
    order.sort_by(|a, b| b.0.total_cmp(&a.0));
    // The brightest 0.5 % of the pixels: the caustic's core.
    let top = &order[..(order.len() / 200).max(4)];
    let weight: f32 = top.iter().map(|t| t.0).sum();
    let centroid = top.iter().fold(glam::Vec2::ZERO, |c, &(l, i)| {
        let (x, y) = (
            (i as u32 % size) as f32 + 0.5,
            (i as u32 / size) as f32 + 0.5,
        );
        c + glam::Vec2::new(x, y) * l / weight
    });
    let sphere = scene
        .instances
        .iter()
        .find(|i| i.name == "glass-sphere")
        .expect("sphere")
        .transform
        .w_axis
        .truncate();
    let light = scene.lights[0].position;
    // The paraxial focus lies 0.75 m down the axis, 0.65 m to the plane: the caustic's core is
    // where the axis meets the plane.
    let axis_hit = sphere + (sphere - light) * (sphere.y / (light.y - sphere.y));
    let project = |p: Vec3| {
        scene
            .camera
            .project_to_pixel(p, size, size)
            .expect("in front of the camera")
    };
    let expected = project(axis_hit);
    let peak = weight / top.len() as f32;
    // The plane beside the sphere, lit by the spot and outside the sphere's shadow.
    let lit = project(Vec3::new(0.0, 0.0, 0.9));
    let at = |v: glam::Vec2| (v.y as u32 * size + v.x as u32) as usize;
    let lit_radiance = luminance(&frame.hdr[4 * at(lit)..4 * at(lit) + 4]);
    eprintln!(
        "glass-sphere caustic: core at {centroid} px, axis meets the plane at {expected} px; core \
         radiance {peak:.3} vs the lit plane's {lit_radiance:.3}"
    );
    assert!(
        centroid.distance(expected) < 3.0,
        "the caustic's core is at {centroid} px, the ball lens focuses at {expected} px"
    );
    assert!(
        peak > 10.0 * lit_radiance,
        "the caustic's core ({peak}) is not focused: the lit plane shows {lit_radiance}"
    );
}

#[test]
fn a_golden_mismatch_fails_and_writes_actual_expected_and_difference_images() {
    let (w, h) = (8, 8);
    let expected: Vec<f32> = (0..w * h * 4).map(|i| (i % 7) as f32 * 0.1).collect();
    let path = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("golden-selftest.exr");
    ispm::output::write_exr(&path, w, h, &expected).expect("write");
    let expected = ispm::output::read_exr(&path).expect("read").2;
    // Equal images pass with relMSE 0 (unless ISPM_BLESS=1, which rewrites the temporary file).
    let same =
        common::golden::assert_matches_golden_at(&path, "golden-selftest", w, h, &expected, 1e-6);
    assert_eq!(same, 0.0);
    if std::env::var_os("ISPM_BLESS").is_some_and(|v| v == "1") {
        return;
    }
    let brighter: Vec<f32> = expected.iter().map(|v| v * 1.5 + 0.1).collect();
    let failed = std::panic::catch_unwind(|| {
        common::golden::assert_matches_golden_at(&path, "golden-selftest", w, h, &brighter, 1e-3)
    });
    assert!(failed.is_err(), "a 50 % brighter image passed");
    let dir = common::image_dir("golden-selftest");
    for file in [
        "actual.exr",
        "actual.png",
        "expected.exr",
        "expected.png",
        "difference.png",
    ] {
        assert!(dir.join(file).is_file(), "{file} not written");
    }
}

/// Mean indirect radiance over the floor pixels (world y < 1 cm, normal up) with world
/// `x` in `range`.
fn floor_indirect(renderer: &Renderer, camera: Vec3, range: std::ops::Range<f32>) -> (Vec3, usize) {
    let position: Vec<[f32; 4]> =
        bytemuck::pod_collect_to_vec(&renderer.read_gbuffer("position").expect("position"));
    let indirect = renderer
        .photons()
        .expect("ispm")
        .read_indirect()
        .expect("indirect");
    let mut sum = Vec3::ZERO;
    let mut n = 0;
    for (p, l) in position.iter().zip(indirect.chunks_exact(4)) {
        let world = Vec3::new(p[0], p[1], p[2]) + camera;
        if p[3] != 0.0 && world.y.abs() < 0.01 && range.contains(&world.x) {
            sum += Vec3::new(l[0], l[1], l[2]);
            n += 1;
        }
    }
    (sum / n.max(1) as f32, n)
}

#[test]
fn cornell_box_bleeds_red_and_green_onto_the_floor() {
    let scene = bundled("cornell-box");
    let (renderer, _) = render(&scene, settings(64, 64, 20_000, 1));
    let camera = scene.camera.position();
    let (left, n_left) = floor_indirect(&renderer, camera, -1.0..-0.75);
    let (right, n_right) = floor_indirect(&renderer, camera, 0.75..1.0);
    eprintln!("floor indirect near the red wall {left} ({n_left} px), near the green wall {right} ({n_right} px)");
    assert!(
        n_left > 20 && n_right > 20,
        "floor not in view: {n_left}, {n_right}"
    );
    assert!(
        left.x > 1.2 * left.y,
        "no red bleeding near the red wall: {left}"
    );
    assert!(
        right.y > 1.2 * right.x,
        "no green bleeding near the green wall: {right}"
    );
}

/// Glass shows the room's indirect light, not only its direct light: the translucent pass adds
/// the photons' indirect light seen from the environment cube's centre
/// (`photon_frame/environment.rs`). Inside `cornell-box`'s glass sphere, ISPM's mean radiance
/// (8 accumulated frames, each with new photons) is the CPU photon gather's (which follows the
/// refraction and reflection exactly and gathers at the first diffuse surface) within 12 %.
/// With direct light only in the cube it was 0.46 of it; now 1.076 (seeds 4, 9: 1.069, 1.064;
/// the gather is itself blurred at this size: against the path tracer at 160×120 the middle of
/// the ball is 0.958).
#[test]
fn the_glass_sphere_shows_the_rooms_indirect_light_like_the_cpu_gather() {
    use ispm::config::settings::Method as Reference;
    use ispm::reference::{render as reference, RefSettings};
    let scene = bundled("cornell-box");
    let (w, h) = (64, 48);
    let gpu = common::gpu();
    let accumulate = RenderSettings {
        accumulate: true,
        ..settings(w, h, 20_000, 3)
    };
    let mut renderer = Renderer::new(&gpu, &scene, accumulate).expect("renderer");
    for _ in 1..8 {
        renderer.submit_frame().expect("frame");
    }
    let ispm = renderer.render().expect("render");
    common::assert_validation_clean(&gpu);
    let gather = reference(
        &scene,
        Reference::PhotonGather,
        &RefSettings {
            width: w,
            height: h,
            spp: 4,
            jitter: true,
            photons: 100_000,
            bounces: 64,
            iterations: 1,
            radius: None,
            alpha: 2.0 / 3.0,
            seed: 5,
        },
        None,
        &std::sync::atomic::AtomicBool::new(false),
    )
    .expect("photon gather");
    // The middle of the glass ball on screen: a square of half its projected radius.
    let glass = scene
        .instances
        .iter()
        .find(|i| scene.materials[scene.meshes[i.mesh].material].has_delta_lobe())
        .expect("cornell-box has a glass ball");
    let points: Vec<Vec3> = scene.meshes[glass.mesh]
        .positions
        .iter()
        .map(|&p| glass.transform.transform_point3(p))
        .collect();
    let centre = points.iter().sum::<Vec3>() / points.len() as f32;
    let radius = points
        .iter()
        .map(|p| p.distance(centre))
        .fold(0.0, f32::max);
    let c = scene
        .camera
        .project_to_pixel(centre, w, h)
        .expect("in view");
    let up = scene.camera.transform.y_axis.truncate().normalize();
    let edge = scene
        .camera
        .project_to_pixel(centre + up * radius, w, h)
        .expect("in view");
    let half = 0.5 * c.distance(edge);
    let (mut a, mut b, mut n) = (0.0f64, 0.0f64, 0);
    for y in (c.y - half) as u32..=(c.y + half) as u32 {
        for x in (c.x - half) as u32..=(c.x + half) as u32 {
            let i = (y * w + x) as usize;
            a += (0..3).map(|k| ispm.hdr[4 * i + k] as f64).sum::<f64>();
            b += gather.pixels[i].iter().map(|&v| v as f64).sum::<f64>();
            n += 1;
        }
    }
    let ratio = a / b;
    eprintln!("glass ball ({n} px around {c}): ISPM / photon gather = {ratio:.3}");
    assert!(n >= 16, "the glass ball covers {n} px only");
    assert!(
        (0.88..1.12).contains(&ratio),
        "ISPM / photon gather = {ratio:.3} in the glass ball"
    );
}

// ---------------------------------------------------------------------------------------------
// Bounce map = CPU first bounce, statistically
// ---------------------------------------------------------------------------------------------

/// Compares the GPU bounce map with the CPU first bounce on `scene`, light by light, for each
/// seed; fails on any bin more than 5σ apart.
fn bounce_map_matches_cpu_first_bounce(name: &str, scene: &Scene, photons: usize, seeds: &[u32]) {
    for &seed in seeds {
        let gpu = gpu_bounces(scene, photons, seed);
        let cpu = cpu_bounces(scene, 2 * photons, seed);
        for light in 0..scene.lights.len() {
            let (g_hist, g_total, g_n) = histograms(&gpu, light, scene);
            let (c_hist, c_total, c_n) = histograms(&cpu, light, scene);
            assert!(g_n > 0 && c_n > 0, "{name}: light {light} emitted nothing");
            let mut report =
                format!("{name} seed {seed} light {light} ({g_n} texels, {c_n} CPU photons):");
            let mut worst = 0.0f64;
            for c in 0..3 {
                let sigma = (g_total[c].variance(g_n) + c_total[c].variance(c_n)).sqrt();
                let z = (g_total[c].sum - c_total[c].sum) / sigma.max(1e-30);
                report += &format!(
                    " power[{c}] {:.4} vs {:.4} ({z:+.2}σ);",
                    g_total[c].sum, c_total[c].sum
                );
                worst = worst.max(z.abs());
            }
            for (what, (g, k)) in ["position", "direction", "lobe"]
                .iter()
                .zip(g_hist.iter().zip(&c_hist))
            {
                let cmp = compare(g, g_n, k, c_n);
                report += &format!(
                    " {what}: χ² {:.1}/{} bins, max |z| {:.2};",
                    cmp.chi2, cmp.bins, cmp.max_z
                );
                assert!(cmp.bins > 0, "{report}");
                // χ² with `bins` degrees of freedom: mean bins, σ √(2·bins).
                let bins = cmp.bins as f64;
                assert!(
                    cmp.chi2 < bins + 5.0 * (2.0 * bins).sqrt(),
                    "{what} histograms differ: {report}"
                );
                worst = worst.max(cmp.max_z);
            }
            // The delta-lobe share, for the record.
            let share = |h: &[Tally]| h[1].sum / (h[0].sum + h[1].sum).max(1e-30);
            report += &format!(
                " delta-lobe power share {:.4} vs {:.4}",
                share(&g_hist[2]),
                share(&c_hist[2])
            );
            eprintln!("{report}");
            assert!(
                worst < 5.0,
                "GPU bounce map differs from the CPU first bounce by {worst:.2}σ: {report}"
            );
        }
    }
}

#[test]
fn bounce_map_is_the_cpu_first_bounce_in_distribution_with_spot_lights_glass_and_gloss() {
    let scene = bundled("cornell-box");
    bounce_map_matches_cpu_first_bounce("cornell-box", &scene, 40_000, &[1, 2, 3]);
}

/// The sun over the mirror ring: half of the photons come from the caustic view around the
/// ring, at 49× the texel density and 1/49 of the power.
#[test]
fn bounce_map_is_the_cpu_first_bounce_in_distribution_with_a_caustic_view() {
    let scene = bundled("caustic-ring");
    bounce_map_matches_cpu_first_bounce("caustic-ring", &scene, 40_000, &[1, 2]);
}

#[test]
fn bounce_map_is_the_cpu_first_bounce_in_distribution_with_a_point_light() {
    let scene = ispm::reference::scenes::cornell(2);
    bounce_map_matches_cpu_first_bounce("cornell(2)", &scene, 30_000, &[1, 2]);
}

// ---------------------------------------------------------------------------------------------
// Convergence to the path-traced reference
// ---------------------------------------------------------------------------------------------

/// relMSE of ISPM's indirect light (and of its whole image, for the record) against the path
/// tracer, mean over two seeds.
struct Point {
    photons: usize,
    r_max: f32,
    indirect: f64,
    total: f64,
    /// Mean indirect radiance of ISPM over the path tracer's (all pixels and channels).
    mean_ratio: f64,
}

fn measure(scene: &Scene, reference: &Reference, photons: usize, radius: Option<f32>) -> Point {
    let mut point = Point {
        photons,
        r_max: 0.0,
        indirect: 0.0,
        total: 0.0,
        mean_ratio: 0.0,
    };
    let seeds = [1, 2];
    for seed in seeds {
        let (renderer, frame) = render(
            scene,
            RenderSettings {
                bounces: CONVERGENCE_BOUNCES,
                radius,
                ..settings(CONVERGENCE_SIZE, CONVERGENCE_SIZE, photons, seed)
            },
        );
        let photons = renderer.photons().expect("ispm");
        point.r_max = photons.kernel().r_max;
        let indirect = photons.read_indirect().expect("indirect");
        point.indirect += rel_mse(&indirect, &reference.indirect) / seeds.len() as f64;
        point.total += rel_mse(&frame.hdr, &reference.total) / seeds.len() as f64;
        point.mean_ratio += mean(&indirect) / mean(&reference.indirect) / seeds.len() as f64;
    }
    point
}

#[test]
fn ispm_indirect_light_converges_to_the_path_tracer() {
    let scene = ispm::reference::scenes::cornell(2);
    assert!(
        scene
            .materials
            .iter()
            .all(|m| m.transmission.max_element() == 0.0 && m.glossy.max_element() == 0.0),
        "the convergence scene must be purely diffuse"
    );
    let reference = path_traced(&scene, REFERENCE_PASSES);
    let counts = [5_000, 20_000, 80_000];
    let default: Vec<Point> = counts
        .iter()
        .map(|&n| measure(&scene, &reference, n, None))
        .collect();
    // The default: kNN kernel radii (`photon::density`) under the clamp r_max ∝ N^(-1/4). At
    // these counts (≤ 100k) k is fixed, so the kernels shrink as N^(-1/2) wherever they are below
    // r_max, holding k photons each: the bias falls, the noise much less (measured 0.1036,
    // 0.0578, 0.0521; the path-density radius, whose r_max kernels held ∝ √N photons: 0.1050,
    // 0.0633, 0.0420). For comparison, the constant-count clamp r_max ∝ N^(-1/2) from the same
    // radius at the first count.
    let r0 = default[0].r_max;
    let constant_count: Vec<Point> = counts
        .iter()
        .map(|&n| {
            let r = r0 * (n as f32 / counts[0] as f32).powf(-0.5);
            measure(&scene, &reference, n, Some(r))
        })
        .collect();
    let mut table = format!(
        "cornell(2), {CONVERGENCE_SIZE}², {CONVERGENCE_BOUNCES} bounces, reference: path tracer \
         {REFERENCE_PASSES} spp at pixel centres, its noise floor {:.4}\n\
         | photons | kernel | r_max (m) | relMSE indirect | − floor | relMSE total | mean ratio |\n\
         |---|---|---|---|---|---|---|\n",
        reference.floor
    );
    for (name, curve) in [
        ("default N^(-1/4)", &default),
        ("constant count N^(-1/2)", &constant_count),
    ] {
        for p in curve.iter() {
            table += &format!(
                "| {} | {name} | {:.4} | {:.4} | {:.4} | {:.4} | {:.3} |\n",
                p.photons,
                p.r_max,
                p.indirect,
                p.indirect - reference.floor,
                p.total,
                p.mean_ratio
            );
        }
    }
    eprintln!("{table}");
    // Falls monotonically with the default (each step by at least 5 %: two seeds' noise in the
    // relMSE is ~1 %).
    for w in default.windows(2) {
        assert!(
            w[1].indirect < 0.95 * w[0].indirect,
            "relMSE did not fall from {} to {} photons:\n{table}",
            w[0].photons,
            w[1].photons
        );
    }
    // The constant-count schedule: bias falls, noise does not; the error must at least not grow.
    for w in constant_count.windows(2) {
        assert!(
            w[1].indirect < 1.1 * w[0].indirect,
            "relMSE grew from {} to {} photons:\n{table}",
            w[0].photons,
            w[1].photons
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Caustics: convergence to progressive photon mapping
// ---------------------------------------------------------------------------------------------

/// One ISPM render of a caustic scene against the progressive reference.
struct CausticPoint {
    photons: usize,
    /// `RenderSettings::caustic_share` (0: no caustic views).
    share: f32,
    stored: usize,
    r_min: f32,
    per_pixel: f64,
    blocks: f64,
    mean_ratio: f64,
}

/// ISPM's indirect light on the bundled scene `name` against progressive photon mapping's
/// (`progressive − path-trace(bounces 0)`, both at pixel centres, so the difference is exactly
/// the gathered part), over the pixels that see a surface without delta lobes from the camera
/// (glass and mirrors are the translucent pass's; the G-buffer sees the floor behind them), for
/// each (photons, caustic share) of `runs`.
fn caustic_curve(name: &str, runs: &[(usize, f32)]) -> Vec<CausticPoint> {
    let scene = bundled(name);
    let size = CONVERGENCE_SIZE;
    let indirect_ref = progressive_indirect(&scene);
    let behind_glass: Vec<bool> = first_hits(&scene, size)
        .iter()
        .map(|&h| h == Some(true))
        .collect();
    let mut curve = Vec::new();
    for &(photons, share) in runs {
        let (renderer, frame) = render(
            &scene,
            RenderSettings {
                bounces: CONVERGENCE_BOUNCES,
                caustic_share: share,
                ..settings(size, size, photons, 1)
            },
        );
        let material: Vec<u32> =
            bytemuck::pod_collect_to_vec(&renderer.read_gbuffer("material").expect("material"));
        let position: Vec<[f32; 4]> =
            bytemuck::pod_collect_to_vec(&renderer.read_gbuffer("position").expect("position"));
        let mask: Vec<bool> = material
            .iter()
            .zip(&position)
            .zip(&behind_glass)
            .map(|((&m, p), &glass)| {
                let m = &scene.materials[m as usize];
                !glass
                    && p[3] != 0.0
                    && m.transmission.max_element() == 0.0
                    && m.exponent.is_finite()
            })
            .collect();
        let ispm = renderer.photons().expect("ispm");
        let indirect = ispm.read_indirect().expect("indirect");
        let keep = |img: &[f32]| -> Vec<f32> {
            img.chunks_exact(4)
                .zip(&mask)
                .filter(|(_, &m)| m)
                .flat_map(|(p, _)| p.iter().copied())
                .collect()
        };
        let (a, r) = (
            block_means(&indirect, &mask, size, 8),
            block_means(&indirect_ref, &mask, size, 8),
        );
        assert!(a.len() >= 4 * 16, "too few floor blocks: {}", a.len() / 4);
        curve.push(CausticPoint {
            photons,
            share,
            stored: frame.stats.stored_photons,
            r_min: ispm.kernel().r_min,
            per_pixel: rel_mse(&keep(&indirect), &keep(&indirect_ref)),
            blocks: rel_mse(&a, &r),
            mean_ratio: mean(&a) / mean(&r),
        });
    }
    let mut table = format!(
        "{name}, 64², reference: progressive {PROGRESSIVE_ITERATIONS} × 100k photons, pixel centres\n\
         | photons | caustic share | stored | r_min (m) | relMSE per pixel | relMSE 8×8 blocks | \
         mean ratio |\n|---|---|---|---|---|---|---|\n",
    );
    for p in &curve {
        table += &format!(
            "| {} | {} | {} | {:.4} | {:.4} | {:.4} | {:.3} |\n",
            p.photons, p.share, p.stored, p.r_min, p.per_pixel, p.blocks, p.mean_ratio
        );
    }
    eprintln!("{table}");
    curve
}

/// `counts` at the default caustic share.
fn runs(counts: &[usize]) -> Vec<(usize, f32)> {
    let share = RenderSettings::default().caustic_share;
    counts.iter().map(|&n| (n, share)).collect()
}

/// The band the glass sphere's full-block mean ratio must stay in. Its focused caustic (the
/// ball lens's, in front of the sphere) dominates these blocks; against the reference of
/// [`PROGRESSIVE_ITERATIONS`] the ratio is 0.990 at 10k photons and 0.999–1.004 from 40k to
/// 640k. (Against the older reference of one global radius it was 1.08–1.10, the reference's
/// wide early radii having spread the caustic into blocks the mask leaves out; docs/accuracy.md
/// §3.)
const GLASS_MEAN_RATIO: std::ops::Range<f64> = 0.97..1.03;

/// The caustic's energy lands where progressive photon mapping puts it (8×8-pixel blocks), at
/// the photon counts where the caustic kernel is not far below a pixel.
#[test]
fn ispm_caustic_energy_matches_progressive_photon_mapping_at_block_scale() {
    for p in caustic_curve("glass-sphere", &runs(&[10_000, 40_000])) {
        // Measured 0.0002 and 0.0001 (0.0062 and 0.0054 against the older reference).
        assert!(
            p.blocks < 0.002,
            "{} photons: block relMSE {}",
            p.photons,
            p.blocks
        );
        assert!(
            GLASS_MEAN_RATIO.contains(&p.mean_ratio),
            "{} photons: indirect energy ratio {}",
            p.photons,
            p.mean_ratio
        );
    }
}

/// With the pixel-footprint floor on the kernel radius (`photon::kernel`, "Radius from the pixel
/// footprint") the caustic's per-pixel error falls as the photons grow, then holds at the
/// pixel-scale floor. Without the floor it grew 0.088 → 0.168 from 160k to 640k photons
/// (fireflies, docs/accuracy.md "Caustics").
#[test]
fn ispm_caustic_error_falls_as_photons_grow() {
    let curve = caustic_curve("glass-sphere", &runs(&[10_000, 40_000, 160_000, 640_000]));
    for w in curve[..3].windows(2) {
        assert!(
            w[1].per_pixel < w[0].per_pixel,
            "per-pixel relMSE grew from {} to {} photons: {} → {}",
            w[0].photons,
            w[1].photons,
            w[0].per_pixel,
            w[1].per_pixel
        );
    }
    let (held, last) = (&curve[2], &curve[3]);
    assert!(
        last.per_pixel < 1.1 * held.per_pixel,
        "per-pixel relMSE rose from {} to {} photons: {} → {} (fireflies?)",
        held.photons,
        last.photons,
        held.per_pixel,
        last.per_pixel
    );
    for p in &curve {
        assert!(
            GLASS_MEAN_RATIO.contains(&p.mean_ratio),
            "{} photons: indirect energy ratio {}",
            p.photons,
            p.mean_ratio
        );
    }
}

/// The mirror ring's cardioid (`caustic-ring`, the sun at 20°): the caustic views store far more
/// photons at the same `--photons`, and the caustic they draw agrees with progressive photon
/// mapping per pixel and at block scale, where one view fitted to the scene puts its energy in
/// the wrong places (docs/accuracy.md §3).
///
/// Per pixel and in blocks the caustic views' cardioid is the closer one and its error falls
/// with the photons (measured per pixel 0.0061 and 0.0018 at 20k and 80k photons, without
/// caustic views 0.116 and 0.052; blocks 0.0004 and 0.0000 against 0.0165 and 0.0033), since
/// the reference draws the cardioid sharp itself (half of each iteration's photons aimed at the
/// ring, `reference::caustic_photons`). Against the older reference of one global radius the
/// views' sharper cardioid was *further* from it per pixel at 80k than at 20k (0.017 against
/// 0.013), the reference's own blur.
#[test]
fn the_ring_caustic_matches_progressive_photon_mapping_with_caustic_views() {
    let counts = [20_000, 80_000];
    let mut all = runs(&counts);
    all.extend(counts.iter().map(|&n| (n, 0.0)));
    let curve = caustic_curve("caustic-ring", &all);
    let (with, without) = curve.split_at(counts.len());
    for (p, q) in with.iter().zip(without) {
        assert!(
            p.stored >= 10 * q.stored,
            "{} photons: {} stored with caustic views, {} without",
            p.photons,
            p.stored,
            q.stored
        );
        assert!(
            p.per_pixel < 0.02 && p.per_pixel * 4.0 < q.per_pixel,
            "{} photons: per-pixel relMSE {} with caustic views, {} without",
            p.photons,
            p.per_pixel,
            q.per_pixel,
        );
        assert!(
            p.blocks < 0.002 && p.blocks * 4.0 < q.blocks,
            "{} photons: block relMSE {} with caustic views, {} without",
            p.photons,
            p.blocks,
            q.blocks
        );
        assert!(
            (0.95..1.05).contains(&p.mean_ratio),
            "{} photons: indirect energy ratio {}",
            p.photons,
            p.mean_ratio
        );
    }
    assert!(
        with[1].per_pixel < with[0].per_pixel,
        "the cardioid's per-pixel relMSE grew from {} to {} photons: {} → {}",
        with[0].photons,
        with[1].photons,
        with[0].per_pixel,
        with[1].per_pixel
    );
}
