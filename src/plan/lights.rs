//! The per-light decisions of a plan ([`SceneAnalysis::plan`], again whenever the camera moves
//! or a light changes): whether a light has power, is enclosed away from every viewer, reaches
//! the scene and the visible part of it, and so gets shadow views and photons; then the photon
//! budget re-split over the lights that emit them.

use super::{reach, LightPlan, SceneAnalysis, Viewpoint};
use crate::photon::emit::photon_budget_among;
use crate::scene::{Camera, LightKind, Scene};
use glam::Vec3;

impl SceneAnalysis {
    /// Per light: direct and photons, with the budget re-split over the photon lights.
    pub(super) fn plan_lights(
        &self,
        scene: &Scene,
        camera: &Camera,
        indirect: bool,
    ) -> Vec<LightPlan> {
        if scene.lights.is_empty() {
            return Vec::new();
        }
        let (settings, bounds) = (&self.settings, &self.bounds);
        let translucent = self.translucent.needed;
        let aspect = settings.width.max(1) as f32 / settings.height.max(1) as f32;
        let visible = reach::visible_box(camera, aspect, bounds);
        let diag = bounds.extent().length().max(1e-6);
        let mut viewers = vec![Viewpoint {
            position: camera.position(),
            clearance: reach::near_reach(camera, aspect),
        }];
        if translucent {
            // The environment cubes see the whole scene from their probes' centres.
            for probe in &self.probes {
                viewers.push(Viewpoint {
                    position: probe.center(),
                    clearance: (1e-3 * diag).max(1e-4),
                });
            }
        }
        // What viewers can see: the camera's visible box, or all of it for the probes.
        let seen = if translucent { *bounds } else { visible };
        let enclosures = &self.enclosures;
        let mut plans: Vec<LightPlan> = scene
            .lights
            .iter()
            .map(|light| {
                let named = |direct, reason: String| LightPlan {
                    name: light.name.clone(),
                    direct,
                    photons: 0,
                    reason,
                };
                let power = reach::light_power(light, bounds);
                if power.is_nan() || power <= 0.0 {
                    return named(false, "zero power".to_string());
                }
                let position = match light.kind {
                    // Light from outside everything: a point beyond the scene's bounds.
                    LightKind::Directional => {
                        bounds.center() - light.direction.normalize_or(Vec3::NEG_Y) * 2.0 * diag
                    }
                    _ => light.position,
                };
                let source = Viewpoint {
                    position,
                    clearance: 1e-4 * diag,
                };
                let walls: Vec<&str> = viewers
                    .iter()
                    .filter_map(|v| enclosures.separating(&source, v))
                    .collect();
                if walls.len() == viewers.len() {
                    return named(
                        false,
                        format!(
                            "enclosed: the closed opaque surface '{}' separates it from the camera",
                            walls[0]
                        ),
                    );
                }
                if !reach::light_reaches(light, reach::sphere_of(bounds)) {
                    return named(false, "its cone misses the scene".to_string());
                }
                let direct =
                    !seen.is_empty() && reach::light_reaches(light, reach::sphere_of(&seen));
                let photons = indirect;
                let unseen = if seen.is_empty() {
                    "nothing of the scene is in view"
                } else {
                    "its cone misses the visible scene"
                };
                let reason = match (direct, photons) {
                    (true, true) => "lights the visible scene and emits photons".to_string(),
                    (true, false) => "lights the visible scene (no indirect light)".to_string(),
                    (false, true) => format!("{unseen}: photons only, no shadow map"),
                    (false, false) => format!("{unseen}, and there is no indirect light"),
                };
                LightPlan {
                    photons: usize::from(photons),
                    ..named(direct, reason)
                }
            })
            .collect();
        let mask: Vec<bool> = plans.iter().map(|l| l.photons > 0).collect();
        let budget = photon_budget_among(scene, settings.photons, &mask);
        for (plan, n) in plans.iter_mut().zip(budget) {
            plan.photons = n;
        }
        plans
    }
}
