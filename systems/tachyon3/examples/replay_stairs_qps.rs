//! Percentiles of the QP solve on the stairs run's 500 committed QPs
//! (`systems/tachyon3/tests/data/stairs_qps.bin`), each backend in the same run, wall and thread CPU time:
//!
//! ```text
//! cargo run --release -p cbfgen-tachyon3 --example replay_stairs_qps [-- ROUNDS]
//! ```
//!
//! The problems are replayed in time order through a QP laid out as the filter's (warm
//! start from the previous problem), `ROUNDS` times (default 20); the first round is a
//! warm-up and not counted.
#[path = "../tests/common/replay.rs"]
mod replay;

use std::time::Duration;

use cbfgen::cpu_time::Stopwatch;
use cbfgen::filter::Solver;

fn percentiles(mut v: Vec<Duration>) -> [f64; 3] {
    v.sort_unstable();
    let pick = |p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1].as_secs_f64() * 1e6;
    [pick(0.5), pick(0.99), pick(1.0)]
}

fn main() {
    let rounds: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(20);
    let problems = replay::stairs_qps();
    println!("{} QPs of the stairs run, {} timed rounds; per solve [µs]", problems.len(), rounds);
    println!(
        "{:<34} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
        "backend", "median", "p99", "max", "cpu med", "cpu p99", "cpu max"
    );
    let mut medians = Vec::new();
    for backend in [Solver::Dense, Solver::DenseThenOsqp, Solver::Osqp] {
        let mut replay = replay::Replay::new(backend, &problems[0]);
        let (mut wall, mut cpu) = (Vec::new(), Vec::new());
        for round in 0..=rounds {
            for p in &problems {
                replay.load(p);
                let watch = Stopwatch::start();
                std::hint::black_box(replay.solve());
                let (w, c) = watch.elapsed();
                if round > 0 {
                    wall.push(w);
                    cpu.push(c);
                }
            }
        }
        let ([wm, w99, wmax], [cm, c99, cmax]) = (percentiles(wall), percentiles(cpu));
        medians.push(wm);
        let label = match backend {
            Solver::Dense => "dense (lexicographic solve)",
            Solver::DenseThenOsqp => "dense_then_osqp (the default)",
            Solver::Osqp => "osqp (ADMM, verified by the dense solve)",
        };
        println!("{label:<34} {wm:>9.1} {w99:>9.1} {wmax:>9.1} {cm:>9.1} {c99:>9.1} {cmax:>9.1}");
    }
    println!("dense median / OSQP median: {:.3}", medians[0] / medians[2]);
}
