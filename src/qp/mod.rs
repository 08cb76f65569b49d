//! The quadratic-program solvers behind the filter and the MPCs.
//!
//! * `osqp_workspace` — one OSQP lifecycle (set-up, update, guarded solve) for every QP
//!   the crate hands to OSQP: the filter's fallback and reference backend, and the MPCs.

pub(crate) mod osqp_workspace;
