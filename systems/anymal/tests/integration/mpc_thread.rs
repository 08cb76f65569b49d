//! The MPC in its own thread against the same MPC inline: given the same states, the
//! thread publishes bit for bit the plans the inline MPC computes; a state posted while
//! it is busy replaces the older ones, and the newest is never lost; a bad state is
//! refused before it reaches the thread, which goes on working.

use std::time::{Duration, Instant};

use cbfgen_anymal::gait::standing_on_the_ground;
use cbfgen_anymal::mpc::{self, state_from_whole_body, KinodynamicMpc, MpcSettings, Plan};
use cbfgen_anymal::mpc_thread::MpcThread;
use cbfgen_anymal::stones::{SteppingStones, StoneField};
use cbfgen_anymal::terrain::Footholds;
use cbfgen_anymal::walk::{Controller, LayeredController, WalkSettings};

/// Wait (at most a minute: a bound for a stuck thread, not a speed requirement) until
/// `done` holds.
fn eventually(mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < Duration::from_secs(60), "the MPC thread did not get there in a minute");
        std::thread::sleep(Duration::from_millis(1));
    }
}

fn setup() -> (SteppingStones, Footholds, MpcSettings) {
    let stones = SteppingStones::new(&StoneField { strides: 2, seed: 4, ..StoneField::default() }).unwrap();
    let footholds = Footholds::new(stones.terrain().clone(), 0.02).unwrap();
    (stones, footholds, MpcSettings::default())
}

#[test]
fn the_thread_publishes_the_plans_the_inline_mpc_computes() {
    let (stones, footholds, settings) = setup();
    let trot = *stones.trot();
    let mut inline = KinodynamicMpc::new(settings).unwrap();
    let mut thread = MpcThread::spawn(KinodynamicMpc::new(settings).unwrap(), trot, footholds.clone()).unwrap();
    let mut plan = Plan::new(settings.horizon, settings.dt);
    let region = |foot: usize, time: f64| footholds.region(&trot, foot, time);
    let mut x = mpc::standing();
    for k in 0..6 {
        let t = 0.3 + 0.04 * k as f64;
        let report = inline.solve(t, &x, &trot, &region).unwrap();
        assert!(report.updated);
        thread.post(t, &x);
        eventually(|| thread.published() == k + 1);
        let taken = thread.take(&mut plan).expect("a new plan");
        assert_eq!(taken, report);
        assert_eq!(plan.parts(), inline.latest().parts(), "iteration {k}");
        assert_eq!(thread.take(&mut plan), None, "the same plan taken twice");
        // On along the plan (the MPC's own model): the next iteration's state.
        let (_, u) = inline.plan_at(t).unwrap();
        x = mpc::integrate(&x, &u, 0.04);
    }
}

#[test]
fn the_newest_state_posted_is_the_one_solved_last() {
    let (stones, footholds, settings) = setup();
    let mut thread = MpcThread::spawn(KinodynamicMpc::new(settings).unwrap(), *stones.trot(), footholds).unwrap();
    let mut plan = Plan::new(settings.horizon, settings.dt);
    let x = mpc::standing();
    // Posted faster than any solve: the thread skips to the newest it finds.
    for k in 0..20 {
        thread.post(0.01 * k as f64, &x);
    }
    eventually(|| {
        thread.take(&mut plan);
        plan.is_valid() && plan.start() == 0.19
    });
    assert!(thread.published() <= 20);
    let (solves, failed) = thread.solves();
    assert!(solves >= thread.published() && solves <= 20 && failed == solves - thread.published());
    assert_eq!(thread.last_error(), None);
}

#[test]
fn a_bad_state_is_refused_before_the_thread_and_the_next_cycles_are_planned() {
    let (stones, _, _) = setup();
    let settings = WalkSettings { threaded: true, ..WalkSettings::default() };
    let mut layers =
        LayeredController::new(*stones.trot(), stones.terrain().clone(), Controller::CbfInBoth, &settings).unwrap();
    let x = standing_on_the_ground();
    let mut bad = x;
    bad[30] = f64::NAN;
    assert!(layers.update(0.0, &bad).is_err());
    assert!(layers.update(f64::INFINITY, &x).is_err());
    // The thread solves the good state; a cycle then tracks its plan.
    let mut t = 0.0;
    eventually(|| {
        t += 2.5e-3;
        layers.update(t, &x).unwrap().planned
    });
    let plan_state = layers.plan().at(t).unwrap().0;
    let measured = state_from_whole_body(&x);
    assert!((plan_state[5] - measured[5]).abs() < 0.05, "the plan starts where the robot stands");
}
