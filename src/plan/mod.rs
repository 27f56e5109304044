//! Scene analysis → the effects plan (issue #9): which light-transport effects a scene and
//! view call for, and so which passes, shader variants, lights and bounces a frame needs, each
//! with the reason (the material or light that caused it). No Vulkan: `render/frame.rs` reads the
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
//!
//! Beside the effects plan, this room holds the frame's other CPU-side plans: [`lighting`]
//! (each light as the GPU sees it and the shadow-map views that cover it) and [`bounce_plan`]
//! (the photon budget → light views of the bounce map, and the bounce map read back → the
//! photon map).

mod analysis;
pub mod bounce_plan;
mod bounces;
mod emitters;
mod enclosure;
pub mod lighting;
mod lights;
mod motion;
mod pass_list;
pub mod probes;
mod reach;
#[cfg(test)]
mod tests;

pub(crate) use analysis::welds_enclosures;
pub use enclosure::{Enclosures, StaticEnclosures, Viewpoint};
pub use motion::MotionPlan;

use crate::config::settings::Effects;
use crate::config::settings::{Density, RenderSettings, SkippedPass};
use crate::photon::bsdf::{BsdfVariant, MaterialLobes};
use crate::scene::{Aabb, Material};
use crate::timing::pass_id::PassId;
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
    /// Its direct light can reach something a viewer (the camera, or an environment probe
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

/// What a frame of one scene, seen from one camera, needs.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct EffectsPlan {
    pub effects: Effects,
    /// The translucent pass and its environment cube maps (instances with a delta material,
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
    /// At `subsample > 1`: the fine photons (caustic photons with narrow kernels,
    /// `photon::kernel::Share`) estimated at full resolution and the others at 1/N
    /// (`render/photon_frame/estimate.rs`). Where the scene can make caustic photons (a delta
    /// or glossy lobe) and `--subsample-caustics` is not given.
    pub fine_photons: Decision,
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
    /// Where the environment cubes see the scene from: the bounds each probe is centred on
    /// ([`probes::assign_probes`]; none without the translucent pass).
    probes: Vec<Aabb>,
    enclosures: Enclosures,
    /// Emissive surfaces as lights, before looking at the lights.
    emitters: Decision,
}

impl EffectsPlan {
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
    /// (`bounce_plan::BouncePlan::with_budget`).
    pub fn photon_budget(&self) -> Vec<Option<usize>> {
        self.lights
            .iter()
            .map(|l| (l.photons > 0).then_some(l.photons))
            .collect()
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
