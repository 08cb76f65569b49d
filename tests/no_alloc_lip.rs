//! The LIP-MPC control path allocates nothing: a whole walk to the goal, one MPC step
//! (half-planes, preprocessing, value update, OSQP solve, state advance) after another,
//! counted on Rust's global allocator and on the C `malloc` family OSQP would call.
//!
//! The counters are process-wide, so this binary has no test harness (`harness = false`
//! in Cargo.toml): libtest's own thread allocates while a test runs, and once made this
//! count flaky under load. `main` runs the one check on the only thread.

#[path = "common/alloc_count.rs"]
mod alloc_count;

use cbfgen::lip::scenario::{Scenario, Walker};
use cbfgen::lip::LipMpc;

fn main() {
    a_walk_of_mpc_steps_allocates_nothing();
    println!("a_walk_of_mpc_steps_allocates_nothing ... ok");
}

fn a_walk_of_mpc_steps_allocates_nothing() {
    let mut walker = Walker::new(Scenario::standard()).expect("walker");
    alloc_count::assert_counters_work(|| LipMpc::new(Default::default(), 2, LipMpc::default_solver_settings()));

    let mut broken = *walker.state();
    broken[1] = f64::NAN;
    let ((advanced, errors), rust, c) = alloc_count::counting(|| {
        let (mut advanced, mut errors) = (0, 0);
        for step in 0..60 {
            // Once, a bad state: the error path must not allocate either.
            if step == 10 {
                let good = *walker.state();
                walker.set_state(broken);
                errors += usize::from(walker.step().is_err());
                walker.set_state(good);
            }
            match walker.step() {
                Ok(outcome) if outcome.advanced => advanced += 1,
                _ => break,
            }
            if walker.at_goal() {
                break;
            }
        }
        (advanced, errors)
    });
    assert_eq!((rust, c), (0, 0), "allocations during {advanced} MPC steps: Rust {rust}, C {c}");
    assert_eq!(errors, 1, "the NaN state must be an error");
    assert!(walker.at_goal() && advanced > 20, "the loop must really walk: {advanced} steps");
}
