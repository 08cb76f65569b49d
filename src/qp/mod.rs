//! The quadratic-program solvers behind the filter and the MPCs.
//!
//! * [`lexicographic`] — the filter's QP with priority tiers, solved exactly in the `NU`
//!   inputs: every row hard when the rows fit the input box (one dual active-set solve,
//!   warm-started), else tier by tier the least largest violation first; every stage
//!   KKT-verified before it answers. The filter's first choice.
//! * [`dual_active_set`] — a dense Goldfarb–Idnani dual active-set solver for small,
//!   strictly convex QPs with hard rows: exact, warm-started, KKT-verified (the MPCs).
//! * [`hierarchy`] — strict priorities of least-squares tasks and inequalities, each level
//!   solved by [`dual_active_set`] in the null space of the tasks above (a whole-body
//!   controller's hierarchy).
//! * [`ocp`] — one iteration of a nonlinear MPC: an optimal-control QP over a horizon,
//!   its sparsity laid out once, the linearised stages written in place, solved by OSQP
//!   or by `riccati_ipm`'s interior-point method.
//! * `riccati_ipm` — Mehrotra's predictor–corrector for [`ocp`], each Newton step a
//!   Riccati recursion along the horizon.
//! * [`metric`] — the cost's metric `P = L Lᵀ` (input weights, or a spec's objective
//!   `P(x)`) and the scaled inputs `z = Lᵀ u` every stage and OSQP work in.
//! * [`recorded`] — a cycle's QP kept to replay against any solver (test fixtures,
//!   benchmarks).
//! * [`QpStatus`], [`Backend`], [`SolverSettings`], [`Solver`] — the vocabulary every
//!   solver here speaks, which the filter and the MPCs read.
//! * `csc` — the one compressed-sparse-column builder for the matrices handed to OSQP.
//! * `osqp_workspace` — one OSQP lifecycle (set-up, update, guarded solve) for every QP
//!   the crate hands to OSQP: the filter's fallback and reference backend, and the MPCs.

pub mod csc;
pub mod dual_active_set;
pub mod hierarchy;
pub mod lexicographic;
pub mod metric;
pub mod ocp;
pub mod osqp_workspace;
pub mod recorded;
mod riccati_ipm;
mod settings;
mod status;

pub use settings::{Solver, SolverSettings};
pub use status::{Backend, Iterate, QpStatus};

/// Bounds at or beyond this magnitude (and infinite ones) stand for "no bound", as in
/// OSQP (its `OSQP_INFTY`): every QP in the crate writes a missing bound as `±INFINITY`.
pub const INFINITY: f64 = 1e30;
