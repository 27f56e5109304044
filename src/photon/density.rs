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
//! right range `mid+1..hi`; ranges of at most [`LEAF`] points are leaves, scanned whole (below).
//! It adds one byte per point (the split axis) and a second copy of the coordinates, by axis.
//! A search visits the near side
//! first and skips a subtree whose region lies farther than the current bound (its distance from
//! the query accumulated axis by axis, Arya and Mount's incremental distance); pending subtrees
//! wait on a fixed stack, and the distances found go into a fixed buffer: no allocation per
//! query.
//!
//! [`knn_radii`] queries the points in the tree's own order, in runs of [`QUERY_RUN`] on every
//! core (rayon). Consecutive points are near each other, and the last query's answer bounds the
//! next one's: its k + 1 points lie within `d + |p − q|` of the new point `p`. So a query
//! collects the squared distances below a bound and selects the (k + 1)-th
//! (`select_nth_unstable_by_key`, on the distances' bits) instead of keeping a heap. The density
//! changes little from one point to the next, so it first tries the tighter `d + 0.2·|p − q|`
//! (`GUESS` in `queries.rs`): fewer points to collect and select from, enough for 93 % of the
//! queries on a 100k-photon map; the rest are searched again with the safe `d + |p − q|`
//! (about k·(1 + |p − q|/d)² points). `benches/host_estimate.rs`, one thread: the guess 233 →
//! 165 ms (1.41×, `queries.rs`), the guess and the selection on bits together 249 → 166 ms
//! (1.5×, against the safe bound with `total_cmp`). A bound that overflows the buffer goes
//! straight to a max-heap of the k + 1 best, as do a bound that holds too few points
//! (rounding) and the first query of a run. A bound that holds at least k + 1
//! points holds the k + 1 nearest, so every path finds the exact k-th distance, and the result
//! does not depend on the number of threads. (On 200k points on the faces of a cube, k = 64, 2
//! cores: a heap per query and the split plane's distance as the bound took about 600 ms; the
//! last query's bound, the incremental distance and collect-and-select brought it to 190 ms,
//! measured on a shared machine. On `cornell-box`'s 194k photons it takes ~180 ms.)
//!
//! A leaf's distances are computed [`LEAF`] lanes at once, from the points' coordinates kept a
//! second time by axis (structure of arrays, padded with points at infinity; the compiler
//! vectorises the loop), rounding as `Vec3::distance_squared` does, and a bounded query appends
//! those below its bound without a branch per point. With leaves of 16 instead of 8 points and
//! the tree's subranges of at least 2048 points built on two threads (was 16 384), the radii
//! took 1.27× less time on one thread and 1.30× on two (the 10k-photon map of
//! `benches/host_estimate.rs`), 1.20× on two at 100k; the radii are the same bit for bit
//! (renders before and after compared byte for byte).

mod kdtree;
mod queries;
#[cfg(test)]
mod tests;

pub use kdtree::KdTree;

use crate::photon::types::{unpack_direction, Photon};
use queries::class_radii;

/// ρp above which a photon is a caustic photon: no diffuse bounce on its path (module docs,
/// "Classes").
pub const CAUSTIC_PATH_DENSITY: f32 = crate::layout::shared_constants::CAUSTIC_PATH_DENSITY;

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

/// Points of a leaf range, scanned all at once (module docs, "The k-d tree"). 16 measured
/// fastest of 8, 16 and 32 (`cargo bench --bench host_estimate`, 100k photons, one thread: 269,
/// 249 and 262 ms).
pub const LEAF: usize = 16;

/// Points of the tree (in tree order) one worker queries in turn, each query bounding the next
/// (module docs, "The k-d tree").
pub const QUERY_RUN: usize = 256;

/// The radius of a photon alone in its class: no density to measure. Above every kernel
/// clamp, so the kernel gives it `r_max`.
pub const NO_NEIGHBOURS: f32 = f32::INFINITY;

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

/// Each photon's kNN radius `r_i` (metres; [`NO_NEIGHBOURS`] for a photon alone in its class),
/// in the order of `photons`: the distance to its `neighbours.of(class)`-th nearest neighbour
/// among the photons of its class (module docs). Deterministic, on every core.
pub fn knn_radii<'a>(
    photons: impl IntoIterator<Item = &'a Photon>,
    neighbours: Neighbours,
) -> Vec<f32> {
    knn_radii_and_caustics(photons, neighbours).0
}

/// [`knn_radii`], and how many of the photons are caustic photons ([`PhotonClass`]: each
/// photon's class is read once, for both).
pub fn knn_radii_and_caustics<'a>(
    photons: impl IntoIterator<Item = &'a Photon>,
    neighbours: Neighbours,
) -> (Vec<f32>, usize) {
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
    (radii, index[PhotonClass::Caustic as usize].len())
}
