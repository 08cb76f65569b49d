//! The closed loop on perceived terrain: a LiDAR on the body, planes and edge cuboids at
//! 1 Hz on a worker thread, and a gait and filter that never see the true terrain. On the
//! step, the stairs and the four shapes a straight flight does not make, the robot
//! finishes, and neither the body nor a wheel enters the true solid terrain (the floor
//! and every step as a block, risers and treads) by more than 1 mm, measured in the test
//! with parry3d (`common/terrain_contact.rs`).

use cbfgen_tachyon3::sim::perceived::PerceptionSettings;
use cbfgen_tachyon3::sim::{self, Scenario, SimConfig, SimResult};

use crate::terrain_contact;
use terrain_contact::{assert_out_of_the_terrain, measured_run};

fn perceived_run(scenario: Scenario) -> SimResult {
    let config = SimConfig { perception: Some(PerceptionSettings::default()), ..SimConfig::new(scenario, true) };
    sim::run(&config, |_| {}).expect("simulation")
}

fn check(scenario: Scenario) {
    let result = perceived_run(scenario);
    let s = result.summary;
    let name = scenario.name();
    assert!(s.completed, "{name}: {s}");
    let m = measured_run(&scenario.terrain().expect("terrain"), &result);
    assert_out_of_the_terrain(name, m);
    // Perception ran at 1 Hz through the whole run, beside the loop.
    let perception = result.perception.as_ref().expect("perception record");
    let p = s.perception.expect("perception summary");
    assert_eq!(p.updates, perception.updates.len());
    assert!(p.updates as f64 >= s.duration.floor(), "{name}: {} updates in {:.1} s", p.updates, s.duration);
    for pair in perception.updates.windows(2) {
        assert!((pair[1].requested_at - pair[0].requested_at - 1.0).abs() < 1e-6 || pair[0].requested_at == 0.0);
        assert!((pair[1].applied_at - pair[1].requested_at - 0.5).abs() < 1e-6, "{:?}", pair[1]);
    }
}

// One test per course, so the harness runs them on both cores.
#[test]
fn the_step_is_climbed_on_perceived_terrain_without_penetration() {
    check(Scenario::Step);
}

#[test]
fn the_stairs_are_climbed_on_perceived_terrain_without_penetration() {
    check(Scenario::Stairs);
}

#[test]
fn unequal_rises_are_crossed_on_perceived_terrain() {
    check(Scenario::UnequalRises);
}

#[test]
fn a_landing_is_crossed_on_perceived_terrain() {
    check(Scenario::Landing);
}

#[test]
fn a_box_is_crossed_on_perceived_terrain() {
    check(Scenario::Box);
}

#[test]
fn a_platform_is_crossed_on_perceived_terrain() {
    check(Scenario::Platform);
}

/// A perceived run is reproducible: the worker thread's timing does not reach the result.
#[test]
fn a_perceived_run_repeats_exactly() {
    let a = perceived_run(Scenario::Step);
    let b = perceived_run(Scenario::Step);
    assert_eq!(a.samples.len(), b.samples.len());
    assert!(a.samples.iter().zip(&b.samples).all(|(p, q)| p.x == q.x), "the two runs' states differ");
}

/// Without the body CBF the same perceived course drives the body into the true edge: the
/// perceived edges are what keeps it off.
#[test]
fn without_the_body_cbf_the_body_hits_the_true_edge_on_perceived_terrain() {
    let config = SimConfig { perception: Some(PerceptionSettings::default()), ..SimConfig::new(Scenario::Step, false) };
    let result = sim::run(&config, |_| {}).expect("simulation");
    assert!(result.summary.min_body_clearance() < -0.01, "{}", result.summary);
}

#[test]
fn bad_perception_settings_are_typed_errors() {
    let base = PerceptionSettings::default();
    for bad in [
        PerceptionSettings { scan_period: 0.0, ..base },
        PerceptionSettings { scan_period: f64::NAN, ..base },
        PerceptionSettings { update_period: 0.01, ..base },
        PerceptionSettings { latency: 2.0, ..base },
        PerceptionSettings { mount: [1e300, 0.0, 0.0], ..base },
        PerceptionSettings { edge_margin: -0.1, ..base },
        PerceptionSettings { edge_lift: f64::INFINITY, ..base },
        PerceptionSettings { floor_lift: -0.051, ..base },
        PerceptionSettings { lidar: cbfgen_perception::scanner::Lidar { beams: 0, ..base.lidar }, ..base },
        PerceptionSettings {
            worker: cbfgen_perception::worker::WorkerSettings { map_voxel: f64::MAX, ..base.worker },
            ..base
        },
    ] {
        let config = SimConfig { perception: Some(bad), ..SimConfig::new(Scenario::Step, true) };
        assert!(sim::run(&config, |_| {}).is_err(), "{bad:?}");
    }
}

/// The ground perceived from the start pose after `steps` control cycles standing still,
/// with the robot believing it is `offset` (x, z) away from where it is.
fn ground_seen_with_estimate_offset(offset: [f64; 2], cycles: usize) -> Vec<cbfgen_tachyon3::terrain::Level> {
    use cbfgen_tachyon3::sim::gait::GaitParams;
    use cbfgen_tachyon3::sim::perceived::Perceiver;
    use cbfgen_tachyon3::sim::{Course, DT};
    let mut course = Course::new(Scenario::Stairs, GaitParams::default()).expect("course");
    let truth = course.initial_state(0.3);
    let mut estimate = truth;
    // Every world position the state holds (body, toes) is relative to the origin, whose
    // own position is a state too: moving it moves the whole robot.
    estimate[0] += offset[0];
    estimate[2] += offset[1];
    let mut perceiver = Perceiver::new(PerceptionSettings::default(), course.terrain()).expect("perceiver");
    perceiver.start_estimated(&truth, &estimate, &mut course).expect("start");
    for k in 1..=cycles {
        perceiver.step_estimated(k as f64 * DT, &truth, &estimate, &mut course).expect("step");
    }
    course.ground().levels().to_vec()
}

#[test]
fn scans_registered_from_a_wrong_pose_estimate_move_the_perceived_stairs_with_the_error() {
    // The map is built from the pose the robot believes: a belief 4 cm forward and 3 cm up
    // puts every tread 3 cm higher and every riser 4 cm further on, as seen by the gait.
    let offset = [0.04, 0.03];
    let truth = ground_seen_with_estimate_offset([0.0; 2], 1600);
    let shifted = ground_seen_with_estimate_offset(offset, 1600);
    assert!(truth.len() >= 3, "levels seen: {truth:?}");
    assert_eq!(truth.len(), shifted.len(), "{truth:?} vs {shifted:?}");
    for (a, b) in truth.iter().zip(&shifted) {
        assert!((b.height - a.height - offset[1]).abs() < 3e-3, "height {} vs {}", b.height, a.height);
        if a.end.is_finite() {
            assert!((b.end - a.end - offset[0]).abs() < 1e-2, "edge at {} vs {}", b.end, a.end);
        }
    }
}
