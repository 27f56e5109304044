//! Unidirectional path tracing with next-event estimation to the punctual lights (which rays
//! cannot hit, so there is nothing to weight by MIS) and to the emissive surfaces (by area,
//! `emitter_light.rs`), and Russian roulette on the throughput from the fourth surface.
//! Emission is added where next-event estimation cannot have counted it: at the first surface
//! and after a delta (mirror, refraction) bounce; a path that reaches an emitter by sampling a
//! finite lobe adds none (the emitter sample at the surface before counted that light).

use super::{direct_light, emitter_light, Accumulator, Ctx, HdrImage};
use crate::photon::bsdf::Lobe;
use crate::photon::ray::Ray;
use crate::photon::rng::Rng;
use crate::photon::trace::{bsdf_at, carries_power, emitted};
use anyhow::Result;
use glam::Vec3;

/// Surfaces after which Russian roulette starts.
const RR_START: u32 = 3;

fn radiance(ctx: &Ctx, mut ray: Ray, rng: &mut Rng) -> Vec3 {
    let mut throughput = Vec3::ONE;
    let mut l = Vec3::ZERO;
    // Emission counts here: the camera ray, or a delta bounce (no emitter sample sees it).
    let mut counts_emission = true;
    for depth in 0..=ctx.settings.bounces {
        let Some(hit) = ctx.bvh.intersect(&ray) else {
            break;
        };
        let bsdf = bsdf_at(ctx.scene, &hit);
        let wo = -ray.dir;
        if counts_emission {
            l += throughput * emitted(ctx.scene, &hit);
        }
        l += throughput * direct_light(ctx.scene, ctx.bvh, &hit, &bsdf, wo);
        l += throughput * emitter_light(ctx, &hit, &bsdf, wo);
        let Some(s) = bsdf.sample(wo, hit.shading_normal, hit.geometric_normal, rng.next_3())
        else {
            break;
        };
        throughput *= s.weight;
        counts_emission = matches!(s.lobe, Lobe::Mirror | Lobe::Refraction);
        if depth >= RR_START {
            let survive = throughput.max_element().clamp(0.05, 1.0);
            if rng.next_f32() >= survive {
                break;
            }
            throughput /= survive;
        }
        if !carries_power(throughput) {
            break;
        }
        ray = hit.spawn_ray(s.wi);
    }
    l
}

pub(super) fn render(ctx: &Ctx) -> Result<HdrImage> {
    let s = ctx.settings;
    let passes = s.spp.max(1);
    ctx.set_length(passes as u64 * s.height as u64);
    let mut acc = Accumulator::new(s.width, s.height);
    for pass in 0..passes {
        match ctx.pass(pass, |x, y, rng| {
            let ray = ctx.camera_ray(x, y, rng);
            radiance(ctx, ray, rng)
        }) {
            Some(image) => acc.add(image),
            None => break,
        }
    }
    acc.finish()
}
