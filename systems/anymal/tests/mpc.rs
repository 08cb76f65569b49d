//! The kino-dynamic MPC in closed loop on its own model (the generated flow, integrated by
//! RK4 at 2.5 ms with the plan's input; the MPC at 25 Hz): on flat ground it tracks a
//! commanded trot velocity (6 s), and at every plan the mode constraints and the friction
//! pyramid hold on the nonlinear model (within the linearisation's error), checked from
//! the generated kernels, not from the QP.

// Index loops mirror the formulas.
#![allow(clippy::needless_range_loop)]

use cbfgen_anymal::gait::Trot;
use cbfgen_anymal::mpc::{integrate, standing, KinodynamicMpc, MpcSettings, Region, FEET};
use cbfgen_anymal::mpc_generated as gen;

const SIM_DT: f64 = 2.5e-3;
const MPC_PERIOD: f64 = 0.04;

#[test]
fn on_flat_ground_it_tracks_a_commanded_trot_and_its_plans_keep_the_modes_and_the_pyramid() {
    let mut x = standing();
    let trot = Trot::from_standing(0.3, 0.08, [0.3, 0.0]);
    let settings = MpcSettings::default();
    let mut mpc = KinodynamicMpc::new(settings).unwrap();
    let ground = |_: usize, _: f64| Region::GROUND;
    let seconds = 6.0;
    let steps = (seconds / SIM_DT).round() as usize;
    let per_solve = (MPC_PERIOD / SIM_DT).round() as usize;
    let mut travelled_at_2s = None;
    let (mut worst_stance_velocity, mut worst_swing_force, mut worst_pyramid) = (0.0_f64, 0.0_f64, 0.0_f64);
    let (mut lowest, mut worst_lag) = (f64::INFINITY, 0.0_f64);
    let mut highest = f64::NEG_INFINITY;
    for step in 0..steps {
        let t = step as f64 * SIM_DT;
        if step % per_solve == 0 {
            let report = mpc.solve(t, &x, &trot, &ground).unwrap();
            assert!(report.status.is_solved(), "t = {t:.2}: {report:?}");
            let (start, states, inputs) = mpc.plan();
            // The plan's first stages, on the nonlinear model.
            for k in 0..5 {
                let time = start + k as f64 * settings.dt;
                let reference = trot.reference(time);
                let (_, _, velocities, _, _) = gen::feet(&states[k], &inputs[k]);
                let rotation = gen::orientation(&states[k]).0;
                for foot in 0..FEET {
                    let f = [inputs[k][3 * foot], inputs[k][3 * foot + 1], inputs[k][3 * foot + 2]];
                    if reference.stance[foot] {
                        let speed = velocities[foot].iter().map(|v| v * v).sum::<f64>().sqrt();
                        worst_stance_velocity = worst_stance_velocity.max(speed);
                        let world: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| rotation[i][j] * f[j]).sum());
                        let bound = settings.friction / std::f64::consts::SQRT_2 * world[2];
                        worst_pyramid = worst_pyramid.max(world[0].abs() - bound).max(world[1].abs() - bound);
                        worst_pyramid = worst_pyramid.max(-world[2]);
                    } else {
                        worst_swing_force = worst_swing_force.max(f.iter().fold(0.0, |m, v| m.max(v.abs())));
                    }
                }
            }
        }
        let (_, u) = mpc.plan_at(t).unwrap();
        x = integrate(&x, &u, SIM_DT);
        if t >= 1.0 {
            let planned = trot.reference(t + SIM_DT).trunk_position[0] + gen::COM_OFFSET[0];
            worst_lag = worst_lag.max((x[3] - planned).abs());
            lowest = lowest.min(x[5]);
            highest = highest.max(x[5]);
        }
        if (t - 2.0).abs() < SIM_DT / 2.0 {
            travelled_at_2s = Some(x[3]);
        }
    }
    // Steady state: from 2 s on, the commanded 0.3 m/s on average, and the centre of mass
    // never far from the gait's.
    assert!(worst_lag < 0.06, "the centre of mass strayed {worst_lag} m from the gait's");
    let speed = (x[3] - travelled_at_2s.unwrap()) / (seconds - 2.0);
    assert!((speed - 0.3).abs() < 0.03, "average speed {speed} m/s for 0.3");
    assert!(x[4].abs() < 0.05, "lateral drift {} m", x[4]);
    let height = standing()[5];
    assert!(
        lowest > height - 0.03 && highest < height + 0.03,
        "centre of mass height {lowest}..{highest} for {height}"
    );
    // Linearised around the last plan, so met to the linearisation's error only.
    assert!(worst_stance_velocity < 0.02, "a stance foot planned to move at {worst_stance_velocity} m/s");
    assert!(worst_swing_force < 1.0, "a swing foot planned to push {worst_swing_force} N");
    assert!(worst_pyramid < 2.0, "the pyramid exceeded by {worst_pyramid} N");
}
