//! The project's own scenes, written as glTF 2.0 binary (`.glb`) with serde_json.
//!
//! `cargo run --example make-scenes` writes [`all`] to `assets/`; `tests/scene_bundled.rs`
//! checks that the committed files equal what this module produces now. Each material carries
//! standard metallic-roughness values (so other viewers show something sensible) and its exact
//! über-BSDF parameters in `extras.ispm`, which the loader applies verbatim.

mod hard;
mod shapes;
mod writer;

pub use shapes::{
    cuboid, icosphere, look_rotation, quad, ring, sphere_uvs, unit_icosphere, Geometry,
};
pub use writer::{AnimationChannel, GltfWriter, MaterialSpec};

use glam::{Quat, Vec3};

/// Every bundled scene: `(name, .glb bytes)`.
pub fn all() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        ("cornell-box", cornell_box()),
        ("caustic-ring", caustic_ring()),
        ("glass-sphere", glass_sphere()),
        ("diffuse-box", diffuse_box()),
        ("thin-walls", hard::thin_walls()),
        ("facing-mirrors", hard::facing_mirrors()),
        ("glass-cube", hard::glass_cube()),
    ]
}

const WHITE: [f32; 3] = [0.75, 0.75, 0.75];

/// The Cornell room both Cornell boxes share: white, red and green diffuse materials (white is
/// the first, so its index is returned) and five 2 m walls, open towards the camera at +Z,
/// scaled by `scale` about the floor's centre and moved by `offset` (the nodes carry the offset,
/// so the vertices stay as small as the room: the hard cases' scale and position tests).
pub fn cornell_room(w: &mut GltfWriter, scale: f32, offset: Vec3) -> usize {
    let white = w.material(&MaterialSpec::diffuse("white", WHITE));
    let red = w.material(&MaterialSpec::diffuse("red", [0.63, 0.065, 0.05]));
    let green = w.material(&MaterialSpec::diffuse("green", [0.14, 0.45, 0.091]));
    let walls = [
        ("floor", Vec3::ZERO, Vec3::Y, white),
        ("ceiling", Vec3::new(0.0, 2.0, 0.0), Vec3::NEG_Y, white),
        ("back", Vec3::new(0.0, 1.0, -1.0), Vec3::Z, white),
        ("left", Vec3::new(-1.0, 1.0, 0.0), Vec3::X, red),
        ("right", Vec3::new(1.0, 1.0, 0.0), Vec3::NEG_X, green),
    ];
    for (name, c, n, m) in walls {
        let mesh = w.mesh(name, &quad(c * scale, n, scale, scale), m);
        w.mesh_node(name, mesh, offset, Quat::IDENTITY);
    }
    white
}

/// The paper's Figure 6: a 2 m Cornell box (open towards the camera at +Z) with a glossy purple
/// sphere, a glass sphere (η = 1.3), a white box and two spot lights (white, blue) aiming down.
pub fn cornell_box() -> Vec<u8> {
    let mut w = GltfWriter::default();
    let white = cornell_room(&mut w, 1.0, Vec3::ZERO);
    let purple = w.material(&MaterialSpec {
        base_color: [0.45, 0.15, 0.55],
        roughness: 0.376,
        lambertian: [0.25, 0.05, 0.3],
        glossy: [0.35, 0.2, 0.4],
        exponent: 100.0,
        ..MaterialSpec::diffuse("glossy-purple", [0.0; 3])
    });
    let glass = w.material(&MaterialSpec {
        base_color: [1.0, 1.0, 1.0],
        roughness: 0.0,
        transmission_factor: 0.9,
        ior_ext: Some(1.3),
        lambertian: [0.02; 3],
        glossy: [0.05; 3],
        exponent: f32::INFINITY,
        transmission: [0.9; 3],
        ior: 1.3,
        fresnel: true,
        ..MaterialSpec::diffuse("glass-1.3", [0.0; 3])
    });
    let sphere = w.mesh("glossy-sphere", &icosphere(0.3, 3), purple);
    w.mesh_node(
        "glossy-sphere",
        sphere,
        Vec3::new(-0.45, 0.3, -0.35),
        Quat::IDENTITY,
    );
    let ball = w.mesh("glass-sphere", &icosphere(0.32, 4), glass);
    w.mesh_node(
        "glass-sphere",
        ball,
        Vec3::new(0.2, 0.32, 0.35),
        Quat::IDENTITY,
    );
    let block = w.mesh("white-box", &cuboid(Vec3::new(0.25, 0.5, 0.25)), white);
    w.mesh_node(
        "white-box",
        block,
        Vec3::new(0.5, 0.5, -0.45),
        Quat::from_rotation_y(0.3),
    );
    // 4 W/sr from 1.95 m: about 1.05 W/m² on the floor below each light.
    let down = Vec3::new(0.0, -1.95, 0.0);
    let (white_at, blue_at) = (Vec3::new(-0.4, 1.95, 0.0), Vec3::new(0.4, 1.95, 0.0));
    w.spot(
        "white-spot",
        white_at,
        white_at + down,
        [1.0, 1.0, 1.0],
        4.0,
        (0.45, 0.6),
    );
    w.spot(
        "blue-spot",
        blue_at,
        blue_at + down,
        [0.25, 0.45, 1.0],
        4.0,
        (0.45, 0.6),
    );
    w.camera(
        "camera",
        Vec3::new(0.0, 1.0, 3.6),
        Vec3::new(0.0, 1.0, 0.0),
        0.7,
    );
    w.glb()
}

/// The paper's Figure 5: a mirror ring on a diffuse floor lit at 20° elevation, so its
/// reflection focuses into a cardioid caustic inside the ring.
pub fn caustic_ring() -> Vec<u8> {
    let mut w = GltfWriter::default();
    let floor_m = w.material(&MaterialSpec::diffuse("floor", WHITE));
    let metal = w.material(&MaterialSpec::mirror("mirror-metal", [0.95, 0.93, 0.88]));
    let floor = w.mesh("floor", &quad(Vec3::ZERO, Vec3::Y, 2.0, 2.0), floor_m);
    w.mesh_node("floor", floor, Vec3::ZERO, Quat::IDENTITY);
    let r = w.mesh("ring", &ring(0.5, 0.2, 0.015, 192), metal);
    w.mesh_node("ring", r, Vec3::ZERO, Quat::IDENTITY);
    let elevation = 20f32.to_radians();
    let dir = Vec3::new(-elevation.cos(), -elevation.sin(), 0.0);
    w.sun("sun", dir, [1.0, 1.0, 1.0], 3.0);
    w.camera("camera", Vec3::new(0.0, 1.5, 1.2), Vec3::ZERO, 0.7);
    w.glb()
}

/// A glass sphere (η = 1.5) on a diffuse plane under an oblique spot light: a focused refractive
/// caustic in front of the sphere.
pub fn glass_sphere() -> Vec<u8> {
    let mut w = GltfWriter::default();
    let floor_m = w.material(&MaterialSpec::diffuse("floor", WHITE));
    let glass = w.material(&MaterialSpec::glass("glass-1.5"));
    let floor = w.mesh("floor", &quad(Vec3::ZERO, Vec3::Y, 3.0, 3.0), floor_m);
    w.mesh_node("floor", floor, Vec3::ZERO, Quat::IDENTITY);
    let ball = w.mesh("glass-sphere", &icosphere(0.5, 4), glass);
    w.mesh_node(
        "glass-sphere",
        ball,
        Vec3::new(0.0, 0.5, 0.0),
        Quat::IDENTITY,
    );
    // 10 W/sr from 2.7 m, 50° above the plane, behind the sphere as the camera sees it: the
    // ball lens (focal length nR / 2(n − 1) = 0.75 m from its centre) focuses the light down its
    // axis, which meets the floor 0.65 m from the centre, just short of the focus: a tight
    // caustic on the floor in front of the sphere, where the camera sees it.
    w.spot(
        "spot",
        Vec3::new(-1.5, 2.6, -0.9),
        Vec3::new(0.0, 0.5, 0.0),
        [1.0, 1.0, 1.0],
        10.0,
        (0.6, 0.75),
    );
    w.camera(
        "camera",
        Vec3::new(2.0, 1.5, 2.0),
        Vec3::new(0.0, 0.4, 0.0),
        0.7,
    );
    w.glb()
}

/// A Cornell box, diffuse only: the `cornell-box` room (white, red and green walls, open
/// towards the camera) with a tall white block, a matte white sphere and one white spot light
/// under the ceiling. Nothing glossy, mirrored or transparent, so the effects plan compiles both
/// optional lobes out and runs no translucent pass (docs/effects.md).
pub fn diffuse_box() -> Vec<u8> {
    let mut w = GltfWriter::default();
    let white = cornell_room(&mut w, 1.0, Vec3::ZERO);
    let tall = w.mesh("tall-block", &cuboid(Vec3::new(0.3, 0.6, 0.3)), white);
    w.mesh_node(
        "tall-block",
        tall,
        Vec3::new(-0.35, 0.6, -0.3),
        Quat::from_rotation_y(0.3),
    );
    let ball = w.mesh("white-sphere", &icosphere(0.3, 3), white);
    w.mesh_node(
        "white-sphere",
        ball,
        Vec3::new(0.35, 0.3, 0.25),
        Quat::IDENTITY,
    );
    // 4 W/sr from 1.95 m straight down: about 1.05 W/m² on the floor below it.
    let at = Vec3::new(0.0, 1.95, 0.0);
    w.spot("spot", at, at - Vec3::Y, [1.0, 1.0, 1.0], 4.0, (0.7, 0.9));
    w.camera(
        "camera",
        Vec3::new(0.0, 1.0, 3.6),
        Vec3::new(0.0, 1.0, 0.0),
        0.7,
    );
    w.glb()
}
