//! ANYmal C's generated dynamics models, for the controller stack in `cbfgen-anymal`
//! (which re-exports them as `wbc_generated` and `mpc_generated`).
//!
//! The specs are `systems/anymal/spec/anymal_wbc.py` and `anymal_mpc.py`; both read the
//! robot through `anymal_robot.py`, as the kinematic filter's spec does. The modules are a
//! crate of their own because they are large (22 000 generated lines: the contacts, the
//! foothold rows and the MPC's flow, unrolled) and change rarely: an edit to the filter's
//! spec recompiles the filter alone.

/// The module generated from `anymal_wbc.py`: the robot in free-flyer coordinates for a
/// whole-body controller — its floating-base dynamics (`dynamics`), the feet as contact
/// points (`contacts`) and the foothold rows in generalized accelerations. Never edited by
/// hand.
#[allow(missing_docs)]
pub mod wbc {
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/generated/anymal_wbc.rs"));
}

/// The module generated from `anymal_mpc.py`: the robot as seed 004's kino-dynamic MPC
/// sees it — one rigid body frozen at the standing state, contact forces and joint
/// velocities as inputs — with the flow and the feet and their Jacobians (`flow`, `feet`,
/// `orientation`) for the MPC's linearisation. Never edited by hand.
#[allow(missing_docs)]
pub mod mpc {
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/generated/anymal_mpc.rs"));
}
