//! One OSQP lifecycle for every QP in the crate: set up once, then each cycle update the
//! data, solve behind `catch_unwind`, read the outcome through `QpStatus::of` (so no
//! non-finite iterate is ever handed on), and rebuild the workspace before the next solve
//! after a fault or a non-finite iterate. A QP supplies only what is its own: how to set
//! the problem up, what to write into it each cycle, and what to keep of a solve.

use std::panic::{catch_unwind, AssertUnwindSafe};

use osqp::Problem;

use super::{Iterate, QpStatus};
use crate::error::CbfError;

/// A QP solved by OSQP through [`solve`].
pub trait OsqpQp {
    /// The slot holding the OSQP workspace (`None` until set up, or after a fault).
    fn workspace(&mut self) -> &mut Option<Problem>;
    /// Build the workspace from the current data (allocates).
    fn setup(&self) -> Result<Problem, CbfError>;
    /// Write this cycle's data into the workspace (must not allocate).
    fn update(&self, problem: &mut Problem);
    /// Keep what this QP needs of a solve: its status, OSQP's finite iterate where there is
    /// one, and the ADMM iterations.
    fn read(&mut self, status: QpStatus, iterate: Option<Iterate<'_>>, iterations: u32);
}

/// Set `qp`'s workspace up (at construction).
///
/// # Errors
/// OSQP refusing the set-up.
pub fn set_up(qp: &mut impl OsqpQp) -> Result<(), CbfError> {
    let problem = qp.setup()?;
    *qp.workspace() = Some(problem);
    Ok(())
}

/// One solve of `qp`. Allocation-free, except that a workspace dropped after a fault or
/// a non-finite iterate is rebuilt first. A panic inside OSQP's wrapper (a violated
/// invariant) reads as [`QpStatus::SolverFault`].
pub fn solve(qp: &mut impl OsqpQp) -> QpStatus {
    let mut slot = qp.workspace().take();
    let status = catch_unwind(AssertUnwindSafe(|| {
        if slot.is_none() {
            slot = Some(qp.setup().ok()?);
        }
        let problem = slot.as_mut()?;
        qp.update(problem);
        let result = problem.solve();
        let (status, iterate) = QpStatus::of(&result);
        qp.read(status, iterate, result.iter());
        Some(status)
    }))
    .ok()
    .flatten()
    .unwrap_or(QpStatus::SolverFault);
    if !status.needs_rebuild() {
        *qp.workspace() = slot;
    }
    status
}
