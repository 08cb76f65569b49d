//! The multi-layer control path allocates nothing: MPC re-plans and CBF-QP solves over
//! thousands of cycles, for all three MPC modes, with a NaN state injected now and then;
//! and beside them, a table of side paths, each on its own solver and fed from the first
//! system's cycle: either layer stopped at its iteration limit, the MPC's dense solve
//! stopped at its step budget or handing over to OSQP, and the inputs and rows each
//! rejects (the CBF-QP's `QpFailed` reports included). Counted for Rust's global
//! allocator and for the C `malloc` family OSQP calls; each path must really have been
//! taken, every time it ran.
//!
//! The counters are process-wide, so this binary has no test harness (`harness = false`
//! in Cargo.toml): libtest's own thread allocates while a test runs, and once made this
//! count flaky under load. `main` runs the one check on the only thread.

#[path = "../../../testkit/alloc_count.rs"]
mod alloc_count;
use cbfgen_testkit::tally;

use cbfgen::filter::{Backend, QpStatus, Solver, SolverSettings};
use cbfgen::CbfError;
use cbfgen_multilayer::{
    CbfQpSettings, IdCbfQp, KinematicMpc, MpcOutput, MpcSettings, MultiLayerController, ScenarioConfig, SineBarrier,
    State,
};

/// Control cycles (1 ms each) per system.
const CYCLES: usize = 4000;
/// Every side path runs once per this many cycles.
const SIDE_PATH_EVERY: usize = 10;

fn main() {
    every_multilayer_path_allocates_nothing();
    println!("every_multilayer_path_allocates_nothing ... ok");
}

/// What one call did.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Outcome {
    /// `Ok` with this status (`None`: the filter attempted no solve).
    Status(Option<QpStatus>),
    /// The MPC's `Ok`, with its status and the solver that answered.
    Mpc(QpStatus, Backend),
    /// `Err` naming what was wrong: the non-finite value, "row", or the `QpFailed` status.
    Rejected(&'static str),
}

fn outcome(result: Result<Option<QpStatus>, CbfError>) -> Outcome {
    match result {
        Ok(status) => Outcome::Status(status),
        Err(e) => rejected(e),
    }
}

fn mpc_outcome(result: Result<MpcOutput, CbfError>) -> Outcome {
    match result {
        Ok(out) => Outcome::Mpc(out.status, out.answered_by),
        Err(e) => rejected(e),
    }
}

fn rejected(e: CbfError) -> Outcome {
    match e {
        CbfError::NonFinite { what, .. } => Outcome::Rejected(what),
        CbfError::NonFiniteRow { .. } => Outcome::Rejected("row"),
        CbfError::QpFailed { status, .. } => Outcome::Rejected(status),
        _ => Outcome::Rejected("another error"),
    }
}

/// The first system's cycle, which every side path is fed from.
#[derive(Debug, Clone, Copy)]
struct Cycle {
    t: f64,
    x: State,
    /// How many times this side path ran before.
    run: usize,
}

/// A side path's call: runs its own solver on one cycle.
type Call = Box<dyn FnMut(&Cycle) -> Outcome>;

/// One side path: a closure owning its own solver (the layers are different types, so
/// the table holds calls rather than solvers), and what every run must do.
struct SidePath {
    call: Call,
    tally: tally::Tally<Outcome>,
}

impl SidePath {
    fn run(&mut self, t: f64, x: State) {
        let outcome = (self.call)(&Cycle { t, x, run: self.tally.runs });
        self.tally.record(outcome);
    }
}

/// A command far from the last one every run (±50 m/s², alternating): a warm start is
/// then never already the answer, so a solve cut short cannot have converged.
fn flipping_command(run: usize) -> f64 {
    if run.is_multiple_of(2) {
        50.0
    } else {
        -50.0
    }
}

fn every_multilayer_path_allocates_nothing() {
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

    // Construction allocates by design, so every solver and box is made here.
    let barrier = config.barrier;
    let mode = config.modes()[1];
    // OSQP only, unpolished: the dense solve would answer this QP exactly, before OSQP ran
    // or from its face.
    let one_iteration = SolverSettings { backend: Solver::Osqp, max_iter: 1, polish: false, ..config.qp.solver };
    let cbf_qp = |settings: CbfQpSettings| IdCbfQp::new(settings, barrier).expect("CBF-QP");
    let one_iteration_qp = CbfQpSettings { solver: one_iteration, ..config.qp };
    let mpc_solver = |solver: SolverSettings| MpcSettings { solver, ..config.mpc };
    // The dense paths' MPCs drive to 10 m below a boundary that stays between 1 and 3 m,
    // from a state on it: the plan rides the boundary, every barrier row binds at every
    // phase, and a cold dense solve takes many steps.
    let pulled_down = |solver: SolverSettings| MpcSettings { q_ref: -10.0, ..mpc_solver(solver) };
    let one_iteration_mpc = mpc_solver(SolverSettings { backend: Solver::Osqp, max_iter: 1, ..config.mpc.solver });
    let one_dense_step =
        pulled_down(SolverSettings { backend: Solver::Dense, dense_max_steps: 1, ..config.mpc.solver });
    // OSQP at loose tolerances behind a one-step dense budget, so that it meets them on
    // every run (the answer is OSQP's whatever it takes).
    let fallback_mpc =
        pulled_down(SolverSettings { dense_max_steps: 1, eps_abs: 1e-3, eps_rel: 1e-3, ..config.mpc.solver });
    let controller = || MultiLayerController::new(barrier, mode, config.mpc, config.qp, config.cycle_dt).unwrap();
    // A boundary the input bound cannot keep: h = −1 needs u ≥ k0 = 100 m/s², and |u| ≤ 1.
    let below = move |k: &Cycle| [barrier.boundary(k.t) - 1.0, 0.0];
    let high = SineBarrier::new(1.0, 2.0, 2.0).expect("finite");
    let on_high = move |k: &Cycle| [high.boundary(k.t), 0.0];
    use {Outcome::*, QpStatus::*};
    // One row per side path: name, what every run must do, the call.
    let table: [(&str, Outcome, Call); 10] = [
        ("CBF-QP iteration limit", Status(Some(MaxIterations)), {
            let mut qp = cbf_qp(one_iteration_qp);
            Box::new(move |k| outcome(qp.solve(k.t, &k.x, flipping_command(k.run)).map(|o| o.status)))
        }),
        ("CBF-QP NaN command", Rejected("nominal input"), {
            let mut qp = cbf_qp(config.qp);
            Box::new(move |k| outcome(qp.solve(k.t, &k.x, f64::NAN).map(|o| o.status)))
        }),
        ("CBF-QP NaN state", Rejected("state entry"), {
            let mut qp = cbf_qp(config.qp);
            Box::new(move |k| outcome(qp.solve(k.t, &[f64::NAN, k.x[1]], 0.0).map(|o| o.status)))
        }),
        ("CBF-QP row beyond input bound", Status(Some(Solved)), {
            let mut qp = cbf_qp(CbfQpSettings { u_max: 1.0, ..config.qp });
            Box::new(move |k| outcome(qp.solve(k.t, &below(k), flipping_command(k.run)).map(|o| o.status)))
        }),
        ("MPC OSQP iteration limit", Mpc(MaxIterations, Backend::Osqp), {
            let mut mpc = KinematicMpc::new(one_iteration_mpc, mode, barrier).expect("MPC");
            Box::new(move |k| mpc_outcome(mpc.solve(k.t, &k.x)))
        }),
        ("MPC dense step limit", Mpc(MaxIterations, Backend::Dense), {
            let mut mpc = KinematicMpc::new(one_dense_step, mode, high).expect("MPC");
            Box::new(move |k| mpc_outcome(mpc.solve(k.t, &on_high(k))))
        }),
        ("MPC dense out of steps, OSQP", Mpc(Solved, Backend::Osqp), {
            let mut mpc = KinematicMpc::new(fallback_mpc, mode, high).expect("MPC");
            Box::new(move |k| mpc_outcome(mpc.solve(k.t, &on_high(k))))
        }),
        ("MPC NaN velocity", Rejected("velocity"), {
            let mut mpc = KinematicMpc::new(config.mpc, mode, barrier).expect("MPC");
            Box::new(move |k| outcome(mpc.solve(k.t, &[k.x[0], f64::NAN]).map(|o| Some(o.status))))
        }),
        ("controller NaN time", Rejected("time"), {
            let mut c = controller();
            Box::new(move |k| outcome(c.control(f64::NAN, &k.x).map(|o| o.qp.status)))
        }),
        ("controller NaN velocity", Rejected("velocity"), {
            let mut c = controller();
            Box::new(move |k| outcome(c.control(k.t, &[k.x[0], f64::NAN]).map(|o| o.qp.status)))
        }),
    ];
    let mut side_paths = table.map(|(name, expect, call)| SidePath { call, tally: tally::Tally::new(name, expect) });

    let (mut ok, mut replans, mut injected, mut rejected) = (0usize, 0usize, 0usize, 0usize);
    let mut dense_replans = 0usize;
    let ((), rust, c) = alloc_count::counting(|| {
        for cycle in 0..CYCLES {
            let t = cycle as f64 * config.cycle_dt;
            if cycle % SIDE_PATH_EVERY == SIDE_PATH_EVERY / 2 {
                side_paths.iter_mut().for_each(|path| path.run(t, states[0]));
            }
            for (controller, x) in controllers.iter_mut().zip(states.iter_mut()) {
                // Every 500th cycle a bad state first: the error path must not allocate either.
                if cycle % 500 == 250 {
                    injected += 1;
                    rejected += usize::from(controller.control(t, &[f64::NAN, x[1]]).is_err());
                }
                let Ok(out) = controller.control(t, x) else { continue };
                ok += 1;
                replans += usize::from(out.mpc.is_some());
                dense_replans += usize::from(out.mpc.is_some_and(|m| m.answered_by == Backend::Dense));
                let dt = config.cycle_dt;
                *x = [x[0] + x[1] * dt + 0.5 * out.u * dt * dt, x[1] + out.u * dt];
            }
        }
    });

    let systems = controllers.len();
    println!(
        "  {:<32} {ok:>5} cycles solved, {replans} re-plans, {rejected} of {injected} NaN states rejected",
        "systems"
    );
    for path in &side_paths {
        path.tally.print(32);
    }
    assert_eq!(
        (rust, c),
        (0, 0),
        "allocations during {} cycles and their side paths: Rust {rust}, C {c}",
        systems * CYCLES
    );
    assert_eq!(ok, systems * CYCLES, "every cycle must solve");
    assert_eq!(replans, systems * 80, "the MPC re-plans every 50 cycles");
    assert_eq!(dense_replans, replans, "every re-plan takes the default, dense, path");
    assert!(injected > 0 && rejected == injected, "every NaN state must be rejected: {rejected} of {injected}");
    assert!(states.iter().all(|x| x[0] < 0.9), "the systems must have moved: {states:?}");
    for path in &side_paths {
        path.tally.assert_every_run_taken(CYCLES / SIDE_PATH_EVERY);
    }
}
