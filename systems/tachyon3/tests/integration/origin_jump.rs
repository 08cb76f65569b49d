//! The paper's ground-moving origin, jumping to the wheels in contact at each support
//! exchange: the jump moves nothing the filter sees, and the stairs are climbed with it.

use cbfgen::nalgebra::{Rotation3, Vector3};
use cbfgen_tachyon3::catalog::{Capacity, Catalog, EdgeCuboid, Environment};
use cbfgen_tachyon3::generated::{self as gen, input, state};
use cbfgen_tachyon3::model::{self, State, TOE_BLOCK};
use cbfgen_tachyon3::sim::gait::OriginRule;
use cbfgen_tachyon3::sim::{self, Scenario, SimConfig};
use cbfgen_tachyon3::terrain::Stairs;

use crate::terrain_contact;
use terrain_contact::{assert_out_of_the_terrain, measured_run};

#[test]
fn a_jump_of_the_origin_keeps_every_world_pose_and_every_rows_h_and_its_derivatives() {
    // The hardware stairs' five nosings and a tilted cuboid: room for six edges.
    let capacity = Capacity::edges(6, [4; 6]);
    let mut env = Environment::new(capacity).expect("env");
    for k in 0..5 {
        env.push_edge(Stairs::HARDWARE.edge(k).expect("edge")).expect("slot");
    }
    let tilted = cbfgen::OrientedBox::new(
        Vector3::new(0.9, 0.3, 0.2),
        Rotation3::from_euler_angles(0.1, 0.2, 0.3),
        Vector3::new(0.05, 0.4, 0.05),
    )
    .expect("box");
    env.push_edge(EdgeCuboid::from_box(&tilted)).expect("slot");
    env.set_swing([true; 6]);
    let mut x: State = model::standard_posture();
    // Moving, pitched, yawed, the toes off their hips, the yaw rate at zero.
    for (i, v) in [(state::PX, 0.3), (state::YAW, 0.4), (state::V, 0.2), (model::BODY_PITCH, -0.05)] {
        x[i] = v;
    }
    for leg in 0..6 {
        x[TOE_BLOCK + 4 * leg] += 0.03 * leg as f64 - 0.07;
        x[TOE_BLOCK + 4 * leg + 2] = 0.01 * leg as f64;
    }
    let (mut before, mut after) = (Catalog::new(capacity).expect("catalog"), Catalog::new(capacity).expect("catalog"));
    before.evaluate(&x, &env).expect("rows");
    let mut y = x;
    model::shift_origin(&mut y, 0.137);
    after.evaluate(&y, &env).expect("rows");
    let (b0, r0, t0) = gen::world_kinematics(&x);
    let (b1, r1, t1) = gen::world_kinematics(&y);
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    assert!((0..3).all(|i| close(b0[i], b1[i]) && (0..3).all(|j| close(r0[i][j], r1[i][j]))));
    assert!((0..6).all(|l| (0..3).all(|i| close(t0[l][i], t1[l][i]))));
    let mut compared = 0;
    for ((p, q), slot) in before.rows().iter().zip(after.rows()).zip(before.slots()) {
        if !p.active {
            continue;
        }
        for k in 0..3 {
            assert!((p.lie[k] - q.lie[k]).abs() < 1e-9 * (1.0 + p.lie[k].abs()), "{slot:?} lie[{k}]");
        }
        // The input rows too, but for yaw acceleration, whose lever arm is the point's
        // distance from the origin that moved.
        for u in (0..p.lg.len()).filter(|&u| u != input::YAW_ACC) {
            assert!((p.lg[u] - q.lg[u]).abs() < 1e-9 * (1.0 + p.lg[u].abs()), "{slot:?} lg[{u}]");
        }
        compared += 1;
    }
    assert!(compared > 50, "{compared}");
}

#[test]
fn with_the_origin_jumping_at_each_support_exchange_the_stairs_are_climbed_without_penetration() {
    let mut config = SimConfig::new(Scenario::Stairs, true);
    config.gait.origin = OriginRule::JumpAtExchange;
    let result = sim::run(&config, |_| {}).expect("simulation");
    assert!(result.summary.completed, "{}", result.summary);
    let m = measured_run(&Scenario::Stairs.terrain().expect("terrain"), &result);
    assert_out_of_the_terrain("stairs, origin jumping", m);
    assert!(m.body > 0.0 && m.wheel_riser > 0.0, "{m:?}");
    // One jump at every touchdown (a tripod swinging, then none), each to the centroid.
    let touchdowns = result.samples.windows(2).filter(|w| w[0].swinging >= 0 && w[1].swinging < 0).count();
    let jumps: Vec<_> = result.samples.iter().filter(|s| s.origin_jump.is_some()).collect();
    assert!(touchdowns >= 10 && jumps.len() == touchdowns, "{} jumps, {touchdowns} touchdowns", jumps.len());
    for s in &jumps {
        let centroid = (0..6).map(|leg| s.x[TOE_BLOCK + 4 * leg]).sum::<f64>() / 6.0;
        assert!(centroid.abs() < 1e-12, "t = {}: wheels' centroid {centroid} after the jump", s.t);
    }
    let largest = jumps.iter().map(|s| s.origin_jump.unwrap_or(0.0).abs()).fold(0.0, f64::max);
    assert!(largest > 0.01, "the origin never moved: largest jump {largest}");
}
