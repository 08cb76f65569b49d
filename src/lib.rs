//! # cbfgen — code-generated Exponential-CBF safety filters: the core
//!
//! A build-time SymEngine stage (`symbolic/`) differentiates each safety constraint of a
//! system's spec and emits straight-line Rust; this crate is what that code runs on. It
//! knows no robot: every system (the built-in ones in `systems/`, and yours) is a crate
//! that depends on this one and generates its module with `cbfgen-build`.
//!
//! * [`system`] — the contract a system's generated code implements.
//! * [`filter`] — the ECBF-QP safety filter over any [`system::BarrierSet`]: one
//!   allocation-free control update, every row met when the input box allows it, the
//!   families' priorities deciding who yields when it does not, and a safety verdict
//!   measured at the input returned.
//! * [`qp`] — its solvers and their vocabulary: an exact lexicographic solve in the inputs
//!   first, OSQP as fallback and reference.
//! * [`dynamic`] — any generated system behind object-safe traits, picked by name from a
//!   [`dynamic::Registry`] the caller fills (what the Python bindings use).
//! * [`plugin`] — a system built later, from a spec, loaded at run time as a shared
//!   library behind a versioned C ABI (`cbfgen.load` in Python).
//! * [`param_domain`] — the domains run-time parameters declare (lengths `> 0`, proper
//!   rotations), checked before a kernel reads them.
//! * [`lanes`] — `exp`, `tanh` and `ln` of many arguments at once in SIMD lanes, with
//!   stated error bounds: what generated kernels call.
//! * [`cpu_time`] — the thread CPU clock an update reads beside wall time when asked to.
//! * [`ops`] — the operations each generated kernel performs, stated by the generator and
//!   checked by running it on a counting number.
//!
//! Geometry every system can build barriers from:
//!
//! * [`ssat`] — Smooth Separating Axis Theorem between oriented boxes, with a certified
//!   margin that turns a smooth barrier into an exact no-overlap proof.
//! * [`sphere_box`] — a sphere vs an oriented box: the exact signed distance and a smooth
//!   clearance whose certified margin makes `h ≥ 0` a proof.
//! * [`sat`] — the exact SAT, the reference the smooth one is tested against.
//! * [`geometry`] — validated oriented boxes.

#![warn(missing_docs)]

pub mod compose;
pub mod cpu_time;
pub mod dual;
pub mod dynamic;
pub mod error;
pub mod filter;
pub mod geometry;
pub mod interval;
pub mod kernel_table;
pub mod lanes;
pub mod limits;
pub mod ops;
pub mod param_domain;
pub mod plugin;
pub mod qp;
pub mod rigid_body;
pub mod sat;
pub mod scalar;
pub mod sphere_box;
pub mod ssat;
pub mod system;
pub mod torque;

/// The primitives' kernels (SSAT variants, sphere-box clearance) emitted by
/// `python -m symbolic.generate`. Never edited by hand: change `symbolic/` and rebuild
/// (build.rs regenerates when the inputs' hash changes).
#[path = "../generated/mod.rs"]
#[allow(missing_docs)]
pub mod generated;

pub use error::CbfError;
pub use geometry::OrientedBox;
/// The nalgebra this crate is built with: generated parameter structs name their vector
/// and matrix fields through it, so a user crate needs no nalgebra dependency of its own.
pub use nalgebra;

/// The README's and the SSAT page's examples compile and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
#[doc = include_str!("../docs/ssat.md")]
pub struct ReadmeDoctests;

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
