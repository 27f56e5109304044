//! The kernel schedule of progressive accumulation (probabilistic progressive photon mapping,
//! Knaus & Zwicker 2011): frame `i` of an accumulation (0-based) draws an independent photon
//! map and estimates with kernels of area `r²ᵢ = r²₀ · Πₖ₌₁..ᵢ (k + α)/(k + 1)`. The area shrinks
//! as `i^(α−1)` (bias → 0) while the photons per kernel of one frame fall more slowly than the
//! frames add up (the mean's variance → 0), so the mean of the frames converges to the true
//! radiance. The CPU reference `progressive` shrinks its global radius by the same rule
//! (`reference::gather::progressive_radius`).

/// α of the schedule: the share of a kernel's area each frame keeps, asymptotically. Knaus and
/// Zwicker's and the reference's 2/3 (`reference::RefSettings::alpha`).
pub const ALPHA: f32 = 2.0 / 3.0;

/// `rᵢ / r₀` of frame `frame` of an accumulation (1 for its first frame, 0).
pub fn progressive_scale(frame: u32) -> f32 {
    let mut r2 = 1.0f64;
    for k in 1..=frame {
        r2 *= (f64::from(k) + f64::from(ALPHA)) / (f64::from(k) + 1.0);
    }
    r2.sqrt() as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_frame_keeps_its_kernels_and_later_ones_shrink_as_frame_to_the_alpha_minus_one() {
        assert_eq!(progressive_scale(0), 1.0);
        assert!(progressive_scale(1) < 1.0);
        for i in 1..64 {
            assert!(progressive_scale(i + 1) < progressive_scale(i));
        }
        // r² ∝ i^(α−1) asymptotically: doubling the frames scales r² by 2^(α−1).
        let (a, b) = (progressive_scale(512), progressive_scale(1024));
        let ratio = f64::from(b * b / (a * a));
        assert!(
            (ratio - 2f64.powf(f64::from(ALPHA) - 1.0)).abs() < 1e-3,
            "{ratio}"
        );
    }

    #[test]
    fn it_matches_the_progressive_references_radius() {
        for i in [0, 1, 5, 40] {
            let r = crate::reference::gather::progressive_radius(0.3, ALPHA, i);
            assert!((r - 0.3 * progressive_scale(i)).abs() < 1e-6, "{i}");
        }
    }
}
