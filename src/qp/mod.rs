//! The quadratic-program solvers behind the filter and the MPCs.
//!
//! * [`dual_active_set`] — a dense Goldfarb–Idnani dual active-set solver for small,
//!   strictly convex QPs with hard rows: exact, warm-started, KKT-verified (the MPCs).
//! * `osqp_workspace` — one OSQP lifecycle (set-up, update, guarded solve) for every QP
//!   the crate hands to OSQP: the filter's fallback and reference backend, and the MPCs.

pub mod dual_active_set;
pub(crate) mod osqp_workspace;
