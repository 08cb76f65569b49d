//! Table I interleaved: every query timed in turn, round after round, so that a machine's
//! drift (another VM's load, frequency changes) hits every row alike and the ratios
//! between rows hold within the run. Prints per query the median over rounds of wall and
//! thread CPU time per pair, and the ratios to parry3d's GJK and to the default SSAT
//! (LSE + x·tanh, evaluate) in the same rounds.
//!
//! `cargo bench --bench table_one` (or `scripts/cbf bench --bench table_one`);
//! `-- --rounds N` for more rounds than the default 201. Run by `cargo test --benches`,
//! one round, as a check that every query runs.

#[path = "common/table_one.rs"]
mod table_one;

use cbfgen::cpu_time::{median_p99_max, thread_cpu_time};
use std::hint::black_box;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let rounds = args
        .iter()
        .position(|a| a == "--rounds")
        .and_then(|i| args.get(i + 1))
        .and_then(|n| n.parse().ok())
        .unwrap_or(cbfgen_testkit::bench_run::repetitions(201));
    let queries = table_one::queries();
    // Warm up: every query a few passes, so caches and branch predictors start alike.
    for (_, _, pass) in &queries {
        for _ in 0..20 {
            black_box(pass());
        }
    }
    let pairs = table_one::PAIRS as f64;
    let (mut wall, mut cpu) =
        (vec![Vec::with_capacity(rounds); queries.len()], vec![Vec::with_capacity(rounds); queries.len()]);
    for _ in 0..rounds {
        for (k, (_, _, pass)) in queries.iter().enumerate() {
            let (c0, t0) = (thread_cpu_time(), Instant::now());
            black_box(pass());
            let w = t0.elapsed().as_secs_f64();
            let c = match (c0, thread_cpu_time()) {
                (Some(a), Some(b)) => b.saturating_sub(a).as_secs_f64(),
                _ => f64::NAN,
            };
            wall[k].push(w * 1e9 / pairs);
            cpu[k].push(c * 1e9 / pairs);
        }
    }
    let median = |v: &mut Vec<f64>| median_p99_max(v)[0];
    let wall: Vec<f64> = wall.iter_mut().map(median).collect();
    let cpu: Vec<f64> = cpu.iter_mut().map(median).collect();
    let gjk = queries.iter().position(|(n, _, _)| n == "parry3d_gjk_distance").expect("GJK is a query");
    let ssat = queries.iter().position(|(n, _, _)| n == "evaluate/lse_xtanh").expect("the default SSAT is a query");
    println!("Table I, {rounds} interleaved rounds over {} box pairs (medians per pair)", table_one::PAIRS);
    println!("{:<34} {:>9} {:>9} {:>9} {:>9}  function timed", "query", "wall ns", "cpu ns", "vs GJK", "vs SSAT");
    for (k, (name, function, _)) in queries.iter().enumerate() {
        println!(
            "{name:<34} {:>9.1} {:>9.1} {:>8.2}× {:>8.2}×  {function}",
            wall[k],
            cpu[k],
            wall[k] / wall[gjk],
            wall[k] / wall[ssat]
        );
    }
}
