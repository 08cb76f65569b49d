//! The Tachyon 3 model's layout and dynamics, as generated from its spec
//! (`systems/tachyon3/spec/tachyon3.py`, numbers from `systems/tachyon3/spec/tachyon3.toml`).
//!
//! State (36) and input (17) layouts are [`STATE_NAMES`] and [`INPUT_NAMES`]: the
//! ground-moving origin (world position, yaw, speed, yaw rate), the origin-relative body
//! (x, z, pitch and rates) and six toes (x, z and rates, each in its leg's lateral plane).

use crate::generated as gen;
use cbfgen::error::CbfError;
pub use gen::{
    world_kinematics, xdot, BODY_HALF_EXTENTS, ECBF_POLES, HIP_OUTWARD, HIP_POSITIONS, HIP_RANGES, INPUT_LIMITS,
    INPUT_MATRIX_PATTERN, INPUT_NAMES, KNEE_RANGE, LEG_NAMES, NOMINAL_CLEARANCE, NU, NX, STATE_NAMES, TOE_RADIUS,
};

/// A state vector.
pub type State = [f64; NX];
/// An input vector.
pub type Input = [f64; NU];

/// Index of the first toe block (the generated `state::LF_X`); toe `leg` occupies
/// `TOE_BLOCK + 4 * leg ..+4` (x, z, vx, vz).
pub const TOE_BLOCK: usize = gen::state::LF_X;
/// The body's x, z \[m\] and pitch \[rad\] relative to the origin (the generated
/// `state::BX`, `BZ`, `PITCH`); each rate is 3 further on.
pub use gen::state::{BX as BODY_X, BZ as BODY_Z, PITCH as BODY_PITCH};

// The layout the `+ 3` and `4 * leg` arithmetic above relies on, held to the generated
// indices when this compiles.
const _: () = assert!(
    gen::state::BVX == BODY_X + 3
        && gen::state::BVZ == BODY_Z + 3
        && gen::state::PITCH_RATE == BODY_PITCH + 3
        && gen::state::LF_VZ == TOE_BLOCK + 3
        && gen::state::MF_X == TOE_BLOCK + 4
);

/// The core's state domain, here too: inside it every generated Tachyon 3 row is finite
/// except where the geometry itself is singular (a toe exactly at its hip joint, where
/// the knee length is zero), which the filter answers with a flagged fallback. World
/// points built from a state (origin + body offset + hip + toe) stay within a few times
/// it, inside the box domain ([`MAX_COORDINATE`](cbfgen::geometry::MAX_COORDINATE)), so
/// the exact clearance checks accept every state the filter does.
pub use cbfgen::system::STATE_LIMIT;

/// The state `h` seconds on with input `u` held, one RK4 step of `ẋ = f(x) + g(x) u`: the
/// continuous plant between two samples, in fine steps.
pub fn held_step(x: &State, u: &[f64; NU], h: f64) -> State {
    let Ok(next) = cbfgen::system::rk4_step(|y| Ok::<_, std::convert::Infallible>(xdot(y, u)), x, h);
    next
}

/// `Ok(())` when every entry is finite with `|x_i| ≤` [`STATE_LIMIT`]
/// ([`system::validate_state`](cbfgen::system::validate_state) on the model's state).
///
/// # Errors
/// [`CbfError::NonFinite`] or [`CbfError::OutOfRange`] naming the first bad entry's kind.
pub fn validate_state(x: &State) -> Result<(), CbfError> {
    cbfgen::system::validate_state(x)
}

/// Position of a named state in [`State`].
pub fn state_index(name: &str) -> Option<usize> {
    STATE_NAMES.iter().position(|n| *n == name)
}

/// Position of a named input in [`Input`].
pub fn input_index(name: &str) -> Option<usize> {
    INPUT_NAMES.iter().position(|n| *n == name)
}

/// The standard low posture at rest at the world origin: body underside at
/// [`NOMINAL_CLEARANCE`], pitch 0, every toe on the ground (wheel centre at
/// [`TOE_RADIUS`]) straight below its hip.
pub fn standard_posture() -> State {
    let mut x = [0.0; NX];
    x[BODY_Z] = NOMINAL_CLEARANCE + BODY_HALF_EXTENTS[2];
    for (leg, hip) in HIP_POSITIONS.iter().enumerate() {
        x[TOE_BLOCK + 4 * leg] = hip[0];
        x[TOE_BLOCK + 4 * leg + 1] = TOE_RADIUS;
    }
    x
}

/// The body box at state `x`, in the world.
///
/// # Errors
/// A state whose body pose is not finite.
pub fn body_box(x: &State) -> Result<cbfgen::geometry::OrientedBox, CbfError> {
    use nalgebra::{Matrix3, Rotation3, Vector3};
    let (center, rotation, _) = world_kinematics(x);
    let r = Rotation3::from_matrix_unchecked(Matrix3::from_fn(|i, j| rotation[i][j]));
    cbfgen::geometry::OrientedBox::new(Vector3::from(center), r, Vector3::from(BODY_HALF_EXTENTS))
}

/// Each leg's joints at `x`, in [`LEG_NAMES`] order: `[knee length [m], hip angle [rad,
/// positive outward], knee rate [m/s], hip rate [rad/s]]`. These are the joint-limit
/// kernels' own quantities (their `knee_min` and `hip_min` rows, h and its first Lie
/// derivative, plus the limits): what a joint-level controller tracks.
pub fn leg_joints(x: &State) -> [[f64; 4]; 6] {
    type JointKernel = fn(&[f64; NX]) -> ([[f64; 3]; 4], [[f64; 5]; 4]);
    const KERNELS: [JointKernel; 6] = [
        gen::joint_limits_lf,
        gen::joint_limits_mf,
        gen::joint_limits_rf,
        gen::joint_limits_lr,
        gen::joint_limits_mr,
        gen::joint_limits_rr,
    ];
    std::array::from_fn(|leg| {
        let (lie, _) = KERNELS[leg](x);
        let (knee, hip) = (lie[0], lie[2]);
        [knee[0] + KNEE_RANGE[0], hip[0] + HIP_RANGES[leg][0], knee[1], hip[1]]
    })
}

/// Move the ground-moving origin `d` metres along its heading without moving the robot:
/// the origin's world position shifts by `d` along the yaw, and the body's and every
/// toe's origin-relative x by `−d`. Every world pose is the same afterwards (so is every
/// row's `h`), and with the yaw rate at zero every world velocity too: the paper's origin
/// jumps this way to the wheels in contact when the support legs change (section II-B).
pub fn shift_origin(x: &mut State, d: f64) {
    let (s, c) = x[gen::state::YAW].sin_cos();
    x[gen::state::PX] += d * c;
    x[gen::state::PY] += d * s;
    x[BODY_X] -= d;
    for leg in 0..6 {
        x[TOE_BLOCK + 4 * leg] -= d;
    }
}

/// Origin-relative x of the robot's foremost point: the body's front face or a toe
/// sphere's front, whichever reaches further (yaw and pitch ignored).
pub fn front_reach(x: &State) -> f64 {
    (0..6).map(|leg| x[TOE_BLOCK + 4 * leg] + TOE_RADIUS).fold(x[BODY_X] + BODY_HALF_EXTENTS[0], f64::max)
}

/// The farthest any point of the body box moves when the body rolls by `roll` \[rad\]
/// about its own x axis: a corner, `2 r sin(|roll| / 2)` with `r` the half-diagonal of the
/// box's y–z face \[m\]. The model's state has no roll; a body keeping this clearance
/// ([`Environment::set_body_clearance`](crate::catalog::Environment::set_body_clearance))
/// is clear however it is rolled by `roll` or less.
pub fn roll_clearance(roll: f64) -> f64 {
    let r = BODY_HALF_EXTENTS[1].hypot(BODY_HALF_EXTENTS[2]);
    2.0 * r * (roll.abs().min(std::f64::consts::PI) / 2.0).sin()
}
