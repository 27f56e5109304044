//! Photon records shared with the GPU, exactly as DESIGN.md §2.1 (paper Table 1), the
//! packing of a direction with its path density, and of a stored photon's normal with its
//! kernel radius.
//!
//! Both records are `#[repr(C)]` + [`bytemuck::Pod`] arrays of `f32` with no padding; their GLSL
//! twins in `glsl/common/packing.glsl` read them as std430 arrays of `vec4` (2 for a
//! [`BounceMapPhoton`], 3 for a [`Photon`]), which have the same 32- and 48-byte strides.
//!
//! # Direction packing
//! A unit direction ω and a path density ρp ≥ 0 are stored as `v = ω·(ρp + 1)`
//! ([`pack_direction`]); [`unpack_direction`] returns `(v/‖v‖, ‖v‖ − 1)`.
//! - ρp is clamped to `[0, PATH_DENSITY_MAX]` (10¹⁵) when packing, so `‖v‖²` (≤ 10³⁰) stays
//!   finite in `f32`; NaN ρp packs as 0.
//! - ρp below about 6·10⁻⁸ rounds to 0 in `ρp + 1`: such paths (three or more diffuse bounces)
//!   already get the largest kernel, so nothing is lost that the kernel clamp would keep.
//! - A zero or non-finite ω packs to the zero vector, which unpacks to `(0, 0)`: "no direction",
//!   used by absorbed bounce-map photons (whose power is 0).
//!
//! # Normal packing
//! The photon map the photon volumes draw carries each photon's kNN kernel radius `r_i`
//! (metres, `photon::density`) in the length of its normal: `v = n̂·r_i` ([`pack_normal`]);
//! [`unpack_normal`] returns `(v/‖v‖, ‖v‖)`. The record keeps its 48 bytes.
//! - `r_i` is clamped to `[PACKED_RADIUS_MIN, PACKED_RADIUS_MAX]` (10⁻⁹ m, 10⁹ m) when packing,
//!   so the length is never 0 (the direction survives coincident photons, whose kNN distance
//!   is 0) and `‖v‖²` stays a finite, normal `f32`; NaN and +∞ (a photon alone in its class,
//!   `density::NO_NEIGHBOURS`) pack as the maximum, which every kernel clamp turns into `r_max`.
//! - The tracer stores unit normals (`photon::trace`, the per-light photons `PhotonFrame`
//!   keeps); only the copy written for the GPU ([`crate::render::photon_frame::PhotonFrame::photon_map`])
//!   and the CPU gather's records are packed. Readers that want the direction normalise (the
//!   photon volumes' shaders always did).
//! - A zero or non-finite n packs to the zero vector, which unpacks to `(0, 0)`.
use crate::layout::shared_constants::{PACKED_RADIUS_MAX, PACKED_RADIUS_MIN, PATH_DENSITY_MAX};
use bytemuck::{Pod, Zeroable};
use core::mem::{offset_of, size_of};
use glam::Vec3;

/// One texel of a bounce map: the photon leaving the surface that texel of the light G-buffer saw.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BounceMapPhoton {
    /// Power Φ (W, linear RGB); 0 when the photon was absorbed or the texel saw nothing.
    pub power: Vec3,
    /// Outgoing direction packed with the path density, see [`pack_direction`].
    pub direction: Vec3,
    /// Index of refraction of the medium the outgoing photon travels in.
    pub eta: f32,
    /// Depth of the hit point in the light G-buffer (the position, recovered from the light's
    /// view).
    pub depth: f32,
}

/// One stored photon of the photon map.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Photon {
    /// Power Φ (W, linear RGB).
    pub power: Vec3,
    /// Incident direction (pointing away from the surface, towards where the photon came from)
    /// packed with the path density, see [`pack_direction`].
    pub direction: Vec3,
    /// World-space position of the hit.
    pub position: Vec3,
    /// Normal n̂p of the surface the photon hit, turned to the incident side: unit as traced;
    /// packed with the photon's kernel radius in the photon map the GPU draws, see
    /// [`pack_normal`].
    pub normal: Vec3,
}

const _: () = assert!(size_of::<BounceMapPhoton>() == 32);
const _: () = assert!(offset_of!(BounceMapPhoton, power) == 0);
const _: () = assert!(offset_of!(BounceMapPhoton, direction) == 12);
const _: () = assert!(offset_of!(BounceMapPhoton, eta) == 24);
const _: () = assert!(offset_of!(BounceMapPhoton, depth) == 28);
const _: () = assert!(size_of::<Photon>() == 48);
const _: () = assert!(offset_of!(Photon, power) == 0);
const _: () = assert!(offset_of!(Photon, direction) == 12);
const _: () = assert!(offset_of!(Photon, position) == 24);
const _: () = assert!(offset_of!(Photon, normal) == 36);

/// Packs a direction (normalised here) and a path density into one vector: `ω̂·(ρp + 1)`.
pub fn pack_direction(w: Vec3, rho_p: f32) -> Vec3 {
    let len2 = w.length_squared();
    if !(len2.is_finite() && len2 > 0.0) {
        return Vec3::ZERO;
    }
    let rho = if rho_p.is_nan() {
        0.0
    } else {
        rho_p.clamp(0.0, PATH_DENSITY_MAX)
    };
    w * (len2.sqrt().recip() * (rho + 1.0))
}

/// Inverse of [`pack_direction`]: `(unit direction, ρp ≥ 0)`; the zero vector gives `(0, 0)`.
pub fn unpack_direction(v: Vec3) -> (Vec3, f32) {
    let len = v.length();
    if !(len.is_finite() && len > 0.0) {
        return (Vec3::ZERO, 0.0);
    }
    (v / len, (len - 1.0).max(0.0))
}

/// Packs a normal (normalised here) and a kernel radius in metres into one vector: `n̂·r`, `r`
/// clamped to `[PACKED_RADIUS_MIN, PACKED_RADIUS_MAX]` (NaN: the maximum).
pub fn pack_normal(n: Vec3, radius: f32) -> Vec3 {
    let len2 = n.length_squared();
    if !(len2.is_finite() && len2 > 0.0) {
        return Vec3::ZERO;
    }
    let r = if radius.is_nan() {
        PACKED_RADIUS_MAX
    } else {
        radius.clamp(PACKED_RADIUS_MIN, PACKED_RADIUS_MAX)
    };
    n * (len2.sqrt().recip() * r)
}

/// Inverse of [`pack_normal`]: `(unit normal, radius)`; the zero vector gives `(0, 0)`.
pub fn unpack_normal(v: Vec3) -> (Vec3, f32) {
    let len = v.length();
    if !(len.is_finite() && len > 0.0) {
        return (Vec3::ZERO, 0.0);
    }
    (v / len, len)
}

impl BounceMapPhoton {
    pub fn new(power: Vec3, direction: Vec3, rho_p: f32, eta: f32, depth: f32) -> Self {
        Self {
            power,
            direction: pack_direction(direction, rho_p),
            eta,
            depth,
        }
    }
}

impl Photon {
    pub fn new(power: Vec3, incident: Vec3, rho_p: f32, position: Vec3, normal: Vec3) -> Self {
        Self {
            power,
            direction: pack_direction(incident, rho_p),
            position,
            normal,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn roundtrip(w: Vec3, rho: f32) -> (Vec3, f32) {
        unpack_direction(pack_direction(w, rho))
    }

    #[test]
    fn pack_unpack_roundtrips_axis_and_negative_directions() {
        let dirs = [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            -Vec3::X,
            -Vec3::Y,
            -Vec3::Z,
            Vec3::new(-0.3, 0.5, -0.8).normalize(),
        ];
        for w in dirs {
            for rho in [0.0, 1e-3, 0.5, 1.0, 10.0, 1e6, 1e12] {
                let (w2, rho2) = roundtrip(w, rho);
                assert!(w2.distance(w) < 1e-6, "{w} {rho}: {w2}");
                assert!((rho2 - rho).abs() <= 1e-6 * (rho + 1.0), "{rho} → {rho2}");
            }
        }
    }

    #[test]
    fn zero_path_density_unpacks_to_exactly_zero_not_negative() {
        for w in [Vec3::X, Vec3::new(1.0, 1.0, 1.0), Vec3::new(-0.2, 0.9, 0.1)] {
            let (_, rho) = roundtrip(w, 0.0);
            assert!((0.0..1e-6).contains(&rho), "{rho}");
        }
        assert_eq!(roundtrip(Vec3::Y, -5.0).1, 0.0);
        assert_eq!(roundtrip(Vec3::Y, f32::NAN).1, 0.0);
    }

    #[test]
    fn huge_path_density_is_clamped_and_stays_finite() {
        for rho in [1e15, 1e30, f32::MAX, f32::INFINITY] {
            let v = pack_direction(Vec3::new(0.0, -1.0, 0.0), rho);
            assert!(v.is_finite() && v.length_squared().is_finite());
            let (w, r) = unpack_direction(v);
            assert!(w.distance(-Vec3::Y) < 1e-6);
            assert!((r / PATH_DENSITY_MAX - 1.0).abs() < 1e-6, "{rho} → {r}");
        }
    }

    #[test]
    fn degenerate_direction_packs_to_zero_and_unpacks_to_nothing() {
        for w in [
            Vec3::ZERO,
            Vec3::splat(f32::NAN),
            Vec3::new(f32::INFINITY, 0.0, 0.0),
        ] {
            assert_eq!(pack_direction(w, 3.0), Vec3::ZERO);
        }
        assert_eq!(unpack_direction(Vec3::ZERO), (Vec3::ZERO, 0.0));
    }

    #[test]
    fn normal_packing_roundtrips_the_radius_within_its_clamp() {
        let normals = [
            Vec3::X,
            -Vec3::Y,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
            // Not unit: normalised when packing.
            Vec3::new(0.0, 0.0, 7.0),
        ];
        for n in normals {
            for r in [1e-9, 1e-4, 0.0123, 1.0, 37.5, 1e9] {
                let v = pack_normal(n, r);
                let (n2, r2) = unpack_normal(v);
                assert!(n2.distance(n.normalize()) < 1e-6, "{n} {r}: {n2}");
                assert!((r2 / r - 1.0).abs() < 1e-6, "{r} → {r2}");
                assert!(v.length_squared().is_finite() && v.length_squared() > 0.0);
            }
        }
        // Coincident photons (kNN distance 0) keep their normal; no density packs the maximum.
        let (n, r) = unpack_normal(pack_normal(Vec3::Y, 0.0));
        assert!(n.distance(Vec3::Y) < 1e-6 && (r / PACKED_RADIUS_MIN - 1.0).abs() < 1e-6);
        for r in [f32::INFINITY, f32::NAN, 1e30] {
            let (n, r2) = unpack_normal(pack_normal(-Vec3::Z, r));
            assert!(n.distance(-Vec3::Z) < 1e-6, "{r}: {n}");
            assert!((r2 / PACKED_RADIUS_MAX - 1.0).abs() < 1e-6, "{r} → {r2}");
        }
        for n in [
            Vec3::ZERO,
            Vec3::splat(f32::NAN),
            Vec3::new(0.0, f32::INFINITY, 0.0),
        ] {
            assert_eq!(pack_normal(n, 0.5), Vec3::ZERO);
        }
        assert_eq!(unpack_normal(Vec3::ZERO), (Vec3::ZERO, 0.0));
    }

    #[test]
    fn glsl_twin_packs_normals_with_the_shared_constants() {
        let packing = include_str!("../../glsl/common/packing.glsl");
        for f in [
            "vec3 pack_normal(vec3 n, float radius)",
            "vec3 unpack_normal(vec3 v, out float radius)",
            "PACKED_RADIUS_MIN",
            "PACKED_RADIUS_MAX",
        ] {
            assert!(packing.contains(f), "packing.glsl lacks `{f}`");
        }
    }

    #[test]
    fn photon_records_are_flat_float_arrays_in_table_1_order() {
        let b = BounceMapPhoton::new(Vec3::new(1.0, 2.0, 3.0), Vec3::Z, 1.0, 1.5, 7.0);
        let f: &[f32] = bytemuck::cast_slice(std::slice::from_ref(&b));
        assert_eq!(f, &[1.0, 2.0, 3.0, 0.0, 0.0, 2.0, 1.5, 7.0]);
        let p = Photon::new(Vec3::ONE, -Vec3::X, 0.0, Vec3::new(4.0, 5.0, 6.0), Vec3::Y);
        let f: &[f32] = bytemuck::cast_slice(std::slice::from_ref(&p));
        assert_eq!(
            f,
            &[1.0, 1.0, 1.0, -1.0, 0.0, 0.0, 4.0, 5.0, 6.0, 0.0, 1.0, 0.0]
        );
    }
}
