//! Rays, hit records and robust spawning of secondary rays.
//!
//! # Ray-origin offsetting: pbrt-v4's error bounds
//!
//! A secondary ray that starts exactly at a computed hit point can re-hit the surface it left,
//! because the point carries rounding error. We follow pbrt-v4 (Pharr, Jakob, Humphreys,
//! *Physically Based Rendering* 4th ed., §6.8.6): the hit point is computed from barycentrics,
//! which gives a conservative per-component absolute error bound
//! `γ₇ · (|b₀p₀| + |b₁p₁| + |b₂p₂|)` ([`Hit::position_error`]); [`offset_ray_origin`] pushes the
//! origin along the geometric normal, to the side of the outgoing direction, just far enough to
//! leave that error box, and then rounds each moved component one more float away.
//!
//! We chose this over Wächter & Binder's integer-ULP offset (Ray Tracing Gems ch. 6) because
//! that offset is a fixed 256 ULPs per component: about 2 m at 10⁵ m from the origin, which
//! jumps straight through metre-sized objects there, and a fixed 1.5·10⁻⁵ m near the origin,
//! which is not relative to a millimetre-scale scene. The error bound scales with the
//! magnitudes that actually produced the point, at every scale. The companion half of the
//! scheme is in [`super::triangle`]: a hit is accepted only when its `t` is conservatively
//! positive, so a ray starting on the correct side of the error box cannot re-hit its surface.
//!
//! A spawned ray also names the triangle it leaves ([`TriangleKey`], [`Ray::leaves`]), and the
//! BVH skips that triangle without testing it. That changes no hit (the two halves above
//! already keep the ray off it); it spares the one test a ray leaving a surface would otherwise
//! always make.

use glam::{Vec2, Vec3};

/// A ray `origin + t · dir` for `t ∈ (0, t_max)`. `dir` need not be normalised; `t` is then in
/// units of `dir`'s length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub t_max: f32,
    /// The triangle the ray leaves, which the BVH's queries skip without testing it
    /// ([`TriangleKey`]); [`TriangleKey::NONE`] for a ray that leaves no surface.
    pub leaves: TriangleKey,
}

impl Ray {
    /// A ray without an upper bound on `t`.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self::with_t_max(origin, dir, f32::INFINITY)
    }

    /// A ray limited to `t < t_max`.
    pub fn with_t_max(origin: Vec3, dir: Vec3, t_max: f32) -> Self {
        Self {
            origin,
            dir,
            t_max,
            leaves: TriangleKey::NONE,
        }
    }

    /// This ray, leaving the triangle `key` names: the BVH that made `key` skips that triangle.
    /// The origin must already be off it (as [`Hit::spawn_ray`]'s is); a ray from a hit's
    /// plain position that names the hit's triangle could miss a surface touching it.
    #[must_use]
    pub fn leaving(self, key: TriangleKey) -> Self {
        Self {
            leaves: key,
            ..self
        }
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

/// A triangle as [`crate::photon::bvh::SceneBvh`] stores it (which part of the BVH, where in its
/// leaves), so that a ray spawned from a hit can skip the triangle it leaves without testing it
/// (`Ray::leaves`).
///
/// Skipping it changes no hit as long as the offset holds. The spawned origin is moved off the
/// triangle's plane, to the side the ray goes, past the hit point's error bound
/// ([`offset_ray_origin`]). A plane is met at most once, so the ray can meet its own triangle
/// only behind its origin, which the triangle test rejects (its `t` must be conservatively
/// positive). The skip only spares that test; the self-intersection tests
/// (`photon/tracing_tests.rs`) check the offset with the skip removed, so that a skip cannot
/// hide an offset that fails. The photon tracer's rays leave a wall, and on the benchmark's
/// room they made 0.57 of their 3.39 triangle tests a ray on their own triangle
/// (`docs/performance.md`, "CPU photon tracing").
///
/// A key holds for the BVH that made the hit, until its static part is rebuilt (an instance
/// leaving it) or, for a moving instance, until [`crate::photon::bvh::SceneBvh::update`]
/// places the instance again (even where it was). Outside that it skips nothing: every build
/// of a static part and every placement of an instance, in any BVH, names its hits anew.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TriangleKey {
    /// `crate::photon::bvh`'s name of the part of the BVH: a number drawn for each build of the
    /// static part and each placement of a moving instance, never the same twice in the
    /// process; `0` for none.
    pub(crate) part: u64,
    /// Leaf-order index of the triangle in that part.
    pub(crate) leaf: u32,
}

impl TriangleKey {
    /// No triangle: nothing is skipped.
    pub const NONE: Self = Self { part: 0, leaf: 0 };
}

/// The closest intersection of a ray with the scene.
///
/// Normals follow glTF's winding: the front face is counter-clockwise, and both normals point
/// out of the front face whichever side the ray came from (`front_face` says which that was).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// World-space hit point, interpolated from the triangle's vertices.
    pub position: Vec3,
    /// Conservative absolute error bound of each component of `position`.
    pub position_error: Vec3,
    /// Index of the triangle in [`crate::scene::Scene::world_triangles`] order.
    pub triangle: u32,
    /// Index of the triangle within its instance's mesh.
    pub primitive: u32,
    /// Index into [`crate::scene::Scene::instances`].
    pub instance: u32,
    /// Barycentrics `(u, v)` of vertices 1 and 2 (vertex 0 has `1 − u − v`).
    pub barycentrics: Vec2,
    /// Unit geometric normal in world space (front side).
    pub geometric_normal: Vec3,
    /// Unit shading normal in world space, interpolated from the vertex normals.
    pub shading_normal: Vec3,
    /// Interpolated texture coordinates.
    pub uv: Vec2,
    /// Index into [`crate::scene::Scene::materials`].
    pub material: usize,
    /// True when the ray arrived at the front (counter-clockwise) side.
    pub front_face: bool,
    /// The triangle hit, as the BVH names it: what a ray spawned from here skips.
    pub key: TriangleKey,
}

impl Hit {
    /// A ray leaving this hit in direction `dir` (either side of the surface) that cannot
    /// re-hit this hit's triangle: it starts off the surface ([`offset_ray_origin`]) and skips
    /// the triangle ([`TriangleKey`]).
    #[inline(always)]
    pub fn spawn_ray(&self, dir: Vec3) -> Ray {
        let origin = offset_ray_origin(
            self.position,
            self.position_error,
            self.geometric_normal,
            dir,
        );
        Ray::new(origin, dir).leaving(self.key)
    }

    /// A shadow ray from this hit towards the point `target` (`t_max` stops just short of it).
    pub fn spawn_ray_to(&self, target: Vec3) -> Ray {
        let dir = target - self.position;
        let origin = offset_ray_origin(
            self.position,
            self.position_error,
            self.geometric_normal,
            dir,
        );
        Ray::with_t_max(origin, target - origin, 1.0 - SHADOW_EPSILON).leaving(self.key)
    }
}

/// Shortens shadow rays so they stop short of the point they are aimed at.
pub const SHADOW_EPSILON: f32 = 1e-4;

/// `γₙ = n·ε / (1 − n·ε)`, the bound on the relative error of `n` chained roundings, where
/// `ε = 2⁻²⁴` is the unit roundoff of `f32` (pbrt-v4 §6.8.1).
pub const fn gamma(n: i32) -> f32 {
    let n_eps = n as f32 * (f32::EPSILON * 0.5);
    n_eps / (1.0 - n_eps)
}

/// The point `p` (with per-component absolute error `p_error`) moved along the geometric
/// normal `n_geom` to the side of `dir`, out of its error box and one float further
/// (pbrt-v4's `OffsetRayOrigin`). A ray from there in direction `dir` cannot re-hit the
/// surface that `p` lies on.
#[inline(always)]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, n_geom: Vec3, dir: Vec3) -> Vec3 {
    let d = n_geom.abs().dot(p_error);
    let mut offset = d * n_geom;
    if dir.dot(n_geom) < 0.0 {
        offset = -offset;
    }
    let moved = p + offset;
    let away = |po: f32, off: f32| {
        if off > 0.0 {
            next_float_up(po)
        } else if off < 0.0 {
            next_float_down(po)
        } else {
            po
        }
    };
    Vec3::new(
        away(moved.x, offset.x),
        away(moved.y, offset.y),
        away(moved.z, offset.z),
    )
}

/// The smallest `f32` greater than `v` (`v` itself for +∞ and NaN).
#[inline]
pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 || v.is_nan() {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    f32::from_bits(if v >= 0.0 { bits + 1 } else { bits - 1 })
}

/// The largest `f32` less than `v` (`v` itself for −∞ and NaN).
#[inline]
pub fn next_float_down(v: f32) -> f32 {
    if v.is_infinite() && v < 0.0 || v.is_nan() {
        return v;
    }
    let v = if v == 0.0 { -0.0 } else { v };
    let bits = v.to_bits();
    f32::from_bits(if v > 0.0 { bits - 1 } else { bits + 1 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_float_steps_one_ulp_across_zero_and_signs() {
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_float_down(1.0), 1.0 - f32::EPSILON / 2.0);
        assert!(next_float_up(0.0) > 0.0 && next_float_up(-0.0) > 0.0);
        assert!(next_float_down(0.0) < 0.0 && next_float_down(-0.0) < 0.0);
        assert!(next_float_up(-1.0) > -1.0 && next_float_down(-1.0) < -1.0);
        assert_eq!(next_float_up(f32::MAX), f32::INFINITY);
    }

    #[test]
    fn offset_origin_moves_to_the_side_of_the_direction() {
        let p = Vec3::new(1e5, 3.0, -2.0);
        let err = Vec3::splat(gamma(7) * 1e5);
        let n = Vec3::Y;
        let up = offset_ray_origin(p, err, n, Vec3::new(0.3, 0.5, 0.1));
        let down = offset_ray_origin(p, err, n, Vec3::new(0.3, -0.5, 0.1));
        assert!(up.y - p.y > err.y && p.y - down.y > err.y);
        assert_eq!((up.x, up.z), (p.x, p.z));
    }
}
