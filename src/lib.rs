//! # cbfgen — code-generated Exponential-CBF safety filters
//!
//! A build-time SymEngine stage (`symbolic/`) differentiates each safety constraint and
//! emits straight-line Rust into `generated/`; this crate wraps those kernels in a safe
//! API. Data flows one way: model → symbolic expressions → derivatives → CSE → Rust →
//! [`generated`] → the modules below.
//!
//! The generic core serves any control-affine system:
//!
//! * [`system`] — the contract a system's code implements (generated from a spec by
//!   `python -m symbolic generate`, or by the `cbfgen-build` helper from a build script).
//! * [`filter`] — the ECBF-QP safety filter over any [`system::BarrierSet`]: one
//!   allocation-free control update, every row met when the input box allows it, the
//!   families' priorities deciding who yields when it does not, and a safety verdict
//!   measured at the input returned.
//! * [`qp`] — its solvers: an exact lexicographic solve in the inputs first, OSQP as
//!   fallback and reference.
//! * [`dynamic`] — every generated system behind object-safe traits, picked by name at
//!   run time (what the Python bindings use).
//! * [`param_domain`] — the domains run-time parameters declare (lengths `> 0`, proper
//!   rotations), checked before a kernel reads them.
//!
//! Geometry every system can build barriers from:
//!
//! * [`ssat`] — Smooth Separating Axis Theorem between oriented boxes, with a certified
//!   margin that turns a smooth barrier into an exact no-overlap proof.
//! * [`sphere_box`] — a sphere vs an oriented box: the exact signed distance and a smooth
//!   clearance whose certified margin makes `h ≥ 0` a proof (Tachyon 3's toe rows).
//! * [`sat`] — the exact SAT, the reference the smooth one is tested against.
//! * [`geometry`] — validated oriented boxes; [`chart`] — the SVG figures every system draws.
//! * `perception` (feature `perception`, on with `cli` and `python`) — planes and edge
//!   cuboids from a simulated LiDAR's points.
//!
//! The systems, each beside its scenario code, in [`systems`]: Tachyon 3 (the paper's
//! robot: catalog, stairs, gait, simulation), the 3D-LIP footstep MPC and the multi-layer
//! MPC + CBF-QP.

#![warn(missing_docs)]

pub mod chart;
pub mod cpu_time;
pub mod dynamic;
pub mod error;
pub mod filter;
pub mod geometry;
pub mod param_domain;
pub mod perception;
pub mod qp;
pub mod sat;
pub mod sphere_box;
pub mod ssat;
pub mod system;
pub mod systems;

/// Kernels emitted by `python -m symbolic.generate`. Never edited by hand: change
/// `symbolic/` and rebuild (build.rs regenerates when the inputs' hash changes).
#[path = "../generated/mod.rs"]
#[allow(missing_docs)]
pub mod generated;

pub use error::CbfError;
pub use geometry::OrientedBox;
/// The nalgebra this crate is built with: generated parameter structs name their vector
/// and matrix fields through it, so a user crate needs no nalgebra dependency of its own.
pub use nalgebra;

/// Include a system module that `cbfgen-build` generated into `OUT_DIR`, inside the module
/// that should hold it:
///
/// ```ignore
/// pub mod planar_robot {
///     cbfgen::include_system!("planar_robot");
/// }
/// ```
#[macro_export]
macro_rules! include_system {
    ($name:literal) => {
        include!(concat!(env!("OUT_DIR"), "/", $name, ".rs"));
    };
}

/// The README's examples compile and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// The Python extension module `cbfgen._native` (built by maturin with this feature).
#[cfg(feature = "python")]
mod python;
