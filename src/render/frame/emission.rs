//! Emissive surfaces as lights in the GPU frame (issue #18; `scene/emitters.rs` has the
//! sampling, docs/overview.md "Emissive surfaces" the design).
//!
//! ```text
//!  Renderer::lights = scene's lights ++ area samples of photon sample s (RenderSettings::emitter_lights)
//!        │ next_accumulation: a still frame takes sample s + 1
//!  place_area_samples(s) ─► new points on the emitters ─► apply_lights: plan, shadow views,
//!                           light-G-buffer views and bounce map move to them; the
//!                           accumulation goes on (averaged over frames: the area light)
//! ```
//!
//! A frame that stands alone (no accumulation) keeps the area samples of sample 0, so a
//! real-time frame is stable and reuses its photon map. Moving an emissive instance draws the
//! emitters again from its new place.

use super::Renderer;
use crate::scene::emitters::Emitters;
use crate::scene::Light;

/// The emitters as they were before instances moved ([`Renderer::move_emitters`]).
pub(super) struct EmittersBefore {
    emitters: Emitters,
    lights: Vec<Light>,
    sample: u32,
}

impl Renderer {
    /// The area-sample lights of photon sample `sample`, after the scene's lights.
    fn lights_for_sample(&self, sample: u32) -> Vec<Light> {
        let mut lights = self.lights[..self.scene_lights].to_vec();
        let count = self.settings.emitter_lights;
        lights.extend(self.emitters.lights(&self.source, sample, count));
        lights
    }

    /// Places the emitters' area samples for photon sample `sample` (nothing to do when they
    /// are there already, or there are no emitters); the accumulation goes on.
    pub(super) fn place_area_samples(&mut self, sample: u32) -> anyhow::Result<()> {
        if self.emitters.is_empty() || sample == self.emitter_sample {
            return Ok(());
        }
        let lights = self.lights_for_sample(sample);
        self.apply_lights(&lights)?;
        self.emitter_sample = sample;
        Ok(())
    }

    /// After instances moved (already applied to `source`): when an emissive one moved, the
    /// emitters are taken again from the moved scene and their area samples of sample 0 replace
    /// the old ones in `source` (what the plan is made from) and the frame's lights. Returns
    /// the emitters and lights before, for [`Self::restore_emitters`].
    pub(super) fn move_emitters(&mut self, moved: &[usize]) -> Option<EmittersBefore> {
        let emissive = moved.iter().any(|&i| {
            let mesh = &self.source.meshes[self.source.instances[i].mesh];
            self.source
                .materials
                .get(mesh.material)
                .is_some_and(|m| m.emission.max_element() > 0.0)
        });
        if !emissive {
            return None;
        }
        let emitters = Emitters::of(&self.source);
        let before = EmittersBefore {
            emitters: std::mem::replace(&mut self.emitters, emitters),
            lights: self.lights.clone(),
            sample: self.emitter_sample,
        };
        let lights = self.lights_for_sample(0);
        self.source.lights = lights.clone();
        self.lights = lights;
        self.emitter_sample = 0;
        Some(before)
    }

    /// Undoes [`Self::move_emitters`] (the instances' move failed).
    pub(super) fn restore_emitters(&mut self, before: Option<EmittersBefore>) {
        if let Some(before) = before {
            self.emitters = before.emitters;
            self.source.lights = before.lights.clone();
            self.lights = before.lights;
            self.emitter_sample = before.sample;
        }
    }
}
