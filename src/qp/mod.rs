//! The quadratic-program solvers behind the filter and the MPCs.
//!
//! * [`input_space`] — the ECBF QP solved exactly in the `NU` inputs (its slacks
//!   eliminated): a warm-started Newton / active-set method, allocation-free, verified by
//!   its KKT conditions before it answers. The filter's first choice.
//! * [`dual_active_set`] — a dense Goldfarb–Idnani dual active-set solver for small,
//!   strictly convex QPs with hard rows: exact, warm-started, KKT-verified (the MPCs).
//! * [`recorded`] — a cycle's QP kept to replay against any solver (test fixtures,
//!   benchmarks).
//! * `osqp_workspace` — one OSQP lifecycle (set-up, update, guarded solve) for every QP
//!   the crate hands to OSQP: the filter's fallback and reference backend, and the MPCs.

pub mod dual_active_set;
pub mod input_space;
pub(crate) mod osqp_workspace;
pub mod recorded;
