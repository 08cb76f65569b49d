//! What one kino-dynamic MPC iteration costs in its closed loop, on the MPC's own model
//! ([`cbfgen_anymal::mpc::integrate`], 400 Hz), one real-time iteration every 40 ms: the
//! interior-point method (the default) and OSQP (the peer: `osqp::Problem::solve`, ADMM)
//! in the same run, each from the same start. CPU time of the calling thread around each
//! iteration (wall time beside it): median, p99, max, and the solver's iterations (Newton
//! steps, or ADMM iterations); the target is a 20 ms median (the seed's MPC runs at 20 Hz
//! or more beside the 400 Hz controller).
//!
//! Courses: by default 10 s of a 0.3 m/s trot on flat ground (250 iterations); with
//! `stones`, the trot of stepping-stone field 0 (4 strides) with the proposed controller's
//! foothold CBFs (eq. 25 on the shrinking set, γ = 30 /s, as in the stepping-stone walks).
//!
//! `stage=S` sets the MPC's stage length to `S` seconds, its horizon kept at 1 s.
//!
//! ```sh
//! cargo run --release -p cbfgen-anymal --example mpc_latency [stones] [stage=0.02]
//! ```

use cbfgen::cpu_time::{median_p99_max, Stopwatch};
use cbfgen_anymal::gait::Trot;
use cbfgen_anymal::mpc::{integrate, standing, KinodynamicMpc, MpcSettings, Region};
use cbfgen_anymal::stones::{SteppingStones, StoneField};
use cbfgen_anymal::terrain::Footholds;
use cbfgen_anymal::walk::{Controller, WalkSettings};

const STEP: f64 = 2.5e-3;
const STEPS_PER_ITERATION: usize = 16;

fn main() -> Result<(), cbfgen::CbfError> {
    let on_stones = std::env::args().any(|a| a == "stones");
    let walk = WalkSettings::default();
    let stones = SteppingStones::new(&StoneField { strides: 4, ..StoneField::default() })?;
    let footholds = Footholds::new(stones.terrain().clone(), walk.margin)?;
    let (trot, mut settings, iterations) = if on_stones {
        let footholds = Controller::CbfInBoth.mpc_footholds(&walk);
        let iterations = (stones.end() / (STEPS_PER_ITERATION as f64 * STEP)) as usize;
        (*stones.trot(), MpcSettings { footholds, ..walk.mpc }, iterations)
    } else {
        (Trot::from_standing(0.3, 0.08, [0.3, 0.0]), MpcSettings::default(), 250)
    };
    if let Some(stage) = std::env::args().find_map(|a| a.strip_prefix("stage=").and_then(|s| s.parse::<f64>().ok())) {
        settings = settings.with_stage(stage)?;
    }
    let region = |foot: usize, time: f64| if on_stones { footholds.region(&trot, foot, time) } else { Region::GROUND };
    let course = if on_stones { "stepping stones, field 0, 4 strides" } else { "flat trot, 10 s" };
    println!("kino-dynamic MPC, {course}, {iterations} iterations each");
    println!("                              median     p99     max");
    let mut medians = Vec::new();
    for settings in [settings, settings.with_admm()] {
        let mut mpc = KinodynamicMpc::new(settings)?;
        let mut x = standing();
        let (mut cpu, mut wall, mut steps) = (Vec::new(), Vec::new(), Vec::new());
        let mut unsolved = 0;
        for k in 0..iterations {
            let t = (k * STEPS_PER_ITERATION) as f64 * STEP;
            let clock = Stopwatch::start();
            let report = mpc.solve(t, &x, &trot, &region)?;
            let (w, c) = clock.elapsed();
            cpu.push(c.as_secs_f64() * 1e3);
            wall.push(w.as_secs_f64() * 1e3);
            steps.push(f64::from(report.iterations));
            unsolved += usize::from(!report.status.is_solved());
            for s in 0..STEPS_PER_ITERATION {
                let Some((_, u)) = mpc.plan_at(t + s as f64 * STEP) else { break };
                x = integrate(&x, &u, STEP);
            }
        }
        let name = format!("{:?}", settings.method);
        let [cpu_median, cpu_p99, cpu_max] = median_p99_max(&mut cpu);
        let [wall_median, wall_p99, wall_max] = median_p99_max(&mut wall);
        let [it_median, it_p99, it_max] = median_p99_max(&mut steps);
        println!("{name:<14} CPU [ms]      {cpu_median:>8.2} {cpu_p99:>7.2} {cpu_max:>7.2}");
        println!("{name:<14} wall [ms]     {wall_median:>8.2} {wall_p99:>7.2} {wall_max:>7.2}");
        println!("{name:<14} iterations    {it_median:>8.0} {it_p99:>7.0} {it_max:>7.0}   ({unsolved} not solved)");
        medians.push(cpu_median);
    }
    println!("OSQP / interior point, median CPU time: {:.1}", medians[1] / medians[0]);
    Ok(())
}
