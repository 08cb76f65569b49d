//! What one kino-dynamic MPC iteration costs in its closed loop: 10 s of a 0.3 m/s trot on
//! the MPC's own model ([`cbfgen_anymal::mpc::integrate`], 400 Hz), one real-time
//! iteration every 40 ms (250 of them). CPU time of the calling thread around each
//! iteration (wall time beside it): median, p99, max, and OSQP's iterations; the target
//! is a 20 ms median (the seed's MPC runs at 20 Hz or more beside the 400 Hz controller).
//!
//! ```sh
//! cargo run --release -p cbfgen-anymal --example mpc_latency
//! ```

use cbfgen::cpu_time::{median_p99_max, Stopwatch};
use cbfgen_anymal::gait::Trot;
use cbfgen_anymal::mpc::{integrate, standing, KinodynamicMpc, MpcSettings, Region};

const STEP: f64 = 2.5e-3;
const STEPS_PER_ITERATION: usize = 16;

fn main() -> Result<(), cbfgen::CbfError> {
    let trot = Trot::from_standing(0.3, 0.08, [0.3, 0.0]);
    let mut mpc = KinodynamicMpc::new(MpcSettings::default())?;
    let mut x = standing();
    let iterations = 250;
    let (mut cpu, mut wall, mut admm) = (Vec::new(), Vec::new(), Vec::new());
    let mut unsolved = 0;
    for k in 0..iterations {
        let t = (k * STEPS_PER_ITERATION) as f64 * STEP;
        let clock = Stopwatch::start();
        let report = mpc.solve(t, &x, &trot, &|_, _| Region::GROUND)?;
        let (w, c) = clock.elapsed();
        cpu.push(c.as_secs_f64() * 1e3);
        wall.push(w.as_secs_f64() * 1e3);
        admm.push(f64::from(report.iterations));
        unsolved += usize::from(!report.status.is_solved());
        for s in 0..STEPS_PER_ITERATION {
            let (_, u) = mpc.plan_at(t + s as f64 * STEP).expect("a plan");
            x = integrate(&x, &u, STEP);
        }
    }
    let [cpu_median, cpu_p99, cpu_max] = median_p99_max(&mut cpu);
    let [wall_median, wall_p99, wall_max] = median_p99_max(&mut wall);
    let [admm_median, admm_p99, admm_max] = median_p99_max(&mut admm);
    println!("kino-dynamic MPC, {iterations} iterations ({unsolved} not solved to tolerance)");
    println!("            median     p99     max");
    println!("CPU [ms]  {cpu_median:>8.2} {cpu_p99:>7.2} {cpu_max:>7.2}");
    println!("wall [ms] {wall_median:>8.2} {wall_p99:>7.2} {wall_max:>7.2}");
    println!("OSQP      {admm_median:>8.0} {admm_p99:>7.0} {admm_max:>7.0}");
    Ok(())
}
