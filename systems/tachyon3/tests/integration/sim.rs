//! The closed-loop scenarios, checked with exact geometry against the solid terrain (the
//! floor and every step as a block, rebuilt in the test and measured with parry3d,
//! `common/terrain_contact.rs`): the filter gets the robot over the step, up five stairs
//! and over the other shapes with neither the body nor a wheel more than 1 mm into a
//! solid and no wheel against a riser, and without the body SSAT CBF the same gait drives
//! the body into the edge (so the scenario really tests the CBF).

use cbfgen_tachyon3::catalog::Family;
use cbfgen_tachyon3::model::STATE_NAMES;
use cbfgen_tachyon3::sim::{self, output, Scenario, SimConfig};
use cbfgen_tachyon3::terrain::Stairs;

use crate::terrain_contact;
use terrain_contact::{assert_out_of_the_terrain, measured_run, PENETRATION_TOLERANCE};

#[test]
fn the_filter_gets_the_robot_over_the_step_without_penetration() {
    let result = sim::run(&SimConfig::new(Scenario::Step, true), |_| {}).expect("simulation");
    check_timings(&result);
    let s = result.summary;
    assert!(s.completed, "the robot must cross the step: {s}");
    let m = measured_run(&Scenario::Step.terrain().expect("terrain"), &result);
    assert_out_of_the_terrain("step", m);
    // The wheels keep off the riser: the toe rows' certified margin (1.2 mm) and more.
    assert!(m.wheel_riser > 1e-3, "{m:?}");
    assert!(s.min_h[Family::JointLimits.index()] >= -1e-3, "joint limits: {}", s.min_h[Family::JointLimits.index()]);
    // Crossed: every toe ends on the step's top, the body centre beyond the riser.
    let last = result.samples.last().expect("samples");
    let (body, _, toes) = cbfgen_tachyon3::generated::world_kinematics(&last.x);
    let riser = Stairs::SINGLE_STEP.start_x;
    assert!(body[0] > riser && toes.iter().all(|t| t[0] > riser), "{body:?} {toes:?}");
}

/// The summary's timing figures, recomputed from the samples: nearest-rank percentiles and
/// direct counts of cycles over the 1 ms period, on the wall clock and the thread's CPU clock.
fn check_timings(result: &sim::SimResult) {
    let s = &result.summary;
    let percentiles = |f: fn(&sim::Sample) -> f64| {
        let mut v: Vec<f64> = result.samples.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        let rank = |p: f64| v[((p * v.len() as f64).ceil() as usize).max(1) - 1];
        [rank(0.5), rank(0.99), rank(1.0)]
    };
    assert_eq!(percentiles(|x| x.update_us), [s.median_update_us, s.p99_update_us, s.max_update_us]);
    assert_eq!(percentiles(|x| x.cpu_us), [s.median_cpu_us, s.p99_cpu_us, s.max_cpu_us]);
    let over = |f: fn(&sim::Sample) -> f64| result.samples.iter().filter(|x| f(x) > 1000.0).count();
    assert_eq!(s.over_period_wall, over(|x| x.update_us));
    assert_eq!(s.over_period_cpu, over(|x| x.cpu_us));
    assert!(result.samples.iter().all(|x| x.cpu_us.is_finite() && x.cpu_us >= 0.0));
    if cfg!(unix) {
        assert!(s.median_cpu_us > 0.0 && s.p99_cpu_us > 0.0 && s.max_cpu_us > 0.0, "{s}");
        // The thread cannot work longer than the wall time around its work; the slack
        // covers the clocks' granularity.
        assert!(s.median_cpu_us <= s.median_update_us * 1.5 + 5.0, "{s}");
    }
}

#[test]
fn without_the_body_cbf_the_body_hits_the_step_edge() {
    let result = sim::run(&SimConfig::new(Scenario::Step, false), |_| {}).expect("simulation");
    let m = measured_run(&Scenario::Step.terrain().expect("terrain"), &result);
    assert!(m.body < -PENETRATION_TOLERANCE, "expected the body in the step: {m:?}");
    assert!(m.wheel > -PENETRATION_TOLERANCE && m.wheel_riser > 0.0, "the wheels are still protected: {m:?}");
}

#[test]
fn figures_and_the_documented_csv_are_written() {
    let mut config = SimConfig::new(Scenario::Step, true);
    config.max_time = 2.0;
    let result = sim::run(&config, |_| {}).expect("simulation");
    let dir = std::env::temp_dir().join(format!("cbfgen-sim-test-{}", std::process::id()));
    let written = output::write_all(&dir, &result, None, None, 10).expect("write");
    assert_eq!(written.len(), 10, "one CSV, the animation page and four figures as SVG and PNG: {written:?}");
    for path in &written {
        let bytes = std::fs::read(path).expect("readable");
        assert!(bytes.len() > 500, "{} is nearly empty", path.display());
        match path.extension().and_then(|e| e.to_str()) {
            Some("svg") => {
                let text = String::from_utf8(bytes).expect("text");
                assert!(text.starts_with("<svg") && text.contains("<polyline") && text.trim_end().ends_with("</svg>"));
            }
            Some("png") => assert_eq!(&bytes[1..4], b"PNG", "{}", path.display()),
            Some("html") => assert!(String::from_utf8(bytes).expect("text").contains(r#"id="data""#)),
            _ => {}
        }
    }
    let csv = std::fs::read_to_string(dir.join("step.csv")).expect("csv");
    let header: Vec<&str> = csv.lines().next().expect("header").split(',').collect();
    let mut documented = vec!["t"];
    documented.extend(STATE_NAMES);
    documented.extend(["body_z_world", "body_raise"]);
    let families: Vec<String> = Family::ALL.iter().map(|f| format!("min_h_{}", f.name())).collect();
    documented.extend(families.iter().map(String::as_str));
    documented.extend([
        "active_rows",
        "iterations",
        "source",
        "computed_rows",
        "culled_rows",
        "eval_us",
        "solve_us",
        "update_us",
        "cpu_us",
        "body_clearance",
        "body_nearest",
        "toe_clearance",
        "toe_nearest",
        "toe_riser_clearance",
        "toe_riser_nearest",
        "swinging",
    ]);
    assert_eq!(header, documented);
    assert_eq!(csv.lines().count(), 1 + result.samples.len().div_ceil(10));
    assert!(csv.lines().skip(1).all(|l| l.split(',').count() == header.len()));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_filter_gets_the_robot_up_all_five_stairs_without_penetration() {
    let result = sim::run(&SimConfig::new(Scenario::Stairs, true), |_| {}).expect("simulation");
    check_timings(&result);
    let s = result.summary;
    assert!(s.completed, "every toe must reach the top landing: {s}");
    let top = Stairs::HARDWARE.count as f64 * Stairs::HARDWARE.rise;
    let (_, _, toes) = cbfgen_tachyon3::generated::world_kinematics(&result.samples.last().expect("samples").x);
    assert!(toes.iter().all(|t| t[2] > top), "toes {toes:?} below the top landing {top}");
    let m = measured_run(&Scenario::Stairs.terrain().expect("terrain"), &result);
    assert_out_of_the_terrain("stairs", m);
    assert!(m.body > 0.0 && m.wheel_riser > 1e-3, "{m:?}");
    assert_eq!(s.riser_contact_cycles, 0, "{s}");
    // The body CBF is what lifts the body over the nosings: at the same time into the
    // run, the body stands well above where the same gait puts it without that CBF.
    let without = sim::run(&SimConfig::new(Scenario::Stairs, false), |_| {}).expect("simulation");
    let height = |x: &sim::Sample| x.x[2] + x.x[cbfgen_tachyon3::model::BODY_Z];
    let lift = result
        .samples
        .iter()
        .zip(&without.samples)
        .map(|(a, b)| height(a) - height(b))
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(lift > 0.05, "the body CBF lifted the body by at most {lift:.3} m");
}

/// The shapes a straight flight does not make (unequal rises, a landing, a box to cross, a
/// platform to roll off): the robot finishes each, and neither the body nor a wheel enters
/// the solid terrain by more than 1 mm, risers (up and down) and treads alike; the body
/// does not touch it, nor a wheel a riser.
#[test]
fn unequal_rises_a_landing_a_box_and_a_platform_are_crossed_without_penetration() {
    for scenario in [Scenario::UnequalRises, Scenario::Landing, Scenario::Box, Scenario::Platform] {
        let result = sim::run(&SimConfig::new(scenario, true), |_| {}).expect("simulation");
        let s = result.summary;
        assert!(s.completed, "{}: {s}", scenario.name());
        let m = measured_run(&scenario.terrain().expect("terrain"), &result);
        assert_out_of_the_terrain(scenario.name(), m);
        assert!(m.body > 0.0 && m.wheel_riser > 0.0, "{}: {m:?}", scenario.name());
    }
}

#[test]
fn fig9_counts_the_rows_computed_and_applied_not_the_catalog_capacity() {
    let result = sim::run(&SimConfig::new(Scenario::Stairs, true), |_| {}).expect("simulation");
    // Counted from the model and the course, not from the filter's flags: per leg 4
    // joint-limit, 1 foot-height and 2 stability rows; per step a body row and 6 toe rows
    // (one edge cuboid along each riser); a foothold strip of 4 half-planes for each leg
    // of the swinging tripod and 1 (its tread's start) for each standing leg.
    let (legs, tripod) = (6, 3);
    let fixed = legs * (4 + 1 + 2) + 7 * Stairs::HARDWARE.count;
    for s in &result.samples {
        let footholds = if s.swinging >= 0 { tripod * 4 + (legs - tripod) } else { legs };
        assert_eq!(s.computed_rows, fixed + footholds, "t = {} s", s.t);
        assert!(s.culled_rows + s.active_rows <= s.computed_rows, "culled rows applied at t = {} s", s.t);
    }
    let most = |f: fn(&sim::Sample) -> usize| result.samples.iter().map(f).max().expect("samples");
    let (computed, applied) = (most(|s| s.computed_rows), most(|s| s.active_rows));
    eprintln!(
        "stairs: at most {computed} rows computed, {applied} applied, {} culled in one cycle (catalog capacity 269)",
        most(|s| s.culled_rows)
    );
    // Some rows bind and some are culled, or the figure's lines say nothing.
    assert!(applied > fixed / 2 && most(|s| s.culled_rows) > 0, "applied {applied}");
}
