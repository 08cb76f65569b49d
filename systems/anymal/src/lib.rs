//! ANYmal C on a floating base, built from ANYbotics' own robot description through the
//! spec language's URDF front end: the robot of seed 004's stepping-stone experiment.
//!
//! Everything robot-specific is in the spec, `spec/anymal.py`: example-robot-data's
//! `anymal.urdf` and `anymal.srdf` give the kinematic tree, the joint limits, one box per
//! link around its collision primitives, the foot spheres, the self-collision pairs and the
//! standing state. The state is the trunk's position and roll, pitch, yaw, the 12 joint
//! angles leg by leg (LF, RF, LH, RH; HAA, HFE, KFE), then all 18 rates; the inputs are the
//! 18 generalized accelerations. Its families: `joint_limits`, `velocity_limits`,
//! `foot_region` (each foot sphere's centre inside half-spaces given at run time: a
//! foothold, or the ground) and `self_collision` (30 SRDF pairs by smooth SAT).
//!
//! For torques: [`wbc_generated`] is the same robot in free-flyer coordinates (its
//! dynamics, contacts and foothold rows in generalized accelerations, from
//! `spec/anymal_wbc.py`), [`wbc`] seed 004's hierarchical whole-body controller on it,
//! [`plant`] a rigid-contact plant to try it on and [`gait`] a trot (in place or at a velocity).
//!
//! Trotting in place on footholds 6 cm square ([`square_footholds`]): the nominal input
//! ([`swinging_nominal`]) swings each hip 0.4 rad, far past them; one second at 1 kHz
//! (the model is exact here: x'' = u):
//!
//! ```
//! use cbfgen::filter::EcbfFilter;
//! use cbfgen_anymal::generated::{self as gen, Barriers, NU, NX};
//! use cbfgen_anymal::{square_footholds, swinging_nominal};
//!
//! let mut start = [0.0; NX];
//! start[..NU].copy_from_slice(&gen::STANDING); // the SRDF's standing state, at rest
//! let params = square_footholds(&start, 0.03, 0.0)?;
//! let mut filter = EcbfFilter::new(Barriers::new(params.capacity())?, gen::default_settings())?;
//! // How far any foot strays from its square's centre in x or y [m], filtered or not.
//! let mut run = |filtered: bool| -> Result<f64, cbfgen::CbfError> {
//!     let (mut x, dt, mut worst) = (start, 1e-3, 0.0_f64);
//!     for k in 0..1000 {
//!         let u_ref = swinging_nominal(k as f64 * dt, &x, 0.4, 1.5);
//!         let u = if filtered { filter.update(&x, &u_ref, &params)?.u } else { u_ref };
//!         for i in 0..NU {
//!             x[i] += dt * x[NU + i] + 0.5 * dt * dt * u[i];
//!             x[NU + i] += dt * u[i];
//!         }
//!         for (foot, home) in gen::feet(&x).0.iter().zip(gen::feet(&start).0) {
//!             worst = worst.max((foot[0] - home[0]).abs()).max((foot[1] - home[1]).abs());
//!         }
//!     }
//!     Ok(worst)
//! };
//! assert!(run(true)? <= 0.03 + 1e-6);
//! assert!(run(false)? > 0.1);
//! # Ok::<(), cbfgen::CbfError>(())
//! ```
#![warn(missing_docs)]

/// The module generated from `spec/anymal.py` (by `cbfgen-build` in `build.rs`, checked in
/// under `generated/`). Never edited by hand: change the spec and rebuild.
#[allow(missing_docs)]
pub mod generated {
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/generated/anymal.rs"));
}

/// The whole-body controller's model (`spec/anymal_wbc.py`), generated in
/// `cbfgen-anymal-dynamics`: its floating-base dynamics (`dynamics`), the feet as contact
/// points (`contacts`) and the foothold rows in generalized accelerations.
pub use cbfgen_anymal_dynamics::wbc as wbc_generated;

/// The kino-dynamic MPC's model (`spec/anymal_mpc.py`), generated in
/// `cbfgen-anymal-dynamics`: one rigid body frozen at the standing state, with the flow and
/// the feet and their Jacobians (`flow`, `feet`, `orientation`) for the MPC's linearisation.
pub use cbfgen_anymal_dynamics::mpc as mpc_generated;

pub mod gait;
pub mod mpc;
pub mod mpc_thread;
pub mod plant;
pub mod stones;
pub mod terrain;
mod vec3;
pub mod walk;
pub mod wbc;

use cbfgen::error::{finite, positive, CbfError};
use generated::{self as gen, Capacity, FootRegionParams, Params, NU, NX};

/// Half-spaces each foot's region holds at most, in [`square_footholds`]: four sides and the ground.
pub const FOOTHOLD_HALF_SPACES: usize = 5;

/// A square foothold of half-width `half_width` \[m\] centred (in x, y) on where each foot
/// stands at state `x`, and the ground `z >= ground + foot radius` under it: each foot's
/// region is five half-spaces, so the filter keeps the foot sphere on its square and above
/// the ground.
///
/// # Errors
/// A non-finite or non-positive `half_width`, or a non-finite `ground` or state.
pub fn square_footholds(x: &[f64; NX], half_width: f64, ground: f64) -> Result<Params, CbfError> {
    positive("foothold half_width", half_width)?;
    finite("ground height", ground)?;
    for &v in x {
        finite("state", v)?;
    }
    let mut params = Params::new(Capacity { foot_region: [FOOTHOLD_HALF_SPACES; gen::LEGS.len()] })?;
    let (feet, _) = gen::feet(x);
    for (member, foot) in params.foot_region.iter_mut().zip(feet) {
        let floor = ([0.0, 0.0, -1.0], -(ground + gen::FOOT_RADIUS));
        for (normal, offset) in square_sides(foot, half_width).into_iter().chain([floor]) {
            member.push(FootRegionParams { normal: normal.into(), offset })?;
        }
    }
    Ok(params)
}

/// The four sides of a square of half-width `half_width` \[m\] centred (in x, y; world) on
/// `centre`, as half-spaces `(n, d)` with `n · c ≤ d` inside.
pub fn square_sides(centre: [f64; 3], half_width: f64) -> [([f64; 3], f64); 4] {
    [
        ([1.0, 0.0, 0.0], centre[0] + half_width),
        ([-1.0, 0.0, 0.0], half_width - centre[0]),
        ([0.0, 1.0, 0.0], centre[1] + half_width),
        ([0.0, -1.0, 0.0], half_width - centre[1]),
    ]
}

/// A nominal input that asks for more than the footholds allow: a PD (stiffness 400,
/// damping 40 per coordinate) holding the trunk at [`gen::STANDING`] while each leg's hip
/// (HFE) swings `amplitude` \[rad\] at `frequency` \[Hz\], diagonal legs in phase as in a
/// trot, and each knee (KFE) lifts the foot by half that in the swing's first half.
pub fn swinging_nominal(t: f64, x: &[f64; NX], amplitude: f64, frequency: f64) -> [f64; NU] {
    const STIFFNESS: f64 = 400.0;
    const DAMPING: f64 = 40.0;
    let mut target = gen::STANDING;
    for (leg, name) in gen::LEGS.iter().enumerate() {
        // LF and RH in phase, RF and LH half a period later.
        let phase = if matches!(*name, "LF" | "RH") { 0.0 } else { std::f64::consts::PI };
        let swing = (std::f64::consts::TAU * frequency * t + phase).sin();
        let hfe = 6 + 3 * leg + 1;
        target[hfe] += amplitude * swing;
        // Knees bend the same way as the standing state's (its sign) to lift the foot.
        target[hfe + 1] += 0.5 * amplitude * swing.max(0.0) * target[hfe + 1].signum();
    }
    std::array::from_fn(|i| STIFFNESS * (target[i] - x[i]) - DAMPING * x[NU + i])
}
