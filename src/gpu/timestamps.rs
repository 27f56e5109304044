//! GPU timestamps around named scopes.
//!
//! A [`Timestamps`] pool is reset on the host ([`Timestamps::reset`], host query reset) once
//! the GPU has finished the previous use; every [`Cmd::scope`](super::Cmd::scope) then writes a
//! begin and an end timestamp, and [`Timestamps::read`] turns them into nanosecond spans on the
//! device clock after the work completed.

use super::cmd::Cmd;
use super::device::{Gpu, Retired};
use super::error::{vk_err, GpuResult};
use ash::vk;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

/// A pool of timestamp queries and the names of the scopes written into it.
pub struct Timestamps {
    gpu: Arc<Gpu>,
    pool: vk::QueryPool,
    capacity: u32,
    next: AtomicU32,
    names: Mutex<Vec<(String, u32)>>,
}

/// One timed scope, in device nanoseconds.
#[derive(Clone, Debug, PartialEq)]
pub struct Span {
    pub name: String,
    pub begin_ns: f64,
    pub end_ns: f64,
}

impl Span {
    pub fn ms(&self) -> f64 {
        (self.end_ns - self.begin_ns) * 1e-6
    }
}

impl Timestamps {
    /// A pool for `scopes` scopes (two queries each).
    pub fn new(gpu: &Arc<Gpu>, name: &str, scopes: u32) -> GpuResult<Arc<Timestamps>> {
        let capacity = scopes * 2;
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(capacity);
        // SAFETY: the device is live and the create info is valid.
        let pool = unsafe { gpu.raw().create_query_pool(&info, None) }
            .map_err(vk_err("vkCreateQueryPool"))?;
        gpu.set_name(pool, name);
        let t = Timestamps {
            gpu: gpu.clone(),
            pool,
            capacity,
            next: AtomicU32::new(0),
            names: Mutex::new(Vec::new()),
        };
        t.reset();
        Ok(Arc::new(t))
    }

    /// Resets every query on the host. The GPU must be done with the previous use.
    pub fn reset(&self) {
        // SAFETY: hostQueryReset is enabled; the caller guarantees no pending GPU work uses
        // the pool.
        unsafe { self.gpu.raw().reset_query_pool(self.pool, 0, self.capacity) };
        self.next.store(0, Ordering::Release);
        if let Ok(mut n) = self.names.lock() {
            n.clear();
        }
    }

    pub(super) fn write_begin(&self, cmd: &Cmd, name: &str) -> Option<usize> {
        let first = self.next.fetch_add(2, Ordering::AcqRel);
        if first + 1 >= self.capacity {
            log::warn!("timestamp pool full: scope {name} is not timed");
            return None;
        }
        self.write(cmd, first);
        let mut names = self.names.lock().ok()?;
        names.push((name.to_string(), first));
        Some(names.len() - 1)
    }

    pub(super) fn write_end(&self, cmd: &Cmd, scope: usize) {
        let first = self
            .names
            .lock()
            .ok()
            .and_then(|n| n.get(scope).map(|s| s.1));
        if let Some(first) = first {
            self.write(cmd, first + 1);
        }
    }

    fn write(&self, cmd: &Cmd, query: u32) {
        // SAFETY: recording state; the query index is < capacity and was reset on the host
        // before this use; synchronization2 is enabled.
        unsafe {
            cmd.device().cmd_write_timestamp2(
                cmd.raw(),
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                query,
            )
        };
    }

    /// The spans written since the last reset. Call after the GPU work completed.
    pub fn read(&self) -> anyhow::Result<Vec<Span>> {
        let count = self.next.load(Ordering::Acquire).min(self.capacity);
        if count == 0 {
            return Ok(Vec::new());
        }
        let mut ticks = vec![0u64; count as usize];
        // SAFETY: the queries [0, count) were written by completed work; the output slice
        // holds one u64 per query.
        unsafe {
            self.gpu.raw().get_query_pool_results(
                self.pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .map_err(vk_err("vkGetQueryPoolResults"))?;
        let period = f64::from(self.gpu.properties.timestamp_period);
        let names = self.names.lock().map(|n| n.clone()).unwrap_or_default();
        Ok(names
            .into_iter()
            .filter(|(_, first)| first + 1 < count)
            .map(|(name, first)| Span {
                name,
                begin_ns: ticks[first as usize] as f64 * period,
                end_ns: ticks[first as usize + 1] as f64 * period,
            })
            .collect())
    }
}

impl Drop for Timestamps {
    fn drop(&mut self) {
        self.gpu.retire(Retired::QueryPool(self.pool));
    }
}
