//! Warps from the unit square to directions, with their pdfs, and a local shading frame.
//!
//! Every function has a twin of the same name in `glsl/common/bsdf.glsl`. Local directions are
//! expressed in a [`Frame`] whose `n` is +z.

use crate::layout::shared_constants::PI;
use glam::{Vec2, Vec3};

/// An orthonormal basis `(t, b, n)` around a unit normal `n` (right-handed: `t × b = n`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// The branchless basis of Duff et al., "Building an Orthonormal Basis, Revisited" (JCGT
    /// 2017). `n` must be unit length. The sign test is `n.z >= 0` (as in GLSL, which has no
    /// `copysign`), so `-0.0` counts as positive; both choices are valid.
    pub fn from_normal(n: Vec3) -> Self {
        let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Self {
            t: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            b: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }

    /// World → local (n becomes +z).
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    /// Local → world.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// Shirley–Chiu concentric map from [0,1)² to the unit disk (area-preserving up to a
/// constant: pdf = 1/π on the disk).
pub fn concentric_disk(u: [f32; 2]) -> Vec2 {
    let o = Vec2::new(2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, (PI / 4.0) * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - (PI / 4.0) * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted direction in the local upper hemisphere (Malley's method);
/// pdf = [`cosine_hemisphere_pdf`].
pub fn cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Solid-angle pdf of [`cosine_hemisphere`] for a local direction with `cos_theta = z`.
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) / PI
}

/// Half vector for the normalised Blinn–Phong lobe: density ∝ cosᵉθh over the local upper
/// hemisphere, pdf = [`blinn_phong_half_vector_pdf`]. Safe for `exponent` = 0 and 1e30.
pub fn blinn_phong_half_vector(u: [f32; 2], exponent: f32) -> Vec3 {
    let cos_theta = u[0].powf(1.0 / (exponent + 1.0)).min(1.0);
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
}

/// Solid-angle pdf of [`blinn_phong_half_vector`]: (e+1)/(2π)·cosᵉθh, zero below the horizon.
#[inline]
pub fn blinn_phong_half_vector_pdf(cos_theta_h: f32, exponent: f32) -> f32 {
    if cos_theta_h <= 0.0 {
        return 0.0;
    }
    (exponent + 1.0) / (2.0 * PI) * cos_theta_h.min(1.0).powf(exponent)
}

/// Uniform direction on the unit sphere; pdf = 1/(4π).
pub fn uniform_sphere(u: [f32; 2]) -> Vec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::rng::Rng;

    #[test]
    fn duff_frame_is_orthonormal_for_axis_and_near_pole_normals() {
        let normals = [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            -Vec3::X,
            -Vec3::Y,
            -Vec3::Z,
            Vec3::new(1.0, 0.0, -0.0),
            Vec3::new(1e-7, 0.0, -1.0).normalize(),
            Vec3::new(1e-4, -1e-4, -1.0).normalize(),
            Vec3::new(0.3, -0.4, 0.5).normalize(),
        ];
        for n in normals {
            let f = Frame::from_normal(n);
            for v in [f.t, f.b] {
                assert!((v.length() - 1.0).abs() < 1e-5, "{n}: {v}");
                assert!(v.dot(n).abs() < 1e-5);
            }
            assert!(f.t.dot(f.b).abs() < 1e-5);
            assert!(f.t.cross(f.b).distance(n) < 1e-5, "right-handed for {n}");
            let w = Vec3::new(0.2, -0.7, 0.1);
            assert!(f.to_world(f.to_local(w)).distance(w) < 1e-5);
        }
    }

    #[test]
    fn concentric_disk_stays_in_the_disk_and_covers_it_uniformly() {
        let mut rng = Rng::new(5);
        let mut inner = 0;
        let n = 200_000;
        for _ in 0..n {
            let d = concentric_disk(rng.next_2());
            assert!(d.length() <= 1.0 + 1e-6);
            inner += usize::from(d.length() < 0.5);
        }
        // Area fraction of the radius-½ disk is ¼.
        assert!((inner as f64 / n as f64 - 0.25).abs() < 0.005);
        assert_eq!(concentric_disk([0.5, 0.5]), Vec2::ZERO);
    }

    #[test]
    fn warped_directions_are_unit_and_their_pdfs_integrate_to_one() {
        let mut rng = Rng::new(9);
        for _ in 0..10_000 {
            let u = rng.next_2();
            for w in [
                cosine_hemisphere(u),
                blinn_phong_half_vector(u, 0.0),
                blinn_phong_half_vector(u, 50.0),
                blinn_phong_half_vector(u, 1e30),
                uniform_sphere(u),
            ] {
                assert!(w.is_finite() && (w.length() - 1.0).abs() < 1e-5);
            }
            assert!(cosine_hemisphere(u).z >= 0.0);
        }
        // Midpoint quadrature in cos θ: ∫ pdf dω = 2π ∫₀¹ pdf(μ) dμ.
        let n = 100_000;
        for e in [0.0, 1.0, 10.0, 100.0] {
            let mut s = 0.0f64;
            let mut c = 0.0f64;
            for i in 0..n {
                let mu = (i as f32 + 0.5) / n as f32;
                s += f64::from(blinn_phong_half_vector_pdf(mu, e));
                c += f64::from(cosine_hemisphere_pdf(mu));
            }
            let scale = 2.0 * std::f64::consts::PI / f64::from(n);
            assert!(
                (s * scale - 1.0).abs() < 1e-3,
                "exponent {e}: {}",
                s * scale
            );
            assert!((c * scale - 1.0).abs() < 1e-3);
        }
    }
}
