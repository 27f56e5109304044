//! Incoherent ray tracing throughput on a ~100k-triangle scene: obvhs's CWBVH traversal with
//! its own (non-watertight) Möller–Trumbore test against [`SceneBvh`] with our watertight test,
//! plus build and update times of the two-level structure. `cargo bench --bench trace`.

use std::sync::{LazyLock, Mutex};
use std::time::Duration;

use divan::counter::ItemsCount;
use divan::Bencher;
use glam::{Mat4, Quat, Vec3, Vec3A};
use ispm::photon::bvh::SceneBvh;
use ispm::photon::ray::Ray;
use ispm::photon::shapes::{grid, icosphere, scene_of};
use ispm::photon::triangle::WatertightRay;
use ispm::scene::Scene;
use obvhs::cwbvh::{builder::build_cwbvh_from_tris, CwBvh};
use obvhs::ray::RayHit;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

const RAYS: usize = 4096;
/// Instance index of the 82k-triangle sphere in [`scene`].
const BLOB: usize = 1;

fn main() {
    divan::main();
}

/// A bumpy 100×100 ground (20 000 triangles) and a displaced icosphere (81 920 triangles).
fn scene() -> Scene {
    let mut blob = icosphere(6);
    for p in &mut blob.positions {
        *p *= 1.0 + 0.1 * (7.0 * p.x).sin() * (5.0 * p.y).cos() * (3.0 * p.z).sin();
    }
    scene_of(vec![
        (
            grid(100, |x, z| 0.5 * (x * 0.3).sin() * (z * 0.2).cos()),
            Mat4::from_translation(Vec3::new(-50.0, -10.0, -50.0)),
        ),
        (
            blob,
            Mat4::from_scale_rotation_translation(Vec3::splat(8.0), Quat::IDENTITY, Vec3::ZERO),
        ),
    ])
}

static SCENE: LazyLock<Scene> = LazyLock::new(scene);

/// Random origins in the scene's box, uniform random directions (deterministic LCG).
static RAY_BATCH: LazyLock<Vec<Ray>> = LazyLock::new(|| {
    let bounds = SCENE.bounds();
    let mut state = 0x853c_49e6_748f_ea9bu64;
    let mut uniform = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..RAYS)
        .map(|_| {
            let origin = bounds.min + bounds.extent() * Vec3::new(uniform(), uniform(), uniform());
            let z = 1.0 - 2.0 * uniform();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * uniform();
            Ray::new(origin, Vec3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect()
});

static STATIC_BVH: LazyLock<SceneBvh> = LazyLock::new(|| SceneBvh::new(&SCENE));
static TWO_LEVEL_BVH: LazyLock<Mutex<SceneBvh>> =
    LazyLock::new(|| Mutex::new(SceneBvh::with_moving_instances(&SCENE, &[BLOB])));

/// obvhs's CWBVH over the world triangles (same preset), triangles in leaf order.
static RAW: LazyLock<(CwBvh, Vec<Triangle>)> = LazyLock::new(|| {
    let tris: Vec<Triangle> = SCENE
        .world_triangles()
        .into_iter()
        .map(|([a, b, c], _)| Triangle {
            v0: a.into(),
            v1: b.into(),
            v2: c.into(),
        })
        .collect();
    let bvh = build_cwbvh_from_tris(
        &tris,
        BvhBuildParams::medium_build(),
        &mut Duration::default(),
    );
    let ordered = bvh
        .primitive_indices
        .iter()
        .map(|&i| tris[i as usize])
        .collect();
    (bvh, ordered)
});

#[divan::bench]
fn closest_hit_obvhs_moller_trumbore(bencher: Bencher) {
    let (bvh, tris) = &*RAW;
    let rays = &*RAY_BATCH;
    bencher.counter(ItemsCount::new(RAYS)).bench(|| {
        let mut hits = 0u32;
        for ray in rays {
            let ray = obvhs::ray::Ray::new_inf(Vec3A::from(ray.origin), Vec3A::from(ray.dir));
            let mut hit = RayHit::none();
            hits += bvh.ray_traverse(ray, &mut hit, |r, id| tris[id].intersect(r)) as u32;
        }
        hits
    });
}

/// obvhs's node test and traversal with our watertight triangle test: isolates the cost of
/// the triangle test from that of the conservative node test.
#[divan::bench]
fn closest_hit_obvhs_nodes_watertight_triangles(bencher: Bencher) {
    let (bvh, tris) = &*RAW;
    let rays = &*RAY_BATCH;
    bencher.counter(ItemsCount::new(RAYS)).bench(|| {
        let mut hits = 0u32;
        for ray in rays {
            let watertight = WatertightRay::new(ray.origin, ray.dir);
            let ray = obvhs::ray::Ray::new_inf(Vec3A::from(ray.origin), Vec3A::from(ray.dir));
            let mut hit = RayHit::none();
            hits += bvh.ray_traverse(ray, &mut hit, |r, id| {
                let t = &tris[id];
                watertight
                    .intersect(t.v0.into(), t.v1.into(), t.v2.into(), r.tmax)
                    .map_or(f32::INFINITY, |h| h.t)
            }) as u32;
        }
        hits
    });
}

#[divan::bench]
fn closest_hit_scene_bvh_watertight(bencher: Bencher) {
    let bvh = &*STATIC_BVH;
    let rays = &*RAY_BATCH;
    bencher
        .counter(ItemsCount::new(RAYS))
        .bench(|| rays.iter().filter(|r| bvh.intersect(r).is_some()).count());
}

#[divan::bench]
fn closest_hit_scene_bvh_two_level(bencher: Bencher) {
    let bvh = TWO_LEVEL_BVH.lock().expect("unpoisoned");
    let rays = &*RAY_BATCH;
    bencher
        .counter(ItemsCount::new(RAYS))
        .bench(|| rays.iter().filter(|r| bvh.intersect(r).is_some()).count());
}

#[divan::bench]
fn any_hit_obvhs_moller_trumbore(bencher: Bencher) {
    let (bvh, tris) = &*RAW;
    let rays = &*RAY_BATCH;
    bencher.counter(ItemsCount::new(RAYS)).bench(|| {
        rays.iter()
            .filter(|ray| {
                let ray = obvhs::ray::Ray::new_inf(Vec3A::from(ray.origin), Vec3A::from(ray.dir));
                !bvh.ray_traverse_miss(ray, |r, id| tris[id].intersect(r))
            })
            .count()
    });
}

#[divan::bench]
fn any_hit_scene_bvh_watertight(bencher: Bencher) {
    let bvh = &*STATIC_BVH;
    let rays = &*RAY_BATCH;
    bencher
        .counter(ItemsCount::new(RAYS))
        .bench(|| rays.iter().filter(|r| bvh.occluded(r)).count());
}

#[divan::bench(sample_count = 5, sample_size = 1)]
fn build_scene_bvh_static(bencher: Bencher) {
    let scene = &*SCENE;
    bencher.bench(|| SceneBvh::new(scene).triangle_count());
}

#[divan::bench]
fn update_after_moving_instance(bencher: Bencher) {
    let mut bvh = TWO_LEVEL_BVH.lock().expect("unpoisoned");
    let mut angle = 0.0f32;
    bencher.bench_local(|| {
        angle += 0.01;
        bvh.set_instance_transform(
            BLOB,
            Mat4::from_rotation_y(angle) * Mat4::from_scale(Vec3::splat(8.0)),
        );
        bvh.update();
    });
}
