//! Per-light photon reuse (issue #9): the photon map kept light by light, and which lights a
//! frame traces again.
//!
//! ```text
//!   plan (this frame) ─┐    per light l: same_light_views(last traced plan, l)
//!   last traced plan ──┴──►   && geometry unchanged && reuse allowed ?
//!                                 yes ──► l's bounce-map records and photons kept
//!                                 no  ──► l's views: light G-buffer, bounce map, readback,
//!                                         CPU trace of l's bounce-map photons
//!   photon map = light 0's photons ++ light 1's ++ … (light order: a fresh renderer's order)
//! ```
//!
//! A light's bounce-map records depend on its views (matrices, uniforms, extents, caustic
//! windows, power), on their places (view index = light-G-buffer layer and caustic parent;
//! record index = the GPU's random seed), on the geometry, the materials and `--seed`; its CPU
//! paths on its records, the geometry, `--seed` and the bounces (each path is seeded by a hash
//! of where it starts, `photon/trace.rs`, so it does not depend on the other lights' paths).
//! The materials, the seed, the bounces and the BSDF variant are fixed for a renderer; an
//! instance move ([`Traced::invalidate`]) re-traces every light; the rest is compared view by
//! view ([`BouncePlan::same_light_views`]), never taken from the caller. So a kept light's
//! records and photons are bit for bit those a fresh trace would make, and so is the image.

use crate::ispm::BouncePlan;
use crate::photon::types::Photon;

/// One light's share of the photon map.
#[derive(Clone, Debug, Default)]
pub(super) struct LightPhotons {
    /// Its photons, origin-relative, in trace order.
    pub photons: Vec<Photon>,
    /// Its bounce-map photons (the paths started on the CPU).
    pub starts: usize,
    /// Its paths alive after each bounce (`PhotonMap::attrition`).
    pub attrition: Vec<u64>,
}

/// The last traced photon map, per light, and the plan it was traced with.
#[derive(Default)]
pub(super) struct Traced {
    /// `None`: nothing kept (no frame traced yet, or the geometry moved since).
    plan: Option<BouncePlan>,
    /// Per light of the scene, in order.
    pub lights: Vec<LightPhotons>,
}

impl Traced {
    /// Forgets the kept photons: the next frame traces every light (an instance moved).
    pub fn invalidate(&mut self) {
        self.plan = None;
    }

    /// Keeps `lights` (one per scene light) as traced with `plan`.
    pub fn keep(&mut self, plan: &BouncePlan, lights: Vec<LightPhotons>) {
        self.plan = Some(plan.clone());
        self.lights = lights;
    }

    /// Per light of `plan`'s scene (`lights` of them): whether its photons must be traced
    /// again (always when `reuse` is off: `--effects all`).
    pub fn changed(&self, plan: &BouncePlan, lights: usize, reuse: bool) -> Vec<bool> {
        match &self.plan {
            Some(last) if reuse && self.lights.len() == lights => (0..lights)
                .map(|l| !plan.same_light_views(last, l))
                .collect(),
            _ => vec![true; lights],
        }
    }

    /// The light kept for `light`, taken out (the caller puts the new map back with
    /// [`Self::keep`]).
    pub fn take(&mut self, light: usize) -> LightPhotons {
        self.lights
            .get_mut(light)
            .map(std::mem::take)
            .unwrap_or_default()
    }
}

/// Elementwise sum of attrition counts of different lengths.
pub(super) fn add_attrition(total: &mut Vec<u64>, more: &[u64]) {
    if total.len() < more.len() {
        total.resize(more.len(), 0);
    }
    for (a, b) in total.iter_mut().zip(more) {
        *a += b;
    }
}
