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

use common::golden::{assert_matches_golden, rel_mse};
use glam::Vec3;
use ispm::frame::{FrameImage, Method, RenderSettings, Renderer};
use ispm::scene::Scene;

fn settings(width: u32, height: u32, photons: usize, seed: u32) -> RenderSettings {
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

fn render(scene: &Scene, settings: RenderSettings) -> (Renderer, FrameImage) {
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

// ---------------------------------------------------------------------------------------------
// Bounce map = CPU first bounce, statistically
// ---------------------------------------------------------------------------------------------

/// One emitted photon after its first bounce: zero power when it missed or was absorbed.
#[derive(Clone, Copy, Debug)]
struct Bounced {
    light: usize,
    power: Vec3,
    /// Where it left the surface (meaningful when `power` > 0).
    position: Vec3,
    direction: Vec3,
    rho_p: f32,
}

/// The GPU bounce map of `scene` (rendered with `photons` and `seed`), one record per texel,
/// each assigned to its light, with its hit point rebuilt from the light G-buffer depth.
fn gpu_bounces(scene: &Scene, photons: usize, seed: u32) -> Vec<Bounced> {
    let (renderer, _) = render(scene, settings(16, 16, photons, seed));
    let map = renderer.photons().expect("ispm").bounce_map().to_vec();
    let camera = scene.camera.position().as_dvec3();
    let bounds = scene.bounds();
    let plan = ispm::ispm::BouncePlan::new(scene, camera, &bounds, photons);
    assert_eq!(
        plan.texels,
        map.len(),
        "the plan does not describe this bounce map"
    );
    let setup = ispm::lighting::LightSetup::new(&scene.lights, camera, &bounds, 1, 0);
    let mut out = Vec::with_capacity(map.len());
    for (light, gpu_light) in setup.lights.iter().enumerate() {
        let (first, count) = (gpu_light.shadow.y as usize, gpu_light.shadow.z as usize);
        for view in &plan.views[first..first + count] {
            let (res, offset) = (view.texels.x as usize, view.texels.y as usize);
            let records = &map[offset..offset + res * res];
            // `photon_starts` places every surviving record of this view (and only this view).
            let mut only_this_view =
                vec![ispm::photon::types::BounceMapPhoton::default(); map.len()];
            only_this_view[offset..offset + res * res].copy_from_slice(records);
            let mut starts = plan.photon_starts(&only_this_view).into_iter();
            for r in records {
                let (direction, rho_p) = ispm::photon::types::unpack_direction(r.direction);
                let alive = r.power.max_element() > 0.0 && direction != Vec3::ZERO;
                let position = if alive {
                    starts.next().expect("a start per surviving texel").origin
                } else {
                    Vec3::ZERO
                };
                out.push(Bounced {
                    light,
                    power: if alive { r.power } else { Vec3::ZERO },
                    position,
                    direction,
                    rho_p,
                });
            }
            assert!(starts.next().is_none());
        }
    }
    out
}

/// The CPU emitter's photons after `photon::trace::first_bounce`.
fn cpu_bounces(scene: &Scene, photons: usize, seed: u32) -> Vec<Bounced> {
    let bvh = ispm::photon::bvh::SceneBvh::new(scene);
    ispm::photon::emit::emit_photons(scene, photons, seed)
        .iter()
        .map(|p| {
            let light = p.light as usize;
            match ispm::photon::trace::first_bounce(scene, &bvh, p) {
                Some(s) => Bounced {
                    light,
                    power: s.power,
                    position: s.origin,
                    direction: s.direction,
                    rho_p: s.rho_p,
                },
                None => Bounced {
                    light,
                    power: Vec3::ZERO,
                    position: Vec3::ZERO,
                    direction: Vec3::ZERO,
                    rho_p: 0.0,
                },
            }
        })
        .collect()
}

/// A Monte-Carlo sum Σ wⱼ·1[j in bin] over n samples, with its variance estimate
/// Σ wⱼ²·1 − (Σ wⱼ·1)²/n (independent samples; the GPU's stratified texels vary less, so this
/// overestimates its variance and the test is conservative).
#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    sum: f64,
    sum_sq: f64,
    count: usize,
}

impl Tally {
    fn add(&mut self, w: f64) {
        self.sum += w;
        self.sum_sq += w * w;
        self.count += 1;
    }

    fn variance(&self, n: usize) -> f64 {
        (self.sum_sq - self.sum * self.sum / n.max(1) as f64).max(0.0)
    }
}

/// Two independent estimates of the same histogram compared bin by bin: z = Δ/σ per bin
/// (bins with fewer than 20 samples on both sides together are skipped), χ² = Σ z².
struct Comparison {
    max_z: f64,
    chi2: f64,
    bins: usize,
}

fn compare(gpu: &[Tally], gpu_n: usize, cpu: &[Tally], cpu_n: usize) -> Comparison {
    let mut c = Comparison {
        max_z: 0.0,
        chi2: 0.0,
        bins: 0,
    };
    for (g, k) in gpu.iter().zip(cpu) {
        if g.count + k.count < 20 {
            continue;
        }
        let sigma = (g.variance(gpu_n) + k.variance(cpu_n)).sqrt();
        let z = (g.sum - k.sum) / sigma.max(1e-30);
        c.max_z = c.max_z.max(z.abs());
        c.chi2 += z * z;
        c.bins += 1;
    }
    c
}

/// Power-weighted histograms of one light's bounced photons: [position cell (4³ over the scene
/// bounds), outgoing direction (4 bands of ω.y × 4 azimuth quadrants), lobe (ρp > 0.1: a delta
/// lobe)] and the per-channel total power.
fn histograms(
    samples: &[Bounced],
    light: usize,
    scene: &Scene,
) -> ([Vec<Tally>; 3], [Tally; 3], usize) {
    let bounds = scene.bounds();
    let (min, extent) = (bounds.min, bounds.extent().max(Vec3::splat(1e-6)));
    let mut position = vec![Tally::default(); 64];
    let mut direction = vec![Tally::default(); 16];
    let mut lobe = vec![Tally::default(); 2];
    let mut total = [Tally::default(); 3];
    let mut n = 0;
    for s in samples.iter().filter(|s| s.light == light) {
        n += 1;
        for (c, t) in total.iter_mut().enumerate() {
            t.add(f64::from(s.power[c]));
        }
        let w = f64::from(s.power.element_sum() / 3.0);
        if w <= 0.0 {
            continue;
        }
        let cell = ((s.position - min) / extent * 4.0)
            .floor()
            .clamp(Vec3::ZERO, Vec3::splat(3.0))
            .as_uvec3();
        position[(cell.x + 4 * cell.y + 16 * cell.z) as usize].add(w);
        let band = (((s.direction.y + 1.0) * 2.0).floor() as usize).min(3);
        let quadrant = match (s.direction.x >= 0.0, s.direction.z >= 0.0) {
            (true, true) => 0,
            (false, true) => 1,
            (false, false) => 2,
            (true, false) => 3,
        };
        direction[band * 4 + quadrant].add(w);
        lobe[usize::from(s.rho_p > 0.1)].add(w);
    }
    ([position, direction, lobe], total, n)
}

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

#[test]
fn bounce_map_is_the_cpu_first_bounce_in_distribution_with_a_point_light() {
    let scene = ispm::reference::scenes::cornell(2);
    bounce_map_matches_cpu_first_bounce("cornell(2)", &scene, 30_000, &[1, 2]);
}

// ---------------------------------------------------------------------------------------------
// Convergence to the path-traced reference
// ---------------------------------------------------------------------------------------------

const CONVERGENCE_SIZE: u32 = 64;
/// Light-path bounces of both renderers (ISPM's `bounces`, the path tracer's `bounces`).
const CONVERGENCE_BOUNCES: u32 = 8;

/// Path-tracer passes (1 spp each) of the convergence reference.
const REFERENCE_PASSES: u32 = 256;

/// The path-traced reference: indirect light, the whole image, and the relMSE its own noise
/// adds to any comparison with it.
struct Reference {
    indirect: Vec<f32>,
    total: Vec<f32>,
    floor: f64,
}

/// The path tracer's indirect light at the pixel centres of `scene`'s camera: the mean over
/// `passes` seeds of `path-trace(bounces) − path-trace(bounces = 0)`. With one sample per
/// pixel the camera ray is the pixel centre and direct light draws no random numbers, so the
/// subtraction removes exactly the direct part of the same path. The floor is the per-pixel
/// variance of the mean in relMSE units: E[relMSE(a, reference)] ≈ relMSE(a, truth) + floor.
fn path_traced(scene: &Scene, passes: u32) -> Reference {
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let reference = |bounces: u32, seed: u32| {
        let settings = ispm::reference::RefSettings {
            width: CONVERGENCE_SIZE,
            height: CONVERGENCE_SIZE,
            spp: 1,
            bounces,
            seed,
            ..Default::default()
        };
        ispm::reference::render(
            scene,
            ispm::reference::Method::PathTrace,
            &settings,
            None,
            &cancel,
        )
        .expect("path trace")
        .pixels
    };
    let direct = reference(0, 0);
    let n = direct.len();
    let mut sum = vec![[0.0f64; 3]; n];
    let mut sum_sq = vec![[0.0f64; 3]; n];
    for seed in 0..passes {
        for (i, p) in reference(CONVERGENCE_BOUNCES, seed).iter().enumerate() {
            for c in 0..3 {
                let v = f64::from(p[c] - direct[i][c]);
                sum[i][c] += v;
                sum_sq[i][c] += v * v;
            }
        }
    }
    let k = f64::from(passes);
    let mut image = Vec::with_capacity(4 * n);
    let mut total = Vec::with_capacity(4 * n);
    let mut floor = 0.0;
    for (i, (s, q)) in sum.iter().zip(&sum_sq).enumerate() {
        for c in 0..3 {
            let mean = s[c] / k;
            total.push(mean as f32 + direct[i][c]);
            let variance_of_mean = (q[c] / k - mean * mean).max(0.0) / (k - 1.0);
            floor += variance_of_mean / (mean * mean + common::golden::REL_MSE_EPSILON);
            image.push(mean as f32);
        }
        image.push(1.0);
        total.push(1.0);
    }
    Reference {
        indirect: image,
        total,
        floor: floor / (3 * n) as f64,
    }
}

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

fn mean(image: &[f32]) -> f64 {
    let sum: f64 = image
        .chunks_exact(4)
        .flat_map(|p| &p[..3])
        .map(|&v| f64::from(v))
        .sum();
    sum / (image.len() / 4 * 3).max(1) as f64
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
    // The consistent schedule: r_max ∝ N^(-1/4) from the default radius at the first count,
    // so that photons per kernel grow as √N while the kernel shrinks.
    let r0 = default[0].r_max;
    let consistent: Vec<Point> = counts
        .iter()
        .map(|&n| {
            let r = r0 * (n as f32 / counts[0] as f32).powf(-0.25);
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
    for (name, curve) in [("default 1/√N", &default), ("N^(-1/4)", &consistent)] {
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
    // Falls monotonically with the consistent schedule (each step by at least 5 %: two
    // seeds' noise in the relMSE is ~1 %).
    for w in consistent.windows(2) {
        assert!(
            w[1].indirect < 0.95 * w[0].indirect,
            "relMSE did not fall from {} to {} photons:\n{table}",
            w[0].photons,
            w[1].photons
        );
    }
    // The default schedule keeps the photon count per kernel constant: bias falls, noise does
    // not, and the error must at least not grow.
    for w in default.windows(2) {
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

/// Means of `block`×`block` pixel blocks whose pixels are all in `mask` (RGBA): the image at
/// the scale where a caustic's energy, not its per-pixel noise, is compared.
fn block_means(image: &[f32], mask: &[bool], size: u32, block: usize) -> Vec<f32> {
    let size = size as usize;
    let mut out = Vec::new();
    for by in 0..size / block {
        for bx in 0..size / block {
            let pixels = (0..block * block)
                .map(|k| (by * block + k / block) * size + bx * block + k % block);
            if !pixels.clone().all(|i| mask[i]) {
                continue;
            }
            let mut sum = [0.0f32; 3];
            for i in pixels {
                for (c, s) in sum.iter_mut().enumerate() {
                    *s += image[4 * i + c] / (block * block) as f32;
                }
            }
            out.extend([sum[0], sum[1], sum[2], 1.0]);
        }
    }
    out
}

/// One ISPM render of the caustic scene against the progressive reference.
struct CausticPoint {
    photons: usize,
    r_min: f32,
    per_pixel: f64,
    blocks: f64,
    mean_ratio: f64,
}

/// ISPM's indirect light on `glass-sphere` against progressive photon mapping's
/// (`progressive − path-trace(bounces 0)`, both at pixel centres, so the difference is exactly
/// the gathered part), over the pixels that see a surface without delta lobes (the glass itself
/// needs the translucent pass).
fn caustic_curve(counts: &[usize]) -> Vec<CausticPoint> {
    let scene = bundled("glass-sphere");
    let size = CONVERGENCE_SIZE;
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let reference = |method, iterations| {
        let settings = ispm::reference::RefSettings {
            width: size,
            height: size,
            spp: 1,
            photons: 100_000,
            iterations,
            bounces: CONVERGENCE_BOUNCES,
            seed: 5,
            ..Default::default()
        };
        ispm::reference::render(&scene, method, &settings, None, &cancel)
            .expect("reference")
            .pixels
    };
    let progressive = reference(ispm::reference::Method::Progressive, 16);
    let direct = reference(ispm::reference::Method::PathTrace, 1);
    let indirect_ref: Vec<f32> = progressive
        .iter()
        .zip(&direct)
        .flat_map(|(p, d)| [p[0] - d[0], p[1] - d[1], p[2] - d[2], 1.0])
        .collect();
    let mut curve = Vec::new();
    for &photons in counts {
        let (renderer, _) = render(
            &scene,
            RenderSettings {
                bounces: CONVERGENCE_BOUNCES,
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
            .map(|(&m, p)| {
                let m = &scene.materials[m as usize];
                p[3] != 0.0 && m.transmission.max_element() == 0.0 && m.exponent.is_finite()
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
            r_min: ispm.kernel().r_min,
            per_pixel: rel_mse(&keep(&indirect), &keep(&indirect_ref)),
            blocks: rel_mse(&a, &r),
            mean_ratio: mean(&a) / mean(&r),
        });
    }
    let mut table = String::from(
        "glass-sphere, 64², reference: progressive 16 × 100k photons, pixel centres\n\
         | photons | r_min (m) | relMSE per pixel | relMSE 8×8 blocks | mean ratio |\n\
         |---|---|---|---|---|\n",
    );
    for p in &curve {
        table += &format!(
            "| {} | {:.4} | {:.4} | {:.4} | {:.3} |\n",
            p.photons, p.r_min, p.per_pixel, p.blocks, p.mean_ratio
        );
    }
    eprintln!("{table}");
    curve
}

/// The caustic's energy lands where progressive photon mapping puts it (8×8-pixel blocks), at
/// the photon counts where the caustic kernel is not far below a pixel.
#[test]
fn ispm_caustic_energy_matches_progressive_photon_mapping_at_block_scale() {
    for p in caustic_curve(&[10_000, 40_000]) {
        assert!(
            p.blocks < 0.01,
            "{} photons: block relMSE {}",
            p.photons,
            p.blocks
        );
        assert!(
            (0.8..1.25).contains(&p.mean_ratio),
            "{} photons: indirect energy ratio {}",
            p.photons,
            p.mean_ratio
        );
    }
}

/// Known to fail (docs/accuracy.md, "Caustics"): with the default kernel, r_min = r_max/50
/// shrinks as 1/√N far below the pixel footprint (≈ 3 cm here), so caustic photons become
/// sub-pixel fireflies and the per-pixel error grows with the photon count.
#[test]
#[ignore = "fails: caustic kernels shrink below a pixel (docs/accuracy.md, Caustics)"]
fn ispm_caustic_error_falls_as_photons_grow() {
    let curve = caustic_curve(&[10_000, 40_000, 160_000, 640_000]);
    for w in curve.windows(2) {
        assert!(
            w[1].per_pixel < w[0].per_pixel,
            "per-pixel relMSE grew from {} to {} photons: {} → {}",
            w[0].photons,
            w[1].photons,
            w[0].per_pixel,
            w[1].per_pixel
        );
    }
}
