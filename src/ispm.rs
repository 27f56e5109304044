//! The CPU side of Image Space Photon Mapping: how the photon budget becomes light-G-buffer
//! views (DESIGN.md §2.3), and how the bounce map read back from the GPU becomes the photon map
//! (§2, step 4).
//!
//! ```text
//!   photons N ──► light L gets N·Φ_L/Φ_total ──► per view: res = ⌈√(N_L / views_L)⌉
//!   bounce map (GPU) ──readback──► texel ray + depth → hit point ──► trace_photons ──► photon map
//! ```
//!
//! **Exact power.** A perspective texel carries I · Ω_texel · falloff, with Ω_texel the texel's
//! area on the plane at unit distance foreshortened by (1 + x² + y²)^(-3/2). That is exact to
//! second order; the per-light factor [`BouncePlan`] folds into the intensity makes the sum
//! over all of a light's texels equal its exact flux (4πI for a point light, 2πI·∫falloff for a
//! spot, E·area of the orthographic window for a directional light), so the photons a light
//! emits always carry exactly its power, whatever the resolution ("rescaled for the rounding").

use crate::layout::{BounceView, FrameUniforms, LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT};
use crate::lighting::LightSetup;
use crate::photon::emit::{photon_budget_among, spot_falloff, spot_falloff_integral};
use crate::photon::rng::hash_vec3;
use crate::photon::trace::PhotonState;
use crate::photon::types::BounceMapPhoton;
use crate::scene::{Aabb, LightKind, Scene};
use glam::{DMat4, DVec2, DVec3, DVec4, UVec4, Vec4};

/// Largest light-G-buffer resolution per view (texels per side).
pub const MAX_RESOLUTION: u32 = 2048;

/// The light views of one frame's photon emission.
#[derive(Clone, Debug, Default)]
pub struct BouncePlan {
    pub views: Vec<BounceView>,
    /// Camera-relative world → light clip, per view.
    pub view_matrices: Vec<DMat4>,
    /// The light G-buffer raster's uniforms, per view.
    pub uniforms: Vec<FrameUniforms>,
    /// Texels per side of each view (0 for lights that get no photons).
    pub resolutions: Vec<u32>,
    pub max_resolution: u32,
    /// Bounce-map records in all (Σ resolution²).
    pub texels: usize,
    /// The camera position the matrices are relative to.
    pub camera: DVec3,
}

fn unproject(inverse: &DMat4, ndc: DVec2, z: f64) -> DVec3 {
    let h = *inverse * DVec4::new(ndc.x, ndc.y, z, 1.0);
    h.truncate() / h.w
}

/// NDC of the centre of texel (x, y) of a `res`² view (row 0 at NDC y = −1, as Vulkan).
fn texel_ndc(x: u32, y: u32, res: u32) -> DVec2 {
    let r = f64::from(res);
    DVec2::new(
        (f64::from(x) + 0.5) / r * 2.0 - 1.0,
        (f64::from(y) + 0.5) / r * 2.0 - 1.0,
    )
}

impl BouncePlan {
    /// Plans `photons` photons over the lights of `scene` for a camera at `camera`.
    pub fn new(scene: &Scene, camera: DVec3, bounds: &Aabb, photons: usize) -> BouncePlan {
        Self::active(
            scene,
            &vec![true; scene.lights.len()],
            camera,
            bounds,
            photons,
        )
    }

    /// [`BouncePlan::new`] over the lights with `active[i]` only (the effects plan's photon
    /// mask, `plan::EffectsPlan::photon_mask`): the others get no views, no light G-buffer
    /// layer and no bounce-map texels, and the whole budget is split over the active ones by
    /// power. A light missing from `active` is inactive.
    pub fn active(
        scene: &Scene,
        active: &[bool],
        camera: DVec3,
        bounds: &Aabb,
        photons: usize,
    ) -> BouncePlan {
        // Shadow views are the light G-buffer's views; with resolution 1 their texel parameter
        // is the full window: 2·tan(fov/2) (perspective) or 2·radius (orthographic).
        let setup = LightSetup::new(&scene.lights, camera, bounds, 1, 0);
        let budget = photon_budget_among(scene, photons, active);
        let mut plan = BouncePlan {
            camera,
            ..Default::default()
        };
        let lights = scene.lights.iter().zip(&setup.lights).zip(&budget);
        for (i, ((light, gpu_light), &n)) in lights.enumerate() {
            if active.get(i) != Some(&true) {
                continue;
            }
            let first = gpu_light.shadow.y as usize;
            let count = gpu_light.shadow.z as usize;
            let res = if n == 0 || count == 0 {
                0
            } else {
                ((n as f64 / count as f64).sqrt().ceil() as u32).clamp(1, MAX_RESOLUTION)
            };
            let kind = gpu_light.shadow.x;
            let (cos_outer, cos_inner) = (gpu_light.direction.w, gpu_light.intensity.w);
            let axis = gpu_light.direction.truncate().as_dvec3();
            let ortho = kind == LIGHT_DIRECTIONAL;
            // Σ over the light's texels of the per-texel weight the shader uses.
            let mut sum = 0.0f64;
            let mut params = Vec::with_capacity(count);
            for v in first..first + count {
                let m = setup.view_matrices[v];
                let window = f64::from(setup.views[v].params.x);
                let param = if ortho {
                    (window / f64::from(res.max(1))).powi(2)
                } else {
                    window * 0.5
                };
                params.push(param);
                if res == 0 {
                    continue;
                }
                if ortho {
                    sum += param * f64::from(res * res);
                    continue;
                }
                let inverse = m.inverse();
                let side = 2.0 * param / f64::from(res);
                for y in 0..res {
                    for x in 0..res {
                        let ndc = texel_ndc(x, y, res);
                        let q = ndc * param;
                        let mut w = side * side / (1.0 + q.length_squared()).powf(1.5);
                        if kind == LIGHT_SPOT {
                            let dir = (unproject(&inverse, ndc, 1.0)
                                - unproject(&inverse, ndc, 0.0))
                            .normalize();
                            w *=
                                f64::from(spot_falloff(cos_inner, cos_outer, axis.dot(dir) as f32));
                        }
                        sum += w;
                    }
                }
            }
            let exact = match light.kind {
                LightKind::Point => 4.0 * std::f64::consts::PI,
                LightKind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } => {
                    std::f64::consts::TAU
                        * f64::from(spot_falloff_integral(inner_cone_angle, outer_cone_angle))
                }
                LightKind::Directional => sum,
            };
            let scale = if sum > 0.0 { exact / sum } else { 0.0 };
            let light_rel = (light.position.as_dvec3() - camera).as_vec3();
            let seed = hash_vec3(light.position);
            for (k, v) in (first..first + count).enumerate() {
                let m = setup.view_matrices[v];
                plan.views.push(BounceView {
                    inv_view_proj: m.inverse().as_mat4(),
                    light: light_rel.extend(0.0),
                    axis: gpu_light.direction,
                    intensity: (light.intensity * scale as f32).extend(cos_inner),
                    params: Vec4::new(params[k] as f32, if ortho { 1.0 } else { 0.0 }, 0.0, 0.0),
                    texels: UVec4::new(res, plan.texels as u32, kind, seed),
                });
                let viewer = if ortho {
                    (-axis).as_vec3().extend(0.0)
                } else {
                    light_rel.extend(1.0)
                };
                plan.uniforms.push(FrameUniforms {
                    view_proj: m.as_mat4(),
                    inv_view_proj: m.inverse().as_mat4(),
                    camera_pos: camera.as_vec3().extend(1.0),
                    counts: UVec4::new(0, 0, res, res),
                    params: Vec4::ZERO,
                    viewer,
                });
                plan.view_matrices.push(m);
                plan.resolutions.push(res);
                plan.texels += (res * res) as usize;
                plan.max_resolution = plan.max_resolution.max(res);
            }
            debug_assert!(kind == LIGHT_POINT || kind == LIGHT_SPOT || ortho);
        }
        plan
    }

    /// The photons to continue on the CPU: every bounce-map record with power, placed at the
    /// hit point its texel ray and depth describe (in world space).
    pub fn photon_starts(&self, bounce_map: &[BounceMapPhoton]) -> Vec<PhotonState> {
        let mut starts = Vec::new();
        for (v, view) in self.views.iter().enumerate() {
            let res = view.texels.x;
            if res == 0 {
                continue;
            }
            let inverse = self.view_matrices[v].inverse();
            let offset = view.texels.y as usize;
            for y in 0..res {
                for x in 0..res {
                    let Some(p) = bounce_map.get(offset + (y * res + x) as usize) else {
                        continue;
                    };
                    if p.power.max_element().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
                    {
                        continue;
                    }
                    let ndc = texel_ndc(x, y, res);
                    let near = unproject(&inverse, ndc, 0.0);
                    let dir = (unproject(&inverse, ndc, 1.0) - near).normalize();
                    let hit = near + dir * f64::from(p.depth) + self.camera;
                    if let Some(s) = PhotonState::from_bounce_map(p, hit.as_vec3()) {
                        starts.push(s);
                    }
                }
            }
        }
        starts
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::emit::photon_budget;
    use crate::scene::{Light, Scene};
    use glam::Vec3;

    fn scene_with(lights: Vec<Light>) -> Scene {
        let mut s = crate::photon::shapes::scene_of(vec![(
            crate::photon::shapes::icosphere(2),
            glam::Mat4::IDENTITY,
        )]);
        s.lights = lights;
        s
    }

    /// A point light (6 views) and a spot light (1 view) ten times as intense, at the origin.
    fn point_and_spot() -> Scene {
        let point = Light {
            name: "p".into(),
            kind: LightKind::Point,
            position: Vec3::ZERO,
            direction: Vec3::NEG_Y,
            intensity: Vec3::splat(3.0),
        };
        let spot = Light {
            name: "s".into(),
            kind: LightKind::Spot {
                inner_cone_angle: 0.3,
                outer_cone_angle: 0.5,
            },
            intensity: Vec3::splat(30.0),
            ..point.clone()
        };
        scene_with(vec![point, spot])
    }

    #[test]
    fn photon_budget_sets_view_resolutions_and_texel_offsets() {
        let scene = point_and_spot();
        let plan = BouncePlan::new(&scene, DVec3::new(0.0, 0.0, 5.0), &scene.bounds(), 60_000);
        assert_eq!(plan.views.len(), 7);
        // Every light gets about its share; the realised texels are at least the budget.
        let budget = photon_budget(&scene, 60_000);
        let point_texels: u32 = plan.resolutions[..6].iter().map(|r| r * r).sum();
        let spot_texels = plan.resolutions[6] * plan.resolutions[6];
        assert!(
            point_texels as usize >= budget[0],
            "{point_texels} < {}",
            budget[0]
        );
        assert!(
            spot_texels as usize >= budget[1],
            "{spot_texels} < {}",
            budget[1]
        );
        let mut offset = 0;
        for v in &plan.views {
            assert_eq!(v.texels.y as usize, offset);
            offset += (v.texels.x * v.texels.x) as usize;
        }
        assert_eq!(plan.texels, offset);
    }

    #[test]
    fn inactive_lights_get_no_views_and_their_budget_goes_to_the_others() {
        let scene = point_and_spot();
        let camera = DVec3::new(0.0, 0.0, 5.0);
        let all = BouncePlan::new(&scene, camera, &scene.bounds(), 60_000);
        let spot_only = BouncePlan::active(&scene, &[false, true], camera, &scene.bounds(), 60_000);
        assert_eq!(spot_only.views.len(), 1);
        let res = spot_only.resolutions[0];
        assert!(res * res >= 60_000, "{res}² < the whole budget");
        assert!(res > all.resolutions[6], "the spot got no more photons");
        // The same light, the same seed and window: only the resolution changed.
        assert_eq!(spot_only.views[0].texels.w, all.views[6].texels.w);
        assert_eq!(spot_only.view_matrices[0], all.view_matrices[6]);
        assert_eq!(spot_only.texels, (res * res) as usize);
        let none = BouncePlan::active(&scene, &[], camera, &scene.bounds(), 60_000);
        assert!(none.views.is_empty() && none.texels == 0);
    }

    #[test]
    fn a_photon_start_lands_where_its_texel_ray_and_depth_say() {
        let light = Light {
            name: "p".into(),
            kind: LightKind::Point,
            position: Vec3::new(0.2, 0.1, -0.3),
            direction: Vec3::NEG_Y,
            intensity: Vec3::ONE,
        };
        let scene = scene_with(vec![light]);
        let camera = DVec3::new(1.0, 2.0, 5.0);
        let plan = BouncePlan::new(&scene, camera, &scene.bounds(), 600);
        let res = plan.resolutions[0];
        let mut map = vec![
            BounceMapPhoton {
                power: Vec3::ZERO,
                direction: Vec3::ZERO,
                eta: 1.0,
                depth: 0.0,
            };
            plan.texels
        ];
        let (x, y) = (res / 3, res / 2);
        map[(y * res + x) as usize] = BounceMapPhoton {
            power: Vec3::ONE,
            direction: crate::photon::types::pack_direction(Vec3::Y, 0.5),
            eta: 1.0,
            depth: 0.7,
        };
        let starts = plan.photon_starts(&map);
        assert_eq!(starts.len(), 1);
        let from_light = starts[0].origin - Vec3::new(0.2, 0.1, -0.3);
        assert!(
            (from_light.length() - 0.7).abs() < 1e-3,
            "{}",
            from_light.length()
        );
    }
}
