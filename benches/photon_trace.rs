//! CPU photon tracing throughput: photon bounces (rays cast by the tracer, each followed by a
//! BSDF evaluation and Russian roulette) per second, against the raw incoherent ray-cast rate
//! of bare `obvhs` (its CWBVH and Möller–Trumbore triangles) and of our `SceneBvh` on the same
//! scene, in the same run, with 1 and 2 rayon threads: on incoherent rays inside the box and on
//! the tracer's own rays (`PHOTON_SEGMENTS`).
//! `cargo bench --bench photon_trace`; results in `docs/performance.md`. Two checks instead of
//! the benchmarks: `PHOTON_MAP_DIGEST=1` prints a digest of the photon map (a change to the
//! tracer that should keep every bit must keep it), and `BVH_STATS=1` with `--features
//! bvh-stats` prints the nodes and triangles tested per ray.
//!
//! Scene: the Cornell-like closed box of `reference::scenes::cornell` (walls of albedo 0.7,
//! coloured side walls) with its sphere subdivided 6 times (81 920 + 12 triangles); a point
//! light below the ceiling; 8192 photons per iteration, up to 16 bounces.

use std::sync::LazyLock;
use std::time::Duration;

use divan::counter::ItemsCount;
use divan::Bencher;
use glam::{Vec3, Vec3A};
use ispm::photon::bsdf::BsdfVariant;
use ispm::photon::bvh::SceneBvh;
use ispm::photon::emit::{emit_photons, EmittedPhoton};
use ispm::photon::ray::Ray;
use ispm::photon::rng::Rng;
use ispm::photon::trace::{trace_from_lights, StoreOn, TraceSettings};
use ispm::reference::scenes::cornell;
use ispm::scene::Scene;
use obvhs::cwbvh::{builder::build_cwbvh_from_tris, CwBvh};
use obvhs::ray::RayHit;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;

const PHOTONS: usize = 8192;
const RAYS: usize = 8192;

fn main() {
    // `PHOTON_MAP_DIGEST=1`: print a digest of the benchmark's photon map and exit, to check
    // that a change to the tracer leaves the map the same bit for bit.
    if std::env::var_os("PHOTON_MAP_DIGEST").is_some() {
        use std::hash::{DefaultHasher, Hasher};
        let map = trace_from_lights(&SCENE, &BVH, &EMITTED, &SETTINGS);
        let mut h = DefaultHasher::new();
        h.write(bytemuck::cast_slice(&map.photons));
        for a in &map.attrition {
            h.write_u64(*a);
        }
        for p in &map.stored_power {
            h.write(bytemuck::bytes_of(p));
        }
        println!(
            "photon map: {} photons, {} rays, digest {:016x}",
            map.photons.len(),
            map.attrition.iter().sum::<u64>(),
            h.finish()
        );
        return;
    }
    // `BVH_STATS=1` with `--features bvh-stats`: print the nodes and triangles tested per ray
    // and exit (docs/performance.md, "The triangle a ray leaves").
    #[cfg(feature = "bvh-stats")]
    if std::env::var_os("BVH_STATS").is_some() {
        print_bvh_stats();
        return;
    }
    divan::main();
}

/// Nodes and triangles tested per ray: by the tracer (its own rays, each skipping the triangle
/// it leaves), by `SceneBvh` on [`PHOTON_SEGMENTS`], and by bare obvhs on them.
#[cfg(feature = "bvh-stats")]
fn print_bvh_stats() {
    // obvhs's `traverse!` names `UVec2` unqualified.
    use glam::UVec2;
    use ispm::photon::bvh::stats;
    let per_ray = |(nodes, triangles): (u64, u64), rays: usize| {
        format!(
            "{:.2} nodes, {:.2} triangles a ray ({rays} rays)",
            nodes as f64 / rays as f64,
            triangles as f64 / rays as f64
        )
    };
    LazyLock::force(&BVH);
    let segments = &*PHOTON_SEGMENTS;
    stats::take();
    let map = trace_from_lights(&SCENE, &BVH, &EMITTED, &SETTINGS);
    let rays = map.attrition.iter().sum::<u64>() as usize;
    println!("photon tracing: {}", per_ray(stats::take(), rays));
    scene_bvh_hits(segments);
    println!(
        "SceneBvh, the tracer's segments: {}",
        per_ray(stats::take(), segments.len())
    );
    let (bvh, tris) = &*RAW;
    let (mut nodes, mut triangles) = (0u64, 0u64);
    for r in segments {
        let ray = obvhs::ray::Ray::new_inf(Vec3A::from(r.origin), Vec3A::from(r.dir));
        let mut hit = RayHit::none();
        let mut state = bvh.new_traversal(ray.direction);
        let mut node;
        obvhs::traverse!(
            bvh,
            node,
            state,
            {
                nodes += 1;
                node.intersect_ray(&ray, state.oct_inv4)
            },
            {
                triangles += 1;
                let t = tris[state.primitive_id as usize].intersect(&ray);
                if t < hit.t {
                    hit.t = t;
                    hit.primitive_id = state.primitive_id;
                }
            }
        );
    }
    println!(
        "bare obvhs, the tracer's segments: {}",
        per_ray((nodes, triangles), segments.len())
    );
}

static SCENE: LazyLock<Scene> = LazyLock::new(|| cornell(6));
static BVH: LazyLock<SceneBvh> = LazyLock::new(|| SceneBvh::new(&SCENE));
static EMITTED: LazyLock<Vec<EmittedPhoton>> = LazyLock::new(|| emit_photons(&SCENE, PHOTONS, 1));

const SETTINGS: TraceSettings = TraceSettings {
    max_bounces: 16,
    seed: 3,
    variant: BsdfVariant::ALL,
    store_on: StoreOn::FiniteLobes,
};

/// Rays the tracer casts per iteration: one per photon alive after each bounce count
/// (`attrition[0]`: the emitted photons' first rays).
static PHOTON_RAYS: LazyLock<u64> = LazyLock::new(|| {
    trace_from_lights(&SCENE, &BVH, &EMITTED, &SETTINGS)
        .attrition
        .iter()
        .sum()
});

/// The segments the tracer casts, one per ray: the emitted photons' first rays as cast, then
/// one ray per stored photon along its segment *from its far end*: from the stored hit back
/// towards where the photon came from (the box is closed and every diffuse hit after the first
/// is stored, so these are all the tracer's rays but the few that a photon's last scattering
/// sends nowhere). A segment traversed backwards visits the nodes round the same line and ends
/// at the same surfaces; the bare-obvhs rate on these rays is the rate of the tracer's own ray
/// distribution, which (unlike `RAY_BATCH`'s) starts on the surfaces and follows the photons
/// where the light sends them.
static PHOTON_SEGMENTS: LazyLock<Vec<Ray>> = LazyLock::new(|| {
    let map = trace_from_lights(&SCENE, &BVH, &EMITTED, &SETTINGS);
    let first = EMITTED.iter().map(|p| Ray::new(p.origin, p.direction));
    let back = map.photons.iter().filter_map(|p| {
        let (towards_source, _) = ispm::photon::types::unpack_direction(p.direction);
        let eps = 1e-4 * p.position.abs().max_element().max(1.0);
        let origin = p.position + p.normal.normalize_or_zero() * eps;
        (towards_source != Vec3::ZERO).then(|| Ray::new(origin, towards_source))
    });
    first.chain(back).collect()
});

/// Incoherent rays inside the box: origins uniform in it, directions uniform on the sphere.
static RAY_BATCH: LazyLock<Vec<Ray>> = LazyLock::new(|| {
    let mut rng = Rng::new(7);
    (0..RAYS)
        .map(|_| {
            let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.9 - 0.95;
            let d = ispm::photon::sampling::uniform_sphere(rng.next_2());
            Ray::new(o, d)
        })
        .collect()
});

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("rayon pool")
}

#[divan::bench(args = [1, 2])]
fn photon_bounces(bencher: Bencher, threads: usize) {
    let pool = pool(threads);
    let rays = *PHOTON_RAYS as usize;
    bencher
        .counter(ItemsCount::new(rays))
        .bench(|| pool.install(|| trace_from_lights(&SCENE, &BVH, &EMITTED, &SETTINGS)));
}

#[divan::bench(args = [1, 2])]
fn incoherent_rays_scene_bvh(bencher: Bencher, threads: usize) {
    let pool = pool(threads);
    LazyLock::force(&BVH);
    bencher
        .counter(ItemsCount::new(RAYS))
        .bench(|| pool.install(|| scene_bvh_hits(&RAY_BATCH)));
}

/// Bare obvhs over the same world triangles (its CWBVH, same build preset as `SceneBvh`),
/// triangles in leaf order: the raw ray-cast rate the tracer's cost is measured against.
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

#[divan::bench(args = [1, 2])]
fn incoherent_rays_raw_obvhs(bencher: Bencher, threads: usize) {
    let pool = pool(threads);
    LazyLock::force(&RAW);
    bencher
        .counter(ItemsCount::new(RAYS))
        .bench(|| pool.install(|| raw_obvhs_hits(&RAY_BATCH)));
}

/// How many of `rays` hit something, by bare obvhs on every thread of the current pool.
fn raw_obvhs_hits(rays: &[Ray]) -> usize {
    let (bvh, tris) = &*RAW;
    rays.par_chunks(256)
        .map(|c| {
            c.iter()
                .filter(|r| {
                    let ray = obvhs::ray::Ray::new_inf(Vec3A::from(r.origin), Vec3A::from(r.dir));
                    let mut hit = RayHit::none();
                    bvh.ray_traverse(ray, &mut hit, |r, id| tris[id].intersect(r))
                })
                .count()
        })
        .sum()
}

/// How many of `rays` hit something, by `SceneBvh::intersect` on every thread of the pool.
fn scene_bvh_hits(rays: &[Ray]) -> usize {
    rays.par_chunks(256)
        .map(|c| c.iter().filter(|r| BVH.intersect(r).is_some()).count())
        .sum()
}

/// Bare obvhs on [`PHOTON_SEGMENTS`]: the raw ray-cast rate of the tracer's own rays.
#[divan::bench(args = [1, 2])]
fn photon_segments_raw_obvhs(bencher: Bencher, threads: usize) {
    let pool = pool(threads);
    LazyLock::force(&RAW);
    let rays = &*PHOTON_SEGMENTS;
    bencher
        .counter(ItemsCount::new(rays.len()))
        .bench(|| pool.install(|| raw_obvhs_hits(rays)));
}

/// `SceneBvh::intersect` on [`PHOTON_SEGMENTS`].
#[divan::bench(args = [1, 2])]
fn photon_segments_scene_bvh(bencher: Bencher, threads: usize) {
    let pool = pool(threads);
    LazyLock::force(&BVH);
    let rays = &*PHOTON_SEGMENTS;
    bencher
        .counter(ItemsCount::new(rays.len()))
        .bench(|| pool.install(|| scene_bvh_hits(rays)));
}
