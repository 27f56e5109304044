//! [`EffectsPlan::passes`]: every pass of the frame, in frame order, run or skipped, and the
//! reason, from the plan's decisions (`ispm plan` prints them; the stats list the skipped ones).

use super::{EffectsPlan, PassPlan};
use crate::config::settings::Density;
use crate::timing::pass_id::PassId;

impl EffectsPlan {
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
        let fine = match indirect.needed {
            true => pass(
                PassId::FinePhotons,
                self.fine_photons.needed,
                &self.fine_photons.reason,
            ),
            false => photon(PassId::FinePhotons),
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
            fine,
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
