//! The course with a turn: three steps, a 90° left turn on a 2.4 m landing, three steps.
//! Measured against its solids written out by hand here (not from `Route`), with parry3d.

use cbfgen_tachyon3::generated::{self as gen, state};
use cbfgen_tachyon3::sim::{self, Scenario, SimConfig};

use crate::terrain_contact;
use terrain_contact::{assert_out_of_the_terrain, measured_run_in, Solids};

/// The course's world: floor; flight 1 up +x from x = 1 (16.5 × 35 cm steps, 2.4 m wide)
/// to the landing, x 1.7–4.1 and y ±1.2 at 0.495 m; flight 2 up +y from the landing's
/// side y = 1.2, across its x, each block down to the floor.
fn turn_course_solids() -> Solids {
    let (w, x_landing) = ([-1.2, 1.2], [1.7, 4.1]);
    Solids::blocks(&[
        [[-10.0, 12.0], [-10.0, 12.0], [-1.0, 0.0]],
        [[1.0, 1.35], w, [0.0, 0.165]],
        [[1.35, 1.7], w, [0.0, 0.33]],
        [x_landing, w, [0.0, 0.495]],
        [x_landing, [1.2, 1.55], [0.0, 0.66]],
        [x_landing, [1.55, 1.9], [0.0, 0.825]],
        [x_landing, [1.9, 11.9], [0.0, 0.99]],
    ])
}

#[test]
fn the_robot_climbs_turns_ninety_degrees_on_the_landing_and_climbs_on_without_penetration() {
    let result = sim::run(&SimConfig::new(Scenario::Turn, true), |_| {}).expect("simulation");
    let s = &result.summary;
    assert!(s.completed, "{s}");
    let m = measured_run_in(&turn_course_solids(), &result);
    assert_out_of_the_terrain("turn", m);
    assert!(m.body > 0.0 && m.wheel_riser > 0.0, "{m:?}");
    // It faces +y at the end, on the top of flight 2.
    let last = result.samples.last().expect("samples").x;
    assert!((last[state::YAW] - std::f64::consts::FRAC_PI_2).abs() < 1f64.to_radians(), "yaw {}", last[state::YAW]);
    assert!(
        last[state::PY] > 1.9 && (1.7..4.1).contains(&last[state::PX]),
        "ends at ({}, {})",
        last[state::PX],
        last[state::PY]
    );
    // The paper's three-leg turn: the yaw rate is zero whenever all six wheels are down
    // (LF, RF, LR and RR cannot steer), so the robot turns only while a tripod is lifted,
    // and turns about the drive axle left down: LF-RF while LR, RR and MF (tripod 0) are
    // lifted, LR-RR while MR, LF and RF (tripod 1) are. Those two wheels roll along their
    // heading and do not slide sideways (by finite differences of their world centres;
    // turned about the body centre they would slide at 0.4 m × the yaw rate).
    let turning: Vec<_> = result.samples.iter().filter(|s| s.x[state::YAW_RATE].abs() > 0.01).collect();
    assert!(turning.iter().all(|s| s.swinging >= 0), "turned on six wheels");
    let axle = |tripod: i8| if tripod == 0 { [0, 2] } else { [3, 5] };
    let (mut worst_slide, mut peak_rate) = (0.0f64, 0.0f64);
    for pair in result.samples.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        if a.swinging < 0 || a.swinging != b.swinging || a.x[state::YAW_RATE].abs() < 0.01 {
            continue;
        }
        let (_, _, toes_a) = gen::world_kinematics(&a.x);
        let (_, _, toes_b) = gen::world_kinematics(&b.x);
        let yaw = a.x[state::YAW];
        for leg in axle(a.swinging) {
            let v = [(toes_b[leg][0] - toes_a[leg][0]) / (b.t - a.t), (toes_b[leg][1] - toes_a[leg][1]) / (b.t - a.t)];
            worst_slide = worst_slide.max((-v[0] * yaw.sin() + v[1] * yaw.cos()).abs());
        }
        peak_rate = peak_rate.max(a.x[state::YAW_RATE].abs());
    }
    assert!(peak_rate > 0.3, "peak yaw rate {peak_rate} rad/s");
    assert!(worst_slide < 0.01, "a drive wheel slid sideways at {worst_slide} m/s (yaw rate up to {peak_rate})");
    // Both axles took turns, in at least three turning swings (at most 30° each).
    let swings = turning.windows(2).filter(|w| w[0].swinging != w[1].swinging || w[1].t - w[0].t > 0.1).count() + 1;
    assert!(swings >= 3, "{swings} turning swings");
    assert!(turning.iter().any(|s| s.swinging == 0) && turning.iter().any(|s| s.swinging == 1));
}

#[test]
fn perception_on_a_course_that_turns_is_refused_with_an_error() {
    let mut config = SimConfig::new(Scenario::Turn, true);
    config.perception = Some(Default::default());
    let err = sim::run(&config, |_| {}).expect_err("perception reads one flight along x");
    assert!(err.to_string().contains("flights of a course run on perceived terrain"), "{err}");
}

#[test]
fn a_placement_maps_boxes_half_planes_and_states_consistently() {
    use cbfgen_tachyon3::catalog::HalfPlane;
    use cbfgen_tachyon3::model::standard_posture;
    use cbfgen_tachyon3::terrain::route::Placement;
    use nalgebra::Vector3;
    let p = Placement { origin: [2.0, -1.0], heading: 0.7, lift: 0.3 };
    // A local point, by hand: rotate by 0.7 about z, then shift.
    let (s, c) = 0.7f64.sin_cos();
    let local = [0.4, -0.2, 0.1];
    let world = [2.0 + c * 0.4 + s * 0.2, -1.0 + s * 0.4 - c * 0.2, 0.4];
    let back = p.local_point(&world);
    assert!((0..3).all(|i| (back[i] - local[i]).abs() < 1e-12), "{back:?}");
    // A local box's centre goes where the point goes.
    let b = cbfgen::OrientedBox::axis_aligned(Vector3::from(local), Vector3::new(0.1, 0.2, 0.3)).expect("box");
    let w = p.world_box(&b).expect("box");
    assert!((0..3).all(|i| (w.center()[i] - world[i]).abs() < 1e-12));
    // A local half-plane holds at the world point exactly as at the local one.
    let h = HalfPlane::new([0.6, 0.8], -0.1).expect("half-plane");
    let hw = p.world_half_plane(&h).expect("half-plane");
    let value = |h: &HalfPlane, q: [f64; 3]| h.normal[0] * q[0] + h.normal[1] * q[1] + h.offset;
    assert!((value(&h, local) - value(&hw, world)).abs() < 1e-12);
    // A state's origin maps as a point, its yaw turns by the heading, the rest is kept.
    let mut x = standard_posture();
    (x[0], x[1], x[3]) = (world[0], world[1], 1.0);
    let xl = p.local_state(&x);
    assert!((xl[0] - local[0]).abs() < 1e-12 && (xl[1] - local[1]).abs() < 1e-12 && (xl[3] - 0.3).abs() < 1e-12);
    assert_eq!(xl[4..], x[4..]);
}

/// A route of a user's own, placed anywhere: the first flight turned 0.3 rad and moved,
/// a right turn on its landing, then two more steps up. Run in a loop
/// written here (as a user's controller would), judged by the course's exact clearances
/// and by where it ends, computed by hand.
#[test]
fn a_route_of_ones_own_with_a_right_turn_is_climbed_from_a_loop_written_by_hand() {
    use cbfgen::filter::EcbfFilter;
    use cbfgen_tachyon3::catalog::{default_settings, Catalog};
    use cbfgen_tachyon3::model;
    use cbfgen_tachyon3::sim::gait::GaitParams;
    use cbfgen_tachyon3::sim::{Course, DT};
    use cbfgen_tachyon3::terrain::route::{Flight, Placement, Route};
    use cbfgen_tachyon3::terrain::Terrain;
    let (heading, origin) = (0.3f64, [5.0, -2.0]);
    // Flight 1 (its frame): steps of 15 cm at x = 1 and 1.3, a landing from 1.6 to 4.0.
    let first = Terrain::new(&[[1.0, 0.15], [1.3, 0.30], [1.6, 0.45], [4.0, 0.0]], 1.2, 0.025).expect("terrain");
    // Flight 2 starts at the landing's centre (x = 2.8 in flight 1's frame), facing right.
    let (s, c) = heading.sin_cos();
    let centre = [origin[0] + 2.8 * c, origin[1] + 2.8 * s];
    let second = Terrain::new(&[[1.2, 0.15], [1.5, 0.30]], 1.2, 0.025).expect("terrain");
    let turned = Placement { origin: centre, heading: heading - std::f64::consts::FRAC_PI_2, lift: 0.45 };
    let route = Route::new(vec![
        Flight { terrain: first, placement: Placement { origin, heading, lift: 0.0 }, turn_at: Some(2.8) },
        Flight { terrain: second, placement: turned, turn_at: None },
    ])
    .expect("route");
    let mut course = Course::from_route(route, GaitParams::default()).expect("course");
    let mut filter =
        EcbfFilter::new(Catalog::new(Course::CAPACITY).expect("catalog"), default_settings()).expect("filter");
    let mut x = course.initial_state(0.3);
    let (mut finished, mut worst_body, mut worst_wheel) = (None, f64::INFINITY, f64::INFINITY);
    for k in 0..(80.0 / DT) as usize {
        let t = k as f64 * DT;
        // The turn is about a drive axle, onto which this moves the origin.
        course.exchange_origin(t, &mut x);
        let plan = course.plan(t, &x).expect("plan");
        let out = *filter.update(&x, &plan.u_ref, course.environment()).expect("update");
        let c = course.clearance(&x).expect("clearance");
        (worst_body, worst_wheel) = (worst_body.min(c.body.distance), worst_wheel.min(c.wheel.distance));
        if course.finished(&x) {
            finished = Some(t);
            break;
        }
        let dx = model::xdot(&x, &out.u);
        for (v, d) in x.iter_mut().zip(dx) {
            *v += DT * d;
        }
    }
    assert!(finished.is_some(), "not finished at 80 s");
    assert!(worst_body > 0.0 && worst_wheel > -1e-3, "body {worst_body}, wheel {worst_wheel}");
    // It faces flight 2's heading, on its top: past its last riser (1.5 m along it from
    // the landing's centre), within its width.
    assert!((x[state::YAW] - (heading - std::f64::consts::FRAC_PI_2)).abs() < 1f64.to_radians());
    let (along, across) = {
        let h = heading - std::f64::consts::FRAC_PI_2;
        let (dx, dy) = (x[state::PX] - centre[0], x[state::PY] - centre[1]);
        (dx * h.cos() + dy * h.sin(), -dx * h.sin() + dy * h.cos())
    };
    // Across: the turn point, plus up to 0.1 m rolled while stopping from 0.2 m/s, plus
    // what the pivots about the front and the rear axle in turn leave (about 0.1 m for
    // three 30° pivots about axles 0.4-0.5 m from the body centre).
    assert!(along > 1.5 && across.abs() < 0.3, "ends {along} m along flight 2, {across} m across");
}

/// A loop that never moves the origin onto the drive axle is told so at the first
/// turning swing, rather than turning the robot about the wrong point.
#[test]
fn a_loop_without_exchange_origin_is_refused_at_the_first_turning_swing() {
    use cbfgen_tachyon3::sim::gait::GaitParams;
    use cbfgen_tachyon3::sim::{Course, DT};
    let mut course = Course::new(Scenario::Turn, GaitParams::default()).expect("course");
    let mut x = course.initial_state(0.3);
    // Placed on the landing past its turn point, at rest: the turn starts at once.
    let turn_at = course.route().flights()[0].turn_at.expect("a turn");
    x[state::PX] = turn_at + 0.01;
    x[state::PZ] = 0.495;
    let err = (0..(5.0 / DT) as usize).find_map(|k| course.plan(k as f64 * DT, &x).err()).expect("refused within 5 s");
    assert!(err.to_string().contains("exchange_origin"), "{err}");
}

/// The paper's velocity command on open ground: roll at 0.1 m/s and turn left at 0.15
/// rad/s. The heading follows the command on average, the robot turns only on three
/// legs (yaw rate zero whenever the six wheels are down), and the drive axle left down
/// rolls without sliding sideways, while the origin on it moves as the unicycle it is.
#[test]
fn a_velocity_and_yaw_rate_command_is_followed_by_three_leg_turning_swings() {
    use cbfgen::filter::EcbfFilter;
    use cbfgen_tachyon3::catalog::{default_settings, Catalog};
    use cbfgen_tachyon3::model;
    use cbfgen_tachyon3::sim::gait::GaitParams;
    use cbfgen_tachyon3::sim::{Course, DT};
    use cbfgen_tachyon3::terrain::route::{Flight, Placement, Route};
    use cbfgen_tachyon3::terrain::Terrain;
    // Open ground: the one step is 40 m away, the ground 20 m wide.
    let ground = Terrain::new(&[[40.0, 0.1]], 10.0, 0.025).expect("terrain");
    let placement = Placement { origin: [0.0, 0.0], heading: 0.0, lift: 0.0 };
    let route = Route::new(vec![Flight { terrain: ground, placement, turn_at: None }]).expect("route");
    let mut course = Course::from_route(route, GaitParams::default()).expect("course");
    let max = course.gait().max_yaw_rate();
    assert!(course.command(0.1, 1.01 * max).is_err() && course.command(f64::NAN, 0.0).is_err());
    assert!(course.command(-0.1, 0.0).is_err());
    let (speed, yaw_rate, duration) = (0.1, 0.15, 30.0);
    assert!(yaw_rate < max, "{max}");
    course.command(speed, yaw_rate).expect("command");
    let mut filter =
        EcbfFilter::new(Catalog::new(Course::CAPACITY).expect("catalog"), default_settings()).expect("filter");
    let mut x = course.initial_state(30.0);
    let start = x;
    let (mut worst_slide, mut six_down_rate, mut turning_cycles, mut rolled) = (0.0f64, 0.0f64, 0, 0.0);
    for k in 0..(duration / DT) as usize {
        let t = k as f64 * DT;
        course.exchange_origin(t, &mut x);
        let plan = course.plan(t, &x).expect("plan");
        let lifted = course.swinging();
        let out = *filter.update(&x, &plan.u_ref, course.environment()).expect("update");
        let (_, _, before) = gen::world_kinematics(&x);
        let dx = model::xdot(&x, &out.u);
        for (v, d) in x.iter_mut().zip(dx) {
            *v += DT * d;
        }
        let (_, _, after) = gen::world_kinematics(&x);
        rolled += DT * x[state::V];
        match lifted {
            None => six_down_rate = six_down_rate.max(x[state::YAW_RATE].abs()),
            Some(tripod) if x[state::YAW_RATE].abs() > 0.01 => {
                turning_cycles += 1;
                // The axle left down: LF-RF under tripod 0's swing, LR-RR under tripod 1's.
                for leg in if tripod == 0 { [0, 2] } else { [3, 5] } {
                    let v = [(after[leg][0] - before[leg][0]) / DT, (after[leg][1] - before[leg][1]) / DT];
                    let yaw = x[state::YAW];
                    worst_slide = worst_slide.max((-v[0] * yaw.sin() + v[1] * yaw.cos()).abs());
                }
            }
            Some(_) => {}
        }
    }
    // On average the command's heading: within one turning swing (30°) of yaw_rate · t.
    let turned = x[state::YAW] - start[state::YAW];
    assert!((turned - yaw_rate * duration).abs() < std::f64::consts::FRAC_PI_6, "turned {turned} rad in {duration} s");
    assert!(turning_cycles > 0 && six_down_rate < 0.01, "yaw rate {six_down_rate} rad/s on six wheels");
    assert!(worst_slide < 0.01, "a drive wheel slid sideways at {worst_slide} m/s");
    // It rolled on through the turns: the commanded speed on six wheels, the step speed
    // (0.08 m/s) while a tripod is lifted.
    let low = 0.7 * GaitParams::default().step_speed * duration;
    assert!((low..1.05 * speed * duration).contains(&rolled), "rolled {rolled} m in {duration} s");
}
