//! Where light can go and what a camera can see, as conservative boxes and spheres: a test
//! here may say "reaches" when it does not, never the other way round.

use crate::photon::emit::light_flux;
use crate::scene::{Aabb, Camera, Light, LightKind};
use glam::{DVec3, Vec3};

/// Extra angle (radians) a spot cone is widened by in [`light_reaches`], against rounding.
const CONE_MARGIN: f64 = 1e-4;

/// The largest RGB channel of the light's flux (0 for black, negative or non-finite
/// intensities, which the emitter sanitises to 0).
pub fn light_power(light: &Light, bounds: &Aabb) -> f32 {
    light_flux(light, bounds).max_element()
}

/// The bounding sphere of a non-empty box.
pub fn sphere_of(b: &Aabb) -> (Vec3, f32) {
    (b.center(), b.extent().length() * 0.5)
}

/// The intersection of two boxes (empty if they do not overlap).
pub fn intersect(a: &Aabb, b: &Aabb) -> Aabb {
    let out = Aabb {
        min: a.min.max(b.min),
        max: a.max.min(b.max),
    };
    if out.is_empty() {
        Aabb::EMPTY
    } else {
        out
    }
}

/// Tangents of the half field of view (horizontal, vertical) at aspect `width/height`.
fn half_tangents(camera: &Camera, aspect: f32) -> (f64, f64) {
    let ty = (f64::from(camera.yfov) * 0.5).tan();
    (ty * f64::from(aspect), ty)
}

/// How far from the camera's position the near plane reaches (its corners): geometry closer
/// than this may be clipped open, so the camera can see past it.
pub fn near_reach(camera: &Camera, aspect: f32) -> f32 {
    let (tx, ty) = half_tangents(camera, aspect);
    (f64::from(camera.znear) * (1.0 + tx * tx + ty * ty).sqrt()) as f32
}

/// A box holding every point of `bounds` the camera can see: the view frustum cut at the
/// farthest corner of `bounds` (and at `zfar`), boxed, intersected with `bounds`. Empty when
/// the scene is wholly behind the far plane or closer than the near plane.
pub fn visible_box(camera: &Camera, aspect: f32, bounds: &Aabb) -> Aabb {
    if bounds.is_empty() {
        return Aabb::EMPTY;
    }
    let t = camera.transform.as_dmat4();
    let eye = t.w_axis.truncate();
    let right = t.x_axis.truncate().normalize_or_zero();
    let up = t.y_axis.truncate().normalize_or_zero();
    let forward = -t.z_axis.truncate().normalize_or_zero();
    let (lo, hi) = (bounds.min.as_dvec3(), bounds.max.as_dvec3());
    let farthest = (0..8)
        .map(|i| {
            let c = DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            (c - eye).length()
        })
        .fold(0.0, f64::max);
    let near = f64::from(camera.znear);
    let far = camera.zfar.map_or(farthest, |z| farthest.min(f64::from(z)));
    if far.is_nan() || far < near {
        return Aabb::EMPTY;
    }
    let (tx, ty) = half_tangents(camera, aspect);
    let mut frustum = Aabb::EMPTY;
    for depth in [near, far] {
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
            let p = eye + forward * depth + right * (sx * tx * depth) + up * (sy * ty * depth);
            frustum.grow(p.as_vec3());
        }
    }
    // Widen by a relative epsilon: the corners were rounded to f32.
    let pad = Vec3::splat(1e-5 * (far as f32).max(1.0));
    frustum.min -= pad;
    frustum.max += pad;
    intersect(&frustum, bounds)
}

/// Can light from `light` arrive anywhere inside the sphere `(centre, radius)`? An emitter's
/// area sample: when the sphere reaches in front of it. Point and directional lights: yes (a directional light's box is fitted to the scene). Spot lights:
/// when the cone (outer angle, widened by [`CONE_MARGIN`]) meets the sphere: the angle between
/// the axis and the direction to the centre is at most the cone's half-angle plus the angle
/// the sphere subtends, or the apex is inside the sphere.
pub fn light_reaches(light: &Light, (centre, radius): (Vec3, f32)) -> bool {
    if light.kind == LightKind::AreaSample {
        // A hemisphere: the sphere must reach in front of the light's plane.
        let normal = light.direction.normalize_or(Vec3::NEG_Y).as_dvec3();
        let ahead = normal.dot(centre.as_dvec3() - light.position.as_dvec3());
        return ahead > -f64::from(radius);
    }
    let LightKind::Spot {
        outer_cone_angle, ..
    } = light.kind
    else {
        return true;
    };
    let to_centre = centre.as_dvec3() - light.position.as_dvec3();
    let distance = to_centre.length();
    let radius = f64::from(radius);
    if distance <= radius {
        return true;
    }
    let axis = light.direction.normalize_or(Vec3::NEG_Y).as_dvec3();
    let angle = axis.dot(to_centre / distance).clamp(-1.0, 1.0).acos();
    let subtended = (radius / distance).asin();
    angle <= f64::from(outer_cone_angle) + subtended + CONE_MARGIN
}
