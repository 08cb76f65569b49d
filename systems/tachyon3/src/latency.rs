//! Latency harness: consecutive filter updates along the [`Approach`] drive, with
//! percentiles of the time per update. Single thread, one cycle after another as a
//! controller would run them (no criterion batching or warm caches between repetitions
//! of the same input). Each update is timed on two clocks: wall time, and the thread's
//! CPU time ([`cbfgen::cpu_time`]). A virtual machine that deschedules the thread adds
//! wall time but no CPU time, so a wall-time outlier with an ordinary CPU time is a
//! stall, not work.

use std::fmt;
use std::time::{Duration, Instant};

use crate::approach::Approach;
use crate::catalog::{Capacity, Catalog};
use crate::model::NU;
use crate::terrain::Stairs;
use cbfgen::error::CbfError;
use cbfgen::filter::{BoundCheck, EcbfFilter, FilterSettings, InputSource, Solver};

/// Control period \[s\].
pub const DT: f64 = 1e-3;

/// The control period as a duration: an update that takes longer (on either clock)
/// misses its cycle.
pub const PERIOD: Duration = Duration::from_millis(1);

/// Cycles in `times` longer than [`PERIOD`] (strictly).
pub fn over_period(times: impl IntoIterator<Item = Duration>) -> usize {
    times.into_iter().filter(|&t| t > PERIOD).count()
}

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

pub use cbfgen::cpu_time::nearest_rank;

impl Percentiles {
    /// Nearest-rank percentiles; sorts `samples`. `None` when empty.
    pub fn of(samples: &mut [Duration]) -> Option<Self> {
        samples.sort_unstable();
        Some(Self { median: nearest_rank(samples, 0.5)?, p99: nearest_rank(samples, 0.99)?, max: *samples.last()? })
    }
}

/// One cycle's whole update on both clocks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CycleTime {
    /// Wall-clock time of the [`EcbfFilter::update`] call, timed around it.
    pub wall: Duration,
    /// The thread's CPU time over the update
    /// ([`FilterOutput::cpu_time`](cbfgen::filter::FilterOutput::cpu_time), which the
    /// harness turns on); zero where the platform has no thread clock.
    pub cpu: Duration,
}

/// What a harness run measured.
#[derive(Debug, Clone)]
pub struct LatencyReport {
    /// Consecutive filter updates run.
    pub cycles: usize,
    /// Rows of the filter's catalog (all evaluated every cycle).
    pub rows: usize,
    /// The solver the filter was set to use.
    pub backend: Solver,
    /// Wall-clock time of a whole [`EcbfFilter::update`] call.
    pub total: Percentiles,
    /// The thread's CPU time over a whole update (zero where the platform has no thread
    /// clock).
    pub total_cpu: Percentiles,
    /// Cycles whose whole update took longer than [`PERIOD`] of wall time.
    pub over_period_wall: usize,
    /// Cycles whose whole update took longer than [`PERIOD`] of CPU time.
    pub over_period_cpu: usize,
    /// Every cycle's whole update on both clocks, in cycle order.
    pub cycle_times: Vec<CycleTime>,
    /// Wall time in row evaluation and activation
    /// ([`FilterOutput::eval_time`](cbfgen::filter::FilterOutput::eval_time)).
    pub eval: Percentiles,
    /// Wall time in the QP update and solve
    /// ([`FilterOutput::solve_time`](cbfgen::filter::FilterOutput::solve_time)).
    pub solve: Percentiles,
    /// ADMM iterations per cycle: median, p99, max.
    pub iterations: [u32; 3],
    /// Active rows per cycle: min, max.
    pub active_rows: [usize; 2],
    /// Cycles whose input did not come from a solved QP (source other than
    /// [`InputSource::Qp`]: unconverged iterates and fallbacks).
    pub fallbacks: usize,
    /// Cycles whose input is OSQP's iterate polished to the KKT-verified optimum.
    pub polished: usize,
    /// Cycles answered by the dense solve (KKT-verified).
    pub dense: usize,
    /// Cycles where the dense solve's first stage did not verify within its budget.
    pub dense_fallbacks: usize,
    /// Cycles whose safety verdict was not "every row met" (rows relaxed, or a row not
    /// finite).
    pub relaxed: usize,
    /// Cycles whose rows did not all fit the input box (elastic stages ran).
    pub conflicting: usize,
    /// Dense solve steps per cycle: median, p99, max.
    pub dense_steps: [u32; 3],
    /// Travel from start to end \[m\], and the robot front's final gap to the first riser.
    pub travel: f64,
    /// Gap from the robot's foremost point to the first riser at the end \[m\] (negative
    /// past it).
    pub final_gap: f64,
    /// The filter's stated worst case per update, in counts and (calibrated on this
    /// machine before the run) in time, beside the most any update took.
    pub bound: BoundCheck,
}

/// Most updates one [`run`] times: it keeps about 100 bytes per update for its
/// percentiles (100 MB at this limit).
pub const MAX_CYCLES: usize = 1_000_000;

/// Run `cycles` updates at 1 kHz from `start_gap` metres before the stairs at `speed`.
///
/// # Errors
/// `cycles` outside `1..=`[`MAX_CYCLES`] (checked before anything is allocated), filter
/// construction or an update returning an error (bad state).
pub fn run(cycles: usize, speed: f64, start_gap: f64, settings: FilterSettings<NU>) -> Result<LatencyReport, CbfError> {
    if cycles == 0 {
        return Err(CbfError::NotPositive { what: "latency cycles", value: 0.0 });
    }
    if cycles > MAX_CYCLES {
        return Err(CbfError::TooLarge { what: "latency cycles", value: cycles, max: MAX_CYCLES });
    }
    let capacity = Capacity::PAPER_WORST_CASE;
    let stairs = Stairs::HARDWARE;
    let backend = settings.solver.backend;
    // The harness reports CPU time beside wall time, so it asks the filter for it.
    let settings = FilterSettings { measure_cpu_time: true, ..settings };
    let mut filter = EcbfFilter::new(Catalog::new(capacity)?, settings)?;
    let mut drive = Approach::new(capacity, stairs, start_gap, speed)?;
    let start_x = drive.x[0];
    let calibration = filter.calibrate(0.0, &drive.x, &drive.env)?;
    let mut bound = BoundCheck::new(filter.worst_case(), calibration);
    let mut cycle_times = Vec::with_capacity(cycles);
    let (mut eval, mut solve) = (Vec::with_capacity(cycles), Vec::with_capacity(cycles));
    let mut iterations = Vec::with_capacity(cycles);
    let (mut active_min, mut active_max, mut fallbacks, mut polished) = (usize::MAX, 0, 0, 0);
    let (mut dense, mut dense_fallbacks, mut steps) = (0, 0, Vec::with_capacity(cycles));
    let (mut relaxed, mut conflicting) = (0, 0);
    for _ in 0..cycles {
        let u_ref = drive.nominal_input();
        // Wall time around the call; the filter reads the thread's CPU clock itself.
        let t0 = Instant::now();
        let out = *filter.update(&drive.x, &u_ref, &drive.env)?;
        cycle_times.push(CycleTime { wall: t0.elapsed(), cpu: out.cpu_time.unwrap_or_default() });
        eval.push(out.eval_time);
        solve.push(out.solve_time);
        iterations.push(out.iterations);
        active_min = active_min.min(out.active_rows);
        active_max = active_max.max(out.active_rows);
        fallbacks += usize::from(out.source != InputSource::Qp);
        polished += usize::from(out.polished);
        dense += usize::from(out.backend == Some(cbfgen::qp::Backend::Dense));
        dense_fallbacks += usize::from(out.dense_fallback);
        relaxed += usize::from(!out.safety.is_met());
        conflicting += usize::from(out.elastic_stages > 0);
        steps.push(out.dense_steps);
        bound.record(&out);
        drive.advance(&out.u, DT);
    }
    iterations.sort_unstable();
    let empty = || CbfError::LengthMismatch { what: "latency cycles", expected: 1, got: 0 };
    let pick = |p: f64| nearest_rank(&iterations, p).ok_or_else(empty);
    let front = drive.x[0] + drive.front_reach();
    let mut wall: Vec<Duration> = cycle_times.iter().map(|c| c.wall).collect();
    let mut cpu: Vec<Duration> = cycle_times.iter().map(|c| c.cpu).collect();
    Ok(LatencyReport {
        cycles,
        rows: filter.rows().len(),
        backend,
        total: Percentiles::of(&mut wall).ok_or_else(empty)?,
        total_cpu: Percentiles::of(&mut cpu).ok_or_else(empty)?,
        over_period_wall: over_period(wall),
        over_period_cpu: over_period(cpu),
        cycle_times,
        eval: Percentiles::of(&mut eval).ok_or_else(empty)?,
        solve: Percentiles::of(&mut solve).ok_or_else(empty)?,
        iterations: [pick(0.5)?, pick(0.99)?, pick(1.0)?],
        active_rows: [active_min, active_max],
        fallbacks,
        polished,
        dense,
        dense_fallbacks,
        relaxed,
        conflicting,
        dense_steps: {
            steps.sort_unstable();
            [
                nearest_rank(&steps, 0.5).unwrap_or(0),
                nearest_rank(&steps, 0.99).unwrap_or(0),
                steps.last().copied().unwrap_or(0),
            ]
        },
        travel: drive.x[0] - start_x,
        final_gap: stairs.start_x - front,
        bound,
    })
}

impl fmt::Display for LatencyReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let us = |d: Duration| d.as_secs_f64() * 1e6;
        writeln!(
            f,
            "{} consecutive updates of {} rows at 1 kHz (drive into a 5-step staircase), solver {}",
            self.cycles,
            self.rows,
            self.backend.name()
        )?;
        writeln!(f, "{:<30}{:>10}{:>10}{:>10}{:>10}", "time per update [µs]", "median", "p99", "max", "> 1 ms")?;
        for (name, p, over) in [
            ("whole update, wall", self.total, Some(self.over_period_wall)),
            ("whole update, thread CPU", self.total_cpu, Some(self.over_period_cpu)),
            ("row evaluation, wall", self.eval, None),
            ("QP update + solve, wall", self.solve, None),
        ] {
            write!(f, "{:<30}{:>10.1}{:>10.1}{:>10.1}", name, us(p.median), us(p.p99), us(p.max))?;
            match over {
                Some(n) => writeln!(f, "{n:>10}")?,
                None => writeln!(f)?,
            }
        }
        let [im, i99, imax] = self.iterations;
        writeln!(f, "ADMM iterations: median {im}, p99 {i99}, max {imax}")?;
        writeln!(f, "active rows: {} to {}", self.active_rows[0], self.active_rows[1])?;
        writeln!(
            f,
            "answered by the dense solve: {} cycles (active-set changes median {}, p99 {}, max {}; {} fell back to OSQP); OSQP polished: {}; cycles not solved to tolerance: {}",
            self.dense, self.dense_steps[0], self.dense_steps[1], self.dense_steps[2], self.dense_fallbacks, self.polished, self.fallbacks
        )?;
        writeln!(
            f,
            "cycles whose rows did not all fit the input box: {}; cycles not reported safe (rows relaxed): {}",
            self.conflicting, self.relaxed
        )?;
        writeln!(
            f,
            "travel {:.3} m; the robot's front stopped {:.3} m before the first riser",
            self.travel, self.final_gap
        )?;
        write!(f, "{}", self.bound)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_by_hand() {
        let v: Vec<u32> = (1..=100).collect();
        assert_eq!([0.5, 0.99, 1.0].map(|p| nearest_rank(&v, p)), [Some(50), Some(99), Some(100)]);
        assert_eq!(nearest_rank(&[7.0], 0.99), Some(7.0));
        assert_eq!(nearest_rank::<f64>(&[], 0.5), None);
    }

    #[test]
    fn over_period_is_strict() {
        let ms = Duration::from_millis;
        assert_eq!(over_period([ms(0), ms(1), ms(2), Duration::from_nanos(1_000_001)]), 2);
        assert_eq!(over_period([]), 0);
    }

    #[test]
    fn a_short_run_reports_both_clocks_consistently() {
        let settings = crate::catalog::default_settings();
        let r = run(200, 0.3, 0.6, settings).expect("harness");
        assert_eq!((r.cycles, r.cycle_times.len()), (200, 200));
        // The counts are a direct count over the cycles, on each clock.
        assert_eq!(r.over_period_wall, r.cycle_times.iter().filter(|c| c.wall > PERIOD).count());
        assert_eq!(r.over_period_cpu, r.cycle_times.iter().filter(|c| c.cpu > PERIOD).count());
        // The percentiles are those of the recorded cycles.
        let mut cpu: Vec<Duration> = r.cycle_times.iter().map(|c| c.cpu).collect();
        let mut wall: Vec<Duration> = r.cycle_times.iter().map(|c| c.wall).collect();
        assert_eq!(Percentiles::of(&mut cpu), Some(r.total_cpu));
        assert_eq!(Percentiles::of(&mut wall), Some(r.total));
        let us = Duration::from_micros;
        if cfg!(unix) {
            assert!(r.total_cpu.median > Duration::ZERO, "{r}");
            // Work cannot take more CPU time than the wall time around it, give or take the
            // two clocks' granularity and the CPU clock's own reading inside the call.
            assert!(r.total_cpu.median <= r.total.median.mul_f64(1.5) + us(5), "{r}");
        }
        let text = r.to_string();
        assert!(text.contains("whole update, thread CPU") && text.contains("> 1 ms"), "{text}");
    }

    #[test]
    fn under_a_tight_work_budget_no_update_works_beyond_its_stated_worst_case_and_cut_cycles_are_flagged() {
        // Driven into the first riser, the rows change their active set now and then. With
        // the smallest budget, a solve that must add a row stops before it: those updates
        // hand back a flagged input, and no update works past the worst case stated.
        let mut settings = crate::catalog::default_settings();
        settings.solver.dense_max_work = 1;
        let tight = run(2000, 0.5, 0.0, settings).expect("harness");
        let plenty = run(2000, 0.5, 0.0, crate::catalog::default_settings()).expect("harness");
        for r in [&tight, &plenty] {
            assert_eq!((r.bound.updates, r.bound.beyond_counts), (2000, 0), "{r}");
            assert!(r.bound.most.dense_trips > 0 && r.bound.most.qp_solves == 1, "{r}");
        }
        assert_eq!(plenty.fallbacks, 0, "{plenty}");
        assert!(tight.fallbacks > 0, "{tight}");
        // The stated worst case follows the budget.
        let (tight_us, plenty_us) = (tight.bound.micros(), plenty.bound.micros());
        assert!(tight.bound.worst_case.dense_trips < plenty.bound.worst_case.dense_trips, "{tight}");
        assert!(tight_us.zip(plenty_us).is_some_and(|(t, p)| t.is_finite() && t < p), "{tight}");
    }

    #[test]
    fn cycle_counts_outside_the_range_are_refused_before_any_allocation() {
        let settings = crate::catalog::default_settings();
        // A trillion cycles would ask for about 100 TB before the first update.
        for cycles in [0, MAX_CYCLES + 1, 1_000_000_000_000] {
            assert!(run(cycles, 0.3, 0.6, settings.clone()).is_err(), "{cycles}");
        }
    }
}
