//! The CPU references of `tests/ispm_accuracy.rs` (docs/accuracy.md §2–3): the path tracer's and
//! progressive photon mapping's indirect light at pixel centres, and image means.

use glam::Vec3;
use ispm::scene::Scene;

/// Image side of the convergence tests.
pub const CONVERGENCE_SIZE: u32 = 64;
/// Light-path bounces of both renderers (ISPM's `bounces`, the references' `bounces`).
pub const CONVERGENCE_BOUNCES: u32 = 8;

/// Path-tracer passes (1 spp each) of the convergence reference.
pub const REFERENCE_PASSES: u32 = 256;
/// Progressive photon mapping's iterations (100k photons each) in [`progressive_indirect`]. Its
/// shrinking radius blurs the glass sphere's focused caustic while it is large, into the blocks
/// next to the sphere that the comparison leaves out: ISPM's mean ratio against it on
/// glass-sphere (40k photons) is 1.12 at 16 iterations, 1.11 at 64, 1.10 at 128 and 1.09 at 256,
/// and the block relMSE 0.015, 0.0087, 0.0064, 0.0046. A test run of the glass-sphere
/// energy test took 8 s with 64 iterations and 37 s with 256.
pub const PROGRESSIVE_ITERATIONS: u32 = 128;

/// The path-traced reference: indirect light, the whole image, and the relMSE its own noise
/// adds to any comparison with it.
pub struct Reference {
    pub indirect: Vec<f32>,
    pub total: Vec<f32>,
    pub floor: f64,
}

/// The path tracer's indirect light at the pixel centres of `scene`'s camera: the mean over
/// `passes` seeds of `path-trace(bounces) − path-trace(bounces = 0)`. With one sample per
/// pixel the camera ray is the pixel centre and direct light draws no random numbers, so the
/// subtraction removes exactly the direct part of the same path. The floor is the per-pixel
/// variance of the mean in relMSE units: E[relMSE(a, reference)] ≈ relMSE(a, truth) + floor.
pub fn path_traced(scene: &Scene, passes: u32) -> Reference {
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
            ispm::config::settings::Method::PathTrace,
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
            floor += variance_of_mean / (mean * mean + ispm::tools::metrics::REL_MSE_EPSILON);
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

/// Mean of an RGBA image over pixels and RGB channels.
pub fn mean(image: &[f32]) -> f64 {
    let sum: f64 = image
        .chunks_exact(4)
        .flat_map(|p| &p[..3])
        .map(|&v| f64::from(v))
        .sum();
    sum / (image.len() / 4 * 3).max(1) as f64
}

/// Means of `block`×`block` pixel blocks whose pixels are all in `mask` (RGBA): the image at
/// the scale where a caustic's energy, not its per-pixel noise, is compared.
pub fn block_means(image: &[f32], mask: &[bool], size: u32, block: usize) -> Vec<f32> {
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

/// Progressive photon mapping's gathered (indirect) light on `scene` at pixel centres:
/// `progressive − path-trace(bounces 0)`, both with one sample per pixel, so the difference is
/// exactly the gathered part at every surface without delta lobes. [`PROGRESSIVE_ITERATIONS`] × 100k
/// photons.
pub fn progressive_indirect(scene: &Scene) -> Vec<f32> {
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let reference = |method, iterations, bounces| {
        let settings = ispm::reference::RefSettings {
            width: CONVERGENCE_SIZE,
            height: CONVERGENCE_SIZE,
            spp: 1,
            photons: 100_000,
            iterations,
            bounces,
            seed: 5,
            ..Default::default()
        };
        ispm::reference::render(scene, method, &settings, None, &cancel)
            .expect("reference")
            .pixels
    };
    let progressive = reference(
        ispm::config::settings::Method::Progressive,
        PROGRESSIVE_ITERATIONS,
        CONVERGENCE_BOUNCES,
    );
    // Direct light only: with more bounces the path tracer's diffuse interreflection (floor →
    // glass → floor, L D S D E) would be subtracted too, though ISPM's photons carry it.
    let direct = reference(ispm::config::settings::Method::PathTrace, 1, 0);
    progressive
        .iter()
        .zip(&direct)
        .flat_map(|(p, d)| [p[0] - d[0], p[1] - d[1], p[2] - d[2], 1.0])
        .collect()
}

/// What the camera ray through each pixel centre of a `size`² image first meets: `None`
/// nothing, `Some(true)` a material with a delta lobe (glass, mirror: those pixels are the
/// translucent pass's, and ISPM's G-buffer sees past them), `Some(false)` any other.
pub fn first_hits(scene: &Scene, size: u32) -> Vec<Option<bool>> {
    let bvh = ispm::photon::bvh::SceneBvh::new(scene);
    (0..size * size)
        .map(|i| {
            let (origin, dir) = pixel_ray(scene, size, i);
            bvh.intersect(&ispm::photon::ray::Ray::new(origin, dir))
                .map(|h| scene.materials[h.material].has_delta_lobe())
        })
        .collect()
}

/// The camera ray (origin, unnormalised direction) through the centre of pixel `i` (row-major)
/// of a `size`² image of `scene`.
pub fn pixel_ray(scene: &Scene, size: u32, i: u32) -> (Vec3, Vec3) {
    let cam = &scene.camera;
    let t = (cam.yfov * 0.5).tan();
    let (x, y) = (i % size, i / size);
    let ndc_x = (x as f32 + 0.5) / size as f32 * 2.0 - 1.0;
    let ndc_y = 1.0 - (y as f32 + 0.5) / size as f32 * 2.0;
    let dir = cam
        .transform
        .transform_vector3(Vec3::new(ndc_x * t, ndc_y * t, -1.0));
    (cam.position(), dir)
}
