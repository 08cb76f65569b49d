//! A row of your own, benched beside generated ones with criterion: the body centre kept
//! below 0.45 m above the ground-moving origin, written by hand as the filter takes every
//! row (h, its Lie derivatives along the drift, and L_g L_f h on the inputs). Beside it,
//! two generated Tachyon 3 kernels: one leg's joint limits (4 rows) and the body–edge SSAT.
//!
//! ```text
//! cargo run --release -p cbfgen-tachyon3 --example custom_row_bench            # short runs
//! cargo run --release -p cbfgen-tachyon3 --example custom_row_bench -- --long  # criterion's default length
//! ```

use std::hint::black_box;
use std::time::Duration;

use cbfgen::nalgebra::{Matrix3, Vector3};
use cbfgen_tachyon3::generated as gen;
use cbfgen_tachyon3::model::{standard_posture, State, BODY_Z};
use criterion::Criterion;

/// Highest the body centre may ride above the origin \[m\].
const CEILING: f64 = 0.45;

/// `([h, L_f h, L_f² h], L_g L_f h on baz)`: h = CEILING − bz is of relative degree 2,
/// and its second derivative is the body's vertical acceleration input, negated.
fn body_ceiling(x: &State) -> ([f64; 3], f64) {
    ([CEILING - x[BODY_Z], -x[BODY_Z + 3], 0.0], -1.0)
}

fn main() {
    let long = std::env::args().any(|a| a == "--long");
    let mut c = if long {
        Criterion::default()
    } else {
        Criterion::default()
            .warm_up_time(Duration::from_millis(200))
            .measurement_time(Duration::from_millis(500))
            .sample_size(10)
    };
    let mut x = standard_posture();
    x[BODY_Z + 3] = 0.1;
    let (lie, lg_lf) = body_ceiling(&x);
    // The hand-written derivatives against a finite difference of h along the drift.
    let step = 1e-6;
    let moved: State = std::array::from_fn(|i| x[i] + step * gen::drift(&x)[i]);
    assert!(((body_ceiling(&moved).0[0] - lie[0]) / step - lie[1]).abs() < 1e-6);
    println!(
        "body ceiling at the standard posture: h = {:.3} m, L_f h = {:.3} m/s, L_g L_f h = {lg_lf}",
        lie[0], lie[1]
    );

    let nosing = (Vector3::new(0.625, 0.0, 0.175), Matrix3::identity(), Vector3::new(0.025, 1.0, 0.025));
    c.bench_function("custom/body_ceiling (hand-written, 1 row)", |b| b.iter(|| body_ceiling(black_box(&x))));
    c.bench_function("generated/joint_limits_lf (4 rows)", |b| b.iter(|| gen::joint_limits_lf(black_box(&x))));
    c.bench_function("generated/body_edge (SSAT, 1 row)", |b| {
        b.iter(|| gen::body_edge(black_box(&x), &nosing.0, &nosing.1, &nosing.2))
    });
    c.final_summary();
}
