//! Putting this device's clock on the host's: [`Gpu::clock_calibration`] (calibrated where the
//! device can, else an offset measured by one-shot submissions; `gpu/clock.rs` says how each
//! works). Apart from `clock.rs` because the measurement records, submits and reads timestamps:
//! the clock's types stay below the device, this file above the command stream.

use super::clock::{Calibration, ClockSource};
use super::device::{Gpu, QueueRole, Retired};
use super::error::{GpuError, GpuResult};
use super::timestamps::{create_timestamp_pool, read_ticks};
use crate::timing::now_ns;
use std::sync::Arc;

/// Tries of the measured offset; the tightest bracket wins.
const MEASURE_TRIES: u32 = 8;

impl Gpu {
    /// A device-clock reading paired with the host clock: calibrated now where the device can,
    /// else the offset measured at device creation.
    pub fn clock_calibration(self: &Arc<Self>) -> GpuResult<Calibration> {
        if let Some(c) = self.clock.calibrated() {
            return c;
        }
        if let Some(c) = self.clock.measured.get() {
            return Ok(*c);
        }
        let c = self.measure_clock_offset(MEASURE_TRIES)?;
        Ok(*self.clock.measured.get_or_init(|| c))
    }

    /// How this device's timestamps are put on the host clock.
    pub fn clock_source(&self) -> ClockSource {
        self.clock.source()
    }

    /// Measures the device-clock ↔ host-clock offset with `tries` one-shot submissions (the
    /// fallback of calibrated timestamps; public so that tests can compare the two). Blocks
    /// on each submission: call while the device is idle for a tight bracket.
    pub fn measure_clock_offset(self: &Arc<Self>, tries: u32) -> GpuResult<Calibration> {
        let role = QueueRole::ALL
            .into_iter()
            .find(|&r| self.queue(r).timestamp_valid_bits > 0)
            .ok_or(GpuError::NoTimestamps(
                "no queue family has timestampValidBits > 0",
            ))?;
        let tries = tries.max(1);
        let pool = create_timestamp_pool(self, "clock calibration", tries)?;
        let mut best: Option<Calibration> = None;
        let mut result = Ok(());
        for query in 0..tries {
            let attempt = (|| {
                let rec = self.record(role, "clock calibration", None)?;
                rec.cmd().write_timestamp(pool, query);
                let before = now_ns();
                let point = self.submit(rec, &[])?;
                self.wait(point)?;
                let after = now_ns();
                let ticks = read_ticks(self, pool, query, 1)?[0];
                Ok::<_, GpuError>(ticks.map(|device_ticks| Calibration {
                    device_ticks,
                    host_ns: before + (after - before) / 2,
                    uncertainty_ns: (after - before).div_ceil(2),
                    source: ClockSource::MeasuredOffset,
                }))
            })();
            match attempt {
                Ok(Some(c)) if best.is_none_or(|b| c.uncertainty_ns < b.uncertainty_ns) => {
                    best = Some(c)
                }
                Ok(_) => {}
                Err(e) => {
                    result = Err(e);
                    break;
                }
            }
        }
        self.retire(Retired::QueryPool(pool));
        result?;
        best.ok_or(GpuError::NoTimestamps("no calibration timestamp came back"))
    }
}
