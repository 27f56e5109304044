//! Image error measures and the error–time Pareto front (`ispm sweep`, the accuracy tests, the
//! goldens). No Vulkan.
//!
//! - [`rel_mse`]: relative mean squared error on linear HDR radiance,
//!   `mean over pixels p and channels c ∈ {R,G,B} of (a_pc − r_pc)² / (r_pc² + ε)`,
//!   ε = [`REL_MSE_EPSILON`] (docs/accuracy.md, "The error measure"). The one definition every
//!   test and the sweep use.
//! - [`flip`]: the mean of NVIDIA's FLIP error map (LDR FLIP, `nv-flip`, which compiles the
//!   reference C++ implementation) between the two images tonemapped by [`tonemap_srgb8`], the
//!   CPU twin of the GPU tonemap's default operator (Khronos PBR Neutral, then sRGB): 0 for
//!   identical images, at most 1.
//! - [`pareto_front`]: the (time, error) points no other point beats in both.
//!
//! Images are RGBA f32, row-major (alpha ignored), as `FrameImage::hdr` and
//! `PhotonFrame::read_indirect` return them; [`rgba`] widens an RGB reference.

/// ε of [`rel_mse`]: keeps black pixels from dominating (radiances here are ~0.01…10).
pub const REL_MSE_EPSILON: f64 = 1e-2;

/// relMSE of `actual` against `reference` (both RGBA f32; alpha ignored). Panics when the
/// lengths differ (a caller's bug, never input).
pub fn rel_mse(actual: &[f32], reference: &[f32]) -> f64 {
    rel_mse_masked(actual, reference, |_| true)
}

/// [`rel_mse`] over the pixels (indices in row-major order) that `keep` selects; 0 when none is.
pub fn rel_mse_masked(actual: &[f32], reference: &[f32], keep: impl Fn(usize) -> bool) -> f64 {
    assert_eq!(actual.len(), reference.len(), "image sizes differ");
    let mut sum = 0.0f64;
    let mut n = 0usize;
    for (i, (a, r)) in actual
        .chunks_exact(4)
        .zip(reference.chunks_exact(4))
        .enumerate()
    {
        if !keep(i) {
            continue;
        }
        for c in 0..3 {
            let (a, r) = (f64::from(a[c]), f64::from(r[c]));
            sum += (a - r).powi(2) / (r * r + REL_MSE_EPSILON);
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

/// An RGB image as RGBA (alpha 1).
pub fn rgba(rgb: &[[f32; 3]]) -> Vec<f32> {
    rgb.iter().flat_map(|p| [p[0], p[1], p[2], 1.0]).collect()
}

/// `a − b` per RGB channel (alpha 1): the indirect part of an image whose direct part is `b`.
pub fn difference(a: &[f32], b: &[f32]) -> Vec<f32> {
    assert_eq!(a.len(), b.len(), "image sizes differ");
    a.chunks_exact(4)
        .zip(b.chunks_exact(4))
        .flat_map(|(a, b)| [a[0] - b[0], a[1] - b[1], a[2] - b[2], 1.0])
        .collect()
}

/// Khronos PBR Neutral (`glsl/common/tonemap.glsl::pbr_neutral`, formula for formula).
fn pbr_neutral(mut c: [f32; 3]) -> [f32; 3] {
    const START_COMPRESSION: f32 = 0.8 - 0.04;
    const DESATURATION: f32 = 0.15;
    let x = c[0].min(c[1]).min(c[2]);
    let offset = if x < 0.08 { x - 6.25 * x * x } else { 0.04 };
    c = c.map(|v| v - offset);
    let peak = c[0].max(c[1]).max(c[2]);
    if peak < START_COMPRESSION {
        return c;
    }
    let d = 1.0 - START_COMPRESSION;
    let new_peak = 1.0 - d * d / (peak + d - START_COMPRESSION);
    c = c.map(|v| v * new_peak / peak);
    let g = 1.0 - 1.0 / (DESATURATION * (peak - new_peak) + 1.0);
    c.map(|v| v + (new_peak - v) * g)
}

/// The sRGB transfer function of `glsl/common/tonemap.glsl::srgb_encode`.
fn srgb_encode(linear: f32) -> f32 {
    let c = linear.clamp(0.0, 1.0);
    if c < 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Linear HDR RGBA → 8-bit sRGB RGB through PBR Neutral at exposure 0 (the renderer's default
/// display transform), on the CPU, so a reference and a render are tonemapped alike.
pub fn tonemap_srgb8(hdr: &[f32]) -> Vec<u8> {
    hdr.chunks_exact(4)
        .flat_map(|p| {
            let c = pbr_neutral([p[0], p[1], p[2]].map(|v| if v > 0.0 { v } else { 0.0 }));
            c.map(|v| (srgb_encode(v) * 255.0).round() as u8)
        })
        .collect()
}

/// Mean LDR FLIP error of `actual` against `reference` (both linear HDR RGBA, `width`×`height`),
/// tonemapped by [`tonemap_srgb8`], at FLIP's default 67 pixels per degree.
pub fn flip(actual: &[f32], reference: &[f32], width: u32, height: u32) -> f64 {
    let n = width as usize * height as usize * 4;
    assert!(
        actual.len() == n && reference.len() == n,
        "image sizes differ from {width}x{height}"
    );
    let image = |hdr: &[f32]| nv_flip::FlipImageRgb8::with_data(width, height, &tonemap_srgb8(hdr));
    let map = nv_flip::flip(
        image(reference),
        image(actual),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    f64::from(nv_flip::FlipPool::from_image(&map).mean())
}

/// True when `a` dominates `b`: no worse in both coordinates and better in one.
pub fn dominates(a: (f64, f64), b: (f64, f64)) -> bool {
    a.0 <= b.0 && a.1 <= b.1 && (a.0 < b.0 || a.1 < b.1)
}

/// Indices of the points (time, error) that no other point dominates, by increasing time.
/// Of points equal in both coordinates the first is kept. Points with a NaN coordinate are
/// never on the front.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len())
        .filter(|&i| !points[i].0.is_nan() && !points[i].1.is_nan())
        .collect();
    // By time, then error, then index: a point can only be dominated by one before it.
    order.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
            .then(a.cmp(&b))
    });
    let mut front = Vec::new();
    let mut best_error = f64::INFINITY;
    for i in order {
        if points[i].1 < best_error {
            best_error = points[i].1;
            front.push(i);
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic image with radiances over ~0 … 4.
    fn image(width: u32, height: u32) -> Vec<f32> {
        (0..width * height)
            .flat_map(|i| {
                let x = (i % width) as f32 / width as f32;
                let y = (i / width) as f32 / height as f32;
                [4.0 * x * y, x, (1.0 - y) * 0.5, 1.0]
            })
            .collect()
    }

    #[test]
    fn rel_mse_of_an_image_against_itself_is_zero() {
        let a = image(16, 8);
        assert_eq!(rel_mse(&a, &a), 0.0);
    }

    #[test]
    fn rel_mse_of_a_relative_perturbation_is_the_analytic_value() {
        // a = r·(1 + δ) with constant r: every term is δ²r²/(r² + ε).
        for (r, delta) in [(1.0f32, 0.1f32), (0.05, -0.3), (3.0, 0.01)] {
            let reference: Vec<f32> = [r, r, r, 1.0].repeat(64);
            let actual: Vec<f32> = reference.iter().map(|v| v * (1.0 + delta)).collect();
            let (r, delta) = (f64::from(r), f64::from(delta));
            let expected = delta * delta * r * r / (r * r + REL_MSE_EPSILON);
            let got = rel_mse(&actual, &reference);
            assert!(
                ((got - expected) / expected).abs() < 1e-5,
                "r {r}, δ {delta}: {got} vs {expected}"
            );
        }
    }

    #[test]
    fn flip_of_identical_images_is_zero_and_of_different_ones_is_not() {
        let a = image(32, 32);
        assert_eq!(flip(&a, &a, 32, 32), 0.0);
        let b: Vec<f32> = a.iter().map(|v| v * 0.5).collect();
        let e = flip(&b, &a, 32, 32);
        assert!(e > 0.01 && e <= 1.0, "FLIP of a half-bright image: {e}");
    }

    #[test]
    fn cpu_tonemap_matches_the_shader_formula_at_known_points() {
        // Below the compression threshold PBR Neutral only subtracts the toe offset; black is 0
        // and very bright white approaches 1.
        assert_eq!(tonemap_srgb8(&[0.0, 0.0, 0.0, 1.0]), vec![0, 0, 0]);
        assert_eq!(tonemap_srgb8(&[1e6, 1e6, 1e6, 1.0]), vec![255, 255, 255]);
        let mid = 0.5f32 - 0.04;
        let expected = (srgb_encode(mid) * 255.0).round() as u8;
        assert_eq!(tonemap_srgb8(&[0.5, 0.5, 0.5, 1.0]), vec![expected; 3]);
    }

    /// A small deterministic generator (xorshift64*), so the property test needs no crate.
    struct Xorshift(u64);
    impl Xorshift {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn pareto_front_is_non_dominated_and_dominates_every_excluded_point() {
        for seed in 1..=500u64 {
            let mut rng = Xorshift(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
            let n = 1 + (rng.next() * 40.0) as usize;
            // Coarse values on some seeds, so ties in time, error or both occur.
            let coarse = seed % 3 == 0;
            let mut value = || {
                let v = rng.next() * 10.0;
                if coarse {
                    v.round()
                } else {
                    v
                }
            };
            let points: Vec<(f64, f64)> = (0..n).map(|_| (value(), value())).collect();
            let front = pareto_front(&points);
            assert!(!front.is_empty(), "seed {seed}: empty front");
            for &i in &front {
                for (j, &p) in points.iter().enumerate() {
                    assert!(
                        !dominates(p, points[i]),
                        "seed {seed}: front point {i} {:?} dominated by {j} {p:?}",
                        points[i]
                    );
                }
            }
            for (j, &p) in points.iter().enumerate() {
                if front.contains(&j) {
                    continue;
                }
                assert!(
                    front
                        .iter()
                        .any(|&i| dominates(points[i], p) || points[i] == p),
                    "seed {seed}: excluded point {j} {p:?} is not dominated by the front"
                );
            }
            assert!(
                front.windows(2).all(|w| points[w[0]].0 <= points[w[1]].0),
                "seed {seed}: front not ordered by time"
            );
        }
    }
}
