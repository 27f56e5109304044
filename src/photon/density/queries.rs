//! The queries of the k-d tree: what a search collects (the k nearest in a max-heap, or every
//! distance under a bound), and the runs of queries, each bounded by the last one's answer, that
//! give every point of a class its kNN radius (module docs of [`crate::photon::density`],
//! "Radius" and "The k-d tree").

use super::{KdTree, LEAF, MAX_K, NO_NEIGHBOURS, QUERY_RUN};
use glam::Vec3;
use rayon::prelude::*;

/// The fraction of the step from the last query that a bounded query first adds to the last
/// query's radius (module docs of [`crate::photon::density`], "The k-d tree"). On
/// `benches/host_estimate.rs`'s 100k-photon map (131 723 global photons, k = 64, one thread,
/// 2026-11-27), the share of queries whose guess holds too few points: 50 % with a guess of 0,
/// 20 % with 0.1, 7 % with 0.2, 2.7 % with 0.3, 0.7 % with 0.5; 0.2 took the least time, 165 ms
/// against 233 ms with the safe bound alone (1.0).
const GUESS: f32 = 0.2;

/// The most squared distances a bounded query collects before it falls back to a heap.
const WITHIN_CAPACITY: usize = 4 * MAX_K;

/// What a search collects: the squared distances it is offered, and the bound a point or a
/// subtree must beat to matter.
pub(super) trait Collect {
    fn offer(&mut self, d2: f32);
    fn bound(&self) -> f32;

    /// Offers a leaf's squared distances (infinity for a lane without a point).
    #[inline(always)]
    fn offer_leaf(&mut self, d2: &[f32; LEAF]) {
        for &d in d2 {
            self.offer(d);
        }
    }
}

/// The k smallest squared distances offered: a max-heap in a fixed buffer.
pub(super) struct Nearest {
    pub(super) d2: [f32; MAX_K],
    pub(super) len: usize,
    k: usize,
}

impl Nearest {
    pub(super) fn new(k: usize) -> Self {
        Self {
            d2: [0.0; MAX_K],
            len: 0,
            k: k.min(MAX_K),
        }
    }

    /// The k-th smallest squared distance (the largest kept; 0 when none).
    pub(super) fn kth(&self) -> f32 {
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
        // Only distances below the limit were kept: none is negative or NaN, and the bits of
        // non-negative floats order as their values do (cheaper than `total_cmp`).
        let found = &mut self.d2[..self.len];
        Some(*found.select_nth_unstable_by_key(n - 1, |d| d.to_bits()).1)
    }
}

impl Collect for Within {
    fn bound(&self) -> f32 {
        self.limit
    }

    /// Appends every distance below the limit without a branch per lane: each lane is written
    /// at the current length, which only a distance below the limit advances. A leaf that
    /// might not fit goes through [`Collect::offer`] one by one, so the buffer's overflow is
    /// the same as before.
    #[inline(always)]
    fn offer_leaf(&mut self, d2: &[f32; LEAF]) {
        if self.len + LEAF > WITHIN_CAPACITY {
            for &d in d2 {
                self.offer(d);
            }
            return;
        }
        for &d in d2 {
            self.d2[self.len] = d;
            self.len += usize::from(d < self.limit);
        }
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

/// The kNN radius of every point of one class (module docs, "Radius"), in tree order.
pub(super) fn class_radii(tree: &KdTree, k: usize) -> Vec<f32> {
    class_radii_by_path(tree, k).0
}

/// How many queries each search answered: the guessed bound, the safe bound, the heap.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Paths {
    pub guess: usize,
    pub safe: usize,
    pub heap: usize,
}

impl std::ops::Add for Paths {
    type Output = Paths;
    fn add(self, o: Paths) -> Paths {
        Paths {
            guess: self.guess + o.guess,
            safe: self.safe + o.safe,
            heap: self.heap + o.heap,
        }
    }
}

/// [`class_radii`], and which search answered how many queries (tests).
pub(super) fn class_radii_by_path(tree: &KdTree, k: usize) -> (Vec<f32>, Paths) {
    // The point itself is its own nearest: its k + 1 nearest hold k neighbours.
    let k = k.clamp(1, MAX_K - 1);
    let mut out = vec![0.0; tree.len()];
    let paths = out
        .par_chunks_mut(QUERY_RUN)
        .zip(tree.points().par_chunks(QUERY_RUN))
        .map(|(out, points)| run_radii(tree, k, points, out))
        .reduce(Paths::default, |a, b| a + b);
    (out, paths)
}

/// The kNN radii of a run of `points` (consecutive in tree order) into `out`, each query bounded
/// by the last one's answer (module docs, "The k-d tree"), and which search answered each.
fn run_radii(tree: &KdTree, k: usize, points: &[Vec3], out: &mut [f32]) -> Paths {
    let wanted = (k + 1).min(tree.len());
    let mut within = Within::new();
    let mut last: Option<(Vec3, f32)> = None;
    let mut paths = Paths::default();
    for (r, &p) in out.iter_mut().zip(points) {
        // The last query's `wanted` points lie within d + |p − q| of p; the density changes
        // little from one point to the next, so first try d + GUESS·|p − q|, which holds
        // them for most queries with fewer points to select from (each bound widened for
        // rounding; one that holds too few is searched again with the next, then a heap).
        let bounded = last.and_then(|(q, d)| {
            let step = p.distance(q);
            // At the same point the guess is the safe bound: one search.
            let alphas: &[f32] = if step > 0.0 { &[GUESS, 1.0] } else { &[1.0] };
            for &alpha in alphas {
                let bound = (d + alpha * step) * (1.0 + 1e-5);
                // Above 0 even at d = 0 (duplicates): points at distance 0 are below it.
                within.reset((bound * bound).max(f32::MIN_POSITIVE));
                tree.search(p, &mut within);
                if let Some(d2) = within.nth(wanted) {
                    match alpha == GUESS {
                        true => paths.guess += 1,
                        false => paths.safe += 1,
                    }
                    return Some(d2);
                }
                if within.overflow {
                    // A wider bound would hold more still: the heap.
                    return None;
                }
            }
            None
        });
        let (d2, found) = bounded.map_or_else(
            || {
                paths.heap += 1;
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
    paths
}
