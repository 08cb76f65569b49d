//! Latency harness: consecutive filter updates along the [`Approach`] drive, with
//! percentiles of the time per update. Wall-clock, single thread, one cycle after
//! another as a controller would run them (no criterion batching or warm caches
//! between repetitions of the same input).

use std::fmt;
use std::time::{Duration, Instant};

use crate::error::CbfError;
use crate::filter::{EcbfFilter, FilterSettings, InputSource};
use crate::systems::tachyon3::approach::Approach;
use crate::systems::tachyon3::catalog::{Capacity, Catalog};
use crate::systems::tachyon3::model::NU;
use crate::systems::tachyon3::terrain::Stairs;

/// Control period \[s\].
pub const DT: f64 = 1e-3;

/// Percentiles of one timed quantity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Percentiles {
    /// The 50th percentile (nearest rank).
    pub median: Duration,
    /// The 99th percentile (nearest rank).
    pub p99: Duration,
    /// The slowest sample.
    pub max: Duration,
}

/// The nearest-rank `p`-quantile (`0 < p ≤ 1`) of an ascending slice; `None` when empty.
pub fn nearest_rank<T: Copy>(sorted: &[T], p: f64) -> Option<T> {
    let rank = (p * sorted.len() as f64).ceil() as usize;
    sorted.get(rank.clamp(1, sorted.len().max(1)) - 1).copied()
}

impl Percentiles {
    /// Nearest-rank percentiles; sorts `samples`. `None` when empty.
    pub fn of(samples: &mut [Duration]) -> Option<Self> {
        samples.sort_unstable();
        Some(Self { median: nearest_rank(samples, 0.5)?, p99: nearest_rank(samples, 0.99)?, max: *samples.last()? })
    }
}

/// What a harness run measured.
#[derive(Debug, Clone)]
pub struct LatencyReport {
    /// Consecutive filter updates run.
    pub cycles: usize,
    /// Rows of the filter's catalog (all evaluated every cycle).
    pub rows: usize,
    /// Wall-clock time of a whole [`EcbfFilter::update`] call.
    pub total: Percentiles,
    /// Time in row evaluation and activation
    /// ([`FilterOutput::eval_time`](crate::filter::FilterOutput::eval_time)).
    pub eval: Percentiles,
    /// Time in the QP update and solve
    /// ([`FilterOutput::solve_time`](crate::filter::FilterOutput::solve_time)).
    pub solve: Percentiles,
    /// ADMM iterations per cycle: median, p99, max.
    pub iterations: [u32; 3],
    /// Active rows per cycle: min, max.
    pub active_rows: [usize; 2],
    /// Cycles whose input did not come from a solved QP (source other than
    /// [`InputSource::Qp`]: unconverged iterates and fallbacks).
    pub fallbacks: usize,
    /// Cycles whose input is the polished (KKT-verified) optimum.
    pub polished: usize,
    /// Travel from start to end \[m\], and the robot front's final gap to the first riser.
    pub travel: f64,
    /// Gap from the robot's foremost point to the first riser at the end \[m\] (negative
    /// past it).
    pub final_gap: f64,
}

/// Run `cycles` updates at 1 kHz from `start_gap` metres before the stairs at `speed`.
///
/// # Errors
/// Filter construction or an update returning an error (bad state).
pub fn run(cycles: usize, speed: f64, start_gap: f64, settings: FilterSettings<NU>) -> Result<LatencyReport, CbfError> {
    let capacity = Capacity::PAPER_WORST_CASE;
    let stairs = Stairs::HARDWARE;
    let mut filter = EcbfFilter::new(Catalog::new(capacity)?, settings)?;
    let mut drive = Approach::new(capacity, stairs, start_gap, speed)?;
    let start_x = drive.x[0];
    let (mut total, mut eval, mut solve) =
        (Vec::with_capacity(cycles), Vec::with_capacity(cycles), Vec::with_capacity(cycles));
    let mut iterations = Vec::with_capacity(cycles);
    let (mut active_min, mut active_max, mut fallbacks, mut polished) = (usize::MAX, 0, 0, 0);
    for _ in 0..cycles {
        let u_ref = drive.nominal_input();
        let t0 = Instant::now();
        let out = *filter.update(&drive.x, &u_ref, &drive.env)?;
        total.push(t0.elapsed());
        eval.push(out.eval_time);
        solve.push(out.solve_time);
        iterations.push(out.iterations);
        active_min = active_min.min(out.active_rows);
        active_max = active_max.max(out.active_rows);
        fallbacks += usize::from(out.source != InputSource::Qp);
        polished += usize::from(out.polished);
        drive.advance(&out.u, DT);
    }
    iterations.sort_unstable();
    let empty = || CbfError::LengthMismatch { what: "latency cycles", expected: 1, got: 0 };
    let pick = |p: f64| nearest_rank(&iterations, p).ok_or_else(empty);
    let front = drive.x[0] + drive.front_reach();
    Ok(LatencyReport {
        cycles,
        rows: filter.rows().len(),
        total: Percentiles::of(&mut total).ok_or_else(empty)?,
        eval: Percentiles::of(&mut eval).ok_or_else(empty)?,
        solve: Percentiles::of(&mut solve).ok_or_else(empty)?,
        iterations: [pick(0.5)?, pick(0.99)?, pick(1.0)?],
        active_rows: [active_min, active_max],
        fallbacks,
        polished,
        travel: drive.x[0] - start_x,
        final_gap: stairs.start_x - front,
    })
}

impl fmt::Display for LatencyReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let us = |d: Duration| d.as_secs_f64() * 1e6;
        writeln!(
            f,
            "{} consecutive updates of {} rows at 1 kHz (drive into a 5-step staircase)",
            self.cycles, self.rows
        )?;
        writeln!(f, "{:<22}{:>10}{:>10}{:>10}", "time per update [µs]", "median", "p99", "max")?;
        for (name, p) in
            [("whole update", self.total), ("row evaluation", self.eval), ("QP update + solve", self.solve)]
        {
            writeln!(f, "{:<22}{:>10.1}{:>10.1}{:>10.1}", name, us(p.median), us(p.p99), us(p.max))?;
        }
        let [im, i99, imax] = self.iterations;
        writeln!(f, "ADMM iterations: median {im}, p99 {i99}, max {imax}")?;
        writeln!(f, "active rows: {} to {}", self.active_rows[0], self.active_rows[1])?;
        writeln!(
            f,
            "polished (KKT-verified) cycles: {}; cycles not solved to tolerance: {}",
            self.polished, self.fallbacks
        )?;
        write!(
            f,
            "travel {:.3} m; the robot's front stopped {:.3} m before the first riser",
            self.travel, self.final_gap
        )
    }
}

#[cfg(test)]
mod tests {
    use super::nearest_rank;

    #[test]
    fn nearest_rank_by_hand() {
        let v: Vec<u32> = (1..=100).collect();
        assert_eq!([0.5, 0.99, 1.0].map(|p| nearest_rank(&v, p)), [Some(50), Some(99), Some(100)]);
        assert_eq!(nearest_rank(&[7.0], 0.99), Some(7.0));
        assert_eq!(nearest_rank::<f64>(&[], 0.5), None);
    }
}
