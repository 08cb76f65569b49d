//! The double integrator q'' = u above the moving boundary A sin(ω t) + c: seed 004's
//! section III example, and the smallest system there is. This crate is all a system
//! needs: its spec (`spec/double_integrator.py`), a build script calling `cbfgen-build`, and
//! this file including the generated module (`NX`, `NU`, `Params`, `Barriers`, `Filter`,
//! `SYSTEM`, …). [`pressed`] is the closed loop the sampled-data certificate's example
//! and tests share.
//!
//! Picked by name at run time, through the core's type-erased layer:
//!
//! ```
//! use cbfgen::dynamic::{CapacityCount, Registry};
//!
//! static SYSTEMS: Registry = Registry::new(&[cbfgen_double_integrator::SYSTEM]);
//!
//! let planar = SYSTEMS.get("double_integrator")?;
//! assert_eq!((planar.nx(), planar.nu()), (2, 1));
//! let mut params = planar.params(&[])?;
//! let sine = params.family_index("sine_barrier")?;
//! params.set(sine, 0, 0, &[0.0, 1.0, -0.01])?; // amplitude, omega, offset: h = q + 0.01
//! let mut filter = planar.filter(&[], &planar.default_settings())?;
//! filter.update(0.0, &[0.0, 0.0], &[-3.0], params.as_ref())?;
//! // At rest 1 cm above the boundary, poles (10, 10): u ≥ −k₀ h = −100 · 0.01.
//! assert!((filter.output().u[0] + 1.0).abs() < 1e-2);
//! # let _: &[CapacityCount] = &[];
//! # Ok::<(), cbfgen::CbfError>(())
//! ```
#![allow(missing_docs)]

include!(concat!(env!("CARGO_MANIFEST_DIR"), "/generated/double_integrator.rs"));

#[warn(missing_docs)]
pub mod pressed;
