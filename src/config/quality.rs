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
    /// 10k photons, twice the default kernel, 2× subsampled.
    High,
    /// The most accurate single frame the sweep measured: 160k photons, twice the default
    /// kernel, full resolution.
    Reference,
}

impl Quality {
    /// The preset's knobs: points of the single-frame front of the sweeps of the four bundled
    /// scenes of ordinary content taken together, picked by `docs/tools/presets.py`
    /// (docs/accuracy.md §5.3: geometric means over the scenes of the frame time and of the
    /// relMSE over each scene's best,
    /// 160×120, lavapipe with the tiled gather, idle, 2026-11-26). The sweep re-run on
    /// 2026-11-27 (the references that resolve caustics, the fine photons at full resolution)
    /// makes the same rule pick 40k photons at N 4 for `high` and 160k at N 4 for
    /// `reference`; not adopted: with them the default 4-second render's error fell (relMSE
    /// 0.0096 → 0.0087 on cornell-box) but its diffuse walls and ceilings showed darker,
    /// higher-contrast blotches than with these (docs/accuracy.md §5.3). Bounces are not a knob:
    /// Russian roulette ends the paths ([`DEFAULT_BOUNCES`] is only the safety cap).
    /// Accumulated frames are not either: `render` accumulates any preset for its `--seconds`
    /// or `--frames`, and the sweep measured four frames of 10k photons at full resolution
    /// beating every single frame (473.2 ms, 1.33×).
    pub fn preset(self) -> Preset {
        let (photons, radius_scale, subsample) = match self {
            // The fastest point of the front (92.2 ms, 2.06× the best error).
            Quality::Draft => (10_000, 1.0, 4),
            // 99.1 ms, 1.78×.
            Quality::Interactive => (10_000, 2.0, 4),
            // 118.8 ms, 1.59×.
            Quality::High => (10_000, 2.0, 2),
            // The most accurate single frame measured: 898.8 ms, 1.35×.
            Quality::Reference => (160_000, 2.0, 1),
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
/// default size (cornell-box, 640×480, lavapipe, 2 cores, `--seconds 4`) it accumulated 4
/// frames in 8.0 s of wall time, where the flags' own defaults (100k photons, radius ×1, no
/// subsampling) took 18.1 s for 3 frames with a visibly grainier ceiling and back wall, for about
/// the same error after a 4×4 box filter (relMSE 0.0098 against 0.0089; docs/accuracy.md §7,
/// "The defaults").
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
