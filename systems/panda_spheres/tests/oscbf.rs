//! OSCBF's setting on cbfgen: the torque-controlled arm's spheres against random sphere
//! obstacles and a table, checked by the exact sphere distances of every cycle (from the
//! generated forward kinematics, itself checked against Pinocchio and SymEngine).

use cbfgen::filter::InputSource;
use cbfgen::system::BarrierSet;
use cbfgen_panda_spheres::generated::{self as gen, Barriers, NX};
use cbfgen_panda_spheres::{random_obstacles, run, Scenario, Simulation, SPHERES};

fn worst(samples: &[cbfgen_panda_spheres::Sample]) -> (f64, f64, usize) {
    let obstacle = samples.iter().map(|s| s.obstacle_clearance).fold(f64::INFINITY, f64::min);
    let table = samples.iter().map(|s| s.table_clearance).fold(f64::INFINITY, f64::min);
    let not_qp = samples.iter().filter(|s| s.source.is_some_and(|src| src != InputSource::Qp)).count();
    (obstacle, table, not_qp)
}

#[test]
fn the_filter_keeps_every_sphere_off_the_obstacles_and_above_the_table_and_without_it_they_are_not() {
    for seed in [1, 2, 3] {
        let scenario = Scenario::with_obstacles(25, seed);
        let (obstacle, table, not_qp) = worst(&run(&scenario).unwrap());
        eprintln!("seed {seed}: closest obstacle {:.2} mm, table {:.2} mm", obstacle * 1e3, table * 1e3);
        assert!(obstacle >= -1e-3 && table >= -1e-3, "seed {seed}: {obstacle} {table}");
        assert_eq!(not_qp, 0, "seed {seed}: every torque came from the QP");
        assert!(obstacle.min(table) < 0.02, "seed {seed}: the sweep must come close: {obstacle} {table}");
        let (obstacle, table, _) = worst(&run(&scenario.clone().without_filter()).unwrap());
        assert!(obstacle.min(table) < -0.01, "seed {seed}: without the filter something is hit: {obstacle} {table}");
    }
}

#[test]
fn with_every_row_in_the_qp_the_run_is_as_safe() {
    let scenario = Scenario::with_obstacles(50, 4).all_rows();
    let sim = Simulation::new(&scenario).unwrap();
    assert_eq!(sim.filter().rows().len(), SPHERES * 50 + gen::TABLE_SPHERES.len());
    let (obstacle, table, not_qp) = worst(&run(&scenario).unwrap());
    assert!(obstacle >= -1e-3 && table >= -1e-3 && not_qp == 0, "{obstacle} {table} {not_qp}");
}

#[test]
fn culled_rows_hold_their_exact_value_and_the_rest_are_the_full_rows() {
    // Each family's lower bound is its own h less a nanometre (a distance is cheap; its
    // derivatives are not): a culled row's h is within that of the full row's, below it.
    let scenario = Scenario::with_obstacles(50, 5);
    let mut sim = Simulation::new(&scenario).unwrap();
    let params = sim.params().clone();
    let thresholds: Vec<f64> = scenario.settings.families.iter().map(|f| f.activation).collect();
    let (mut culling, mut full) =
        (Barriers::new(params.capacity()).unwrap(), Barriers::new(params.capacity()).unwrap());
    culling.cull_above(&thresholds);
    let mut culled = 0;
    while sim.time() < scenario.duration {
        let x: [f64; NX] = *sim.state();
        if sim.time() % 0.25 < 1e-6 {
            culling.evaluate(0.0, &x, &params).unwrap();
            full.evaluate(0.0, &x, &params).unwrap();
            for (a, b) in culling.rows().iter().zip(full.rows()) {
                if a.culled {
                    culled += 1;
                    assert!(a.h() <= b.h() && b.h() - a.h() <= 1.1e-9, "bound {} against h {}", a.h(), b.h());
                } else {
                    assert_eq!(a.lie.map(f64::to_bits), b.lie.map(f64::to_bits));
                    assert_eq!(a.lg.map(f64::to_bits), b.lg.map(f64::to_bits));
                }
            }
        }
        sim.step().unwrap();
    }
    assert!(culled > 1000, "{culled}");
}

#[test]
fn obstacles_are_drawn_as_oscbf_draws_them_and_clear_of_the_start() {
    let obstacles = random_obstacles(200, 9);
    assert_eq!(obstacles, random_obstacles(200, 9), "seeded");
    for o in &obstacles {
        assert!((0.2..0.8).contains(&o.center[0]) && (-0.4..0.4).contains(&o.center[1]));
        assert!((0.1..0.3).contains(&o.center[2]) && (0.01..0.1).contains(&o.radius));
    }
}

#[test]
fn bad_scenarios_are_typed_errors() {
    let mut s = Scenario::with_obstacles(2, 1);
    s.obstacles[0].radius = -0.1;
    assert!(matches!(Simulation::new(&s), Err(cbfgen::CbfError::ParamOutOfDomain { .. })), "a negative radius");
    let mut s = Scenario::with_obstacles(2, 1);
    s.obstacles[1].center[2] = f64::NAN;
    assert!(matches!(Simulation::new(&s), Err(cbfgen::CbfError::ParamOutOfDomain { .. })), "a NaN centre");
    let mut s = Scenario::with_obstacles(0, 1);
    s.obstacles =
        vec![
            s.obstacles.first().copied().unwrap_or(cbfgen_panda_spheres::Obstacle { center: [0.5; 3], radius: 0.05 });
            65
        ];
    assert!(Simulation::new(&s).is_err(), "too many obstacles");
    let mut s = Scenario::with_obstacles(2, 1);
    s.duration = f64::INFINITY;
    assert!(Simulation::new(&s).is_err(), "an infinite duration");
}

#[test]
fn every_straight_line_kernel_performs_the_operations_its_table_states() {
    // Run on numbers that count (cbfgen::ops::Counted), against the generator's count; the
    // members assembled on a frame's jet and the walked dynamics state none.
    let checked = cbfgen::ops::check_stated(gen::run_counted_kernels::<cbfgen::ops::Counted>)
        .unwrap_or_else(|m| panic!("{m:#?}"));
    assert_eq!(checked, gen::KERNELS.iter().filter(|k| k.ops.is_some()).count());
    assert!(checked >= 90, "{checked} kernels counted");
}
