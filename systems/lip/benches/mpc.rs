//! The MPCs' QPs on the dense dual active-set solve against OSQP, on the same problems:
//! the LIP MPC replaying the standard course's steps, and the multi-layer kinematic MPC
//! replaying the re-plans of its example run (discrete-CBF mode). Each benchmark solves
//! the recorded problems in order, one per iteration, so warm starts carry from one to
//! the next as in the loop (the wrap from the last to the first costs one far jump per
//! pass). Before the benchmarks, the LIP course is walked with each backend and its
//! recorded per-step solve times (wall) are summarised.

use std::hint::black_box;
use std::time::{Duration, Instant};

use cbfgen::filter::{Backend, QpStatus, Solver, SolverSettings};
use cbfgen_lip::scenario::{run, Scenario, Walker};
use cbfgen_lip::{HalfPlane, LipMpc, LipState};
use cbfgen_multilayer::{KinematicMpc, MpcSettings, ScenarioConfig, State};
use criterion::{criterion_group, Criterion};

/// One LIP MPC problem as the walker posed it.
struct LipProblem {
    x0: LipState,
    goal: [f64; 2],
    stance: f64,
    planes: Vec<HalfPlane>,
}

fn lip_settings(backend: Solver) -> SolverSettings {
    SolverSettings { backend, ..LipMpc::default_solver_settings() }
}

/// The standard course's MPC problems, step by step.
fn lip_problems() -> Vec<LipProblem> {
    let scenario = Scenario::standard();
    let mut walker = Walker::new(scenario.clone()).expect("walker");
    let (mut problems, mut stance) = (Vec::new(), scenario.first_stance);
    while !walker.at_goal() && problems.len() < scenario.max_steps {
        let outcome = walker.step().expect("step");
        assert!(outcome.advanced, "the course must be walkable");
        problems.push(LipProblem {
            x0: *walker.local_start(),
            goal: walker.frame().point_to_local(scenario.goal),
            stance,
            planes: walker.planes().to_vec(),
        });
        stance = -stance;
    }
    problems
}

fn lip(c: &mut Criterion) {
    let problems = lip_problems();
    let obstacles = Scenario::standard().obstacles.len();
    let mut g = c.benchmark_group("lip_mpc");
    for (name, backend) in [("step_dense", Solver::DenseThenOsqp), ("step_osqp", Solver::Osqp)] {
        let mut mpc = LipMpc::new(Default::default(), obstacles, lip_settings(backend)).expect("mpc");
        let mut next = 0;
        g.bench_function(name, |b| {
            b.iter(|| {
                let p = &problems[next % problems.len()];
                next += 1;
                let status = mpc.solve(black_box(&p.x0), p.goal, p.stance, &p.planes).expect("valid");
                assert!(status.is_solved());
                status
            })
        });
    }
    g.finish();
}

/// The multi-layer example's MPC re-plans (time and state), discrete-CBF mode.
fn multilayer_problems(config: &ScenarioConfig) -> Vec<(f64, State)> {
    let mode = config.modes()[0];
    let result = cbfgen_multilayer::scenario::run(config, mode).expect("run");
    let every = (config.mpc.dt / config.cycle_dt).round() as usize;
    let t = &result.trace;
    (0..t.t.len()).step_by(every).map(|k| (t.t[k], [t.q[k], t.v[k]])).collect()
}

fn multilayer_settings(backend: Solver) -> MpcSettings {
    let base = MpcSettings::default();
    MpcSettings { solver: SolverSettings { backend, ..base.solver }, ..base }
}

fn multilayer(c: &mut Criterion) {
    let config = ScenarioConfig::default();
    let problems = multilayer_problems(&config);
    let mode = config.modes()[0];
    let mut g = c.benchmark_group("multilayer_mpc");
    for (name, backend) in [("solve_dense", Solver::DenseThenOsqp), ("solve_osqp", Solver::Osqp)] {
        let mut mpc = KinematicMpc::new(multilayer_settings(backend), mode, config.barrier).expect("mpc");
        let mut next = 0;
        g.bench_function(name, |b| {
            b.iter(|| {
                let (t, x) = problems[next % problems.len()];
                next += 1;
                mpc.solve(black_box(t), &x).expect("solved").desired_accel
            })
        });
    }
    g.finish();
}

fn micros(d: Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

/// Median and largest of `times`, in µs.
fn median_max(times: &mut [Duration]) -> (f64, f64) {
    times.sort();
    (micros(times[times.len() / 2]), micros(times[times.len() - 1]))
}

/// The LIP course walked 20 times (once when checked) per backend: the scenario's own per-step solve
/// times (wall; preprocessing, value update and solve), pooled; and the multi-layer
/// example's re-plans timed the same way.
fn scenario_times() {
    // One walk each when `cargo test --benches` checks that the bench runs.
    let runs = cbfgen_testkit::bench_run::repetitions(20);
    println!("LIP standard course, {runs} walks per backend, MPC solve time per step (wall):");
    let mut lip_medians = Vec::new();
    for backend in [Solver::DenseThenOsqp, Solver::Osqp] {
        let scenario = Scenario { solver: lip_settings(backend), ..Scenario::standard() };
        let (mut times, mut inaccurate, mut by_osqp, mut steps) = (Vec::new(), 0, 0, 0);
        for _ in 0..runs {
            let result = run(&scenario).expect("run");
            assert!(result.reached_goal);
            for s in &result.steps {
                times.push(s.outcome.solve_time);
                inaccurate += usize::from(s.outcome.status == QpStatus::SolvedInaccurate);
                by_osqp += usize::from(s.outcome.answered_by == Backend::Osqp);
                steps += 1;
            }
        }
        let (median, max) = median_max(&mut times);
        lip_medians.push((median, max));
        println!(
            "  {:<16} median {median:8.1} µs, max {max:8.1} µs over {steps} steps; {by_osqp} answered by OSQP, \
             {inaccurate} inaccurate",
            backend.name()
        );
    }
    let [(dm, dx), (om, ox)] = [lip_medians[0], lip_medians[1]];
    println!("  OSQP / dense: median {:.0}x, max {:.0}x", om / dm, ox / dx);

    let config = ScenarioConfig::default();
    let problems = multilayer_problems(&config);
    println!("Multi-layer example, {} MPC re-plans x {runs} (discrete-CBF mode), solve time (wall):", problems.len());
    let mut medians = Vec::new();
    for backend in [Solver::DenseThenOsqp, Solver::Osqp] {
        let mut times = Vec::new();
        let mut by_osqp = 0;
        for _ in 0..runs {
            let mut mpc =
                KinematicMpc::new(multilayer_settings(backend), config.modes()[0], config.barrier).expect("mpc");
            for &(t, x) in &problems {
                let started = Instant::now();
                let out = mpc.solve(t, &x).expect("solved");
                times.push(started.elapsed());
                by_osqp += usize::from(out.answered_by == Backend::Osqp);
            }
        }
        let (median, max) = median_max(&mut times);
        medians.push((median, max));
        println!("  {:<16} median {median:8.1} µs, max {max:8.1} µs; {by_osqp} answered by OSQP", backend.name());
    }
    let [(dm, dx), (om, ox)] = [medians[0], medians[1]];
    println!("  OSQP / dense: median {:.1}x, max {:.1}x", om / dm, ox / dx);
}

criterion_group!(benches, lip, multilayer);

fn main() {
    scenario_times();
    benches();
    Criterion::default().configure_from_args().final_summary();
}
