//! A swing toe started 8 cm outside its foothold (the paper's section IV-D case), handled
//! two ways: the foothold pull (a CLF, the rows off while the toe is out) and the
//! foothold rows kept on. See `cbfgen_tachyon3::sim::foothold_swing` for the scene.
//!
//! `cargo run --release -p cbfgen-tachyon3 --example foothold_pull [-- OUT_DIR]` writes
//! `foothold_pull.{svg,png}` into OUT_DIR (default `out/`) and prints when each toe
//! entered, the largest toe acceleration and the cycles each verdict was relaxed.

use cbfgen_chart::{Chart, Series};
use cbfgen_tachyon3::model::LEG_NAMES;
use cbfgen_tachyon3::sim::foothold_swing::{swing_into_footholds, swing_time, FootholdSwing, OutsideRule};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "out".into()));
    let shift = 0.08;
    let runs = [
        ("pull (CLF), rows off while out", "#1f77b4", swing_into_footholds(OutsideRule::Pull, shift)?),
        ("foothold rows kept on", "#d62728", swing_into_footholds(OutsideRule::KeepRows, shift)?),
    ];
    let mut chart = Chart::new(
        &format!("A swing toe {} cm outside its foothold: depth inside it", shift * 100.0),
        "time since lift-off [s]",
        "depth of the toe centre inside its inset foothold [m]",
    );
    for (name, color, run) in &runs {
        // The first swinging leg; the tripod's three behave alike (the test checks all).
        chart = chart.with(Series::new(name, color, run.t.iter().zip(&run.depth).map(|(&t, d)| (t, d[0])).collect()));
        report(name, run);
    }
    let touchdown = swing_time();
    chart = chart
        .with(Series::new("foothold edge", "black", vec![(0.0, 0.0), (1.5 * touchdown, 0.0)]).dashed())
        .with(Series::new("touchdown", "gray", vec![(touchdown, -shift), (touchdown, 0.1)]).dashed());
    for path in chart.write(&dir, "foothold_pull")? {
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn report(name: &str, run: &FootholdSwing) {
    let peak = run.peak_accel();
    let entered: Vec<String> = run
        .entered()
        .iter()
        .zip(run.legs)
        .map(|(t, leg)| format!("{} {}", LEG_NAMES[leg], t.map_or("never".into(), |t| format!("{t:.3} s"))))
        .collect();
    println!(
        "{name}: entered {}; largest toe acceleration {peak:.2} m/s^2; safety relaxed in {} cycles, convergence in {}",
        entered.join(", "),
        run.safety_relaxed(),
        run.convergence_relaxed()
    );
}
