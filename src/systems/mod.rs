//! The systems built on the generic core, each with its own scenario code: what a new
//! robot adds beside its spec.
//!
//! * [`tachyon3`] — the six-wheeled telescopic-legged robot of the Tachyon 3 paper: its
//!   model, constraint catalog, stairs, gait and closed-loop simulation.
//! * [`lip`] — bipedal navigation: a 3D-LIP MPC with linear discrete CBFs around obstacles.
//! * [`multilayer`] — a CBF in a low-rate MPC and in a high-rate QP, on the double integrator.
//! * [`panda`] — a Franka-Panda-like 7-DoF arm: joint limits, obstacles and self-collision
//!   by smooth SAT, from a spec alone.

pub mod lip;
pub mod multilayer;
pub mod panda;
pub mod tachyon3;
