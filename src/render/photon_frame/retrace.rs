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
//! records and photons are bit for bit those a fresh trace would make, and so is the image: the
//! photons' kernel radii, which depend on every light's photons, are measured again over the
//! whole map each time it is traced (`photon_frame.rs`, "Kernel radii").

use crate::photon::bvh::SceneBvh;
use crate::photon::trace::{trace_photon_groups, PhotonState, TraceSettings};
use crate::photon::types::{BounceMapPhoton, Photon};
use crate::plan::bounce_plan::BouncePlan;
use crate::render::stats::{skipped, FrameStats, ReusedLight, TRACE_PASSES};
use crate::scene::Scene;
use crate::timing;
use crate::timing::pass_id::PassId;
use std::ops::Range;

/// One light's share of the photon map.
#[derive(Clone, Debug, Default)]
pub(super) struct LightPhotons {
    /// Its photons, origin-relative, in trace order.
    pub photons: Vec<Photon>,
    /// Its bounce-map photons (the paths started on the CPU).
    pub starts: usize,
    /// The photons it sent (bounce-map records with an `eta`: `bounce_map.comp`).
    pub emitted: usize,
    /// Its paths alive after each bounce (`PhotonMap::attrition`).
    pub attrition: Vec<u64>,
}

/// What one frame's photon map is made from.
pub(super) struct Frame<'a> {
    pub plan: &'a BouncePlan,
    pub scene: &'a Scene,
    pub bvh: &'a SceneBvh,
    pub trace: &'a TraceSettings,
    /// Per light: whether its photons are traced again ([`Traced::changed`]).
    pub retrace: &'a [bool],
    /// The photon sample the bounce map was made with (its texels' jittered points).
    pub sample: u32,
}

/// Reads the bounce-map records of a texel range (a re-traced light's) from this frame's
/// readback.
pub(super) type ReadRecords<'a> =
    dyn FnMut(Range<usize>, &mut [BounceMapPhoton]) -> anyhow::Result<()> + 'a;

/// The last traced photon map, per light, and the plan it was traced with.
#[derive(Default)]
pub(super) struct Traced {
    /// `None`: nothing kept (no frame traced yet, or the geometry moved since).
    plan: Option<BouncePlan>,
    /// Per light of the scene, in order: the photon map is their photons, light after light.
    lights: Vec<LightPhotons>,
    /// The last frame's bounce map, one record per texel of its plan: the kept lights' records
    /// stay in place, the re-traced lights' are read back over theirs.
    bounce_map: Vec<BounceMapPhoton>,
}

impl Traced {
    /// Forgets the kept photons: the next frame traces every light (an instance moved).
    pub fn invalidate(&mut self) {
        self.plan = None;
    }

    /// Forgets everything: a frame without photons.
    pub fn clear(&mut self) {
        *self = Self::default();
    }

    /// The last frame's bounce map.
    pub fn bounce_map(&self) -> &[BounceMapPhoton] {
        &self.bounce_map
    }

    /// The photon map per light, in light order.
    pub fn lights(&self) -> &[LightPhotons] {
        &self.lights
    }

    /// The photon map (origin-relative) as one slice per light, light after light.
    pub fn light_photons(&self) -> impl Iterator<Item = &[Photon]> {
        self.lights.iter().map(|l| l.photons.as_slice())
    }

    /// The photon map (origin-relative): every light's photons, light after light.
    pub fn photons(&self) -> impl Iterator<Item = &Photon> {
        self.light_photons().flatten()
    }

    /// The photon map's length.
    pub fn photon_count(&self) -> usize {
        self.lights.iter().map(|l| l.photons.len()).sum()
    }

    /// Keeps `lights` (one per scene light) as traced with `plan`.
    fn keep(&mut self, plan: &BouncePlan, lights: Vec<LightPhotons>) {
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
    fn take(&mut self, light: usize) -> LightPhotons {
        self.lights
            .get_mut(light)
            .map(std::mem::take)
            .unwrap_or_default()
    }
}

impl Traced {
    /// Traces the re-traced lights of `frame` on every core (their records read with `read`)
    /// and keeps the others' photons and records: the bounce map ([`Self::bounce_map`]) and
    /// photon map ([`Self::photons`]: origin-relative, light after light, the order a fresh
    /// trace of every light stores them in) are then the frame's. Fills `stats`' photon counts,
    /// attrition, CPU trace time and per-light lists.
    pub fn update(
        &mut self,
        frame: &Frame,
        read: &mut ReadRecords,
        stats: &mut FrameStats,
    ) -> anyhow::Result<()> {
        let plan = frame.plan;
        let traces = frame.retrace.iter().any(|&r| r);
        let trace_span = traces.then(|| timing::span(PassId::CpuTrace.name()));
        // The kept lights' records stay where they are (the same places in both plans).
        let kept_records = self.bounce_map.len();
        self.bounce_map
            .resize(plan.texels, BounceMapPhoton::default());
        // Kept lights' photons, and the re-traced lights' starts (traced together below).
        let mut lights = vec![None; frame.retrace.len()];
        let mut traced: Vec<(usize, usize, Vec<PhotonState>)> = Vec::new();
        for (light, &retrace) in frame.retrace.iter().enumerate() {
            let views = plan.light_views(light);
            let texels = plan.texel_range(views.clone());
            if views.is_empty() {
                lights[light] = Some(LightPhotons::default()); // no photons this frame
                continue;
            }
            if !retrace {
                // Invariant: `changed` keeps a light only if the last traced plan has its views,
                // bit for bit at the same places, so its records are in the last bounce map.
                assert!(
                    texels.end <= kept_records && self.plan.is_some(),
                    "light {light} is kept but its records {texels:?} are not in the last \
                     bounce map ({kept_records} records)"
                );
                let name = &frame.scene.lights[light].name;
                stats
                    .lights_reused
                    .push(ReusedLight::new(light, name, "its photons reused"));
                lights[light] = Some(self.take(light));
                continue;
            }
            timing::timed("bounce map read", || {
                read(texels.clone(), &mut self.bounce_map[texels.clone()])
            })?;
            let emitted = self.bounce_map[texels]
                .iter()
                .filter(|p| p.eta != 0.0)
                .count();
            let starts = timing::timed("photon starts", || {
                plan.photon_starts_from_origin(&self.bounce_map, views, frame.sample, frame.bvh)
            });
            traced.push((light, emitted, starts));
        }
        // One parallel trace of every re-traced light's starts; each light's photons are those
        // a trace of its starts alone makes (`trace_photon_groups`).
        let groups: Vec<&[PhotonState]> = traced.iter().map(|(_, _, s)| s.as_slice()).collect();
        let maps = trace_photon_groups(frame.scene, frame.bvh, &groups, frame.trace);
        for ((light, emitted, starts), map) in traced.iter().zip(maps) {
            // Traced relative to the origin (the BVH is), so the photons come out relative;
            // the photon volumes add the eye's offset (`photon_frame.rs`).
            let photons = map.photons;
            stats.lights_retraced.push(*light);
            stats.traced_bounce_map_photons += starts.len();
            lights[*light] = Some(LightPhotons {
                photons,
                starts: starts.len(),
                emitted: *emitted,
                attrition: map.attrition,
            });
        }
        let lights: Vec<LightPhotons> = lights.into_iter().map(Option::unwrap_or_default).collect();
        if let Some(span) = trace_span {
            stats.cpu_trace_ms = span.finish();
        } else {
            let reason = "every light's photons reused: no light's views changed";
            stats.passes_skipped = skipped(TRACE_PASSES, reason);
        }
        for l in &lights {
            stats.bounce_map_photons += l.starts;
            stats.emitted_photons += l.emitted;
            stats.stored_photons += l.photons.len();
            add_attrition(&mut stats.attrition, &l.attrition);
        }
        self.keep(plan, lights);
        Ok(())
    }
}

/// Elementwise sum of attrition counts of different lengths.
fn add_attrition(total: &mut Vec<u64>, more: &[u64]) {
    if total.len() < more.len() {
        total.resize(more.len(), 0);
    }
    for (a, b) in total.iter_mut().zip(more) {
        *a += b;
    }
}
