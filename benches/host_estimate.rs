//! The host's share of a frame's radiance estimate on a GPU (docs/performance.md, "Where the
//! frame goes"): the photons' kNN radii (`photon::density::knn_radii`, every core) and the tiled
//! estimator's lists (`passes::photon_tiles::lists::bin`) on one thread and on every core, and
//! the order its workgroups take the tiles in (`passes::photon_tiles::order`), in the same run. `cargo bench --bench host_estimate`; results in `docs/performance.md`.
//! `RAYON_NUM_THREADS=N` sets the threads of the benchmarks without an argument.
//!
//! Photon map: the Cornell-like closed box of `reference::scenes::cornell` (its sphere
//! subdivided 4 times), 100 000 photons emitted from its point light, traced by the CPU tracer
//! (all lobes, up to 16 bounces; about 190 000 stored); the kNN radii also of 10 000 emitted
//! (the default preset's). Screen: 640×480 from the scene's camera,
//! the kernel of 100 000 photons at radius ×1.

use std::sync::LazyLock;

use divan::Bencher;
use glam::{Mat3, Mat4};
use ispm::passes::photon_tiles::lists::{bin, Screen};
use ispm::passes::photon_tiles::order::{dispatch_order, TileOrder};
use ispm::photon::bsdf::BsdfVariant;
use ispm::photon::bvh::SceneBvh;
use ispm::photon::density::{knn_radii, Neighbours};
use ispm::photon::emit::emit_photons;
use ispm::photon::kernel::KernelSettings;
use ispm::photon::trace::{trace_from_lights, PhotonMap, StoreOn, TraceSettings};
use ispm::photon::types::{pack_normal, Photon};
use ispm::reference::gather::GatherMap;
use ispm::reference::scenes::cornell;
use ispm::render::photon_frame::environment::indirect_cube;
use ispm::scene::Scene;

const PHOTONS: usize = 100_000;
const SIZE: (u32, u32) = (640, 480);

fn main() {
    divan::main();
}

static SCENE: LazyLock<Scene> = LazyLock::new(|| cornell(4));

/// The photon map traced from `emitted` photons.
fn traced(emitted: usize) -> Vec<Photon> {
    let bvh = SceneBvh::new(&SCENE);
    let emitted = emit_photons(&SCENE, emitted, 1);
    let settings = TraceSettings {
        max_bounces: 16,
        seed: 3,
        variant: BsdfVariant::ALL,
        store_on: StoreOn::FiniteLobes,
    };
    trace_from_lights(&SCENE, &bvh, &emitted, &settings).photons
}

/// The traced photon map of [`PHOTONS`] photons.
static MAP: LazyLock<Vec<Photon>> = LazyLock::new(|| traced(PHOTONS));

/// The same of the default preset's 10 000 photons.
static MAP_10K: LazyLock<Vec<Photon>> = LazyLock::new(|| traced(10_000));

/// The map as the tiled estimator bins it: normals packed with the kNN radii.
static DRAWN: LazyLock<Vec<Photon>> = LazyLock::new(|| {
    let radii = knn_radii(MAP.iter(), Neighbours::for_photons(PHOTONS));
    MAP.iter()
        .zip(radii)
        .map(|(p, r)| Photon {
            normal: pack_normal(p.normal, r),
            ..*p
        })
        .collect()
});

/// A rayon pool of `n` threads (0: one per core).
fn pool(n: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .expect("a thread pool")
}

/// The kNN radii of the map of `emitted` photons, on every core.
#[divan::bench(args = [10_000, PHOTONS], sample_count = 20)]
fn knn_radii_every_core(bencher: Bencher, emitted: usize) {
    let map = if emitted == PHOTONS { &*MAP } else { &*MAP_10K };
    let neighbours = Neighbours::for_photons(emitted);
    bencher.bench(|| knn_radii(map.iter(), neighbours));
}

/// The tile lists of the 640×480 screen on a pool of `n` threads (0: one per core), split for
/// as many (on the calling thread alone for one, as the renderer bins on a CPU device).
#[divan::bench(args = [1, 2, 0], sample_count = 20)]
fn tile_lists(bencher: Bencher, n: usize) {
    let (screen, kernel, offset) = screen();
    let counts = [DRAWN.len() as u32];
    let pool = pool(n);
    let threads = pool.current_num_threads();
    bencher.bench(|| {
        pool.install(|| {
            bin(
                |range| DRAWN[range].iter().copied(),
                &counts,
                (&kernel, offset),
                &screen,
                threads,
            )
        })
    });
}

/// The order in which the gather's workgroups take the 4800 tiles of those lists
/// (`passes::photon_tiles::order`): row-major (a GPU's) and balanced (a CPU device's).
#[divan::bench(args = ["rows", "balanced"], sample_count = 50)]
fn tile_order(bencher: Bencher, order: &str) {
    let (screen, kernel, offset) = screen();
    let counts = [DRAWN.len() as u32];
    let lists = bin(
        |range| DRAWN[range].iter().copied(),
        &counts,
        (&kernel, offset),
        &screen,
        1,
    );
    let order = match order {
        "rows" => TileOrder::Rows,
        _ => TileOrder::Balanced,
    };
    let lengths = lists.lengths(0);
    bencher.bench(|| dispatch_order(&lengths, 0, true, order));
}

/// The 640×480 screen from the scene's camera, the kernel of [`PHOTONS`] and the eye offset.
fn screen() -> (Screen, KernelSettings, glam::Vec3) {
    let camera = &SCENE.camera;
    let rotation = Mat4::from_mat3(Mat3::from_mat4(camera.view()));
    let aspect = SIZE.0 as f32 / SIZE.1 as f32;
    let proj = glam::camera::rh::proj::vulkan::perspective_infinite_reverse(
        camera.yfov,
        aspect,
        camera.znear,
    );
    let screen = Screen {
        view_proj: proj * rotation,
        size: SIZE,
        subsample: 1,
    };
    let kernel = KernelSettings::scene_relative(&SCENE.bounds(), PHOTONS, None)
        .for_view(camera.yfov, SIZE.1);
    (screen, kernel, -camera.position())
}

/// The environment cube's indirect light (6 × 32² texels, each a ray and a gather of the
/// photon map) at the box's centre, from the map of `emitted` photons, on every core.
#[divan::bench(args = [10_000, PHOTONS], sample_count = 10)]
fn environment_cube(bencher: Bencher, emitted: usize) {
    let map = if emitted == PHOTONS { &*MAP } else { &*MAP_10K };
    let bvh = SceneBvh::new(&SCENE);
    let radii = knn_radii(map.iter(), Neighbours::for_photons(emitted));
    let kernel = KernelSettings::scene_relative(&SCENE.bounds(), emitted, None);
    let centre = glam::Vec3::ZERO;
    let photon_map = PhotonMap {
        photons: map.clone(),
        ..Default::default()
    };
    let gather = GatherMap::with_knn_radii(photon_map, &radii, &kernel, centre);
    let delta = SCENE.delta_instance_mask();
    bencher.bench(|| {
        indirect_cube(
            &SCENE,
            &bvh,
            &gather,
            &delta,
            centre,
            kernel.gather_exponent_max(),
        )
    });
}

/// The same in the bundled `caustic-ring` (the metal ring's cube, centred in the ring 0.1 m
/// above the floor), whose kNN radii span two orders of magnitude: the ring's focused caustic
/// beside the sparse light it scatters over the floor.
#[divan::bench(args = [10_000, PHOTONS], sample_count = 10)]
fn environment_cube_caustic_ring(bencher: Bencher, emitted: usize) {
    let scene = ispm::scene::bundled::resolve(Some("caustic-ring")).expect("bundled scene");
    let bvh = SceneBvh::new(&scene);
    let settings = TraceSettings {
        max_bounces: 16,
        seed: 3,
        variant: BsdfVariant::ALL,
        store_on: StoreOn::FiniteLobes,
    };
    let map = trace_from_lights(&scene, &bvh, &emit_photons(&scene, emitted, 1), &settings);
    let radii = knn_radii(map.photons.iter(), Neighbours::for_photons(emitted));
    let kernel = KernelSettings::scene_relative(&scene.bounds(), emitted, None);
    let centre = glam::Vec3::new(0.0, 0.1, 0.0);
    let gather = GatherMap::with_knn_radii(map, &radii, &kernel, centre);
    let delta = scene.delta_instance_mask();
    bencher.bench(|| {
        indirect_cube(
            &scene,
            &bvh,
            &gather,
            &delta,
            centre,
            kernel.gather_exponent_max(),
        )
    });
}
