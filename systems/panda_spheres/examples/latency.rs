//! OSCBF's setting in its closed loop: the filter's CPU time per update over the whole
//! 10 s sweep (10 000 cycles at 1 kHz), at N = 0, 10, 25, 50 obstacles, with every row in
//! the QP (as OSCBF solves it) and with the default culling. Median, p99 and max, read
//! from the thread's CPU clock around each update (`FilterSettings::measure_cpu_time`);
//! every cycle's exact clearances must stay above −1 mm, as in `tests/oscbf.rs` (the ECBF
//! condition holds in continuous time; the torque held over each 1 ms period lets a
//! sphere pressed onto the table dip by micrometres).
//!
//! ```sh
//! cargo run --release -p cbfgen-panda-spheres --example latency
//! ```

use cbfgen::cpu_time::median_p99_max;
use cbfgen_panda_spheres::{Scenario, Simulation};

fn main() -> Result<(), cbfgen::CbfError> {
    println!(
        "{:>3} {:>6} {:>9} | CPU µs per update: {:>7} {:>7} {:>7} | min clearance [µm]",
        "N", "rows", "rows in", "median", "p99", "max"
    );
    for n in [0, 10, 25, 50] {
        for (label, scenario) in
            [("all", Scenario::with_obstacles(n, 1).all_rows()), ("culled", Scenario::with_obstacles(n, 1))]
        {
            let mut scenario = scenario;
            scenario.settings.measure_cpu_time = true;
            let mut sim = Simulation::new(&scenario)?;
            let cycles = (scenario.duration / cbfgen_panda_spheres::DT).round() as usize;
            let (mut cpu, mut clearance) = (Vec::with_capacity(cycles), f64::INFINITY);
            for _ in 0..cycles {
                let sample = sim.step()?;
                cpu.extend(sample.cpu_us);
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
        }
    }
    Ok(())
}
