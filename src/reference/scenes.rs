//! Small procedural scenes with known answers, for the physics tests and the benchmarks.

use crate::photon::shapes::icosphere;
use crate::scene::{Camera, Instance, Light, LightKind, Material, Mesh, Scene};
use glam::{Mat4, Vec2, Vec3};

fn diffuse(name: &str, albedo: Vec3) -> Material {
    Material {
        name: name.into(),
        lambertian: albedo,
        ..Material::default()
    }
}

/// A point light named "point".
pub fn point_light(position: Vec3, intensity: Vec3) -> Light {
    Light {
        name: "point".into(),
        kind: LightKind::Point,
        position,
        direction: Vec3::NEG_Y,
        intensity,
    }
}

/// A camera at `position` looking along `forward` (not parallel to +Y).
fn camera_at(position: Vec3, forward: Vec3, yfov_degrees: f32) -> Camera {
    let view = glam::camera::rh::view::look_to_mat4(position, forward, Vec3::Y);
    Camera {
        transform: view.inverse(),
        yfov: yfov_degrees.to_radians(),
        znear: 1e-3,
        zfar: None,
    }
}

/// DESIGN.md §6's analytic scene: inside a closed icosphere of radius 1 (vertices on the unit
/// sphere) of Lambertian albedo `albedo`, a point light of intensity `intensity` (RGB) at the
/// centre, the camera at the centre. For albedo ρ and intensity I the exact radiance of the
/// smooth sphere is `I·ρ/(π(1 − ρ))`: 1 for ρ = 0.5, I = π.
pub fn furnace_sphere(subdivisions: u32, albedo: f32, intensity: f32) -> Scene {
    let mut mesh = icosphere(subdivisions);
    mesh.material = 0;
    let mut scene = Scene {
        meshes: vec![mesh],
        instances: vec![Instance {
            name: "sphere".into(),
            mesh: 0,
            transform: Mat4::IDENTITY,
        }],
        materials: vec![diffuse("wall", Vec3::splat(albedo))],
        lights: vec![point_light(Vec3::ZERO, Vec3::splat(intensity))],
        ..Scene::default()
    };
    scene.camera = camera_at(Vec3::ZERO, Vec3::new(0.3, -0.2, -1.0), 90.0);
    scene
}

/// One axis-aligned quad of the box `[-1, 1]³`: the face at `axis = sign`, facing inwards.
fn wall(axis: usize, sign: f32, material: usize) -> Mesh {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let corner = |a: f32, b: f32| {
        let mut p = [0.0f32; 3];
        p[axis] = sign;
        p[u] = a;
        p[v] = b;
        Vec3::from_array(p)
    };
    let positions = vec![
        corner(-1.0, -1.0),
        corner(1.0, -1.0),
        corner(1.0, 1.0),
        corner(-1.0, 1.0),
    ];
    let mut inward = [0.0f32; 3];
    inward[axis] = -sign;
    let inward = Vec3::from_array(inward);
    // Counter-clockwise seen from inside.
    let tri_normal = (positions[1] - positions[0]).cross(positions[2] - positions[0]);
    let triangles = if tri_normal.dot(inward) > 0.0 {
        vec![[0, 1, 2], [0, 2, 3]]
    } else {
        vec![[0, 2, 1], [0, 3, 2]]
    };
    Mesh {
        name: format!("wall{axis}{sign}"),
        normals: vec![inward; 4],
        uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
        positions,
        triangles,
        material,
    }
}

/// The closed box `[-1, 1]³` (exactly shared corners: watertight) with `materials[i]` on the
/// faces −X, +X, −Y, +Y, −Z, +Z, a point light at `light`, and the camera inside at z = 0.9.
pub fn closed_box(materials: [Material; 6], light: Light) -> Scene {
    let mut scene = Scene {
        materials: materials.to_vec(),
        lights: vec![light],
        ..Scene::default()
    };
    for (i, (axis, sign)) in [
        (0, -1.0),
        (0, 1.0),
        (1, -1.0),
        (1, 1.0),
        (2, -1.0),
        (2, 1.0),
    ]
    .into_iter()
    .enumerate()
    {
        scene.meshes.push(wall(axis, sign, i));
        scene.instances.push(Instance {
            name: format!("wall{i}"),
            mesh: i,
            transform: Mat4::IDENTITY,
        });
    }
    scene.camera = camera_at(Vec3::new(0.0, 0.0, 0.9), Vec3::NEG_Z, 70.0);
    scene
}

/// A closed grey box of albedo `albedo` with a point light of intensity `intensity` at the
/// centre: the photon-accounting scene.
pub fn grey_box(albedo: f32, intensity: f32) -> Scene {
    let m = diffuse("grey", Vec3::splat(albedo));
    closed_box(
        std::array::from_fn(|_| m.clone()),
        point_light(Vec3::ZERO, Vec3::splat(intensity)),
    )
}

/// A Cornell-like closed box (red −X wall, green +X wall, white elsewhere), a point light
/// below the ceiling and a white sphere of radius 0.35 on the floor.
pub fn cornell(sphere_subdivisions: u32) -> Scene {
    let white = diffuse("white", Vec3::splat(0.7));
    let mut scene = closed_box(
        [
            diffuse("red", Vec3::new(0.6, 0.1, 0.1)),
            diffuse("green", Vec3::new(0.1, 0.6, 0.1)),
            white.clone(),
            white.clone(),
            white.clone(),
            white,
        ],
        point_light(Vec3::new(0.0, 0.8, 0.0), Vec3::splat(2.0)),
    );
    let mut sphere = icosphere(sphere_subdivisions);
    sphere.material = 2;
    scene.meshes.push(sphere);
    scene.instances.push(Instance {
        name: "sphere".into(),
        mesh: scene.meshes.len() - 1,
        transform: Mat4::from_scale_rotation_translation(
            Vec3::splat(0.35),
            glam::Quat::IDENTITY,
            Vec3::new(0.3, -0.65, -0.2),
        ),
    });
    scene
}

/// The same scene scaled by `s` about the origin: geometry, camera and light positions; point
/// and spot intensities × s² (so that the irradiance at scaled points is unchanged).
pub fn scaled(scene: &Scene, s: f32) -> Scene {
    let m = Mat4::from_scale(Vec3::splat(s));
    let mut out = scene.clone();
    for inst in &mut out.instances {
        inst.transform = m * inst.transform;
    }
    for light in &mut out.lights {
        light.position *= s;
        if light.kind != LightKind::Directional {
            light.intensity *= s * s;
        }
    }
    let mut cam = out.camera.transform;
    cam.w_axis = (cam.w_axis.truncate() * s).extend(1.0);
    out.camera.transform = cam;
    out.camera.znear *= s;
    out
}
