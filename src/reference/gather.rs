//! Photon mapping by gathering: `photon-gather` (one photon map, ISPM's per-photon kernel
//! radius from the photons' kNN density, `photon::density`) and `progressive` (a new photon map
//! per iteration, each photon's kNN kernel shrinking as Knaus & Zwicker 2011's radius). Both
//! aim half their photons at the scene's mirrors and glass (`reference::caustic_photons`).
//!
//! Estimator (DESIGN.md §2.2, paper eq. 1 without the cosine): `L = Σ f(s, ωi, ωo)·Φ·κ`.
//! The stored power is flux through the surface, so `Φ·κ` (κ in 1/m², integrating to 1 over the
//! tangent disk) is already irradiance; a `max(0, ωi·n)` factor would count the cosine twice.
//! Only its sign survives, as the front-side test that `Bsdf::eval` applies (0 for ωi on the
//! other side of the surface from ωo). `docs/references.md` lists the tests that decide this.

use super::caustic_photons::{delta_target, split_emission, CAUSTIC_SHARE};
use super::photon_index::PhotonGrid;
use super::{direct_light, emitter_light, eye_path, Accumulator, Ctx, HdrImage};
use crate::photon::bsdf::Bsdf;
use crate::photon::density::{knn_radii, Neighbours};
use crate::photon::emit::EmittedPhoton;
use crate::photon::kernel::{kernel_radius, kernel_weight, KernelSettings};
use crate::photon::ray::Hit;
use crate::photon::rng::hash2;
use crate::photon::trace::{trace_from_lights, PhotonMap, TraceSettings};
use crate::photon::types::unpack_direction;
use anyhow::Result;
use glam::Vec3;

/// Most surfaces an eye path visits through delta bounces.
const EYE_DEPTH: u32 = 16;

/// A photon map ready to gather from: per-photon kernel radii and a grid.
pub struct GatherMap {
    pub map: PhotonMap,
    /// `(r_xy, r_z)` per photon.
    pub radii: Vec<(f32, f32)>,
    grid: PhotonGrid,
}

impl GatherMap {
    /// Radii from each photon's kNN radius among the photons of its class
    /// ([`knn_radii`] with `neighbours`) and its distance from `eye` ([`kernel_radius`]): the
    /// rule of ISPM's photon volumes.
    pub fn with_density(
        map: PhotonMap,
        kernel: &KernelSettings,
        neighbours: Neighbours,
        eye: Vec3,
    ) -> Self {
        let knn = knn_radii(&map.photons, neighbours);
        Self::with_knn_radii(map, &knn, kernel, eye)
    }

    /// Radii from kNN radii `knn` already measured (photon-map order) and each photon's
    /// distance from `eye` ([`kernel_radius`]).
    pub fn with_knn_radii(map: PhotonMap, knn: &[f32], kernel: &KernelSettings, eye: Vec3) -> Self {
        debug_assert_eq!(map.photons.len(), knn.len());
        let radii: Vec<(f32, f32)> = map
            .photons
            .iter()
            .zip(knn)
            .map(|(p, &r)| kernel_radius(r, kernel, p.position.distance(eye)))
            .collect();
        Self::with_radii(map, radii)
    }

    fn with_radii(map: PhotonMap, radii: Vec<(f32, f32)>) -> Self {
        // The kernel is 0 outside the sphere of radius r_xy (`kernel_weight`).
        let extents: Vec<f32> = radii.iter().map(|r| r.0).collect();
        let grid = PhotonGrid::new(&map.photons, &extents);
        Self { map, radii, grid }
    }

    /// Indirect radiance reflected towards `wo` at `hit`: `Σ f·Φ·κ`.
    pub fn radiance(&self, hit: &Hit, bsdf: &Bsdf, wo: Vec3) -> Vec3 {
        let mut sum = Vec3::ZERO;
        let Some(bsdf) = bsdf.towards(wo, hit.shading_normal, hit.geometric_normal) else {
            return sum;
        };
        self.grid.for_each_near(hit.position, |i| {
            let p = &self.map.photons[i];
            let (r_xy, r_z) = self.radii[i];
            let kappa = kernel_weight(p.position, p.normal, r_xy, r_z, hit.position);
            if kappa > 0.0 {
                let (wi, _) = unpack_direction(p.direction);
                sum += bsdf.eval(wi) * p.power * kappa;
            }
        });
        sum
    }
}

/// The photon map of `emitted` photons of `ctx`'s scene, traced with seed `seed`.
pub(super) fn photon_map(ctx: &Ctx, emitted: &[EmittedPhoton], seed: u32) -> PhotonMap {
    let settings = TraceSettings {
        max_bounces: ctx.settings.bounces.max(1),
        seed,
        variant: crate::photon::bsdf::BsdfVariant::ALL,
        store_on: crate::photon::trace::StoreOn::FiniteLobes,
    };
    trace_from_lights(ctx.scene, ctx.bvh, emitted, &settings)
}

/// Eye passes over `map` into `acc`; false when cancelled.
fn gather_passes(ctx: &Ctx, map: &GatherMap, first_pass: u32, acc: &mut Accumulator) -> bool {
    for pass in 0..ctx.settings.spp.max(1) {
        let image = ctx.pass(first_pass + pass, |x, y, rng| {
            let ray = ctx.camera_ray(x, y, rng);
            eye_path(ctx, ray, rng, EYE_DEPTH, |hit, bsdf, wo| {
                direct_light(ctx.scene, ctx.bvh, hit, bsdf, wo)
                    + emitter_light(ctx, hit, bsdf, wo)
                    + map.radiance(hit, bsdf, wo)
            })
        });
        match image {
            Some(image) => acc.add(image),
            None => return false,
        }
    }
    true
}

pub(super) fn render_gather(ctx: &Ctx) -> Result<HdrImage> {
    let s = ctx.settings;
    ctx.set_length(s.spp.max(1) as u64 * s.height as u64);
    // The same kernel as the GPU's photon volumes: kNN radii, clamp and pixel-footprint floor.
    let kernel = KernelSettings::scene_relative(&ctx.scene.bounds(), s.photons, s.radius)
        .for_view(ctx.scene.camera.yfov, s.height);
    let eye = ctx.scene.camera.position();
    // Half the photons aimed at the mirrors and glass, as ISPM's caustic views aim half of its
    // own (`reference::caustic_photons`): the baseline is a photon mapper with a caustic map.
    let target = delta_target(ctx.scene);
    let emitted = split_emission(
        ctx.scene,
        ctx.bvh,
        s.photons,
        s.seed,
        target.as_ref(),
        CAUSTIC_SHARE,
    );
    let map = photon_map(ctx, &emitted, s.seed);
    let map = GatherMap::with_density(map, &kernel, Neighbours::for_photons(s.photons), eye);
    let mut acc = Accumulator::new(s.width, s.height);
    gather_passes(ctx, &map, 0, &mut acc);
    acc.finish()
}

/// Knaus–Zwicker radius of iteration `i` (0-based): `r²_{i+1} = r²_i·(i+α)/(i+1)` (1-based).
pub fn progressive_radius(r0: f32, alpha: f32, i: u32) -> f32 {
    let mut r2 = (r0 as f64) * (r0 as f64);
    for k in 1..=i {
        r2 *= (k as f64 + alpha as f64) / (k as f64 + 1.0);
    }
    r2.sqrt() as f32
}

/// Progressive photon mapping: iteration `i` traces a new photon map, half of whose photons
/// are aimed at the mirrors and glass ([`super::caustic_photons`]), and gathers it with each
/// photon's kNN kernel (as `photon-gather`: its class's k-th neighbour, clamped to
/// `[r_min, r_max]`) scaled by the Knaus–Zwicker factor `s_i = progressive_radius(1, α, i)`;
/// the image is the iterations' mean.
///
/// *Why not one global radius* (Knaus & Zwicker's own rule, this function's first form): the
/// global radius must start wide enough for the sparsest light in the scene (`r_max`, 13 cm on
/// `caustic-ring` at 100k photons) and shrinks only as `i^((α−1)/2)`, to 0.40× after 256
/// iterations: every caustic came out blurred by a 5 cm kernel. Against Mitsuba 3's particle
/// tracer on `caustic-ring`'s floor (640×480, 3-pixel blur) that reference had a relMSE of
/// 0.0156, six times ISPM's own render at 160k photons (docs/accuracy.md, "The references'
/// caustics"). Scaling each photon's kNN radius by the same factor keeps the schedule that
/// makes the estimate consistent (every kernel above the floor below shrinks as `s_i`, the
/// photons per kernel grow with the iterations) and starts each kernel at the size its own
/// photons' density calls for:
/// a few millimetres in a bright caustic, `r_max` where photons are sparse; the aimed photons
/// make the caustics' photons many, so that their kernels are small and their noise low.
///
/// Sampled at pixel centres (one eye sample per pixel, or `jitter` off: the sweep's references),
/// the kernels keep `photon-gather`'s floor of one pixel's footprint, which does not shrink: the
/// estimate converges to the radiance filtered over about a pixel round each pixel centre, the
/// filter ISPM's and `photon-gather`'s estimates converge to as well. Without it the kernels of
/// a focused caustic shrank far below a pixel and the pixel centres sampled its peak or missed
/// it: `glass-sphere`'s focus at 64² came out 14 % brighter over the image than its pixels'
/// mean, a few pixels many times too bright (`tests/ispm_accuracy.rs`, caustic tests). With
/// jittered samples (`spp > 1`, `ispm render`'s default 16) the samples' box over the pixel is
/// the filter, as in Mitsuba, and the kernels have no floor: both at once blurred the
/// cross-check's glass caustic to 0.876 of Mitsuba's (docs/crosscheck.md).
pub(super) fn render_progressive(ctx: &Ctx) -> Result<HdrImage> {
    let s = ctx.settings;
    let iterations = s.iterations.max(1);
    ctx.set_length(iterations as u64 * s.spp.max(1) as u64 * s.height as u64);
    let kernel = KernelSettings::scene_relative(&ctx.scene.bounds(), s.photons, s.radius);
    // The pixel filter is the jittered samples' box or the kernels' footprint floor, not both.
    let jittered = s.spp > 1 && s.jitter;
    let kernel = if jittered {
        kernel
    } else {
        kernel.for_view(ctx.scene.camera.yfov, s.height)
    };
    let neighbours = Neighbours::for_photons(s.photons);
    let eye = ctx.scene.camera.position();
    let target = delta_target(ctx.scene);
    let mut acc = Accumulator::new(s.width, s.height);
    for i in 0..iterations {
        if ctx.cancelled() {
            break;
        }
        let scale = progressive_radius(1.0, s.alpha, i);
        let seed = hash2(s.seed, i);
        let emitted = split_emission(
            ctx.scene,
            ctx.bvh,
            s.photons,
            seed,
            target.as_ref(),
            CAUSTIC_SHARE,
        );
        let map = photon_map(ctx, &emitted, seed);
        let map =
            GatherMap::with_density(map, &KernelSettings { scale, ..kernel }, neighbours, eye);
        // Each iteration is a complete estimate; the image is their running mean.
        let mut one = Accumulator::new(s.width, s.height);
        if !gather_passes(ctx, &map, i * s.spp.max(1), &mut one) {
            break;
        }
        let image = one.finish()?;
        acc.add(image.pixels.into_iter().map(Vec3::from_array).collect());
    }
    acc.finish()
}

#[cfg(test)]
mod tests {
    use super::progressive_radius;

    #[test]
    fn progressive_radius_follows_knaus_zwicker() {
        let (r0, a) = (0.2f32, 2.0 / 3.0);
        assert_eq!(progressive_radius(r0, a, 0), r0);
        let r1 = progressive_radius(r0, a, 1);
        assert!((r1 * r1 - r0 * r0 * (1.0 + a) / 2.0).abs() < 1e-7);
        // r_i² ∝ i^(α−1) asymptotically: the radius keeps shrinking, ever more slowly.
        let (r100, r1000) = (
            progressive_radius(r0, a, 100),
            progressive_radius(r0, a, 1000),
        );
        let ratio = (r1000 / r100).powi(2);
        assert!((ratio - 10f32.powf(a - 1.0)).abs() < 0.01, "{ratio}");
    }
}
