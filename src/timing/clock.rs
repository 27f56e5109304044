//! The host clock of every span: `CLOCK_MONOTONIC` in nanoseconds (elsewhere than Unix,
//! nanoseconds since the first reading, from `std::time::Instant`).

/// Now on the host clock, in nanoseconds.
#[cfg(unix)]
pub fn now_ns() -> u64 {
    read(rustix::time::ClockId::Monotonic)
}

/// Now on `CLOCK_MONOTONIC_RAW` (the clock some devices calibrate against), in nanoseconds.
#[cfg(any(target_os = "linux", target_os = "android"))]
pub fn raw_now_ns() -> u64 {
    read(rustix::time::ClockId::MonotonicRaw)
}

#[cfg(unix)]
fn read(clock: rustix::time::ClockId) -> u64 {
    let t = rustix::time::clock_gettime(clock);
    (t.tv_sec as u64)
        .saturating_mul(1_000_000_000)
        .saturating_add(t.tv_nsec as u64)
}

/// Now on the host clock, in nanoseconds since the process first read it.
#[cfg(not(unix))]
pub fn now_ns() -> u64 {
    static EPOCH: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
    EPOCH
        .get_or_init(std::time::Instant::now)
        .elapsed()
        .as_nanos() as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn host_clock_advances_with_instant() {
        let (a, i) = (now_ns(), std::time::Instant::now());
        std::thread::sleep(std::time::Duration::from_millis(5));
        let (b, elapsed) = (now_ns(), i.elapsed().as_nanos() as u64);
        assert!(b > a);
        // Both read CLOCK_MONOTONIC on Linux: the two intervals differ by the reads' cost.
        assert!(b - a + 1_000_000 > elapsed && elapsed + 1_000_000 > b - a);
    }
}
