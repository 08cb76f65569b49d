//! The control path allocates nothing, on every way through `EcbfFilter::update`:
//! thousands of updates along the drive into the stairs (the QP path), and beside them,
//! a table of side paths, each on its own filter: OSQP stopped at its iteration or time
//! limit, a non-finite row before and after a solve (the fallbacks), and the three
//! rejected inputs. Counted two ways — Rust's global allocator, and the C `malloc`
//! family that OSQP (compiled C, linked into this binary) calls — and each path must
//! really have been taken, every time it ran.
//!
//! The counters are process-wide, so this binary has no test harness (`harness = false`
//! in Cargo.toml): libtest's own thread allocates while a test runs, and once made this
//! count flaky under load. `main` runs the one check on the only thread.

#[path = "../../../testkit/alloc_count.rs"]
mod alloc_count;
#[path = "common/singular.rs"]
mod singular;
use cbfgen_tachyon3::catalog::Tachyon3FilterExt;
use cbfgen_testkit::tally;

use std::time::Duration;

use cbfgen::filter::{Backend, EcbfFilter, FilterSettings, InputSource, QpStatus, Solver, SolverSettings};
use cbfgen::CbfError;
use cbfgen_tachyon3::approach::Approach;
use cbfgen_tachyon3::catalog::{self, Capacity, Environment, Family, Tachyon3Filter};
use cbfgen_tachyon3::model::{Input, State, BODY_X, BODY_Z, INPUT_LIMITS};
use cbfgen_tachyon3::terrain::Stairs;

/// Drive cycles (1 ms each).
const CYCLES: usize = 3000;
/// Every side path runs once per this many drive cycles.
const SIDE_PATH_EVERY: usize = 10;

fn main() {
    every_filter_update_path_allocates_nothing();
    println!("every_filter_update_path_allocates_nothing ... ok");
}

/// What one `update` did, in the terms the table's expectations are written in.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Outcome {
    /// `Ok`: where the input came from, OSQP's report, and the first non-finite active row.
    Output { source: InputSource, status: Option<QpStatus>, nonfinite_row: Option<usize> },
    /// `Err` naming what was wrong, with the filter's last output left as it was and a
    /// finite `fallback_input` for the caller.
    Rejected(&'static str),
    /// A documented property failed (named); never expected.
    Broken(&'static str),
}

/// What a side path feeds `update`, derived from the drive's current cycle.
#[derive(Debug, Clone, Copy)]
enum Feed {
    /// The drive's own state and nominal command.
    Drive,
    /// The drive's state with a full command whose sign flips every run: the warm start
    /// is then always far from the answer, so a solve cut short cannot have converged.
    FlippingFullCommand,
    /// A state with the front-left toe exactly on its hip joint (`singular::toe_at_hip(0)`).
    ToeOnHip,
    NanState,
    NanCommand,
    /// A finite state entry beyond `model::STATE_LIMIT`.
    HugeState,
    /// A finite nominal input of `f64::MAX` (once NaN labelled as solved).
    HugeCommand,
    /// The drive's state and command with an environment sized for another capacity.
    ForeignEnvironment,
}

/// A side path's filter before the count: as built, or after one solved update (so it
/// has a last safe input to fall back to, and an output an error must not change).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Start {
    Fresh,
    AfterASolve,
}

/// Everything the feeds draw on.
struct Scene {
    drive: Approach,
    toe_on_hip: State,
    foreign_env: Environment,
}

impl Feed {
    /// `(x, u_ref, env)` for this path's `run`-th call.
    fn inputs(self, scene: &Scene, run: usize) -> (State, Input, &Environment) {
        let (mut x, mut u_ref, mut env) = (scene.drive.x, scene.drive.nominal_input(), &scene.drive.env);
        match self {
            Feed::Drive => {}
            Feed::FlippingFullCommand => {
                let sign = if run.is_multiple_of(2) { 1.0 } else { -1.0 };
                u_ref = INPUT_LIMITS.map(|l| sign * l);
            }
            Feed::ToeOnHip => x = scene.toe_on_hip,
            Feed::NanState => x[BODY_Z] = f64::NAN,
            Feed::NanCommand => u_ref[0] = f64::NAN,
            Feed::HugeState => x[BODY_X] = 1e300,
            Feed::HugeCommand => u_ref[3] = f64::MAX,
            Feed::ForeignEnvironment => env = &scene.foreign_env,
        }
        (x, u_ref, env)
    }
}

/// One side path: its own filter, what it is fed, and what every run must do.
struct SidePath {
    filter: Tachyon3Filter,
    feed: Feed,
    tally: tally::Tally<Outcome>,
}

impl SidePath {
    fn run(&mut self, scene: &Scene) {
        let (x, u_ref, env) = self.feed.inputs(scene, self.tally.runs);
        let outcome = observe(&mut self.filter, &x, &u_ref, env);
        self.tally.record(outcome);
    }
}

/// One update, with the properties its path documents checked on the spot (all without
/// allocating, since this runs inside the count).
fn observe(filter: &mut Tachyon3Filter, x: &State, u_ref: &Input, env: &Environment) -> Outcome {
    let before = *filter.output();
    // Copied out, so the filter can be inspected in every arm.
    match filter.update(x, u_ref, env).copied() {
        Ok(out) => {
            let fell_back = matches!(out.source, InputSource::LastSafe | InputSource::NominalClipped);
            if fell_back && out.u != filter.fallback_input(u_ref) {
                return Outcome::Broken("a fallback output differs from fallback_input()");
            }
            Outcome::Output { source: out.source, status: out.status, nonfinite_row: out.nonfinite_row }
        }
        Err(_) if *filter.output() != before => Outcome::Broken("an Err changed the filter's output"),
        Err(_) if !filter.fallback_input(u_ref).iter().all(|u| u.is_finite()) => {
            Outcome::Broken("fallback_input() after an Err is not finite")
        }
        Err(e) => Outcome::Rejected(error_subject(&e)),
    }
}

/// What a rejected update complained about.
fn error_subject(e: &CbfError) -> &'static str {
    match e {
        CbfError::NonFinite { what, .. } | CbfError::OutOfRange { what, .. } => what,
        CbfError::CapacityMismatch => "environment capacity",
        _ => "another error",
    }
}

fn every_filter_update_path_allocates_nothing() {
    let capacity = Capacity::PAPER_WORST_CASE;
    let mut filter = EcbfFilter::with_capacity(capacity, catalog::default_settings()).expect("filter");
    let mut scene = Scene {
        drive: Approach::new(capacity, Stairs::HARDWARE, 0.3, 0.4).expect("drive"),
        toe_on_hip: singular::toe_at_hip(0),
        foreign_env: Environment::new(Capacity::edges(1, [1; 6])).expect("environment"),
    };
    let knee_min_front_left = filter
        .slots()
        .position(|s| s.family == Family::JointLimits && s.leg == Some(0) && s.instance == 0)
        .expect("a knee-minimum row for leg 0");

    alloc_count::assert_counters_work(|| {
        EcbfFilter::with_capacity(Capacity::edges(1, [1; 6]), catalog::default_settings())
    });

    let osqp = SolverSettings { backend: Solver::Osqp, ..SolverSettings::default() };
    let one_iteration = SolverSettings { max_iter: 1, polish: false, ..osqp };
    // No solve finishes within 1 ns, so OSQP stops after its first iteration whatever the
    // load: the outcome does not depend on timing.
    let one_nanosecond = SolverSettings { time_limit: Some(Duration::from_nanos(1)), polish: false, ..osqp };
    // One row per stage does not verify a full command whose sign flips every run, so
    // OSQP runs (and stops after one iteration: tolerances that tight are never met by
    // one), or, dense only, the point reached comes back.
    let dense_spent = SolverSettings {
        backend: Solver::DenseThenOsqp,
        dense_max_steps: 1,
        eps_abs: SolverSettings::MIN_TOLERANCE,
        eps_rel: SolverSettings::MIN_TOLERANCE,
        ..one_iteration
    };
    let dense_only_spent = SolverSettings { backend: Solver::Dense, dense_max_steps: 1, ..SolverSettings::default() };
    let default = SolverSettings::default();
    let ok = |source, status, nonfinite_row| Outcome::Output { source, status, nonfinite_row };
    let nonfinite = Some(knee_min_front_left);
    use {InputSource::*, QpStatus::*, Start::*};
    // One row per side path: name, solver settings, the filter's history, feed, what every run must do.
    #[rustfmt::skip]
    let table = [
        ("OSQP backend, polished", osqp, Fresh, Feed::Drive,
            ok(Qp, Some(Solved), None)),
        ("dense budget spent, OSQP runs", dense_spent, Fresh, Feed::FlippingFullCommand,
            ok(Unconverged, Some(MaxIterations), None)),
        ("dense only, budget spent", dense_only_spent, Fresh, Feed::FlippingFullCommand,
            ok(Unconverged, Some(MaxIterations), None)),
        ("OSQP iteration limit", one_iteration, Fresh, Feed::FlippingFullCommand,
            ok(Unconverged, Some(MaxIterations), None)),
        ("OSQP time limit", one_nanosecond, Fresh, Feed::FlippingFullCommand,
            ok(Unconverged, Some(TimeLimit), None)),
        ("non-finite row, nothing solved yet", default, Fresh, Feed::ToeOnHip,
            ok(NominalClipped, None, nonfinite)),
        ("non-finite row after a solve", default, AfterASolve, Feed::ToeOnHip,
            ok(LastSafe, None, nonfinite)),
        ("NaN state", default, AfterASolve, Feed::NanState,
            Outcome::Rejected("state entry")),
        ("NaN nominal input", default, AfterASolve, Feed::NanCommand,
            Outcome::Rejected("nominal input")),
        ("state beyond its domain", default, AfterASolve, Feed::HugeState,
            Outcome::Rejected("state entry")),
        ("nominal input beyond its domain", default, Fresh, Feed::HugeCommand,
            Outcome::Rejected("nominal input")),
        ("environment of another capacity", default, AfterASolve, Feed::ForeignEnvironment,
            Outcome::Rejected("environment capacity")),
    ];
    // Construction allocates by design, so every filter is built (and primed) here.
    let mut side_paths = table.map(|(name, solver, start, feed, expect)| {
        let mut filter =
            EcbfFilter::with_capacity(capacity, FilterSettings { solver, ..catalog::default_settings() }).expect(name);
        if start == AfterASolve {
            let out = filter.update(&scene.drive.x, &scene.drive.nominal_input(), &scene.drive.env).expect(name);
            assert_eq!(out.source, InputSource::Qp, "{name}: the priming update must solve the QP");
        }
        // A solve cut short continues from where it stopped at the next run, so the
        // budget-spent paths may finish now and then: most of their runs must still spend it.
        let tally = if solver.dense_max_steps == 1 {
            tally::Tally::allowing(name, expect, ok(Qp, Some(Solved), None), 0.8)
        } else {
            tally::Tally::new(name, expect)
        };
        SidePath { filter, feed, tally }
    });

    // The sampled-data certificate: every row's kernel on intervals, the flow enclosed,
    // the QP solved again with margins, all on the stack.
    let sampled = FilterSettings {
        sampled_data: Some(cbfgen::filter::SampledData::every_family(1e-3)),
        ..catalog::default_settings()
    };
    let mut certified = EcbfFilter::with_capacity(capacity, sampled).expect("certified filter");
    let mut certificates = 0;

    let (mut sources, mut dense) = ([0usize; InputSource::ALL.len()], 0);
    let ((), rust, c) = alloc_count::counting(|| {
        for cycle in 0..CYCLES {
            if cycle % SIDE_PATH_EVERY == SIDE_PATH_EVERY / 2 {
                side_paths.iter_mut().for_each(|path| path.run(&scene));
                let drive = &scene.drive;
                if let Ok(out) = certified.update(&drive.x, &drive.nominal_input(), &drive.env) {
                    certificates += usize::from(out.between_samples != cbfgen::filter::BetweenSamples::Off);
                }
            }
            let drive = &mut scene.drive;
            let out = match filter.update(&drive.x, &drive.nominal_input(), &drive.env) {
                Ok(out) => *out,
                Err(_) => break,
            };
            sources[out.source as usize] += 1;
            dense += usize::from(out.backend == Some(Backend::Dense));
            drive.advance(&out.u, 1e-3);
        }
    });

    println!(
        "  {:<36} {:>4} updates: {sources:?} by source {:?}, {dense} by the dense solve",
        "drive",
        CYCLES,
        InputSource::ALL
    );
    for path in &side_paths {
        path.tally.print(36);
    }
    assert_eq!((rust, c), (0, 0), "allocations during {CYCLES} drive cycles and their side paths: Rust {rust}, C {c}");
    assert_eq!(certificates, CYCLES / SIDE_PATH_EVERY, "every certified update assessed between the samples");
    assert_eq!(sources.iter().sum::<usize>(), CYCLES, "a drive update failed");
    assert!(
        sources[InputSource::Qp as usize] > CYCLES - 100 && dense > CYCLES - 100,
        "the drive must really solve: sources {sources:?}, {dense} by the dense solve"
    );
    assert!(scene.drive.x[0] > 0.1, "the robot must have moved");
    for path in &side_paths {
        path.tally.assert_every_run_taken(CYCLES / SIDE_PATH_EVERY);
    }
}
