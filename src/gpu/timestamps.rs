//! GPU timestamps around named scopes, on the host clock.
//!
//! A [`Timestamps`] pool holds the scopes of one frame (one pool per frame slot when several
//! frames are in flight: it is a query pool and a small list, cheap to keep several). Its
//! life per frame:
//! 1. [`Timestamps::reset`]`(frame)` on the host (host query reset), once the GPU has finished
//!    the pool's previous use;
//! 2. recordings made with `Gpu::record(role, name, Some(pool))` on any queue: every
//!    [`Cmd::scope`](super::Cmd::scope) writes a begin and an end timestamp into the queries
//!    this pool hands out, which remembers the recording's queue and its nesting depth;
//! 3. [`Timestamps::read`] once that work has completed: the spans, mapped from device ticks
//!    to the host clock (`gpu/clock.rs`), tagged with queue, depth and frame; while a
//!    [`crate::timing`] capture runs they join it too (once per reset).
//!
//! Queues whose family has `timestampValidBits == 0` write no timestamps (their scopes are
//! debug labels only; logged once).

use super::device::{Gpu, QueueRole, Retired};
use super::error::{vk_err, GpuResult};
use crate::timing::{self, ClockNote, Span, Track};
use ash::vk;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

/// A pool of timestamp queries and the scopes written into it.
pub struct Timestamps {
    gpu: Arc<Gpu>,
    pool: vk::QueryPool,
    capacity: u32,
    next: AtomicU32,
    state: Mutex<State>,
}

#[derive(Default)]
struct State {
    frame: Option<u64>,
    scopes: Vec<ScopeRecord>,
    /// The spans since the last reset were handed to the capture.
    reported: bool,
}

struct ScopeRecord {
    name: String,
    /// Index of the begin query; the end query follows it.
    first: u32,
    role: QueueRole,
    depth: u32,
}

/// Set once a scope went untimed because its queue writes no timestamps.
static NO_TIMESTAMPS_LOGGED: AtomicBool = AtomicBool::new(false);

/// A timestamp query pool of `count` queries, reset on the host.
pub(super) fn create_timestamp_pool(gpu: &Gpu, name: &str, count: u32) -> GpuResult<vk::QueryPool> {
    let info = vk::QueryPoolCreateInfo::default()
        .query_type(vk::QueryType::TIMESTAMP)
        .query_count(count);
    // SAFETY: the device is live and the create info is valid.
    let pool =
        unsafe { gpu.raw().create_query_pool(&info, None) }.map_err(vk_err("vkCreateQueryPool"))?;
    gpu.set_name(pool, name);
    // SAFETY: hostQueryReset is enabled; the pool is new, so no GPU work uses it.
    unsafe { gpu.raw().reset_query_pool(pool, 0, count) };
    Ok(pool)
}

/// The ticks of queries `[first, first + count)` of `pool`; `None` for one not yet written.
/// Does not wait.
pub(super) fn read_ticks(
    gpu: &Gpu,
    pool: vk::QueryPool,
    first: u32,
    count: u32,
) -> GpuResult<Vec<Option<u64>>> {
    // Value and availability per query.
    let mut raw = vec![[0u64; 2]; count as usize];
    // SAFETY: the range lies inside the pool; each element holds a 64-bit value and a 64-bit
    // availability word, as TYPE_64 | WITH_AVAILABILITY writes them.
    let result = unsafe {
        gpu.raw().get_query_pool_results(
            pool,
            first,
            &mut raw,
            vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WITH_AVAILABILITY,
        )
    };
    match result {
        Ok(()) | Err(vk::Result::NOT_READY) => {}
        Err(e) => return Err(vk_err("vkGetQueryPoolResults")(e)),
    }
    Ok(raw
        .into_iter()
        .map(|[value, available]| (available != 0).then_some(value))
        .collect())
}

impl Timestamps {
    /// A pool for `scopes` scopes (two queries each).
    pub fn new(gpu: &Arc<Gpu>, name: &str, scopes: u32) -> GpuResult<Arc<Timestamps>> {
        let capacity = scopes.max(1) * 2;
        let pool = create_timestamp_pool(gpu, name, capacity)?;
        Ok(Arc::new(Timestamps {
            gpu: gpu.clone(),
            pool,
            capacity,
            next: AtomicU32::new(0),
            state: Mutex::new(State::default()),
        }))
    }

    fn state(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Resets every query on the host for frame `frame`. The GPU must be done with the
    /// previous use.
    pub fn reset(&self, frame: u64) {
        // SAFETY: hostQueryReset is enabled; the caller guarantees no pending GPU work uses
        // the pool.
        unsafe { self.gpu.raw().reset_query_pool(self.pool, 0, self.capacity) };
        self.next.store(0, Ordering::Release);
        let mut state = self.state();
        state.frame = Some(frame);
        state.scopes.clear();
        state.reported = false;
    }

    /// Opens scope `name` at nesting `depth` of a recording for `role`: its index and the
    /// query its begin timestamp goes to (`Cmd::scope` writes it); `None` when the scope goes
    /// untimed.
    pub(super) fn begin(
        &self,
        role: QueueRole,
        name: &str,
        depth: u32,
    ) -> Option<(usize, vk::QueryPool, u32)> {
        if self.gpu.queue(role).timestamp_valid_bits == 0 {
            if !NO_TIMESTAMPS_LOGGED.swap(true, Ordering::Relaxed) {
                log::warn!(
                    "the {} queue's family writes no timestamps: its passes are not timed",
                    role.name()
                );
            }
            return None;
        }
        let first = self.next.fetch_add(2, Ordering::AcqRel);
        if first + 1 >= self.capacity {
            log::warn!("timestamp pool full: scope {name} is not timed");
            return None;
        }
        let mut state = self.state();
        state.scopes.push(ScopeRecord {
            name: name.to_string(),
            first,
            role,
            depth,
        });
        Some((state.scopes.len() - 1, self.pool, first))
    }

    /// The query the end timestamp of `scope` goes to.
    pub(super) fn end(&self, scope: usize) -> Option<(vk::QueryPool, u32)> {
        let first = self.state().scopes.get(scope).map(|s| s.first)?;
        Some((self.pool, first + 1))
    }

    /// The spans written since the last reset, on the host clock. Call after the GPU work
    /// completed (a scope whose timestamps are not available yet is left out). While a
    /// capture runs, the first read after a reset adds the spans to it.
    pub fn read(&self) -> anyhow::Result<Vec<Span>> {
        let count = self.next.load(Ordering::Acquire).min(self.capacity);
        if count == 0 {
            return Ok(Vec::new());
        }
        let ticks = read_ticks(&self.gpu, self.pool, 0, count)?;
        let calibration = self.gpu.clock_calibration()?;
        let period = f64::from(self.gpu.properties.timestamp_period);
        let mut state = self.state();
        let frame = state.frame;
        let spans: Vec<Span> = state
            .scopes
            .iter()
            .filter_map(|s| {
                let queue = self.gpu.queue_index(s.role);
                let bits = self.gpu.queue_list()[queue].timestamp_valid_bits;
                let host = |q: u32| {
                    let t = (*ticks.get(q as usize)?)?;
                    calibration.to_host_ns(t, bits, period)
                };
                Some(Span {
                    name: s.name.clone(),
                    track: Track::Gpu {
                        queue,
                        role: s.role,
                    },
                    frame,
                    depth: s.depth,
                    begin_ns: host(s.first)?,
                    end_ns: host(s.first + 1)?,
                })
            })
            .collect();
        if timing::capturing() && !state.reported {
            state.reported = true;
            let queues = (0..self.gpu.queue_list().len())
                .map(|q| (q, self.gpu.queue_label(q)))
                .collect();
            let note = ClockNote {
                method: calibration.source.to_string(),
                uncertainty_ns: calibration.uncertainty_ns,
            };
            timing::record_gpu(spans.clone(), queues, note);
        }
        Ok(spans)
    }
}

impl Drop for Timestamps {
    fn drop(&mut self) {
        self.gpu.retire(Retired::QueryPool(self.pool));
    }
}
