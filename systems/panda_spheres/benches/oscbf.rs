//! OSCBF's setting, timed: one filter update on joint torques (rows evaluated, mapped
//! through M(q)⁻¹, QP solved) at N = 0, 10, 25, 50 sphere obstacles plus the table, at
//! the moment of the sweep where the hand is among the obstacles (t = 4 s, seed 1):
//!
//! * `oscbf/update_<rows>_rows/N=<n>/all_rows` — every row evaluated and in the QP (as
//!   OSCBF solves it);
//! * `oscbf/update_<rows>_rows/N=<n>/culled` — the default: rows farther than 0.3 m
//!   neither evaluated nor in the QP;
//! * `oscbf_parts/…` — the same update's parts at N = 25: the rows in accelerations, the
//!   dynamics, and the dense QP alone.

use cbfgen::system::BarrierSet;
use cbfgen_panda_spheres::generated::{self as gen, Barriers};
use cbfgen_panda_spheres::{Scenario, Simulation};
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

const MOMENT: f64 = 4.0;

fn at_moment(scenario: &Scenario) -> Simulation {
    let mut sim = Simulation::new(scenario).expect("scenario");
    while sim.time() < MOMENT {
        sim.step().expect("a valid cycle");
    }
    sim
}

fn update(c: &mut Criterion) {
    let mut g = c.benchmark_group("oscbf");
    for n in [0, 10, 25, 50] {
        for (label, scenario) in
            [("all_rows", Scenario::with_obstacles(n, 1).all_rows()), ("culled", Scenario::with_obstacles(n, 1))]
        {
            let sim = at_moment(&scenario);
            let (x, params) = (*sim.state(), sim.params().clone());
            let tau = scenario.nominal(MOMENT, &x);
            let mut filter = cbfgen::filter::EcbfFilter::new(
                cbfgen_panda_spheres::TorqueRows::new(Barriers::new(params.capacity()).unwrap(), gen::dynamics),
                scenario.settings.clone(),
            )
            .unwrap();
            filter.update(&x, &tau, &params).expect("in the domain");
            let rows = filter.rows().len();
            g.bench_function(format!("update_{rows}_rows/N={n}/{label}"), |b| {
                b.iter(|| filter.update(black_box(&x), black_box(&tau), &params).map(|o| o.u))
            });
        }
    }
    g.finish();
}

fn parts(c: &mut Criterion) {
    let scenario = Scenario::with_obstacles(25, 1).all_rows();
    let sim = at_moment(&scenario);
    let (x, params) = (*sim.state(), sim.params().clone());
    let mut rows = Barriers::new(params.capacity()).unwrap();
    let mut g = c.benchmark_group("oscbf_parts");
    g.bench_function("rows_in_accelerations (N=25, all)", |b| b.iter(|| rows.evaluate(0.0, black_box(&x), &params)));
    g.bench_function("dynamics (M and b)", |b| b.iter(|| gen::dynamics(black_box(&x))));
    let mut torque = cbfgen_panda_spheres::TorqueRows::new(Barriers::new(params.capacity()).unwrap(), gen::dynamics);
    g.bench_function("rows_in_torques (N=25, all)", |b| b.iter(|| torque.evaluate(0.0, black_box(&x), &params)));
    g.finish();
}

criterion_group!(benches, update, parts);
criterion_main!(benches);
