//! A state where the model's geometry is singular, shared by the tests that drive the
//! filter's non-finite-row fallback (included by path).
#![allow(dead_code)]

use cbfgen_tachyon3::model::{self, State, HIP_POSITIONS, TOE_BLOCK};

/// The standard posture with leg `leg`'s toe exactly on its hip joint: the knee length is
/// 0, so the joint-limit rows' hip angle and derivatives divide 0 by 0. The pitch is 0,
/// so the hip sits at body position + mount; the toe is placed by adding the same terms
/// the generated kernel subtracts, so the difference is exactly 0.0, not merely tiny.
pub fn toe_at_hip(leg: usize) -> State {
    let mut x = model::standard_posture();
    debug_assert_eq!(x[model::BODY_PITCH], 0.0);
    x[TOE_BLOCK + 4 * leg] = x[model::BODY_X] + HIP_POSITIONS[leg][0];
    x[TOE_BLOCK + 4 * leg + 1] = x[model::BODY_Z] + HIP_POSITIONS[leg][2];
    x
}
