//! Direct light from emissive surfaces in the CPU references (issue #18): next-event estimation
//! by area on the emitters (`scene::emitters`), so the path tracer need not find a small lamp by
//! chance. Paths that reach an emitter by sampling a finite lobe then add no emission
//! (`path_trace.rs`): each path's emitted light is counted once.

use super::Ctx;
use crate::photon::bsdf::Bsdf;
use crate::photon::ray::Hit;
use crate::photon::rng::{hash2, hash_vec3, Rng};
use glam::Vec3;

/// Points sampled on the emitters per shading point.
pub const EMITTER_SAMPLES: u32 = 4;

/// Salt of the emitter samples' random numbers.
const EMITTER_STREAM: u32 = 0x3e17_7e55;

/// The light the emitters send to `hit` and its finite lobes reflect towards `wo`, estimated
/// with [`EMITTER_SAMPLES`] points drawn ∝ power and uniformly by area, shadow rays to each.
/// The random numbers are a hash of the hit and `wo`, so a pixel centre's direct light is
/// deterministic, as the punctual lights' is.
pub(crate) fn emitter_light(ctx: &Ctx, hit: &Hit, bsdf: &Bsdf, wo: Vec3) -> Vec3 {
    let emitters = ctx.emitters;
    if emitters.is_empty() {
        return Vec3::ZERO;
    }
    let seed = hash2(
        hash2(hash_vec3(hit.position), hash_vec3(wo)),
        ctx.settings.seed,
    );
    let mut rng = Rng::new(hash2(seed, EMITTER_STREAM));
    let mut sum = Vec3::ZERO;
    for _ in 0..EMITTER_SAMPLES {
        let Some(s) = emitters.sample(rng.next_3()) else {
            break;
        };
        let to = s.position - hit.position;
        let d2 = to.length_squared();
        if !(d2 > 0.0 && d2.is_finite()) {
            continue;
        }
        let wi = to / d2.sqrt();
        let cos_emitter = s.normal.dot(-wi);
        if cos_emitter <= 0.0 || s.pdf_area <= 0.0 {
            continue;
        }
        let f = bsdf.eval(wo, wi, hit.shading_normal, hit.geometric_normal);
        if f.max_element() <= 0.0 {
            continue;
        }
        // Aimed a hair in front of the emitter, so the shadow ray does not end on it.
        let target = emitters.in_front(s.position, s.normal);
        if ctx.bvh.occluded(&hit.spawn_ray_to(target)) {
            continue;
        }
        let cos = wi.dot(hit.shading_normal).abs();
        sum += f * s.radiance * (cos * cos_emitter / (d2 * s.pdf_area));
    }
    sum / EMITTER_SAMPLES as f32
}
