//! Scene analysis → the effects plan (issue #9): which light-transport effects a scene and
//! view call for, and so which passes, shader variants, lights and bounces a frame needs, each
//! with the reason (the material or light that caused it). No Vulkan: `frame.rs` reads the
//! plan; `ispm plan` prints it. Every rule and why it is safe: `docs/effects.md`.
//!
//! ```text
//!   SceneAnalysis::new (once per scene and settings):
//!   materials ──► lobes ──► translucent pass, delta and glossy shader variants,
//!                           indirect (a scatterer and a receiver), bounce depth (albedo)
//!   geometry ──► one plane?  closed opaque surfaces
//!   SceneAnalysis::plan (again whenever the camera moves or a light changes):
//!   lights ──► power, cone vs scene / visible box, closed opaque surfaces ──► per light:
//!              direct (shadow views) and photons (budget re-split over the active ones)
//!   animations ──► motion: the instances with a BVH of their own, updated by transform (the
//!                  static geometry's is built once), and whether frames re-trace photons
//!   ──► passes(): every pass of the frame, run or skipped, and why
//! ```
//!
//! A rule only ever removes work whose result is provably zero (or, for the bounce depth,
//! below a stated fraction of the emitted power); every doubt keeps the work on.
//! [`Effects::All`] reproduces the unplanned frame: every variant, light and pass.

mod bounces;
mod emitters;
mod enclosure;
mod reach;
#[cfg(test)]
mod tests;

pub use enclosure::{Enclosures, Probe, StaticEnclosures};

use crate::pass_id::PassId;
use emitters::{emitters_decision, has_area_samples};

use crate::photon::bsdf::{BsdfVariant, MaterialLobes};
use crate::photon::emit::{photon_budget, photon_budget_among};
use crate::scene::emitters::Emitters;
use crate::scene::{Aabb, Camera, LightKind, Material, Scene};
pub use crate::settings::Effects;
use crate::settings::{Density, Method, RenderSettings, SkippedPass};
use glam::Vec3;
use std::fmt;

/// Power, relative to the emitted power, that the photons beyond the suggested bounce depth
/// may carry at most (in expectation, at the scene's brightest material's albedo).
pub const BOUNCE_POWER_CUTOFF: f64 = 1e-3;

/// One decision and why it was taken.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Decision {
    pub needed: bool,
    pub reason: String,
}

impl Decision {
    fn yes(reason: impl Into<String>) -> Self {
        Self {
            needed: true,
            reason: reason.into(),
        }
    }

    fn no(reason: impl Into<String>) -> Self {
        Self {
            needed: false,
            reason: reason.into(),
        }
    }
}

/// What one light contributes to the frame.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LightPlan {
    pub name: String,
    /// Its direct light can reach something a viewer (the camera, or the environment cube
    /// when the translucent pass runs) sees: it gets shadow views and the direct pass sums it.
    pub direct: bool,
    /// Photons it emits (0: no light G-buffer views, no bounce-map texels).
    pub photons: usize,
    pub reason: String,
}

impl LightPlan {
    /// The light takes part in the frame at all.
    pub fn active(&self) -> bool {
        self.direct || self.photons > 0
    }
}

/// One pass of the frame, run or skipped.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PassPlan {
    pub name: PassId,
    pub run: bool,
    pub reason: String,
}

/// What moves in the scene (glTF animations, `--orbit-lights`), and so what a frame redoes.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MotionPlan {
    /// The instances that move (indices into `Scene::instances`): each gets an object-space
    /// BVH of its mesh, moved by transform every frame (`photon::bvh::SceneBvh::update`); every
    /// other instance is in the static BVH, built once and never rebuilt.
    pub instances: Vec<usize>,
    /// The lights that move (indices into `Scene::lights`).
    pub lights: Vec<usize>,
    pub reason: String,
}

impl MotionPlan {
    /// What `scene`'s animations move.
    pub fn of(scene: &Scene) -> Self {
        let instances = scene.moving_instances();
        let lights = scene.moving_lights();
        let names = |names: Vec<&str>| {
            let shown: Vec<String> = names.iter().take(3).map(|n| format!("'{n}'")).collect();
            let more = names.len().saturating_sub(3);
            let more = if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            };
            format!("{}{more}", shown.join(", "))
        };
        let static_triangles: usize = scene
            .instances
            .iter()
            .enumerate()
            .filter(|(i, _)| instances.binary_search(i).is_err())
            .map(|(_, inst)| scene.meshes[inst.mesh].triangles.len())
            .sum();
        let mut what = Vec::new();
        if !instances.is_empty() {
            let moving = instances.iter().map(|&i| scene.instances[i].name.as_str());
            what.push(format!(
                "{} instance(s) move ({})",
                instances.len(),
                names(moving.collect())
            ));
        }
        if !lights.is_empty() {
            let moving = lights.iter().map(|&i| scene.lights[i].name.as_str());
            what.push(format!(
                "{} light(s) move ({})",
                lights.len(),
                names(moving.collect())
            ));
        }
        let reason = if what.is_empty() {
            "nothing is animated: one BVH, built once; frames reuse the photon map until a light \
             or an instance is changed"
                .to_string()
        } else if instances.is_empty() {
            format!(
                "{}: the BVH is static, built once; every frame re-traces the photon map",
                what.join(", ")
            )
        } else {
            format!(
                "{}: static geometry's BVH ({static_triangles} triangles) is built once and never \
                 rebuilt, the moving instances' BVHs are moved by transform each frame; every \
                 frame re-traces the photon map",
                what.join(", ")
            )
        };
        Self {
            instances,
            lights,
            reason,
        }
    }

    /// Something moves.
    pub fn moves(&self) -> bool {
        !self.instances.is_empty() || !self.lights.is_empty()
    }
}

/// What a frame of one scene, seen from one camera, needs.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct EffectsPlan {
    pub effects: Effects,
    /// The translucent pass and its environment cube map (instances with a delta material,
    /// `Material::has_delta_lobe`, leave the eye G-buffer for it).
    pub translucent: Decision,
    /// Mirror and refraction code in the shaders (the [`BsdfVariant::delta`] switch), and
    /// caustic paths in the CPU trace.
    pub delta: Decision,
    /// The finite-exponent glossy lobe in the shaders ([`BsdfVariant::glossy`]).
    pub glossy: Decision,
    /// Photon-mapped indirect light: light G-buffers, bounce map, readback, CPU trace, upload,
    /// photon volumes (+ upsample) and composite.
    pub indirect: Decision,
    /// Emissive surfaces as lights (issue #18): their area samples are among `lights`, new
    /// points every accumulated frame (`scene::emitters`).
    pub emitters: Decision,
    /// One entry per `Scene::lights`, in order (a renderer's area samples last).
    pub lights: Vec<LightPlan>,
    /// The most bounces a photon needs (0 without indirect light), at most `--bounces`.
    pub max_bounces: u32,
    pub max_bounces_reason: String,
    /// The subsample factor the frame uses (upsample runs above 1).
    pub subsample: u32,
    /// The density estimator (`--density`; the renderer resolves `Auto` for its device before
    /// it plans).
    pub density: Density,
    /// Levels of the indirect light's denoiser for a frame that starts an accumulation
    /// (`--denoise`, 0: off; `passes/denoise.rs`).
    pub denoise: u32,
    /// Whether still frames are averaged (`RenderSettings::accumulate`, and only where the
    /// frames differ: a frame with photon-mapped indirect light, or lit by emitters' area
    /// samples).
    pub accumulate: bool,
    /// What moves, and what that costs per frame.
    pub motion: MotionPlan,
}

/// A material in use (by an instance), with its lobes.
struct Used {
    material: Material,
    lobes: MaterialLobes,
}

/// The materials instances use (the default material for a missing one, as `GpuScene` does).
fn used_materials(scene: &Scene) -> Vec<Used> {
    let mut ids: Vec<usize> = scene
        .instances
        .iter()
        .map(|i| scene.meshes[i.mesh].material)
        .collect();
    ids.sort_unstable();
    ids.dedup();
    ids.into_iter()
        .map(|id| {
            let material = scene.materials.get(id).cloned().unwrap_or_default();
            Used {
                lobes: MaterialLobes::of(&material),
                material,
            }
        })
        .collect()
}

fn lobe_decision(
    used: &[Used],
    has: impl Fn(&MaterialLobes) -> bool,
    why: impl Fn(&Material, &MaterialLobes) -> String,
    none: &str,
) -> Decision {
    match used.iter().find(|u| has(&u.lobes)) {
        Some(u) => Decision::yes(why(&u.material, &u.lobes)),
        None => Decision::no(none),
    }
}

/// All world vertices lie on one plane: a photon leaving the surface never meets it again.
fn planar(scene: &Scene, bounds: &Aabb) -> bool {
    let triangles = scene.world_triangles();
    let Some(normal) = triangles.iter().find_map(|(t, _)| {
        let n = (t[1] - t[0]).as_dvec3().cross((t[2] - t[0]).as_dvec3());
        (n.length() > 0.0).then(|| n.normalize())
    }) else {
        return true;
    };
    let origin = triangles[0].0[0].as_dvec3();
    let tolerance = 1e-6 * f64::from(bounds.extent().length()).max(1e-30);
    triangles
        .iter()
        .flat_map(|(t, _)| t.iter())
        .all(|p| (p.as_dvec3() - origin).dot(normal).abs() <= tolerance)
}

fn show(v: Vec3) -> String {
    format!("({:.3}, {:.3}, {:.3})", v.x, v.y, v.z)
}

/// The part of the analysis that depends on neither the camera nor the lights: the materials'
/// lobes, the geometry (is it one plane, its closed opaque surfaces), the bounce depth and the
/// settings. A renderer keeps one and re-plans from it when the camera moves or a light changes
/// ([`SceneAnalysis::plan`]): only the per-light tests run again, not the passes over every
/// triangle. Measured on the 2-core CI machine: 0.01 ms to re-plan `cornell-box` against 4 ms
/// for the analysis; 0.4 ms against 0.5 s at 330k triangles.
pub struct SceneAnalysis {
    settings: RenderSettings,
    bounds: Aabb,
    subsample: u32,
    translucent: Decision,
    delta: Decision,
    glossy: Decision,
    /// Indirect light before looking at the lights ([`EffectsPlan::indirect`] also needs a light
    /// that emits photons).
    indirect: Decision,
    /// The bounce depth and its reason, for frames with indirect light.
    bounces: (u32, String),
    /// Where the environment cube sees the scene from: the delta instances' bounds (empty
    /// without the translucent pass).
    delta_bounds: Aabb,
    enclosures: Enclosures,
    /// Emissive surfaces as lights, before looking at the lights.
    emitters: Decision,
}

/// Whether the analysis of `scene` welds its closed surfaces (`plan/enclosure.rs`): only a
/// planned frame (`--effects auto`) of a scene with lights.
pub(crate) fn welds_enclosures(scene: &Scene, settings: &RenderSettings) -> bool {
    settings.effects == Effects::Auto && !scene.lights.is_empty()
}

impl SceneAnalysis {
    /// Analyses the geometry and materials of `scene` for frames made with `settings`.
    pub fn new(scene: &Scene, settings: &RenderSettings) -> Self {
        Self::analyse(scene, settings, None)
    }

    /// [`Self::new`], the closed surfaces of the instances that do not move taken from
    /// `statics` (made for this scene, none of its static instances moved since): for frames
    /// in which instances moved, the static geometry is not welded again.
    pub fn with_static(
        scene: &Scene,
        settings: &RenderSettings,
        statics: &StaticEnclosures,
    ) -> Self {
        Self::analyse(scene, settings, Some(statics))
    }

    fn analyse(
        scene: &Scene,
        settings: &RenderSettings,
        statics: Option<&StaticEnclosures>,
    ) -> Self {
        let used = used_materials(scene);
        let bounds = scene.bounds();
        let subsample = settings.subsample_factor();
        let delta_instance = scene.instances.iter().find_map(|i| {
            let m = scene.materials.get(scene.meshes[i.mesh].material)?;
            m.has_delta_lobe()
                .then_some((i.name.as_str(), m.name.as_str()))
        });
        let translucent = match delta_instance {
            Some((instance, material)) => Decision::yes(format!(
                "instance '{instance}' has the mirror or transmissive material '{material}'"
            )),
            None => Decision::no("no instance has a mirror or transmissive material"),
        };
        let delta = lobe_decision(
            &used,
            MaterialLobes::delta,
            |m, l| {
                if l.refraction {
                    format!(
                        "material '{}' refracts (transmission {})",
                        m.name,
                        show(m.transmission)
                    )
                } else {
                    format!("material '{}' is a perfect mirror", m.name)
                }
            },
            "no material has a mirror or refraction lobe",
        );
        let glossy = lobe_decision(
            &used,
            |l| l.glossy,
            |m, _| {
                if m.glossy.max_element() > 0.0 {
                    format!(
                        "material '{}' is glossy (reflectance {}, exponent {})",
                        m.name,
                        show(m.glossy),
                        m.exponent
                    )
                } else {
                    format!(
                        "material '{}' has a Fresnel glossy lobe (exponent {}, ior {})",
                        m.name, m.exponent, m.ior
                    )
                }
            },
            "no material has a finite-exponent glossy lobe",
        );
        // `--effects all` plans nothing: none of the rest is needed.
        let planned = settings.effects == Effects::Auto;
        let indirect = if planned {
            EffectsPlan::indirect_possible(scene, settings, &used, &bounds)
        } else {
            Decision::no("--effects all")
        };
        let mut delta_bounds = Aabb::EMPTY;
        if planned && translucent.needed {
            for inst in &scene.instances {
                let mesh = &scene.meshes[inst.mesh];
                if scene
                    .materials
                    .get(mesh.material)
                    .is_some_and(Material::has_delta_lobe)
                {
                    for &p in &mesh.positions {
                        delta_bounds.grow(inst.transform.transform_point3(p));
                    }
                }
            }
        }
        let enclosures = if welds_enclosures(scene, settings) {
            match statics {
                Some(statics) => Enclosures::with_static(statics, scene),
                None => Enclosures::new(scene),
            }
        } else {
            Enclosures::default()
        };
        let emitters = emitters_decision(scene, settings);
        Self {
            emitters,
            settings: settings.clone(),
            bounds,
            subsample,
            translucent,
            delta,
            glossy,
            bounces: bounces::bounce_depth(&used, settings.bounces),
            indirect,
            delta_bounds,
            enclosures,
        }
    }

    /// Per light: direct and photons, with the budget re-split over the photon lights.
    fn plan_lights(&self, scene: &Scene, camera: &Camera, indirect: bool) -> Vec<LightPlan> {
        if scene.lights.is_empty() {
            return Vec::new();
        }
        let (settings, bounds) = (&self.settings, &self.bounds);
        let translucent = self.translucent.needed;
        let aspect = settings.width.max(1) as f32 / settings.height.max(1) as f32;
        let visible = reach::visible_box(camera, aspect, bounds);
        let diag = bounds.extent().length().max(1e-6);
        let mut viewers = vec![Probe {
            position: camera.position(),
            clearance: reach::near_reach(camera, aspect),
        }];
        if translucent {
            // The environment cube sees the whole scene from the delta instances' centre.
            viewers.push(Probe {
                position: self.delta_bounds.center(),
                clearance: (1e-3 * diag).max(1e-4),
            });
        }
        // What viewers can see: the camera's visible box, or all of it for the cube.
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
                let source = Probe {
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

    /// The plan of a frame of `scene` seen from `camera`. `scene` has the geometry and
    /// materials this analysis was made of; its lights may have changed since.
    pub fn plan(&self, scene: &Scene, camera: &Camera) -> EffectsPlan {
        let settings = &self.settings;
        if settings.effects == Effects::All {
            return EffectsPlan::all(scene, settings, self.translucent.clone(), self.subsample);
        }
        let mut indirect = self.indirect.clone();
        let lights = self.plan_lights(scene, camera, indirect.needed);
        if indirect.needed && lights.iter().all(|l| l.photons == 0) {
            indirect = Decision::no(if scene.lights.is_empty() {
                "the scene has no lights".to_string()
            } else {
                "no light emits photons that reach the scene".to_string()
            });
        }
        let (max_bounces, max_bounces_reason) = if indirect.needed {
            self.bounces.clone()
        } else {
            (0, "no indirect light".to_string())
        };
        let sampled = has_area_samples(scene);
        let accumulate = settings.accumulate && (indirect.needed || sampled);
        EffectsPlan {
            effects: Effects::Auto,
            translucent: self.translucent.clone(),
            delta: self.delta.clone(),
            glossy: self.glossy.clone(),
            indirect,
            lights,
            max_bounces,
            max_bounces_reason,
            subsample: self.subsample,
            density: settings.density,
            denoise: settings.denoise,
            accumulate,
            emitters: self.emitters.clone(),
            motion: MotionPlan::of(scene),
        }
    }
}

impl EffectsPlan {
    /// Analyses `scene` rendered with `settings` from `camera` (a [`SceneAnalysis`] used once).
    /// Its emissive surfaces are lights: the plan has their area samples of frame 0 after the
    /// scene's lights, as a renderer of it does.
    pub fn analyse(scene: &Scene, settings: &RenderSettings, camera: &Camera) -> Self {
        let scene = Emitters::with_area_samples(scene, settings.emitter_lights);
        SceneAnalysis::new(&scene, settings).plan(&scene, camera)
    }

    /// `--effects all`: the unplanned frame.
    fn all(
        scene: &Scene,
        settings: &RenderSettings,
        translucent: Decision,
        subsample: u32,
    ) -> Self {
        let forced = |what: &str| Decision::yes(format!("--effects all ({what})"));
        let ispm = settings.method == Method::Ispm;
        let budget = if ispm {
            photon_budget(scene, settings.photons)
        } else {
            vec![0; scene.lights.len()]
        };
        let lights = scene
            .lights
            .iter()
            .zip(budget)
            .map(|(l, photons)| LightPlan {
                name: l.name.clone(),
                direct: true,
                photons,
                reason: "--effects all: every light, photons by power".to_string(),
            })
            .collect();
        Self {
            effects: Effects::All,
            translucent: Decision {
                reason: format!("--effects all: {}", translucent.reason),
                ..translucent
            },
            delta: forced("every lobe compiled in"),
            glossy: forced("every lobe compiled in"),
            indirect: if ispm {
                forced("--method ispm")
            } else {
                Decision::no("--method direct")
            },
            lights,
            max_bounces: if ispm { settings.bounces.max(1) } else { 0 },
            max_bounces_reason: "--effects all: --bounces (at least 1)".to_string(),
            subsample,
            density: settings.density,
            denoise: settings.denoise,
            accumulate: settings.accumulate && (ispm || has_area_samples(scene)),
            emitters: emitters_decision(scene, settings),
            motion: MotionPlan::of(scene),
        }
    }

    /// Indirect light before looking at the lights: the settings ask for it, some material
    /// scatters light, some material can show stored photons, and the geometry is not one
    /// plane.
    fn indirect_possible(
        scene: &Scene,
        settings: &RenderSettings,
        used: &[Used],
        bounds: &Aabb,
    ) -> Decision {
        if settings.method == Method::Direct {
            return Decision::no("--method direct");
        }
        if settings.bounces == 0 {
            return Decision::no("--bounces 0");
        }
        if settings.photons == 0 {
            return Decision::no("--photons 0");
        }
        if scene.instances.is_empty() {
            return Decision::no("the scene has no geometry");
        }
        if !used.iter().any(|u| u.lobes.scatters()) {
            return Decision::no("every material is black: no light is reflected or refracted");
        }
        let Some(receiver) = used.iter().find(|u| u.lobes.finite()) else {
            return Decision::no(
                "no material has a Lambertian or glossy lobe to store photons on and show them",
            );
        };
        if planar(scene, bounds) {
            return Decision::no(
                "all geometry lies in one plane: light leaving it never meets it again",
            );
        }
        // Name another scatterer where there is one: a material cannot light itself alone.
        let scatterer = used
            .iter()
            .filter(|u| u.lobes.scatters())
            .find(|u| u.material.name != receiver.material.name)
            .unwrap_or(receiver);
        Decision::yes(format!(
            "material '{}' scatters light and material '{}' shows the photons stored on it",
            scatterer.material.name, receiver.material.name
        ))
    }

    /// The über-BSDF lobes the shaders need.
    pub fn bsdf_variant(&self) -> BsdfVariant {
        BsdfVariant {
            glossy: self.glossy.needed,
            delta: self.delta.needed,
        }
    }

    /// The optional lobes of `compiled` (the variant the frame's shaders and CPU trace were
    /// built with: this plan's [`Self::bsdf_variant`], narrowed further by
    /// `RenderSettings::bsdf_variant`) that are off, in the stats' form: `glossy_lobe`,
    /// `delta_lobes` (mirror and refraction: no caustic paths), each with the plan's reason, or
    /// the setting's where the plan needed the lobe.
    pub fn variants_skipped(&self, compiled: BsdfVariant) -> Vec<SkippedPass> {
        [
            ("glossy_lobe", compiled.glossy, &self.glossy),
            ("delta_lobes", compiled.delta, &self.delta),
        ]
        .into_iter()
        .filter(|(_, on, _)| !on)
        .map(|(name, _, decision)| SkippedPass {
            name: name.to_string(),
            reason: if decision.needed {
                "compiled out by RenderSettings::bsdf_variant".to_string()
            } else {
                decision.reason.clone()
            },
        })
        .collect()
    }

    /// Per light: gets shadow views and direct light (`LightSetup::active`).
    pub fn direct_mask(&self) -> Vec<bool> {
        self.lights.iter().map(|l| l.direct).collect()
    }

    /// Per light: emits photons.
    pub fn photon_mask(&self) -> Vec<bool> {
        self.lights.iter().map(|l| l.photons > 0).collect()
    }

    /// Per light: the photons it emits, `None` where it emits none ([`Self::photon_mask`]
    /// off). The frame's one split of `--photons` over the lights, made in
    /// [`SceneAnalysis::plan`] by power; the bounce plan takes it as it is
    /// (`ispm::BouncePlan::with_budget`).
    pub fn photon_budget(&self) -> Vec<Option<usize>> {
        self.lights
            .iter()
            .map(|l| (l.photons > 0).then_some(l.photons))
            .collect()
    }

    /// Every pass of the frame, in frame order, run or skipped, and why.
    pub fn passes(&self) -> Vec<PassPlan> {
        let pass = |name, run, reason: &str| PassPlan {
            name,
            run,
            reason: reason.to_string(),
        };
        let indirect = &self.indirect;
        let photon = |name| pass(name, indirect.needed, &indirect.reason);
        let shadows = match self.lights.iter().find(|l| l.direct) {
            Some(l) => pass(
                PassId::ShadowMaps,
                true,
                &format!("light '{}' lights the view", l.name),
            ),
            None if self.lights.is_empty() => pass(PassId::ShadowMaps, false, "no lights"),
            None => pass(
                PassId::ShadowMaps,
                false,
                "no light reaches anything in view",
            ),
        };
        let upsample = if !indirect.needed {
            photon(PassId::Upsample)
        } else if self.subsample > 1 {
            pass(
                PassId::Upsample,
                true,
                &format!("--subsample {}", self.subsample),
            )
        } else {
            pass(
                PassId::Upsample,
                false,
                "--subsample 1: a full-resolution estimate",
            )
        };
        // The boundary normalisation of the global photons (`passes/support.rs`).
        let support = if !indirect.needed {
            photon(PassId::Support)
        } else if self.subsample > 1 {
            pass(
                PassId::Support,
                true,
                &format!(
                    "the photon volumes' kernels at surface boundaries (the 1/{} estimate)",
                    self.subsample
                ),
            )
        } else {
            pass(
                PassId::Support,
                true,
                "the photon volumes' kernels at surface boundaries",
            )
        };
        let denoise = if !indirect.needed {
            photon(PassId::Denoise)
        } else if self.denoise > 0 {
            pass(
                PassId::Denoise,
                true,
                &format!(
                    "--denoise {}: the indirect light's blotches, fewer levels as frames \
                     accumulate",
                    self.denoise
                ),
            )
        } else {
            pass(PassId::Denoise, false, "--denoise 0")
        };
        let translucent = |name| pass(name, self.translucent.needed, &self.translucent.reason);
        // The density estimator that runs, and the one that does not (`--density`).
        let (tiles, volumes) = match self.density {
            Density::Tiled => (
                photon(PassId::PhotonTiles),
                pass(
                    PassId::PhotonVolumes,
                    false,
                    "--density tiled: the tiled gather makes the estimate",
                ),
            ),
            Density::Volumes => (
                pass(
                    PassId::PhotonTiles,
                    false,
                    "--density volumes: the photon volumes make the estimate",
                ),
                photon(PassId::PhotonVolumes),
            ),
            Density::Auto => (
                pass(
                    PassId::PhotonTiles,
                    false,
                    "--density auto: the tiled gather where the device has its subgroup operations",
                ),
                photon(PassId::PhotonVolumes),
            ),
        };
        vec![
            photon(PassId::LightGbuffers),
            photon(PassId::BounceMap),
            photon(PassId::Readback),
            photon(PassId::CpuTrace),
            photon(PassId::Upload),
            shadows,
            pass(PassId::EyeGbuffer, true, "every frame: the camera's view"),
            pass(
                PassId::Direct,
                true,
                "every frame: direct light and emission",
            ),
            volumes,
            tiles,
            support,
            denoise,
            upsample,
            photon(PassId::Composite),
            translucent(PassId::Environment),
            translucent(PassId::Translucent),
            self.accumulate_pass(),
            pass(PassId::Tonemap, true, "every frame: the display image"),
        ]
    }
}

impl EffectsPlan {
    /// The accumulate pass: run when still frames are averaged.
    fn accumulate_pass(&self) -> PassPlan {
        if self.accumulate && !self.indirect.needed {
            PassPlan {
                name: PassId::Accumulate,
                run: true,
                reason: "progressive: still frames are averaged, each with new points on the \
                         emissive surfaces (reset when anything moves)"
                    .to_string(),
            }
        } else if self.accumulate {
            PassPlan {
                name: PassId::Accumulate,
                run: true,
                reason: "progressive: still frames are averaged, each with new photons and \
                         smaller kernels (reset when anything moves)"
                    .to_string(),
            }
        } else if !self.indirect.needed && !self.emitters.needed {
            PassPlan {
                name: PassId::Accumulate,
                run: false,
                reason: "no indirect light: every frame is the same".to_string(),
            }
        } else {
            PassPlan {
                name: PassId::Accumulate,
                run: false,
                reason: "not accumulating: each frame stands alone (real-time frames, bench)"
                    .to_string(),
            }
        }
    }
}

impl fmt::Display for EffectsPlan {
    /// One line per decision: `what: yes|no — reason`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let yes = |b: bool| if b { "yes" } else { "no" };
        let effects = match self.effects {
            Effects::Auto => "auto",
            Effects::All => "all",
        };
        writeln!(f, "effects: {effects}")?;
        for (what, d) in [
            ("translucent pass + environment map", &self.translucent),
            (
                "mirror/refraction lobes (shaders, caustic paths)",
                &self.delta,
            ),
            ("glossy lobe (shaders, CPU trace)", &self.glossy),
            ("indirect light (photons)", &self.indirect),
            ("emissive surfaces as lights", &self.emitters),
        ] {
            writeln!(f, "{what}: {} — {}", yes(d.needed), d.reason)?;
        }
        writeln!(
            f,
            "max bounces: {} — {}",
            self.max_bounces, self.max_bounces_reason
        )?;
        let motion = if self.motion.moves() {
            "moving"
        } else {
            "static"
        };
        writeln!(f, "motion: {motion} — {}", self.motion.reason)?;
        for (i, l) in self.lights.iter().enumerate() {
            let what = match (l.direct, l.photons) {
                (false, 0) => "skipped".to_string(),
                (true, 0) => "direct".to_string(),
                (false, n) => format!("{n} photons"),
                (true, n) => format!("direct + {n} photons"),
            };
            writeln!(f, "light {i} '{}': {what} — {}", l.name, l.reason)?;
        }
        for p in self.passes() {
            let run = if p.run { "run" } else { "skip" };
            writeln!(f, "pass {}: {run} — {}", p.name, p.reason)?;
        }
        Ok(())
    }
}
