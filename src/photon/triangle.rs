//! Watertight ray–triangle intersection (Woop, Benthin, Wald, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1), 2013), with pbrt-v4's two refinements:
//!
//! - when an edge function comes out exactly `0.0` in `f32`, all three are recomputed in `f64`
//!   (products of two `f32`s are exact there, so the sign is exact), which decides rays that
//!   pass exactly through an edge or a vertex consistently for every triangle sharing it;
//! - a hit is accepted only when its `t` exceeds a conservative bound on its rounding error,
//!   so a ray spawned from an offset origin ([`super::ray::offset_ray_origin`]) cannot re-hit
//!   the surface behind it.
//!
//! The ray is translated to the origin, its axes permuted so that the largest direction
//! component becomes z, and sheared so that the direction becomes +z; the triangle is then
//! tested in 2D with three edge functions. Adjacent triangles compute the edge function of
//! their shared edge from the same two transformed vertices with the operands swapped, which in
//! floating point gives exactly the negated value: no ray slips between them. Both faces are
//! hit; the caller decides which side was hit from the geometric normal.

use glam::{Vec3, Vec3A, Vec3Swizzles};

use super::ray::gamma;

/// Where a ray meets a triangle: `t` and barycentrics (`b0 + b1 + b2 = 1`, each in `[0, 1]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    pub t: f32,
    pub b0: f32,
    pub b1: f32,
    pub b2: f32,
}

/// A ray prepared for watertight intersection against many triangles: the per-ray
/// permutation and shear of Woop et al. are computed once.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    origin: Vec3,
    /// The permutation `(kx, ky, kz)` is a rotation of `(x, y, z)` (`kx = kz + 1`,
    /// `ky = kz + 2`, mod 3): `kz` picks one of three copies of the test, each with its
    /// permutation fixed at compile time (a branch per ray rather than per vertex component).
    kz: usize,
    shear_x: f32,
    shear_y: f32,
    shear_z: f32,
    valid: bool,
}

impl WatertightRay {
    /// Prepares `origin + t · dir`. A zero or non-finite `dir` never hits anything.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        let abs = dir.abs();
        let kz = if abs.x > abs.y {
            if abs.x > abs.z {
                0
            } else {
                2
            }
        } else if abs.y > abs.z {
            1
        } else {
            2
        };
        let kx = (kz + 1) % 3;
        let ky = (kx + 1) % 3;
        let dz = dir[kz];
        let valid = dz != 0.0 && dir.is_finite() && origin.is_finite();
        Self {
            origin,
            kz,
            shear_x: -dir[kx] / dz,
            shear_y: -dir[ky] / dz,
            shear_z: 1.0 / dz,
            valid,
        }
    }

    /// The hit with triangle `(p0, p1, p2)` with `0 < t < t_max`, if any. Degenerate
    /// (zero-area or collinear) triangles and rays in the triangle's plane never hit.
    #[inline]
    pub fn intersect(&self, p0: Vec3, p1: Vec3, p2: Vec3, t_max: f32) -> Option<TriangleHit> {
        if !self.valid {
            return None;
        }
        match self.kz {
            0 => self.intersect_permuted::<0>(p0, p1, p2, t_max),
            1 => self.intersect_permuted::<1>(p0, p1, p2, t_max),
            _ => self.intersect_permuted::<2>(p0, p1, p2, t_max),
        }
    }

    /// [`Self::intersect`] of the triangle whose vertices' x, y and z coordinates are `rows`
    /// ([`transpose`]): the same hit, bit for bit, with the three vertices in SIMD lanes.
    #[inline(always)]
    pub fn intersect_transposed(&self, rows: &[Vec3A; 3], t_max: f32) -> Option<TriangleHit> {
        if !self.valid {
            return None;
        }
        match self.kz {
            0 => self.intersect_rows::<0>(rows, t_max),
            1 => self.intersect_rows::<1>(rows, t_max),
            _ => self.intersect_rows::<2>(rows, t_max),
        }
    }

    /// [`Self::intersect`] for a valid ray whose dominant axis is `KZ`.
    #[inline(always)]
    fn intersect_permuted<const KZ: usize>(
        &self,
        p0: Vec3,
        p1: Vec3,
        p2: Vec3,
        t_max: f32,
    ) -> Option<TriangleHit> {
        // Translate to the ray origin, permute so the dominant direction axis is z.
        let permute = |p: Vec3| {
            let q = p - self.origin;
            match KZ {
                0 => Vec3::new(q.y, q.z, q.x),
                1 => Vec3::new(q.z, q.x, q.y),
                _ => q,
            }
        };
        let (mut a, mut b, mut c) = (permute(p0), permute(p1), permute(p2));
        // Shear x and y so the ray direction becomes +z (z is scaled later, only if needed).
        a.x += self.shear_x * a.z;
        a.y += self.shear_y * a.z;
        b.x += self.shear_x * b.z;
        b.y += self.shear_y * b.z;
        c.x += self.shear_x * c.z;
        c.y += self.shear_y * c.z;

        // Edge functions; e0 is opposite p0 and weighs it.
        let e0 = b.x * c.y - b.y * c.x;
        let e1 = c.x * a.y - c.y * a.x;
        let e2 = a.x * b.y - a.y * b.x;
        self.finish(a, b, c, [e0, e1, e2], t_max)
    }

    /// [`Self::intersect`] of the triangle whose vertices' x, y and z coordinates are `rows`
    /// (lane i: vertex i; [`transpose`]), for a valid ray whose dominant axis is `KZ`: the
    /// translation, shear and edge functions of the three vertices at once, the same operations
    /// as [`Self::intersect_permuted`]'s in the same order, so the same hit bit for bit.
    #[inline(always)]
    fn intersect_rows<const KZ: usize>(
        &self,
        rows: &[Vec3A; 3],
        t_max: f32,
    ) -> Option<TriangleHit> {
        let [x, y, z] = *rows;
        let o = self.origin;
        let ((px, ox), (py, oy), (pz, oz)) = match KZ {
            0 => ((y, o.y), (z, o.z), (x, o.x)),
            1 => ((z, o.z), (x, o.x), (y, o.y)),
            _ => ((x, o.x), (y, o.y), (z, o.z)),
        };
        // (a.z, b.z, c.z), then the sheared (a.x, b.x, c.x) and (a.y, b.y, c.y).
        let qz = pz - Vec3A::splat(oz);
        let sx = (px - Vec3A::splat(ox)) + Vec3A::splat(self.shear_x) * qz;
        let sy = (py - Vec3A::splat(oy)) + Vec3A::splat(self.shear_y) * qz;
        let e = sx.yzx() * sy.zxy() - sy.yzx() * sx.zxy();
        // The common miss, decided here; zeros and hits go on in `finish`.
        if !e.cmpeq(Vec3A::ZERO).any() && e.cmplt(Vec3A::ZERO).any() && e.cmpgt(Vec3A::ZERO).any() {
            return None;
        }
        let a = Vec3::new(sx.x, sy.x, qz.x);
        let b = Vec3::new(sx.y, sy.y, qz.y);
        let c = Vec3::new(sx.z, sy.z, qz.z);
        self.finish(a, b, c, e.to_array(), t_max)
    }

    /// The permuted, sheared vertices' test from their edge functions on: the exact recompute
    /// of zeros, the sign test, `t` and its error bound.
    #[inline(always)]
    fn finish(
        &self,
        mut a: Vec3,
        mut b: Vec3,
        mut c: Vec3,
        [mut e0, mut e1, mut e2]: [f32; 3],
        t_max: f32,
    ) -> Option<TriangleHit> {
        if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
            let dop = |px: f32, qy: f32, py: f32, qx: f32| {
                (f64::from(px) * f64::from(qy) - f64::from(py) * f64::from(qx)) as f32
            };
            e0 = dop(b.x, c.y, b.y, c.x);
            e1 = dop(c.x, a.y, c.y, a.x);
            e2 = dop(a.x, b.y, a.y, b.x);
        }
        if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
            return None;
        }
        let det = e0 + e1 + e2;
        if det == 0.0 || det.is_nan() {
            return None;
        }

        a.z *= self.shear_z;
        b.z *= self.shear_z;
        c.z *= self.shear_z;
        let t_scaled = e0 * a.z + e1 * b.z + e2 * c.z;
        let outside = if det < 0.0 {
            t_scaled >= 0.0 || t_scaled < t_max * det
        } else {
            t_scaled <= 0.0 || t_scaled > t_max * det
        };
        if outside {
            return None;
        }
        let inv_det = 1.0 / det;
        if !inv_det.is_finite() {
            return None;
        }
        let t = t_scaled * inv_det;

        // Reject t that is not conservatively positive (pbrt-v4 §6.8.4).
        let max_zt = a.z.abs().max(b.z.abs()).max(c.z.abs());
        let max_xt = a.x.abs().max(b.x.abs()).max(c.x.abs());
        let max_yt = a.y.abs().max(b.y.abs()).max(c.y.abs());
        let delta_z = gamma(3) * max_zt;
        let delta_x = gamma(5) * (max_xt + max_zt);
        let delta_y = gamma(5) * (max_yt + max_zt);
        let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
        let max_e = e0.abs().max(e1.abs()).max(e2.abs());
        let delta_t =
            3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
        if t <= delta_t || !t.is_finite() {
            return None;
        }
        Some(TriangleHit {
            t,
            b0: e0 * inv_det,
            b1: e1 * inv_det,
            b2: e2 * inv_det,
        })
    }
}

/// A triangle's vertices as the rows [`WatertightRay::intersect_transposed`] takes: their x, y
/// and z coordinates (lane i: vertex i).
pub fn transpose([p0, p1, p2]: [Vec3; 3]) -> [Vec3A; 3] {
    [
        Vec3A::new(p0.x, p1.x, p2.x),
        Vec3A::new(p0.y, p1.y, p2.y),
        Vec3A::new(p0.z, p1.z, p2.z),
    ]
}

/// One-off watertight intersection of `origin + t · dir` (`0 < t < t_max`) with a triangle.
pub fn intersect_triangle(
    origin: Vec3,
    dir: Vec3,
    t_max: f32,
    [p0, p1, p2]: [Vec3; 3],
) -> Option<TriangleHit> {
    WatertightRay::new(origin, dir).intersect(p0, p1, p2, t_max)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRI: [Vec3; 3] = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];

    #[test]
    fn ray_through_triangle_interior_returns_t_and_barycentrics() {
        let hit = intersect_triangle(Vec3::new(0.0, 0.0, 2.0), -Vec3::Z, f32::INFINITY, TRI)
            .expect("hit");
        assert!((hit.t - 2.0).abs() < 1e-6);
        let p = hit.b0 * TRI[0] + hit.b1 * TRI[1] + hit.b2 * TRI[2];
        assert!(p.distance(Vec3::ZERO) < 1e-6);
        assert!((hit.b0 + hit.b1 + hit.b2 - 1.0).abs() < 1e-6);
    }

    #[test]
    fn back_faces_are_hit_and_t_max_and_negative_t_are_respected() {
        let from_below = intersect_triangle(Vec3::new(0.0, 0.0, -2.0), Vec3::Z, 10.0, TRI);
        assert!((from_below.expect("back face").t - 2.0).abs() < 1e-6);
        assert!(intersect_triangle(Vec3::new(0.0, 0.0, -2.0), Vec3::Z, 1.9, TRI).is_none());
        assert!(intersect_triangle(Vec3::new(0.0, 0.0, -2.0), -Vec3::Z, 10.0, TRI).is_none());
    }

    #[test]
    fn degenerate_triangles_never_hit_and_never_produce_nan() {
        let p = Vec3::new(0.3, 0.2, 0.0);
        let degenerate = [
            [p, p, p],
            [Vec3::ZERO, Vec3::X, Vec3::X],
            [Vec3::ZERO, Vec3::X, 2.0 * Vec3::X],
            [
                Vec3::ZERO,
                Vec3::new(1.0, 1.0, 1.0),
                Vec3::new(2.0, 2.0, 2.0),
            ],
        ];
        let dirs = [
            -Vec3::Z,
            Vec3::new(0.3, -0.2, -1.0),
            Vec3::new(-1.0, -1.0, -1.0),
            -Vec3::X,
            Vec3::Y,
        ];
        for tri in degenerate {
            for dir in dirs {
                for origin in [
                    Vec3::new(0.5, 0.5, 1.0),
                    Vec3::new(0.3, 0.2, 1.0),
                    Vec3::ZERO,
                ] {
                    let hit = intersect_triangle(origin - dir, dir, f32::INFINITY, tri);
                    assert!(hit.is_none(), "{tri:?} hit by {dir:?}: {hit:?}");
                }
            }
        }
    }

    #[test]
    fn rays_parallel_to_the_triangle_plane_miss() {
        for origin in [Vec3::new(-3.0, 0.0, 0.0), Vec3::new(-3.0, 0.0, 1e-7)] {
            for dir in [Vec3::X, Vec3::new(1.0, 0.1, 0.0), Vec3::new(1.0, -0.5, 0.0)] {
                assert!(intersect_triangle(origin, dir, f32::INFINITY, TRI).is_none());
            }
        }
    }

    #[test]
    fn rays_with_zero_direction_components_hit_without_nan() {
        for dir in [
            -Vec3::Z,
            Vec3::new(0.0, 0.5, -1.0),
            Vec3::new(-0.0, -0.0, -1.0),
        ] {
            let origin = Vec3::new(0.1, 0.3, 0.0) - 3.0 * dir;
            let hit = intersect_triangle(origin, dir, f32::INFINITY, TRI).expect("hit");
            assert!(hit.t.is_finite() && hit.b0.is_finite() && hit.b1.is_finite());
        }
        assert!(intersect_triangle(Vec3::Z, Vec3::ZERO, f32::INFINITY, TRI).is_none());
    }

    #[test]
    fn transposed_test_gives_the_same_hits_bit_for_bit() {
        let mut rng = crate::photon::rng::Rng::new(5);
        let mut point = |scale: f32| {
            Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 * scale - scale
        };
        let mut hits = 0;
        for i in 0..20_000 {
            // Some triangles share a vertex with the ray's target, some are degenerate.
            let tri = [point(1.0), point(1.0), point(1.0)];
            let target = match i % 4 {
                0 => tri[0],
                1 => 0.5 * (tri[1] + tri[2]),
                _ => point(0.5),
            };
            let tri = if i % 97 == 0 {
                [tri[0], tri[0], tri[1]]
            } else {
                tri
            };
            let origin = point(3.0);
            let dir = if i % 13 == 0 {
                Vec3::new(0.0, target.y - origin.y, 0.0)
            } else {
                target - origin
            };
            let ray = WatertightRay::new(origin, dir);
            let t_max = if i % 3 == 0 { 0.7 } else { f32::INFINITY };
            let scalar = ray.intersect(tri[0], tri[1], tri[2], t_max);
            let rows = ray.intersect_transposed(&transpose(tri), t_max);
            let bits =
                |h: Option<TriangleHit>| h.map(|h| [h.t, h.b0, h.b1, h.b2].map(f32::to_bits));
            assert_eq!(bits(scalar), bits(rows), "{tri:?} {origin} {dir}");
            hits += scalar.is_some() as u32;
        }
        assert!(hits > 5000, "{hits} hits");
    }

    #[test]
    fn ray_through_shared_edge_hits_both_triangles_consistently() {
        // Two triangles sharing the edge (0,-1,0)–(0,1,0); rays exactly through its points.
        let left = [
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(-1.0, 0.0, 0.0),
        ];
        let right = [
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
        ];
        for i in 0..=64 {
            let y = -1.0 + i as f32 / 32.0;
            let dir = Vec3::new(0.37, 0.11, -1.0);
            let origin = Vec3::new(0.0, y, 0.0) - 5.0 * dir;
            let l = intersect_triangle(origin, dir, f32::INFINITY, left);
            let r = intersect_triangle(origin, dir, f32::INFINITY, right);
            assert!(
                l.is_some() || r.is_some(),
                "ray through edge at y={y} slipped through"
            );
        }
    }
}
