//! OSCBF's setting in its closed loop: the filter's CPU time per update over the whole
//! 10 s sweep (10 000 cycles at 1 kHz), at N = 0, 10, 25, 50 obstacles, with every row in
//! the QP (as OSCBF solves it) and with the default culling. Median, p99 and max, read
//! from the thread's CPU clock around each update (`FilterSettings::measure_cpu_time`);
//! every cycle's exact clearances must stay above −1 mm, as in `tests/oscbf.rs` (the ECBF
//! condition holds in continuous time; the torque held over each 1 ms period lets a
//! sphere pressed onto the table dip by micrometres). Then each run's stated worst case
//! per update beside the most an update took (docs/filter.md, "The worst case of an
//! update"), in counts and in CPU time; no update may pass it.
//!
//! ```sh
//! cargo run --release -p cbfgen-panda-spheres --example latency
//! ```

use cbfgen::cpu_time::median_p99_max;
use cbfgen::filter::BoundCheck;
use cbfgen_panda_spheres::{Scenario, Simulation};
use std::time::Duration;

fn main() -> Result<(), cbfgen::CbfError> {
    println!(
        "{:>3} {:>6} {:>9} | CPU µs per update: {:>7} {:>7} {:>7} | min clearance [µm]",
        "N", "rows", "rows in", "median", "p99", "max"
    );
    let mut bounds = Vec::new();
    for n in [0, 10, 25, 50] {
        for (label, scenario) in
            [("all", Scenario::with_obstacles(n, 1).all_rows()), ("culled", Scenario::with_obstacles(n, 1))]
        {
            let mut scenario = scenario;
            scenario.settings.measure_cpu_time = true;
            let mut sim = Simulation::new(&scenario)?;
            let mut bound = BoundCheck::new(sim.filter().worst_case(), sim.calibrate()?);
            let cycles = (scenario.duration / cbfgen_panda_spheres::DT).round() as usize;
            let (mut cpu, mut clearance) = (Vec::with_capacity(cycles), f64::INFINITY);
            for _ in 0..cycles {
                let sample = sim.step()?;
                cpu.extend(sample.cpu_us);
                let cpu_time = Duration::from_secs_f64(sample.cpu_us.unwrap_or_default() * 1e-6);
                bound.record_work(sample.work.unwrap_or_default(), cpu_time);
                clearance = clearance.min(sample.obstacle_clearance).min(sample.table_clearance);
            }
            let [median, p99, max] = median_p99_max(&mut cpu);
            println!(
                "{n:>3} {:>6} {label:>9} | {:>27.1} {p99:>7.1} {max:>7.1} | {:.1}",
                sim.filter().rows().len(),
                median,
                clearance * 1e6
            );
            assert!(clearance >= -1e-3, "N = {n} ({label}): an arm sphere entered an obstacle or the table");
            assert_eq!(bound.beyond_counts, 0, "N = {n} ({label}): an update beyond its stated worst case");
            assert_eq!(bound.beyond_time, 0, "N = {n} ({label}): an update beyond its stated worst case in time");
            bounds.push((n, label, bound));
        }
    }
    println!("\nworst case per update, stated / most measured:");
    println!(
        "{:>3} {:>9} | {:>21} | {:>15} | {:>9} | {:>21} | ns per trip",
        "N", "rows in", "dense-solver trips", "OSQP iterations", "row ops", "CPU time [µs]"
    );
    for (n, label, b) in bounds {
        let (w, m) = (b.worst_case, b.most);
        let trips = format!("{} / {}", w.dense_trips, m.dense_trips);
        let osqp = format!("{} / {}", w.osqp_iterations, m.osqp_iterations);
        let rows = w.row_ops.map_or_else(|| "-".to_string(), |o| o.total().to_string());
        let most_us = b.max_cpu.as_secs_f64() * 1e6;
        let time = b.micros().map_or_else(|| "not stated".to_string(), |us| format!("{us:.0} / {most_us:.0}"));
        let per_trip = b.calibration.ns_per_dense_trip;
        println!("{n:>3} {label:>9} | {trips:>21} | {osqp:>15} | {rows:>9} | {time:>21} | {per_trip:.2}");
    }
    Ok(())
}
