//! Tachyon 3 (paper: *Real-time Perceptive Motion Control using Control Barrier Functions
//! with Analytical Smoothing for Six-Wheeled-Telescopic-Legged Robot Tachyon 3*).
//!
//! * [`model`] — the state/input layout and dynamics (generated from the model file).
//! * [`catalog`] — every ECBF row of the model, evaluated into preallocated storage; it
//!   implements [`BarrierSet`](crate::system::BarrierSet), so the generic
//!   [`EcbfFilter`](crate::filter::EcbfFilter) runs it ([`catalog::Tachyon3Filter`]).
//! * [`terrain`] — stairs as edge cuboids and floors; [`approach`] — a scripted drive to them.
//! * [`sim`] — the closed-loop stair simulation (gait, filter, integration, CSV and
//!   figures), on the true terrain or on perceived terrain ([`sim::perceived`]: LiDAR,
//!   map, planes and edge cuboids at 1 Hz on a worker thread).
//! * [`latency`] — the percentile harness of the 269-row worst case.

pub mod approach;
pub mod catalog;
pub mod latency;
pub mod model;
pub mod sim;
pub mod terrain;
