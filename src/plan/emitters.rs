//! Emissive surfaces in the effects plan (issue #18): whether they light the scene, and
//! whether a scene's lights include their area samples (`scene::emitters`).

use super::Decision;
use crate::config::settings::RenderSettings;
use crate::scene::emitters::Emitters;
use crate::scene::{LightKind, Scene};

/// Whether `scene`'s lights include emitters' area samples (`scene::emitters`).
pub(super) fn has_area_samples(scene: &Scene) -> bool {
    scene.lights.iter().any(|l| l.kind == LightKind::AreaSample)
}

/// Whether emissive surfaces light the scene, and why.
pub(super) fn emitters_decision(scene: &Scene, settings: &RenderSettings) -> Decision {
    let emitters = Emitters::of(scene);
    if emitters.is_empty() {
        return Decision::no("no surface emits light");
    }
    let what = emitters.describe(scene);
    if settings.emitter_lights == 0 {
        return Decision::no(format!(
            "{what}; no area samples (emitter_lights 0): seen, not lighting"
        ));
    }
    Decision::yes(format!(
        "{what}: {} area-sample lights per frame (direct light with shadows, photons by power), \
         new points every accumulated frame",
        settings.emitter_lights
    ))
}
