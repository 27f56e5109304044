//! The bounce depth of the effects plan (issue #19): Russian roulette ends photon paths, and
//! the plan truncates them only where the energy left is negligible (`docs/effects.md`,
//! "Bounce depth").

use super::{Used, BOUNCE_POWER_CUTOFF};
use crate::photon::bsdf::bounce_albedo;
use crate::photon::trace::MAX_BOUNCES;

/// The suggested bounce cap: the smallest K with a^(K+1)/(1 − a) < [`BOUNCE_POWER_CUTOFF`]
/// for the brightest material's [`bounce_albedo`] a (the expected power of all photons past
/// bounce K, relative to the emitted power), at least 1, at most `--bounces` (by default the
/// safety cap `MAX_BOUNCES`: Russian roulette ends the paths, the count is set by energy).
pub(super) fn bounce_depth(used: &[Used], bounces: u32) -> (u32, String) {
    let brightest = used
        .iter()
        .map(|u| (&u.material, bounce_albedo(&u.material)))
        .max_by(|a, b| a.1.total_cmp(&b.1));
    let Some((material, albedo)) = brightest else {
        return (bounces, "no materials".to_string());
    };
    let a = f64::from(albedo);
    let tail = |k: u32| a.powi(k as i32 + 1) / (1.0 - a);
    let cap = (1..bounces).find(|&k| a < 1.0 && tail(k) < BOUNCE_POWER_CUTOFF);
    match cap {
        Some(k) => (
            k,
            format!(
                "Russian roulette ends the photon paths; brightest material '{}' keeps \
                 {albedo:.3} per bounce: photons past bounce {k} carry < \
                 {BOUNCE_POWER_CUTOFF:e} of the emitted power",
                material.name
            ),
        ),
        _ if bounces >= MAX_BOUNCES => (
            bounces,
            format!(
                "Russian roulette ends the photon paths; {bounces} is only the safety cap \
                 (brightest material '{}' keeps {albedo:.3} per bounce)",
                material.name
            ),
        ),
        _ => (
            bounces,
            format!(
                "--bounces {bounces}: photons past it carry up to {} of the emitted power \
                 (brightest material '{}' keeps {albedo:.3} per bounce)",
                if a < 1.0 {
                    format!("{:.1e}", tail(bounces))
                } else {
                    "all".to_string()
                },
                material.name
            ),
        ),
    }
}
