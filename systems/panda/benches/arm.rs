//! The 7-DoF arm's filter (`systems/panda/spec/panda.py`), beside Tachyon 3's in the README:
//!
//! * `arm/update_<rows>_rows/{dense_then_osqp,osqp}` — one full update (every row evaluated,
//!   the QP solved, warm-started) at two moments of the standard scenario: `sweep` (1.2 s,
//!   the forearm held off the box) and `fold` (12 s, the hand held off the shoulder), and
//!   `…/torques_dense_then_osqp` the same rows mapped to joint torques through the
//!   generated dynamics;
//! * `arm_rows/all_<rows>` — every row evaluated, no solve;
//! * `arm_row/<family>` — one member's kernel: all 14 joint-limit rows, all 14 velocity
//!   rows, one link (the hand) against one obstacle, one self-collision pair (link2/hand);
//! * `arm_dynamics/mass_matrix_and_bias` — the generated M(q) and C(q, q̇) q̇ + g(q);
//! * `arm_kinematics/…` — the generated hand pose and its 6×7 Jacobian, and every link
//!   box's pose (forward kinematics of the 11 boxes).
//!
//! Pinocchio's own figures for the same quantities, called from Python on the same
//! machine, are `scripts/pinocchio_peer.py`'s.

use cbfgen::filter::{EcbfFilter, Solver};
use cbfgen::system::BarrierSet;
use cbfgen::torque::JointTorque;
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
        // The same rows on joint torques: M and b generated from the URDF, M factored, every
        // row mapped (cbfgen::torque::JointTorque), then the dense solve.
        let mut settings = Scenario::standard().settings;
        settings.input_min = gen::TAU_MAX.map(|t| -t);
        settings.input_max = gen::TAU_MAX;
        let mut torque =
            EcbfFilter::new(JointTorque::new(Barriers::new(params.capacity()).expect("rows"), gen::dynamics), settings)
                .expect("filter");
        let (m, bias) = gen::dynamics(&x);
        let tau: [f64; gen::NU] =
            std::array::from_fn(|i| (0..gen::NU).map(|j| m[i][j] * u_ref[j]).sum::<f64>() + bias[i]);
        torque.update(&x, &tau, &params).expect("in the domain");
        let rows = torque.rows().len();
        g.bench_function(format!("update_{rows}_rows/{moment}/torques_dense_then_osqp"), |b| {
            b.iter(|| torque.update(black_box(&x), black_box(&tau), &params).map(|o| o.u))
        });
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
    let (center, rotation, half) = (box_.center, box_.rotation, box_.half);
    let mut g = c.benchmark_group("arm_row");
    g.bench_function("joint_limits (14 rows)", |b| b.iter(|| gen::joint_limits(black_box(&x))));
    g.bench_function("velocity_limits (14 rows)", |b| b.iter(|| gen::velocity_limits(black_box(&x))));
    g.bench_function("obstacle (hand vs one box)", |b| {
        b.iter(|| gen::obstacle_hand(black_box(&x), &center, &rotation, &half))
    });
    g.bench_function("self_collision (link2 vs hand)", |b| b.iter(|| gen::self_collision_link2_hand(black_box(&x))));
    g.finish();
    // The generated rigid-body dynamics from the URDF's inertials: M(q) and C(q, q̇) q̇ + g(q).
    c.bench_function("arm_dynamics/mass_matrix_and_bias", |b| b.iter(|| gen::dynamics(black_box(&x))));
    c.bench_function("arm_kinematics/hand_pose_and_jacobian", |b| b.iter(|| gen::hand(black_box(&x))));
    c.bench_function("arm_kinematics/link_box_poses", |b| b.iter(|| gen::link_boxes(black_box(&x))));
}

criterion_group!(benches, update, rows);
criterion_main!(benches);
