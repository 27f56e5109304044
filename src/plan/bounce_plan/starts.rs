//! The photons the CPU continues ([`BouncePlan::photon_starts`]): each bounce-map record with
//! power placed at the hit point its jittered texel ray and depth describe, snapped onto the
//! surface it meets there when the renderer's BVH is at hand, and keyed by its texel.

use super::texels::{jittered_ndc, texel_jitter, unproject, FAR, NEAR};
use super::BouncePlan;
use crate::photon::bvh::SceneBvh;
use crate::photon::rng::hash2;
use crate::photon::trace::PhotonState;
use crate::photon::types::BounceMapPhoton;
use glam::DVec3;
use rayon::prelude::*;
use std::ops::Range;

/// Salt of a bounce-map photon's CPU path key (its generator must not repeat the texel's).
const CPU_PATH_STREAM: u32 = 0x0c90_7ace;

impl BouncePlan {
    /// The photons to continue on the CPU: every bounce-map record with power, placed at the
    /// hit point its texel ray (through the texel's jittered point of sample `sample`,
    /// [`texel_jitter`]) and depth describe (in world space), and pushed along its direction by
    /// the hit point's error bound.
    pub fn photon_starts(&self, bounce_map: &[BounceMapPhoton], sample: u32) -> Vec<PhotonState> {
        self.starts(bounce_map, self.origin, 0..self.views.len(), sample, None)
    }

    /// [`Self::photon_starts`] relative to the plan's origin (the renderer's CPU trace, whose
    /// BVH `surface` is built relative to it: `photon_frame.rs`), of the views `views` only
    /// (e.g. one light's, [`Self::light_views`]), in the same order. Each start is snapped onto
    /// the surface its jittered texel ray meets near the bounce map's depth (below).
    pub fn photon_starts_from_origin(
        &self,
        bounce_map: &[BounceMapPhoton],
        views: Range<usize>,
        sample: u32,
        surface: &SceneBvh,
    ) -> Vec<PhotonState> {
        self.starts(bounce_map, DVec3::ZERO, views, sample, Some(surface))
    }

    /// The photon starts of the views `views`, placed in the frame whose origin is `origin` in
    /// the plan's.
    fn starts(
        &self,
        bounce_map: &[BounceMapPhoton],
        origin: DVec3,
        views: Range<usize>,
        sample: u32,
        surface: Option<&SceneBvh>,
    ) -> Vec<PhotonState> {
        // The error of a hit point: 10⁻⁴ of its depth and origin-relative size (the light
        // G-buffer's interpolated position and f32 depth, generously), plus 4ε of its
        // coordinates (their rounding to f32, and the triangles': a few ulps).
        // Scale and position case: no absolute term, so a millimetre scene is not left 0.1 mm
        // off its surfaces, and a scene 10⁵ m from the origin not 10 m (which had every photon
        // leave a 2 m box).
        let error = |relative: DVec3, depth: f32, hit: DVec3| {
            (1e-4 * (relative.abs().max_element() + f64::from(depth))
                + 4.0 * f64::from(f32::EPSILON) * hit.abs().max_element()) as f32
        };
        // The bounce map placed each photon on the plane of the triangle its texel's centre saw
        // (`bounce_map.comp`); a jittered point past that triangle's edge lies on the plane
        // extended, a hair off the surface (behind it inside a faceted sphere, so the photon
        // would leave). With the BVH, the texel's ray is traced over ±5 % of that depth and the
        // start moved onto the surface it meets there; a ray that meets none (it passes a
        // silhouette) keeps the plane's point.
        let place = |p: &BounceMapPhoton, near: DVec3, dir: DVec3, key: u32| {
            let depth = f64::from(p.depth);
            let mut relative = near + dir * depth;
            if let Some(bvh) = surface {
                let from = near + dir * (0.95 * depth);
                let ray = crate::photon::ray::Ray::with_t_max(
                    from.as_vec3(),
                    dir.as_vec3(),
                    (0.1 * depth) as f32,
                );
                if let Some(h) = bvh.intersect(&ray) {
                    relative = h.position.as_dvec3();
                }
            }
            let hit = relative + origin;
            let error = error(relative, p.depth, hit);
            PhotonState::from_bounce_map(p, hit.as_vec3(), error, key)
        };
        // Row by row on every core (each texel's start depends on its texel alone), in the
        // texels' order.
        let mut starts = Vec::new();
        for (v, view) in self
            .views
            .iter()
            .enumerate()
            .take(views.end)
            .skip(views.start)
        {
            let (width, height) = (view.texels.x, view.texels.y);
            if width == 0 || height == 0 {
                continue;
            }
            let inverse = &self.view_matrices[v].inverse();
            let offset = view.texels.z as usize;
            let place = &place;
            starts.par_extend((0..height).into_par_iter().flat_map_iter(|y| {
                (0..width).filter_map(move |x| {
                    let index = offset + (y * width + x) as usize;
                    let p = bounce_map.get(index)?;
                    if p.power.max_element().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
                    {
                        return None;
                    }
                    let texel_key = self.texel_key(v, x, y);
                    let jitter = texel_jitter(texel_key, sample);
                    let ndc = jittered_ndc(x, y, jitter, width, height);
                    let near = unproject(inverse, ndc, NEAR);
                    let dir = (unproject(inverse, ndc, FAR) - near).normalize();
                    // The path is keyed by its texel, as the bounce map's own generator is, not
                    // by where it starts.
                    place(p, near, dir, hash2(texel_key, CPU_PATH_STREAM))
                })
            }));
        }
        starts
    }
}
