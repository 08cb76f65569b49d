//! What one whole-body controller cycle costs in its closed loop: 10 s of trotting in
//! place at 400 Hz on the rigid-contact plant ([`cbfgen_anymal::plant`], 2 kHz), the
//! LF foot asked 10 cm past its 3 cm square (the foothold CBF binds), 4 000 updates. CPU
//! time of the calling thread around each update (and wall time beside it): median, p99,
//! max; the seed's controller runs at 400 Hz, a 2.5 ms budget.
//!
//! ```sh
//! cargo run --release -p cbfgen-anymal --example wbc_latency
//! ```

use cbfgen::cpu_time::{median_p99_max, Stopwatch};
use cbfgen_anymal::gait::{footholds_around, standing_on_the_ground, Trot};
use cbfgen_anymal::plant;
use cbfgen_anymal::wbc::{WbcSettings, WholeBodyController};
use cbfgen_anymal::wbc_generated as gen;

const CYCLE: f64 = 2.5e-3;
const STEPS_PER_CYCLE: usize = 5;

fn main() -> Result<(), cbfgen::CbfError> {
    let mut x = standing_on_the_ground();
    let home = gen::contacts(&x).0;
    let params = footholds_around(&home, 0.03)?;
    let gait = Trot::in_place(0.3, 0.08, 0.1, home, [x[0], x[1], x[2]]);
    let mut controller = WholeBodyController::new(params.capacity(), WbcSettings::default())?;
    let cycles = (10.0 / CYCLE).round() as usize;
    let (mut cpu, mut wall) = (Vec::with_capacity(cycles), Vec::with_capacity(cycles));
    let mut unsolved = 0;
    for k in 0..cycles {
        let t = k as f64 * CYCLE;
        let reference = gait.reference(t);
        let clock = Stopwatch::start();
        let out = controller.update(t, &x, &reference, &params, CYCLE)?;
        let (w, c) = clock.elapsed();
        cpu.push(c.as_secs_f64() * 1e6);
        wall.push(w.as_secs_f64() * 1e6);
        unsolved += usize::from(!out.solved);
        for _ in 0..STEPS_PER_CYCLE {
            let Some(step) = plant::accelerations(&x, &out.torques, reference.stance) else {
                panic!("cycle {k}: the plant's contacts became singular");
            };
            plant::integrate(&mut x, &step.accelerations, CYCLE / STEPS_PER_CYCLE as f64);
        }
    }
    let [cpu_median, cpu_p99, cpu_max] = median_p99_max(&mut cpu);
    let [wall_median, wall_p99, wall_max] = median_p99_max(&mut wall);
    println!("whole-body controller, {cycles} updates (every level solved in {} of them)", cycles - unsolved);
    println!("           median     p99     max  [µs]");
    println!("CPU     {cpu_median:>9.1} {cpu_p99:>7.1} {cpu_max:>7.1}");
    println!("wall    {wall_median:>9.1} {wall_p99:>7.1} {wall_max:>7.1}");
    Ok(())
}
