//! CPU reference renderers, the ground truth the GPU renderer is compared against (see
//! `docs/references.md`):
//! - [`Method::PathTrace`]: unidirectional path tracing with next-event estimation to the
//!   punctual lights and Russian roulette; unbiased for everything but caustics seen through
//!   nothing (punctual lights cannot be hit, so L S D E paths are reached only by photons).
//! - [`Method::PhotonGather`]: traditional photon mapping with ISPM's kernel and estimator:
//!   eye rays follow delta bounces to the first surface with a finite BSDF, direct light by
//!   NEE, indirect light gathered from the photon map.
//! - [`Method::Progressive`]: progressive photon mapping (Knaus & Zwicker 2011): a new photon
//!   map per iteration (half its photons aimed at the mirrors and glass, [`caustic_photons`]),
//!   each photon's kNN kernel scaled by `s_i` with `s²_{i+1} = s²_i (i+α)/(i+1)`: consistent up
//!   to a filter of about one pixel (the kernels' footprint floor, which does not shrink),
//!   caustics included (`gather::render_progressive`).
//!
//! All use every rayon thread over rows, are deterministic for a seed (per-pixel RNG streams,
//! photon maps independent of the thread count), report progress on an optional indicatif bar,
//! and stop at the next row when `cancel` is set, returning the last complete pass.
//! Never touches Vulkan.

pub mod caustic_photons;
mod emitter_light;
pub mod gather;
mod image;
mod path_trace;
pub mod photon_index;
pub mod scenes;

pub use self::image::HdrImage;

use crate::config::settings::Method;
use crate::photon::bsdf::{Bsdf, Lobe};
use crate::photon::bvh::SceneBvh;
use crate::photon::emit::spot_falloff;
use crate::photon::ray::{Hit, Ray};
use crate::photon::rng::{hash2, Rng};
use crate::photon::trace::{bsdf_at, emitted, has_finite_lobe, MAX_BOUNCES};
use crate::scene::emitters::Emitters;
use crate::scene::{LightKind, Scene};
use anyhow::{bail, Result};
use glam::Vec3;
use indicatif::ProgressBar;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Settings of the references.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefSettings {
    pub width: u32,
    pub height: u32,
    /// Eye samples per pixel (jittered when > 1 and `jitter`; pixel centres otherwise). For
    /// `progressive`, eye samples per iteration.
    pub spp: u32,
    /// Jitter the eye samples over the pixel when `spp > 1` (antialiasing). Off: every sample
    /// goes through the pixel centre, as the rasteriser samples, so a reference matches a GPU
    /// render's edges (`ispm sweep`).
    pub jitter: bool,
    /// Photons emitted per photon map (per iteration for `progressive`).
    pub photons: usize,
    /// Most bounces of a light path (photon scattering events; path-trace depth − 1). Default
    /// [`MAX_BOUNCES`], a safety net: Russian roulette ends the paths.
    pub bounces: u32,
    /// Progressive photon mapping iterations.
    pub iterations: u32,
    /// Kernel `r_max` override in metres (`--radius`); scene-relative when `None`. For
    /// `progressive`, the clamp of the first iteration's kernels.
    pub radius: Option<f32>,
    /// Knaus–Zwicker α.
    pub alpha: f32,
    pub seed: u32,
}

impl Default for RefSettings {
    fn default() -> Self {
        Self {
            width: 256,
            height: 256,
            spp: 16,
            jitter: true,
            photons: 200_000,
            bounces: MAX_BOUNCES,
            iterations: 16,
            radius: None,
            alpha: 2.0 / 3.0,
            seed: 0,
        }
    }
}

/// Renders `scene` with `method`, a CPU reference (`--method photon-gather`, `path-trace` or
/// `progressive`). Fails for a GPU method, or when cancelled before the first pass completed.
pub fn render(
    scene: &Scene,
    method: Method,
    settings: &RefSettings,
    progress: Option<&ProgressBar>,
    cancel: &AtomicBool,
) -> Result<HdrImage> {
    let bvh = SceneBvh::new(scene);
    let emitters = Emitters::of(scene);
    let ctx = Ctx {
        scene,
        bvh: &bvh,
        emitters: &emitters,
        settings,
        progress,
        cancel,
    };
    match method {
        Method::PathTrace => path_trace::render(&ctx),
        Method::PhotonGather => gather::render_gather(&ctx),
        Method::Progressive => gather::render_progressive(&ctx),
        Method::Ispm | Method::Direct => bail!(
            "--method {} is drawn by the GPU renderer, not a CPU reference",
            method.name()
        ),
    }
}

/// What every renderer needs.
pub(crate) struct Ctx<'a> {
    pub scene: &'a Scene,
    pub bvh: &'a SceneBvh,
    /// The scene's emissive surfaces (direct light by [`emitter_light::emitter_light`]).
    pub emitters: &'a Emitters,
    pub settings: &'a RefSettings,
    pub progress: Option<&'a ProgressBar>,
    pub cancel: &'a AtomicBool,
}

/// Running mean of complete passes.
pub(crate) struct Accumulator {
    sum: Vec<Vec3>,
    passes: u32,
    width: u32,
    height: u32,
}

impl Accumulator {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            sum: vec![Vec3::ZERO; width as usize * height as usize],
            passes: 0,
            width,
            height,
        }
    }

    pub fn add(&mut self, pass: Vec<Vec3>) {
        for (s, p) in self.sum.iter_mut().zip(pass) {
            *s += p;
        }
        self.passes += 1;
    }

    pub fn finish(self) -> Result<HdrImage> {
        if self.passes == 0 {
            bail!("interrupted before the first complete pass");
        }
        let scale = 1.0 / self.passes as f32;
        Ok(HdrImage {
            width: self.width,
            height: self.height,
            pixels: self
                .sum
                .into_iter()
                .map(|s| (s * scale).to_array())
                .collect(),
        })
    }
}

impl Ctx<'_> {
    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    pub fn set_length(&self, units: u64) {
        if let Some(p) = self.progress {
            p.set_length(units);
        }
    }

    /// One pass over all pixels, rows in parallel: `shade(x, y, rng)` with a per-pixel, per-pass
    /// RNG. `None` when cancelled (the pass is incomplete). Advances the progress bar by one per
    /// row.
    pub fn pass(
        &self,
        pass: u32,
        shade: impl Fn(u32, u32, &mut Rng) -> Vec3 + Sync,
    ) -> Option<Vec<Vec3>> {
        let (w, h) = (self.settings.width, self.settings.height);
        let rows: Vec<Option<Vec<Vec3>>> = (0..h)
            .into_par_iter()
            .map(|y| {
                if self.cancelled() {
                    return None;
                }
                let row = (0..w)
                    .map(|x| {
                        let pixel = y * w + x;
                        let mut rng =
                            Rng::new(hash2(hash2(pixel, pass), self.settings.seed ^ 0x5eed_0001));
                        let c = shade(x, y, &mut rng);
                        if c.is_finite() {
                            c
                        } else {
                            Vec3::ZERO
                        }
                    })
                    .collect();
                if let Some(p) = self.progress {
                    p.inc(1);
                }
                Some(row)
            })
            .collect();
        let mut out = Vec::with_capacity((w * h) as usize);
        for row in rows {
            out.extend(row?);
        }
        Some(out)
    }

    /// The camera ray through pixel (x, y): its centre when `spp == 1`, jittered otherwise.
    pub fn camera_ray(&self, x: u32, y: u32, rng: &mut Rng) -> Ray {
        let s = self.settings;
        let (jx, jy) = if s.spp <= 1 || !s.jitter {
            (0.5, 0.5)
        } else {
            (rng.next_f32(), rng.next_f32())
        };
        let cam = &self.scene.camera;
        let tan = (cam.yfov * 0.5).tan();
        let aspect = s.width as f32 / s.height.max(1) as f32;
        let px = ((x as f32 + jx) / s.width as f32 * 2.0 - 1.0) * tan * aspect;
        let py = (1.0 - (y as f32 + jy) / s.height as f32 * 2.0) * tan;
        let dir = cam
            .transform
            .transform_vector3(Vec3::new(px, py, -1.0))
            .normalize();
        Ray::new(cam.position(), dir)
    }
}

pub(crate) use emitter_light::emitter_light;

/// Direct light from every punctual light at `hit` (finite lobes; shadow rays).
pub(crate) fn direct_light(
    scene: &Scene,
    bvh: &SceneBvh,
    hit: &Hit,
    bsdf: &Bsdf,
    wo: Vec3,
) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for light in &scene.lights {
        let (wi, radiance_in, shadow) = match light.kind {
            LightKind::Directional => {
                let wi = -light.direction.normalize_or_zero();
                (wi, light.intensity, hit.spawn_ray(wi))
            }
            LightKind::Point | LightKind::Spot { .. } | LightKind::AreaSample => {
                let to = light.position - hit.position;
                let d2 = to.length_squared();
                if d2.is_nan() || d2 <= 0.0 {
                    continue;
                }
                let wi = to / d2.sqrt();
                let mut e = light.intensity / d2;
                if let LightKind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } = light.kind
                {
                    e *= spot_falloff(
                        inner_cone_angle.cos(),
                        outer_cone_angle.cos(),
                        light.direction.normalize_or_zero().dot(-wi),
                    );
                }
                if light.kind == LightKind::AreaSample {
                    e *= light.direction.normalize_or_zero().dot(-wi).max(0.0);
                }
                (wi, e, hit.spawn_ray_to(light.position))
            }
        };
        if radiance_in.max_element() <= 0.0 {
            continue;
        }
        let f = bsdf.eval(wo, wi, hit.shading_normal, hit.geometric_normal);
        if f.max_element() <= 0.0 {
            continue;
        }
        let cos = wi.dot(hit.shading_normal).abs();
        if !bvh.occluded(&shadow) {
            sum += f * radiance_in * cos;
        }
    }
    sum
}

/// Follows an eye ray through delta bounces; at every surface with a finite BSDF calls
/// `finite(hit, bsdf, wo)` for the radiance its finite lobes reflect, weighted by the path
/// throughput, and adds emission. At surfaces with delta lobes the path continues through one
/// of them (chosen ∝ its albedo, weight c/p). At most `max_depth` surfaces.
pub(crate) fn eye_path(
    ctx: &Ctx,
    mut ray: Ray,
    rng: &mut Rng,
    max_depth: u32,
    finite: impl Fn(&Hit, &Bsdf, Vec3) -> Vec3,
) -> Vec3 {
    let mut throughput = Vec3::ONE;
    let mut radiance = Vec3::ZERO;
    for _ in 0..max_depth {
        let Some(hit) = ctx.bvh.intersect(&ray) else {
            break;
        };
        let bsdf = bsdf_at(ctx.scene, &hit);
        let wo = -ray.dir;
        radiance += throughput * emitted(ctx.scene, &hit);
        if has_finite_lobe(&bsdf) {
            radiance += throughput * finite(&hit, &bsdf, wo);
        }
        let w = bsdf.albedo_weights(wo, hit.shading_normal, hit.geometric_normal);
        let delta = w[Lobe::Mirror as usize] + w[Lobe::Refraction as usize];
        if delta <= 0.0 {
            break;
        }
        let lobe = if rng.next_f32() * delta < w[Lobe::Mirror as usize] {
            Lobe::Mirror
        } else {
            Lobe::Refraction
        };
        let p = w[lobe as usize] / delta;
        let Some(s) = bsdf.sample_lobe(
            lobe,
            wo,
            hit.shading_normal,
            hit.geometric_normal,
            rng.next_2(),
        ) else {
            break;
        };
        throughput *= s.weight / p;
        ray = hit.spawn_ray(s.wi);
    }
    radiance
}
