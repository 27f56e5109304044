//! Tests of ray tracing as a whole: watertightness through the BVH, self-intersection after
//! offsetting, agreement with brute force, and moving instances.

use glam::{Mat4, Quat, Vec3};

use super::bvh::SceneBvh;
use super::ray::{Hit, Ray, TriangleKey};
use super::shapes::{grid, icosphere, scene_of};
use super::triangle::intersect_triangle;
use crate::scene::Scene;

/// Small deterministic generator (PCG-XSH-RR) so the tests need no dependency.
struct Pcg(u64);

impl Pcg {
    fn next_u32(&mut self) -> u32 {
        let old = self.0;
        self.0 = old
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }
    fn uniform(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }
    fn unit_vector(&mut self) -> Vec3 {
        let z = 1.0 - 2.0 * self.uniform();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * self.uniform();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
    /// A unit vector in the hemisphere around `n` (strictly away from the plane).
    fn hemisphere(&mut self, n: Vec3) -> Vec3 {
        loop {
            let v = self.unit_vector();
            let c = v.dot(n);
            if c.abs() > 1e-3 {
                return if c > 0.0 { v } else { -v };
            }
        }
    }
}

const AXES: [Vec3; 6] = [
    Vec3::X,
    Vec3::NEG_X,
    Vec3::Y,
    Vec3::NEG_Y,
    Vec3::Z,
    Vec3::NEG_Z,
];

/// Exact vertex positions, edge midpoints and random points along edges of a mesh.
fn edge_and_vertex_targets(scene: &Scene, rng: &mut Pcg) -> Vec<Vec3> {
    let mesh = &scene.meshes[0];
    let mut targets = mesh.positions.clone();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (
                mesh.positions[t[k] as usize],
                mesh.positions[t[(k + 1) % 3] as usize],
            );
            targets.push((a + b) * 0.5);
            targets.push(a.lerp(b, rng.uniform()));
        }
    }
    targets
}

#[test]
fn rays_from_inside_a_closed_icosphere_through_edges_and_vertices_always_hit() {
    let scene = scene_of(vec![(icosphere(3), Mat4::IDENTITY)]);
    let bvh = SceneBvh::new(&scene);
    let mut rng = Pcg(1);
    let targets = edge_and_vertex_targets(&scene, &mut rng);
    let mut rays = 0;
    for &target in &targets {
        let mut origins = vec![Vec3::ZERO, 0.5 * rng.unit_vector(), target * 0.3];
        origins.extend(
            AXES.iter()
                .map(|&a| target - 0.5 * a)
                .filter(|o| o.length() < 0.9),
        );
        for origin in origins {
            let dir = target - origin;
            for ray in [Ray::new(origin, dir), Ray::new(origin, dir.normalize())] {
                rays += 1;
                assert!(bvh.intersect(&ray).is_some(), "{ray:?} slipped through");
                assert!(bvh.occluded(&ray), "{ray:?} slipped through (any-hit)");
            }
        }
    }
    assert!(rays > 10_000);
}

#[test]
fn rays_from_outside_through_edges_and_vertices_hit_on_entry_and_exit() {
    for moving in [false, true] {
        let transform = Mat4::from_scale_rotation_translation(
            Vec3::splat(2.0),
            Quat::from_rotation_y(0.3),
            Vec3::new(1.0, -2.0, 0.5),
        );
        let scene = scene_of(vec![(icosphere(3), transform)]);
        let moving_set: &[usize] = if moving { &[0] } else { &[] };
        let bvh = SceneBvh::with_moving_instances(&scene, moving_set);
        let mut rng = Pcg(2);
        let targets = edge_and_vertex_targets(&scene, &mut rng);
        for &local in &targets {
            let target = transform.transform_point3(local);
            let outward = (target - Vec3::new(1.0, -2.0, 0.5)).normalize();
            let mut dirs: Vec<Vec3> = AXES.to_vec();
            dirs.extend((0..4).map(|_| rng.unit_vector()));
            for dir in dirs.into_iter().filter(|d| d.dot(outward) < -0.1) {
                let ray = Ray::new(target - 10.0 * dir, dir);
                let entry = bvh
                    .intersect(&ray)
                    .unwrap_or_else(|| panic!("{ray:?} missed"));
                assert!(
                    entry.front_face && (entry.t - 10.0).abs() < 0.1,
                    "{entry:?}"
                );
                let onwards = offset_only(entry.spawn_ray(dir));
                let exit = bvh
                    .intersect(&onwards)
                    .unwrap_or_else(|| panic!("{onwards:?} leaked out of the sphere"));
                assert_eq!(bvh.intersect(&entry.spawn_ray(dir)), Some(exit));
                assert!(
                    !exit.front_face && exit.triangle != entry.triangle,
                    "{exit:?}"
                );
            }
        }
    }
}

/// `ray` without the triangle it leaves: only its offset origin keeps it off that triangle.
/// The self-intersection tests check the offset this way, since the skip (`TriangleKey`)
/// would pass them on its own; the skip is sound because the offset holds.
fn offset_only(ray: Ray) -> Ray {
    ray.leaving(TriangleKey::NONE)
}

/// Hit a sphere from outside; spawn reflected rays (they must not re-hit anything on a convex
/// surface) and refracted rays (they must cross and hit another triangle), by their offset
/// origins alone; with the skip of the triangle they leave, every query answers the same.
fn check_self_intersection(scale: f32, translation: Vec3, moving: bool) {
    let transform = Mat4::from_scale_rotation_translation(
        Vec3::splat(scale),
        Quat::from_rotation_x(0.7),
        translation,
    );
    let scene = scene_of(vec![(icosphere(2), transform)]);
    let moving_set: &[usize] = if moving { &[0] } else { &[] };
    let bvh = SceneBvh::with_moving_instances(&scene, moving_set);
    let mut rng = Pcg(3);
    let mut spawned = 0;
    for _ in 0..200 {
        let target = translation + 0.5 * scale * rng.unit_vector();
        let origin = translation + 4.0 * scale * rng.unit_vector();
        let Some(hit) = bvh.intersect(&Ray::new(origin, target - origin)) else {
            panic!("ray at the sphere's interior missed");
        };
        let outward = hit.geometric_normal;
        for _ in 0..20 {
            let reflected = rng.hemisphere(outward);
            let skipping = hit.spawn_ray(reflected);
            assert_eq!(skipping.leaves, hit.key);
            let ray = offset_only(skipping);
            let again = bvh.intersect(&ray);
            assert_eq!(bvh.intersect(&skipping), again);
            assert!(
                again.is_none_or(|h: Hit| h.triangle != hit.triangle),
                "reflected ray re-hit its triangle at scale {scale}, offset {translation}"
            );
            if translation == Vec3::ZERO {
                assert!(
                    again.is_none(),
                    "reflected ray hit a convex surface again: {again:?}"
                );
            }
            assert!(!bvh.occluded(&Ray::with_t_max(ray.origin, ray.dir, scale * 1e-2)));
            assert!(
                !bvh.occluded(&Ray::with_t_max(ray.origin, ray.dir, scale * 1e-2).leaving(hit.key))
            );

            let refracted = rng.hemisphere(-outward);
            let skipping = hit.spawn_ray(refracted);
            let ray = offset_only(skipping);
            let exit = bvh
                .intersect(&ray)
                .expect("refracted ray must cross and exit");
            assert_eq!(bvh.intersect(&skipping), Some(exit));
            assert_ne!(
                exit.triangle, hit.triangle,
                "refracted ray re-hit its triangle"
            );
            assert!(!exit.front_face);
            spawned += 2;
        }
    }
    assert_eq!(spawned, 8000);
}

/// The skip itself: a ray that would hit a triangle does not when it is said to leave it (it
/// goes on to the sphere's far side), for closest hits and for occlusion, in the static part
/// and in a moving instance, and only in the instance named (two moving instances share one
/// mesh BVH and so their leaf numbers). A key says nothing to another BVH, to a rebuilt static
/// part, or to a moving instance placed anew since.
#[test]
fn a_ray_skips_the_triangle_it_leaves_and_only_that_one() {
    let at = |x: f32| Mat4::from_translation(Vec3::new(x, 0.0, 0.0));
    let sphere = icosphere(2);
    let scene = scene_of(vec![(sphere.clone(), at(-3.0)), (sphere, at(3.0))]);
    let up = |x: f32| Ray::new(Vec3::new(x + 0.1, -10.0, 0.05), Vec3::Y);
    // The same ray, ending half-way through the sphere.
    let short =
        |x: f32, hit: &Hit| Ray::with_t_max(Vec3::new(x + 0.1, -10.0, 0.05), Vec3::Y, hit.t + 1.0);
    // Leaf `leaf` of the part `key` names.
    let in_part = |key: TriangleKey, leaf: u32| TriangleKey { leaf, ..key };
    for moving in [&[][..], &[0, 1][..]] {
        let bvh = SceneBvh::with_moving_instances(&scene, moving);
        let a = bvh.intersect(&up(-3.0)).unwrap();
        let b = bvh.intersect(&up(3.0)).unwrap();
        assert_eq!((a.instance, b.instance), (0, 1));
        assert_ne!(a.key, b.key, "{moving:?}");
        for (hit, x) in [(a, -3.0), (b, 3.0)] {
            let through = bvh.intersect(&up(x).leaving(hit.key)).unwrap();
            assert!(
                through.instance == hit.instance && !through.front_face && through.t > hit.t + 1.5,
                "{moving:?}: {through:?} after skipping {hit:?}"
            );
            assert!(bvh.occluded(&short(x, &hit)));
            assert!(
                !bvh.occluded(&short(x, &hit).leaving(hit.key)),
                "{moving:?}"
            );
            // A shadow ray names the triangle it leaves too.
            assert_eq!(hit.spawn_ray_to(Vec3::ZERO).leaves, hit.key);
        }
        // A's key says nothing of B, though with moving instances both are leaf `a.key.leaf`
        // of the one mesh BVH.
        assert_eq!(
            bvh.intersect(&up(3.0).leaving(a.key)),
            Some(b),
            "{moving:?}"
        );
        if !moving.is_empty() {
            assert_eq!(a.key.leaf, b.key.leaf, "the same point of the same mesh");
            assert_ne!(a.key.part, b.key.part);
        } else {
            // One static part: the leaf alone tells the two apart.
            assert_eq!(in_part(a.key, b.key.leaf), b.key);
        }
        // Nor does it say anything to another BVH of the same scene (the same leaves).
        let other = SceneBvh::with_moving_instances(&scene, moving);
        let a_there = other.intersect(&up(-3.0)).unwrap();
        assert_eq!(a_there.key.leaf, a.key.leaf);
        assert_eq!(other.intersect(&up(-3.0).leaving(a.key)), Some(a_there));
    }
    // Instance 1 leaves the static part: the part is rebuilt, and instance 0's old keys are
    // stale, whichever leaf they name.
    let mut bvh = SceneBvh::new(&scene);
    let old = bvh.intersect(&up(-3.0)).unwrap();
    bvh.set_instance_transform(1, at(4.0));
    bvh.update();
    let fresh = bvh.intersect(&up(-3.0)).unwrap();
    assert_ne!(old.key.part, fresh.key.part);
    let stale = in_part(old.key, fresh.key.leaf);
    assert_eq!(bvh.intersect(&up(-3.0).leaving(stale)), Some(fresh));
    assert!(bvh.intersect(&up(-3.0).leaving(fresh.key)).unwrap().t > fresh.t + 1.5);
    // Instance 1, moving now, is placed again (where it was: any new placement renews its
    // keys), and its key from before skips nothing.
    let before = bvh.intersect(&up(4.0)).unwrap();
    bvh.set_instance_transform(1, at(4.0));
    bvh.update();
    let after = bvh.intersect(&up(4.0)).unwrap();
    assert_eq!(after.key.leaf, before.key.leaf);
    assert_eq!(bvh.intersect(&up(4.0).leaving(before.key)), Some(after));
    assert!(bvh.intersect(&up(4.0).leaving(after.key)).unwrap().t > after.t + 1.5);
}

#[test]
fn spawned_rays_never_rehit_their_triangle_at_millimetre_scale() {
    check_self_intersection(1e-3, Vec3::ZERO, false);
}

#[test]
fn spawned_rays_never_rehit_their_triangle_at_metre_scale() {
    check_self_intersection(1.0, Vec3::ZERO, false);
    check_self_intersection(1.0, Vec3::ZERO, true);
}

#[test]
fn spawned_rays_never_rehit_their_triangle_at_ten_kilometre_scale() {
    check_self_intersection(1e4, Vec3::ZERO, false);
}

#[test]
fn spawned_rays_never_rehit_their_triangle_far_from_the_origin() {
    let far = Vec3::new(1e5, -1e5, 1e5);
    check_self_intersection(1.0, far, false);
    check_self_intersection(1.0, far, true);
    check_self_intersection(1e3, far, false);
}

/// A non-trivial scene: a bumpy ground, a displaced sphere and a second, rotated sphere.
fn test_scene() -> Scene {
    let mut blob = icosphere(4);
    for p in &mut blob.positions {
        *p *= 1.0 + 0.15 * (5.0 * p.x).sin() * (4.0 * p.y).cos();
    }
    let ground = grid(24, |x, z| 0.3 * (x * 0.7).sin() * (z * 0.5).cos());
    scene_of(vec![
        (
            ground,
            Mat4::from_translation(Vec3::new(-12.0, -2.0, -12.0)),
        ),
        (blob, Mat4::from_translation(Vec3::new(0.0, 0.5, 0.0))),
        (
            icosphere(2),
            Mat4::from_scale_rotation_translation(
                Vec3::new(1.0, 0.5, 2.0),
                Quat::from_rotation_z(0.4),
                Vec3::new(3.0, 0.0, -1.0),
            ),
        ),
    ])
}

fn random_ray(rng: &mut Pcg) -> Ray {
    let origin = Vec3::new(
        -10.0 + 20.0 * rng.uniform(),
        -3.0 + 8.0 * rng.uniform(),
        -10.0 + 20.0 * rng.uniform(),
    );
    let t_max = if rng.uniform() < 0.5 {
        f32::INFINITY
    } else {
        10.0 * rng.uniform()
    };
    let dir = if rng.uniform() < 0.5 {
        rng.unit_vector()
    } else {
        // Aimed at the spheres, so that most rays hit something.
        Vec3::new(1.0, 0.0, 0.0) + 3.0 * rng.unit_vector() - origin
    };
    Ray::with_t_max(origin, dir, t_max)
}

/// Closest hit by testing every triangle: `(t, triangle id)`.
fn brute_force(triangles: &[[Vec3; 3]], ray: &Ray) -> Option<(f32, u32)> {
    let mut best = None;
    let mut t_max = ray.t_max;
    for (i, &tri) in triangles.iter().enumerate() {
        if let Some(hit) = intersect_triangle(ray.origin, ray.dir, t_max, tri) {
            t_max = hit.t;
            best = Some((hit.t, i as u32));
        }
    }
    best
}

#[test]
fn bvh_closest_hit_and_occlusion_agree_with_brute_force() {
    let scene = test_scene();
    let triangles: Vec<[Vec3; 3]> = scene
        .world_triangles()
        .into_iter()
        .map(|(t, _)| t)
        .collect();
    let bvh = SceneBvh::new(&scene);
    assert_eq!(bvh.triangle_count(), triangles.len());
    let mut rng = Pcg(4);
    let mut hits = 0;
    for _ in 0..3000 {
        let ray = random_ray(&mut rng);
        let expected = brute_force(&triangles, &ray);
        let got = bvh.intersect(&ray);
        assert_eq!(got.map(|h| h.t), expected.map(|e| e.0), "{ray:?}");
        if let (Some(got), Some((t, id))) = (got, expected) {
            // Ties in t (a ray through a shared edge) may pick either triangle.
            let other = intersect_triangle(
                ray.origin,
                ray.dir,
                f32::INFINITY,
                triangles[got.triangle as usize],
            );
            assert!(got.triangle == id || other.is_some_and(|h| h.t == t));
            assert!((got.position - ray.at(t)).length() < 1e-3);
            hits += 1;
        }
        assert_eq!(bvh.occluded(&ray), expected.is_some(), "{ray:?}");
    }
    assert!(hits > 1000, "too few hits ({hits}) to mean anything");
}

/// The position, shading normal and uv of `hit` made as the hit record made them before the
/// BVH kept a leaf-order record per triangle: from the mesh's index, position, normal and uv
/// arrays, by `hit.instance` and `hit.primitive`.
fn attributes_from_the_mesh(scene: &Scene, hit: &Hit) -> (Vec3, Vec3, glam::Vec2) {
    let inst = &scene.instances[hit.instance as usize];
    let mesh = &scene.meshes[inst.mesh];
    let idx = mesh.triangles[hit.primitive as usize].map(|v| v as usize);
    let (b1, b2) = (hit.barycentrics.x, hit.barycentrics.y);
    let b0 = 1.0 - b1 - b2;
    let p = idx.map(|v| inst.transform.transform_point3(mesh.positions[v]));
    let position = b0 * p[0] + b1 * p[1] + b2 * p[2];
    let normal_matrix = glam::Mat3::from_mat4(inst.transform).inverse().transpose();
    let n = normal_matrix
        * (b0 * mesh.normals[idx[0]] + b1 * mesh.normals[idx[1]] + b2 * mesh.normals[idx[2]]);
    let uv = b0 * mesh.uvs[idx[0]] + b1 * mesh.uvs[idx[1]] + b2 * mesh.uvs[idx[2]];
    (position, n.normalize(), uv)
}

#[test]
fn hit_records_carry_the_mesh_attributes_of_the_triangle_hit_static_and_moving() {
    let scene = test_scene();
    for moving in [&[][..], &[1, 2][..]] {
        let bvh = SceneBvh::with_moving_instances(&scene, moving);
        let mut rng = Pcg(11);
        let mut hits = 0;
        for _ in 0..2000 {
            let ray = random_ray(&mut rng);
            let Some(hit) = bvh.intersect(&ray) else {
                continue;
            };
            // The triangle named is the one hit, and its attributes are its own (a neighbouring
            // triangle's normals differ by its facet angle, > 1e-2 here).
            let (position, n, uv) = attributes_from_the_mesh(&scene, &hit);
            assert!(
                (position - hit.position).length() < 1e-4,
                "{ray:?}: {position} against {}",
                hit.position
            );
            assert!(
                (n - hit.shading_normal).length() < 1e-4,
                "{ray:?}: {n} against {}",
                hit.shading_normal
            );
            assert!(
                (uv - hit.uv).length() < 1e-4,
                "{ray:?}: {uv} against {}",
                hit.uv
            );
            hits += 1;
        }
        assert!(hits > 500, "{hits}");
    }
}

#[test]
fn moving_an_instance_then_updating_matches_a_fresh_build() {
    let scene = test_scene();
    let mut bvh = SceneBvh::with_moving_instances(&scene, &[2]);
    let moved = Mat4::from_scale_rotation_translation(
        Vec3::new(1.5, 0.5, 1.0),
        Quat::from_rotation_y(1.1),
        Vec3::new(-3.0, 1.0, 2.0),
    );
    bvh.set_instance_transform(2, moved);
    // The blob was static: moving it too rebuilds the static part once.
    bvh.set_instance_transform(1, Mat4::from_translation(Vec3::new(0.0, 1.0, 3.0)));
    bvh.update();

    let mut moved_scene = scene.clone();
    moved_scene.instances[2].transform = moved;
    moved_scene.instances[1].transform = Mat4::from_translation(Vec3::new(0.0, 1.0, 3.0));
    let fresh = SceneBvh::with_moving_instances(&moved_scene, &[1, 2]);
    let fresh_static = SceneBvh::new(&moved_scene);

    let mut rng = Pcg(5);
    let mut agree_with_static = 0;
    for _ in 0..3000 {
        let ray = random_ray(&mut rng);
        // The same hits; their keys name parts of two different BVHs (`TriangleKey`).
        let unkeyed = |h: Option<Hit>| {
            h.map(|h| Hit {
                key: TriangleKey::NONE,
                ..h
            })
        };
        let (a, b) = (bvh.intersect(&ray), fresh.intersect(&ray));
        assert_eq!(unkeyed(a), unkeyed(b), "{ray:?}");
        assert_eq!(bvh.occluded(&ray), fresh.occluded(&ray));
        let c = fresh_static.intersect(&ray);
        let same = match (a, c) {
            (Some(a), Some(c)) => a.triangle == c.triangle && (a.t - c.t).abs() <= 1e-4 * c.t,
            (None, None) => true,
            _ => false,
        };
        agree_with_static += same as u32;
    }
    // Instance-space and world-space intersection round differently only at edges.
    assert!(agree_with_static >= 2990, "{agree_with_static}");
}

#[test]
fn shading_attributes_are_interpolated_and_normals_are_unit() {
    let scene = test_scene();
    let bvh = SceneBvh::with_moving_instances(&scene, &[2]);
    let mut rng = Pcg(6);
    for _ in 0..500 {
        let ray = random_ray(&mut rng);
        if let Some(hit) = bvh.intersect(&ray) {
            assert!((hit.geometric_normal.length() - 1.0).abs() < 1e-5);
            assert!((hit.shading_normal.length() - 1.0).abs() < 1e-5);
            assert_eq!(hit.front_face, hit.geometric_normal.dot(ray.dir) < 0.0);
            assert!(hit.uv.is_finite() && hit.barycentrics.min_element() >= 0.0);
            if hit.instance == 0 {
                // The ground's vertex normals are all +Y.
                assert!(hit.shading_normal.abs_diff_eq(Vec3::Y, 1e-6));
            }
        }
    }
}

#[test]
fn empty_scene_has_no_hits() {
    let bvh = SceneBvh::new(&Scene::default());
    let ray = Ray::new(Vec3::ZERO, Vec3::X);
    assert!(bvh.intersect(&ray).is_none() && !bvh.occluded(&ray));
    assert_eq!(bvh.triangle_count(), 0);
}

#[test]
fn mirrored_instances_keep_their_outside_as_the_front_face() {
    let mirror = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    let scene = scene_of(vec![(icosphere(2), mirror)]);
    for bvh in [
        SceneBvh::new(&scene),
        SceneBvh::with_moving_instances(&scene, &[0]),
    ] {
        let ray = Ray::new(Vec3::new(0.1, 0.2, 5.0), -Vec3::Z);
        let hit = bvh.intersect(&ray).expect("hit");
        assert!(hit.front_face && hit.geometric_normal.z > 0.9 && hit.shading_normal.z > 0.9);
    }
}

/// A closed axis-aligned box `[-n, n]³` whose faces are `2n × 2n` grids, so BVH node boxes are
/// flat and their corners coincide with vertices: the worst case for slab-test rounding.
fn grid_box(n: i32) -> crate::scene::Mesh {
    let mut mesh = crate::scene::Mesh {
        name: String::from("grid box"),
        ..Default::default()
    };
    for axis in 0..3 {
        for side in [-n, n] {
            for i in -n..n {
                for j in -n..n {
                    let corner = |a: i32, b: i32| {
                        let mut p = [0.0f32; 3];
                        p[axis] = side as f32;
                        p[(axis + 1) % 3] = a as f32;
                        p[(axis + 2) % 3] = b as f32;
                        Vec3::from(p)
                    };
                    let base = mesh.positions.len() as u32;
                    mesh.positions.extend([
                        corner(i, j),
                        corner(i + 1, j),
                        corner(i + 1, j + 1),
                        corner(i, j + 1),
                    ]);
                    mesh.triangles.push([base, base + 1, base + 2]);
                    mesh.triangles.push([base, base + 2, base + 3]);
                }
            }
        }
    }
    mesh.normals = mesh.positions.iter().map(|p| p.normalize()).collect();
    mesh.uvs = vec![glam::Vec2::ZERO; mesh.positions.len()];
    mesh
}

#[test]
fn rays_from_inside_a_box_through_node_box_corners_always_hit() {
    let mesh = grid_box(4);
    let vertices = mesh.positions.clone();
    for (transform, moving) in [
        (Mat4::IDENTITY, false),
        (
            Mat4::from_scale_rotation_translation(
                Vec3::new(3.0, 0.5, 1.7),
                Quat::IDENTITY,
                Vec3::new(0.3, -4.0, 2.0),
            ),
            false,
        ),
        (Mat4::from_scale(Vec3::new(0.001, 0.002, 0.001)), true),
    ] {
        let scene = scene_of(vec![(mesh.clone(), transform)]);
        let moving_set: &[usize] = if moving { &[0] } else { &[] };
        let bvh = SceneBvh::with_moving_instances(&scene, moving_set);
        let mut rng = Pcg(7);
        for &v in &vertices {
            let target = transform.transform_point3(v);
            for _ in 0..8 {
                let local = 3.9 * Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 1.95;
                let origin = transform.transform_point3(local);
                let ray = Ray::new(origin, target - origin);
                assert!(bvh.intersect(&ray).is_some(), "{ray:?} slipped through");
                assert!(bvh.occluded(&ray), "{ray:?} slipped through (any-hit)");
            }
            for axis in AXES {
                let origin = transform.transform_point3(v - 0.5 * axis);
                let inside = (v - 0.5 * axis).abs().max_element() < 4.0;
                let ray = Ray::new(origin, transform.transform_vector3(axis));
                if inside {
                    assert!(bvh.intersect(&ray).is_some(), "{ray:?} slipped through");
                }
            }
        }
    }
}

#[test]
fn scene_bvh_can_be_shared_between_tracing_threads() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<SceneBvh>();
}
