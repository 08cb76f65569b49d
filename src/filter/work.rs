//! What one update costs, counted as it runs ([`Work`]), and the most it can cost
//! ([`WorstCase`]), stated from the filter's size and settings alone.
//!
//! An update is row evaluation, then one QP solve (and, with the sampled-data certificate,
//! up to [`SampledData::max_rounds`](super::SampledData::max_rounds) more, each after an
//! enclosure of the rows over the period). Each part has a bound that holds whatever the
//! state, the rows and the history:
//! * **row evaluation**: the generated kernels' stated operation counts
//!   ([`BarrierSet::evaluation_ops`](crate::system::BarrierSet::evaluation_ops)), every
//!   instance slot filled, nothing culled;
//! * **the dense solves**: each within [`SolverSettings::dense_max_work`](crate::qp::SolverSettings::dense_max_work)
//!   trips, and what its last stage may do past it ([`crate::qp::dual_active_set::DualActiveSet::work_overshoot`]);
//! * **OSQP**, where it may run: [`SolverSettings::max_iter`](crate::qp::SolverSettings::max_iter)
//!   iterations per solve.
//!
//! In time, a [`Calibration`] of this machine turns the counts into microseconds
//! ([`WorstCase::micros`]). Counts are exact bounds; the time is a model of this machine
//! as measured, not a guarantee: a stall of the virtual machine is not in it.
//!
//! ```
//! use cbfgen::filter::work::{Calibration, Work, WorstCase};
//!
//! let bound = WorstCase { qp_solves: 1, dense_trips: 2_100_000, osqp_iterations: 200, ..WorstCase::default() };
//! let done = Work { qp_solves: 1, dense_trips: 41_000, osqp_iterations: 0 };
//! assert!(bound.covers(&done));
//! let machine =
//!     Calibration { ns_per_dense_trip: 0.9, ns_per_osqp_iteration: 4_000.0, ns_per_row_op: 0.5, ..Default::default() };
//! // Row evaluation states no count here, so there is no bound in time.
//! assert_eq!(bound.micros(&machine), None);
//! ```

use crate::ops::OpCount;

/// What one update did, counted as it ran ([`Output::work`](super::Output::work)); laid
/// out as C lays it out, for the plugin interface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(C)]
pub struct Work {
    /// QP solves (1, or more with the sampled-data certificate's rounds; 0 when the rows
    /// could not be solved at all).
    pub qp_solves: u32,
    /// Dense-solver trips over every solve
    /// ([`DualActiveSet::work`](crate::qp::dual_active_set::DualActiveSet::work)).
    pub dense_trips: u64,
    /// OSQP iterations over every solve.
    pub osqp_iterations: u32,
}

impl Work {
    /// Each count the larger of the two: the most a series of updates reached, count by
    /// count.
    pub fn most(self, other: Self) -> Self {
        Self {
            qp_solves: self.qp_solves.max(other.qp_solves),
            dense_trips: self.dense_trips.max(other.dense_trips),
            osqp_iterations: self.osqp_iterations.max(other.osqp_iterations),
        }
    }
}

/// The most one update can do with a filter's size and settings
/// ([`EcbfFilter::worst_case`](super::EcbfFilter::worst_case)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WorstCase {
    /// QP solves.
    pub qp_solves: u32,
    /// Dense-solver trips over every solve.
    pub dense_trips: u64,
    /// OSQP iterations over every solve.
    pub osqp_iterations: u32,
    /// Operations of one row evaluation, as the generated kernels state them; `None` where
    /// the barrier set states none ([`BarrierSet::evaluation_ops`](crate::system::BarrierSet::evaluation_ops):
    /// a hand-written set, rows in torques without their dynamics' count).
    pub row_ops: Option<OpCount>,
    /// Enclosures of the rows over a period (the certificate's; 0 without it).
    pub enclosures: u32,
    /// Interval operations over every enclosure and the margins read from them (the
    /// certificate's: [`BarrierSet::enclosure_ops`](crate::system::BarrierSet::enclosure_ops)
    /// per enclosure, each row's condition on its enclosure); `Some(ZERO)` without the
    /// certificate, `None` where the barrier set states no enclosure count (rows in
    /// torques: their flow is enclosed by the joint-torque map, which states none).
    pub interval_ops: Option<OpCount>,
}

impl WorstCase {
    /// Whether an update's counted work is within this bound (each count at most its
    /// bound).
    pub fn covers(&self, work: &Work) -> bool {
        work.qp_solves <= self.qp_solves
            && work.dense_trips <= self.dense_trips
            && work.osqp_iterations <= self.osqp_iterations
    }

    /// This bound in microseconds on a machine calibrated as `c`: every part at its most,
    /// times the slowest rate measured for it. `None` when a part has no stated count (row
    /// evaluation or enclosures without counts), or enclosures with no interval rate in
    /// `c` (calibrated without the certificate).
    pub fn micros(&self, c: &Calibration) -> Option<f64> {
        let (rows, intervals) = (self.row_ops?, self.interval_ops?);
        if intervals.total() > 0 && c.ns_per_interval_op <= 0.0 {
            return None;
        }
        let ns = self.dense_trips as f64 * c.ns_per_dense_trip
            + f64::from(self.osqp_iterations) * c.ns_per_osqp_iteration
            + rows.total() as f64 * c.ns_per_row_op
            + intervals.total() as f64 * c.ns_per_interval_op;
        Some(ns * 1e-3)
    }
}

/// How fast this machine does each unit of work, measured (the slowest rate seen):
/// what [`WorstCase::micros`] multiplies the counts by.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[repr(C)] // crosses the plugin ABI as is
pub struct Calibration {
    /// Nanoseconds per dense-solver trip.
    pub ns_per_dense_trip: f64,
    /// Nanoseconds per OSQP iteration at the filter's size.
    pub ns_per_osqp_iteration: f64,
    /// Nanoseconds per operation of row evaluation.
    pub ns_per_row_op: f64,
    /// Nanoseconds per interval operation of the certificate's enclosures (0 when not
    /// measured: no certificate, or no stated count to time it by).
    pub ns_per_interval_op: f64,
}

/// A filter's stated worst case beside what its updates did: fed each update's
/// [`Output`](super::Output) by [`BoundCheck::record`], it keeps the most of each count and
/// of the CPU time, and how many updates went beyond the bound in counts (never, or the
/// bound is wrong) and in time (on a quiet machine, none).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundCheck {
    /// The filter's stated worst case.
    pub worst_case: WorstCase,
    /// This machine's rates.
    pub calibration: Calibration,
    /// Updates recorded.
    pub updates: usize,
    /// The most of each count over the updates.
    pub most: Work,
    /// The longest update on the thread's CPU clock (zero without one).
    pub max_cpu: std::time::Duration,
    /// Updates whose counted work went beyond the worst case.
    pub beyond_counts: usize,
    /// Updates whose CPU time went beyond the worst case in time
    /// ([`WorstCase::micros`]; 0 when it states none).
    pub beyond_time: usize,
}

impl BoundCheck {
    /// Nothing recorded yet.
    pub fn new(worst_case: WorstCase, calibration: Calibration) -> Self {
        Self {
            worst_case,
            calibration,
            updates: 0,
            most: Work::default(),
            max_cpu: std::time::Duration::ZERO,
            beyond_counts: 0,
            beyond_time: 0,
        }
    }

    /// The worst case in microseconds on this machine, where stated.
    pub fn micros(&self) -> Option<f64> {
        self.worst_case.micros(&self.calibration)
    }

    /// Count one update.
    pub fn record<U>(&mut self, out: &super::Output<U>) {
        self.record_work(out.work, out.cpu_time.unwrap_or_default());
    }

    /// Count one update that did `work` in `cpu` of the thread's CPU time (zero when not
    /// measured).
    pub fn record_work(&mut self, work: Work, cpu: std::time::Duration) {
        self.updates += 1;
        self.most = self.most.most(work);
        self.beyond_counts += usize::from(!self.worst_case.covers(&work));
        self.max_cpu = self.max_cpu.max(cpu);
        if let Some(bound) = self.micros() {
            self.beyond_time += usize::from(cpu.as_secs_f64() * 1e6 > bound);
        }
    }
}

impl core::fmt::Display for BoundCheck {
    /// A table: each count's stated worst case beside the most an update took.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let (w, m) = (&self.worst_case, &self.most);
        writeln!(f, "{:<34}{:>16}{:>16}", "one update", "worst case", "most measured")?;
        writeln!(f, "{:<34}{:>16}{:>16}", "QP solves", w.qp_solves, m.qp_solves)?;
        writeln!(f, "{:<34}{:>16}{:>16}", "dense-solver trips", w.dense_trips, m.dense_trips)?;
        writeln!(f, "{:<34}{:>16}{:>16}", "OSQP iterations", w.osqp_iterations, m.osqp_iterations)?;
        let ops = w.row_ops.map_or_else(|| "not stated".to_string(), |o| o.total().to_string());
        writeln!(f, "{:<34}{:>16}{:>16}", "row evaluation, operations", ops, "-")?;
        if w.enclosures > 0 {
            let ops = w.interval_ops.map_or_else(|| "not stated".to_string(), |o| o.total().to_string());
            writeln!(f, "{:<34}{:>16}{:>16}", "enclosures, interval operations", ops, "-")?;
        }
        let c = &self.calibration;
        let time = self.micros().map_or_else(|| "not stated".to_string(), |us| format!("{us:.1}"));
        writeln!(f, "{:<34}{:>16}{:>16.1}", "CPU time [µs]", time, self.max_cpu.as_secs_f64() * 1e6)?;
        write!(f, "rates (slowest measured): {:.3} ns per trip", c.ns_per_dense_trip)?;
        if w.osqp_iterations > 0 {
            write!(f, ", {:.0} ns per OSQP iteration", c.ns_per_osqp_iteration)?;
        }
        if w.row_ops.is_some() {
            write!(f, ", {:.3} ns per row operation", c.ns_per_row_op)?;
        }
        if w.enclosures > 0 && w.interval_ops.is_some() {
            write!(f, ", {:.3} ns per interval operation", c.ns_per_interval_op)?;
        }
        writeln!(f)?;
        if w.enclosures > 0 && w.interval_ops.is_none() {
            writeln!(f, "not stated in time: {} enclosures whose operations are not stated", w.enclosures)?;
        }
        write!(
            f,
            "of {} updates, beyond the worst case: {} in counts, {} in CPU time",
            self.updates, self.beyond_counts, self.beyond_time
        )
    }
}
