//! Quality presets (`--quality draft|interactive|high|reference` of `render`, `view` and
//! `bench`): each sets the knobs `ispm sweep` varies to one point of the measured error–time
//! Pareto fronts of the bundled scenes (docs/accuracy.md §5, which records the fronts and the
//! points chosen). A flag given explicitly (`--photons`, `--bounces`, `--radius`,
//! `--subsample`, `--upsample`) overrides the preset's value for that knob. Without
//! `--quality`, `render --method ispm` starts from [`RENDER_DEFAULT`] and `view` from
//! [`VIEW_DEFAULT`]; `bench`, `--method direct`, the CPU references and `--quality none` use
//! the flags' own defaults. A preset fills the knobs not given in
//! `settings::RenderSettings::from_knobs`, the one place settings are made.
//!
//! The radius is a scale of the scene-relative kernel (`KernelSettings::scene_relative`), as
//! the sweep's `radius` knob, so a preset means the same on a scene of any size.

use crate::config::settings::{Preset, Upsample, DEFAULT_BOUNCES};

/// A point on the measured fronts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Quality {
    /// The fastest point of the front: 10k photons, 4× subsampled.
    Draft,
    /// 10k photons, twice the default kernel, 4× subsampled.
    Interactive,
    /// 40k photons, twice the default kernel, 4× subsampled.
    High,
    /// The most accurate single frame the sweep measured: 160k photons, twice the default
    /// kernel, 4× subsampled.
    Reference,
}

impl Quality {
    /// The preset's knobs: points of the single-frame front of the four bundled scenes' sweeps
    /// taken together, picked by `docs/tools/presets.py` (docs/accuracy.md §5.3: geometric
    /// means over the scenes of the frame time and of the relMSE over each scene's best,
    /// 160×120, lavapipe with the tiled gather, idle, 2026-11-27, against the references that
    /// resolve caustics and with the fine photons at full resolution: every point of the
    /// front is now 4× subsampled). Bounces are not a knob:
    /// Russian roulette ends the paths ([`DEFAULT_BOUNCES`] is only the safety cap).
    /// Accumulated frames are not either: `render` accumulates any preset for its `--seconds`
    /// or `--frames` (the sweep's accumulated frames are off the single frames' front since the
    /// fine photons: four frames of 10k photons took longer than `reference` for more error).
    pub fn preset(self) -> Preset {
        let (photons, radius_scale, subsample) = match self {
            // The fastest point of the front (53.8 ms, 1.57× the best error).
            Quality::Draft => (10_000, 1.0, 4),
            // 61.9 ms, 1.35×.
            Quality::Interactive => (10_000, 2.0, 4),
            // 127.1 ms, 1.17×.
            Quality::High => (40_000, 2.0, 4),
            // The most accurate single frame measured: 444.0 ms, 1.01×.
            Quality::Reference => (160_000, 2.0, 4),
        };
        Preset {
            photons,
            bounces: DEFAULT_BOUNCES,
            radius_scale,
            subsample,
            upsample: Upsample::Joint,
        }
    }
}

/// The preset `ispm render --method ispm` uses when `--quality` is not given: its other flags
/// override this preset's values as they would a named one's. On the default scene at the
/// default size (cornell-box, 640×480, lavapipe, 2 cores, `--seconds 4`, 2026-11-27) it
/// accumulated 8 frames in 3.5 s of wall time, relMSE 0.0087 against the 160×120 reference
/// after a 4×4 box filter (0.0025 blurred), where the `high` before it (10k photons,
/// `--subsample 2`) accumulated 9 frames for 0.0096 (0.0031) and `interactive` 14 frames for
/// 0.0093 (0.0029); docs/accuracy.md §7, "The defaults".
pub const RENDER_DEFAULT: Quality = Quality::High;

/// The preset `ispm view` starts with when `--quality` is not given: the cheapest frame that
/// stays clean in motion (7 frames in a 4 s budget at 640×480, where the flags' own defaults
/// drew one frame in 5 s).
pub const VIEW_DEFAULT: Quality = Quality::Interactive;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_are_ordered_by_cost() {
        let order = [
            Quality::Draft,
            Quality::Interactive,
            Quality::High,
            Quality::Reference,
        ]
        .map(Quality::preset);
        for w in order.windows(2) {
            assert!(w[0].photons <= w[1].photons, "{w:?}");
            assert!(w[0].subsample >= w[1].subsample, "{w:?}");
            assert!(w[0].bounces <= w[1].bounces, "{w:?}");
            assert!(w[0] != w[1], "two presets are the same point: {w:?}");
        }
    }
}
