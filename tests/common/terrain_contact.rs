//! The body against the true terrain: the exact SAT separation of the body box from every
//! solid box of a scenario's terrain, over a run.
#![allow(dead_code)]

use cbfgen::sat;
use cbfgen::systems::tachyon3::model::body_box;
use cbfgen::systems::tachyon3::sim::{Scenario, SimResult};

/// Deepest the body box goes into any solid box of `scenario`'s terrain over `result`,
/// every fifth cycle \[m\] (negative: penetration).
pub fn body_into_terrain(scenario: Scenario, result: &SimResult) -> f64 {
    let solids = scenario.terrain().expect("terrain").solid_boxes().expect("boxes");
    result
        .samples
        .iter()
        .step_by(5)
        .map(|sample| {
            let body = body_box(&sample.x).expect("body");
            solids.iter().map(|b| sat::separation(b, &body)).fold(f64::INFINITY, f64::min)
        })
        .fold(f64::INFINITY, f64::min)
}
