//! Tachyon 3 (paper: *Real-time Perceptive Motion Control using Control Barrier Functions
//! with Analytical Smoothing for Six-Wheeled-Telescopic-Legged Robot Tachyon 3*).
//!
//! * [`model`] — the state/input layout and dynamics (generated from the model file).
//! * [`catalog`] — every ECBF row of the model, evaluated into preallocated storage; it
//!   implements [`BarrierSet`](cbfgen::system::BarrierSet), so the generic
//!   [`EcbfFilter`](cbfgen::filter::EcbfFilter) runs it ([`catalog::Tachyon3Filter`]).
//! * [`foothold`] — convex foothold polygons, and the switch between the foothold rows
//!   and the control-Lyapunov pull of a swing toe outside its foothold.
//! * [`terrain`] — stairs as edge cuboids and floors; [`approach`] — a scripted drive to them.
//! * [`sim`] — the closed-loop stair simulation (gait, filter, integration, CSV and
//!   figures), on the true terrain or on perceived terrain ([`sim::perceived`]: LiDAR,
//!   map, planes and edge cuboids at 1 Hz on a worker thread).
//! * [`latency`] — the percentile harness of the 269-row worst case.

#![warn(missing_docs)]

/// The module generated from `spec/tachyon3.py` (by `cbfgen-build` in `build.rs`, checked in
/// under `generated/`). Never edited by hand: change the spec and rebuild.
#[allow(missing_docs)]
pub mod generated {
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/generated/tachyon3.rs"));
}

pub mod approach;
pub mod catalog;
pub mod foothold;
pub mod latency;
pub mod model;
pub mod sim;
pub mod terrain;

/// The examples of the filter's page, which use Tachyon 3, compile and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../../../docs/filter.md")]
pub struct DocsDoctests;
