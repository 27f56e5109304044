//! The analysis of a scene's materials and geometry ([`SceneAnalysis::new`]): the translucent
//! pass, the delta and glossy shader variants, whether indirect light is possible at all, the
//! bounce depth and the closed surfaces; and [`SceneAnalysis::plan`], which adds the per-light
//! decisions (`lights.rs`) to make the [`EffectsPlan`], or the unplanned one (`--effects all`).

use super::emitters::{emitters_decision, has_area_samples};
use super::{bounces, Decision, EffectsPlan, Enclosures, LightPlan, MotionPlan, Used};
use super::{SceneAnalysis, StaticEnclosures};
use crate::config::settings::{Effects, Method, RenderSettings};
use crate::photon::bsdf::MaterialLobes;
use crate::photon::emit::photon_budget;
use crate::scene::emitters::Emitters;
use crate::scene::{Aabb, Camera, Material, Scene};
use glam::Vec3;

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
        // Each delta instance with its bounds: the environment probes (`probes.rs`).
        let delta_instances = scene.delta_instance_bounds();
        let (probes, _) = super::probes::assign_probes(&delta_instances);
        let delta_instance = scene.instances.iter().find_map(|i| {
            let m = scene.materials.get(scene.meshes[i.mesh].material)?;
            m.has_delta_lobe()
                .then_some((i.name.as_str(), m.name.as_str()))
        });
        let translucent = match delta_instance {
            Some((instance, material)) => {
                let count =
                    |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
                Decision::yes(format!(
                    "instance '{instance}' has the mirror or transmissive material \
                     '{material}' ({} of such materials, {})",
                    count(delta_instances.len(), "instance"),
                    count(probes.len(), "environment probe")
                ))
            }
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
            probes,
            enclosures,
        }
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
            fine_photons: fine_photons(
                settings,
                self.subsample,
                self.delta.needed || self.glossy.needed,
            ),
            density: settings.density,
            denoise: settings.denoise,
            accumulate,
            emitters: self.emitters.clone(),
            motion: MotionPlan::of(scene),
        }
    }
}

/// [`EffectsPlan::fine_photons`]: subsampling, not `--subsample-caustics`, and lobes that make
/// caustic photons (`caustic_lobes`: a delta or glossy one).
fn fine_photons(settings: &RenderSettings, subsample: u32, caustic_lobes: bool) -> Decision {
    if subsample == 1 {
        Decision::no("--subsample 1: the full-resolution estimate holds every photon")
    } else if settings.subsampled_caustics {
        Decision::no(format!(
            "--subsample-caustics: every photon at 1/{subsample}"
        ))
    } else if !caustic_lobes {
        Decision::no("no mirror, glass or glossy material: no caustic photons")
    } else {
        Decision::yes(format!(
            "caustic photons with kernels under {} pixels of the 1/{subsample} image, at full \
             resolution",
            crate::photon::kernel::FINE_KERNEL_PIXELS
        ))
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
            fine_photons: fine_photons(settings, subsample, true),
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
}
