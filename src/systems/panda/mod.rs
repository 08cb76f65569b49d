//! A Franka-Panda-like 7-DoF arm kept inside its joint limits, off its obstacles and off
//! itself by smooth SAT: the second robot on the generic toolchain.
//!
//! Everything robot-specific is in its spec, `symbolic/systems/panda.py` (published DH
//! table and joint limits, assumed link boxes, four barrier families); the generator turns
//! it into [`crate::generated::panda`] and the generic [`EcbfFilter`](crate::filter::EcbfFilter)
//! runs it. This module is only the closed-loop scenario and its figures:
//!
//! * [`scenario`] — a joint-space PD through timed waypoints whose straight path sweeps the
//!   forearm and hand through a box on a table, then folds the hand onto the shoulder and
//!   presses the elbow past its limit; run with and without the filter, with every checked
//!   box pair's exact SAT separation measured each cycle (`cbfgen arm`).
//! * [`output`] — its CSV and figures.
//!
//! ```
//! use cbfgen::systems::panda::{Scenario, Simulation};
//!
//! let mut sim = Simulation::new(&Scenario::standard())?;
//! for _ in 0..100 {
//!     let sample = sim.step()?;
//!     assert!(sample.u.iter().all(|u| u.is_finite()));
//! }
//! assert!((sim.time() - 0.1).abs() < 1e-9);
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

pub mod output;
pub mod scenario;

pub use scenario::{run, Obstacle, Run, Sample, Scenario, Simulation, Summary, Waypoint, DT};
