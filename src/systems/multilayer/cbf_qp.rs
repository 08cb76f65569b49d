//! The high-rate ID-CBF-QP: track the MPC's acceleration, keep the ECBF condition.
//!
//! ```text
//! minimise   ½ (u − a_des)²
//! subject to L_g L_f h · u ≥ −(L_f² h + k1 L_f h + k0 h)      (ECBF, ∂h/∂t terms included)
//!            −u_max ≤ u ≤ u_max
//! ```
//!
//! With unit mass the inverse-dynamics equality `M q̈ = u` makes the acceleration and
//! the input the same variable, so the QP has one. The ECBF row is divided by
//! `|L_g L_f h|` each cycle (so OSQP sees a unit row whatever the kernel returns); the
//! matrices' pattern is fixed at construction, and a cycle updates values only.

use osqp::Problem;

use super::barrier::BarrierRow;
use super::solver::{Csc, INF};
use crate::error::CbfError;
use crate::filter::{Iterate, QpStatus, SolverSettings};
use crate::osqp_workspace::{self, OsqpQp};

/// Gains, input bound and solver settings of the CBF-QP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CbfQpSettings {
    /// Real poles `p1, p2 > 0` [1/s]: `k0 = p1 p2`, `k1 = p1 + p2`.
    pub poles: [f64; 2],
    /// `|u| ≤ u_max` [m/s²]; `f64::INFINITY` for none.
    pub u_max: f64,
    /// OSQP settings of this layer.
    pub solver: SolverSettings,
}

impl Default for CbfQpSettings {
    /// Poles at 10/s (k0 = 100, k1 = 20: h settles in a few tenths of a second, well
    /// inside one MPC period of 50 ms × 30), no input bound (the paper's example has
    /// none), tolerances tight enough that the ECBF row holds to 1e-6 m/s².
    fn default() -> Self {
        Self {
            poles: [10.0, 10.0],
            u_max: f64::INFINITY,
            solver: SolverSettings { eps_abs: 1e-8, eps_rel: 1e-8, max_iter: 4000, ..SolverSettings::default() },
        }
    }
}

impl CbfQpSettings {
    /// `[k0, k1]`.
    pub fn gains(&self) -> [f64; 2] {
        let gains = crate::system::Gains::from_poles(&self.poles.into());
        [gains.as_slice()[0], gains.as_slice()[1]]
    }
}

/// One CBF-QP solution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CbfQpOutput {
    /// The input `u` [m/s²].
    pub u: f64,
    /// `Solved`, `SolvedInaccurate`, or a limit (its iterate, flagged).
    pub status: QpStatus,
    /// OSQP's ADMM iterations in this solve.
    pub iterations: u32,
}

/// The one-variable ID-CBF-QP on OSQP.
pub struct IdCbfQp {
    settings: CbfQpSettings,
    gains: [f64; 2],
    /// Rows: the ECBF row, then the input bound. One column.
    a: Csc,
    q_lin: [f64; 1],
    lower: [f64; 2],
    upper: [f64; 2],
    problem: Option<Problem>,
    /// The last solve's input (NaN when it returned no iterate) and ADMM iterations.
    u: f64,
    iterations: u32,
}

impl std::fmt::Debug for IdCbfQp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("IdCbfQp").field("settings", &self.settings).finish_non_exhaustive()
    }
}

impl IdCbfQp {
    /// # Errors
    /// Non-positive poles or bound, or OSQP refusing the set-up.
    pub fn new(settings: CbfQpSettings) -> Result<Self, CbfError> {
        settings.solver.validate()?;
        for p in settings.poles {
            crate::filter::domain::pole(p)?;
        }
        if settings.u_max.is_nan() || settings.u_max <= 0.0 {
            return Err(CbfError::NotPositive { what: "input bound", value: settings.u_max });
        }
        let u_max = settings.u_max.min(INF);
        let qp = Self {
            settings,
            gains: settings.gains(),
            a: Csc::new(2, 1, |_, _| true, |_, _| 1.0),
            q_lin: [0.0],
            lower: [-INF, -u_max],
            upper: [INF, u_max],
            problem: None,
            u: f64::NAN,
            iterations: 0,
        };
        let mut qp = qp;
        osqp_workspace::set_up(&mut qp)?;
        Ok(qp)
    }

    /// The settings it was built with.
    pub fn settings(&self) -> &CbfQpSettings {
        &self.settings
    }

    /// The input closest to `desired_accel` that keeps the ECBF row of `row`.
    /// Allocation-free unless the previous call ended in a solver fault.
    ///
    /// # Errors
    /// A non-finite `desired_accel` or row, a row with `L_g L_f h = 0` (the input cannot
    /// act on it), or no usable iterate (infeasible against `u_max`, solver fault):
    /// [`CbfError::QpFailed`]. Nothing is applied then; the caller decides what to do.
    pub fn solve(&mut self, desired_accel: f64, row: &BarrierRow) -> Result<CbfQpOutput, CbfError> {
        crate::filter::domain::input("desired acceleration", desired_accel)?;
        if !(row.lie.iter().all(|v| v.is_finite()) && row.lg_lf.is_finite()) {
            return Err(CbfError::NonFiniteRow { row: 0 });
        }
        let scale = row.lg_lf.abs();
        if scale < 1e-12 {
            return Err(CbfError::QpFailed { layer: "ID-CBF-QP", status: "input_cannot_act" });
        }
        self.q_lin[0] = -desired_accel;
        self.a.data[0] = row.lg_lf / scale;
        self.lower[0] = (-row.ecbf_bound(self.gains) / scale).clamp(-INF, INF);
        let status = osqp_workspace::solve(self);
        let (iterations, u) = (self.iterations, self.u);
        if !matches!(
            status,
            QpStatus::Solved | QpStatus::SolvedInaccurate | QpStatus::MaxIterations | QpStatus::TimeLimit
        ) || !u.is_finite()
        {
            return Err(CbfError::QpFailed { layer: "ID-CBF-QP", status: status.name() });
        }
        Ok(CbfQpOutput { u, status, iterations })
    }
}

impl OsqpQp for IdCbfQp {
    fn workspace(&mut self) -> &mut Option<Problem> {
        &mut self.problem
    }

    fn setup(&self) -> Result<Problem, CbfError> {
        let p = Csc::new(1, 1, |_, _| true, |_, _| 1.0);
        Problem::new(p.view(), &self.q_lin, self.a.view(), &self.lower, &self.upper, &self.settings.solver.to_osqp())
            .map_err(|e| CbfError::SolverSetup { reason: e.to_string() })
    }

    fn update(&self, problem: &mut Problem) {
        problem.update_lin_cost(&self.q_lin);
        problem.update_bounds(&self.lower, &self.upper);
        problem.update_A(self.a.view());
    }

    fn read(&mut self, _status: QpStatus, iterate: Option<Iterate<'_>>, iterations: u32) {
        self.iterations = iterations;
        self.u = iterate.map_or(f64::NAN, |(z, _)| z[0]);
    }
}
