//! Which lobes of the über-BSDF a material can scatter into, and the shader variant that
//! compiles the unused optional lobes out (`glsl/common/bsdf.glsl`'s specialisation constants).
//!
//! A lobe is *present* when its reflectance c (module docs of `bsdf.rs`) is non-zero for some
//! `wo`. With Fresnel, `c_S = ρS + (1 − ρS)·S` and `S > 0` away from normal incidence whenever
//! η ≠ 1, so a Fresnel material has a specular lobe even with `ρS = 0`: a glossy one for a finite
//! exponent, a mirror for σ = ∞.

use super::{fresnel_ramp, fresnel_ramp_share, Bsdf};
use crate::layout::shared_constants::{SPEC_ID_DELTA_LOBES, SPEC_ID_GLOSSY_LOBE};
use crate::scene::Material;
use glam::Vec3;

/// The lobes of one material that can carry light (texture-independent: a texture only scales
/// the Lambertian reflectance down).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MaterialLobes {
    pub lambertian: bool,
    /// Glossy with a finite exponent.
    pub glossy: bool,
    /// Perfect mirror (σ = ∞).
    pub mirror: bool,
    pub refraction: bool,
}

impl MaterialLobes {
    /// The lobes of `material` after [`Bsdf::new`]'s sanitising.
    pub fn of(material: &Material) -> Self {
        let b = Bsdf::new(material, None);
        let specular = b.glossy.max_element() > 0.0 || (b.fresnel && b.ior != 1.0);
        Self {
            lambertian: b.lambertian.max_element() > 0.0,
            glossy: specular && b.exponent.is_finite(),
            mirror: specular && b.exponent.is_infinite(),
            refraction: b.transmission.max_element() > 0.0,
        }
    }

    /// A mirror or refraction lobe.
    pub fn delta(&self) -> bool {
        self.mirror || self.refraction
    }

    /// A lobe the eye can see photons through (photons are stored only on such surfaces).
    pub fn finite(&self) -> bool {
        self.lambertian || self.glossy
    }

    /// Any lobe at all: the material reflects or transmits some light.
    pub fn scatters(&self) -> bool {
        self.finite() || self.delta()
    }
}

/// An upper estimate of the power a photon keeps, per bounce, at a surface of `material`: the
/// largest RGB channel of `c_L + c_S + c_T`, averaged over incident directions with the cosine
/// weight of a diffuse radiance field (midpoint rule in cos² θ, 256 steps); for a
/// transmissive material, the larger of the two sides (inside, total internal reflection
/// returns everything). Without Fresnel it is `max(ρL + ρS + ρT)` exactly.
pub fn bounce_albedo(material: &Material) -> f32 {
    let b = Bsdf::new(material, None);
    let total = |s: f32| {
        b.lambertian * (1.0 - s)
            + b.glossy
            + (Vec3::ONE - b.glossy) * s
            + b.transmission * (1.0 - s)
    };
    if !b.fresnel {
        return total(0.0).max_element();
    }
    const STEPS: usize = 256;
    let side = |eta: f32| {
        let sum: Vec3 = (0..STEPS)
            .map(|i| {
                let cos = ((i as f32 + 0.5) / STEPS as f32).sqrt();
                total(fresnel_ramp(cos, eta) * fresnel_ramp_share(b.fresnel_exponent))
            })
            .sum();
        (sum / STEPS as f32).max_element()
    };
    let front = side(b.ior);
    if b.transmission.max_element() > 0.0 {
        front.max(side(1.0 / b.ior))
    } else {
        front
    }
}

/// The optional lobes compiled into the shaders that evaluate or sample the über-BSDF. A lobe
/// that is off has zero reflectance on the GPU; for a scene none of whose materials has that
/// lobe, the images are the same as with it on (`tests/effects.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct BsdfVariant {
    /// The finite-exponent glossy lobe.
    pub glossy: bool,
    /// The mirror and refraction lobes.
    pub delta: bool,
}

impl Default for BsdfVariant {
    fn default() -> Self {
        Self::ALL
    }
}

impl BsdfVariant {
    /// Every lobe compiled in (the shaders' defaults).
    pub const ALL: Self = Self {
        glossy: true,
        delta: true,
    };

    /// The smallest variant that renders every material of `lobes` exactly.
    pub fn covering<'a>(lobes: impl IntoIterator<Item = &'a MaterialLobes>) -> Self {
        lobes.into_iter().fold(
            Self {
                glossy: false,
                delta: false,
            },
            |v, l| Self {
                glossy: v.glossy || l.glossy,
                delta: v.delta || l.delta(),
            },
        )
    }

    /// `(specialisation-constant id, bool value)` of each lobe switch, ids from
    /// `shared_constants.rs`.
    pub fn constants(self) -> [(u32, bool); 2] {
        [
            (SPEC_ID_GLOSSY_LOBE, self.glossy),
            (SPEC_ID_DELTA_LOBES, self.delta),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn material(f: impl FnOnce(&mut Material)) -> Material {
        let mut m = Material {
            lambertian: Vec3::splat(0.5),
            ..Material::default()
        };
        f(&mut m);
        m
    }

    #[test]
    fn lobes_follow_the_reflectances_and_the_fresnel_ramp() {
        let diffuse = MaterialLobes::of(&material(|_| {}));
        assert_eq!(
            diffuse,
            MaterialLobes {
                lambertian: true,
                ..Default::default()
            }
        );
        let glossy = MaterialLobes::of(&material(|m| {
            m.glossy = Vec3::splat(0.2);
            m.exponent = 40.0;
        }));
        assert!(glossy.glossy && !glossy.delta());
        // Zero ρS but Fresnel and η ≠ 1: a specular lobe at grazing angles.
        let fresnel_rough = MaterialLobes::of(&material(|m| m.fresnel = true));
        assert!(fresnel_rough.glossy && !fresnel_rough.mirror);
        let fresnel_smooth = MaterialLobes::of(&material(|m| {
            m.fresnel = true;
            m.exponent = f32::INFINITY;
        }));
        assert!(fresnel_smooth.mirror && !fresnel_smooth.glossy);
        // η = 1: the Fresnel ramp is zero everywhere.
        let index_matched = MaterialLobes::of(&material(|m| {
            m.fresnel = true;
            m.ior = 1.0;
        }));
        assert!(!index_matched.glossy && !index_matched.mirror);
        let glass = MaterialLobes::of(&material(|m| m.transmission = Vec3::new(0.0, 0.1, 0.0)));
        assert!(glass.refraction && glass.delta());
        // NaN reflectances are sanitised to zero, as the BSDF does.
        let nan = MaterialLobes::of(&material(|m| {
            m.lambertian = Vec3::NAN;
            m.glossy = Vec3::NAN;
        }));
        assert!(!nan.scatters());
    }

    #[test]
    fn covering_variant_is_the_union_of_the_lobes() {
        let d = MaterialLobes {
            lambertian: true,
            ..Default::default()
        };
        let g = MaterialLobes {
            glossy: true,
            ..Default::default()
        };
        let m = MaterialLobes {
            mirror: true,
            ..Default::default()
        };
        let none = BsdfVariant::covering([&d]);
        assert!(!none.glossy && !none.delta);
        assert_eq!(
            BsdfVariant::covering([&d, &g]),
            BsdfVariant {
                glossy: true,
                delta: false
            }
        );
        assert_eq!(BsdfVariant::covering([&g, &m]), BsdfVariant::ALL);
        assert_eq!(
            BsdfVariant::ALL.constants(),
            [(SPEC_ID_GLOSSY_LOBE, true), (SPEC_ID_DELTA_LOBES, true)]
        );
    }

    #[test]
    fn bounce_albedo_is_the_reflectance_sum_or_its_fresnel_average() {
        let d = material(|m| m.lambertian = Vec3::new(0.2, 0.6, 0.1));
        assert!((bounce_albedo(&d) - 0.6).abs() < 1e-6);
        // Fresnel moves reflectance from the Lambertian lobe to the specular one: the sum grows
        // towards grazing, so the average lies between ρL and 1.
        // (A smooth lobe, σ = 100: a rough one keeps little of the ramp, fresnel_ramp_share.)
        let f = material(|m| {
            m.fresnel = true;
            m.exponent = 100.0;
        });
        let a = bounce_albedo(&f);
        assert!(a > 0.5 && a < 0.6, "{a}");
        // Glass seen from inside: total internal reflection keeps everything beyond the
        // critical angle, so the inside average exceeds the outside one.
        let glass = material(|m| {
            m.lambertian = Vec3::ZERO;
            m.transmission = Vec3::splat(0.9);
            m.exponent = f32::INFINITY;
            m.fresnel = true;
        });
        let g = bounce_albedo(&glass);
        assert!(g > 0.9 && g <= 1.0, "{g}");
    }
}
