//! The light a scene gets when its file brings none (issue #18): a key light over the camera's
//! shoulder, so that a glTF file with no light and no emissive surface is never a black picture.
//!
//! The rule ([`Scene::needs_default_light`]): no KHR_lights_punctual light and no instance
//! whose material emits ([`Material::is_emitter`](super::Material::is_emitter); unlit
//! materials do not count, their emission is only their displayed colour). The loader adds the
//! light when [`LoadOptions::default_light`](super::load::LoadOptions) asks (the command line
//! does, unless `--no-default-light`), so every method renders the same light.
//!
//! The light ([`key_light`]), from the camera the scene starts at and the scene's bounds:
//!
//! ```text
//!   aim point   t = eye + forward · max(forward · (centre − eye), R/4)   (R: bounds' radius)
//!   position    p = t + |t − eye| · normalize(−forward + 0.6·up + 0.35·right)
//!               (about 30° above and 20° to the right of the view axis, as far from t as the
//!               eye; kept inside the bounds, 5 % in from their faces, when the eye is inside)
//!   spot cone   outer = min(60°, 1.1 · (angle(t − p, centre − p) + asin(R / |centre − p|)) + 2°),
//!               60° when p is inside the bounding sphere; inner = 0.8 · outer
//!   intensity   I = π · |t − p|² W/sr, white
//! ```
//!
//! so the irradiance at the aim point, on a surface facing the light, is π W/m²: a Lambertian
//! surface of albedo ρ there has radiance ρ W/(m²·sr), which the default tonemap (PBR Neutral)
//! at 0 EV shows at about ρ, the way an unlit material of base colour ρ is shown. A 60° cone is
//! the widest one shadow view covers (`plan/lighting.rs`), so the light costs one shadow map and one
//! light G-buffer, like a file's spot light.

use super::{Aabb, Camera, Light, LightKind, Scene};
use glam::Vec3;
use std::f32::consts::{FRAC_PI_3, PI};

/// Name of the default light (in `ispm plan`, the stats and the viewer's overlay).
pub const DEFAULT_LIGHT_NAME: &str = "default key light";

/// Irradiance, W/m², the default light delivers at its aim point on a surface facing it.
pub const DEFAULT_LIGHT_IRRADIANCE: f32 = PI;

/// Widest outer cone angle of the default light (one shadow view).
const MAX_CONE: f32 = FRAC_PI_3;

impl Scene {
    /// True when some instance's material emits light ([`super::Material::is_emitter`]).
    pub fn has_emitter(&self) -> bool {
        self.instances.iter().any(|inst| {
            let mesh = &self.meshes[inst.mesh];
            self.materials
                .get(mesh.material)
                .is_some_and(|m| m.is_emitter())
        })
    }

    /// True when nothing in the scene gives light: no punctual light, no emitter.
    pub fn needs_default_light(&self) -> bool {
        self.lights.is_empty() && !self.has_emitter()
    }

    /// Adds the default key light, placed for [`Scene::camera`], when the scene
    /// [needs one](Scene::needs_default_light); returns whether it did.
    pub fn add_default_light(&mut self) -> bool {
        if !self.needs_default_light() {
            return false;
        }
        self.lights
            .push(key_light(&self.camera, self.motion_bounds()));
        self.default_light = true;
        true
    }

    /// Places the default light again for [`Scene::camera`] (after the camera was changed,
    /// `--camera N`); does nothing when the scene has no default light.
    pub fn aim_default_light(&mut self) {
        if self.default_light && !self.lights.is_empty() {
            self.lights[0] = key_light(&self.camera, self.motion_bounds());
        }
    }
}

/// The default key light for a scene with `bounds` seen from `camera` (see the module docs).
pub fn key_light(camera: &Camera, bounds: Aabb) -> Light {
    let eye = camera.position();
    let forward = camera
        .transform
        .transform_vector3(Vec3::NEG_Z)
        .normalize_or(Vec3::NEG_Z);
    let right = camera
        .transform
        .transform_vector3(Vec3::X)
        .normalize_or(Vec3::X);
    let (centre, radius) = if bounds.is_empty() {
        (eye + 5.0 * forward, 1.0)
    } else {
        (bounds.center(), (0.5 * bounds.extent().length()).max(1e-3))
    };
    let depth = forward.dot(centre - eye).max(0.25 * radius);
    let aim = eye + depth * forward;
    let offset = (-forward + 0.6 * Vec3::Y + 0.35 * right).normalize_or(Vec3::Y);
    let mut position = aim + depth * offset;
    let inside = !bounds.is_empty() && eye.cmpge(bounds.min).all() && eye.cmple(bounds.max).all();
    if inside {
        let margin = 0.05 * bounds.extent();
        position = position.clamp(bounds.min + margin, bounds.max - margin);
    }
    let to_aim = aim - position;
    let distance = to_aim.length().max(1e-3 * radius);
    let direction = to_aim.normalize_or(forward);
    let to_centre = centre - position;
    let outer = if to_centre.length() <= radius {
        MAX_CONE
    } else {
        let off_axis = direction.angle_between(to_centre.normalize());
        let half = (radius / to_centre.length()).asin();
        (1.1 * (off_axis + half) + 2f32.to_radians()).min(MAX_CONE)
    };
    Light {
        name: DEFAULT_LIGHT_NAME.to_string(),
        kind: LightKind::Spot {
            inner_cone_angle: 0.8 * outer,
            outer_cone_angle: outer,
        },
        position,
        direction,
        intensity: Vec3::splat(DEFAULT_LIGHT_IRRADIANCE * distance * distance),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Instance, Material, Mesh};
    use glam::Mat4;

    fn unit_box() -> Aabb {
        Aabb {
            min: Vec3::splat(-1.0),
            max: Vec3::ONE,
        }
    }

    /// Irradiance from `light` at `p` on a surface facing it (inside the inner cone).
    fn irradiance_at(light: &Light, p: Vec3) -> f32 {
        light.intensity.x / light.position.distance_squared(p)
    }

    #[test]
    fn key_light_sits_above_behind_the_framing_camera_and_gives_pi_at_the_centre() {
        let bounds = unit_box();
        let camera = Camera::framing(bounds);
        let light = key_light(&camera, bounds);
        assert!(light.position.y > camera.position().y, "above the camera");
        assert!(light.position.z > 0.0, "on the camera's side of the scene");
        let to_centre = (bounds.center() - light.position).normalize();
        assert!(light.direction.dot(to_centre) > 0.999, "aims at the centre");
        assert!((irradiance_at(&light, Vec3::ZERO) - PI).abs() < 1e-3);
        let LightKind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } = light.kind
        else {
            panic!("a spot light");
        };
        assert!(inner_cone_angle < outer_cone_angle && outer_cone_angle <= MAX_CONE);
        // The cone covers the whole bounding sphere.
        let dist = light.position.length();
        assert!(outer_cone_angle >= (3f32.sqrt() / dist).asin());
    }

    #[test]
    fn key_light_of_a_camera_inside_the_scene_stays_inside_and_is_widest() {
        let bounds = Aabb {
            min: Vec3::new(-5.0, 0.0, -5.0),
            max: Vec3::new(5.0, 3.0, 5.0),
        };
        let camera = Camera {
            transform: Mat4::from_translation(Vec3::new(0.0, 1.5, 4.0)),
            ..Camera::default()
        };
        let light = key_light(&camera, bounds);
        assert!(light.position.cmpgt(bounds.min).all() && light.position.cmplt(bounds.max).all());
        assert!(
            matches!(light.kind, LightKind::Spot { outer_cone_angle, .. } if outer_cone_angle == MAX_CONE)
        );
        assert!(light.intensity.is_finite() && light.intensity.x > 0.0);
    }

    #[test]
    fn key_light_of_an_empty_scene_is_finite() {
        let light = key_light(&Camera::framing(Aabb::EMPTY), Aabb::EMPTY);
        assert!(light.position.is_finite() && light.direction.is_finite());
        assert!(light.intensity.is_finite() && light.intensity.x > 0.0);
    }

    fn one_triangle(material: Material) -> Scene {
        Scene {
            meshes: vec![Mesh {
                positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
                normals: vec![Vec3::Z; 3],
                uvs: vec![glam::Vec2::ZERO; 3],
                triangles: vec![[0, 1, 2]],
                ..Mesh::default()
            }],
            instances: vec![Instance {
                name: "t".into(),
                mesh: 0,
                transform: Mat4::IDENTITY,
            }],
            materials: vec![material],
            ..Scene::default()
        }
    }

    #[test]
    fn only_a_scene_without_lights_and_emitters_gets_the_default_light() {
        let mut plain = one_triangle(Material::default());
        assert!(plain.add_default_light());
        assert!(plain.default_light && plain.lights.len() == 1);
        assert!(!plain.add_default_light(), "added once");

        let glowing = Material {
            emission: Vec3::splat(2.0),
            ..Material::default()
        };
        let mut lamp = one_triangle(glowing.clone());
        assert!(!lamp.add_default_light(), "an emitter lights the scene");

        let mut unlit = one_triangle(Material {
            unlit: true,
            ..glowing.clone()
        });
        assert!(unlit.add_default_light(), "an unlit colour is no light");

        // An emissive material no instance uses does not count.
        let mut unused = one_triangle(Material::default());
        unused.materials.push(glowing);
        assert!(unused.add_default_light());
    }
}
