//! The radiance estimate at two subsample factors (`ispm bench --compare-subsample`).

use super::ConfigResult;
use crate::timing::pass_id::PassId;
use serde::Serialize;

/// The radiance estimate at two subsample factors, measured in the same alternating chunks
/// (`--compare-subsample`). The estimate is every GPU pass between the photon map and the
/// full-resolution indirect image, all of which run at the subsampled resolution except the
/// last: the density pass (`gpu.photon_tiles` or `gpu.photon_volumes`), the boundary
/// normalisation (`gpu.support`), the filter of the global photons' share (`gpu.denoise`, when
/// `--denoise` is on) and, when subsampled, `gpu.upsample` and the fine photons' full-resolution
/// estimate (`gpu.fine_photons`, where the scene makes caustic photons). Each is also given
/// alone; the
/// host's tile lists (`cpu.photon tiles`) are given apart, as they do not run on the GPU.
#[derive(Clone, Debug, Serialize)]
pub struct SubsampleSpeedup {
    /// The overlapped frame's factor (`--subsample`).
    pub base_factor: u32,
    /// The compared factor (`--compare-subsample`).
    pub factor: u32,
    /// Median ms per frame of the whole estimate at each factor.
    pub base_estimate_ms: f64,
    pub estimate_ms: f64,
    /// The estimate's passes at each factor.
    pub base_passes: EstimatePasses,
    pub passes: EstimatePasses,
    /// `base_estimate_ms ÷ estimate_ms`: how many times cheaper the estimate is at `factor`.
    pub estimate: f64,
    /// The density passes (the fine photons' included) and the upsample alone (without the
    /// support and the filter), base ÷ compared.
    pub density_and_upsample: f64,
    /// The density pass alone, base ÷ compared.
    pub density_pass: f64,
    /// Median ms per frame of the host's tile lists at each factor (0 for the volumes).
    pub base_binning_ms: f64,
    pub binning_ms: f64,
    /// Frame period, base ÷ compared.
    pub frame: f64,
}

/// Median ms per frame of each pass of the radiance estimate (0 where it did not run).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct EstimatePasses {
    pub density: f64,
    pub support: f64,
    pub denoise: f64,
    pub upsample: f64,
    /// The fine photons at full resolution (`gpu.fine_photons`).
    pub fine: f64,
}

impl EstimatePasses {
    fn of(c: &ConfigResult) -> Self {
        let median = |pass| c.median(pass).unwrap_or(0.0);
        Self {
            density: median(PassId::PhotonTiles) + median(PassId::PhotonVolumes),
            support: median(PassId::Support),
            denoise: median(PassId::Denoise),
            upsample: median(PassId::Upsample),
            fine: median(PassId::FinePhotons),
        }
    }

    fn total(&self) -> f64 {
        self.density + self.support + self.denoise + self.upsample + self.fine
    }
}

impl SubsampleSpeedup {
    pub(super) fn new(
        base: &ConfigResult,
        base_factor: u32,
        other: &ConfigResult,
        factor: u32,
    ) -> Self {
        let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
        let (b, o) = (EstimatePasses::of(base), EstimatePasses::of(other));
        let key = format!("cpu.{}", crate::passes::photon_tiles::lists::SPAN);
        let binning = |c: &ConfigResult| c.stages.get(&key).map_or(0.0, |t| t.median);
        Self {
            base_factor,
            factor,
            base_estimate_ms: b.total(),
            estimate_ms: o.total(),
            base_passes: b,
            passes: o,
            estimate: ratio(b.total(), o.total()),
            density_and_upsample: ratio(
                b.density + b.fine + b.upsample,
                o.density + o.fine + o.upsample,
            ),
            density_pass: ratio(b.density, o.density),
            base_binning_ms: binning(base),
            binning_ms: binning(other),
            frame: ratio(base.frame_ms, other.frame_ms),
        }
    }

    /// The line `ispm bench` prints.
    pub fn line(&self) -> String {
        let passes = |p: &EstimatePasses| {
            format!(
                "density {:.2} + support {:.2} + denoise {:.2} + upsample {:.2} + fine {:.2}",
                p.density, p.support, p.denoise, p.upsample, p.fine
            )
        };
        format!(
            "\nsubsample: estimate {:.2} ms at 1/{} ({}) against {:.2} ms at 1/{} ({}): \
             {:.3}x cheaper (density pass {:.3}x, density + upsample {:.3}x); host tile \
             lists {:.2} / {:.2} ms; frame {:.3}x\n",
            self.estimate_ms,
            self.factor,
            passes(&self.passes),
            self.base_estimate_ms,
            self.base_factor,
            passes(&self.base_passes),
            self.estimate,
            self.density_pass,
            self.density_and_upsample,
            self.binning_ms,
            self.base_binning_ms,
            self.frame,
        )
    }
}
