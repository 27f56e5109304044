//! One time base: device timestamp ticks → nanoseconds of the host clock that CPU spans use
//! ([`crate::timing::now_ns`], `CLOCK_MONOTONIC`).
//!
//! - **Calibrated**: where the device has `VK_KHR_calibrated_timestamps` or
//!   `VK_EXT_calibrated_timestamps` and offers `CLOCK_MONOTONIC` (or, on Linux,
//!   `CLOCK_MONOTONIC_RAW`) among its time domains, `Gpu::clock_calibration` (`gpu/calibrate.rs`) reads the
//!   device clock and the host clock at one instant (± the driver's `maxDeviation`), afresh at
//!   every call, so drift between the clocks does not build up. A `CLOCK_MONOTONIC_RAW`
//!   reading is moved to `CLOCK_MONOTONIC` by host reads of both around it.
//! - **Measured offset** otherwise: a one-shot submission writes a timestamp; host clock reads
//!   just before the submission and just after the wait bracket it; the tightest bracket of
//!   several tries gives the pair (its midpoint, ± half its width). Measured once, when the
//!   device is created and idle.
//!
//! Lavapipe (Mesa 22.3) offers `VK_EXT_calibrated_timestamps` with `CLOCK_MONOTONIC`: it
//! stamps its queries with `CLOCK_MONOTONIC` itself, so the mapping is exact there.
//!
//! A queue family's timestamps keep `timestampValidBits` low bits of the counter: a value is
//! placed by its signed distance (mod 2^bits) from the calibration's device reading, times
//! `timestampPeriod` nanoseconds per tick ([`Calibration::to_host_ns`]).

use super::error::{vk_err, GpuResult};
use crate::timing::now_ns;
use ash::vk;
use std::ffi::CStr;
use std::fmt;
use std::sync::OnceLock;

/// How device ticks are put on the host clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockSource {
    /// `vkGetCalibratedTimestamps*` of the device and this host time domain.
    Calibrated {
        extension: &'static str,
        domain: vk::TimeDomainKHR,
    },
    /// A submitted timestamp bracketed by host clock reads.
    MeasuredOffset,
}

impl fmt::Display for ClockSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ClockSource::Calibrated { extension, domain } => {
                let domain = if *domain == vk::TimeDomainKHR::CLOCK_MONOTONIC_RAW {
                    "CLOCK_MONOTONIC_RAW"
                } else {
                    "CLOCK_MONOTONIC"
                };
                write!(f, "{extension} ({domain})")
            }
            ClockSource::MeasuredOffset => write!(f, "measured offset"),
        }
    }
}

/// A device-clock reading and the host-clock time it was taken at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calibration {
    pub device_ticks: u64,
    pub host_ns: u64,
    /// How far the pair may be off, in nanoseconds.
    pub uncertainty_ns: u64,
    pub source: ClockSource,
}

impl Calibration {
    /// A timestamp of `ticks`, written on a queue whose family keeps `valid_bits` bits, on the
    /// host clock; `period_ns` is the device's `timestampPeriod`. The timestamp must lie within
    /// half the counter's range of the calibration. `None` for a family without timestamps.
    pub fn to_host_ns(&self, ticks: u64, valid_bits: u32, period_ns: f64) -> Option<u64> {
        let delta = tick_delta(self.device_ticks, ticks, valid_bits)?;
        let ns = (delta as f64 * period_ns).round() as i64;
        Some(self.host_ns.saturating_add_signed(ns))
    }
}

/// `ticks − reference` on a counter that keeps its low `valid_bits` bits: the signed distance
/// of least magnitude (so a counter that wrapped between the two still gives a small positive
/// difference). `None` when the counter has no bits.
pub fn tick_delta(reference: u64, ticks: u64, valid_bits: u32) -> Option<i64> {
    match valid_bits {
        0 => None,
        64.. => Some(ticks.wrapping_sub(reference) as i64),
        bits => {
            let modulus = 1i128 << bits;
            let d = i128::from(ticks.wrapping_sub(reference)) & (modulus - 1);
            Some(if d >= modulus / 2 { d - modulus } else { d } as i64)
        }
    }
}

enum Calibrator {
    Khr(ash::khr::calibrated_timestamps::Device),
    Ext(ash::ext::calibrated_timestamps::Device),
}

/// The extension and host time domain a device is calibrated with.
#[derive(Clone, Copy, Debug)]
pub(super) struct CalibrationChoice {
    pub extension: &'static CStr,
    pub domain: vk::TimeDomainKHR,
}

/// The device's clock mapping; one per [`Gpu`].
pub(super) struct DeviceClock {
    calibrated: Option<(Calibrator, CalibrationChoice)>,
    pub(super) measured: OnceLock<Calibration>,
}

/// The host time domains [`crate::timing`] can read, best first.
fn host_domains() -> &'static [vk::TimeDomainKHR] {
    if cfg!(any(target_os = "linux", target_os = "android")) {
        &[
            vk::TimeDomainKHR::CLOCK_MONOTONIC,
            vk::TimeDomainKHR::CLOCK_MONOTONIC_RAW,
        ]
    } else if cfg!(unix) {
        &[vk::TimeDomainKHR::CLOCK_MONOTONIC]
    } else {
        &[]
    }
}

/// Which calibrated-timestamps extension (KHR before EXT) and host domain `pd` offers, if any.
pub(super) fn calibration_choice(
    entry: &ash::Entry,
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
) -> Option<CalibrationChoice> {
    // SAFETY: pd came from this instance.
    let extensions = unsafe { instance.enumerate_device_extension_properties(pd) }.ok()?;
    let has = |name: &CStr| {
        extensions
            .iter()
            .any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == name))
    };
    // The EXT first: the KHR is the same extension promoted (2023), and validation layers older
    // than it (Debian 12's 1.3.239) warn on a device that enables the KHR name (NVIDIA offers
    // both).
    let (extension, domains) = if has(ash::ext::calibrated_timestamps::NAME) {
        let f = ash::ext::calibrated_timestamps::Instance::new(entry, instance);
        // SAFETY: pd supports the extension, so its physical-device command may be called.
        let d = unsafe { f.get_physical_device_calibrateable_time_domains(pd) };
        (ash::ext::calibrated_timestamps::NAME, d)
    } else if has(ash::khr::calibrated_timestamps::NAME) {
        let f = ash::khr::calibrated_timestamps::Instance::new(entry, instance);
        // SAFETY: as above.
        let d = unsafe { f.get_physical_device_calibrateable_time_domains(pd) };
        (ash::khr::calibrated_timestamps::NAME, d)
    } else {
        return None;
    };
    let domains = domains.ok()?;
    if !domains.contains(&vk::TimeDomainKHR::DEVICE) {
        return None;
    }
    let domain = *host_domains().iter().find(|d| domains.contains(d))?;
    Some(CalibrationChoice { extension, domain })
}

impl DeviceClock {
    /// The clock of `device`, created with `choice`'s extension enabled (when `Some`).
    pub(super) fn new(
        instance: &ash::Instance,
        device: &ash::Device,
        choice: Option<CalibrationChoice>,
    ) -> DeviceClock {
        let calibrated = choice.map(|c| {
            let f = if c.extension == ash::khr::calibrated_timestamps::NAME {
                Calibrator::Khr(ash::khr::calibrated_timestamps::Device::new(
                    instance, device,
                ))
            } else {
                Calibrator::Ext(ash::ext::calibrated_timestamps::Device::new(
                    instance, device,
                ))
            };
            (f, c)
        });
        DeviceClock {
            calibrated,
            measured: OnceLock::new(),
        }
    }

    /// How this device's ticks are mapped.
    pub fn source(&self) -> ClockSource {
        match &self.calibrated {
            Some((_, c)) => ClockSource::Calibrated {
                extension: extension_name(c.extension),
                domain: c.domain,
            },
            None => ClockSource::MeasuredOffset,
        }
    }

    pub(super) fn calibrated(&self) -> Option<GpuResult<Calibration>> {
        let (calibrator, choice) = self.calibrated.as_ref()?;
        let infos = [
            vk::CalibratedTimestampInfoKHR::default().time_domain(vk::TimeDomainKHR::DEVICE),
            vk::CalibratedTimestampInfoKHR::default().time_domain(choice.domain),
        ];
        let raw = choice.domain == vk::TimeDomainKHR::CLOCK_MONOTONIC_RAW;
        // SAFETY: the extension was enabled at device creation and both domains were reported
        // by vkGetPhysicalDeviceCalibrateableTimeDomains*.
        let result = unsafe {
            match calibrator {
                Calibrator::Khr(f) => f.get_calibrated_timestamps(&infos),
                Calibrator::Ext(f) => f.get_calibrated_timestamps(&infos),
            }
        };
        Some(
            result
                .map_err(vk_err("vkGetCalibratedTimestamps"))
                .map(|(values, deviation)| {
                    let (host_ns, extra) = if raw {
                        raw_to_monotonic(values[1])
                    } else {
                        (values[1], 0)
                    };
                    Calibration {
                        device_ticks: values[0],
                        host_ns,
                        uncertainty_ns: deviation.saturating_add(extra),
                        source: self.source(),
                    }
                }),
        )
    }
}

/// A `CLOCK_MONOTONIC_RAW` reading moved to `CLOCK_MONOTONIC` (by host reads of both
/// clocks), with the extra uncertainty of the move.
#[cfg(any(target_os = "linux", target_os = "android"))]
fn raw_to_monotonic(raw: u64) -> (u64, u64) {
    let a = now_ns();
    let r = crate::timing::raw_now_ns();
    let b = now_ns();
    let mid = a + (b - a) / 2;
    (raw.wrapping_add(mid).wrapping_sub(r), (b - a).div_ceil(2))
}

/// Off Linux `CLOCK_MONOTONIC_RAW` is never chosen ([`host_domains`]).
#[cfg(not(any(target_os = "linux", target_os = "android")))]
fn raw_to_monotonic(raw: u64) -> (u64, u64) {
    (raw, 0)
}

fn extension_name(name: &'static CStr) -> &'static str {
    name.to_str().unwrap_or("calibrated timestamps")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(device_ticks: u64, host_ns: u64) -> Calibration {
        Calibration {
            device_ticks,
            host_ns,
            uncertainty_ns: 0,
            source: ClockSource::MeasuredOffset,
        }
    }

    #[test]
    fn ticks_before_and_after_the_calibration_map_by_signed_distance() {
        let c = at(1_000_000, 5_000_000_000);
        assert_eq!(c.to_host_ns(1_000_250, 64, 1.0), Some(5_000_000_250));
        assert_eq!(c.to_host_ns(999_000, 64, 1.0), Some(4_999_999_000));
        assert_eq!(c.to_host_ns(1_000_000, 64, 1.0), Some(5_000_000_000));
    }

    #[test]
    fn period_scales_ticks_to_nanoseconds() {
        // Intel's 52.083 ns and an AMD-like 40 ns tick.
        let c = at(10_000, 1_000_000_000);
        assert_eq!(c.to_host_ns(10_096, 64, 52.083), Some(1_000_005_000));
        assert_eq!(c.to_host_ns(9_000, 64, 40.0), Some(999_960_000));
        // 1e6 ticks of 0.5 ns: 0.5 ms.
        assert_eq!(c.to_host_ns(1_010_000, 64, 0.5), Some(1_000_500_000));
    }

    #[test]
    fn counter_that_wrapped_with_fewer_valid_bits_still_moves_forward() {
        let bits = 36;
        let top = (1u64 << bits) - 1;
        // Calibrated 10 ticks before the wrap; the timestamp came 15 ticks later, after it.
        let c = at(top - 9, 7_000);
        assert_eq!(tick_delta(top - 9, 5, bits), Some(15));
        assert_eq!(c.to_host_ns(5, bits, 1.0), Some(7_015));
        // And a timestamp taken before a calibration that followed the wrap.
        let c = at(3, 7_000);
        assert_eq!(tick_delta(3, top - 1, bits), Some(-5));
        assert_eq!(c.to_host_ns(top - 1, bits, 2.0), Some(6_990));
    }

    #[test]
    fn bits_above_the_valid_ones_are_ignored() {
        // A 64-bit calibrated device reading against 32-bit query values.
        let reference = (0xdead_u64 << 32) | 0xffff_fff0;
        assert_eq!(tick_delta(reference, 0x0000_0010, 32), Some(0x20));
        assert_eq!(tick_delta(reference, 0xffff_ff00, 32), Some(-0xf0));
    }

    #[test]
    fn full_width_counters_wrap_too_and_no_bits_give_nothing() {
        assert_eq!(tick_delta(u64::MAX - 1, 3, 64), Some(5));
        assert_eq!(tick_delta(3, u64::MAX, 64), Some(-4));
        assert_eq!(tick_delta(0, 1u64 << 62, 63), Some(-(1i64 << 62)));
        assert_eq!(tick_delta(0, (1u64 << 62) - 1, 63), Some((1i64 << 62) - 1));
        assert_eq!(tick_delta(5, 6, 0), None);
        assert_eq!(at(5, 100).to_host_ns(6, 0, 1.0), None);
    }

    #[test]
    fn times_before_the_host_epoch_clamp_at_zero() {
        assert_eq!(at(1_000, 10).to_host_ns(0, 64, 1.0), Some(0));
    }
}
