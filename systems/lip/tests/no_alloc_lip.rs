//! The LIP-MPC control path allocates nothing: a whole walk to the goal, one MPC step
//! (half-planes, preprocessing, value update, dense solve, state advance) after another,
//! with a NaN state injected before every step; and beside it, a table of side paths,
//! each on its own MPC and fed from the walk: OSQP alone, stopped at its iteration or time
//! limit; the dense solve alone, stopped at its step budget; the dense solve out of steps
//! with OSQP answering instead; and every input `LipMpc::solve` rejects. Counted on Rust's global allocator
//! and on the C `malloc` family OSQP calls; each path must really have been taken, every
//! time it ran.
//!
//! The counters are process-wide, so this binary has no test harness (`harness = false`
//! in Cargo.toml): libtest's own thread allocates while a test runs, and once made this
//! count flaky under load. `main` runs the one check on the only thread.

#[path = "../../../testkit/alloc_count.rs"]
mod alloc_count;
use cbfgen_testkit::tally;

use std::time::Duration;

use cbfgen::filter::{Backend, QpStatus, Solver, SolverSettings};
use cbfgen::CbfError;
use cbfgen_lip::scenario::{Scenario, Walker};
use cbfgen_lip::{HalfPlane, LipMpc, LipState};

/// Half-planes a fed-in problem can hold: more than the standard course's obstacles, so
/// one more than the MPC was built for fits.
const MAX_PLANES: usize = 8;

fn main() {
    every_mpc_step_path_allocates_nothing();
    println!("every_mpc_step_path_allocates_nothing ... ok");
}

/// What one `LipMpc::solve` did.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Outcome {
    /// `Ok` with this status, from this solver.
    Status(QpStatus, Backend),
    /// `Err` naming what was wrong, with the MPC's status and plan left as they were.
    Rejected(&'static str),
    /// A documented property failed (named); never expected.
    Broken(&'static str),
}

/// One MPC problem, as the walker posed it in its last step's frame.
#[derive(Debug, Clone, Copy)]
struct Problem<'a> {
    x0: LipState,
    goal: [f64; 2],
    stance: f64,
    planes: &'a [HalfPlane],
}

/// What a side path makes of the walker's last problem.
#[derive(Debug, Clone, Copy)]
enum Feed {
    /// The problem as posed. The walk moves the frame every step, so a warm start is
    /// never already the answer and a solve cut short cannot have converged.
    Walk,
    /// The problem as posed with the goal 10 m further out on the same bearing, so that
    /// many rows bind (near the goal a problem can need a single active-set change).
    FarGoal,
    NanState,
    NanGoal,
    NanPlane,
    /// A stance sign other than ±1.
    StanceZero,
    /// One half-plane more than the MPC was built for.
    ExtraPlane,
}

impl Feed {
    /// The problem to solve, with `scratch` holding its half-planes.
    fn apply<'a>(self, walked: &Problem<'_>, scratch: &'a mut [HalfPlane; MAX_PLANES]) -> Problem<'a> {
        let n = walked.planes.len();
        scratch[..n].copy_from_slice(walked.planes);
        let mut problem = Problem { x0: walked.x0, goal: walked.goal, stance: walked.stance, planes: &[] };
        let mut planes = n;
        match self {
            Feed::Walk => {}
            Feed::FarGoal => {
                let [dx, dy] = [problem.goal[0] - problem.x0[0], problem.goal[1] - problem.x0[2]];
                let stretch = 10.0 / dx.hypot(dy).max(1e-9);
                problem.goal = [problem.goal[0] + stretch * dx, problem.goal[1] + stretch * dy];
            }
            Feed::NanState => problem.x0[1] = f64::NAN,
            Feed::NanGoal => problem.goal[0] = f64::NAN,
            Feed::NanPlane => scratch[0].delta = f64::NAN,
            Feed::StanceZero => problem.stance = 0.0,
            Feed::ExtraPlane => {
                scratch[n] = scratch[0];
                planes += 1;
            }
        }
        problem.planes = &scratch[..planes];
        problem
    }
}

/// One side path: its own MPC, what it is fed, and what every run must do.
struct SidePath {
    mpc: LipMpc,
    feed: Feed,
    tally: tally::Tally<Outcome>,
}

impl SidePath {
    fn run(&mut self, walked: &Problem<'_>, scratch: &mut [HalfPlane; MAX_PLANES]) {
        let problem = self.feed.apply(walked, scratch);
        let outcome = observe(&mut self.mpc, &problem);
        self.tally.record(outcome);
    }
}

/// One solve, with what `LipMpc::solve` documents checked on the spot (without
/// allocating, since this runs inside the count): only a solved QP replaces the plan.
fn observe(mpc: &mut LipMpc, p: &Problem<'_>) -> Outcome {
    let (status_before, first_input_before) = (mpc.status(), mpc.plan().inputs()[0]);
    let result = mpc.solve(&p.x0, p.goal, p.stance, p.planes);
    let plan_kept = mpc.plan().inputs()[0] == first_input_before;
    match result {
        Ok(status) if !status.is_solved() && !plan_kept => Outcome::Broken("an unsolved QP replaced the plan"),
        Ok(status) => Outcome::Status(status, mpc.answered_by()),
        Err(_) if !plan_kept || mpc.status() != status_before => Outcome::Broken("an Err changed the MPC"),
        Err(e) => Outcome::Rejected(error_subject(&e)),
    }
}

/// What a rejected solve complained about.
fn error_subject(e: &CbfError) -> &'static str {
    match e {
        CbfError::NonFinite { what, .. }
        | CbfError::OutOfRange { what, .. }
        | CbfError::CapacityExceeded { what, .. } => what,
        _ => "another error",
    }
}

fn every_mpc_step_path_allocates_nothing() {
    let scenario = Scenario::standard();
    let obstacles = scenario.obstacles.len();
    assert!(obstacles < MAX_PLANES, "the scratch must hold one half-plane more than the course has");
    let mut walker = Walker::new(scenario.clone()).expect("walker");
    alloc_count::assert_counters_work(|| LipMpc::new(Default::default(), 2, LipMpc::default_solver_settings()));

    let default = scenario.solver;
    assert_eq!(default.backend, Solver::DenseThenOsqp, "the walk takes the default path");
    let osqp = SolverSettings { backend: Solver::Osqp, ..default };
    let one_iteration = SolverSettings { max_iter: 1, ..osqp };
    // No solve finishes within 1 ns, so OSQP stops after its first iteration whatever the
    // load: the outcome does not depend on timing.
    let one_nanosecond = SolverSettings { time_limit: Some(Duration::from_nanos(1)), ..osqp };
    // A far goal needs more than one active-set change (from a cold start: these MPCs
    // never solve, so they have no active set to start from).
    let one_dense_step = SolverSettings { backend: Solver::Dense, dense_max_steps: 1, ..default };
    // OSQP at loose tolerances behind it, so that it meets them on every far-goal problem
    // (at the default 1e-6 one in forty stops only "inaccurate").
    let fallback = SolverSettings { dense_max_steps: 1, eps_abs: 1e-3, eps_rel: 1e-3, ..default };
    use {Outcome::*, QpStatus::*};
    // One row per side path: name, solver settings, feed, what every run must do.
    #[rustfmt::skip]
    let table = [
        ("OSQP iteration limit", one_iteration, Feed::Walk, Status(MaxIterations, Backend::Osqp)),
        ("OSQP time limit", one_nanosecond, Feed::Walk, Status(TimeLimit, Backend::Osqp)),
        ("dense step limit", one_dense_step, Feed::FarGoal, Status(MaxIterations, Backend::Dense)),
        ("dense out of steps, OSQP", fallback, Feed::FarGoal, Status(Solved, Backend::Osqp)),
        ("NaN state", default, Feed::NanState, Rejected("LIP state")),
        ("NaN goal", default, Feed::NanGoal, Rejected("goal x")),
        ("NaN half-plane", default, Feed::NanPlane, Rejected("obstacle half-plane")),
        ("stance sign 0", default, Feed::StanceZero, Rejected("stance sign")),
        ("one half-plane too many", default, Feed::ExtraPlane, Rejected("obstacles")),
    ];
    // Construction allocates by design, so every MPC is built here. Each solves the
    // course's first problem (start frame, obstacles left out) once, so the plan a
    // rejected call must keep is a real one; the limit paths cannot solve it and keep the
    // empty plan, which no iterate may replace (the fallback path solves it on OSQP).
    let mut side_paths = table.map(|(name, solver, feed, expect)| {
        let mut mpc = LipMpc::new(scenario.params, obstacles, solver).expect(name);
        let status = mpc.solve(&scenario.start, scenario.goal, scenario.first_stance, &[]).expect(name);
        assert!(status.is_solved() || solver != default, "{name}: the first problem must solve, got {status:?}");
        SidePath { mpc, feed, tally: tally::Tally::new(name, expect) }
    });
    let mut scratch = [HalfPlane { normal: [1.0, 0.0], point: [0.0; 2], delta: 0.0, inside: false }; MAX_PLANES];

    let mut broken = *walker.state();
    broken[1] = f64::NAN;
    let ((steps, advanced, injected, errors, dense), rust, c) = alloc_count::counting(|| {
        let (mut steps, mut advanced, mut injected, mut errors, mut dense) = (0, 0, 0, 0, 0);
        let mut stance = scenario.first_stance;
        while steps < scenario.max_steps && !walker.at_goal() {
            // A bad state first: the walker's error path must not allocate either.
            let good = *walker.state();
            walker.set_state(broken);
            injected += 1;
            errors += usize::from(walker.step().is_err());
            walker.set_state(good);

            let Ok(outcome) = walker.step() else { break };
            steps += 1;
            dense += usize::from(outcome.answered_by == Backend::Dense);
            let walked = Problem {
                x0: *walker.local_start(),
                goal: walker.frame().point_to_local(scenario.goal),
                stance,
                planes: walker.planes(),
            };
            side_paths.iter_mut().for_each(|path| path.run(&walked, &mut scratch));
            if outcome.advanced {
                advanced += 1;
                stance = -stance;
            }
        }
        (steps, advanced, injected, errors, dense)
    });

    println!(
        "  {:<24} {steps:>3} steps, {advanced} advanced, {dense} by the dense solve, {errors} of {injected} NaN \
         states rejected",
        "walk"
    );
    for path in &side_paths {
        path.tally.print(24);
    }
    assert_eq!((rust, c), (0, 0), "allocations during {steps} MPC steps and their side paths: Rust {rust}, C {c}");
    assert!(injected > 0 && errors == injected, "every NaN state must be an error: {errors} of {injected}");
    assert!(
        walker.at_goal() && advanced == steps && steps > 20,
        "the loop must really walk: {advanced} of {steps} steps"
    );
    assert_eq!(dense, steps, "the walk must take the dense path every step");
    for path in &side_paths {
        path.tally.assert_every_run_taken(steps);
    }
}
