//! Lights as the GPU sees them, and the shadow-map views that cover them.
//!
//! Every light gets one or more layers of the shadow atlas (a 2D array depth image):
//!
//! ```text
//!   spot, outer cone ≤ 60°  → 1 perspective view along the axis (fov = 2·outer + margin)
//!   point, or a wider spot  → 6 perspective views of 90°, the faces of a cube
//!   emitter's area sample   → the same cube (its hemisphere needs 5 faces at most)
//!   directional             → 2 orthographic views (shadow maps; the photons' views: 1)
//! ```
//!
//! # Directional lights
//! One orthographic view around the whole scene spreads its texels over all of it: on
//! `caustic-ring`'s floor at 1024² a texel was about 5 pixels of a 640×480 image, and the ring's
//! shadow showed the steps. A shadow-map light setup made for an eye ([`LightSetup::active`]
//! with its view-projection) gives a directional light two views, as cascaded shadow maps do
//! with two cascades:
//!
//! ```text
//!   view first      fitted to what the eye sees of the scene (focus.rs: the scene's bounds
//!                   clipped by the eye's frustum), square, in quarter-octave sizes, its centre
//!                   on the texel grid; depth range that of the whole scene (casters outside
//!                   the eye's view still cast into it)
//!   view first + 1  around the whole scene (what the environment cube and reflections see)
//! ```
//!
//! `shadows.glsl` uses the first where the point it looks up (offset against acne) falls 4
//! texels inside it, else the second. An orthographic view's depth is linear over the whole
//! scene's depth range, which the fitted view keeps while its texel shrinks (down to 1/64 of
//! the whole view's): its lookup offset, a texel and a half, is held to at least 128 float32
//! steps of that range (`ShadowView::params.z`), twice the 64 steps that kept the H100 free of
//! acne. Without an eye (or when it sees none of the scene) both views are the whole scene's,
//! so the count of views, and the atlas, does not depend on the camera.
//!
//! All matrices map *camera-relative* world space (world minus the camera position, computed
//! in f64) to the light's clip space, so precision does not depend on the distance from the
//! world origin.
//!
//! Every light view has reversed depth (near plane at depth 1, far plane at 0,
//! `LIGHT_VIEW_NEAR_Z`): with a D32F depth buffer its precision is relative to the distance. The
//! shadow maps' near plane is 10⁻⁴ of the scene's diagonal from the light. With standard depth
//! (near 0, far 1) a float32 step near depth 1 was about 0.7 mm of distance on the Cornell box's
//! floor, less than the normal offset's margin at 1024² shadow maps, which NVIDIA's rasteriser
//! turned into shadow acne (docs/performance.md, "On an NVIDIA H100"). The photons' views
//! ([`LightSetup::photon_views`]: light G-buffers, bounce map) put the near plane at 10⁻⁶ of the
//! diagonal, so a light 0.1 mm from a surface still sends its photons onto it (hard case "a
//! light touching a surface", docs/stability.md).

use crate::layout::{
    GpuLight, ShadowView, LIGHT_AREA_SAMPLE, LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT,
};
use crate::scene::{Aabb, Light, LightKind};
use glam::{DMat4, DVec3, UVec4, Vec3};

mod focus;

/// Above this outer-cone angle a spot light is covered by a cube of views, not one frustum.
const MAX_SINGLE_VIEW_CONE: f32 = std::f32::consts::FRAC_PI_3;

/// The lights of a frame and the shadow views that cover them.
#[derive(Clone, Debug, Default)]
pub struct LightSetup {
    pub lights: Vec<GpuLight>,
    pub views: Vec<ShadowView>,
    /// For each view: camera-relative world → light clip (what the shadow pass draws with).
    pub view_matrices: Vec<DMat4>,
}

fn any_perpendicular(d: DVec3) -> DVec3 {
    if d.y.abs() < 0.99 {
        DVec3::Y
    } else {
        DVec3::X
    }
}

/// What a setup's views are for, which sets how they map depth.
#[derive(Clone, Copy, Debug)]
enum Depth<'a> {
    /// Shadow maps: near plane 10⁻⁴ of the scene's diagonal from the light; directional lights
    /// get two views, the first fitted to what `eye` sees (module docs).
    Shadow { eye: Option<&'a DMat4> },
    /// Photon views: near plane 10⁻⁶ of the diagonal; one view per directional light.
    Photon,
}

impl Depth<'_> {
    /// The near plane's distance from the light, as a fraction of the scene's diagonal.
    fn near(self) -> f64 {
        match self {
            Depth::Shadow { .. } => 1e-4,
            Depth::Photon => 1e-6,
        }
    }

    /// `m` (to clip space with depth 0 at the near plane) with reversed depth: z' = w − z, which
    /// maps the near plane to 1 and the far plane to 0 (module docs).
    fn apply(self, m: DMat4) -> DMat4 {
        let reverse = DMat4::from_cols(
            glam::DVec4::X,
            glam::DVec4::Y,
            glam::DVec4::new(0.0, 0.0, -1.0, 0.0),
            glam::DVec4::new(0.0, 0.0, 1.0, 1.0),
        );
        reverse * m
    }
}

/// Near and far planes for a perspective view from `eye` that must see all of `bounds`, the near
/// plane `near` of its diagonal from `eye`.
fn near_far(eye: DVec3, bounds: &Aabb, near: f64) -> (f64, f64) {
    let min = bounds.min.as_dvec3();
    let max = bounds.max.as_dvec3();
    let diag = (max - min).length().max(1e-6);
    let mut far: f64 = 0.0;
    for i in 0..8 {
        let c = DVec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        );
        far = far.max((c - eye).length());
    }
    // The near plane follows the scene's scale.
    let near = diag * near;
    (near, (far * 1.01).max(near * 2.0))
}

fn perspective(fov: f64, near: f64, far: f64) -> DMat4 {
    glam::dcamera::rh::proj::vulkan::perspective(fov, 1.0, near, far)
}

impl LightSetup {
    /// Builds the lights and shadow views of `lights` for a camera at `camera` over a scene
    /// with `bounds`, with shadow maps of `resolution`² texels. Cube faces are widened by
    /// `margin` texels on each side so that a lookup near a face's edge (normal offset, 3×3
    /// PCF, bilinear footprint) stays inside the face; photon emission passes 0, because its
    /// faces must tile the sphere exactly once. Directional lights' views are both the whole
    /// scene's (no eye: module docs, "Directional lights").
    pub fn new(
        lights: &[Light],
        camera: DVec3,
        bounds: &Aabb,
        resolution: u32,
        margin: u32,
    ) -> LightSetup {
        Self::active(
            lights,
            &vec![true; lights.len()],
            (camera, None),
            bounds,
            resolution,
            margin,
        )
    }

    /// The views photons start from (the bounce map's light views, `plan/bounce_plan.rs`): [`LightSetup::new`]
    /// with one texel (each view's texel parameter is its whole window) and no margin (a cube's
    /// faces tile the sphere exactly once), with reversed depth and a near plane 10⁻⁶ of the
    /// scene's diagonal from the light (module docs).
    pub fn photon_views(lights: &[Light], origin: DVec3, bounds: &Aabb) -> LightSetup {
        let active = vec![true; lights.len()];
        Self::with_depth(lights, &active, origin, bounds, (1, 0), Depth::Photon)
    }

    /// [`LightSetup::new`] for the lights with `active[i]` only (the effects plan's direct-light
    /// mask, `plan::EffectsPlan::direct_mask`): the others get no [`GpuLight`] and no shadow
    /// views, so the shadow pass draws nothing for them and the direct pass does not loop over
    /// them. A light missing from `active` is inactive. `(camera, eye)`: the camera's world
    /// position and, if given, the eye's view-projection (camera-relative world → clip), to
    /// which directional lights fit their first view (module docs, "Directional lights").
    pub fn active(
        lights: &[Light],
        active: &[bool],
        (camera, eye): (DVec3, Option<&DMat4>),
        bounds: &Aabb,
        resolution: u32,
        margin: u32,
    ) -> LightSetup {
        let texels = (resolution, margin);
        Self::with_depth(
            lights,
            active,
            camera,
            bounds,
            texels,
            Depth::Shadow { eye },
        )
    }

    fn with_depth(
        lights: &[Light],
        active: &[bool],
        camera: DVec3,
        bounds: &Aabb,
        (resolution, margin): (u32, u32),
        depth: Depth,
    ) -> LightSetup {
        let mut setup = LightSetup::default();
        let res = f64::from(resolution.max(1));
        let active_lights = lights
            .iter()
            .enumerate()
            .filter(|(i, _)| active.get(*i) == Some(&true))
            .map(|(_, light)| light);
        for light in active_lights {
            let pos = light.position.as_dvec3();
            let dir = light.direction.normalize_or(Vec3::NEG_Y).as_dvec3();
            let first = setup.views.len() as u32;
            let (kind, cos_outer, cos_inner) = match light.kind {
                LightKind::Point => (LIGHT_POINT, -1.0, -1.0),
                LightKind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } => (LIGHT_SPOT, outer_cone_angle.cos(), inner_cone_angle.cos()),
                LightKind::Directional => (LIGHT_DIRECTIONAL, -1.0, -1.0),
                // A hemisphere: the "cone" is everything in front of the surface.
                LightKind::AreaSample => (LIGHT_AREA_SAMPLE, 0.0, 1.0),
            };
            let to_relative = DMat4::from_translation(camera);
            match light.kind {
                LightKind::Spot {
                    outer_cone_angle, ..
                } if outer_cone_angle <= MAX_SINGLE_VIEW_CONE => {
                    let fov = (2.0 * f64::from(outer_cone_angle) * 1.05).max(1e-3);
                    let (near, far) = near_far(pos, bounds, depth.near());
                    let view =
                        glam::dcamera::rh::view::look_to_mat4(pos, dir, any_perpendicular(dir));
                    let m = depth.apply(perspective(fov, near, far) * view * to_relative);
                    setup.push_view(m, (2.0 * (fov * 0.5).tan() / res) as f32, false, 0.0);
                }
                LightKind::Point | LightKind::Spot { .. } | LightKind::AreaSample => {
                    let (near, far) = near_far(pos, bounds, depth.near());
                    let half = (1.0 + 2.0 * f64::from(margin) / res).atan();
                    let proj = perspective(2.0 * half, near, far);
                    let faces = [
                        (DVec3::X, DVec3::NEG_Y),
                        (DVec3::NEG_X, DVec3::NEG_Y),
                        (DVec3::Y, DVec3::Z),
                        (DVec3::NEG_Y, DVec3::NEG_Z),
                        (DVec3::Z, DVec3::NEG_Y),
                        (DVec3::NEG_Z, DVec3::NEG_Y),
                    ];
                    for (forward, up) in faces {
                        let view = glam::dcamera::rh::view::look_to_mat4(pos, forward, up);
                        setup.push_view(
                            depth.apply(proj * view * to_relative),
                            (2.0 * half.tan() / res) as f32,
                            false,
                            0.0,
                        );
                    }
                }
                LightKind::Directional => {
                    let center = bounds.center().as_dvec3();
                    let radius = (bounds.extent().as_dvec3().length() * 0.5).max(1e-6);
                    let from = center - dir * radius * 2.0;
                    let view =
                        glam::dcamera::rh::view::look_to_mat4(from, dir, any_perpendicular(dir));
                    let (near, far) = (radius * 1e-3, radius * 4.0);
                    let ortho = |centre: glam::DVec2, half: f64| {
                        let proj = glam::dcamera::rh::proj::vulkan::orthographic(
                            centre.x - half,
                            centre.x + half,
                            centre.y - half,
                            centre.y + half,
                            near,
                            far,
                        );
                        (
                            depth.apply(proj * view * to_relative),
                            (2.0 * half / res) as f32,
                        )
                    };
                    // Depth is linear here and keeps the whole scene's range while a fitted
                    // view's texel may be 64× smaller: the lookup offset is held to at least
                    // 128 float32 steps of depth (2⁻²⁴ of the range each, near depth 1), so
                    // that half of it still spans the 64 steps acne needs (module docs).
                    let least = (128.0 * (far - near) / f64::from(1u32 << 24)) as f32;
                    let whole = ortho(glam::DVec2::ZERO, radius);
                    if let Depth::Shadow { eye } = depth {
                        let seen = eye.and_then(|eye| {
                            focus::window(&view, eye, camera, bounds, radius, resolution)
                        });
                        let (m, texel) = seen.map_or(whole, |(c, half)| ortho(c, half));
                        setup.push_view(m, texel, true, least);
                    }
                    setup.push_view(whole.0, whole.1, true, least);
                }
            }
            let count = setup.views.len() as u32 - first;
            let rel = (pos - camera).as_vec3();
            setup.lights.push(GpuLight {
                position: rel.extend(0.0),
                direction: dir.as_vec3().extend(cos_outer),
                intensity: light.intensity.extend(cos_inner),
                shadow: UVec4::new(kind, first, count, 0),
            });
        }
        setup
    }

    /// Adds a view; `least_offset` (m) is the smallest shadow-lookup offset it takes
    /// (`shadows.glsl`).
    fn push_view(&mut self, m: DMat4, texel: f32, ortho: bool, least_offset: f32) {
        self.views.push(ShadowView {
            view_proj: m.as_mat4(),
            params: glam::Vec4::new(texel, if ortho { 1.0 } else { 0.0 }, least_offset, 0.0),
        });
        self.view_matrices.push(m);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_bounds() -> Aabb {
        Aabb {
            min: Vec3::splat(-1.0),
            max: Vec3::splat(1.0),
        }
    }

    fn light(kind: LightKind) -> Light {
        Light {
            name: "l".into(),
            kind,
            position: Vec3::new(0.0, 0.9, 0.0),
            direction: Vec3::NEG_Y,
            intensity: Vec3::ONE,
        }
    }

    /// `shadows.glsl`'s `shadow_lookup_point` (a copy: change both): the point looked up for
    /// surface point `p` with normal `n`, `wi` towards the light, `texel` the view's texel at
    /// p's distance and `least` its `params.z`.
    fn lookup_point(p: Vec3, n: Vec3, wi: Vec3, texel: f32, least: f32) -> (Vec3, f32) {
        let cos_t = n.dot(wi).clamp(0.0, 1.0);
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let h = (1.5 * texel * sin_t.max(0.2)).max(least);
        (p + n * (0.5 * h) + wi * (0.5 * h / cos_t.max(0.05)), h)
    }

    /// A sun straight down on a floor of half-width `half` (2 m of air above it), seen by an
    /// eye at `camera` looking at the origin: the setup with the eye, at `resolution`².
    fn sun_seen_from(half: f32, camera: DVec3, resolution: u32) -> (Aabb, LightSetup) {
        let bounds = Aabb {
            min: Vec3::new(-half, 0.0, -half),
            max: Vec3::new(half, 2.0, half),
        };
        let eye = glam::dcamera::rh::proj::vulkan::perspective_infinite_reverse(0.8, 1.333, 0.01)
            * glam::dcamera::rh::view::look_at_mat4(DVec3::ZERO, -camera, DVec3::Y);
        let lights = [light(LightKind::Directional)];
        let setup = LightSetup::active(
            &lights,
            &[true],
            (camera, Some(&eye)),
            &bounds,
            resolution,
            3,
        );
        (bounds, setup)
    }

    /// A spot narrow enough for one view, pointing down from (0, 0.9, 0).
    fn narrow_spot() -> Light {
        light(LightKind::Spot {
            inner_cone_angle: 0.3,
            outer_cone_angle: 0.5,
        })
    }

    /// A point light, a narrow spot (one view), a wide spot (a cube) and a directional light.
    fn every_kind() -> [Light; 4] {
        [
            light(LightKind::Point),
            narrow_spot(),
            light(LightKind::Spot {
                inner_cone_angle: 1.0,
                outer_cone_angle: 1.5,
            }),
            light(LightKind::Directional),
        ]
    }

    #[test]
    fn each_light_kind_gets_the_views_that_cover_it() {
        let lights = every_kind();
        let s = LightSetup::new(&lights, DVec3::ZERO, &unit_bounds(), 256, 3);
        let counts: Vec<u32> = s.lights.iter().map(|l| l.shadow.z).collect();
        assert_eq!(counts, vec![6, 1, 6, 2]);
        assert_eq!(s.views.len(), 15);
        let firsts: Vec<u32> = s.lights.iter().map(|l| l.shadow.y).collect();
        assert_eq!(firsts, vec![0, 6, 7, 13]);
    }

    #[test]
    fn a_directional_lights_first_view_is_fitted_to_what_the_eye_sees_and_its_second_to_all() {
        // A sun straight down on a 20 m floor; the eye 3 m above it looks at a spot 2 m ahead.
        let camera = DVec3::new(0.0, 3.0, 2.0);
        let (bounds, fitted) = sun_seen_from(10.0, camera, 1024);
        let lights = [light(LightKind::Directional)];
        let blind = LightSetup::new(&lights, camera, &bounds, 1024, 3);
        assert_eq!(fitted.lights[0].shadow.z, 2);
        assert_eq!(
            fitted.views.len(),
            blind.views.len(),
            "the atlas does not depend on the eye"
        );
        let (near, far) = (fitted.views[0].params.x, fitted.views[1].params.x);
        assert!(near < far / 3.0, "texels {near} m and {far} m");
        // Without the eye both views are the whole scene's, the second always.
        assert_eq!(blind.views[0].params.x, far);
        assert_eq!(blind.view_matrices[1], fitted.view_matrices[1]);
        // The floor point the eye looks at is inside the first view, well in depth range.
        let ndc = |m: &DMat4, p: DVec3| {
            let c = *m * (p - camera).extend(1.0);
            c.truncate() / c.w
        };
        let p = ndc(&fitted.view_matrices[0], DVec3::ZERO);
        assert!(
            p.x.abs() < 0.9 && p.y.abs() < 0.9 && p.z > 0.0 && p.z < 1.0,
            "{p}"
        );
        // The photons' views keep one view per directional light.
        let photon = LightSetup::photon_views(&lights, DVec3::ZERO, &bounds);
        assert_eq!(photon.lights[0].shadow.z, 1);
    }

    /// The fitted view of a sun keeps the whole scene's depth range while its texel shrinks
    /// (down to 1/64 of the whole view's), so the lookup offset (`shadows.glsl`, mirrored here:
    /// h = max(1.5 texels × max(sin θ, 0.2), params.z), half along the normal and half along
    /// the ray) is held to a least value that still moves the depth by 64 float32 steps.
    #[test]
    fn a_fitted_sun_views_lookup_offset_spans_many_depth_steps_at_its_smallest_window() {
        // A sun straight down on a 100 m floor; the eye 0.5 m above it sees under a metre.
        let camera = DVec3::new(0.0, 0.5, 0.2);
        let (_, s) = sun_seen_from(50.0, camera, 8192);
        let (fitted, whole) = (s.views[0], s.views[1]);
        assert!(
            fitted.params.x <= whole.params.x / 60.0,
            "texels {} and {}",
            fitted.params.x,
            whole.params.x
        );
        let depth = |p: Vec3| {
            let clip = fitted.view_proj * (p - camera.as_vec3()).extend(1.0);
            clip.z / clip.w
        };
        let p = Vec3::ZERO;
        let (q, _) = lookup_point(p, Vec3::Y, Vec3::Y, fitted.params.x, fitted.params.z);
        let (zp, zq) = (depth(p), depth(q));
        let step = f32::from_bits(zp.to_bits() + 1) - zp;
        let steps = (zq - zp).abs() / step;
        assert!(
            (0.0..1.0).contains(&zp) && steps >= 64.0,
            "depth {zp}: the offset moves it {steps} float32 steps"
        );
    }

    #[test]
    fn inactive_lights_get_no_light_and_no_views() {
        let [point, narrow_spot, _, directional] = every_kind();
        let lights = [point, narrow_spot, directional];
        let all = LightSetup::new(&lights, DVec3::ZERO, &unit_bounds(), 256, 3);
        let some = LightSetup::active(
            &lights,
            &[false, true, true],
            (DVec3::ZERO, None),
            &unit_bounds(),
            256,
            3,
        );
        assert_eq!(some.lights.len(), 2);
        assert_eq!(some.views.len(), 3);
        // The remaining lights are the same, their views renumbered from 0.
        assert_eq!(some.lights[0].intensity, all.lights[1].intensity);
        assert_eq!(some.lights[0].shadow.y, 0);
        assert_eq!(some.lights[1].shadow.y, 1);
        assert_eq!(some.view_matrices[1], all.view_matrices[7]);
        let none = LightSetup::active(&lights, &[], (DVec3::ZERO, None), &unit_bounds(), 256, 3);
        assert!(none.lights.is_empty() && none.views.is_empty());
    }

    #[test]
    fn photon_views_reverse_depth_and_see_a_surface_a_hundred_thousandth_of_the_scene_away() {
        // The unit box's diagonal is 2√3: 10⁻⁵ of it is 35 µm, inside the shadow views' near
        // plane (10⁻⁴) and outside the photon views' (10⁻⁶).
        let lights = [narrow_spot()];
        let bounds = unit_bounds();
        let diagonal = f64::from((bounds.max - bounds.min).length());
        let ndc_z = |s: &LightSetup, distance: f64| {
            let p = lights[0].position.as_dvec3() + DVec3::NEG_Y * distance;
            let clip = s.view_matrices[0] * p.extend(1.0);
            clip.z / clip.w
        };
        let shadow = LightSetup::new(&lights, DVec3::ZERO, &bounds, 256, 0);
        let photon = LightSetup::photon_views(&lights, DVec3::ZERO, &bounds);
        let close = 1e-5 * diagonal;
        // Both reverse depth: nearer than the shadow view's near plane is beyond depth 1.
        assert!(ndc_z(&shadow, close) > 1.0, "clipped by the shadow view");
        let (near, far) = (ndc_z(&photon, close), ndc_z(&photon, 1.5));
        assert!(near > 0.0 && near <= 1.0, "{near}");
        assert!(far > 0.0 && far < near, "reversed: {far} beyond {near}");
        // The same x and y: only depth differs.
        let p = DVec3::new(0.1, -0.5, 0.2).extend(1.0);
        let (a, b) = (shadow.view_matrices[0] * p, photon.view_matrices[0] * p);
        assert!((a.x / a.w - b.x / b.w).abs() < 1e-12 && (a.y / a.w - b.y / b.w).abs() < 1e-12);
    }

    #[test]
    fn a_point_below_a_spot_projects_inside_its_view_and_in_depth_range() {
        let lights = [narrow_spot()];
        let camera = DVec3::new(0.0, 0.0, 3.0);
        let s = LightSetup::new(&lights, camera, &unit_bounds(), 256, 3);
        let p = DVec3::new(0.1, -1.0, 0.0) - camera;
        let clip = s.view_matrices[0] * p.extend(1.0);
        let ndc = clip.truncate() / clip.w;
        assert!(ndc.x.abs() < 1.0 && ndc.y.abs() < 1.0, "{ndc}");
        assert!(ndc.z > 0.0 && ndc.z < 1.0, "{ndc}");
    }

    /// The shadow lookup's offset (`glsl/common/shadows.glsl`) must move the looked-up depth by
    /// many float32 steps, or rasterisers that round the stored depth a step differently
    /// (NVIDIA's) show shadow acne. With standard depth (near 0, far 1) a floor 1.9 scene units
    /// below a spot under a 4096² map got under one step; reversed depth gives thousands
    /// (docs/performance.md, "On an NVIDIA H100"). Half of the offset runs along the ray to the
    /// light: it lifts the point as far off the surface's plane as the normal offset it
    /// replaced, and moves the lookup (and the shadow edges) sideways half as far.
    #[test]
    fn the_shadow_lookup_offset_spans_many_depth_steps_and_moves_half_as_far_sideways() {
        let lights = [narrow_spot()];
        let camera = DVec3::new(0.0, 0.0, 3.0);
        let s = LightSetup::new(&lights, camera, &unit_bounds(), 4096, 3);
        let (view, light_at) = (s.views[0], Vec3::new(0.0, 0.9, 0.0));
        let ndc = |p: Vec3| {
            let clip = view.view_proj * (p - camera.as_vec3()).extend(1.0);
            clip.truncate() / clip.w
        };
        for x in [0.0f32, 0.05, 0.2, 0.4] {
            let p = Vec3::new(x, -1.0, 0.1);
            let (n, wi) = (Vec3::Y, (light_at - p).normalize());
            let texel = view.params.x * (light_at - p).length();
            let (q, h) = lookup_point(p, n, wi, texel, view.params.z);
            let normal_offset = p + n * h;
            let (a, b, c) = (ndc(p), ndc(q), ndc(normal_offset));
            let step = f32::from_bits(a.z.to_bits() + 1) - a.z;
            let steps = (b.z - a.z).abs() / step;
            assert!(
                (0.0..1.0).contains(&a.z) && steps >= 64.0,
                "x = {x}: depth {}, the offset moves it {steps} float32 steps",
                a.z
            );
            // Sideways (in texels: 4096 over ndc's 2), half the normal offset's.
            let texels = |v: Vec3| (v.truncate() - a.truncate()).length() * 4096.0 / 2.0;
            let (moved, before) = (texels(b), texels(c));
            assert!(
                (moved - 0.5 * before).abs() <= 0.01 * before + 0.002,
                "x = {x}: the lookup moved {moved} texels sideways, the normal offset {before}"
            );
            assert!(
                (n.dot(q - p) - h).abs() < 1e-3 * h,
                "x = {x}: not h off the plane"
            );
        }
    }

    #[test]
    fn cube_faces_cover_every_direction() {
        let lights = [light(LightKind::Point)];
        let s = LightSetup::new(&lights, DVec3::ZERO, &unit_bounds(), 256, 3);
        let pos = DVec3::new(0.0, 0.9, 0.0);
        for d in [
            DVec3::X,
            DVec3::NEG_X,
            DVec3::Y,
            DVec3::NEG_Y,
            DVec3::Z,
            DVec3::NEG_Z,
        ] {
            let p = pos + d * 0.5 + d.any_orthonormal_vector() * 0.2;
            let a = d.abs();
            let face = if a.x > 0.5 {
                if d.x > 0.0 {
                    0
                } else {
                    1
                }
            } else if a.y > 0.5 {
                if d.y > 0.0 {
                    2
                } else {
                    3
                }
            } else if d.z > 0.0 {
                4
            } else {
                5
            };
            let clip = s.view_matrices[face] * p.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            assert!(
                clip.w > 0.0 && ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0,
                "{d}: {ndc}"
            );
        }
    }
}
