//! Record the ECBF QPs of the stairs run into the fixture the solver tests and benches
//! replay (`systems/tachyon3/tests/data/stairs_qps.bin`):
//!
//! ```text
//! cargo run --release -p cbfgen-tachyon3 --example record_stairs_qps -- systems/tachyon3/tests/data/stairs_qps.bin
//! ```
//!
//! Kept: every cycle of the hard window (t = 25.10–25.30 s: the MR leg's joint-limit and
//! foothold rows already violated, four body inputs saturated, stiff rows), and the rest
//! of the run evenly spaced, 500 problems in all. The run itself is deterministic, so the
//! file is too.

use std::fs::File;
use std::io::BufWriter;

use cbfgen_tachyon3::sim::{self, Scenario, SimConfig};

/// The stretch of the stairs run where OSQP needed its full 200 iterations.
const HARD_WINDOW: (f64, f64) = (25.10, 25.30);
const KEPT: usize = 500;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).unwrap_or_else(|| "systems/tachyon3/tests/data/stairs_qps.bin".into());
    let config = SimConfig::new(Scenario::Stairs, true);
    let in_window = |t: f64| (HARD_WINDOW.0..HARD_WINDOW.1).contains(&t);
    let (mut hard, mut rest) = (Vec::new(), Vec::new());
    sim::run_observed(
        &config,
        |_| {},
        |t, filter| {
            // Every 10th cycle outside the window (thinned again below), every one inside.
            if in_window(t) {
                hard.push(filter.recorded_qp(t));
            } else if ((t * 1e3).round() as usize).is_multiple_of(10) {
                rest.push(filter.recorded_qp(t));
            }
        },
    )?;
    let spread = KEPT.saturating_sub(hard.len()).min(rest.len());
    let picks: Vec<usize> = (0..spread).map(|k| k * rest.len() / spread).collect();
    let mut kept: Vec<_> = picks.into_iter().map(|i| rest[i].clone()).chain(hard).collect();
    kept.sort_by(|a, b| a.t.total_cmp(&b.t));
    cbfgen::qp::recorded::write(&mut BufWriter::new(File::create(&path)?), &kept)?;
    let rows: usize = kept.iter().map(|p| p.rows.len()).sum();
    println!(
        "{} problems ({} in t = {:.2}–{:.2} s), {rows} rows, written to {path}",
        kept.len(),
        kept.iter().filter(|p| in_window(p.t)).count(),
        HARD_WINDOW.0,
        HARD_WINDOW.1
    );
    Ok(())
}
