//! The calling thread's CPU time, read beside wall time so that a percentile can tell work
//! from a stall: a virtual machine that deschedules the thread adds wall time, not CPU time.

use std::time::Duration;

/// CPU time consumed by the calling thread so far, or `None` where the platform has no
/// per-thread clock (this crate reads `CLOCK_THREAD_CPUTIME_ID` on Unix).
///
/// One reading is a system call on Linux (the thread clock has no vDSO path): about
/// 0.2–0.5 µs, paid twice per update when
/// [`FilterSettings::measure_cpu_time`](crate::filter::FilterSettings::measure_cpu_time) is on.
pub fn thread_cpu_time() -> Option<Duration> {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: `ts` is a valid, writable timespec; the clock id is a constant the libc
        // crate defines for this platform.
        let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
        (rc == 0).then(|| Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32))
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// A stopwatch over both clocks: wall time since [`Stopwatch::start`], and the thread's
/// CPU time over the same span (`Duration::ZERO` where there is no thread clock).
#[derive(Debug, Clone, Copy)]
pub struct Stopwatch {
    wall: std::time::Instant,
    cpu: Option<Duration>,
}

impl Stopwatch {
    /// Start both clocks.
    pub fn start() -> Self {
        Self { wall: std::time::Instant::now(), cpu: thread_cpu_time() }
    }

    /// `(wall, cpu)` elapsed since the start.
    pub fn elapsed(&self) -> (Duration, Duration) {
        let wall = self.wall.elapsed();
        let cpu = match (self.cpu, thread_cpu_time()) {
            (Some(a), Some(b)) => b.saturating_sub(a),
            _ => Duration::ZERO,
        };
        (wall, cpu)
    }
}

/// Median, p99 and maximum (nearest rank) of `values`, sorted in place; zeros when empty.
pub fn median_p99_max(values: &mut [f64]) -> [f64; 3] {
    values.sort_unstable_by(f64::total_cmp);
    [0.5, 0.99, 1.0].map(|p| nearest_rank(values, p).unwrap_or(0.0))
}

/// The nearest-rank `p`-quantile (`0 < p ≤ 1`) of an ascending slice; `None` when empty.
pub fn nearest_rank<T: Copy>(sorted: &[T], p: f64) -> Option<T> {
    let rank = (p * sorted.len() as f64).ceil() as usize;
    sorted.get(rank.clamp(1, sorted.len().max(1)) - 1).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_time_advances_with_work_and_not_with_sleep() {
        let watch = Stopwatch::start();
        std::thread::sleep(Duration::from_millis(30));
        let (wall, cpu) = watch.elapsed();
        assert!(wall >= Duration::from_millis(30));
        // Sleeping costs (almost) no CPU: the clock is the thread's, not the wall's.
        assert!(cpu < Duration::from_millis(15), "cpu {cpu:?} while sleeping");

        let watch = Stopwatch::start();
        let mut x = 0.0f64;
        while watch.elapsed().0 < Duration::from_millis(30) {
            x = std::hint::black_box(x + 1.0);
        }
        let (_, cpu) = watch.elapsed();
        if cfg!(unix) {
            assert!(cpu >= Duration::from_millis(5), "cpu {cpu:?} while spinning");
        }
    }
}
