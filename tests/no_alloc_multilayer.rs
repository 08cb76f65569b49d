//! The multi-layer control path allocates nothing: MPC re-plans and CBF-QP solves over
//! thousands of cycles, for all three MPC modes, bad inputs included. Counted for Rust's
//! global allocator and for the C `malloc` family OSQP would call.
//!
//! The counters are process-wide, so this binary has no test harness (`harness = false`
//! in Cargo.toml): libtest's own thread allocates while a test runs, and once made this
//! count flaky under load. `main` runs the one check on the only thread.

#[path = "common/alloc_count.rs"]
mod alloc_count;

use cbfgen::multilayer::{MultiLayerController, ScenarioConfig};

fn main() {
    thousands_of_multilayer_cycles_allocate_nothing();
    println!("thousands_of_multilayer_cycles_allocate_nothing ... ok");
}

fn thousands_of_multilayer_cycles_allocate_nothing() {
    let config = ScenarioConfig::default();
    let mut controllers: Vec<MultiLayerController> = config
        .modes()
        .into_iter()
        .map(|mode| MultiLayerController::new(config.barrier, mode, config.mpc, config.qp, config.cycle_dt).unwrap())
        .collect();
    let mut states = vec![config.x0; controllers.len()];

    alloc_count::assert_counters_work(|| {
        MultiLayerController::new(config.barrier, config.modes()[0], config.mpc, config.qp, config.cycle_dt)
    });

    let mut ok = 0usize;
    let mut replans = 0usize;
    let ((), rust, c) = alloc_count::counting(|| {
        for cycle in 0..4000 {
            let t = cycle as f64 * config.cycle_dt;
            for (controller, x) in controllers.iter_mut().zip(states.iter_mut()) {
                // Every 500th cycle a bad state first: the error path must not allocate either.
                if cycle % 500 == 250 {
                    let _ = controller.control(t, &[f64::NAN, x[1]]);
                }
                let Ok(out) = controller.control(t, x) else { continue };
                ok += 1;
                replans += usize::from(out.mpc.is_some());
                let dt = config.cycle_dt;
                *x = [x[0] + x[1] * dt + 0.5 * out.u * dt * dt, x[1] + out.u * dt];
            }
        }
    });
    assert_eq!((rust, c), (0, 0), "allocations during 12000 cycles: Rust {rust}, C {c}");
    assert_eq!(ok, 12_000, "every cycle must solve");
    assert_eq!(replans, 3 * 80, "the MPC re-plans every 50 cycles");
    assert!(states.iter().all(|x| x[0] < 0.9), "the systems must have moved: {states:?}");
}
