//! Animated glTF scenes authored for the motion tests (with the crate's own GLB writer), and an
//! editor of a GLB's JSON chunk for malformed variants.

use glam::{Quat, Vec3};
use ispm::scene::authoring::{icosphere, quad, AnimationChannel, GltfWriter, MaterialSpec};
use serde_json::Value;

/// Node indices of [`glass_on_a_carousel`].
pub struct Carousel {
    pub glb: Vec<u8>,
    /// The group turning about +Y (no mesh of its own).
    pub carrier: usize,
    /// The glass ball, child of the carrier, bobbing up and down (cubic spline).
    pub ball: usize,
    /// The spot light, child of the carrier.
    pub lamp: usize,
}

fn flat(v: &[Vec3]) -> Vec<f32> {
    v.iter().flat_map(|p| p.to_array()).collect()
}

fn quats(q: &[Quat]) -> Vec<f32> {
    q.iter().flat_map(|q| q.to_array()).collect()
}

/// A diffuse floor and a static diffuse block under a turning carrier (a half turn about +Y in
/// 2 s, LINEAR) that holds a glass ball at radius 0.6 bobbing between 0.35 and 0.6 m
/// (CUBICSPLINE, 1 s) and a spot light above the middle aiming at the floor beside the block.
pub fn glass_on_a_carousel() -> Carousel {
    let mut w = GltfWriter::default();
    let white = w.material(&MaterialSpec::diffuse("white", [0.75, 0.75, 0.75]));
    let red = w.material(&MaterialSpec::diffuse("red", [0.7, 0.15, 0.1]));
    let glass = w.material(&MaterialSpec::glass("glass"));
    let floor = w.mesh("floor", &quad(Vec3::ZERO, Vec3::Y, 1.5, 1.5), white);
    w.mesh_node("floor", floor, Vec3::ZERO, Quat::IDENTITY);
    let block = w.mesh(
        "block",
        &ispm::scene::authoring::cuboid(Vec3::new(0.15, 0.3, 0.15)),
        red,
    );
    w.mesh_node("block", block, Vec3::new(-0.5, 0.3, -0.5), Quat::IDENTITY);
    let carrier = w.group("carrier", Vec3::ZERO, Quat::IDENTITY);
    let ball_mesh = w.mesh("ball", &icosphere(0.25, 2), glass);
    let ball = w.mesh_node("ball", ball_mesh, Vec3::new(0.6, 0.4, 0.0), Quat::IDENTITY);
    w.add_child(carrier, ball);
    let lamp = w.spot(
        "lamp",
        Vec3::new(0.0, 2.5, 0.0),
        Vec3::new(0.3, 0.0, 0.0),
        [1.0, 1.0, 1.0],
        8.0,
        (0.5, 0.7),
    );
    w.add_child(carrier, lamp);
    w.camera(
        "camera",
        Vec3::new(0.0, 2.2, 2.6),
        Vec3::new(0.0, 0.2, 0.0),
        0.8,
    );
    let turn = [0.0, 1.0, 2.0];
    let turn_values = quats(&[
        Quat::IDENTITY,
        Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
        Quat::from_rotation_y(std::f32::consts::PI),
    ]);
    // Cubic spline: (in-tangent, value, out-tangent) per key; up at 1.5 m/s, down at −1.5 m/s.
    let bob = [0.0, 0.5, 1.0];
    let v = |y: f32| Vec3::new(0.6, y, 0.0);
    let d = |dy: f32| Vec3::new(0.0, dy, 0.0);
    let bob_values = flat(&[
        d(0.0),
        v(0.35),
        d(1.5),
        d(0.0),
        v(0.6),
        d(0.0),
        d(-1.5),
        v(0.35),
        d(0.0),
    ]);
    w.animation(
        "carousel",
        &[
            AnimationChannel {
                node: carrier,
                path: "rotation",
                interpolation: "LINEAR",
                times: &turn,
                values: &turn_values,
            },
            AnimationChannel {
                node: ball,
                path: "translation",
                interpolation: "CUBICSPLINE",
                times: &bob,
                values: &bob_values,
            },
        ],
    );
    Carousel {
        glb: w.glb(),
        carrier,
        ball,
        lamp,
    }
}

/// `glb` with its JSON chunk replaced by `edit`'s change of it (the BIN chunk kept).
pub fn edit_json(glb: &[u8], edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    let le = |at: usize| u32::from_le_bytes(glb[at..at + 4].try_into().expect("4 bytes")) as usize;
    let json_len = le(12);
    let mut doc: Value = serde_json::from_slice(&glb[20..20 + json_len]).expect("GLB JSON");
    edit(&mut doc);
    let rest = &glb[20 + json_len..];
    let mut json = doc.to_string().into_bytes();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + rest.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(rest);
    out
}
