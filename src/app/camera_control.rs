//! The viewer's camera: fly controls and the scripted path of `ispm view --frames`, as plain
//! functions of key state, mouse motion and frame numbers. No window: `viewer.rs` feeds it
//! winit's events, `ispm render --camera-path-frame` the same frame numbers, and the tests
//! below drive it directly.
//!
//! ```text
//!   W A S D (camera plane), Q E (world down, up) ──► MoveKeys::direction (unit)
//!        ──► position += direction × speed × dt
//!   right button held, cursor moves (dx, dy) px ──► yaw −= k·dx, pitch −= k·dy (|pitch| ≤ 89°)
//!        ──► orientation = R_y(yaw) · R_x(pitch) · R_z(roll)   (roll: the file camera's, kept)
//!   wheel ──► speed × 1.25 per notch         F ──► back away along the view until the bounds fit
//!   C, --camera N ──► the file's camera      --frames N ──► scripted_pose(start, bounds, frame)
//!
//!   scripted path, seen from above:                 frame k:  θ_k = 0.3 rad · sin(2πk / 240)
//!                  pivot ●                                    d_k = 0.25 · (1 − cos(2πk / 360)) / 2
//!                 ╱  │  ╲  θ_k: swing about the vertical through the pivot
//!         eye_k ○    │    ○ (the eye keeps looking at it)
//!                    ○ start     d_k: share of the distance to the pivot moved towards it
//! ```
//!
//! A camera is exactly the file's until it is moved: moving translates its transform, and only
//! looking around rebuilds the rotation from yaw, pitch and roll. A moved camera's near plane is
//! at most [`NEAR_FRACTION`] of the scene's diagonal, so flying close to a surface does not clip
//! it (with reversed-Z and an infinite far plane, a small near plane costs no depth precision).
//! The photon volumes need nothing from the camera here: they draw their back faces with a
//! reversed depth test, so a camera inside a volume, or a volume cut by the near plane, still
//! lights the surface (docs/overview.md, "Photon volumes").

use crate::scene::{Aabb, Camera};
use glam::{DQuat, DVec3, EulerRot, Mat4, Quat, Vec3};

/// Radians of yaw or pitch per pixel the cursor moves while the right button is held.
pub const LOOK_RADIANS_PER_PIXEL: f32 = 0.003;
/// Fly speed factor per wheel notch.
pub const SPEED_STEP: f32 = 1.25;
/// The fly speed a scene starts with, in scene diagonals per second.
pub const SPEED_DIAGONALS_PER_SECOND: f32 = 0.25;
/// Slowest and fastest fly speed, in scene diagonals per second.
pub const SPEED_RANGE: (f32, f32) = (1e-4, 1e2);
/// Steepest pitch mouse look reaches (short of straight up or down, where yaw is undefined).
pub const MAX_PITCH: f32 = 89.0 * std::f32::consts::PI / 180.0;
/// A moved camera's near plane is at most this share of the scene's diagonal.
pub const NEAR_FRACTION: f32 = 1e-3;
/// The scripted path's swing about the pivot (radians) and its period (frames).
pub const PATH_SWING: (f64, f64) = (0.3, 240.0);
/// The scripted path's dolly towards the pivot (largest share of the distance) and its period.
pub const PATH_DOLLY: (f64, f64) = (0.25, 360.0);

/// Which movement keys are held.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MoveKeys {
    /// W
    pub forward: bool,
    /// S
    pub back: bool,
    /// A
    pub left: bool,
    /// D
    pub right: bool,
    /// E
    pub up: bool,
    /// Q
    pub down: bool,
}

impl MoveKeys {
    /// The direction the keys ask for, as (right, world up, forward) components of unit
    /// length; opposite keys cancel; zero when nothing (or only opposites) is held.
    pub fn direction(&self) -> Vec3 {
        let axis = |plus: bool, minus: bool| f32::from(u8::from(plus)) - f32::from(u8::from(minus));
        Vec3::new(
            axis(self.right, self.left),
            axis(self.up, self.down),
            axis(self.forward, self.back),
        )
        .normalize_or_zero()
    }

    pub fn any(&self) -> bool {
        self.direction() != Vec3::ZERO
    }
}

/// The camera's rotation as yaw (about world +Y), pitch (about its own +X, up positive) and
/// roll, in that order: R = R_y(yaw) · R_x(pitch) · R_z(roll).
fn euler(transform: &Mat4) -> (f32, f32, f32) {
    let (_, rotation, _) = transform.to_scale_rotation_translation();
    rotation.to_euler(EulerRot::YXZ)
}

/// The camera's unit forward direction (its −Z axis).
pub fn forward(camera: &Camera) -> Vec3 {
    (-camera.transform.z_axis.truncate()).normalize_or(Vec3::NEG_Z)
}

/// The near plane of a moved camera in a scene of `bounds`: the camera's own, at most
/// [`NEAR_FRACTION`] of the diagonal.
pub fn fly_near(camera: &Camera, bounds: &Aabb) -> f32 {
    if bounds.is_empty() {
        return camera.znear;
    }
    let limit = NEAR_FRACTION * bounds.extent().length();
    if limit.is_finite() && limit > 0.0 {
        camera.znear.min(limit)
    } else {
        camera.znear
    }
}

/// The distance from which a sphere of `radius` fills the view of a camera with vertical field
/// of view `yfov` and aspect ratio `aspect` (width / height) along its narrower side.
pub fn framing_distance(radius: f32, yfov: f32, aspect: f32) -> f32 {
    let half_y = 0.5 * yfov;
    let half_x = (half_y.tan() * aspect.max(1e-6)).atan();
    radius / half_y.min(half_x).sin()
}

/// A fly-through camera: the current pose plus what mouse look and the wheel change.
#[derive(Clone, Debug)]
pub struct FlyCamera {
    camera: Camera,
    yaw: f32,
    pitch: f32,
    roll: f32,
    /// Metres per second.
    speed: f32,
    bounds: Aabb,
}

impl FlyCamera {
    /// Starts at `camera` in a scene of `bounds`, at [`SPEED_DIAGONALS_PER_SECOND`].
    pub fn new(camera: Camera, bounds: Aabb) -> Self {
        let (yaw, pitch, roll) = euler(&camera.transform);
        let speed = SPEED_DIAGONALS_PER_SECOND * Self::diagonal(&bounds);
        Self {
            camera,
            yaw,
            pitch,
            roll,
            speed,
            bounds,
        }
    }

    fn diagonal(bounds: &Aabb) -> f32 {
        let d = bounds.extent().length();
        if bounds.is_empty() || !d.is_finite() || d <= 0.0 {
            1.0
        } else {
            d
        }
    }

    /// The camera to render from now.
    pub fn camera(&self) -> Camera {
        self.camera
    }

    /// Jumps to `camera` (`C`: one of the file's cameras), exactly; the speed stays.
    pub fn jump_to(&mut self, camera: Camera) {
        *self = Self {
            speed: self.speed,
            ..Self::new(camera, self.bounds)
        };
    }

    /// Metres per second.
    pub fn speed(&self) -> f32 {
        self.speed
    }

    /// Moves for `dt` seconds the way `keys` ask; returns whether the camera moved.
    pub fn fly(&mut self, keys: &MoveKeys, dt: f32) -> bool {
        let d = keys.direction();
        if d == Vec3::ZERO || dt.is_nan() || dt <= 0.0 {
            return false;
        }
        let t = &self.camera.transform;
        let right = t.x_axis.truncate().normalize_or(Vec3::X);
        let step = (right * d.x + Vec3::Y * d.y + forward(&self.camera) * d.z) * self.speed * dt;
        if !step.is_finite() {
            return false;
        }
        self.camera.transform.w_axis += step.extend(0.0);
        self.camera.znear = fly_near(&self.camera, &self.bounds);
        true
    }

    /// Mouse look: the cursor moved (`dx`, `dy`) pixels (right, down) with the right button
    /// held. Yaw turns about world +Y, pitch about the camera's own X axis, clamped to
    /// ±[`MAX_PITCH`]; roll stays. Returns whether the camera turned.
    pub fn look(&mut self, dx: f32, dy: f32) -> bool {
        if !(dx.is_finite() && dy.is_finite()) || (dx == 0.0 && dy == 0.0) {
            return false;
        }
        self.yaw -= dx * LOOK_RADIANS_PER_PIXEL;
        self.yaw = self.yaw.rem_euclid(std::f32::consts::TAU);
        self.pitch = (self.pitch - dy * LOOK_RADIANS_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
        let rotation = Quat::from_euler(EulerRot::YXZ, self.yaw, self.pitch, self.roll);
        self.camera.transform = Mat4::from_rotation_translation(rotation, self.camera.position());
        self.camera.znear = fly_near(&self.camera, &self.bounds);
        true
    }

    /// The wheel turned by `notches` (positive: away from the user): the speed is multiplied
    /// by [`SPEED_STEP`] per notch, within [`SPEED_RANGE`] diagonals per second.
    pub fn scroll(&mut self, notches: f32) {
        if !notches.is_finite() {
            return;
        }
        let diagonal = Self::diagonal(&self.bounds);
        let (lo, hi) = (SPEED_RANGE.0 * diagonal, SPEED_RANGE.1 * diagonal);
        self.speed = (self.speed * SPEED_STEP.powf(notches)).clamp(lo, hi);
    }

    /// `F`: keeps the orientation and moves back along the view from the centre of the scene's
    /// bounds until their bounding sphere fits the view of aspect ratio `aspect`.
    pub fn frame_scene(&mut self, aspect: f32) {
        if self.bounds.is_empty() {
            return;
        }
        let radius = (0.5 * self.bounds.extent().length()).max(1e-6);
        let distance = framing_distance(radius, self.camera.yfov, aspect);
        let eye = self.bounds.center() - forward(&self.camera) * distance;
        if !eye.is_finite() {
            return;
        }
        self.camera.transform.w_axis = eye.extend(1.0);
        self.camera.znear = fly_near(&self.camera, &self.bounds);
    }
}

/// The point the scripted path swings about: on `start`'s view ray, level with the centre of
/// `bounds` along it (at least a thousandth of the scene's diagonal ahead), so that the scene
/// stays in view.
pub fn path_pivot(start: &Camera, bounds: &Aabb) -> DVec3 {
    let eye = start.position().as_dvec3();
    let ahead = forward(start).as_dvec3();
    let diagonal = f64::from(FlyCamera::diagonal(bounds));
    let along = if bounds.is_empty() {
        diagonal
    } else {
        (bounds.center().as_dvec3() - eye).dot(ahead)
    };
    eye + ahead * along.max(1e-3 * diagonal)
}

/// The pose of frame `frame` of the scripted path that starts at `start` (frame 0 is `start`
/// itself): swung by θ about the vertical through [`path_pivot`] and moved the share d of the
/// way towards it (module docs), still looking at the pivot. Deterministic: a function of
/// `frame` alone, so that `ispm render --camera-path-frame N` renders the pose of
/// `ispm view --frames N`'s last frame.
pub fn scripted_pose(start: &Camera, bounds: &Aabb, frame: u32) -> Camera {
    if frame == 0 {
        return *start;
    }
    let k = f64::from(frame);
    let tau = std::f64::consts::TAU;
    let swing = PATH_SWING.0 * (tau * k / PATH_SWING.1).sin();
    let dolly = PATH_DOLLY.0 * 0.5 * (1.0 - (tau * k / PATH_DOLLY.1).cos());
    let pivot = path_pivot(start, bounds);
    let turn = DQuat::from_rotation_y(swing);
    let eye = pivot + turn * (start.position().as_dvec3() - pivot) * (1.0 - dolly);
    let (_, rotation, _) = start.transform.to_scale_rotation_translation();
    let rotation = (turn * rotation.as_dquat()).normalize();
    let mut camera = Camera {
        transform: Mat4::from_rotation_translation(rotation.as_quat(), eye.as_vec3()),
        ..*start
    };
    camera.znear = fly_near(&camera, bounds);
    camera
}

#[cfg(test)]
mod tests {
    use super::*;

    fn room() -> Aabb {
        Aabb {
            min: Vec3::new(-1.0, 0.0, -1.0),
            max: Vec3::new(1.0, 2.0, 1.0),
        }
    }

    fn looking_at(eye: Vec3, target: Vec3) -> Camera {
        Camera {
            transform: glam::camera::rh::view::look_at_mat4(eye, target, Vec3::Y).inverse(),
            yfov: 0.7,
            znear: 0.05,
            zfar: Some(50.0),
        }
    }

    fn close(a: Vec3, b: Vec3, eps: f32) -> bool {
        (a - b).abs().max_element() <= eps
    }

    #[test]
    fn keys_give_a_unit_direction_and_opposite_keys_cancel() {
        let none = MoveKeys::default();
        assert_eq!(none.direction(), Vec3::ZERO);
        assert!(!none.any());
        let w = MoveKeys {
            forward: true,
            ..none
        };
        assert_eq!(w.direction(), Vec3::Z);
        let wd = MoveKeys { right: true, ..w };
        assert!(close(
            wd.direction(),
            Vec3::new(1.0, 0.0, 1.0).normalize(),
            1e-6
        ));
        let ws = MoveKeys { back: true, ..w };
        assert_eq!(ws.direction(), Vec3::ZERO);
        assert!(!ws.any());
        let qe_a = MoveKeys {
            up: true,
            down: true,
            left: true,
            ..none
        };
        assert_eq!(qe_a.direction(), Vec3::NEG_X);
        let q = MoveKeys { down: true, ..none };
        assert_eq!(q.direction(), Vec3::NEG_Y);
    }

    #[test]
    fn flying_moves_along_the_view_at_the_speed_and_keeps_the_rotation() {
        let start = looking_at(Vec3::new(0.0, 1.0, 3.6), Vec3::new(0.0, 1.0, 0.0));
        let mut fly = FlyCamera::new(start, room());
        let speed = fly.speed();
        assert!((speed - 0.25 * room().extent().length()).abs() < 1e-6);
        assert_eq!(fly.camera(), start, "not moved: exactly the file's camera");
        let w = MoveKeys {
            forward: true,
            ..Default::default()
        };
        assert!(fly.fly(&w, 0.5));
        let moved = fly.camera();
        assert!(close(
            moved.position(),
            Vec3::new(0.0, 1.0, 3.6 - 0.5 * speed),
            1e-5
        ));
        // A translation only: the rotation is the file's, bit for bit.
        for axis in 0..3 {
            assert_eq!(moved.transform.col(axis), start.transform.col(axis));
        }
        assert!(moved.znear <= NEAR_FRACTION * room().extent().length() + 1e-9);
        // E goes up the world's Y whatever the view; D to the camera's right.
        let mut fly = FlyCamera::new(start, room());
        let ed = MoveKeys {
            up: true,
            right: true,
            ..Default::default()
        };
        assert!(fly.fly(&ed, 1.0));
        let step = speed / 2f32.sqrt();
        assert!(close(
            fly.camera().position(),
            Vec3::new(step, 1.0 + step, 3.6),
            1e-5
        ));
        assert!(!fly.fly(&MoveKeys::default(), 1.0));
        assert!(!fly.fly(&ed, 0.0));
    }

    #[test]
    fn mouse_look_turns_yaw_and_pitch_the_expected_way_and_clamps_pitch() {
        let start = looking_at(Vec3::new(0.0, 1.0, 3.6), Vec3::new(0.0, 1.0, 0.0));
        let mut fly = FlyCamera::new(start, room());
        // Cursor right: the view turns right (towards +X from −Z).
        assert!(fly.look(100.0, 0.0));
        let f = forward(&fly.camera());
        let angle = 100.0 * LOOK_RADIANS_PER_PIXEL;
        assert!(close(f, Vec3::new(angle.sin(), 0.0, -angle.cos()), 1e-5));
        assert_eq!(fly.camera().position(), start.position());
        // Cursor down: the view turns down.
        assert!(fly.look(0.0, 50.0));
        assert!(forward(&fly.camera()).y < -0.1);
        // However far it goes, the pitch stops short of straight down, and up stays up.
        fly.look(0.0, 1e6);
        let f = forward(&fly.camera());
        assert!((f.y - (-MAX_PITCH.sin())).abs() < 1e-4, "{f}");
        assert!(fly.camera().transform.y_axis.y > 0.0);
        assert!(!fly.look(0.0, 0.0));
        assert!(!fly.look(f32::NAN, 1.0));
    }

    #[test]
    fn yaw_pitch_roll_round_trip_keeps_a_rolled_file_camera() {
        let rotation = Quat::from_euler(EulerRot::YXZ, 0.4, -0.3, 0.2);
        let start = Camera {
            transform: Mat4::from_rotation_translation(rotation, Vec3::new(1.0, 2.0, 3.0)),
            ..Camera::default()
        };
        let mut fly = FlyCamera::new(start, room());
        // A look of one pixel each way and back returns to the same rotation.
        fly.look(1.0, 1.0);
        fly.look(-1.0, -1.0);
        let t = fly.camera().transform;
        for axis in 0..3 {
            assert!(close(
                t.col(axis).truncate(),
                start.transform.col(axis).truncate(),
                1e-5
            ));
        }
    }

    #[test]
    fn the_wheel_scales_the_speed_within_its_range() {
        let mut fly = FlyCamera::new(Camera::default(), room());
        let v = fly.speed();
        fly.scroll(2.0);
        assert!((fly.speed() - v * SPEED_STEP * SPEED_STEP).abs() < 1e-5);
        fly.scroll(-2.0);
        assert!((fly.speed() - v).abs() < 1e-5);
        fly.scroll(1e4);
        let diagonal = room().extent().length();
        assert!((fly.speed() - SPEED_RANGE.1 * diagonal).abs() < 1e-3);
        fly.scroll(-1e5);
        assert!((fly.speed() - SPEED_RANGE.0 * diagonal).abs() < 1e-6);
        fly.scroll(f32::NAN);
        assert!(fly.speed().is_finite());
    }

    #[test]
    fn framing_puts_every_corner_of_the_bounds_in_the_image() {
        let bounds = room();
        for (width, height) in [(640, 480), (300, 600), (100, 100)] {
            // From inside the room, looking at a corner, tilted.
            let start = looking_at(Vec3::new(0.3, 0.2, 0.1), Vec3::new(-1.0, 1.7, -0.8));
            let mut fly = FlyCamera::new(start, bounds);
            fly.frame_scene(width as f32 / height as f32);
            let cam = fly.camera();
            assert!(close(forward(&cam), forward(&start), 1e-6));
            let mut touches_edge = false;
            for i in 0..8 {
                let corner = Vec3::new(
                    if i & 1 == 0 {
                        bounds.min.x
                    } else {
                        bounds.max.x
                    },
                    if i & 2 == 0 {
                        bounds.min.y
                    } else {
                        bounds.max.y
                    },
                    if i & 4 == 0 {
                        bounds.min.z
                    } else {
                        bounds.max.z
                    },
                );
                let p = cam
                    .project_to_pixel(corner, width, height)
                    .expect("in front of the camera");
                assert!(
                    (0.0..=width as f32).contains(&p.x) && (0.0..=height as f32).contains(&p.y),
                    "{width}x{height}: corner {corner} at pixel {p}"
                );
                let depth = cam.view().transform_point3(corner).z;
                assert!(-depth > cam.znear, "the near plane cuts corner {corner}");
                touches_edge |= p.x < 0.2 * width as f32 || p.y < 0.2 * height as f32;
            }
            // Framed, not merely far away: the box reaches towards the image's edge.
            assert!(
                touches_edge,
                "{width}x{height}: the box is tiny in the image"
            );
        }
    }

    #[test]
    fn jumping_to_a_file_camera_is_exact_and_keeps_the_speed() {
        let mut fly = FlyCamera::new(Camera::default(), room());
        fly.scroll(3.0);
        let speed = fly.speed();
        let other = looking_at(Vec3::new(2.0, 1.5, 2.0), Vec3::new(0.0, 0.4, 0.0));
        fly.jump_to(other);
        assert_eq!(fly.camera(), other);
        assert_eq!(fly.speed(), speed);
    }

    #[test]
    fn the_scripted_path_starts_at_the_camera_and_swings_and_dollies_about_the_pivot() {
        let bounds = room();
        let start = looking_at(Vec3::new(0.0, 1.0, 3.6), Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(scripted_pose(&start, &bounds, 0), start);
        let pivot = path_pivot(&start, &bounds);
        assert!(
            (pivot - DVec3::new(0.0, 1.0, 0.0)).length() < 1e-6,
            "{pivot}"
        );
        let distance = (start.position().as_dvec3() - pivot).length();
        for frame in [1, 17, 60, 120, 333, 1000] {
            let pose = scripted_pose(&start, &bounds, frame);
            assert_eq!(pose, scripted_pose(&start, &bounds, frame), "deterministic");
            // Still looking at the pivot: it projects to the image's centre.
            let p = pose
                .project_to_pixel(pivot.as_vec3(), 200, 100)
                .expect("pivot in front");
            assert!(
                close(p.extend(0.0), Vec3::new(100.0, 50.0, 0.0), 1e-2),
                "{p}"
            );
            // Level with the start (the swing is about the vertical), never further than it.
            let eye = pose.position().as_dvec3();
            assert!((eye.y - 1.0).abs() < 1e-5);
            let k = f64::from(frame);
            let dolly = PATH_DOLLY.0 * 0.5 * (1.0 - (std::f64::consts::TAU * k / 360.0).cos());
            assert!(((eye - pivot).length() - distance * (1.0 - dolly)).abs() < 1e-4);
            let swing = PATH_SWING.0 * (std::f64::consts::TAU * k / 240.0).sin();
            let angle = (eye - pivot).x.atan2((eye - pivot).z);
            assert!(
                (angle - swing).abs() < 1e-5,
                "frame {frame}: {angle} vs {swing}"
            );
            assert!(pose.znear <= NEAR_FRACTION * bounds.extent().length() + 1e-9);
            assert_eq!((pose.yfov, pose.zfar), (start.yfov, start.zfar));
        }
        // Frame 60 (the viewer test's last frame) is well away from the start: 0.3 rad of swing
        // and 6.25 % of the way to the pivot.
        let end = scripted_pose(&start, &bounds, 60);
        assert!((end.position() - start.position()).length() > 1.0);
    }
}
