//! The terrain the perception tests and benches scan: a floor and three 16.5 × 35 cm
//! steps from x = 1 m, 2 m wide, as boxes; and the poses of six scans on the way up (0.6 m
//! above the floor or tread under the sensor, as a climbing body would carry it).
#![allow(dead_code)]

use cbfgen::OrientedBox;
use nalgebra::Vector3;

pub const RISE: f64 = 0.165;
pub const RUN: f64 = 0.35;
pub const FIRST_RISER: f64 = 1.0;
pub const STEPS: usize = 3;
/// Where the top landing ends \[m\].
pub const END: f64 = FIRST_RISER + STEPS as f64 * RUN + 0.6;
/// Sensor positions (x, z) of the scans, y = 0, heading +x.
pub const SCAN_POSES: [(f64, f64); 6] = [(0.0, 0.6), (0.3, 0.6), (0.6, 0.6), (0.9, 0.6), (1.2, 0.765), (1.55, 0.93)];

pub fn terrain() -> Vec<OrientedBox> {
    flight(RISE, RUN, STEPS, END)
}

/// A floor and `steps` steps of `rise` × `run` from x = [`FIRST_RISER`], 2 m wide, the
/// top landing ending at x = `end`.
pub fn flight(rise: f64, run: f64, steps: usize, end: f64) -> Vec<OrientedBox> {
    let mut boxes = vec![OrientedBox::axis_aligned(Vector3::new(1.0, 0.0, -0.5), Vector3::new(4.0, 3.0, 0.5)).unwrap()];
    for k in 0..steps {
        let (x0, top) = (FIRST_RISER + k as f64 * run, (k + 1) as f64 * rise);
        boxes.push(
            OrientedBox::axis_aligned(
                Vector3::new((x0 + end) / 2.0, 0.0, top / 2.0),
                Vector3::new((end - x0) / 2.0, 1.0, top / 2.0),
            )
            .unwrap(),
        );
    }
    boxes
}
