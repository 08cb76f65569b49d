//! Random Tachyon 3 states for the kernel and catalog tests: the body near its standard
//! posture, every toe within 30 cm of its hip in x and below the hips (the legs point
//! down), all rates moderate.
#![allow(dead_code)]

use cbfgen_tachyon3::model::{self, State, BODY_PITCH, BODY_X, BODY_Z, TOE_BLOCK};
use rand::Rng;

pub fn random_state(r: &mut impl Rng) -> State {
    let mut x = model::standard_posture();
    x[0] = r.random_range(-2.0..2.0);
    x[1] = r.random_range(-2.0..2.0);
    x[2] = r.random_range(-0.2..0.2);
    x[3] = r.random_range(-3.0..3.0);
    x[4] = r.random_range(-1.0..1.0);
    x[5] = r.random_range(-0.5..0.5);
    x[BODY_X] = r.random_range(-0.1..0.1);
    x[BODY_Z] = r.random_range(0.2..0.5);
    x[BODY_PITCH] = r.random_range(-0.3..0.3);
    for rate in &mut x[9..12] {
        *rate = r.random_range(-0.5..0.5);
    }
    for leg in 0..6 {
        let t = TOE_BLOCK + 4 * leg;
        x[t] = x[BODY_X] + model::HIP_POSITIONS[leg][0] + r.random_range(-0.3..0.3);
        x[t + 1] = r.random_range(-0.05..0.15); // below the hips, so the legs point down
        x[t + 2] = r.random_range(-0.5..0.5);
        x[t + 3] = r.random_range(-0.5..0.5);
    }
    x
}
