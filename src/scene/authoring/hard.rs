//! The bundled hard cases (issue #8): three of the adversarial scenes of `tests/hard_*.rs`
//! that a person may want to look at and fly around in.

use super::{cornell_room, cuboid, icosphere, quad, GltfWriter, MaterialSpec, WHITE};
use glam::{Quat, Vec3};

/// The `cornell-box` room split at x = 0 by two single-sided white walls back to back in the
/// same plane, a spot light in the left half and a white ball in the right half: no light may
/// leak through the divider, so the right half stays black.
pub fn thin_walls() -> Vec<u8> {
    let mut w = GltfWriter::default();
    let white = cornell_room(&mut w, 1.0, Vec3::ZERO);
    for (name, n) in [("divider-left", Vec3::NEG_X), ("divider-right", Vec3::X)] {
        let mesh = w.mesh(name, &quad(Vec3::new(0.0, 1.0, 0.0), n, 1.0, 1.0), white);
        w.mesh_node(name, mesh, Vec3::ZERO, Quat::IDENTITY);
    }
    let ball = w.mesh("dark-side-ball", &icosphere(0.3, 3), white);
    w.mesh_node(
        "dark-side-ball",
        ball,
        Vec3::new(0.5, 0.3, 0.0),
        Quat::IDENTITY,
    );
    let at = Vec3::new(-0.5, 1.95, 0.0);
    w.spot("spot", at, at - Vec3::Y, [1.0; 3], 4.0, (0.7, 0.9));
    w.camera(
        "camera",
        Vec3::new(0.0, 1.0, 3.6),
        Vec3::new(0.0, 1.0, 0.0),
        0.7,
    );
    w.glb()
}

/// Two perfect mirrors (ρS = 0.95, double-sided) 1.2 m apart facing each other on a diffuse
/// floor, a glossy ball between them and a spot light aimed across: an endless corridor of
/// reflections, where the bounce limit, not Russian roulette, ends most photon paths.
pub fn facing_mirrors() -> Vec<u8> {
    let mut w = GltfWriter::default();
    let floor_m = w.material(&MaterialSpec::diffuse("floor", WHITE));
    let mirror = w.material(&MaterialSpec::mirror("mirror", [0.95; 3]));
    let glossy = w.material(&MaterialSpec {
        base_color: [0.3, 0.5, 0.7],
        roughness: 0.3,
        lambertian: [0.15, 0.3, 0.45],
        glossy: [0.3; 3],
        exponent: 200.0,
        ..MaterialSpec::diffuse("glossy-blue", [0.0; 3])
    });
    let floor = w.mesh("floor", &quad(Vec3::ZERO, Vec3::Y, 2.0, 2.0), floor_m);
    w.mesh_node("floor", floor, Vec3::ZERO, Quat::IDENTITY);
    for (name, x, n) in [
        ("mirror-left", -0.6, Vec3::X),
        ("mirror-right", 0.6, Vec3::NEG_X),
    ] {
        let mesh = w.mesh(name, &quad(Vec3::new(x, 0.6, 0.0), n, 0.8, 0.6), mirror);
        w.mesh_node(name, mesh, Vec3::ZERO, Quat::IDENTITY);
    }
    let ball = w.mesh("ball", &icosphere(0.25, 3), glossy);
    w.mesh_node("ball", ball, Vec3::new(0.0, 0.25, 0.0), Quat::IDENTITY);
    w.spot(
        "spot",
        Vec3::new(0.3, 1.8, 0.9),
        Vec3::new(-0.6, 0.4, 0.0),
        [1.0; 3],
        6.0,
        (0.3, 0.45),
    );
    w.camera(
        "camera",
        Vec3::new(0.0, 1.4, 2.6),
        Vec3::new(0.0, 0.4, 0.0),
        0.8,
    );
    w.glb()
}

/// A closed glass cube (η = 1.5, twelve triangles with sharp edges) and a glass ball of
/// η = 3 (critical angle 19.5°: most light inside it is reflected totally) on a diffuse floor
/// under a sun 30° above the horizon: long refracted caustics, none leaking through an edge.
pub fn glass_cube() -> Vec<u8> {
    let mut w = GltfWriter::default();
    let floor_m = w.material(&MaterialSpec::diffuse("floor", WHITE));
    let glass = w.material(&MaterialSpec::glass("glass-1.5"));
    let dense = w.material(&MaterialSpec {
        ior_ext: Some(3.0),
        ior: 3.0,
        ..MaterialSpec::glass("glass-3")
    });
    let floor = w.mesh("floor", &quad(Vec3::ZERO, Vec3::Y, 2.0, 2.0), floor_m);
    w.mesh_node("floor", floor, Vec3::ZERO, Quat::IDENTITY);
    let cube = w.mesh("glass-cube", &cuboid(Vec3::splat(0.3)), glass);
    w.mesh_node(
        "glass-cube",
        cube,
        Vec3::new(-0.35, 0.3, 0.0),
        Quat::IDENTITY,
    );
    let ball = w.mesh("dense-ball", &icosphere(0.25, 3), dense);
    w.mesh_node(
        "dense-ball",
        ball,
        Vec3::new(0.45, 0.25, 0.2),
        Quat::IDENTITY,
    );
    let elevation = 30f32.to_radians();
    let dir = Vec3::new(
        -elevation.cos() * 0.8,
        -elevation.sin(),
        -elevation.cos() * 0.6,
    );
    w.sun("sun", dir, [1.0; 3], 3.0);
    w.camera(
        "camera",
        Vec3::new(1.8, 1.2, 1.8),
        Vec3::new(0.0, 0.3, 0.0),
        0.7,
    );
    w.glb()
}
