//! Seed 004's Table II on the rigid-contact plant: each of the four controllers over the
//! same stone fields, one markdown row per walk. (MuJoCo's: `python -m
//! cbfgen.physics.stepping_stones`.)
//!
//! ```text
//! cargo run --release -p cbfgen-anymal --example stepping_stones -- [fields] [strides] [controller index] [gamma] [threaded] [region|shrinking] [wbc-region|wbc-extent|wbc-shrinking] [rows]
//! ```
//!
//! Defaults: 5 fields (seeds 0..5), 8 strides each, all four controllers (index 0..4 in
//! Table II's order for one), eq. 25's γ as `WalkSettings::default()`, the MPC inline
//! (`threaded`: in its own thread, the walk in real time), eq. 25 on eq. 24's shrinking
//! set (`region`: on the landing region itself, `FootholdBarrier::Region`), eq. 26 on that
//! set's extent each cycle (`wbc-region`, `wbc-shrinking`: `WholeBodyBarrier`), the stones under
//! the trot's footholds (`rows`: in rows away from the gait, `StoneField::rows`). A `-` for
//! the controller index or γ keeps its default.

use cbfgen_anymal::stones::{SteppingStones, StoneField};
use cbfgen_anymal::walk::{walk, Controller, FootholdBarrier, WalkSettings, WholeBodyBarrier};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let fields: u64 = args.first().map_or(Ok(5), |a| a.parse())?;
    let strides: usize = args.get(1).map_or(Ok(8), |a| a.parse())?;
    let controllers: Vec<Controller> = match args.get(2).filter(|a| *a != "-") {
        Some(k) => vec![*Controller::ALL.get(k.parse::<usize>()?).ok_or("controller index 0..4")?],
        None => Controller::ALL.to_vec(),
    };
    let mut settings = WalkSettings::default();
    if let Some(gamma) = args.get(3).filter(|a| *a != "-") {
        settings.gamma = gamma.parse()?;
    }
    let flags = &args[args.len().min(4)..];
    settings.threaded = flags.iter().any(|a| a == "threaded");
    if let Some(barrier) = FootholdBarrier::ALL.into_iter().find(|b| flags.iter().any(|a| a == b.name())) {
        settings.barrier = barrier;
    }
    let whole_body = |b: &WholeBodyBarrier| flags.iter().any(|a| a.strip_prefix("wbc-") == Some(b.name()));
    if let Some(barrier) = WholeBodyBarrier::ALL.into_iter().find(whole_body) {
        settings.whole_body_barrier = barrier;
    }
    let layout = if flags.iter().any(|a| a == "rows") { StoneField::rows() } else { StoneField::default() };
    println!("| controller | seed | steps | missteps | avg misstep [mm] | worst height [mm] | swing [s] | eq. 24 [s] | eq. 25 [s] | MPC failed | solver iterations (mean) | WBC unsolved | fell | missteps planned |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for controller in controllers {
        for seed in 0..fields {
            let stones = SteppingStones::new(&StoneField { strides, seed, ..layout })?;
            let r = walk(&stones, controller, &settings)?;
            let worst_height = r.landings.iter().map(|l| l.height.abs()).fold(0.0, f64::max);
            println!(
                "| {} | {seed} | {} | {} | {:.1} | {:.1} | {:.2} | {:.2} | {:.2} | {}/{} | {} | {}/{} | {} | {} |",
                controller.name(),
                r.landings.len(),
                r.missteps().count(),
                1e3 * r.mean_misstep(),
                1e3 * worst_height,
                r.swing_time,
                r.violated_24,
                r.violated_25,
                r.mpc_failures.0,
                r.mpc_failures.1,
                r.mpc_solver_iterations / r.mpc_failures.1.max(1) as u64,
                r.wbc_unsolved.0,
                r.wbc_unsolved.1,
                r.fell.map_or("no".to_string(), |t| format!("at {t:.2} s")),
                r.landings.iter().filter(|l| l.planned_misstep > 0.0).count(),
            );
        }
    }
    Ok(())
}
