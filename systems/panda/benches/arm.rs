//! The 7-DoF arm's filter (`systems/panda/spec/panda.py`), beside Tachyon 3's in the README:
//!
//! * `arm/update_53_rows/{dense_then_osqp,osqp}` — one full update (every row evaluated,
//!   the QP solved, warm-started) at two moments of the standard scenario: `sweep` (1.2 s,
//!   the forearm held off the box) and `fold` (12 s, the hand held off the shoulder);
//! * `arm_rows/all_53` — every row evaluated, no solve;
//! * `arm_row/<family>` — one member's kernel: all 14 joint-limit rows, all 14 velocity
//!   rows, one link (the hand) against one obstacle, one self-collision pair (link2/hand).

use cbfgen::filter::{EcbfFilter, Solver};
use cbfgen::system::BarrierSet;
use cbfgen_panda::generated::{self as gen, Barriers};
use cbfgen_panda::{Scenario, Simulation};
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

/// The simulation after `t` seconds of the standard scenario.
fn simulation_at(t: f64) -> Simulation {
    let mut sim = Simulation::new(&Scenario::standard()).expect("the standard scenario");
    while sim.time() < t {
        sim.step().expect("a valid cycle");
    }
    sim
}

fn update(c: &mut Criterion) {
    let mut g = c.benchmark_group("arm");
    for (moment, t) in [("sweep", 1.2), ("fold", 12.0)] {
        let sim = simulation_at(t);
        let (x, params) = (*sim.state(), sim.params().clone());
        let u_ref = Scenario::standard().nominal(t, &x);
        for backend in [Solver::DenseThenOsqp, Solver::Osqp] {
            let mut settings = Scenario::standard().settings;
            settings.solver.backend = backend;
            let mut filter =
                EcbfFilter::new(Barriers::new(params.capacity()).expect("rows"), settings).expect("filter");
            let out = *filter.update(&x, &u_ref, &params).expect("in the domain");
            assert!(out.active_rows > 28, "{moment}: collision rows in the QP: {out:?}");
            let rows = filter.rows().len();
            g.bench_function(format!("update_{rows}_rows/{moment}/{}", backend.name()), |b| {
                b.iter(|| filter.update(black_box(&x), black_box(&u_ref), &params).map(|o| o.u))
            });
        }
    }
    g.finish();
}

fn rows(c: &mut Criterion) {
    let sim = simulation_at(12.0);
    let (x, params) = (*sim.state(), sim.params().clone());
    let mut barriers = Barriers::new(params.capacity()).expect("rows");
    let n = barriers.rows().len();
    c.bench_function(&format!("arm_rows/all_{n}"), |b| b.iter(|| barriers.evaluate(0.0, black_box(&x), &params)));
    let box_ = params.obstacle[7].as_slice()[1];
    let (center, rotation, half) =
        (box_.center.into(), std::array::from_fn(|k| box_.rotation[(k / 3, k % 3)]), box_.half.into());
    let mut g = c.benchmark_group("arm_row");
    g.bench_function("joint_limits (14 rows)", |b| b.iter(|| gen::joint_limits(black_box(&x))));
    g.bench_function("velocity_limits (14 rows)", |b| b.iter(|| gen::velocity_limits(black_box(&x))));
    g.bench_function("obstacle (hand vs one box)", |b| {
        b.iter(|| gen::obstacle_hand(black_box(&x), &center, &rotation, &half))
    });
    g.bench_function("self_collision (link2 vs hand)", |b| b.iter(|| gen::self_collision_link2_hand(black_box(&x))));
    g.finish();
}

criterion_group!(benches, update, rows);
criterion_main!(benches);
