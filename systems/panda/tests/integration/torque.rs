//! The arm torque-controlled: the same rows (written in joint accelerations) mapped to
//! joint torques through the URDF's dynamics ([`cbfgen::torque::JointTorque`] with the
//! generated `dynamics`), in a closed loop whose plant integrates `M(q) q̈ + b(q, q̇) = τ`.
//! Checked against the exact SAT of every pair, the joint limits, and the ECBF condition
//! of every active row recomputed in accelerations from the acceleration the applied
//! torque actually produced (`cbfgen::torque::rigid_body_acceleration`'s LU, not the wrapper's
//! Cholesky).

use cbfgen::filter::{EcbfFilter, FilterSettings, InputSource};
use cbfgen::sat;
use cbfgen::system::BarrierSet;
use cbfgen::torque::{rigid_body_acceleration, step_rigid_body, JointTorque};
use cbfgen_panda::generated::{self as gen, Barriers, Params, NU, NX};
use cbfgen_panda::scenario::link_boxes;
use cbfgen_panda::{Scenario, Simulation, DT};
use nalgebra::{SMatrix, SVector};

type Torque = JointTorque<Barriers, NX, NU>;

fn torque_settings() -> FilterSettings<NU> {
    let mut settings = gen::default_settings();
    settings.input_min = gen::TAU_MAX.map(|t| -t);
    settings.input_max = gen::TAU_MAX;
    settings
}

/// What a torque-controlled run showed: the closest exact SAT separation over every pair
/// and cycle \[m\], the closest joint to its limit \[rad\], the rows whose condition was
/// recomputed, and the cycles whose torque did not come from the QP.
struct Outcome {
    closest: f64,
    joint_margin: f64,
    checked: usize,
    not_qp: usize,
}

/// `scenario` with the filter on torques and the plant integrating the rigid-body dynamics.
fn torque_loop(scenario: &Scenario) -> Outcome {
    // The obstacle parameters, as the acceleration simulation lays them out.
    let params: Params = Simulation::new(scenario).expect("scenario").params().clone();
    let mut filter =
        EcbfFilter::new(Torque::new(Barriers::new(params.capacity()).unwrap(), gen::dynamics), torque_settings())
            .expect("filter");
    let mut fresh = Barriers::new(params.capacity()).unwrap();
    let poles: Vec<Vec<f64>> = filter.settings().families.iter().map(|f| f.poles.as_slice().to_vec()).collect();
    let mut x = [0.0; NX];
    x[..NU].copy_from_slice(&scenario.start);
    let (mut closest, mut joint_margin, mut checked, mut not_qp) = (f64::INFINITY, f64::INFINITY, 0usize, 0usize);
    let cycles = (scenario.duration / DT).round() as usize;
    for cycle in 0..cycles {
        let t = cycle as f64 * DT;
        // Computed torque around the scenario's PD: τ = M q̈_ref + b.
        let (m, b) = gen::dynamics(&x);
        let qdd_ref = scenario.nominal(t, &x);
        let tau_ref: [f64; NU] = std::array::from_fn(|i| (0..NU).map(|j| m[i][j] * qdd_ref[j]).sum::<f64>() + b[i]);
        let out = *filter.update(&x, &tau_ref, &params).expect("update");
        assert!(out.u.iter().all(|u| u.is_finite()));
        not_qp += usize::from(out.source != InputSource::Qp);
        // The condition in accelerations, at the acceleration the torque produces.
        let qdd = rigid_body_acceleration(gen::dynamics, &x, &out.u).expect("M is invertible");
        fresh.evaluate(0.0, &x, &params).unwrap();
        for (k, (row, at)) in fresh.rows().iter().zip(fresh.layout()).enumerate() {
            if !filter.active()[k] || filter.relaxed()[k].is_some() {
                continue;
            }
            let bound = match poles[at.family].as_slice() {
                &[p] => row.lie[1] + p * row.lie[0],
                &[p1, p2] => row.lie[2] + (p1 + p2) * row.lie[1] + p1 * p2 * row.lie[0],
                other => panic!("unexpected poles {other:?}"),
            };
            let lhs = bound + row.lg.iter().zip(&qdd).map(|(g, a)| g * a).sum::<f64>();
            let size = bound.abs() + row.lg.iter().zip(&qdd).map(|(g, a)| g.abs() * (1.0 + a.abs())).sum::<f64>();
            assert!(lhs >= -1e-7 * size, "t = {t:.3}, row {k}: ECBF condition {lhs:e} (size {size:e}) reported met");
            checked += 1;
        }
        x = step_rigid_body(gen::dynamics, &x, &out.u, DT).expect("a regular mass matrix");
        let links = link_boxes(&x).unwrap();
        for o in &scenario.obstacles {
            for &l in &gen::OBSTACLE_LINKS {
                closest = closest.min(sat::separation(&o.shape, &links[l]));
            }
        }
        for &[a, b] in &gen::SELF_PAIRS {
            closest = closest.min(sat::separation(&links[a], &links[b]));
        }
        for ((q, lo), hi) in x[..NU].iter().zip(gen::Q_MIN).zip(gen::Q_MAX) {
            joint_margin = joint_margin.min((q - lo).min(hi - q));
        }
    }
    eprintln!(
        "torque loop: closest pair {:.1} mm, joint margin {joint_margin:.2e} rad, {checked} rows checked, \
         {not_qp} cycles not from the QP",
        closest * 1e3
    );
    Outcome { closest, joint_margin, checked, not_qp }
}

#[test]
fn a_torque_controlled_arm_keeps_every_pair_apart_and_every_row_holds_in_physics() {
    // The standard course: the sweep across the box and the fold onto the shoulder. (The
    // QP's torque metric is not the acceleration one, so the arm does not retrace the
    // acceleration run: it stops at the fold, short of the wrist's limit.)
    let run = torque_loop(&Scenario::standard());
    assert!(run.closest >= -1e-3, "a pair overlapped by {:.2} mm", -run.closest * 1e3);
    assert!(run.joint_margin >= -1e-3, "a joint passed its limit by {} rad", -run.joint_margin);
    assert_eq!(run.not_qp, 0, "every torque came from the QP");
    assert!(run.checked > 100_000, "only {} rows checked", run.checked);
    // The rows do the work: the course drives some pair to within a few cm.
    assert!(run.closest < 0.05, "closest {}", run.closest);
}

#[test]
fn a_torque_controlled_wrist_stops_at_its_limit() {
    // From the ready pose, the last joint is driven 0.3 rad past its limit.
    let ready = [-0.7, 0.0, 0.0, -1.6, 0.0, 1.6, 0.785];
    let mut past = ready;
    past[6] = 3.2;
    let scenario = Scenario {
        start: ready,
        waypoints: vec![cbfgen_panda::Waypoint { from: 0.0, q: past }],
        duration: 6.0,
        ..Scenario::standard()
    };
    let run = torque_loop(&scenario);
    assert!(run.joint_margin >= -1e-3, "a joint passed its limit by {} rad", -run.joint_margin);
    assert!(run.joint_margin < 0.01, "the wrist must come within 0.01 rad of its limit: {}", run.joint_margin);
    assert!(run.closest >= -1e-3 && run.not_qp == 0);
}

#[test]
fn the_mapped_rows_are_the_acceleration_rows_through_the_dynamics() {
    // At states of the scenario: ã = M⁻¹ a and L_f^r h − ã·b, against nalgebra's inverse.
    let scenario = Scenario::standard();
    let mut sim = Simulation::new(&scenario).expect("scenario");
    let params = sim.params().clone();
    let mut mapped = Torque::new(Barriers::new(params.capacity()).unwrap(), gen::dynamics);
    let mut plain = Barriers::new(params.capacity()).unwrap();
    let mut compared = 0;
    while sim.time() < scenario.duration {
        let x = *sim.state();
        if sim.time() % 0.5 < DT / 2.0 {
            mapped.evaluate(0.0, &x, &params).unwrap();
            plain.evaluate(0.0, &x, &params).unwrap();
            let (m, b) = gen::dynamics(&x);
            let inverse = SMatrix::<f64, NU, NU>::from_fn(|i, j| m[i][j]).try_inverse().unwrap();
            let bias = SVector::<f64, NU>::from_fn(|i, _| b[i]);
            for ((got, row), at) in mapped.rows().iter().zip(plain.rows()).zip(plain.layout()) {
                let degree = mapped.families()[at.family].relative_degree;
                let want = inverse * SVector::<f64, NU>::from_fn(|i, _| row.lg[i]);
                let scale = 1.0 + want.abs().max();
                for j in 0..NU {
                    assert!((got.lg[j] - want[j]).abs() <= 1e-12 * scale, "{at:?}: column {j}");
                }
                let lie = row.lie[degree] - want.dot(&bias);
                assert!(
                    (got.lie[degree] - lie).abs() <= 1e-12 * (1.0 + lie.abs() + want.abs().max() * bias.abs().max())
                );
                assert_eq!(got.lie[..degree], row.lie[..degree], "{at:?}: lower derivatives are unchanged");
                compared += 1;
            }
        }
        sim.step().unwrap();
    }
    assert!(compared > 1000);
}

#[test]
fn a_state_whose_mass_matrix_is_not_finite_is_a_typed_error_and_the_next_cycle_works() {
    let scenario = Scenario::standard();
    let params = Simulation::new(&scenario).unwrap().params().clone();
    let mut filter =
        EcbfFilter::new(Torque::new(Barriers::new(params.capacity()).unwrap(), gen::dynamics), torque_settings())
            .unwrap();
    let mut x = [0.0; NX];
    x[..NU].copy_from_slice(&scenario.start);
    let mut bad = x;
    bad[3] = f64::NAN;
    assert!(filter.update(&bad, &[0.0; NU], &params).is_err());
    bad[3] = 1e300;
    assert!(filter.update(&bad, &[0.0; NU], &params).is_err());
    let out = filter.update(&x, &gen::dynamics(&x).1, &params).expect("a good state after bad ones");
    assert_eq!(out.source, InputSource::Qp);
}
