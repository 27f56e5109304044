//! The directional albedo `E(σ, μo)` of the glossy lobe's shape (c_S = 1), for its energy
//! compensation (module docs of `photon::bsdf`, "Glossy energy compensation"). The function
//! lives in one file, `glsl/common/glossy_albedo.glsl` (written by
//! `docs/tools/glossy_albedo.py`): `log E` is a 2D Chebyshev series of degree 14 in
//! `x = 2 log₂(1 + σ)/(6 log₂10) − 1` (σ = 0 … 10⁶) and `y = 2√μo − 1`, fitted to a quadrature
//! table. The shaders include that file, and this module parses its coefficients, so the two
//! sides evaluate the same series in the same order ([`glossy_albedo`] is the twin of
//! `bsdf_glossy_albedo`).

use std::sync::OnceLock;

const SOURCE: &str = include_str!("../../../glsl/common/glossy_albedo.glsl");
/// Degree of the series in each variable, plus one.
pub const TERMS: usize = 15;
/// `6·log₂10`: the σ axis spans six decades.
pub const SIGMA_AXIS_LOG2_SPAN: f32 = 19.931_568;

/// The coefficients `a[i][j]` (of `T_i(x) T_j(y)`), parsed once from the GLSL file: the
/// literals of its calls `float rI = glossy_albedo_chebyshev(y, …);`, in order.
pub fn coefficients() -> &'static [[f32; TERMS]; TERMS] {
    static COEFFICIENTS: OnceLock<[[f32; TERMS]; TERMS]> = OnceLock::new();
    COEFFICIENTS.get_or_init(|| {
        let mut out = [[0.0; TERMS]; TERMS];
        for (i, row) in out.iter_mut().enumerate() {
            let call = format!("float r{i} = glossy_albedo_chebyshev(");
            let start = SOURCE.find(&call).expect("a row of the series") + call.len();
            let end = start + SOURCE[start..].find(");").expect("end of the row");
            let values: Vec<f32> = SOURCE[start..end]
                .split(',')
                .skip(1) // the variable y
                .map(|s| s.trim().parse().expect("a coefficient"))
                .collect();
            *row = values.try_into().expect("TERMS coefficients per row");
        }
        out
    })
}

/// `Σ_k c_k T_k(t)` by Clenshaw's recurrence (`glossy_albedo_chebyshev`).
fn chebyshev(t: f32, c: &[f32; TERMS]) -> f32 {
    let (mut b1, mut b2) = (0.0f32, 0.0f32);
    for k in (1..TERMS).rev() {
        let b = c[k] + 2.0 * t * b1 - b2;
        b2 = b1;
        b1 = b;
    }
    c[0] + t * b1 - b2
}

/// `E(σ, μo)` for a finite exponent σ ≥ 0 and `cos_o` in [0, 1]: in (0.13, 1].
pub fn glossy_albedo(exponent: f32, cos_o: f32) -> f32 {
    let x = (2.0 * (1.0 + exponent.max(0.0)).log2() / SIGMA_AXIS_LOG2_SPAN - 1.0).clamp(-1.0, 1.0);
    let y = 2.0 * cos_o.clamp(0.0, 1.0).sqrt() - 1.0;
    let a = coefficients();
    let rows: [f32; TERMS] = std::array::from_fn(|i| chebyshev(y, &a[i]));
    chebyshev(x, &rows).exp()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::bsdf::Bsdf;
    use crate::scene::Material;
    use glam::Vec3;

    /// The uncompensated shape's albedo by the midpoint rule over the lobe's sampling map, as
    /// the generator computes it (coarser).
    fn quadrature(sigma: f32, mu: f32) -> f32 {
        let (n1, n2) = (512, 256);
        let sin_o = (1.0 - mu * mu).sqrt();
        let mut sum = 0.0f64;
        for a in 0..n1 {
            let cos_h = ((a as f64 + 0.5) / n1 as f64).powf(1.0 / (f64::from(sigma) + 1.0));
            let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
            for b in 0..n2 {
                let phi = std::f64::consts::TAU * (b as f64 + 0.5) / n2 as f64;
                let wo_h = f64::from(sin_o) * sin_h * phi.cos() + f64::from(mu) * cos_h;
                let cos_i = 2.0 * wo_h * cos_h - f64::from(mu);
                if wo_h > 0.0 && cos_i >= 1e-7 {
                    sum += cos_i / f64::from(mu).max(cos_i);
                }
            }
        }
        (sum / (n1 * n2) as f64) as f32
    }

    #[test]
    fn the_glsl_file_declares_the_axis_and_every_row_read_here() {
        let decl =
            format!("const float GLOSSY_ALBEDO_SIGMA_AXIS_LOG2_SPAN = {SIGMA_AXIS_LOG2_SPAN};");
        assert!(SOURCE.contains(&decl), "glossy_albedo.glsl lacks `{decl}`");
        assert!((SIGMA_AXIS_LOG2_SPAN - 6.0 * 10f32.log2()).abs() < 1e-5);
        assert!(SOURCE.contains("float bsdf_glossy_albedo(float exponent, float cos_o)"));
        assert!(
            !SOURCE.contains(&format!("float r{TERMS} =")),
            "more rows than TERMS"
        );
        // The series' constant term is the mean of log E: some value in (log 0.13, 0).
        let a00 = coefficients()[0][0];
        assert!(a00 < 0.0 && a00 > 0.13f32.ln(), "{a00}");
    }

    /// Away from the fit's nodes: within 1 % (relative: the compensation divides by it; the
    /// generator measured 0.45 % at worst), and the value of the docs: 0.138 at σ = 0, μ = 1.
    #[test]
    fn glossy_albedo_matches_quadrature() {
        let mut worst = (0.0f32, 0.0, 0.0);
        for sigma in [0.0f32, 0.5, 3.0, 17.0, 80.0, 450.0, 3000.0, 6e4, 5e5] {
            for mu in [1.0f32, 0.83, 0.5, 0.21, 0.07, 0.012, 0.003] {
                let exact = quadrature(sigma, mu);
                let d = (glossy_albedo(sigma, mu) / exact - 1.0).abs();
                if d > worst.0 {
                    worst = (d, sigma, mu);
                }
            }
        }
        eprintln!(
            "largest table error {} at σ {} μ {}",
            worst.0, worst.1, worst.2
        );
        assert!(worst.0 < 0.01, "{worst:?}");
        assert!((glossy_albedo(0.0, 1.0) - 0.138).abs() < 1e-3);
    }

    /// The compensated lobe reflects c_S at every angle and roughness (white furnace).
    #[test]
    fn compensated_glossy_lobe_reflects_its_reflectance() {
        let mut rng = crate::photon::rng::Rng::new(19);
        for sigma in [0.0f32, 2.0, 30.0, 500.0, 2e4] {
            let bsdf = Bsdf::new(
                &Material {
                    lambertian: Vec3::ZERO,
                    glossy: Vec3::ONE,
                    exponent: sigma,
                    ..Material::default()
                },
                None,
            );
            for mu in [1.0f32, 0.6, 0.25, 0.05, 0.02] {
                let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                let n = 40_000;
                let sum: f64 = (0..n)
                    .filter_map(|_| bsdf.sample(wo, Vec3::Z, Vec3::Z, rng.next_3()))
                    .map(|s| f64::from(s.weight.x))
                    .sum();
                let albedo = sum / f64::from(n);
                assert!(
                    (albedo - 1.0).abs() < 0.015,
                    "σ {sigma}, μ {mu}: albedo {albedo}"
                );
            }
        }
    }
}
