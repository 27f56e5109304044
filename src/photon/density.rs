//! Kernel radii from the photons' own density: the distance to each photon's k-th nearest
//! neighbour of its class (no Vulkan). The photon volumes and the CPU `photon-gather` take
//! their kernel radius from it ([`crate::photon::kernel`], "Radius from the photon density").
//!
//! # Classes
//! The path density ρp (packed in the photon's direction, [`crate::photon::types`]) is the
//! product of one factor per bounce: mean(ρ)/1000 for a Lambertian lobe, mean(ρ)/10 for a
//! glossy one, mean(ρ) for a mirror or refraction (`photon::bsdf::path_density_factor`).
//! Reflectances are at most 1, so one Lambertian bounce anywhere on the path puts ρp at or below
//! 10⁻³. A photon is a **caustic** photon when `ρp > CAUSTIC_PATH_DENSITY` (10⁻²): every bounce
//! of its path was a mirror, a refraction or a glossy lobe, and at most one of them glossy at full
//! reflectance (two give exactly 10⁻², which is not above it). Every other photon is a
//! **global** photon. The classes differ in how their density varies: caustic photons are
//! focused into small bright shapes with sharp edges, global photons spread smoothly over the
//! room. So each class finds its neighbours among its own photons only (a caustic photon's
//! radius is not widened by the sparse global photons around it, nor a global photon's shrunk
//! by a caustic it lies in) and has its own k ([`Neighbours`]), as photon mappers since
//! Jensen's keep a caustic map and a global map.
//!
//! # Radius
//! For photon i of a class of n photons, `d_k(i)` is the distance to its k-th nearest
//! neighbour of the class (itself not counted; coincident photons are neighbours at distance
//! 0), and its radius is `r_i = d_k(i)`: the disk of radius `r_i` around it holds about k
//! photons of its class (`π r_i² N ≈ k` for N points spread uniformly over a unit area, tested).
//! (A scale per class, `r_i = c·d_k`, would only be another k, `k·c²`; k is the one knob.) A
//! class with `n ≤ k` photons uses what it has: `r_i = d_m(i)·√(k/m)`, `m = n − 1`, the radius
//! that holds k photons at the density its m neighbours show; a photon alone in its class has no
//! density ([`NO_NEIGHBOURS`]: the kernel's `r_max`).
//!
//! k per class ([`Neighbours::for_photons`]) was chosen on the bundled scenes at 640×480 and
//! 100k photons against progressive references (docs/accuracy.md, "Kernel radius from the photon
//! density"): [`GLOBAL_K`] and [`CAUSTIC_K`] give their reasons. Up to
//! [`REFERENCE_PHOTONS`] emitted photons k stays fixed; above, it grows as `√N`, so that the
//! photons per kernel grow as `√N` and the radius shrinks as `N^(−1/4)`, the consistent schedule
//! `r_max` follows (`photon::kernel`, "Radius from the photon count"): bias and noise both fall
//! as N grows. (A fixed k keeps the photons per kernel constant, the schedule whose noise does not
//! fall; below the reference count the measured errors favour the larger fixed k over a k that
//! shrinks with N.)
//!
//! # The k-d tree
//! [`KdTree`] is a compact, implicit tree over the points: the points are permuted so that the
//! node of a range `lo..hi` is its middle point, split on the axis of the range's widest extent
//! (`select_nth_unstable_by`, so the build is O(n log n)), with its left range `lo..mid` and its
//! right range `mid+1..hi`; ranges of at most [`LEAF`] points are leaves, scanned linearly. One
//! byte per point (the split axis) is all it adds to the points. A search visits the near side
//! first and skips a subtree whose region lies farther than the current bound (its distance from
//! the query accumulated axis by axis, Arya and Mount's incremental distance); pending subtrees
//! wait on a fixed stack, and the distances found go into a fixed buffer: no allocation per
//! query.
//!
//! [`knn_radii`] queries the points in the tree's own order, in runs of [`QUERY_RUN`] on every
//! core (rayon). Consecutive points are near each other, and the last query's answer bounds the
//! next one's: its k + 1 points lie within `d + |p − q|` of the new point `p`. So a query
//! collects the squared distances below that bound (about k·(1 + |p − q|/d)² of them) and selects
//! the (k + 1)-th (`select_nth_unstable_by`) instead of keeping a heap; a query whose bound holds
//! too few points (rounding) or too many for the buffer, and the first of a run, search with a
//! max-heap of the k + 1 best instead. Every path finds the exact k-th distance, so the result
//! does not depend on the number of threads. (On 200k points on the faces of a cube, k = 64, 2
//! cores: a heap per query and the split plane's distance as the bound took about 600 ms; the
//! last query's bound, the incremental distance and collect-and-select brought it to 190 ms,
//! measured on a shared machine. On `cornell-box`'s 194k photons it takes ~180 ms.)

use crate::photon::types::{unpack_direction, Photon};
use glam::Vec3;
use rayon::prelude::*;

/// ρp above which a photon is a caustic photon: no diffuse bounce on its path (module docs,
/// "Classes").
pub const CAUSTIC_PATH_DENSITY: f32 = crate::shared_constants::CAUSTIC_PATH_DENSITY;

/// k of the global photons at up to [`REFERENCE_PHOTONS`] emitted photons. On `cornell-box` at
/// 640×480 and 100k photons (whole-image relMSE against progressive photon mapping; photon
/// volumes on lavapipe, idle 2 cores, caustic k 16): k = 32: 0.0292, 1.06 s; 48: 0.0247, 1.25 s;
/// 64: 0.0227, 1.39 s; 96: 0.0212, 1.52 s; 128: 0.0209, 1.56 s; the path-density radius it
/// replaces: 0.0310, 1.58 s. Each step from 32 to 96 trades 7–15 % of error for 9–18 % of fill,
/// and past 96 most global photons reach `r_max`. 64 is the largest k whose frame, this module's
/// host time included (~180 ms), is no slower than the path-density rule's: a quarter less error
/// at no cost in time (docs/accuracy.md §6).
pub const GLOBAL_K: usize = 64;

/// k of the caustic photons at up to [`REFERENCE_PHOTONS`] emitted photons. The caustic views
/// lay photons on a lattice (light-view texels projected through the mirror or glass), which a
/// cone kernel smooths only when its radius spans about three lattice spacings: √(32/π) ≈ 3.2
/// does, √(16/π) ≈ 2.3 leaves the lattice's moiré at the cusp of `caustic-ring`'s cardioid.
/// Measured at 640×480, 100k photons (whole-image relMSE): `caustic-ring` k = 8: 0.0646, 16:
/// 0.0557, 24: 0.0490, 32: 0.0452 (the path-density radius: 0.1934); `glass-sphere` 0.0162,
/// 0.0161, –, 0.0161 (0.0240); `cornell-box` 0.02265 at 16 and 32. The focused spot of
/// `glass-sphere` and the cusp stay sharp: there the photons are dense and the footprint floor
/// rules.
pub const CAUSTIC_K: usize = 32;

/// Emitted photons up to which k is [`GLOBAL_K`] and [`CAUSTIC_K`]; above, k grows as `√N`
/// (module docs, "Radius"). The renderer's default budget.
pub const REFERENCE_PHOTONS: usize = 100_000;

/// The most neighbours a query may ask for, itself included (its heap's size): k ≤ `MAX_K − 1`,
/// which the global class reaches at about 1.6 M emitted photons (k stays there beyond).
pub const MAX_K: usize = 256;

/// Points of a leaf range, scanned linearly.
pub const LEAF: usize = 8;

/// Points of the tree (in tree order) one worker queries in turn, each query bounding the next
/// (module docs, "The k-d tree").
pub const QUERY_RUN: usize = 256;

/// The radius of a photon alone in its class: no density to measure. Above every kernel
/// clamp, so the kernel gives it `r_max`.
pub const NO_NEIGHBOURS: f32 = f32::INFINITY;

/// Ranges at least this large are built on two threads (`rayon::join`).
const PARALLEL_BUILD: usize = 16_384;

/// Deepest pending-subtree stack of a query: one entry per level, and a tree over 2³² points of
/// leaves of [`LEAF`] has fewer than 32 levels.
const STACK: usize = 64;

/// The most squared distances a bounded query collects before it falls back to a heap.
const WITHIN_CAPACITY: usize = 4 * MAX_K;

/// Which neighbours a photon's radius is measured against (module docs, "Classes").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhotonClass {
    /// Only mirror, refraction and glossy bounces on its path: `ρp > CAUSTIC_PATH_DENSITY`.
    Caustic,
    /// At least one diffuse bounce (or two full glossy ones) on its path.
    Global,
}

impl PhotonClass {
    /// The class of a photon whose path density is `rho_p` (NaN: global).
    pub fn of(rho_p: f32) -> Self {
        if rho_p > CAUSTIC_PATH_DENSITY {
            Self::Caustic
        } else {
            Self::Global
        }
    }

    /// The class of a stored photon (its ρp, from its packed direction).
    pub fn of_photon(photon: &Photon) -> Self {
        Self::of(unpack_direction(photon.direction).1)
    }
}

/// k per class: how many neighbours of its class a photon's kernel disk holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Neighbours {
    pub caustic: usize,
    pub global: usize,
}

impl Neighbours {
    /// k per class for `photons` emitted photons: [`CAUSTIC_K`] and [`GLOBAL_K`] up to
    /// [`REFERENCE_PHOTONS`], times `√(photons/REFERENCE_PHOTONS)` above (rounded; at most
    /// `MAX_K − 1`).
    pub fn for_photons(photons: usize) -> Self {
        let growth = (photons as f64 / REFERENCE_PHOTONS as f64).sqrt().max(1.0);
        let k = |base: usize| ((base as f64 * growth).round() as usize).min(MAX_K - 1);
        Self {
            caustic: k(CAUSTIC_K),
            global: k(GLOBAL_K),
        }
    }

    /// k of `class`.
    pub fn of(&self, class: PhotonClass) -> usize {
        match class {
            PhotonClass::Caustic => self.caustic,
            PhotonClass::Global => self.global,
        }
    }
}

/// An implicit k-d tree over points (module docs, "The k-d tree").
pub struct KdTree {
    /// The points, permuted into tree order.
    points: Vec<Vec3>,
    /// `ids[j]`: the index in the input of the point at tree position `j`.
    ids: Vec<u32>,
    /// The split axis of the node whose middle point is at `j` (unused at leaves).
    axes: Vec<u8>,
}

/// The axis of `entries`' widest extent.
fn widest_axis(entries: &[(Vec3, u32)]) -> usize {
    let (lo, hi) = entries.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), (p, _)| (lo.min(*p), hi.max(*p)),
    );
    let e = hi - lo;
    // NaN extents (points with NaN coordinates) compare false: axis 0.
    if e.y > e.x && e.y >= e.z {
        1
    } else if e.z > e.x && e.z > e.y {
        2
    } else {
        0
    }
}

fn build(entries: &mut [(Vec3, u32)], axes: &mut [u8]) {
    let n = entries.len();
    if n <= LEAF {
        return;
    }
    let axis = widest_axis(entries);
    let mid = n / 2;
    entries.select_nth_unstable_by(mid, |a, b| a.0[axis].total_cmp(&b.0[axis]));
    axes[mid] = axis as u8;
    let (left, rest) = entries.split_at_mut(mid);
    let (axes_left, axes_rest) = axes.split_at_mut(mid);
    let (right, axes_right) = (&mut rest[1..], &mut axes_rest[1..]);
    if n >= PARALLEL_BUILD {
        rayon::join(|| build(left, axes_left), || build(right, axes_right));
    } else {
        build(left, axes_left);
        build(right, axes_right);
    }
}

/// What a search collects: the squared distances it is offered, and the bound a point or a
/// subtree must beat to matter.
trait Collect {
    fn offer(&mut self, d2: f32);
    fn bound(&self) -> f32;
}

/// The k smallest squared distances offered: a max-heap in a fixed buffer.
struct Nearest {
    d2: [f32; MAX_K],
    len: usize,
    k: usize,
}

impl Nearest {
    fn new(k: usize) -> Self {
        Self {
            d2: [0.0; MAX_K],
            len: 0,
            k: k.min(MAX_K),
        }
    }

    /// The k-th smallest squared distance (the largest kept; 0 when none).
    fn kth(&self) -> f32 {
        if self.len == 0 {
            0.0
        } else {
            self.d2[0]
        }
    }
}

impl Collect for Nearest {
    /// The k-th best once there are k, else ∞.
    fn bound(&self) -> f32 {
        if self.len < self.k {
            f32::INFINITY
        } else {
            self.d2[0]
        }
    }

    fn offer(&mut self, d2: f32) {
        // False for NaN: a point with NaN coordinates never enters.
        let enters = d2 < self.bound();
        if !enters {
            return;
        }
        let h = &mut self.d2;
        if self.len < self.k {
            let mut i = self.len;
            self.len += 1;
            while i > 0 {
                let parent = (i - 1) / 2;
                if h[parent] >= d2 {
                    break;
                }
                h[i] = h[parent];
                i = parent;
            }
            h[i] = d2;
        } else {
            let mut i = 0;
            loop {
                let (a, b) = (2 * i + 1, 2 * i + 2);
                let mut largest = i;
                let mut value = d2;
                if a < self.len && h[a] > value {
                    largest = a;
                    value = h[a];
                }
                if b < self.len && h[b] > value {
                    largest = b;
                }
                if largest == i {
                    break;
                }
                h[i] = h[largest];
                i = largest;
            }
            h[i] = d2;
        }
    }
}

/// Every squared distance offered below a fixed limit, in a fixed buffer.
struct Within {
    d2: [f32; WITHIN_CAPACITY],
    len: usize,
    limit: f32,
    /// More than the buffer holds were below the limit (the search then stops).
    overflow: bool,
}

impl Within {
    fn new() -> Self {
        Self {
            d2: [0.0; WITHIN_CAPACITY],
            len: 0,
            limit: 0.0,
            overflow: false,
        }
    }

    /// Empties it for a search below `limit`.
    fn reset(&mut self, limit: f32) {
        (self.len, self.limit, self.overflow) = (0, limit, false);
    }

    /// The `n`-th smallest squared distance collected (1-based), if there are `n`.
    fn nth(&mut self, n: usize) -> Option<f32> {
        if self.overflow || n == 0 || self.len < n {
            return None;
        }
        let found = &mut self.d2[..self.len];
        Some(*found.select_nth_unstable_by(n - 1, f32::total_cmp).1)
    }
}

impl Collect for Within {
    fn bound(&self) -> f32 {
        self.limit
    }

    fn offer(&mut self, d2: f32) {
        if d2 < self.limit {
            if self.len == WITHIN_CAPACITY {
                // The caller searches again with a heap: stop here.
                self.overflow = true;
                self.limit = f32::NEG_INFINITY;
                return;
            }
            self.d2[self.len] = d2;
            self.len += 1;
        }
    }
}

impl KdTree {
    /// The tree over `points` (their indices are what [`Self::ids`] returns).
    pub fn new(points: &[Vec3]) -> Self {
        assert!(
            u32::try_from(points.len()).is_ok(),
            "a k-d tree holds fewer than 2³² points"
        );
        let mut entries: Vec<(Vec3, u32)> = points
            .iter()
            .enumerate()
            .map(|(i, &p)| (p, i as u32))
            .collect();
        let mut axes = vec![0u8; points.len()];
        build(&mut entries, &mut axes);
        let (points, ids) = entries.into_iter().unzip();
        Self { points, ids, axes }
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The points in tree order.
    pub fn points(&self) -> &[Vec3] {
        &self.points
    }

    /// The input index of each point in tree order.
    pub fn ids(&self) -> &[u32] {
        &self.ids
    }

    /// Offers `found` the squared distance from `q` of every point of the tree that may beat
    /// its bound (module docs, "The k-d tree").
    fn search(&self, q: Vec3, found: &mut impl Collect) {
        if self.points.is_empty() {
            return;
        }
        // Pending subtrees: their range and the per-axis offsets from `q` to their region, whose
        // squared length bounds the distance of every point in it from below.
        let mut stack = [(0u32, 0u32, Vec3::ZERO); STACK];
        let mut top = 0;
        let (mut lo, mut hi, mut offset) = (0usize, self.points.len(), Vec3::ZERO);
        loop {
            if hi - lo <= LEAF {
                for p in &self.points[lo..hi] {
                    found.offer(p.distance_squared(q));
                }
            } else {
                let mid = lo + (hi - lo) / 2;
                let axis = self.axes[mid] as usize;
                let p = self.points[mid];
                found.offer(p.distance_squared(q));
                let diff = q[axis] - p[axis];
                let (near, far) = if diff < 0.0 {
                    ((lo, mid), (mid + 1, hi))
                } else {
                    ((mid + 1, hi), (lo, mid))
                };
                if far.0 < far.1 {
                    let mut far_offset = offset;
                    far_offset[axis] = diff;
                    stack[top] = (far.0 as u32, far.1 as u32, far_offset);
                    top += 1;
                }
                (lo, hi) = near;
                continue;
            }
            // The next pending subtree that may still hold a nearer point.
            loop {
                if top == 0 {
                    return;
                }
                top -= 1;
                let (a, b, o) = stack[top];
                if o.length_squared() < found.bound() {
                    (lo, hi, offset) = (a as usize, b as usize, o);
                    break;
                }
            }
        }
    }

    /// The squared distances from `q` of its `k` nearest points of the tree, ascending (points
    /// at `q` included; fewer when the tree holds fewer than `k`). `k` is at most [`MAX_K`].
    pub fn nearest_squared(&self, q: Vec3, k: usize) -> Vec<f32> {
        assert!(k <= MAX_K, "k = {k} > MAX_K = {MAX_K}");
        let mut nearest = Nearest::new(k);
        if k > 0 {
            self.search(q, &mut nearest);
        }
        let mut out = nearest.d2[..nearest.len].to_vec();
        out.sort_by(f32::total_cmp);
        out
    }

    /// The distance from `q` of its `k`-th nearest point of the tree (points at `q` included)
    /// and `k`, or of the farthest there is and their number when the tree holds fewer;
    /// `(0, 0)` for `k = 0` or an empty tree. `k` is at most [`MAX_K`].
    pub fn kth_nearest(&self, q: Vec3, k: usize) -> (f32, usize) {
        assert!(k <= MAX_K, "k = {k} > MAX_K = {MAX_K}");
        let mut nearest = Nearest::new(k);
        if k > 0 {
            self.search(q, &mut nearest);
        }
        (nearest.kth().sqrt(), nearest.len)
    }
}

/// The kNN radius of every point of one class (module docs, "Radius"), in tree order.
fn class_radii(tree: &KdTree, k: usize) -> Vec<f32> {
    // The point itself is its own nearest: its k + 1 nearest hold k neighbours.
    let k = k.clamp(1, MAX_K - 1);
    let wanted = (k + 1).min(tree.len());
    let mut out = vec![0.0; tree.len()];
    out.par_chunks_mut(QUERY_RUN)
        .zip(tree.points().par_chunks(QUERY_RUN))
        .for_each(|(out, points)| {
            let mut within = Within::new();
            let mut last: Option<(Vec3, f32)> = None;
            for (r, &p) in out.iter_mut().zip(points) {
                // The last query's `wanted` points lie within d + |p − q| of p (widened for
                // rounding: a bound that holds too few is searched again with a heap).
                let bounded = last.and_then(|(q, d)| {
                    let bound = (d + p.distance(q)) * (1.0 + 1e-5) + 1e-30;
                    within.reset(bound * bound);
                    tree.search(p, &mut within);
                    within.nth(wanted)
                });
                let (d2, found) = bounded.map_or_else(
                    || {
                        let mut nearest = Nearest::new(wanted);
                        tree.search(p, &mut nearest);
                        (nearest.kth(), nearest.len)
                    },
                    |d2| (d2, wanted),
                );
                let d = d2.sqrt();
                last = d.is_finite().then_some((p, d));
                let m = found.saturating_sub(1);
                *r = if m == 0 {
                    NO_NEIGHBOURS
                } else if m < k {
                    d * (k as f32 / m as f32).sqrt()
                } else {
                    d
                };
            }
        });
    out
}

/// Each photon's kNN radius `r_i` (metres; [`NO_NEIGHBOURS`] for a photon alone in its class),
/// in the order of `photons`: the distance to its `neighbours.of(class)`-th nearest neighbour
/// among the photons of its class (module docs). Deterministic, on every core.
pub fn knn_radii<'a>(
    photons: impl IntoIterator<Item = &'a Photon>,
    neighbours: Neighbours,
) -> Vec<f32> {
    let mut positions = [Vec::new(), Vec::new()];
    let mut index = [Vec::new(), Vec::new()];
    for (i, p) in photons.into_iter().enumerate() {
        let c = PhotonClass::of_photon(p) as usize;
        positions[c].push(p.position);
        index[c].push(i);
    }
    let mut radii = vec![NO_NEIGHBOURS; index[0].len() + index[1].len()];
    for class in [PhotonClass::Caustic, PhotonClass::Global] {
        let c = class as usize;
        if positions[c].is_empty() {
            continue;
        }
        let tree = KdTree::new(&positions[c]);
        let r = class_radii(&tree, neighbours.of(class));
        for (&id, r) in tree.ids().iter().zip(r) {
            radii[index[c][id as usize]] = r;
        }
    }
    radii
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::rng::Rng;
    use crate::photon::types::pack_direction;

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

    #[test]
    fn every_radius_equals_brute_force_whichever_search_finds_it() {
        // Runs of queries bounded by the last one's answer, heap searches where the bound is
        // too tight (duplicates: d = 0) or holds more than the buffer (a tight cluster of 1500
        // photons next to sparse ones), both classes mixed.
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
        let radii = knn_radii(&photons, neighbours);
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
}
