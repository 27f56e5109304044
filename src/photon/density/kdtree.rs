//! [`KdTree`]: the implicit k-d tree over one class's points (module docs of
//! [`crate::photon::density`], "The k-d tree"): its build, and the search that offers a
//! [`Collect`] every point that may beat its bound.

use super::queries::{Collect, Nearest};
use super::{LEAF, MAX_K};
use glam::Vec3;

/// Ranges at least this large are built on two threads (`rayon::join`).
const PARALLEL_BUILD: usize = 2_048;

/// Deepest pending-subtree stack of a query: one entry per level, and a tree over 2³² points of
/// leaves of [`LEAF`] has fewer than 32 levels.
const STACK: usize = 64;

/// An implicit k-d tree over points (module docs, "The k-d tree").
pub struct KdTree {
    /// The points, permuted into tree order.
    points: Vec<Vec3>,
    /// `ids[j]`: the index in the input of the point at tree position `j`.
    ids: Vec<u32>,
    /// The split axis of the node whose middle point is at `j` (unused at leaves).
    axes: Vec<u8>,
    /// The points' coordinates by axis, in tree order, followed by [`LEAF`] points at infinity:
    /// a leaf's distances are computed [`LEAF`] lanes at a time ([`Self::leaf_distances`]).
    xyz: [Vec<f32>; 3],
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
        let (points, ids): (Vec<Vec3>, Vec<u32>) = entries.into_iter().unzip();
        let xyz = [0, 1, 2].map(|axis| {
            (points.iter().map(|p| p[axis]))
                .chain([f32::INFINITY; LEAF])
                .collect()
        });
        Self {
            points,
            ids,
            axes,
            xyz,
        }
    }

    /// The squared distances from `q` of the points `lo..lo + LEAF` (tree order; points past
    /// the end at infinity), each computed as `Vec3::distance_squared` does, so bit for bit
    /// the same; lanes `n..` are set to infinity.
    #[inline(always)]
    fn leaf_distances(&self, q: Vec3, lo: usize, n: usize) -> [f32; LEAF] {
        let [x, y, z] = [0, 1, 2].map(|axis| &self.xyz[axis][lo..lo + LEAF]);
        let mut d2 = [0.0; LEAF];
        for j in 0..LEAF {
            let (dx, dy, dz) = (x[j] - q.x, y[j] - q.y, z[j] - q.z);
            let d = dx * dx + dy * dy + dz * dz;
            d2[j] = if j < n { d } else { f32::INFINITY };
        }
        d2
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
    pub(super) fn search(&self, q: Vec3, found: &mut impl Collect) {
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
                found.offer_leaf(&self.leaf_distances(q, lo, hi - lo));
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
