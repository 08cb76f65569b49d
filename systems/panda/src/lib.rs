//! Franka Emika's Panda (7 DoF) kept inside its joint limits, off its obstacles and off
//! itself by smooth SAT: the second robot on the generic toolchain, built from its URDF.
//!
//! Everything robot-specific is in its spec, `spec/panda.py` (example-robot-data's URDF
//! and SRDF: kinematics, limits, boxes fitted to the collision meshes, the SRDF's
//! self-collision pairs; four barrier families); the generator turns
//! it into [`generated`] and the generic [`EcbfFilter`](cbfgen::filter::EcbfFilter)
//! runs it. The rest of this crate is the closed-loop scenario and its figures:
//!
//! * [`scenario`] — a joint-space PD through timed waypoints whose straight path sweeps the
//!   forearm and hand through a box on a table, then folds the hand onto the shoulder and
//!   presses the elbow past its limit; run with and without the filter, with every checked
//!   box pair's exact SAT separation measured each cycle (`cbfgen arm`).
//! * [`output`] — its CSV and figures.
//!
//! ```
//! use cbfgen_panda::{Scenario, Simulation};
//!
//! let mut sim = Simulation::new(&Scenario::standard())?;
//! for _ in 0..100 {
//!     let sample = sim.step()?;
//!     assert!(sample.u.iter().all(|u| u.is_finite()));
//! }
//! assert!((sim.time() - 0.1).abs() < 1e-9);
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

#![warn(missing_docs)]

/// The module generated from `spec/panda.py` (by `cbfgen-build` in `build.rs`, checked in
/// under `generated/`). Never edited by hand: change the spec and rebuild.
#[allow(missing_docs)]
pub mod generated {
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/generated/panda.rs"));
}

pub mod output;
pub mod scenario;

pub use scenario::{run, Obstacle, Run, Sample, Scenario, Simulation, Summary, Waypoint, DT};
