//! OSCBF's sweep between the samples: the plant integrated in `FINE` RK4 steps over each
//! 1 ms period under the held torque, each step's exact clearances measured, at N = 0,
//! 10, 25 and 50 obstacles (or the counts given), with the certificate off and on
//! ([`cbfgen::filter::between_samples`]). Prints the least clearance, the updates
//! certified (and why the others were not), the filter's CPU time per update (median,
//! p99, max) and its stated worst case per update in CPU time (with the certificate, its
//! enclosures counted too); no update may pass it.
//!
//! ```sh
//! cargo run --release -p cbfgen-panda-spheres --example between_samples [FINE] [SEED] [N,N,..]
//! ```

use cbfgen::cpu_time::median_p99_max;
use cbfgen::filter::between_samples::BetweenSamples;
use cbfgen::filter::BoundCheck;
use cbfgen_panda_spheres::{Scenario, Simulation, DT};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let fine: usize = args.next().map_or(Ok(100), |a| a.parse())?;
    let seed: u64 = args.next().map_or(Ok(1), |a| a.parse())?;
    let counts: Vec<usize> = match args.next() {
        Some(list) => list.split(',').map(str::parse).collect::<Result<_, _>>()?,
        None => vec![0, 10, 25, 50],
    };
    println!("RK4 steps per 1 ms period: {fine}; obstacles from seed {seed}");
    println!(
        "{:>3} {:>11} | {:>14} {:>14} | {:>12} | CPU µs per update: {:>7} {:>7} {:>7} {:>11} | not certified",
        "N", "certificate", "obstacle [µm]", "table [µm]", "certified", "median", "p99", "max", "worst case"
    );
    for n in counts {
        for certified in [false, true] {
            let mut scenario = Scenario::with_obstacles(n, seed).fine(fine);
            if certified {
                scenario = scenario.certified();
            }
            scenario.settings.measure_cpu_time = true;
            let mut sim = Simulation::new(&scenario)?;
            let mut bound = BoundCheck::new(sim.filter().worst_case(), sim.calibrate()?);
            let cycles = (scenario.duration / DT).round() as usize;
            let (mut cpu, mut obstacle, mut table, mut certain) =
                (Vec::with_capacity(cycles), f64::INFINITY, f64::INFINITY, 0);
            let mut reasons = std::collections::BTreeMap::new();
            for _ in 0..cycles {
                let sample = sim.step()?;
                cpu.extend(sample.cpu_us);
                let cpu_time = std::time::Duration::from_secs_f64(sample.cpu_us.unwrap_or_default() * 1e-6);
                bound.record_work(sample.work.unwrap_or_default(), cpu_time);
                obstacle = obstacle.min(sample.obstacle_clearance);
                table = table.min(sample.table_clearance);
                match sample.between_samples {
                    Some(BetweenSamples::Certified { .. }) => certain += 1,
                    Some(BetweenSamples::Uncertified { why, .. }) => *reasons.entry(why.name()).or_insert(0) += 1,
                    _ => {}
                }
            }
            let [median, p99, max] = median_p99_max(&mut cpu);
            let stated = bound.micros().map_or_else(|| "not stated".to_string(), |us| format!("{us:.0}"));
            println!(
                "{n:>3} {:>11} | {:>14.2} {:>14.2} | {:>5}/{:<6} | {:>26.1} {p99:>7.1} {max:>7.1} {stated:>11} | {reasons:?}",
                if certified { "on" } else { "off" },
                obstacle * 1e6,
                table * 1e6,
                certain,
                cycles,
                median
            );
            assert_eq!(bound.beyond_counts, 0, "N = {n}: an update beyond its stated worst case\n{bound}");
            assert_eq!(bound.beyond_time, 0, "N = {n}: an update beyond its stated worst case in time\n{bound}");
        }
    }
    Ok(())
}
