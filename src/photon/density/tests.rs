//! The k-d tree against brute force, and the radii's classes, k and density.

use super::*;
use crate::photon::rng::Rng;
use crate::photon::types::pack_direction;
use glam::Vec3;

fn brute_force(points: &[Vec3], q: Vec3, k: usize) -> Vec<f32> {
    let mut d: Vec<f32> = points.iter().map(|p| p.distance_squared(q)).collect();
    d.sort_by(f32::total_cmp);
    d.truncate(k);
    d
}

fn random_points(n: usize, seed: u32) -> Vec<Vec3> {
    let mut rng = Rng::new(seed);
    (0..n).map(|_| Vec3::from(rng.next_3())).collect()
}

fn check_against_brute_force(points: &[Vec3], queries: &[Vec3], what: &str) {
    let tree = KdTree::new(points);
    assert_eq!(tree.len(), points.len());
    for k in [0, 1, 2, 3, 7, 16, 64, MAX_K] {
        for &q in queries {
            let expected = brute_force(points, q, k);
            let got = tree.nearest_squared(q, k);
            assert_eq!(got, expected, "{what}: k = {k}, q = {q}");
            let (d, found) = tree.kth_nearest(q, k);
            assert_eq!(found, expected.len(), "{what}: k = {k}");
            let last = expected.last().map_or(0.0, |d2| d2.sqrt());
            assert_eq!(d, last, "{what}: k = {k}, q = {q}");
        }
    }
}

#[test]
fn knn_equals_brute_force_on_random_points() {
    for (n, seed) in [(3, 1), (9, 2), (100, 3), (2000, 4)] {
        let points = random_points(n, seed);
        // Queries at the points themselves and elsewhere, outside the points' box too.
        let mut queries: Vec<Vec3> = points.iter().step_by(n / 3).copied().collect();
        queries.extend(random_points(20, seed + 100).iter().map(|q| *q * 3.0 - 1.0));
        check_against_brute_force(&points, &queries, &format!("{n} random points"));
    }
}

#[test]
fn knn_equals_brute_force_on_points_on_a_plane_with_duplicates() {
    // Photons lie on surfaces: a flat set (one axis constant) with every point three times.
    let flat: Vec<Vec3> = random_points(300, 9)
        .iter()
        .map(|p| Vec3::new(p.x, 0.25, p.z))
        .collect();
    let points: Vec<Vec3> = flat.iter().flat_map(|&p| [p, p, p]).collect();
    let queries: Vec<Vec3> = points.iter().step_by(37).copied().collect();
    check_against_brute_force(&points, &queries, "duplicated plane points");
}

#[test]
fn knn_of_identical_points_is_zero() {
    let points = vec![Vec3::new(0.5, -1.0, 2.0); 1000];
    let q = [points[0], Vec3::ZERO];
    check_against_brute_force(&points, &q, "identical points");
    let tree = KdTree::new(&points);
    assert_eq!(tree.kth_nearest(points[0], 65), (0.0, 65));
}

#[test]
fn knn_of_zero_one_and_two_points() {
    let empty = KdTree::new(&[]);
    assert!(empty.is_empty());
    assert_eq!(empty.kth_nearest(Vec3::ZERO, 4), (0.0, 0));
    assert!(empty.nearest_squared(Vec3::ONE, 4).is_empty());
    for points in [vec![Vec3::X], vec![Vec3::X, Vec3::new(0.0, 3.0, 4.0)]] {
        check_against_brute_force(&points, &[Vec3::ZERO, Vec3::X], "tiny sets");
    }
    let two = KdTree::new(&[Vec3::ZERO, Vec3::new(0.0, 3.0, 4.0)]);
    assert_eq!(two.kth_nearest(Vec3::ZERO, 2), (5.0, 2));
    assert_eq!(two.kth_nearest(Vec3::ZERO, 10), (5.0, 2));
}

/// Every photon's radius by brute force: its k-th nearest neighbour of its class.
fn brute_force_radii(photons: &[Photon], neighbours: Neighbours) -> Vec<f32> {
    photons
        .iter()
        .map(|p| {
            let class = PhotonClass::of_photon(p);
            let same: Vec<Vec3> = photons
                .iter()
                .filter(|q| PhotonClass::of_photon(q) == class)
                .map(|q| q.position)
                .collect();
            let k = neighbours.of(class);
            let d = brute_force(&same, p.position, k + 1);
            let m = d.len() - 1;
            match m {
                0 => NO_NEIGHBOURS,
                m if m < k => d[m].sqrt() * (k as f32 / m as f32).sqrt(),
                _ => d[k].sqrt(),
            }
        })
        .collect()
}

/// A tight cluster of 1500 photons next to 1500 sparse ones (a third of them caustic), with
/// 30 duplicated sparse positions.
fn clustered_photons() -> Vec<Photon> {
    let mut rng = Rng::new(21);
    let mut photons = Vec::new();
    for i in 0..1500 {
        let [x, y, z] = rng.next_3();
        let cluster = Vec3::new(x, y, z) * 1e-4;
        photons.push(photon_at(cluster, 1e-4));
        let sparse = Vec3::from(rng.next_3()) * 2.0;
        photons.push(photon_at(sparse, if i % 3 == 0 { 0.5 } else { 1e-4 }));
        if i % 50 == 0 {
            photons.push(photon_at(sparse, 1e-4));
        }
    }
    photons
}

#[test]
fn every_radius_equals_brute_force_whichever_search_finds_it() {
    // Runs of queries bounded by the last one's answer (its tighter guess first, the safe
    // bound where the guess holds too few), heap searches where the bound holds more than
    // the buffer (the cluster beside sparse photons), duplicates (d = 0), both classes mixed
    // (`each_search_answers_some_queries` checks that every path runs).
    let photons = clustered_photons();
    for (caustic, global) in [(1, 1), (5, 8), (32, 64), (200, 255)] {
        let neighbours = Neighbours { caustic, global };
        assert_eq!(
            knn_radii(&photons, neighbours),
            brute_force_radii(&photons, neighbours),
            "k = {neighbours:?}"
        );
    }
}

#[test]
fn each_search_answers_some_queries() {
    // The photons of the brute-force test above, as one class: the guessed bound, the safe
    // bound and the heap each answer some of its queries, so that test covers all three.
    let positions: Vec<Vec3> = clustered_photons().iter().map(|p| p.position).collect();
    let tree = KdTree::new(&positions);
    for k in [8, 64] {
        let (_, paths) = queries::class_radii_by_path(&tree, k);
        assert!(
            paths.guess > 0 && paths.safe > 0 && paths.heap > 0,
            "k = {k}: {paths:?}"
        );
        assert_eq!(paths.guess + paths.safe + paths.heap, positions.len());
    }
}

#[test]
fn k_is_fixed_up_to_the_reference_count_and_grows_as_its_square_root_above() {
    for n in [0, 1, 5_000, 20_000, REFERENCE_PHOTONS] {
        let k = Neighbours::for_photons(n);
        assert_eq!((k.caustic, k.global), (CAUSTIC_K, GLOBAL_K), "{n}");
    }
    let k = Neighbours::for_photons(4 * REFERENCE_PHOTONS);
    assert_eq!((k.caustic, k.global), (2 * CAUSTIC_K, 2 * GLOBAL_K));
    let k = Neighbours::for_photons(1_000 * REFERENCE_PHOTONS);
    assert_eq!((k.caustic, k.global), (MAX_K - 1, MAX_K - 1));
}

fn photon_at(position: Vec3, rho_p: f32) -> Photon {
    Photon {
        power: Vec3::ONE,
        direction: pack_direction(Vec3::Y, rho_p),
        position,
        normal: Vec3::Y,
    }
}

#[test]
fn the_radius_holds_k_photons_of_a_uniform_set() {
    // N photons spread uniformly over the unit square: π r² N ≈ k. For a Poisson process
    // π d_k² N is Gamma(k, 1)-distributed, of mean k and relative spread 1/√k per photon;
    // the mean over the ≈ 12 800 photons at least 0.1 from the edges (beyond every radius
    // here, so none of their disks is cut by an edge) is within 2 % of k.
    let n = 20_000;
    let mut rng = Rng::new(11);
    let photons: Vec<Photon> = (0..n)
        .map(|_| {
            let [x, z] = rng.next_2();
            photon_at(Vec3::new(x, 0.0, z), 1e-4)
        })
        .collect();
    for k in [8, 16, 64, 128] {
        let neighbours = Neighbours {
            caustic: 1,
            global: k,
        };
        let radii = knn_radii(&photons, neighbours);
        let inner: Vec<f32> = photons
            .iter()
            .zip(&radii)
            .filter(|(p, _)| {
                p.position
                    .x
                    .min(p.position.z)
                    .min(1.0 - p.position.x.max(p.position.z))
                    > 0.1
            })
            .map(|(_, &r)| std::f32::consts::PI * r * r * n as f32)
            .collect();
        assert!(inner.len() > 12_000, "{}", inner.len());
        let mean = inner.iter().sum::<f32>() / inner.len() as f32;
        eprintln!("k = {k}: mean π r² N / k = {:.4}", mean / k as f32);
        assert!(
            (mean / k as f32 - 1.0).abs() < 0.02,
            "k = {k}: mean π r² N = {mean}"
        );
    }
}

#[test]
fn each_class_measures_its_own_density() {
    // A dense caustic (ρp ≈ 1) of 400 photons in a 0.1 m square inside 400 global photons
    // (ρp 10⁻⁴) over a 2 m square: each class's radius is its own class's spacing.
    let mut rng = Rng::new(5);
    let mut photons = Vec::new();
    for _ in 0..400 {
        let [x, z] = rng.next_2();
        photons.push(photon_at(Vec3::new(x * 0.1, 0.0, z * 0.1), 0.9));
        let [x, z] = rng.next_2();
        photons.push(photon_at(
            Vec3::new(x * 2.0 - 1.0, 0.0, z * 2.0 - 1.0),
            1e-4,
        ));
    }
    let neighbours = Neighbours {
        caustic: 16,
        global: 16,
    };
    let (radii, caustic) = knn_radii_and_caustics(&photons, neighbours);
    assert_eq!(caustic, 400, "the caustic photons counted");
    for (p, r) in photons.iter().zip(&radii) {
        let spacing = match PhotonClass::of_photon(p) {
            PhotonClass::Caustic => 0.1 / 20.0,
            PhotonClass::Global => 2.0 / 20.0,
        };
        // Up to ≈ 4 spacings (√(16/π) ≈ 2.3, twice that at an edge or corner).
        assert!(
            (0.5 * spacing..10.0 * spacing).contains(r),
            "{p:?}: r = {r}, spacing {spacing}"
        );
    }
    // Brute force, per class, for a few photons.
    for i in (0..photons.len()).step_by(97) {
        let class = PhotonClass::of_photon(&photons[i]);
        let same: Vec<Vec3> = photons
            .iter()
            .filter(|p| PhotonClass::of_photon(p) == class)
            .map(|p| p.position)
            .collect();
        let d = brute_force(&same, photons[i].position, 17)[16].sqrt();
        assert_eq!(radii[i], d, "photon {i}");
    }
}

#[test]
fn a_class_with_few_photons_uses_what_it_has() {
    // Three caustic photons on a line 1 m apart, one global photon.
    let photons = [
        photon_at(Vec3::ZERO, 1.0),
        photon_at(Vec3::X, 1.0),
        photon_at(Vec3::X * 2.0, 1.0),
        photon_at(Vec3::Z * 5.0, 1e-4),
    ];
    let neighbours = Neighbours {
        caustic: 8,
        global: 8,
    };
    let r = knn_radii(&photons, neighbours);
    // m = 2 neighbours: the farther one scaled by √(8/2) = 2.
    assert_eq!(r[0], 4.0);
    assert_eq!(r[1], 2.0);
    assert_eq!(r[2], 4.0);
    // Alone in its class.
    assert_eq!(r[3], NO_NEIGHBOURS);
    assert!(knn_radii(&[], neighbours).is_empty());
}

#[test]
fn classes_split_at_the_caustic_path_density() {
    assert_eq!(PhotonClass::of(1.0), PhotonClass::Caustic);
    // One glossy bounce of reflectance 0.5: ρ/10.
    assert_eq!(PhotonClass::of(0.05), PhotonClass::Caustic);
    // Two full glossy bounces, one diffuse bounce, nothing.
    assert_eq!(PhotonClass::of(1e-2), PhotonClass::Global);
    assert_eq!(PhotonClass::of(1e-3), PhotonClass::Global);
    assert_eq!(PhotonClass::of(0.0), PhotonClass::Global);
    assert_eq!(PhotonClass::of(f32::NAN), PhotonClass::Global);
}
