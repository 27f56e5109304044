//! Motion: glTF animation clips, the node hierarchy they drive, and the built-in light orbit.
//!
//! ```text
//!   t (seconds) ──► wrapped to the longest clip: t mod D
//!      │
//!   clips: per channel, its sampler at t (STEP, LINEAR with slerp, CUBICSPLINE) replaces one
//!          property (translation, rotation, scale) of its node's rest transform
//!      │
//!   rig: node occurrences, parents first: world = world(parent) × local
//!      │
//!   Pose: instance transforms (world of each instance's node), lights (origin and −Z of their
//!         node), cameras (their node, scale dropped) ──► light orbit: every light's position
//!         and direction turned about +Y through the orbit's centre by 2π·t / period
//! ```
//!
//! One timeline: every clip plays at the same `t`, wrapped modulo the longest clip's duration
//! `D`, so a shorter clip holds its last key until the loop restarts (and the set of poses, which
//! [`Scene::motion_bounds`] samples, repeats with period `D`). Before a sampler's first key it
//! holds the first value (glTF's rule). Two channels targeting the same property of a node: the
//! later one (file order) wins.
//!
//! A node the file animates keeps the scale of its animated transform away from zero
//! ([`MIN_ANIMATED_SCALE`]), so an animated instance always has an invertible transform (glTF
//! files scale to zero to hide things; the BVH and the GPU's normal matrix need an inverse).
//!
//! Nothing here reads glTF: `load.rs` fills [`Animations`] from the file.

use super::{Aabb, Camera, Scene};
use glam::{Mat4, Quat, Vec3, Vec4};

/// Seconds an animation advances per frame where time must not depend on the machine: the
/// viewer's scripted `--frames N` runs and `ispm bench`.
pub const FRAME_STEP_SECONDS: f32 = 1.0 / 60.0;

/// Smallest magnitude of a scale component of a node the file animates.
pub const MIN_ANIMATED_SCALE: f32 = 1e-6;

/// Uniform samples of the timeline [`Scene::motion_bounds`] takes (besides every key time).
const BOUNDS_SAMPLES: usize = 128;

/// Relative padding of the moving instances' box in [`Scene::motion_bounds`]: between samples a
/// rotation sweeps an arc and a cubic spline may overshoot.
const BOUNDS_PADDING: f32 = 0.02;

/// The node property a channel drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Property {
    Translation,
    Rotation,
    Scale,
}

/// How a sampler interpolates between keys (glTF `sampler.interpolation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// The value of the last key at or before `t`.
    Step,
    /// Linear; spherical linear (shortest arc) for rotations.
    Linear,
    /// Cubic Hermite spline with per-key in- and out-tangents (normalised for rotations).
    CubicSpline,
}

/// Keyframes of one property.
///
/// Invariants (established by the loader): at least one key; times finite, ≥ 0 and strictly
/// increasing; `values` holds one entry per key (three for `CubicSpline`: in-tangent, value,
/// out-tangent), all finite; rotation values (not tangents) are unit quaternions.
#[derive(Clone, Debug, PartialEq)]
pub struct Sampler {
    pub interpolation: Interpolation,
    pub times: Vec<f32>,
    /// xyz (w = 0) for translation and scale, xyzw for rotation.
    pub values: Vec<Vec4>,
}

/// One animated property of one node occurrence.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// Index in [`Animations::nodes`].
    pub node: usize,
    pub property: Property,
    pub sampler: Sampler,
}

/// One glTF animation.
#[derive(Clone, Debug, PartialEq)]
pub struct Clip {
    pub name: String,
    pub channels: Vec<Channel>,
    /// The last key time of any of its channels (seconds).
    pub duration: f32,
}

/// A node's transform relative to its parent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LocalTransform {
    Matrix(Mat4),
    Trs {
        translation: Vec3,
        rotation: Quat,
        scale: Vec3,
    },
}

impl LocalTransform {
    /// The matrix; with `keep_invertible`, scale components are kept at least
    /// [`MIN_ANIMATED_SCALE`] in magnitude (a matrix is returned as it is).
    pub fn matrix(&self, keep_invertible: bool) -> Mat4 {
        match *self {
            LocalTransform::Matrix(m) => m,
            LocalTransform::Trs {
                translation,
                rotation,
                scale,
            } => {
                let scale = if keep_invertible {
                    scale.signum() * scale.abs().max(Vec3::splat(MIN_ANIMATED_SCALE))
                } else {
                    scale
                };
                Mat4::from_scale_rotation_translation(scale, rotation, translation)
            }
        }
    }
}

/// One occurrence of a glTF node in the flattened hierarchy.
#[derive(Clone, Debug, PartialEq)]
pub struct RigNode {
    pub name: String,
    /// Index of the parent occurrence (always smaller than this one's).
    pub parent: Option<usize>,
    /// The rest transform (the file's `matrix` or translation/rotation/scale).
    pub local: LocalTransform,
    /// A channel targets this node itself.
    pub targeted: bool,
    /// This node or an ancestor is targeted: its world transform changes with time.
    pub moves: bool,
}

/// `--orbit-lights`: every light turns about the vertical axis through `centre`.
#[derive(Clone, Debug, PartialEq)]
pub struct LightOrbit {
    pub centre: Vec3,
    pub seconds_per_turn: f32,
    /// Each light's (position, direction) when the orbit was added (used when no clip drives
    /// the lights' nodes).
    rest: Vec<(Vec3, Vec3)>,
}

/// Everything that moves a scene; empty for a static one.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Animations {
    pub clips: Vec<Clip>,
    /// The node occurrences of the scene, parents first (empty without clips).
    pub nodes: Vec<RigNode>,
    /// The node of each `Scene::instances` entry (empty without clips).
    pub instance_nodes: Vec<usize>,
    /// The node of each `Scene::lights` entry (empty without clips).
    pub light_nodes: Vec<usize>,
    /// The node of each `Scene::cameras` entry (empty without clips).
    pub camera_nodes: Vec<usize>,
    pub orbit: Option<LightOrbit>,
}

/// Where everything that can move is at one time.
#[derive(Clone, Debug, PartialEq)]
pub struct Pose {
    /// World-from-object transform of every instance, in `Scene::instances` order.
    pub instances: Vec<Mat4>,
    /// Every light, in `Scene::lights` order.
    pub lights: Vec<crate::scene::Light>,
    /// Every file camera, in `Scene::cameras` order.
    pub cameras: Vec<Camera>,
    /// The scene's camera, when it is a file camera that moves.
    pub camera: Option<Camera>,
}

impl Sampler {
    fn value(&self, key: usize) -> Vec4 {
        match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * key + 1],
            _ => self.values[key],
        }
    }

    /// The sampled value at `t` (clamped to the first and last key).
    pub fn sample(&self, t: f32, rotation: bool) -> Vec4 {
        let n = self.times.len();
        if n == 1 || t <= self.times[0] {
            return self.value(0);
        }
        if t >= self.times[n - 1] {
            return self.value(n - 1);
        }
        // times[k] ≤ t < times[k + 1]
        let k = self.times.partition_point(|&x| x <= t) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let dt = t1 - t0;
        let s = ((t - t0) / dt).clamp(0.0, 1.0);
        match self.interpolation {
            Interpolation::Step => self.value(k),
            Interpolation::Linear if rotation => {
                let (a, b) = (
                    Quat::from_vec4(self.value(k)),
                    Quat::from_vec4(self.value(k + 1)),
                );
                Vec4::from(a.slerp(b, s))
            }
            Interpolation::Linear => self.value(k).lerp(self.value(k + 1), s),
            Interpolation::CubicSpline => {
                // glTF 2.0 Appendix C: p(s) = h00·v_k + h10·dt·b_k + h01·v_{k+1} + h11·dt·a_{k+1}.
                let (v0, b0) = (self.values[3 * k + 1], self.values[3 * k + 2]);
                let (a1, v1) = (self.values[3 * (k + 1)], self.values[3 * (k + 1) + 1]);
                let (s2, s3) = (s * s, s * s * s);
                let p = v0 * (2.0 * s3 - 3.0 * s2 + 1.0)
                    + b0 * (dt * (s3 - 2.0 * s2 + s))
                    + v1 * (-2.0 * s3 + 3.0 * s2)
                    + a1 * (dt * (s3 - s2));
                if rotation {
                    // A spline through unit keys can pass near zero with wild tangents.
                    p.try_normalize().unwrap_or(if s < 0.5 { v0 } else { v1 })
                } else {
                    p
                }
            }
        }
    }
}

/// The rigid part of `world` (scale dropped): how the loader places cameras.
pub fn rigid(world: Mat4) -> Mat4 {
    let (_, rotation, translation) = world.to_scale_rotation_translation();
    let rotation = if rotation.is_finite() && rotation.length() > 1e-6 {
        rotation.normalize()
    } else {
        Quat::IDENTITY
    };
    Mat4::from_rotation_translation(rotation, translation)
}

impl Animations {
    /// Nothing moves.
    pub fn is_empty(&self) -> bool {
        self.clips.is_empty() && self.orbit.is_none()
    }

    /// The longest clip's duration: the period of the timeline (0 without clips).
    pub fn duration(&self) -> f32 {
        self.clips.iter().map(|c| c.duration).fold(0.0, f32::max)
    }

    /// The longer of the clips' timeline and the light orbit's turn: one period of each
    /// motion fits in `[0, period]` (0 for a static scene).
    pub fn period(&self) -> f32 {
        let orbit = self.orbit.as_ref().map_or(0.0, |o| o.seconds_per_turn);
        self.duration().max(orbit)
    }

    /// `t` on the clips' timeline: wrapped into `[0, D)`.
    fn clip_time(&self, t: f32) -> f32 {
        let d = self.duration();
        if d > 0.0 && t.is_finite() {
            t.rem_euclid(d)
        } else {
            0.0
        }
    }

    /// World transform of every node occurrence at `t`.
    fn worlds(&self, t: f32) -> Vec<Mat4> {
        let t = self.clip_time(t);
        let mut local: Vec<LocalTransform> = self.nodes.iter().map(|n| n.local).collect();
        for channel in self.clips.iter().flat_map(|c| &c.channels) {
            let rotation = channel.property == Property::Rotation;
            let v = channel.sampler.sample(t, rotation);
            // The loader rejects animated nodes with a matrix.
            if let LocalTransform::Trs {
                translation,
                rotation: r,
                scale,
            } = &mut local[channel.node]
            {
                match channel.property {
                    Property::Translation => *translation = v.truncate(),
                    Property::Rotation => *r = Quat::from_vec4(v),
                    Property::Scale => *scale = v.truncate(),
                }
            }
        }
        let mut world: Vec<Mat4> = Vec::with_capacity(self.nodes.len());
        for (node, local) in self.nodes.iter().zip(&local) {
            let m = local.matrix(node.targeted);
            world.push(match node.parent {
                Some(p) => world[p] * m,
                None => m,
            });
        }
        world
    }

    fn moves(&self, node: Option<&usize>) -> bool {
        node.and_then(|&n| self.nodes.get(n))
            .is_some_and(|n| n.moves)
    }
}

impl Scene {
    /// Something in the scene moves (glTF animations or a light orbit).
    pub fn is_animated(&self) -> bool {
        !self.animations.is_empty()
    }

    /// The instances whose transform changes with time, in instance order.
    pub fn moving_instances(&self) -> Vec<usize> {
        let a = &self.animations;
        (0..self.instances.len())
            .filter(|&i| a.moves(a.instance_nodes.get(i)))
            .collect()
    }

    /// The lights whose position or direction changes with time, in light order.
    pub fn moving_lights(&self) -> Vec<usize> {
        let a = &self.animations;
        (0..self.lights.len())
            .filter(|&i| a.orbit.is_some() || a.moves(a.light_nodes.get(i)))
            .collect()
    }

    /// Turns every light about the vertical axis through the centre of
    /// [`Scene::motion_bounds`], once per `seconds_per_turn` (`--orbit-lights`). Positions and
    /// directions both turn, so a spot keeps aiming at the same height of the axis and a
    /// directional light turns in azimuth.
    pub fn orbit_lights(&mut self, seconds_per_turn: f32) -> anyhow::Result<()> {
        anyhow::ensure!(
            seconds_per_turn.is_finite() && seconds_per_turn > 0.0,
            "a light orbit needs a positive, finite number of seconds per turn, not \
             {seconds_per_turn}"
        );
        let centre = self.motion_bounds().center();
        self.animations.orbit = Some(LightOrbit {
            centre: if centre.is_finite() {
                centre
            } else {
                Vec3::ZERO
            },
            seconds_per_turn,
            rest: self
                .lights
                .iter()
                .map(|l| (l.position, l.direction))
                .collect(),
        });
        Ok(())
    }

    /// Where the instances, lights and cameras are at `t` seconds. Only what moves changes:
    /// a static scene's pose is the scene as it is.
    pub fn pose_at(&self, t: f32) -> Pose {
        let a = &self.animations;
        let worlds = if a.clips.is_empty() {
            Vec::new()
        } else {
            a.worlds(t)
        };
        let node_world = |node: Option<&usize>| node.and_then(|&n| worlds.get(n)).copied();
        let instances = self
            .instances
            .iter()
            .enumerate()
            .map(|(i, inst)| node_world(a.instance_nodes.get(i)).unwrap_or(inst.transform))
            .collect();
        let lights = self
            .lights
            .iter()
            .enumerate()
            .map(|(i, light)| {
                let mut light = light.clone();
                if let Some(world) = node_world(a.light_nodes.get(i)) {
                    light.position = world.transform_point3(Vec3::ZERO);
                    if let Some(d) = world.transform_vector3(Vec3::NEG_Z).try_normalize() {
                        light.direction = d;
                    }
                } else if let Some(&(p, d)) = a.orbit.as_ref().and_then(|o| o.rest.get(i)) {
                    (light.position, light.direction) = (p, d);
                }
                if let Some(orbit) = &a.orbit {
                    let turns = if t.is_finite() {
                        t.rem_euclid(orbit.seconds_per_turn) / orbit.seconds_per_turn
                    } else {
                        0.0
                    };
                    let r = Quat::from_rotation_y(std::f32::consts::TAU * turns);
                    light.position = orbit.centre + r * (light.position - orbit.centre);
                    light.direction = (r * light.direction).normalize_or(light.direction);
                }
                light
            })
            .collect();
        let cameras: Vec<Camera> = self
            .cameras
            .iter()
            .enumerate()
            .map(|(i, camera)| match node_world(a.camera_nodes.get(i)) {
                Some(world) => Camera {
                    transform: rigid(world),
                    ..*camera
                },
                None => *camera,
            })
            .collect();
        // `Scene::camera` is the first file camera (load.rs); it moves with its node.
        let camera = a
            .moves(a.camera_nodes.first())
            .then(|| cameras.first().copied())
            .flatten();
        Pose {
            instances,
            lights,
            cameras,
            camera,
        }
    }

    /// Moves the scene to `pose` (from [`Scene::pose_at`] of this scene).
    pub fn set_pose(&mut self, pose: &Pose) {
        for (inst, &m) in self.instances.iter_mut().zip(&pose.instances) {
            inst.transform = m;
        }
        for (light, posed) in self.lights.iter_mut().zip(&pose.lights) {
            *light = posed.clone();
        }
        for (camera, posed) in self.cameras.iter_mut().zip(&pose.cameras) {
            *camera = *posed;
        }
        if let Some(camera) = pose.camera {
            self.camera = camera;
        }
    }

    /// The scene at `t` seconds (its animations kept, so it can be posed again).
    pub fn posed(&self, t: f32) -> Scene {
        let mut scene = self.clone();
        scene.set_pose(&self.pose_at(t));
        scene
    }

    /// World-space bounds of the geometry over the whole animation: [`Scene::bounds`] for a
    /// scene whose instances do not move; otherwise the static instances' vertices plus the
    /// moving instances' object-space boxes at every key time and at 128 times spread over the
    /// timeline, padded by 2 % of their extent. It does not depend on the pose the scene is in,
    /// so a renderer made at any time of the animation sizes its light views alike.
    pub fn motion_bounds(&self) -> Aabb {
        let moving = self.moving_instances();
        if moving.is_empty() {
            return self.bounds();
        }
        let mut fixed = Aabb::EMPTY;
        for (i, inst) in self.instances.iter().enumerate() {
            if moving.binary_search(&i).is_err() {
                for &p in &self.meshes[inst.mesh].positions {
                    fixed.grow(inst.transform.transform_point3(p));
                }
            }
        }
        let object_boxes: Vec<Aabb> = moving
            .iter()
            .map(|&i| {
                let mut b = Aabb::EMPTY;
                for &p in &self.meshes[self.instances[i].mesh].positions {
                    b.grow(p);
                }
                b
            })
            .collect();
        let a = &self.animations;
        let d = a.duration();
        let mut times: Vec<f32> = (0..=BOUNDS_SAMPLES)
            .map(|k| d * k as f32 / BOUNDS_SAMPLES as f32)
            .collect();
        for clip in &a.clips {
            for channel in &clip.channels {
                times.extend(channel.sampler.times.iter().copied().filter(|&t| t <= d));
            }
        }
        let mut swept = Aabb::EMPTY;
        for t in times {
            let worlds = a.worlds(t);
            for (&i, b) in moving.iter().zip(&object_boxes) {
                let Some(&m) = a.instance_nodes.get(i).and_then(|&n| worlds.get(n)) else {
                    continue;
                };
                for k in 0..8 {
                    let pick = |bit: usize, lo: f32, hi: f32| if k & bit == 0 { lo } else { hi };
                    let corner = Vec3::new(
                        pick(1, b.min.x, b.max.x),
                        pick(2, b.min.y, b.max.y),
                        pick(4, b.min.z, b.max.z),
                    );
                    swept.grow(m.transform_point3(corner));
                }
            }
        }
        if !swept.is_empty() {
            let pad = swept.extent() * BOUNDS_PADDING;
            fixed.grow(swept.min - pad);
            fixed.grow(swept.max + pad);
        }
        fixed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampler(interpolation: Interpolation, times: &[f32], values: &[Vec4]) -> Sampler {
        Sampler {
            interpolation,
            times: times.to_vec(),
            values: values.to_vec(),
        }
    }

    #[test]
    fn step_holds_and_linear_interpolates_and_both_clamp_outside_the_keys() {
        let values = [Vec4::ZERO, Vec4::new(2.0, 4.0, 6.0, 0.0)];
        let step = sampler(Interpolation::Step, &[1.0, 2.0], &values);
        let linear = sampler(Interpolation::Linear, &[1.0, 2.0], &values);
        assert_eq!(step.sample(1.75, false), Vec4::ZERO);
        assert_eq!(step.sample(2.0, false), values[1]);
        assert_eq!(linear.sample(1.25, false), Vec4::new(0.5, 1.0, 1.5, 0.0));
        assert_eq!(
            linear.sample(0.0, false),
            Vec4::ZERO,
            "before the first key"
        );
        assert_eq!(linear.sample(9.0, false), values[1], "after the last key");
    }

    #[test]
    fn linear_rotation_is_the_shortest_arc_at_constant_angular_speed() {
        let a = Quat::IDENTITY;
        let b = Quat::from_rotation_y(1.2);
        // The same rotation written as −b: slerp must still take the short way.
        let s = sampler(
            Interpolation::Linear,
            &[0.0, 1.0],
            &[Vec4::from(a), -Vec4::from(b)],
        );
        let q = Quat::from_vec4(s.sample(0.25, true));
        let expect = Quat::from_rotation_y(0.3);
        assert!(q.angle_between(expect) < 1e-5, "{q:?}");
    }

    #[test]
    fn cubic_spline_follows_the_hermite_basis_and_its_tangents() {
        // y(s) over one unit interval with v0 = 0, v1 = 1, out-tangent b0 = 3, in-tangent a1 = 0:
        // p(s) = 3(s³ − 2s² + s) + (−2s³ + 3s²).
        let v = |y: f32| Vec4::new(0.0, y, 0.0, 0.0);
        let s = sampler(
            Interpolation::CubicSpline,
            &[0.0, 2.0],
            &[v(9.0), v(0.0), v(3.0), v(0.0), v(1.0), v(9.0)],
        );
        for k in 0..=4 {
            let x = k as f32 / 4.0;
            let expect =
                3.0 * (x * x * x - 2.0 * x * x + x) * 2.0 + (-2.0 * x * x * x + 3.0 * x * x);
            let got = s.sample(2.0 * x, false).y;
            assert!((got - expect).abs() < 1e-5, "s = {x}: {got} vs {expect}");
        }
        // Keys are hit exactly; the in-tangent of the first and out-tangent of the last are
        // unused.
        assert_eq!(s.sample(0.0, false), v(0.0));
        assert_eq!(s.sample(2.0, false), v(1.0));
    }

    #[test]
    fn a_cubic_rotation_through_zero_stays_a_unit_quaternion() {
        // Keys q and −q with zero tangents: the spline passes through 0 at s = ½.
        let (q, z) = (Vec4::W, Vec4::ZERO);
        let s = sampler(
            Interpolation::CubicSpline,
            &[0.0, 1.0],
            &[z, q, z, z, -q, z],
        );
        let r = s.sample(0.5, true);
        assert!(r.is_finite() && (r.length() - 1.0).abs() < 1e-6, "{r:?}");
    }

    #[test]
    fn animated_zero_scale_stays_invertible() {
        let l = LocalTransform::Trs {
            translation: Vec3::ONE,
            rotation: Quat::IDENTITY,
            scale: Vec3::new(0.0, -0.0, 2.0),
        };
        assert_eq!(l.matrix(false).determinant(), 0.0);
        let m = l.matrix(true);
        assert!(m.determinant().abs() > 0.0 && m.inverse().is_finite());
    }
}
