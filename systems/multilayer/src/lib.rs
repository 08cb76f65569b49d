//! Multi-layer safety: a CBF in a low-rate MPC and in a high-rate QP (after *Multi-Layered
//! Safety for Legged Robots via Control Barrier Functions and Model Predictive Control*,
//! section III, the double-integrator example).
//!
//! The plant is `q̈ = u` with state `x = [q, q̇]`, to be kept above a moving boundary:
//!
//! ```text
//! h(x, t) = q − A sin(ω t) − c ≥ 0
//! ```
//!
//! * [`mpc`] — a kinematic MPC (positions as states, velocities as inputs) at 20 Hz that
//!   drives `q` to a reference the boundary's crests violate, and hands down the desired
//!   acceleration `(v_1 − v_0)/δt`. [`MpcMode`] says what it knows of the barrier: a
//!   discrete-time CBF `h_k ≥ (1 − γ) h_{k−1}`, the state constraint `h_k ≥ 0`, or nothing.
//! * [`cbf_qp`] — an ID-CBF-QP at 1 kHz that tracks that acceleration subject to the ECBF
//!   condition `L_f² h + L_g L_f h u + k1 L_f h + k0 h ≥ 0`: the generic
//!   [`EcbfFilter`](cbfgen::filter::EcbfFilter) on the double-integrator spec, whose rows
//!   carry ∂h/∂t ([`barrier`]).
//! * [`controller`] — the two at their rates; [`scenario`] — the comparison run and its
//!   figures (`cbfgen multilayer`).
//!
//! Both QPs are OSQP problems laid out once; a cycle updates values only and allocates
//! nothing (`systems/multilayer/tests/no_alloc_multilayer.rs`).

#![warn(missing_docs)]

pub mod barrier;
pub mod cbf_qp;
pub mod controller;
pub mod mpc;
pub mod scenario;

pub use barrier::{BarrierRow, SineBarrier, State};
pub use cbf_qp::{CbfQpOutput, CbfQpSettings, IdCbfQp};
pub use controller::{ControlOutput, MultiLayerController};
pub use mpc::{KinematicMpc, MpcMode, MpcOutput, MpcSettings};
pub use scenario::{ScenarioConfig, Trace, VariantResult};
