//! Closed loops on the generated systems, each checked against truths computed here:
//! the exact SAT for the walls, the ECBF conditions recomputed from hand-expanded gains,
//! and the barrier values written out by hand.

use cbfgen::filter::InputSource;
use cbfgen::nalgebra::{Matrix3, Vector3};
use cbfgen::system::{BarrierSet, ControlAffine};
use cbfgen::{sat, OrientedBox};
use spec_crate::{planar_robot as pr, triple_integrator as ti};

const DT: f64 = 1e-3;

/// `L_f^r h + Σ k_i L_f^i h + L_g L_f^{r-1} h · u + δ` with the gains written out for each
/// degree (not through the runtime's `Gains`).
fn ecbf_residual(lie: &[f64], lg: &[f64], u: &[f64], poles: &[f64], delta: f64) -> f64 {
    let k: Vec<f64> = match *poles {
        [p] => vec![p],
        [p1, p2] => vec![p1 * p2, p1 + p2],
        [p1, p2, p3] => vec![p1 * p2 * p3, p1 * p2 + p1 * p3 + p2 * p3, p1 + p2 + p3],
        _ => panic!("no hand expansion for {} poles", poles.len()),
    };
    let r = k.len();
    let drift: f64 = lie[r] + (0..r).map(|i| k[i] * lie[i]).sum::<f64>();
    drift + lg.iter().zip(u).map(|(a, b)| a * b).sum::<f64>() + delta
}

#[test]
fn the_planar_robot_never_enters_the_wall_and_every_active_row_holds() {
    let capacity = pr::Capacity { wall: 2 };
    let mut params = pr::Params::new(capacity).unwrap();
    let vmax = 1.5;
    params.speed_limit[0].vmax = vmax;
    let (wall_center, wall_half) = (Vector3::new(2.0, 0.1, 0.0), Vector3::new(0.2, 1.5, 1.0));
    params
        .wall
        .push(pr::WallParams { center: wall_center, rotation: Matrix3::identity(), half_extents: wall_half })
        .unwrap();
    let wall = OrientedBox::axis_aligned(wall_center, wall_half).unwrap();
    let settings = pr::default_settings();
    let mut filter = pr::Filter::new(pr::Barriers::new(capacity).unwrap(), settings.clone()).unwrap();

    // A PD controller that drives straight through the wall to a goal behind it.
    let goal = [4.0, 0.0];
    let mut x = [0.0, 0.0, 0.0, 0.0];
    let (mut min_gap, mut max_speed, mut qp_cycles, mut wall_rows_active) = (f64::INFINITY, 0.0_f64, 0, 0);
    for _ in 0..8000 {
        let u_nom = [4.0 * (goal[0] - x[0]) - 3.0 * x[2], 4.0 * (goal[1] - x[1]) - 3.0 * x[3]];
        let out = *filter.update(&x, &u_nom, &params).unwrap();
        assert!(out.u.iter().all(|v| v.is_finite()));
        qp_cycles += usize::from(out.source == InputSource::Qp);

        // The speed-limit row by hand: h = vmax² − |v|², L_f h = 0, L_g h = −2 v.
        let speed_row = &filter.rows()[0];
        let h = vmax * vmax - x[2] * x[2] - x[3] * x[3];
        assert!((speed_row.h() - h).abs() < 1e-12 && speed_row.lie[1] == 0.0);
        assert!((speed_row.lg[0] + 2.0 * x[2]).abs() < 1e-12 && (speed_row.lg[1] + 2.0 * x[3]).abs() < 1e-12);

        for (i, (row, slot)) in filter.rows().iter().zip(filter.barriers().layout()).enumerate() {
            if !filter.active()[i] {
                continue;
            }
            wall_rows_active += usize::from(slot.family == pr::family::WALL);
            let poles = settings.families[slot.family].poles;
            let residual = ecbf_residual(&row.lie, &row.lg, &out.u, poles.as_slice(), filter.delta()[i]);
            let scale = 1.0 + row.lie.iter().chain(&row.lg).map(|v| v.abs()).sum::<f64>();
            assert!(residual >= -1e-6 * scale, "row {i} violates its ECBF condition by {residual}");
        }

        let dx = pr::PlanarRobot::xdot(&x, &out.u);
        for (s, d) in x.iter_mut().zip(dx) {
            *s += DT * d;
        }
        let robot = OrientedBox::axis_aligned(Vector3::new(x[0], x[1], 0.0), Vector3::new(0.3, 0.2, 0.25)).unwrap();
        min_gap = min_gap.min(sat::separation(&robot, &wall));
        max_speed = max_speed.max(x[2].hypot(x[3]));
    }
    assert!(min_gap > 0.0, "the robot entered the wall: exact SAT separation {min_gap}");
    assert!(min_gap < 0.1, "the wall never mattered: closest approach {min_gap} m");
    assert!(max_speed < vmax * 1.01, "speed {max_speed} above the limit {vmax}");
    assert!(wall_rows_active > 100 && qp_cycles == 8000);
}

#[test]
fn the_triple_integrator_stays_below_its_limit_with_degree_three_rows() {
    assert_eq!(ti::FAMILIES[0].relative_degree, 3);
    let mut params = ti::Params::new(ti::Capacity::default()).unwrap();
    let p_max = 1.0;
    params.position_limit[0].p_max = p_max;
    // Every row is hard while the input limits allow it: the barrier itself holds
    // against a nominal input that keeps pushing.
    let settings = ti::default_settings();
    let mut filter = ti::Filter::new(ti::Barriers::new(ti::Capacity::default()).unwrap(), settings.clone()).unwrap();
    let mut x = [0.0, 0.5, 0.0];
    let mut max_p = f64::NEG_INFINITY;
    for _ in 0..6000 {
        let u_nom = [5.0]; // push on
        let out = *filter.update(&x, &u_nom, &params).unwrap();
        let row = &filter.rows()[0];
        // h = p_max − p and its drift derivatives by hand: −v, −a, 0; L_g L_f² h = −1.
        assert_eq!(&row.lie[..4], &[p_max - x[0], -x[1], -x[2], 0.0]);
        assert_eq!(row.lg, [-1.0]);
        let residual = ecbf_residual(&row.lie, &row.lg, &out.u, settings.families[0].poles.as_slice(), filter.delta()[0]);
        assert!(residual >= -1e-6, "ECBF condition violated by {residual}");
        let dx = ti::TripleIntegrator::xdot(&x, &out.u);
        for (s, d) in x.iter_mut().zip(dx) {
            *s += DT * d;
        }
        max_p = max_p.max(x[0]);
    }
    assert!(max_p <= p_max + 1e-6, "crossed the limit: p = {max_p}");
    assert!(max_p > p_max - 0.05, "never approached the limit: p = {max_p}");
}
