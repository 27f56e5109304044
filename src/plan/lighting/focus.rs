//! The part of the scene the camera sees, as a directional light sees it: the window its first
//! shadow view is fitted to (`plan::lighting`, "Directional lights").
//!
//! ```text
//!   scene bounds ∩ eye frustum (4 sides + near plane)   a convex polyhedron: each face of the
//!          │                                            box clipped by the five planes
//!          ▼                                            (Sutherland–Hodgman), its vertices kept
//!   its vertices in the light's view space ──► min/max of x and y: the window
//!          │
//!          ▼
//!   a square window, its half-size the whole scene's halved in quarter octaves until the next
//!   step would not cover it, its centre on the texel grid: moving or turning the camera
//!   changes the window only in steps, so shadow edges do not crawl from frame to frame.
//! ```

use crate::scene::Aabb;
use glam::{DMat4, DVec2, DVec3, DVec4};

/// Quarter octaves below the whole scene's window the fitted one may go (2^−6 = 1/64 of its
/// size): beyond, a texel is far below a pixel of any image the renderer makes of the scene.
const MAX_STEPS: i32 = 24;

/// The square window `(centre, half size)` in the light's view space (`light_view`: world →
/// light view) that covers what the eye sees of `bounds`, or `None` when the eye sees none of
/// it. `eye_view_proj` maps camera-relative world to the eye's clip space; `camera` is the
/// camera's world position; `whole` is the half size of the window that covers all of
/// `bounds`; `resolution` the shadow map's texels per side.
pub fn window(
    light_view: &DMat4,
    eye_view_proj: &DMat4,
    camera: DVec3,
    bounds: &Aabb,
    whole: f64,
    resolution: u32,
) -> Option<(DVec2, f64)> {
    let (min, max) = seen_box(light_view, eye_view_proj, camera, bounds)?;
    // Half size needed, widened on each side (in texels at the final size) by the 4 the
    // shader keeps between the looked-up point and the window's edge (PCF footprint and
    // bilinear taps), the 2 the lookup offset's half along the normal may move it sideways
    // (0.75 texel × sin θ tan θ, up to θ = 70°) and the half the centre may move to the grid.
    let res = f64::from(resolution.max(16));
    let needed = 0.5 * (max - min).max_element() / (1.0 - 13.0 / res);
    let mut half = whole;
    for _ in 0..MAX_STEPS {
        let next = half * 0.5f64.powf(0.25);
        if next < needed {
            break;
        }
        half = next;
    }
    let texel = 2.0 * half / res;
    let centre = ((min + max) * 0.5 / texel).round() * texel;
    Some((centre, half))
}

/// The light-view x, y bounding box of `bounds` ∩ the eye's frustum: the vertices of that
/// convex polyhedron lie on the box's faces (each face clipped by the frustum) or on the
/// frustum's near plane (its quad clipped by the box: a camera inside the box sees from there).
fn seen_box(
    light_view: &DMat4,
    eye_view_proj: &DMat4,
    camera: DVec3,
    bounds: &Aabb,
) -> Option<(DVec2, DVec2)> {
    // Clip-space half-spaces p·(x, y, z, w) ≥ 0 (Gribb–Hartmann): the four sides and the near
    // plane z ≤ w of Vulkan's reversed depth (the far plane of an infinite projection is at
    // infinity and clips nothing).
    let m = eye_view_proj.transpose();
    let (r0, r1, r2, r3) = (m.x_axis, m.y_axis, m.z_axis, m.w_axis);
    let planes = [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r3 - r2];
    let lo = bounds.min.as_dvec3() - camera;
    let hi = bounds.max.as_dvec3() - camera;
    let corner = |i: usize| {
        DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    // The box's faces as corner indices in order around each face.
    const FACES: [[usize; 4]; 6] = [
        [0, 2, 6, 4],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 5, 7, 6],
    ];
    let mut min = DVec2::splat(f64::INFINITY);
    let mut max = DVec2::splat(f64::NEG_INFINITY);
    let mut add = |polygon: Vec<DVec3>| {
        for p in polygon {
            let l = light_view.transform_point3(p + camera);
            min = min.min(DVec2::new(l.x, l.y));
            max = max.max(DVec2::new(l.x, l.y));
        }
    };
    for face in FACES {
        let mut polygon: Vec<DVec3> = face.iter().map(|&i| corner(i)).collect();
        for plane in planes {
            polygon = clip(&polygon, plane);
        }
        add(polygon);
    }
    // The near plane's quad (depth 1 under reversed depth), clipped by the box's six sides.
    let inverse = eye_view_proj.inverse();
    let mut near: Vec<DVec3> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .iter()
        .map(|&(x, y)| inverse.project_point3(DVec3::new(x, y, 1.0)))
        .collect();
    for axis in 0..3 {
        let unit = DVec3::AXES[axis];
        near = clip(&near, unit.extend(-lo[axis]));
        near = clip(&near, (-unit).extend(hi[axis]));
    }
    add(near);
    // Nothing left (or an empty, infinite box): no window.
    (min.is_finite() && max.is_finite() && min.x <= max.x && min.y <= max.y).then_some((min, max))
}

/// One Sutherland–Hodgman step: the part of convex `polygon` where `plane·(p, 1) ≥ 0`.
fn clip(polygon: &[DVec3], plane: DVec4) -> Vec<DVec3> {
    let side = |p: DVec3| plane.dot(p.extend(1.0));
    let mut out = Vec::with_capacity(polygon.len() + 1);
    for (i, &a) in polygon.iter().enumerate() {
        let b = polygon[(i + 1) % polygon.len()];
        let (sa, sb) = (side(a), side(b));
        if sa >= 0.0 {
            out.push(a);
        }
        if (sa >= 0.0) != (sb >= 0.0) {
            out.push(a + (b - a) * (sa / (sa - sb)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// An eye at `eye` looking at `target` with a 45° vertical field of view, 4:3, reversed
    /// infinite depth (as `Renderer::eye_view_proj`), camera-relative.
    fn eye(eye: DVec3, target: DVec3) -> DMat4 {
        let view = glam::dcamera::rh::view::look_at_mat4(DVec3::ZERO, target - eye, DVec3::Y);
        glam::dcamera::rh::proj::vulkan::perspective_infinite_reverse(
            std::f64::consts::FRAC_PI_4,
            4.0 / 3.0,
            0.01,
        ) * view
    }

    /// A sun straight down: light view x, y are world x and −z or similar (any basis).
    fn sun_view() -> DMat4 {
        glam::dcamera::rh::view::look_to_mat4(DVec3::new(0.0, 50.0, 0.0), DVec3::NEG_Y, DVec3::X)
    }

    /// The window at 1024² for an eye at `camera` looking at `target` over [`floor`].
    fn fitted(camera: DVec3, target: DVec3) -> Option<(DVec2, f64)> {
        let whole = 10.0 * 2f64.sqrt();
        window(
            &sun_view(),
            &eye(camera, target),
            camera,
            &floor(),
            whole,
            1024,
        )
    }

    /// Is `p` inside the window by the 4 texels (of 1024) the shader keeps from its edge?
    fn well_inside(p: DVec3, (centre, half): (DVec2, f64)) -> bool {
        let l = sun_view().transform_point3(p);
        let d = (DVec2::new(l.x, l.y) - centre).abs();
        d.max_element() <= half - 4.0 * (2.0 * half / 1024.0)
    }

    /// A 20 m × 20 m floor, 2 m high.
    fn floor() -> Aabb {
        Aabb {
            min: Vec3::new(-10.0, 0.0, -10.0),
            max: Vec3::new(10.0, 2.0, 10.0),
        }
    }

    #[test]
    fn a_camera_looking_down_at_a_small_part_of_a_floor_gets_a_small_window_around_it() {
        let (camera, target) = (DVec3::new(0.0, 3.0, 2.0), DVec3::new(0.0, 0.0, 0.0));
        let whole = 10.0 * 2f64.sqrt();
        let (centre, half) = fitted(camera, target).expect("the floor is seen");
        // Seen: a few metres of floor around the target, and the volume above it up to the
        // camera's height inside the box.
        assert!(half < whole / 3.0, "half size {half} of {whole}");
        // Every point of the floor the eye sees is inside the window.
        let view = eye(camera, target);
        for x in -40..=40 {
            for z in -40..=40 {
                let p = DVec3::new(f64::from(x) * 0.25, 0.0, f64::from(z) * 0.25);
                let clip = view * (p - camera).extend(1.0);
                let ndc = clip.truncate() / clip.w;
                let seen = clip.w > 0.0 && ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0;
                if seen {
                    assert!(
                        well_inside(p, (centre, half)),
                        "{p} seen but outside the window"
                    );
                }
            }
        }
    }

    #[test]
    fn the_window_moves_and_grows_in_steps_only() {
        let target = DVec3::ZERO;
        let whole = 10.0 * 2f64.sqrt();
        let at = |x: f64| fitted(DVec3::new(x, 3.0, 2.0), target).unwrap();
        let (c0, h0) = at(0.0);
        let (c1, h1) = at(1e-4);
        // A tenth of a millimetre: the same window, bit for bit.
        assert_eq!((c0, h0), (c1, h1));
        // Sizes are the whole scene's in quarter octaves; centres on the texel grid.
        for x in [0.0, 0.3, 1.7] {
            let (c, h) = at(x);
            let steps = (whole / h).log2() * 4.0;
            assert!((steps - steps.round()).abs() < 1e-9, "{steps}");
            let texel = 2.0 * h / 1024.0;
            let k = c / texel;
            assert!(
                (k - k.round()).abs().max_element() < 1e-6,
                "{c} off the grid {texel}"
            );
        }
    }

    #[test]
    fn a_camera_that_sees_nothing_of_the_scene_has_no_window_and_one_inside_sees_all_around() {
        let whole = 10.0 * 2f64.sqrt();
        // An empty scene (the loader's bounds of nothing: +∞ … −∞).
        let camera = DVec3::new(0.0, 1.0, 2.0);
        let view = eye(camera, DVec3::ZERO);
        let empty = Aabb {
            min: Vec3::INFINITY,
            max: Vec3::NEG_INFINITY,
        };
        assert!(window(&sun_view(), &view, camera, &empty, whole, 1024).is_none());
        // Outside, looking away.
        let camera = DVec3::new(0.0, 1.0, 30.0);
        let away = eye(camera, DVec3::new(0.0, 1.0, 60.0));
        assert!(window(&sun_view(), &away, camera, &floor(), whole, 1024).is_none());
        // Inside, looking along the floor: the far wall is 10 m away, the window is large,
        // and it holds the foreground the eye sees from inside the box too.
        let camera = DVec3::new(0.0, 1.0, 0.0);
        let target = DVec3::new(0.0, 1.0, -5.0);
        let seen = fitted(camera, target).unwrap();
        assert!(seen.1 >= 5.0 && seen.1 <= whole, "{}", seen.1);
        let along = eye(camera, target);
        for p in [
            DVec3::new(0.0, 0.9, -0.5),
            DVec3::new(0.0, 1.0, -1.0),
            DVec3::new(0.1, 0.95, -0.3),
        ] {
            let clip = along * (p - camera).extend(1.0);
            let ndc = clip.truncate() / clip.w;
            assert!(
                ndc.x.abs() < 1.0 && ndc.y.abs() < 1.0 && ndc.z < 1.0,
                "{p} not seen"
            );
            assert!(
                well_inside(p, seen),
                "{p}, in the foreground, outside the window"
            );
        }
    }
}
