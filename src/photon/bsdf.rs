//! The über-BSDF (paper §6, G3D's SuperBSDF), built from a [`Material`]; its GLSL twin is
//! `glsl/common/bsdf.glsl`, formula for formula and name for name.
//!
//! # Conventions
//! `wo` and `wi` are unit world directions pointing *away* from the surface: `wo` towards where
//! the light goes (the eye, or where a photon came from), `wi` the sampled other direction (the
//! photon's next direction). `n_s` is the shading normal, `n_g` the geometric normal, any side.
//! Both are flipped to `wo`'s side of the **geometric** normal; that side also decides the
//! relative index of refraction: `wo` on the front (`wo·n_g > 0`) means entering the material,
//! η = ior, else leaving it, η = 1/ior. Degenerate input (zero, non-finite, `wo` exactly tangent
//! to `n_g`, `wo` below or within `BSDF_MIN_COS` = 10⁻⁷ of the shading hemisphere's horizon)
//! gives 0 or `None`, never NaN.
//!
//! # Lobes, with their reflectances c (RGB) and shapes g (∫ g cos dω ≤ 1)
//! - **Lambertian** `c_L/π`, sampled by cosine-weighted hemisphere sampling.
//! - **Glossy**, normalised Blinn–Phong in the Ashikhmin–Shirley form, energy-compensated:
//!   `c_S · D(h) / (4 (wi·h) max(cos θo, cos θi) E(σ, cos θo))` with `D(h) = (σ+1)/(2π)·cosσ θh`
//!   the pdf of the half vector. Substituting `dωi = 4 (wi·h) dωh` gives the uncompensated
//!   shape's directional albedo `E(σ, μo) = ∫ D(h) cos θi / max(μo, cos θi) dωh ≤ 1`, which
//!   loses much of the light of a rough lobe (half vectors that reflect `wo` below the horizon,
//!   and the max): 0.14 at σ = 0 and normal incidence, 0.45 at grazing, about 0.5 at grazing
//!   for any σ. **Glossy energy compensation** (issue #19) divides by E, tabulated in
//!   `glsl/common/glossy_albedo.glsl` ([`glossy_albedo`](mod@glossy_albedo)), so the lobe reflects exactly c_S at
//!   every angle (to the table's ±0.5 %): a white glossy room conserves energy like a white
//!   Lambertian one. The estimator `f cos/pdf = c_S cos θi / (max(cos θo, cos θi) E) ≤ c_S/E`
//!   stays bounded (E > 0.13). Like the Fresnel weights below, E depends on `wo` alone, so the
//!   lobe is not reciprocal (the photon tracer takes the photon's incident direction as `wo`);
//!   σ → ∞ tends to the mirror.
//! - **Mirror** (σ = ∞) and **refraction** (Snell, η as above): delta lobes with weight `c`.
//!   Under total internal reflection the refraction lobe reflects (its energy goes to the mirror
//!   direction, `eta` = 1). Refracted photons carry power, so no 1/η² radiance scaling is applied.
//!
//! # Fresnel
//! With `material.fresnel`, `S = (F(cos θo, η) − F0)/(1 − F0)` is the exact unpolarised
//! dielectric Fresnel reflectance renormalised to 0 at normal incidence and 1 at grazing / TIR
//! (`F0 = ((η−1)/(η+1))²`). The reflectances become `c_S = ρS + (1 − ρS)·S`,
//! `c_L = ρL·(1 − S)`, `c_T = ρt·(1 − S)`, so `c_L + c_S + c_T ≤ 1` still holds, ρS stays the
//! reflectance at normal incidence, and ρS = F0, ρt = 1 − F0 is exactly a smooth dielectric. S
//! uses the shading normal (not the half vector), so the lobe weights depend on `wo` alone and
//! the photon tracer can play Russian roulette before sampling. On a rough surface S is scaled
//! by `1 − r` ([`fresnel_ramp_share`], r the perceptual roughness of σ), as Lagarde's
//! roughness-aware Schlick does: the microfacets of a rough surface see little Fresnel gain at
//! grazing angles, and with the full ramp a grey rough glTF dielectric reflected up to 0.88
//! at grazing where glTF's BRDF reflects 0.53 (issue #19; `tests/physics_gltf_brdf.rs`).
//! Without Fresnel, c = ρ.
//! [`Bsdf::new`] scales ρL + ρS + ρt down to ≤ 1 per channel if a texture pushed it over, and
//! clamps a finite σ to `GLOSSY_EXPONENT_MAX` = 10⁶ (a 0.1°-wide lobe), which keeps f finite in
//! `f32` at grazing angles; σ = ∞ is the mirror.
//!
//! # Sampling
//! [`Bsdf::sample`] (path tracing) picks a lobe with probability ∝ [`Bsdf::albedo_weights`]
//! (the mean RGB of each c) and returns the mixture estimator `f cos/pdf` for the non-delta
//! lobes. [`Bsdf::sample_russian_roulette`] (photon tracing, paper §5) survives with probability
//! Σ weights, picks lobe j with probability `w_j`, and returns the power multiplier
//! `c_j ⊙ (g_j cos/pdf_j) / w_j` — "ρ/p per channel". Shading normals are used without Veach's
//! adjoint correction.

#[cfg(test)]
mod chi_square;
pub mod glossy_albedo;
mod lobes;
#[cfg(test)]
mod tests;

use glossy_albedo::glossy_albedo;
pub use lobes::{bounce_albedo, BsdfVariant, MaterialLobes};

use super::sampling::{
    blinn_phong_half_vector, blinn_phong_half_vector_pdf, cosine_hemisphere, cosine_hemisphere_pdf,
    Frame,
};
use crate::layout::shared_constants::{
    BSDF_MIN_COS, BSDF_MIN_LENGTH_SQUARED, GLOSSY_EXPONENT_MAX, PATH_DENSITY_GLOSSY_DIVISOR,
    PATH_DENSITY_LAMBERTIAN_DIVISOR, PI,
};
use crate::scene::Material;
use glam::Vec3;

/// The lobe a sample took; `as usize` indexes [`Bsdf::albedo_weights`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Lobe {
    Lambertian = 0,
    Glossy = 1,
    Mirror = 2,
    Refraction = 3,
}

impl Lobe {
    pub const ALL: [Lobe; 4] = [
        Lobe::Lambertian,
        Lobe::Glossy,
        Lobe::Mirror,
        Lobe::Refraction,
    ];

    /// Mirror and refraction are Dirac deltas: `eval`/`pdf` never see them.
    pub fn is_delta(self) -> bool {
        matches!(self, Lobe::Mirror | Lobe::Refraction)
    }
}

/// One sampled direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// Unit world direction, away from the surface.
    pub wi: Vec3,
    /// The estimator's multiplier per channel: `f·cos θi/pdf` (non-delta), or the delta weight.
    pub weight: Vec3,
    /// Solid-angle pdf (non-delta lobes), or the discrete probability of a delta lobe.
    pub pdf: f32,
    pub lobe: Lobe,
    /// Relative index of refraction crossed (η_transmitted/η_incident); 1 when reflected.
    pub eta: f32,
    /// Factor by which this bounce multiplies the path density ρp, see [`path_density_factor`].
    pub path_density_factor: f32,
}

/// BSDF parameters of one shading point, sanitised from a [`Material`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bsdf {
    /// ρL (texture-modulated when an override is given).
    pub lambertian: Vec3,
    /// ρS at normal incidence.
    pub glossy: Vec3,
    /// σ in [0, `GLOSSY_EXPONENT_MAX`] (10⁶), or `f32::INFINITY` for a perfect mirror.
    pub exponent: f32,
    /// The material's own σ, which sets the share of the Fresnel ramp
    /// ([`fresnel_ramp_share`]): `exponent` but in a [`Bsdf::regularized`] lobe, whose shape is
    /// blurred while its split between the lobes stays the material's.
    pub fresnel_exponent: f32,
    /// ρt.
    pub transmission: Vec3,
    /// η of the interior, finite and > 0.
    pub ior: f32,
    pub fresnel: bool,
}

/// `wo` and the normals of one query, oriented to `wo`'s side.
#[derive(Clone, Copy, Debug)]
struct Oriented {
    wo: Vec3,
    frame: Frame,
    ng: Vec3,
    cos_o: f32,
    eta: f32,
}

/// A BSDF with its outgoing direction fixed ([`Bsdf::towards`]).
pub struct Towards<'a> {
    bsdf: &'a Bsdf,
    o: Oriented,
    c: [Vec3; 4],
    c_mean: [f32; 4],
}

impl Towards<'_> {
    /// [`Bsdf::eval`] at this `wo` and normals, the same bits.
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        let f = (|| {
            let wi = unit(wi)?;
            let cos_i = Bsdf::reflected_cos(&self.o, wi)?;
            Some(
                self.bsdf
                    .eval_and_pdf_oriented(&self.o, &self.c, &self.c_mean, wi, cos_i)
                    .0,
            )
        })()
        .unwrap_or(Vec3::ZERO);
        debug_assert!(f.is_finite() && f.min_element() >= 0.0, "eval = {f}");
        f
    }
}

fn mean(v: Vec3) -> f32 {
    (v.x + v.y + v.z) * (1.0 / 3.0)
}

/// `v` normalised; `None` when it is too short or not finite. A vector already unit to within
/// rounding (|v|² within [`UNIT_LENGTH_SQUARED_TOLERANCE`] of 1, as `normalize` leaves it) is
/// returned as it is: dividing it by its length would change only its last bits, and the photon
/// tracer, whose directions and hit normals all come normalised, spent four square roots and
/// twelve divisions per bounce on it (`docs/performance.md`, "CPU photon tracing"). The GLSL
/// twin `bsdf_unit` divides always (cheap on a GPU); the two agree to within that rounding.
fn unit(v: Vec3) -> Option<Vec3> {
    let l2 = v.length_squared();
    if (l2 - 1.0).abs() <= UNIT_LENGTH_SQUARED_TOLERANCE {
        return Some(v);
    }
    (l2.is_finite() && l2 >= BSDF_MIN_LENGTH_SQUARED).then(|| v / l2.sqrt())
}

/// How far from 1 the squared length of a vector `unit` leaves as it is may be: four units in
/// the last place of 1 (|v| within 2.4·10⁻⁷ of 1), above the ≈ 3 that rounding leaves in the
/// squared length of a normalised `f32` vector.
const UNIT_LENGTH_SQUARED_TOLERANCE: f32 = 4.0 * f32::EPSILON;

fn sanitize_reflectance(v: Vec3) -> Vec3 {
    Vec3::from_array(
        v.to_array()
            .map(|c| if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) }),
    )
}

/// Exact unpolarised Fresnel reflectance of a dielectric interface for `cos_i` on the incident
/// side and relative index `eta` = η_t/η_i. 1 under total internal reflection and at exactly
/// grazing incidence (η ≠ 1); 0 for η = 1. Never NaN for finite `eta > 0`.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    if (eta - 1.0).abs() < 1e-6 {
        return 0.0;
    }
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    (0.5 * (r_parallel * r_parallel + r_perpendicular * r_perpendicular)).clamp(0.0, 1.0)
}

/// Fresnel reflectance renormalised to 0 at normal incidence and 1 at grazing/TIR (see the
/// module docs).
pub fn fresnel_ramp(cos_i: f32, eta: f32) -> f32 {
    let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
    ((fresnel_dielectric(cos_i, eta) - f0) / (1.0 - f0)).clamp(0.0, 1.0)
}

/// How much of the Fresnel ramp a lobe of Blinn–Phong exponent `exponent` keeps: `1 − r`,
/// with `r = (2/(σ + 2))^¼` the glTF perceptual roughness of σ (`α² = 2/(σ + 2)`, `r = √α`;
/// `scene/gltf_material.rs`). 1 for a mirror (σ = ∞), 0 at σ = 0. The Fresnel ramp is taken on
/// the shading normal (module docs); on a rough surface the microfacets' half vectors see a
/// much smaller Fresnel gain at grazing angles (glTF's `F(V·H)`), so the ramp is scaled as in
/// Lagarde's roughness-aware Schlick, `F0 + (max(1 − r, F0) − F0)(1 − cos θ)⁵`.
pub fn fresnel_ramp_share(exponent: f32) -> f32 {
    if exponent.is_nan() || exponent <= 0.0 {
        return 0.0;
    }
    1.0 - (2.0 / (exponent + 2.0)).powf(0.25)
}

/// The paper's ad hoc path-density factor of one bounce through `lobe` whose (Fresnel-weighted)
/// reflectance is `reflectance`: mean(ρ)/1000 for Lambertian, mean(ρ)/10 for glossy, mean(ρ)
/// for mirror and refraction (ρ: the mean of the RGB reflectance; for refraction ρt).
pub fn path_density_factor(lobe: Lobe, reflectance: Vec3) -> f32 {
    let rho = mean(reflectance);
    match lobe {
        Lobe::Lambertian => rho / PATH_DENSITY_LAMBERTIAN_DIVISOR,
        Lobe::Glossy => rho / PATH_DENSITY_GLOSSY_DIVISOR,
        Lobe::Mirror | Lobe::Refraction => rho,
    }
}

fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

impl Bsdf {
    /// The BSDF of `material`; `lambertian_override` replaces ρL (the texture-modulated value at
    /// the shading point).
    pub fn new(material: &Material, lambertian_override: Option<Vec3>) -> Self {
        let mut lambertian =
            sanitize_reflectance(lambertian_override.unwrap_or(material.lambertian));
        let mut glossy = sanitize_reflectance(material.glossy);
        let mut transmission = sanitize_reflectance(material.transmission);
        let total = lambertian + glossy + transmission;
        let scale = Vec3::ONE / total.max(Vec3::ONE);
        lambertian *= scale;
        glossy *= scale;
        transmission *= scale;
        let exponent = match material.exponent {
            e if e.is_nan() => 0.0,
            e if e.is_infinite() && e > 0.0 => f32::INFINITY,
            e => e.clamp(0.0, GLOSSY_EXPONENT_MAX),
        };
        let ior = if material.ior.is_finite() && material.ior > 0.0 {
            material.ior
        } else {
            1.0
        };
        Self {
            lambertian,
            glossy,
            exponent,
            fresnel_exponent: exponent,
            transmission,
            ior,
            fresnel: material.fresnel,
        }
    }

    fn is_mirror(&self) -> bool {
        self.exponent.is_infinite()
    }

    #[inline(always)]
    fn orient(&self, wo: Vec3, n_s: Vec3, n_g: Vec3) -> Option<Oriented> {
        let (wo, mut ns, mut ng) = (unit(wo)?, unit(n_s)?, unit(n_g)?);
        let cos_g = wo.dot(ng);
        if cos_g == 0.0 || !cos_g.is_finite() {
            return None;
        }
        let entering = cos_g > 0.0;
        if !entering {
            ns = -ns;
            ng = -ng;
        }
        let cos_o = wo.dot(ns);
        (cos_o >= BSDF_MIN_COS).then(|| Oriented {
            wo,
            frame: Frame::from_normal(ns),
            ng,
            cos_o: cos_o.min(1.0),
            eta: if entering { self.ior } else { 1.0 / self.ior },
        })
    }

    /// Fresnel-weighted reflectance c of each lobe, indexed by [`Lobe`].
    fn lobe_reflectances(&self, o: &Oriented) -> [Vec3; 4] {
        self.variant_reflectances::<true, true>(o)
    }

    /// [`Self::lobe_reflectances`] in the variant `GLOSSY`, `DELTA` ([`BsdfVariant`]): a lobe
    /// compiled out has c = 0, as in `glsl/common/bsdf.glsl`'s `bsdf_lobe_reflectances`.
    #[inline(always)]
    fn variant_reflectances<const GLOSSY: bool, const DELTA: bool>(
        &self,
        o: &Oriented,
    ) -> [Vec3; 4] {
        let s = if self.fresnel {
            fresnel_ramp(o.cos_o, o.eta) * fresnel_ramp_share(self.fresnel_exponent)
        } else {
            0.0
        };
        let specular = self.glossy + (Vec3::ONE - self.glossy) * s;
        let (glossy, mirror) = if self.is_mirror() {
            (Vec3::ZERO, specular)
        } else {
            (specular, Vec3::ZERO)
        };
        [
            self.lambertian * (1.0 - s),
            if GLOSSY { glossy } else { Vec3::ZERO },
            if DELTA { mirror } else { Vec3::ZERO },
            if DELTA {
                self.transmission * (1.0 - s)
            } else {
                Vec3::ZERO
            },
        ]
    }

    /// Mean RGB reflectance of each lobe at `wo`, indexed by [`Lobe`]; the sum is ≤ 1 and is
    /// the photon's survival probability under Russian roulette. Zeros for degenerate input.
    pub fn albedo_weights(&self, wo: Vec3, n_s: Vec3, n_g: Vec3) -> [f32; 4] {
        self.orient(wo, n_s, n_g)
            .map_or([0.0; 4], |o| self.lobe_reflectances(&o).map(mean))
    }

    /// Is `wi` (unit) on the reflection side of both normals (and not within `BSDF_MIN_COS` of
    /// tangent)? Returns cos θi if so.
    fn reflected_cos(o: &Oriented, wi: Vec3) -> Option<f32> {
        let cos_i = wi.dot(o.frame.n);
        (cos_i >= BSDF_MIN_COS && wi.dot(o.ng) > 0.0).then_some(cos_i.min(1.0))
    }

    /// Glossy shape g (without c) and the pdf of sampling `wi` from the glossy lobe alone.
    fn glossy_shape_and_pdf(&self, o: &Oriented, wi: Vec3, cos_i: f32) -> (f32, f32) {
        let Some(h) = unit(o.wo + wi) else {
            return (0.0, 0.0);
        };
        let wo_h = o.wo.dot(h);
        if wo_h <= 0.0 {
            return (0.0, 0.0);
        }
        let d = blinn_phong_half_vector_pdf(h.dot(o.frame.n), self.exponent);
        let e = glossy_albedo(self.exponent, o.cos_o);
        (d / (4.0 * wo_h * o.cos_o.max(cos_i) * e), d / (4.0 * wo_h))
    }

    /// f (non-delta lobes) and the mixture pdf of `wi`, sharing the glossy lobe's evaluation.
    fn eval_and_pdf_oriented(
        &self,
        o: &Oriented,
        c: &[Vec3; 4],
        w: &[f32; 4],
        wi: Vec3,
        cos_i: f32,
    ) -> (Vec3, f32) {
        let total: f32 = w.iter().sum();
        if total <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let mut f = c[Lobe::Lambertian as usize] * (1.0 / PI);
        let mut pdf = w[Lobe::Lambertian as usize] * cosine_hemisphere_pdf(cos_i);
        if w[Lobe::Glossy as usize] > 0.0 {
            let (shape, glossy_pdf) = self.glossy_shape_and_pdf(o, wi, cos_i);
            f += c[Lobe::Glossy as usize] * shape;
            pdf += w[Lobe::Glossy as usize] * glossy_pdf;
        }
        (f, pdf / total)
    }

    /// The BSDF with its glossy lobe's shape widened to an exponent of at most `max_exponent`
    /// (mirrors and glass, `+∞`, stay delta lobes), its split between the lobes (the Fresnel
    /// share, [`Bsdf::fresnel_exponent`]) kept: the lobe a photon density estimate evaluates
    /// (`photon::kernel`, "Glossy lobes in the estimate"; GLSL twin `bsdf_regularized`).
    pub fn regularized(self, max_exponent: f32) -> Self {
        if self.exponent.is_finite() && self.exponent > max_exponent {
            Self {
                exponent: max_exponent.max(0.0),
                ..self
            }
        } else {
            self
        }
    }

    /// f(wo, wi) of the non-delta lobes (Lambertian + glossy), without the cosine.
    pub fn eval(&self, wo: Vec3, wi: Vec3, n_s: Vec3, n_g: Vec3) -> Vec3 {
        self.towards(wo, n_s, n_g)
            .map_or(Vec3::ZERO, |towards| towards.eval(wi))
    }

    /// [`Bsdf::eval`] for one `wo` and many `wi` (a photon gather): what depends only on `wo`
    /// and the normals (the orientation, the lobes' weights) once. `None` where `eval` is 0 for
    /// every `wi` (a degenerate `wo` or normal).
    pub fn towards(&self, wo: Vec3, n_s: Vec3, n_g: Vec3) -> Option<Towards<'_>> {
        let o = self.orient(wo, n_s, n_g)?;
        let c = self.lobe_reflectances(&o);
        Some(Towards {
            bsdf: self,
            o,
            c,
            c_mean: c.map(mean),
        })
    }

    /// Solid-angle pdf with which [`Bsdf::sample`] returns `wi` through a non-delta lobe,
    /// including the lobe-selection probability.
    pub fn pdf(&self, wo: Vec3, wi: Vec3, n_s: Vec3, n_g: Vec3) -> f32 {
        let pdf = (|| {
            let o = self.orient(wo, n_s, n_g)?;
            let wi = unit(wi)?;
            let cos_i = Self::reflected_cos(&o, wi)?;
            let c = self.lobe_reflectances(&o);
            Some(
                self.eval_and_pdf_oriented(&o, &c, &c.map(mean), wi, cos_i)
                    .1,
            )
        })()
        .unwrap_or(0.0);
        debug_assert!(pdf.is_finite() && pdf >= 0.0, "pdf = {pdf}");
        pdf
    }

    /// Samples the direction of `lobe` alone; returns the direction and the η crossed (for
    /// refraction; 1 otherwise and under TIR). `None` for a lobe the variant `GLOSSY`, `DELTA`
    /// compiles out: its code is not in the function.
    #[inline(always)]
    fn sample_direction<const GLOSSY: bool, const DELTA: bool>(
        &self,
        lobe: Lobe,
        o: &Oriented,
        u: [f32; 2],
    ) -> Option<(Vec3, f32)> {
        let wi = match lobe {
            Lobe::Lambertian => o.frame.to_world(cosine_hemisphere(u)),
            Lobe::Glossy if GLOSSY => {
                let h = o.frame.to_world(blinn_phong_half_vector(u, self.exponent));
                let wo_h = o.wo.dot(h);
                if wo_h <= 0.0 {
                    return None;
                }
                2.0 * wo_h * h - o.wo
            }
            Lobe::Mirror if DELTA => reflect(o.wo, o.frame.n),
            Lobe::Refraction if DELTA => {
                if o.eta == 1.0 {
                    return Some((-o.wo, 1.0));
                }
                let sin2_t = (1.0 - o.cos_o * o.cos_o) / (o.eta * o.eta);
                if sin2_t >= 1.0 {
                    let wi = reflect(o.wo, o.frame.n);
                    return (wi.dot(o.ng) > 0.0).then_some((wi, 1.0));
                }
                let cos_t = (1.0 - sin2_t).sqrt();
                let wi = unit(-o.wo / o.eta + (o.cos_o / o.eta - cos_t) * o.frame.n)?;
                return (wi.dot(o.ng) < 0.0).then_some((wi, o.eta));
            }
            _ => return None,
        };
        let wi = unit(wi)?;
        Self::reflected_cos(o, wi)?;
        Some((wi, 1.0))
    }

    /// Samples `lobe` alone: `weight = c ⊙ g cos/pdf_lobe` (delta: `c`), `pdf` of the lobe alone
    /// (delta: 1). `None` when the lobe has no energy here or the sample leaves the valid side.
    pub fn sample_lobe(
        &self,
        lobe: Lobe,
        wo: Vec3,
        n_s: Vec3,
        n_g: Vec3,
        u: [f32; 2],
    ) -> Option<BsdfSample> {
        let o = self.orient(wo, n_s, n_g)?;
        let c = self.lobe_reflectances(&o)[lobe as usize];
        self.sample_oriented::<true, true>(lobe, &o, c, u)
    }

    /// [`Self::sample_lobe`] at an oriented `wo`, with the lobe's reflectance `c` given, in the
    /// variant `GLOSSY`, `DELTA`.
    #[inline(always)]
    fn sample_oriented<const GLOSSY: bool, const DELTA: bool>(
        &self,
        lobe: Lobe,
        o: &Oriented,
        c: Vec3,
        u: [f32; 2],
    ) -> Option<BsdfSample> {
        if mean(c) <= 0.0 {
            return None;
        }
        let (wi, eta) = self.sample_direction::<GLOSSY, DELTA>(lobe, o, u)?;
        let (weight, pdf) = match lobe {
            Lobe::Lambertian => (c, cosine_hemisphere_pdf(wi.dot(o.frame.n))),
            Lobe::Glossy => {
                let cos_i = wi.dot(o.frame.n).min(1.0);
                let pdf = self.glossy_shape_and_pdf(o, wi, cos_i).1;
                let e = glossy_albedo(self.exponent, o.cos_o);
                (c * (cos_i / (o.cos_o.max(cos_i) * e)), pdf)
            }
            Lobe::Mirror | Lobe::Refraction => (c, 1.0),
        };
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        let s = BsdfSample {
            wi,
            weight,
            pdf,
            lobe,
            eta,
            path_density_factor: path_density_factor(lobe, c),
        };
        debug_assert_sample(&s);
        Some(s)
    }

    /// Path-tracer sampling: lobe ∝ [`Bsdf::albedo_weights`] with `u[0]`, direction with
    /// `u[1..]`; `weight = f cos/pdf` over all non-delta lobes (delta: `c/p`).
    pub fn sample(&self, wo: Vec3, n_s: Vec3, n_g: Vec3, u: [f32; 3]) -> Option<BsdfSample> {
        let o = self.orient(wo, n_s, n_g)?;
        let c = self.lobe_reflectances(&o);
        let w = c.map(mean);
        let total: f32 = w.iter().sum();
        if total <= 0.0 {
            return None;
        }
        let lobe = choose_lobe(&w, u[0] * total);
        let (wi, eta) = self.sample_direction::<true, true>(lobe, &o, [u[1], u[2]])?;
        let s = if lobe.is_delta() {
            let p = w[lobe as usize] / total;
            BsdfSample {
                wi,
                weight: c[lobe as usize] / p,
                pdf: p,
                lobe,
                eta,
                path_density_factor: path_density_factor(lobe, c[lobe as usize]),
            }
        } else {
            let cos_i = wi.dot(o.frame.n).min(1.0);
            let (f, pdf) = self.eval_and_pdf_oriented(&o, &c, &w, wi, cos_i);
            if !(pdf > 0.0 && pdf.is_finite()) {
                return None;
            }
            BsdfSample {
                wi,
                weight: f * (cos_i / pdf),
                pdf,
                lobe,
                eta,
                path_density_factor: path_density_factor(lobe, c[lobe as usize]),
            }
        };
        debug_assert_sample(&s);
        Some(s)
    }

    /// Photon scattering with the paper's Russian roulette: absorbed (`None`) when
    /// `u[0] ≥ Σ albedo_weights`; otherwise lobe j is taken with probability `w_j` and `weight`
    /// is the power multiplier `c_j ⊙ (g_j cos/pdf_j) / w_j`; `pdf` includes `w_j`.
    pub fn sample_russian_roulette(
        &self,
        wo: Vec3,
        n_s: Vec3,
        n_g: Vec3,
        u: [f32; 3],
    ) -> Option<BsdfSample> {
        self.sample_russian_roulette_in::<true, true>(wo, n_s, n_g, u)
    }

    /// [`Self::sample_russian_roulette`] in the variant `GLOSSY`, `DELTA` ([`BsdfVariant`]),
    /// the photon tracer's specialisation: a lobe compiled out has c = 0 (so it neither adds to
    /// the survival probability nor is ever picked) and its sampling code is not in the
    /// function. For a material without that lobe the result is the same, bit for bit.
    pub fn sample_russian_roulette_in<const GLOSSY: bool, const DELTA: bool>(
        &self,
        wo: Vec3,
        n_s: Vec3,
        n_g: Vec3,
        u: [f32; 3],
    ) -> Option<BsdfSample> {
        self.roulette::<GLOSSY, DELTA>(wo, n_s, n_g, u, None)
    }

    /// [`Self::sample_russian_roulette_in`] for a photon of power `power`: lobe j is taken with
    /// probability `w_j = P·c_j / ΣP` (the lobe's reflectance weighted by the photon's own
    /// colour) instead of the mean of `c_j`, so a surviving photon keeps the sum of its channels
    /// (`Σ_k P_k c_jk / w_j = ΣP`: exactly after a Lambertian or delta lobe, in expectation after
    /// the glossy one, whose `f·cos/pdf` varies about 1) and no channel grows bounce after
    /// bounce. With the
    /// mean, a photon reddened by a red wall gained `c_r / mean(c)` ≈ 2.5× in red at every red
    /// bounce: a few were ~100× brighter than the rest after some bounces, each a blotch the size
    /// of its kernel (`photon::trace`, "Bounces"). Both are unbiased; a zero or non-finite
    /// power falls back to the mean.
    pub fn sample_russian_roulette_for<const GLOSSY: bool, const DELTA: bool>(
        &self,
        power: Vec3,
        wo: Vec3,
        n_s: Vec3,
        n_g: Vec3,
        u: [f32; 3],
    ) -> Option<BsdfSample> {
        self.roulette::<GLOSSY, DELTA>(wo, n_s, n_g, u, Some(power))
    }

    /// [`Self::sample_russian_roulette_in`] (`power` `None`) and
    /// [`Self::sample_russian_roulette_for`]: orients `wo` and the normals, then plays the
    /// roulette over the lobes; a Lambertian-only BSDF plays its one lobe's roulette first
    /// ([`Self::roulette_lambertian`]).
    #[inline(always)]
    fn roulette<const GLOSSY: bool, const DELTA: bool>(
        &self,
        wo: Vec3,
        n_s: Vec3,
        n_g: Vec3,
        u: [f32; 3],
        power: Option<Vec3>,
    ) -> Option<BsdfSample> {
        if self.is_lambertian_only() {
            self.roulette_lambertian(wo, n_s, n_g, u, power)
        } else {
            let o = self.orient(wo, n_s, n_g)?;
            self.roulette_lobes::<GLOSSY, DELTA>(&o, u, power)
        }
    }

    /// True when the Lambertian lobe is the only one: no glossy, mirror or refraction
    /// reflectance and no Fresnel ramp, so that [`Self::variant_reflectances`] is
    /// `[ρL, 0, 0, 0]` in every variant. Most surfaces of a room are.
    #[inline(always)]
    fn is_lambertian_only(&self) -> bool {
        self.glossy == Vec3::ZERO && self.transmission == Vec3::ZERO && !self.fresnel
    }

    /// The roulette over the four lobes at an oriented `wo`, in the variant `GLOSSY`, `DELTA`.
    #[inline(always)]
    fn roulette_lobes<const GLOSSY: bool, const DELTA: bool>(
        &self,
        o: &Oriented,
        u: [f32; 3],
        power: Option<Vec3>,
    ) -> Option<BsdfSample> {
        let c = self.variant_reflectances::<GLOSSY, DELTA>(o);
        let by = roulette_colour(power);
        let w = c.map(|cj| roulette_weight(cj, by));
        if u[0] >= w.iter().sum::<f32>() {
            return None;
        }
        let lobe = choose_lobe(&w, u[0]);
        let mut s =
            self.sample_oriented::<GLOSSY, DELTA>(lobe, o, c[lobe as usize], [u[1], u[2]])?;
        let p = w[lobe as usize];
        s.weight /= p;
        s.pdf *= p;
        debug_assert_sample(&s);
        Some(s)
    }

    /// [`Self::roulette`] of a Lambertian-only BSDF ([`Self::is_lambertian_only`]): the same
    /// operations on the one lobe that can be taken, the roulette before `orient` (its weight
    /// does not depend on the directions, and a failure of either gives `None`), so the same
    /// sample bit for bit
    /// (`lambertian_roulette_is_the_lobes_roulette_bit_for_bit`), without the three empty
    /// lobes' reflectances, weights and choice. The photon tracer spends most of its bounces
    /// here (`docs/performance.md`, "CPU photon tracing").
    #[inline(always)]
    fn roulette_lambertian(
        &self,
        wo: Vec3,
        n_s: Vec3,
        n_g: Vec3,
        u: [f32; 3],
        power: Option<Vec3>,
    ) -> Option<BsdfSample> {
        let c = self.lambertian;
        let w = roulette_weight(c, roulette_colour(power));
        // The one lobe's weight does not depend on the directions, so the roulette is played
        // before orienting: an absorbed photon (None either way) skips the unit checks and the
        // frame.
        if u[0] >= w {
            return None;
        }
        let o = self.orient(wo, n_s, n_g)?;
        let mut s = self.sample_oriented::<false, false>(Lobe::Lambertian, &o, c, [u[1], u[2]])?;
        s.weight /= w;
        s.pdf *= w;
        debug_assert_sample(&s);
        Some(s)
    }
}

/// The photon power a roulette weighs the lobes by: `power` when it is finite, non-negative and
/// not zero; `None` (weigh by the mean) otherwise ([`Bsdf::sample_russian_roulette_for`]).
#[inline(always)]
fn roulette_colour(power: Option<Vec3>) -> Option<Vec3> {
    power.filter(|p| p.is_finite() && p.min_element() >= 0.0 && p.element_sum() > 0.0)
}

/// A lobe of reflectance `c`'s share of the roulette: `P·c / ΣP` by the photon's colour `by`,
/// else the mean of `c`.
#[inline(always)]
fn roulette_weight(c: Vec3, by: Option<Vec3>) -> f32 {
    match by {
        Some(p) => c.dot(p) / p.element_sum(),
        None => mean(c),
    }
}

/// The lobe whose cumulative weight interval holds `x` (`0 ≤ x < Σ w`); never a zero-weight
/// lobe, even when rounding puts `x` at the end.
fn choose_lobe(w: &[f32; 4], x: f32) -> Lobe {
    let mut cumulative = 0.0;
    let mut last = Lobe::Lambertian;
    for lobe in Lobe::ALL {
        if w[lobe as usize] <= 0.0 {
            continue;
        }
        last = lobe;
        cumulative += w[lobe as usize];
        if x < cumulative {
            return lobe;
        }
    }
    last
}

fn debug_assert_sample(s: &BsdfSample) {
    debug_assert!(
        s.wi.is_finite() && (s.wi.length() - 1.0).abs() < 1e-3,
        "wi = {}",
        s.wi
    );
    debug_assert!(
        s.weight.is_finite() && s.weight.min_element() >= 0.0,
        "weight = {}",
        s.weight
    );
    debug_assert!(s.pdf.is_finite() && s.pdf > 0.0, "pdf = {}", s.pdf);
    debug_assert!(s.eta.is_finite() && s.eta > 0.0, "eta = {}", s.eta);
}
