//! Counters of the nodes and triangles [`super::SceneBvh`]'s queries test, in every thread,
//! compiled in only with the `bvh-stats` feature (they are atomics in the traversal's inner
//! loop). `benches/photon_trace.rs` prints them per ray (`BVH_STATS=1`; docs/performance.md,
//! "CPU photon tracing").

use std::sync::atomic::{AtomicU64, Ordering};

static NODES: AtomicU64 = AtomicU64::new(0);
static TRIANGLES: AtomicU64 = AtomicU64::new(0);

/// One node test.
#[inline(always)]
pub(super) fn count_node() {
    NODES.fetch_add(1, Ordering::Relaxed);
}

/// One triangle test (the triangle a ray leaves and the instances `intersect_skipping` leaves
/// out are not tested, and not counted).
#[inline(always)]
pub(super) fn count_triangle() {
    TRIANGLES.fetch_add(1, Ordering::Relaxed);
}

/// The node and triangle tests counted since the last call, and the counters reset.
pub fn take() -> (u64, u64) {
    (
        NODES.swap(0, Ordering::Relaxed),
        TRIANGLES.swap(0, Ordering::Relaxed),
    )
}
