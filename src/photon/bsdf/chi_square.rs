//! Chi-square goodness of fit of a direction sampler against its pdf, as pbrt-v4 does it
//! (`src/pbrt/bsdfs_test.cpp`): 80×160 bins in (θ, φ) over the sphere, expected counts from the
//! pdf integrated per bin, cells expected < 5 pooled, Šidák-corrected significance.

use glam::Vec3;
use std::f64::consts::PI;

pub const THETA_BINS: usize = 80;
pub const PHI_BINS: usize = 160;
pub const MIN_EXPECTED: f64 = 5.0;
/// Simpson sub-intervals per bin and axis for the pdf integral.
const SUBDIVISIONS: usize = 4;

/// Bin of a unit direction given in the local frame (+z is the normal).
pub fn bin_of(w: Vec3) -> usize {
    let theta = f64::from(w.z).clamp(-1.0, 1.0).acos();
    let mut phi = f64::from(w.y).atan2(f64::from(w.x));
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let i = ((theta / PI * THETA_BINS as f64) as usize).min(THETA_BINS - 1);
    let j = ((phi / (2.0 * PI) * PHI_BINS as f64) as usize).min(PHI_BINS - 1);
    i * PHI_BINS + j
}

/// Observed counts of `samples` directions (local frame); `None` samples are not counted.
pub fn histogram(samples: impl Iterator<Item = Option<Vec3>>) -> Vec<f64> {
    let mut counts = vec![0.0; THETA_BINS * PHI_BINS];
    for w in samples.flatten() {
        counts[bin_of(w)] += 1.0;
    }
    counts
}

/// Expected counts: `sample_count` × ∫ pdf dω over each bin, by 2D composite Simpson in (θ, φ)
/// with the sin θ Jacobian, refined per bin until Simpson on n and n/2 intervals agree (pbrt
/// uses adaptive Simpson too: near grazing, lobes are very narrow in φ). Bin edges are nudged
/// inwards so that a pdf discontinuous at a bin edge (the horizon, θ = π/2, is one) is
/// integrated from the inside.
pub fn expected_counts(pdf: impl Fn(Vec3) -> f32, sample_count: usize) -> Vec<f64> {
    let mut out = vec![0.0; THETA_BINS * PHI_BINS];
    for i in 0..THETA_BINS {
        for j in 0..PHI_BINS {
            let mut n = SUBDIVISIONS;
            let mut grid = bin_grid(&pdf, i, j, n);
            let mut fine = simpson(&grid, n, 1);
            let mut coarse = simpson(&grid, n, 2);
            while (fine - coarse).abs() / 15.0 > 1e-4 * fine.abs() + 1e-3 / sample_count as f64
                && n < MAX_SUBDIVISIONS
            {
                n *= 2;
                grid = bin_grid(&pdf, i, j, n);
                coarse = fine;
                fine = simpson(&grid, n, 1);
            }
            out[i * PHI_BINS + j] = fine * sample_count as f64;
        }
    }
    out
}

const MAX_SUBDIVISIONS: usize = 512;

/// `pdf · sin θ` on an (n+1)² grid over bin (i, j), row-major in θ.
fn bin_grid(pdf: &impl Fn(Vec3) -> f32, i: usize, j: usize, n: usize) -> Vec<f64> {
    let d_theta = PI / THETA_BINS as f64;
    let d_phi = 2.0 * PI / PHI_BINS as f64;
    // 1e-5 of a bin (4e-7 rad) clears the BSDF's own tangent cut-off (cos θ < 1e-7).
    let nudge = 1e-5;
    let mut grid = Vec::with_capacity((n + 1) * (n + 1));
    for k in 0..=n {
        let t = (k as f64 / n as f64).clamp(nudge, 1.0 - nudge);
        let (st, ct) = ((i as f64 + t) * d_theta).sin_cos();
        for l in 0..=n {
            let (sp, cp) = ((j as f64 + l as f64 / n as f64) * d_phi).sin_cos();
            let w = Vec3::new((st * cp) as f32, (st * sp) as f32, ct as f32);
            grid.push(f64::from(pdf(w)) * st);
        }
    }
    grid
}

/// Composite 2D Simpson over the bin from an (n+1)² grid, using every `stride`-th point.
fn simpson(grid: &[f64], n: usize, stride: usize) -> f64 {
    let m = n / stride;
    let weight = |k: usize| -> f64 {
        if k == 0 || k == m {
            1.0
        } else if k % 2 == 1 {
            4.0
        } else {
            2.0
        }
    };
    let mut sum = 0.0;
    for a in 0..=m {
        for b in 0..=m {
            sum += weight(a) * weight(b) * grid[a * stride * (n + 1) + b * stride];
        }
    }
    let d_theta = PI / THETA_BINS as f64;
    let d_phi = 2.0 * PI / PHI_BINS as f64;
    sum * (d_theta / m as f64) * (d_phi / m as f64) / 9.0
}

/// pbrt's test: `Ok(p-value)` when the counts are consistent with the expectation at
/// significance `alpha` Šidák-corrected over `test_count` tests, else `Err(why)`.
pub fn chi_square_test(
    observed: &[f64],
    expected: &[f64],
    sample_count: usize,
    alpha: f64,
    test_count: usize,
) -> Result<f64, String> {
    let mut order: Vec<usize> = (0..observed.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pooled_obs, mut pooled_exp) = (0.0, 0.0);
    let (mut chi2, mut dof) = (0.0, 0i64);
    for &c in &order {
        let (obs, exp) = (observed[c], expected[c]);
        if exp <= 0.0 {
            if obs > sample_count as f64 * 1e-5 {
                return Err(format!(
                    "{obs} samples in cell {c}, where none are expected"
                ));
            }
        } else if exp < MIN_EXPECTED || (pooled_exp > 0.0 && pooled_exp < MIN_EXPECTED) {
            pooled_obs += obs;
            pooled_exp += exp;
        } else {
            chi2 += (obs - exp).powi(2) / exp;
            dof += 1;
        }
    }
    if pooled_exp > 0.0 || pooled_obs > 0.0 {
        chi2 += (pooled_obs - pooled_exp).powi(2) / pooled_exp;
        dof += 1;
    }
    dof -= 1;
    if dof < 1 {
        return Err(format!("too few degrees of freedom ({dof})"));
    }
    let p_value = chi_square_survival(chi2, dof as f64);
    let corrected = 1.0 - (1.0 - alpha).powf(1.0 / test_count as f64);
    if p_value.is_finite() && p_value >= corrected {
        Ok(p_value)
    } else {
        Err(format!(
            "chi² = {chi2:.1} with {dof} dof: p = {p_value:.3e} < {corrected:.3e}"
        ))
    }
}

/// P(X > x) for X ~ χ²(dof): the regularised upper incomplete gamma Q(dof/2, x/2).
pub fn chi_square_survival(x: f64, dof: f64) -> f64 {
    gamma_q(dof / 2.0, x / 2.0)
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, n = 9; relative error ~1e-15).
fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, &c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma Q(a, x): series for x < a + 1, else Lentz's continued
/// fraction (Numerical Recipes §6.2).
fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let prefactor = (-x + a * x.ln() - ln_gamma(a)).exp();
    if x < a + 1.0 {
        let (mut ap, mut del) = (a, 1.0 / a);
        let mut sum = del;
        for _ in 0..100_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        1.0 - sum * prefactor
    } else {
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..100_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        h * prefactor
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi_square_survival_matches_tabulated_quantiles() {
        // (x, dof, P(X > x)) from standard χ² tables.
        let table = [
            (3.841_459, 1.0, 0.05),
            (6.634_897, 1.0, 0.01),
            (18.307_04, 10.0, 0.05),
            (23.209_25, 10.0, 0.01),
            (124.342_1, 100.0, 0.05),
            (1_074.679, 1000.0, 0.05),
            (10_000.0, 10_000.0, 0.498_119_4),
        ];
        for (x, dof, p) in table {
            let got = chi_square_survival(x, dof);
            assert!(
                (got - p).abs() < 1e-4 * p.max(0.01),
                "Q({x}, {dof}) = {got}, not {p}"
            );
        }
        assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-12);
        assert!((ln_gamma(10.0) - 362_880f64.ln()).abs() < 1e-10);
    }
}
