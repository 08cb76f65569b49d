//! The body against the true terrain: the exact SAT separation of the body box from every
//! solid box of a scenario's terrain, over a run.
#![allow(dead_code)]

use cbfgen::generated::tachyon3::world_kinematics;
use cbfgen::systems::tachyon3::model::BODY_HALF_EXTENTS;
use cbfgen::systems::tachyon3::sim::{Scenario, SimResult};
use cbfgen::{sat, OrientedBox};
use nalgebra::{Matrix3, Rotation3, Vector3};

/// Deepest the body box goes into any solid box of `scenario`'s terrain over `result`,
/// every fifth cycle \[m\] (negative: penetration).
pub fn body_into_terrain(scenario: Scenario, result: &SimResult) -> f64 {
    let solids = scenario.terrain().expect("terrain").solid_boxes().expect("boxes");
    result
        .samples
        .iter()
        .step_by(5)
        .map(|sample| {
            let (c, r, _) = world_kinematics(&sample.x);
            let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_fn(|i, j| r[i][j]));
            let body = OrientedBox::new(Vector3::from(c), rotation, Vector3::from(BODY_HALF_EXTENTS)).expect("body");
            solids.iter().map(|b| sat::separation(b, &body)).fold(f64::INFINITY, f64::min)
        })
        .fold(f64::INFINITY, f64::min)
}
