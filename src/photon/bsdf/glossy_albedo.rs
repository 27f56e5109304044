//! The directional albedo `E(σ, μo)` of the glossy lobe's shape (c_S = 1), for its energy
//! compensation (module docs of `photon::bsdf`, "Glossy energy compensation"). The table lives
//! in one file, `glsl/common/glossy_albedo.glsl` (written by `docs/tools/glossy_albedo.py`),
//! which the shaders include and this module parses, so the two sides read the same numbers;
//! [`glossy_albedo`] interpolates it exactly as `bsdf_glossy_albedo` in `bsdf.glsl` does:
//! bilinearly in `u = log₂(1 + σ)/(6·log₂10)` (σ = 0 … 10⁶) and `v = √μo`.

use std::sync::OnceLock;

const SOURCE: &str = include_str!("../../../glsl/common/glossy_albedo.glsl");
/// Rows of the table (σ steps), as `GLOSSY_ALBEDO_SIGMA_STEPS` in the GLSL file.
pub const SIGMA_STEPS: usize = 49;
/// Columns of the table (μo steps), as `GLOSSY_ALBEDO_MU_STEPS`.
pub const MU_STEPS: usize = 49;
/// `6·log₂10`: the σ axis spans six decades.
pub const SIGMA_AXIS_LOG2_SPAN: f32 = 19.931_568;

/// The table, parsed once from the GLSL file: `SIGMA_STEPS` rows of `MU_STEPS` entries.
pub fn table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let start = SOURCE.find("float[](").expect("GLOSSY_ALBEDO array") + "float[](".len();
        let end = start + SOURCE[start..].find(");").expect("end of GLOSSY_ALBEDO");
        let values: Vec<f32> = SOURCE[start..end]
            .split(',')
            .map(|s| s.trim().parse().expect("a number in GLOSSY_ALBEDO"))
            .collect();
        assert_eq!(values.len(), SIGMA_STEPS * MU_STEPS, "GLOSSY_ALBEDO size");
        values
    })
}

/// Lower grid index and fraction of `x` in `[0, steps − 1]`.
fn cell(x: f32, steps: usize) -> (usize, f32) {
    let x = x.clamp(0.0, (steps - 1) as f32);
    let i = (x.floor() as usize).min(steps - 2);
    (i, x - i as f32)
}

/// `E(σ, μo)` for a finite exponent σ ≥ 0 and `cos_o` in [0, 1]: in (0.13, 1].
pub fn glossy_albedo(exponent: f32, cos_o: f32) -> f32 {
    let u = (1.0 + exponent.max(0.0)).log2() / SIGMA_AXIS_LOG2_SPAN * (SIGMA_STEPS - 1) as f32;
    let v = cos_o.clamp(0.0, 1.0).sqrt() * (MU_STEPS - 1) as f32;
    let (i, fu) = cell(u, SIGMA_STEPS);
    let (j, fv) = cell(v, MU_STEPS);
    let t = table();
    let at = |i: usize, j: usize| t[i * MU_STEPS + j];
    let lo = at(i, j) + (at(i, j + 1) - at(i, j)) * fv;
    let hi = at(i + 1, j) + (at(i + 1, j + 1) - at(i + 1, j)) * fv;
    lo + (hi - lo) * fu
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
    fn the_glsl_file_declares_the_sizes_and_axis_read_here() {
        for decl in [
            format!("const int GLOSSY_ALBEDO_SIGMA_STEPS = {SIGMA_STEPS};"),
            format!("const int GLOSSY_ALBEDO_MU_STEPS = {MU_STEPS};"),
            format!("const float GLOSSY_ALBEDO_SIGMA_AXIS_LOG2_SPAN = {SIGMA_AXIS_LOG2_SPAN};"),
        ] {
            assert!(SOURCE.contains(&decl), "glossy_albedo.glsl lacks `{decl}`");
        }
        assert!((SIGMA_AXIS_LOG2_SPAN - 6.0 * 10f32.log2()).abs() < 1e-5);
        assert_eq!(table().len(), SIGMA_STEPS * MU_STEPS);
    }

    /// Between the grid's nodes too (where interpolation errs most): within 1 % (relative: the
    /// compensation divides by it; the largest, 0.6 %, is at σ ≈ 0.5 where E climbs fastest),
    /// and the value of the docs: 0.138 at σ = 0, μ = 1.
    #[test]
    fn glossy_albedo_table_matches_quadrature() {
        let mut worst = (0.0f32, 0.0, 0.0);
        for sigma in [0.0f32, 0.5, 3.0, 17.0, 80.0, 450.0, 3000.0, 6e4] {
            for mu in [1.0f32, 0.83, 0.5, 0.21, 0.07, 0.012] {
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
