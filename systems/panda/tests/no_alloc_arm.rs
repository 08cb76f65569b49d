//! The arm's control path allocates nothing: the generated `panda` barriers and the
//! generic filter over the standard scenario's 24 s (rows of all four families, of
//! relative degrees 1 and 2, evaluated and solved each cycle), beside a second filter on
//! OSQP alone and a third mapping the rows to joint torques (`cbfgen::torque::JointTorque`),
//! with a NaN state and a nominal input of 1e300 rejected now and then. Counted
//! for Rust's global allocator and for the C `malloc` family OSQP calls.
//!
//! The counters are process-wide, so this binary has no test harness (`harness = false`
//! in Cargo.toml); `main` runs the one check on the only thread.

#[path = "../../../testkit/alloc_count.rs"]
mod alloc_count;

use cbfgen::filter::{EcbfFilter, InputSource, Solver};
use cbfgen::torque::JointTorque;
use cbfgen::CbfError;
use cbfgen_panda::generated::{self, Barriers, Params, NU, NX};
use cbfgen_panda::{Scenario, Simulation, DT};

fn main() {
    the_arm_filter_allocates_nothing();
    println!("the_arm_filter_allocates_nothing ... ok");
}

fn the_arm_filter_allocates_nothing() {
    let scenario = Scenario::standard();
    // The simulation only lays out the obstacles; the loop below is the control path.
    let params: Params = Simulation::new(&scenario).expect("the standard scenario").params().clone();
    let capacity = params.capacity();
    let mut filter = EcbfFilter::new(Barriers::new(capacity).unwrap(), scenario.settings.clone()).unwrap();
    let mut osqp_settings = scenario.settings.clone();
    osqp_settings.solver.backend = Solver::Osqp;
    let mut osqp = EcbfFilter::new(Barriers::new(capacity).unwrap(), osqp_settings).unwrap();
    assert!(params.obstacle.iter().all(|o| o.as_slice().len() == 2));
    let mut torque_settings = scenario.settings.clone();
    torque_settings.input_min = generated::TAU_MAX.map(|t| -t);
    torque_settings.input_max = generated::TAU_MAX;
    let mut torque =
        EcbfFilter::new(JointTorque::new(Barriers::new(capacity).unwrap(), generated::dynamics), torque_settings)
            .unwrap();
    let mut torque_solved = 0usize;

    alloc_count::assert_counters_work(|| {
        EcbfFilter::new(Barriers::new(capacity).unwrap(), scenario.settings.clone()).unwrap()
    });

    let cycles = (scenario.duration / DT).round() as usize;
    let mut x = [0.0; NX];
    x[..7].copy_from_slice(&scenario.start);
    let mut nan = x;
    nan[3] = f64::NAN;
    let (mut solved, mut rejected, mut osqp_solved) = (0usize, 0usize, 0usize);
    let (_, rust, c) = alloc_count::counting(|| {
        for k in 0..cycles {
            let t = k as f64 * DT;
            let u_ref = scenario.nominal(t, &x);
            let u = match filter.update(&x, &u_ref, &params) {
                Ok(out) => {
                    solved += usize::from(out.source == InputSource::Qp);
                    out.u
                }
                Err(_) => unreachable!("the drive's inputs are in the domain"),
            };
            if k % 10 == 0 {
                if let Ok(out) = osqp.update(&x, &u_ref, &params) {
                    osqp_solved += usize::from(matches!(out.source, InputSource::Qp | InputSource::Unconverged));
                }
            }
            if k % 10 == 5 {
                // The same rows on torques (the wrapper factors M each cycle, on the stack).
                let (m, b) = generated::dynamics(&x);
                let tau: [f64; NU] = std::array::from_fn(|i| (0..NU).map(|j| m[i][j] * u_ref[j]).sum::<f64>() + b[i]);
                if let Ok(out) = torque.update(&x, &tau, &params) {
                    torque_solved += usize::from(out.source == InputSource::Qp);
                }
            }
            if k % 100 == 0 {
                rejected +=
                    usize::from(matches!(filter.update(&nan, &u_ref, &params), Err(CbfError::NonFinite { .. })));
                let huge = [1e300; NU];
                rejected += usize::from(matches!(filter.update(&x, &huge, &params), Err(CbfError::OutOfRange { .. })));
            }
            for j in 0..7 {
                x[j] += x[7 + j] * DT + 0.5 * u[j] * DT * DT;
                x[7 + j] += u[j] * DT;
            }
        }
    });
    assert_eq!((rust, c), (0, 0), "allocations during {cycles} arm cycles: Rust {rust}, C {c}");
    assert_eq!(solved, cycles, "every drive update solved its QP");
    assert_eq!(osqp_solved, cycles / 10, "every OSQP update returned its iterate");
    assert_eq!(rejected, 2 * cycles / 100, "every bad input was rejected");
    assert_eq!(torque_solved, cycles / 10, "every torque update solved its QP");
}
