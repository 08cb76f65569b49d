//! The solvers' vocabulary: how a solve ended ([`QpStatus`]), which solver answered
//! ([`Backend`]), and OSQP's iterates as every OSQP problem in the crate reads them.

use osqp::Status;

/// OSQP's primal and dual iterates, borrowed from its workspace.
pub type Iterate<'a> = (&'a [f64], &'a [f64]);

/// How a solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum QpStatus {
    /// The dense solve verified its KKT conditions (every stage of the filter's cascade),
    /// or OSQP met its tolerances (`eps_abs`, `eps_rel`) on a QP whose answer is OSQP's
    /// (the MPCs).
    Solved,
    /// Met the tolerances ×10 only (OSQP's "solved inaccurate").
    SolvedInaccurate,
    /// Stopped before an answer was verified: at `max_iter` (OSQP), at `dense_max_steps`
    /// or on rounding in a degenerate stage (the dense solve), or with an OSQP answer the
    /// dense solve could not verify; with the point reached.
    MaxIterations,
    /// Stopped at `time_limit` before meeting the tolerances, with the iterate it reached.
    TimeLimit,
    /// OSQP reported the constraints infeasible (accurately or not); no iterate.
    PrimalInfeasible,
    /// OSQP reported the cost unbounded below (accurately or not); no iterate.
    DualInfeasible,
    /// OSQP reported the cost matrix not positive semidefinite; no iterate.
    NonConvex,
    /// The solver wrapper panicked (a violated internal invariant); the solver is rebuilt
    /// on the next call.
    SolverFault,
    /// OSQP reported an iterate, or the dense solve a stage, with a NaN or infinite entry.
    /// It is discarded like a fault: the caller falls back, and OSQP's workspace (warm
    /// start, ρ) is rebuilt on the next call so the bad iterate cannot seed later cycles.
    NonFinite,
}

impl QpStatus {
    /// Whether the returned iterate is an optimum to the set tolerances.
    pub fn is_solved(self) -> bool {
        matches!(self, QpStatus::Solved | QpStatus::SolvedInaccurate)
    }

    /// OSQP's report, with the primal and dual iterates where it returned them: an
    /// optimum, or the point it stopped at on an iteration or time limit. Shared by every
    /// OSQP problem in the crate.
    ///
    /// An iterate with a NaN or infinite entry is never handed on: it reads as
    /// [`QpStatus::NonFinite`], without an iterate, whatever OSQP called it (OSQP's
    /// residual check passes NaN).
    pub(crate) fn of<'a>(result: &'a Status<'a>) -> (QpStatus, Option<Iterate<'a>>) {
        match Self::of_unchecked(result) {
            (_, Some((x, y))) if !x.iter().chain(y).all(|v| v.is_finite()) => (QpStatus::NonFinite, None),
            read => read,
        }
    }

    /// Whether the solver's workspace must be rebuilt before the next solve: after a
    /// fault, or after a non-finite iterate (its warm start and ρ may hold NaN).
    pub(crate) fn needs_rebuild(self) -> bool {
        matches!(self, QpStatus::SolverFault | QpStatus::NonFinite)
    }

    fn of_unchecked<'a>(result: &'a Status<'a>) -> (QpStatus, Option<Iterate<'a>>) {
        match result {
            Status::Solved(s) => (QpStatus::Solved, Some((s.x(), s.y()))),
            Status::SolvedInaccurate(s) => (QpStatus::SolvedInaccurate, Some((s.x(), s.y()))),
            Status::MaxIterationsReached(s) => (QpStatus::MaxIterations, Some((s.x(), s.y()))),
            Status::TimeLimitReached(s) => (QpStatus::TimeLimit, Some((s.x(), s.y()))),
            Status::PrimalInfeasible(_) | Status::PrimalInfeasibleInaccurate(_) => (QpStatus::PrimalInfeasible, None),
            Status::DualInfeasible(_) | Status::DualInfeasibleInaccurate(_) => (QpStatus::DualInfeasible, None),
            Status::NonConvex(_) => (QpStatus::NonConvex, None),
            _ => (QpStatus::SolverFault, None),
        }
    }

    /// Snake-case name, as shown in Python.
    pub const fn name(self) -> &'static str {
        match self {
            QpStatus::Solved => "solved",
            QpStatus::SolvedInaccurate => "solved_inaccurate",
            QpStatus::MaxIterations => "max_iterations",
            QpStatus::TimeLimit => "time_limit",
            QpStatus::PrimalInfeasible => "primal_infeasible",
            QpStatus::DualInfeasible => "dual_infeasible",
            QpStatus::NonConvex => "non_convex",
            QpStatus::SolverFault => "solver_fault",
            QpStatus::NonFinite => "non_finite",
        }
    }
}

/// Which solver produced an answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Backend {
    /// The exact dense solve ([`crate::qp::lexicographic`] for the filter).
    Dense,
    /// OSQP (ADMM); for the filter, verified by the dense solve from OSQP's face.
    Osqp,
}

impl Backend {
    /// Snake-case name, as written to CSV and shown in Python.
    pub const fn name(self) -> &'static str {
        match self {
            Backend::Dense => "dense",
            Backend::Osqp => "osqp",
        }
    }
}
