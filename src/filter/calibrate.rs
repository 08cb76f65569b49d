//! This machine's rates for each unit of [`work`](super::work): nanoseconds per
//! dense-solver trip, per OSQP iteration at a filter's size, and per operation of its row
//! evaluation, each the slowest seen over problems of that size. Each problem is timed a
//! few times and its quickest run kept (a run the machine interrupted is slower, not the
//! work), so what remains is how the rate varies with the problem.
//!
//! The problems are generated here, from a fixed seed, at the sizes given: dense QPs with
//! many binding rows (the solver's costly case), and OSQP runs held to their iteration
//! limit. Row evaluation is timed on the caller's own rows.

use super::qp::{EcbfQp, RowSpec};
use super::work::Calibration;
use crate::cpu_time::Stopwatch;
use crate::error::CbfError;
use crate::ops::OpCount;
use crate::qp::dual_active_set::{DualActiveSet, WarmStart};
use crate::qp::{Solver, SolverSettings};
use crate::system::Row;
use std::time::Duration;

/// Runs of each problem; the quickest counts.
const REPEATS: usize = 3;

/// A small deterministic generator (xorshift64*): the calibration's problems are the same
/// on every machine, so rates compare.
struct Numbers(u64);

impl Numbers {
    /// Uniform in `[-1, 1)`.
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11;
        bits as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// The quickest of [`REPEATS`] runs of `run`, on the thread's CPU clock (the machine's
/// stalls are not the work), or the wall's where that reads nothing (no thread clock).
fn quickest(mut run: impl FnMut()) -> Duration {
    (0..REPEATS)
        .map(|_| {
            let watch = Stopwatch::start();
            run();
            let (wall, cpu) = watch.elapsed();
            if cpu.is_zero() {
                wall
            } else {
                cpu
            }
        })
        .min()
        .unwrap_or_default()
}

/// Nanoseconds per dense-solver trip ([`DualActiveSet::work`]): the slowest rate over
/// `problems` random QPs of `vars` variables and `rows` rows whose unconstrained minimum
/// lies far outside the rows, so that up to `vars` of them bind.
///
/// # Errors
/// `vars` of 0.
pub fn dense_trip_ns(vars: usize, rows: usize, problems: usize) -> Result<f64, CbfError> {
    let identity: Vec<f64> = (0..vars * vars).map(|k| if k % (vars + 1) == 0 { 1.0 } else { 0.0 }).collect();
    let mut qp = DualActiveSet::new(&identity, vars, rows)?;
    let mut numbers = Numbers(0x9e37_79b9_7f4a_7c15);
    let mut slowest = 0.0f64;
    for _ in 0..problems {
        let inside: Vec<f64> = (0..vars).map(|_| numbers.next()).collect();
        let data = qp.data_mut();
        for (j, q) in data.q.iter_mut().enumerate() {
            *q = -100.0 * (numbers.next() + 2.0 * inside[j].signum());
        }
        for i in 0..rows {
            let row = &mut data.a[i * vars..(i + 1) * vars];
            row.iter_mut().for_each(|v| *v = numbers.next());
            let at_inside: f64 = row.iter().zip(&inside).map(|(a, z)| a * z).sum();
            data.lower[i] = at_inside - 0.5 * (numbers.next() + 1.0);
            data.upper[i] = f64::INFINITY;
        }
        let elapsed = quickest(|| {
            qp.solve(WarmStart::Cold, u32::MAX);
        });
        if qp.work() > 0 {
            slowest = slowest.max(elapsed.as_nanos() as f64 / qp.work() as f64);
        }
    }
    Ok(slowest)
}

/// Nanoseconds per OSQP iteration on a filter's QP of `NU` inputs laid out as `specs`
/// (each row's input columns; OSQP's settings as `settings` give them, held to
/// `settings.max_iter` iterations by a tolerance no iterate meets): the slowest rate over
/// `problems` random QPs of that pattern, each solve with its data update and ρ's
/// refactorisations.
///
/// # Errors
/// Settings outside their domain, a row naming an input twice or beyond `NU`, or OSQP
/// refusing the set-up.
pub fn osqp_iteration_ns<const NU: usize>(
    specs: &[RowSpec<'_>],
    settings: &SolverSettings,
    problems: usize,
) -> Result<f64, CbfError> {
    let rows = specs.len();
    let held = SolverSettings {
        backend: Solver::Osqp,
        polish: false,
        eps_abs: SolverSettings::MIN_TOLERANCE,
        eps_rel: SolverSettings::MIN_TOLERANCE,
        time_limit: None,
        ..*settings
    };
    let mut qp = EcbfQp::new(specs, &[1.0; NU], &[-10.0; NU], &[10.0; NU], held)?;
    let mut numbers = Numbers(0x2545_f491_4f6c_dd1d);
    let mut values = vec![Row::<NU>::ZERO; rows];
    let active = vec![true; rows];
    let mut slowest = 0.0f64;
    for _ in 0..problems {
        let u_ref: [f64; NU] = std::array::from_fn(|_| 5.0 * numbers.next());
        for (row, spec) in values.iter_mut().zip(specs) {
            row.lg = [0.0; NU];
            for &j in spec.columns {
                row.lg[j] = numbers.next();
            }
            row.lie[0] = 0.1 * (numbers.next() + 1.0);
            row.lie[1] = 2.0 * numbers.next() - 1.0;
            row.active = true;
        }
        let elapsed = quickest(|| {
            // A solve that fails is timed as it ran; the rate needs only its iterations.
            let _ = qp.solve(&u_ref, &values, &active);
        });
        if qp.iterations() > 0 {
            slowest = slowest.max(elapsed.as_nanos() as f64 / f64::from(qp.iterations()));
        }
    }
    Ok(slowest)
}

/// Nanoseconds per operation of work stated to take `ops` (a row evaluation, an
/// enclosure of the rows): the quickest of a few runs of `run` over `ops.total()`, the
/// slowest of `runs` such measures.
pub fn op_ns(ops: OpCount, runs: usize, mut run: impl FnMut()) -> f64 {
    let total = ops.total().max(1) as f64;
    (0..runs).map(|_| quickest(&mut run).as_nanos() as f64 / total).fold(0.0, f64::max)
}

/// Nanoseconds per interval operation of [`solve_linear`](crate::interval::solve_linear)
/// at size `N` (a well-conditioned system of narrow intervals): the rate of an enclosure
/// whose rows cannot be timed over a box on their own (the
/// [joint-torque map](crate::torque::JointTorque)'s, whose flow is mostly such solves
/// and the dynamics' products and sums).
pub fn interval_solve_ns<const N: usize>(runs: usize) -> f64 {
    use crate::interval::{solve_linear, solve_linear_ops, Interval};
    let mut numbers = Numbers(0x6a09_e667_f3bc_c909);
    let near = |v: f64| Interval::new(v - 1e-6, v + 1e-6);
    let a: [[Interval; N]; N] =
        core::array::from_fn(|i| core::array::from_fn(|j| near(if i == j { 4.0 } else { 0.5 * numbers.next() })));
    let b: [Interval; N] = core::array::from_fn(|_| near(numbers.next()));
    op_ns(solve_linear_ops(N), runs, || {
        core::hint::black_box(solve_linear(core::hint::black_box(&a), &b));
    })
}

impl Calibration {
    /// This machine's rates for a filter of `NU` inputs, rows laid out as `specs` and
    /// `settings`, with its row evaluation `evaluate` stated to take `row_ops` (no rate for
    /// it when `None`); the interval rate is left 0 (the filter times its enclosures).
    ///
    /// # Errors
    /// As [`osqp_iteration_ns`].
    pub fn measure<const NU: usize>(
        specs: &[RowSpec<'_>],
        settings: &SolverSettings,
        row_ops: Option<OpCount>,
        evaluate: impl FnMut(),
    ) -> Result<Self, CbfError> {
        // The elastic stage's size: the inputs and t; the box, t ≥ 0 and the rows.
        let ns_per_dense_trip = dense_trip_ns(NU + 1, specs.len() + NU + 1, 200)?;
        let ns_per_osqp_iteration =
            if settings.backend == Solver::Dense { 0.0 } else { osqp_iteration_ns::<NU>(specs, settings, 20)? };
        let ns_per_row_op = row_ops.map_or(0.0, |ops| op_ns(ops, 200, evaluate));
        Ok(Self { ns_per_dense_trip, ns_per_osqp_iteration, ns_per_row_op, ns_per_interval_op: 0.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::system::{Gains, Poles};

    #[test]
    fn the_rates_are_positive_and_finite_and_a_larger_solve_takes_more_time_not_a_higher_rate() {
        let small = dense_trip_ns(4, 10, 20).expect("sizes");
        let large = dense_trip_ns(18, 300, 20).expect("sizes");
        assert!(small.is_finite() && small > 0.0 && large.is_finite() && large > 0.0, "{small} {large}");
        // A trip is a few flops at any size: the rates stay within two orders of magnitude.
        assert!(large < 100.0 * small && small < 100.0 * large, "{small} against {large}");
        let columns = [0, 1, 2, 3];
        let spec = RowSpec { columns: &columns, gains: Gains::from_poles(&Poles::repeated(1.0, 1)), priority: 0 };
        let osqp = osqp_iteration_ns::<4>(&[spec; 20], &SolverSettings::DEFAULT, 3).expect("set-up");
        assert!(osqp.is_finite() && osqp > 0.0, "{osqp}");
    }
}
