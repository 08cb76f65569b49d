//! The torque-controlled sphere arm's control path allocates nothing: 5 s of the 50-obstacle
//! scenario (1 018 rows mapped to torques each cycle), with a NaN state rejected now and
//! then, and 300 cycles more certified between the samples. Counted for Rust's global
//! allocator and for the C `malloc` family OSQP calls; no test harness
//! (`harness = false`), so `main` runs the one check on the only thread.

#[path = "../../../testkit/alloc_count.rs"]
mod alloc_count;

use cbfgen::dual::Dual;
use cbfgen::filter::InputSource;
use cbfgen::interval::Interval;
use cbfgen_panda_spheres::{step_plant, Scenario, Simulation};

fn main() {
    let scenario = Scenario::with_obstacles(50, 1);
    let mut sim = Simulation::new(&scenario).expect("scenario");
    let params = sim.params().clone();
    let mut filter = cbfgen::filter::EcbfFilter::new(
        cbfgen_panda_spheres::TorqueRows::new(
            cbfgen_panda_spheres::generated::Barriers::new(params.capacity()).unwrap(),
            cbfgen_panda_spheres::generated::dynamics,
        ),
        scenario.settings.clone(),
    )
    .unwrap();
    alloc_count::assert_counters_work(|| Simulation::new(&scenario).expect("scenario"));
    let mut x = *sim.state();
    let (mut solved, mut rejected) = (0usize, 0usize);
    let cycles = 5000;
    let (_, rust, c) = alloc_count::counting(|| {
        for k in 0..cycles {
            let tau_ref = scenario.nominal(k as f64 * 1e-3, &x);
            let out = *filter.update(&x, &tau_ref, &params).expect("in the domain");
            solved += usize::from(out.source == InputSource::Qp);
            if k % 100 == 0 {
                let mut nan = x;
                nan[2] = f64::NAN;
                rejected += usize::from(filter.update(&nan, &tau_ref, &params).is_err());
            }
            x = step_plant(&x, &out.u, cbfgen_panda_spheres::DT).expect("a regular mass matrix");
        }
    });
    assert_eq!((rust, c), (0, 0), "allocations during {cycles} cycles: Rust {rust}, C {c}");
    assert_eq!(solved, cycles);
    assert_eq!(rejected, cycles / 100);

    // And certified between the samples: the flow through the interval rigid-body
    // dynamics, the interval solve and every row's interval kernel, each round.
    let scenario = scenario.certified();
    let mut certified_filter = cbfgen::filter::EcbfFilter::new(
        cbfgen_panda_spheres::TorqueRows::new(
            cbfgen_panda_spheres::generated::Barriers::new(params.capacity()).unwrap(),
            cbfgen_panda_spheres::generated::dynamics,
        )
        .with_interval_dynamics(
            cbfgen_panda_spheres::generated::dynamics::<Interval>,
            cbfgen_panda_spheres::generated::dynamics::<Dual<Interval>>,
        ),
        scenario.settings.clone(),
    )
    .unwrap();
    let mut x = *Simulation::new(&scenario).expect("scenario").state();
    let (mut certified, certified_cycles) = (0usize, 300);
    let (_, rust, c) = alloc_count::counting(|| {
        for k in 0..certified_cycles {
            let tau_ref = scenario.nominal(k as f64 * 1e-3, &x);
            let out = *certified_filter.update(&x, &tau_ref, &params).expect("in the domain");
            certified += usize::from(out.between_samples.is_certified());
            x = step_plant(&x, &out.u, cbfgen_panda_spheres::DT).expect("a regular mass matrix");
        }
    });
    assert_eq!((rust, c), (0, 0), "allocations during {certified_cycles} certified cycles: Rust {rust}, C {c}");
    assert!(certified > 0, "no update certified");
    sim.step().expect("the simulation still runs");
    println!("the_sphere_arm_filter_allocates_nothing ... ok");
}
