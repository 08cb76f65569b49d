//! The whole-body controller on its own model with a plant it does not share
//! ([`cbfgen_anymal::plant`]: the torques in, the stance feet held by rigid contacts),
//! integrated at 2 kHz with the controller at 400 Hz. Checked at every cycle: priority 0's rows (equations of motion,
//! torque limits, friction pyramid, stance feet still); standing's forces against the
//! robot's weight; the foothold CBF keeping a swing foot inside its square when the
//! reference asks it out, and the same reference without the CBF leaving it.
//! (The kernels themselves are checked against Pinocchio in python/tests/test_anymal_wbc.py.)

use cbfgen::nalgebra::Matrix3;
use cbfgen_anymal::gait::{footholds_around, standing_on_the_ground, Trot};
use cbfgen_anymal::plant;
use cbfgen_anymal::wbc::{rotation_vector, WbcOutput, WbcReference, WbcSettings, WholeBodyController, FEET};
use cbfgen_anymal::wbc_generated::{self as gen, Capacity, Params, NU, NX};

const SIM_DT: f64 = 0.5e-3;
const STEPS_PER_CYCLE: usize = 5; // 400 Hz

fn no_footholds() -> Params {
    Params::new(Capacity { foot_region: [0; FEET] }).expect("capacity")
}

/// Priority 0 at the controller's own answer: its equations of motion, torque limits,
/// friction pyramid and still stance feet, recomputed from the kernels.
fn check_priority_0(x: &[f64; NX], out: &WbcOutput, stance: [bool; FEET], settings: &WbcSettings, cycle: usize) {
    assert!(out.solved, "cycle {cycle}: {:?}", out.levels);
    let (mass, bias) = gen::dynamics(x);
    let (_, jacobians, drifts) = gen::contacts(x);
    let weight = gen::TOTAL_MASS * 9.81;
    for r in 0..NU {
        let mut residual = bias[r] - if r >= 6 { out.wbc_torques[r - 6] } else { 0.0 };
        residual += mass[r].iter().zip(&out.accelerations).map(|(m, a)| m * a).sum::<f64>();
        for foot in (0..FEET).filter(|f| stance[*f]) {
            for a in 0..3 {
                residual -= jacobians[3 * foot + a][r] * out.forces[foot][a];
            }
        }
        // To 1e-6 of the robot's weight (the hierarchy's regularisation moves each
        // level's answer by about 1e-7 relative).
        assert!(residual.abs() <= 1e-6 * weight, "cycle {cycle}: equation {r} off by {residual}: {out:?}");
    }
    for (j, t) in out.wbc_torques.iter().enumerate() {
        assert!(t.abs() <= settings.torque_limits[j] * (1.0 + 1e-9), "cycle {cycle}: torque {j} = {t}");
    }
    let mu = settings.friction / std::f64::consts::SQRT_2;
    for foot in 0..FEET {
        let f = out.forces[foot];
        if stance[foot] {
            assert!(f[2] >= settings.min_normal_force - 1e-6, "cycle {cycle}: foot {foot} normal force {}", f[2]);
            assert!(f[0].abs().max(f[1].abs()) <= mu * f[2] + 1e-6, "cycle {cycle}: foot {foot} slips: {f:?}");
            for a in 0..3 {
                let j = &jacobians[3 * foot + a];
                let accel: f64 = j.iter().zip(&out.accelerations).map(|(p, q)| p * q).sum::<f64>() + drifts[foot][a];
                assert!(accel.abs() <= 1e-5, "cycle {cycle}: stance foot {foot} accelerates {accel} along {a}");
            }
        } else {
            assert!(f.iter().all(|v| v.abs() <= 1e-6), "cycle {cycle}: swing foot {foot} carries {f:?}");
        }
    }
}

#[test]
fn standing_carries_the_robots_weight_equally_and_holds_still() {
    let x = standing_on_the_ground();
    let settings = WbcSettings::default();
    let mut wbc = WholeBodyController::new(Capacity { foot_region: [0; FEET] }, settings).unwrap();
    let reference = WbcReference::standing([x[0], x[1], x[2]], Matrix3::identity());
    let out = wbc.update(0.0, &x, &reference, &no_footholds(), 2.5e-3).unwrap();
    check_priority_0(&x, &out, [true; FEET], &settings, 0);
    // The URDF's total mass times g, carried by the four feet (shared as equally as the
    // moment balance lets: the centre of mass is not midway between the feet), with no net
    // horizontal force.
    let weight = gen::TOTAL_MASS * 9.81;
    let total: [f64; 3] = std::array::from_fn(|a| out.forces.iter().map(|f| f[a]).sum());
    assert!((total[2] - weight).abs() <= 1e-6 * weight, "{total:?} carry {weight} N");
    assert!(total[0].abs().max(total[1].abs()) <= 1e-6 * weight, "{total:?}");
    for f in out.forces {
        assert!((f[2] - weight / 4.0).abs() <= 0.05 * weight / 4.0, "{f:?}");
    }
    assert!(out.accelerations.iter().all(|a| a.abs() <= 1e-6), "{:?}", out.accelerations);
}

/// [`Trot`] on the plant, LF asked `reach` forward at mid-swing. Returns how far
/// the LF foot got beyond its square's front edge while it swung, and the trunk's largest
/// height error.
fn trot(footholds: bool, reach: f64, seconds: f64) -> (f64, f64) {
    let settings = WbcSettings::default();
    let mut x = standing_on_the_ground();
    let home = gen::contacts(&x).0;
    let params = if footholds { footholds_around(&home, 0.03).unwrap() } else { no_footholds() };
    let mut wbc = WholeBodyController::new(params.capacity(), settings).unwrap();
    let gait = Trot::in_place(0.3, 0.08, reach, home, [x[0], x[1], x[2]]);
    let (mut beyond, mut height) = (f64::NEG_INFINITY, 0.0_f64);
    let dt = SIM_DT * STEPS_PER_CYCLE as f64;
    for cycle in 0..(seconds / dt).round() as usize {
        let t = cycle as f64 * dt;
        let reference = gait.reference(t);
        let out = wbc.update(t, &x, &reference, &params, dt).unwrap();
        check_priority_0(&x, &out, reference.stance, &settings, cycle);
        for _ in 0..STEPS_PER_CYCLE {
            let step = plant::accelerations(&x, &out.torques, reference.stance).expect("regular contacts");
            plant::integrate(&mut x, &step.accelerations, SIM_DT);
            if !reference.stance[0] {
                beyond = beyond.max(gen::contacts(&x).0[0][0] - (home[0][0] + 0.03));
            }
        }
        height = height.max((x[2] - gait.trunk[2]).abs());
    }
    (beyond, height)
}

#[test]
fn a_trot_in_place_keeps_priority_0_and_the_trunk() {
    let (_, height) = trot(false, 0.0, 2.0);
    assert!(height <= 0.02, "the trunk moved {height} m in height");
}

#[test]
fn the_foothold_cbf_keeps_a_swing_foot_in_its_square_and_without_it_the_foot_leaves() {
    let (inside, _) = trot(true, 0.10, 1.5);
    assert!(inside <= 1e-3, "with the CBF the LF foot left its square by {inside} m");
    let (outside, _) = trot(false, 0.10, 1.5);
    assert!(outside >= 0.05, "without the CBF the LF foot stayed within {outside} m of its square");
}

#[test]
fn a_trot_at_0_3_m_per_s_follows_the_trunk_reference_and_keeps_priority_0() {
    let settings = WbcSettings::default();
    let mut x = standing_on_the_ground();
    let home = gen::contacts(&x).0;
    let mut wbc = WholeBodyController::new(Capacity { foot_region: [0; FEET] }, settings).unwrap();
    let gait = Trot { velocity: [0.3, 0.0], ..Trot::in_place(0.3, 0.08, 0.0, home, [x[0], x[1], x[2]]) };
    let dt = SIM_DT * STEPS_PER_CYCLE as f64;
    let seconds = 3.0;
    let mut worst = 0.0_f64;
    for cycle in 0..(seconds / dt).round() as usize {
        let t = cycle as f64 * dt;
        let reference = gait.reference(t);
        let out = wbc.update(t, &x, &reference, &no_footholds(), dt).unwrap();
        check_priority_0(&x, &out, reference.stance, &settings, cycle);
        for _ in 0..STEPS_PER_CYCLE {
            let step = plant::accelerations(&x, &out.torques, reference.stance).expect("regular contacts");
            plant::integrate(&mut x, &step.accelerations, SIM_DT);
        }
        let error = (0..3).map(|k| (x[k] - reference.trunk_position[k]).abs()).fold(0.0, f64::max);
        worst = worst.max(error);
    }
    // 0.3 m/s for 2.7 s (after the first still swing): 0.81 m.
    let travelled = x[0] - gait.trunk[0];
    assert!((travelled - 0.81).abs() <= 0.05, "the trunk went {travelled} m");
    // With only two feet down, on a diagonal, no contact force turns the trunk about that
    // line: it sways (6.6 cm sideways, measured) and the swing feet land where the
    // reference put them, not where balance would (the MPC's job, issue 38).
    assert!(worst <= 0.08, "the trunk strayed {worst} m from its reference");
}

/// The trunk's orientation error against nalgebra's logarithm on true rotations (all
/// angles, half turns included), and finite where rounding has put an integrated rotation's
/// trace above 3 (nalgebra's `acos` is NaN there).
#[test]
fn the_rotation_vector_is_the_logarithm_and_finite_past_a_trace_of_3() {
    use cbfgen::nalgebra::{Rotation3, Vector3};
    let mut worst = 0.0_f64;
    for k in 0..2000 {
        let t = f64::from(k);
        let axis = Vector3::new((0.37 * t).sin(), (0.91 * t + 1.0).cos(), (0.13 * t).sin() + 0.2).normalize();
        let angle = std::f64::consts::PI * f64::from(k % 200) / 199.0 * if k % 2 == 0 { 1.0 } else { -1.0 };
        let r = Rotation3::from_scaled_axis(axis * angle);
        let ours = rotation_vector(r.matrix());
        // The same rotation, by an angle of at most a half turn (at a half turn ±axis are
        // the same, and nalgebra's own axis is unreliable there), and nalgebra's vector
        // away from it.
        let back = Rotation3::from_scaled_axis(ours);
        let mut error = (back.matrix() - r.matrix()).norm() + (ours.norm() - angle.abs()).abs();
        if angle.abs() < 3.1 {
            error += (ours - r.scaled_axis()).norm();
        }
        worst = worst.max(error);
    }
    assert!(worst < 1e-7, "worst {worst}");
    let mut grown = Matrix3::identity() * (1.0 + 1e-12);
    grown[(0, 1)] = 1e-10;
    assert!(grown.trace() > 3.0 && Rotation3::<f64>::from_matrix_unchecked(grown).angle().is_nan());
    let v = rotation_vector(&grown);
    assert!(v.iter().all(|e| e.is_finite()) && v.norm() < 1e-9, "{v:?}");
}

/// Eq. 26 on eq. 24's shrinking set: the whole-body QP's foothold rows for a swing foot,
/// given the growth's value and derivatives at the cycle's time, are the region's rows
/// plus the growth in `h`, its rate in `ḣ` and its curvature in `ḧ`, each against a central
/// difference of the trot's growth in time (the runtime's single source of the shape).
#[test]
fn a_shrinking_sets_rows_carry_the_growth_and_its_time_derivatives() {
    use cbfgen::system::BarrierSet;
    use cbfgen_anymal::terrain::Patch;
    use cbfgen_anymal::wbc::{set_foothold, Growth};
    use cbfgen_anymal::wbc_generated::Barriers;

    let mut x = standing_on_the_ground();
    for (i, v) in x[24..].iter_mut().enumerate() {
        *v = 0.05 * ((i as f64) * 0.7).sin(); // moving, so L_f h is not trivially zero
    }
    let trot = Trot::from_standing(0.3, 0.08, [0.3, 0.0]);
    let home = gen::contacts(&x).0;
    let region =
        Patch::rectangle([home[0][0] + 0.2, home[0][1], 0.0], [0.07, 0.07], 0.0).unwrap().region(0.02).unwrap();
    let capacity = Capacity { foot_region: [4; FEET] };
    let evaluate = |t: f64, growth: Growth| {
        let mut params = Params::new(capacity).unwrap();
        set_foothold(&mut params, 0, &region, growth).unwrap();
        let mut barriers = Barriers::new(capacity).unwrap();
        barriers.evaluate(t, &x, &params).unwrap();
        barriers.rows()[..4].iter().map(|r| r.lie).collect::<Vec<_>>()
    };
    let margin = 0.25;
    for t in [0.31, 0.4, 0.5, 0.58] {
        let growth = trot.shrinking_growth(margin, t);
        let fixed = evaluate(t, Growth::NONE);
        let grown = evaluate(t, Growth { derivatives: growth, at: t });
        let delta = 1e-5;
        let rate =
            (trot.shrinking_growth(margin, t + delta)[0] - trot.shrinking_growth(margin, t - delta)[0]) / (2.0 * delta);
        for (f, g) in fixed.iter().zip(&grown) {
            assert!((g[0] - f[0] - growth[0]).abs() < 1e-12, "t {t}: h {} vs {} + {}", g[0], f[0], growth[0]);
            assert!((g[1] - f[1] - rate).abs() < 1e-6, "t {t}: ḣ {} vs {} + {rate}", g[1], f[1]);
            assert!((g[2] - f[2] - growth[2]).abs() < 1e-9, "t {t}: ḧ {} vs {}", g[2], f[2]);
        }
        assert!(growth[0] > 0.0 && rate < 0.0, "a swing foot's set shrinks: {growth:?}");
    }
}

#[test]
fn every_straight_line_kernel_of_the_three_models_performs_the_operations_its_table_states() {
    // Run on numbers that count (cbfgen::ops::Counted), against the generator's count.
    use cbfgen::ops::{check_stated, Counted};
    let report = |m| panic!("{m:#?}");
    let checked = [
        check_stated(cbfgen_anymal::generated::run_counted_kernels::<Counted>).unwrap_or_else(report),
        check_stated(cbfgen_anymal::wbc_generated::run_counted_kernels::<Counted>).unwrap_or_else(report),
        check_stated(cbfgen_anymal::mpc_generated::run_counted_kernels::<Counted>).unwrap_or_else(report),
    ];
    assert!(checked[0] >= 30 && checked[1] >= 8 && checked[2] >= 10, "{checked:?} kernels counted");
}
