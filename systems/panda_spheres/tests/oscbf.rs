//! OSCBF's setting on cbfgen: the torque-controlled arm's spheres against random sphere
//! obstacles and a table, checked by the exact sphere distances of every cycle (from the
//! generated forward kinematics, itself checked against Pinocchio and SymEngine).

use cbfgen::dual::Dual;
use cbfgen::filter::InputSource;
use cbfgen::interval::Interval;
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
    // members assembled on a frame's jet and the walked dynamics state none in the table
    // (evaluation_ops counts them: the test below).
    let checked = cbfgen::ops::check_stated(gen::run_counted_kernels::<cbfgen::ops::Counted>)
        .unwrap_or_else(|m| panic!("{m:#?}"));
    assert_eq!(checked, gen::KERNELS.iter().filter(|k| k.ops.is_some()).count());
    assert!(checked >= 90, "{checked} kernels counted");
}

#[test]
fn evaluation_ops_is_what_evaluate_performs_in_its_kernels_and_frames_with_every_slot_filled() {
    // evaluate's calls replayed on numbers that count (cbfgen::ops::Counted): each node of
    // the kinematic tree once (its jet and its value), each sphere computed on its link's
    // frame (or, alone on its link, from the state), its lower bound first. Every row the
    // replay computes is the one evaluate stored, bit for bit, so the calls are evaluate's
    // own; with every slot filled and nothing culled, the stated count is exact. The rows in
    // torques add the dynamics (counted once: the walk does not branch on the numbers, which
    // random states check) and the map to torques (checked in the core).
    use cbfgen::ops::Counted;
    use cbfgen::system::Row;
    use cbfgen_panda_spheres::generated::{Capacity, Params, SphereObstacleParams, TableParams, NU};
    use cbfgen_panda_spheres::TorqueRows;

    const TABLE: f64 = -0.05;
    fn row<const L: usize, const C: usize>(lie: &[Counted; L], lg: &[Counted; C], columns: &[usize; C]) -> Row<NU> {
        let mut row = Row::ZERO;
        row.store(&lie.map(|v| v.0), &lg.map(|v| v.0), columns);
        row
    }
    let mut r = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(62);
    for n in [1, 4] {
        let obstacles: Vec<SphereObstacleParams> = random_obstacles(n, 7)
            .iter()
            .map(|o| SphereObstacleParams { center: o.center.into(), radius: o.radius })
            .collect();
        let capacity = Capacity { sphere_obstacle: [n; 20], table: [1; 18] };
        let mut params = Params::new(capacity).unwrap();
        for member in &mut params.sphere_obstacle {
            for o in &obstacles {
                member.push(*o).unwrap();
            }
        }
        for member in &mut params.table {
            member.push(TableParams { height: TABLE }).unwrap();
        }
        let mut barriers = Barriers::new(capacity).unwrap();
        let stated = barriers.evaluation_ops().expect("every sphere kernel states its count");
        let x: [f64; NX] = std::array::from_fn(|i| {
            let q = rand::Rng::random_range(&mut r, -1.0..1.0);
            if i < NU {
                q
            } else {
                2.0 * q
            }
        });
        barriers.evaluate(0.0, &x, &params).unwrap();
        let (replayed, count) = Counted::measure(|| {
            let xc = x.map(Counted);
            let mut out: Vec<Row<NU>> = Vec::new();
            let ((_, j2, j3, j4, j5, j6, j7), [_, v2, v3, v4, v5, v6, v7]) = cbfgen_testkit::panda_tree!(gen, &xc);
            // Each member, instance by instance: its bound, then its row; on its link's frame
            // (the jet and value of the tree above), or alone on its link, from its state
            // parts computed once. (Braces: one member a line.)
            macro_rules! members {
                (for $p:pat in $each:expr => $args:tt: $($kind:ident $($rest:ident)*;)*) => {$(
                    members!(@$kind [$($rest)*] for $p in $each => $args);
                )*};
                (@framed [$jet:ident $value:ident $bound:ident $rows:ident $columns:ident]
                 for $p:pat in $each:expr => ($($arg:expr),*)) => {
                    for $p in $each {
                        let _ = gen::$bound(&$value, $($arg),*);
                        let (lie, lg) = gen::$rows(&$jet, $($arg),*);
                        out.push(row(&lie[0], &lg[0], &gen::$columns));
                    }
                };
                (@split [$bound_state:ident $bound:ident $state:ident $rows:ident $columns:ident]
                 for $p:pat in $each:expr => ($($arg:expr),*)) => {
                    let (bound_part, state_part) = (gen::$bound_state(&xc), gen::$state(&xc));
                    for $p in $each {
                        let _ = gen::$bound(&bound_part, $($arg),*);
                        let (lie, lg) = gen::$rows(&state_part, $($arg),*);
                        out.push(row(&lie[0], &lg[0], &gen::$columns));
                    }
                };
            }
            members! { for o in &obstacles => (&o.center.map(Counted), Counted(o.radius)):
                split sphere_obstacle_link1_1_lower_bound_state sphere_obstacle_link1_1_lower_bound_instance sphere_obstacle_link1_1_state sphere_obstacle_link1_1_instance SPHERE_OBSTACLE_LINK1_1_INPUT_COLUMNS;
                framed j2 v2 sphere_obstacle_link2_2_lower_bound_from_frame sphere_obstacle_link2_2_from_frame SPHERE_OBSTACLE_LINK2_2_INPUT_COLUMNS;
                framed j2 v2 sphere_obstacle_link2_3_lower_bound_from_frame sphere_obstacle_link2_3_from_frame SPHERE_OBSTACLE_LINK2_3_INPUT_COLUMNS;
                framed j3 v3 sphere_obstacle_link3_4_lower_bound_from_frame sphere_obstacle_link3_4_from_frame SPHERE_OBSTACLE_LINK3_4_INPUT_COLUMNS;
                framed j3 v3 sphere_obstacle_link3_5_lower_bound_from_frame sphere_obstacle_link3_5_from_frame SPHERE_OBSTACLE_LINK3_5_INPUT_COLUMNS;
                framed j4 v4 sphere_obstacle_link4_6_lower_bound_from_frame sphere_obstacle_link4_6_from_frame SPHERE_OBSTACLE_LINK4_6_INPUT_COLUMNS;
                framed j4 v4 sphere_obstacle_link4_7_lower_bound_from_frame sphere_obstacle_link4_7_from_frame SPHERE_OBSTACLE_LINK4_7_INPUT_COLUMNS;
                framed j5 v5 sphere_obstacle_link5_8_lower_bound_from_frame sphere_obstacle_link5_8_from_frame SPHERE_OBSTACLE_LINK5_8_INPUT_COLUMNS;
                framed j5 v5 sphere_obstacle_link5_9_lower_bound_from_frame sphere_obstacle_link5_9_from_frame SPHERE_OBSTACLE_LINK5_9_INPUT_COLUMNS;
                framed j5 v5 sphere_obstacle_link5_10_lower_bound_from_frame sphere_obstacle_link5_10_from_frame SPHERE_OBSTACLE_LINK5_10_INPUT_COLUMNS;
                framed j5 v5 sphere_obstacle_link5_11_lower_bound_from_frame sphere_obstacle_link5_11_from_frame SPHERE_OBSTACLE_LINK5_11_INPUT_COLUMNS;
                framed j5 v5 sphere_obstacle_link5_12_lower_bound_from_frame sphere_obstacle_link5_12_from_frame SPHERE_OBSTACLE_LINK5_12_INPUT_COLUMNS;
                framed j6 v6 sphere_obstacle_link6_13_lower_bound_from_frame sphere_obstacle_link6_13_from_frame SPHERE_OBSTACLE_LINK6_13_INPUT_COLUMNS;
                framed j6 v6 sphere_obstacle_link6_14_lower_bound_from_frame sphere_obstacle_link6_14_from_frame SPHERE_OBSTACLE_LINK6_14_INPUT_COLUMNS;
                framed j7 v7 sphere_obstacle_link7_15_lower_bound_from_frame sphere_obstacle_link7_15_from_frame SPHERE_OBSTACLE_LINK7_15_INPUT_COLUMNS;
                framed j7 v7 sphere_obstacle_link7_16_lower_bound_from_frame sphere_obstacle_link7_16_from_frame SPHERE_OBSTACLE_LINK7_16_INPUT_COLUMNS;
                framed j7 v7 sphere_obstacle_link7_17_lower_bound_from_frame sphere_obstacle_link7_17_from_frame SPHERE_OBSTACLE_LINK7_17_INPUT_COLUMNS;
                framed j7 v7 sphere_obstacle_link7_18_lower_bound_from_frame sphere_obstacle_link7_18_from_frame SPHERE_OBSTACLE_LINK7_18_INPUT_COLUMNS;
                framed j7 v7 sphere_obstacle_link7_19_lower_bound_from_frame sphere_obstacle_link7_19_from_frame SPHERE_OBSTACLE_LINK7_19_INPUT_COLUMNS;
                framed j7 v7 sphere_obstacle_link7_20_lower_bound_from_frame sphere_obstacle_link7_20_from_frame SPHERE_OBSTACLE_LINK7_20_INPUT_COLUMNS;
            }
            members! { for height in [TABLE] => (Counted(height)):
                split table_link2_3_lower_bound_state table_link2_3_lower_bound_instance table_link2_3_state table_link2_3_instance TABLE_LINK2_3_INPUT_COLUMNS;
                framed j3 v3 table_link3_4_lower_bound_from_frame table_link3_4_from_frame TABLE_LINK3_4_INPUT_COLUMNS;
                framed j3 v3 table_link3_5_lower_bound_from_frame table_link3_5_from_frame TABLE_LINK3_5_INPUT_COLUMNS;
                framed j4 v4 table_link4_6_lower_bound_from_frame table_link4_6_from_frame TABLE_LINK4_6_INPUT_COLUMNS;
                framed j4 v4 table_link4_7_lower_bound_from_frame table_link4_7_from_frame TABLE_LINK4_7_INPUT_COLUMNS;
                framed j5 v5 table_link5_8_lower_bound_from_frame table_link5_8_from_frame TABLE_LINK5_8_INPUT_COLUMNS;
                framed j5 v5 table_link5_9_lower_bound_from_frame table_link5_9_from_frame TABLE_LINK5_9_INPUT_COLUMNS;
                framed j5 v5 table_link5_10_lower_bound_from_frame table_link5_10_from_frame TABLE_LINK5_10_INPUT_COLUMNS;
                framed j5 v5 table_link5_11_lower_bound_from_frame table_link5_11_from_frame TABLE_LINK5_11_INPUT_COLUMNS;
                framed j5 v5 table_link5_12_lower_bound_from_frame table_link5_12_from_frame TABLE_LINK5_12_INPUT_COLUMNS;
                framed j6 v6 table_link6_13_lower_bound_from_frame table_link6_13_from_frame TABLE_LINK6_13_INPUT_COLUMNS;
                framed j6 v6 table_link6_14_lower_bound_from_frame table_link6_14_from_frame TABLE_LINK6_14_INPUT_COLUMNS;
                framed j7 v7 table_link7_15_lower_bound_from_frame table_link7_15_from_frame TABLE_LINK7_15_INPUT_COLUMNS;
                framed j7 v7 table_link7_16_lower_bound_from_frame table_link7_16_from_frame TABLE_LINK7_16_INPUT_COLUMNS;
                framed j7 v7 table_link7_17_lower_bound_from_frame table_link7_17_from_frame TABLE_LINK7_17_INPUT_COLUMNS;
                framed j7 v7 table_link7_18_lower_bound_from_frame table_link7_18_from_frame TABLE_LINK7_18_INPUT_COLUMNS;
                framed j7 v7 table_link7_19_lower_bound_from_frame table_link7_19_from_frame TABLE_LINK7_19_INPUT_COLUMNS;
                framed j7 v7 table_link7_20_lower_bound_from_frame table_link7_20_from_frame TABLE_LINK7_20_INPUT_COLUMNS;
            }
            out
        });
        let rows = barriers.rows();
        assert_eq!(replayed.len(), rows.len(), "{n} obstacles");
        for (k, (row, replayed)) in rows.iter().zip(&replayed).enumerate() {
            assert!(row.active && !row.culled, "{n} obstacles: row {k}");
            assert_eq!((row.lie, row.lg), (replayed.lie, replayed.lg), "{n} obstacles: row {k}");
        }
        assert_eq!(stated, count, "{n} obstacles: stated {stated}, counted {count}");
        // In torques: the dynamics' count is the same at every state.
        let dynamics = gen::dynamics_ops();
        for _ in 0..20 {
            let x: [f64; NX] = std::array::from_fn(|_| rand::Rng::random_range(&mut r, -3.0..3.0));
            assert_eq!(Counted::measure(|| gen::dynamics(&x.map(Counted))).1, dynamics);
        }
        assert!(dynamics.total() > 1000, "{dynamics}");
        // On dual numbers (the certificate's rates), within what `dual_ops` states, at
        // random states and rates.
        let on_duals = cbfgen::dual::dual_ops(dynamics);
        for _ in 0..5 {
            let x: [Dual<Counted>; NX] = std::array::from_fn(|_| Dual {
                v: Counted(rand::Rng::random_range(&mut r, -3.0..3.0)),
                d: Counted(rand::Rng::random_range(&mut r, -3.0..3.0)),
            });
            let counted = Counted::measure(|| gen::dynamics(&x)).1;
            assert!(counted.total() <= on_duals.total() && counted.mul <= on_duals.mul, "{counted} against {on_duals}");
        }
        let torques = TorqueRows::new(barriers, gen::dynamics);
        assert_eq!(torques.evaluation_ops(), None, "without the dynamics' count");
        let torques = torques.with_dynamics_ops(dynamics);
        let rows = torques.rows().len();
        assert_eq!(torques.evaluation_ops(), Some(stated + dynamics + cbfgen::torque::torque_map_ops(NU, rows)));
        // The enclosure's count needs the interval forms too; its field is at least the
        // interval dynamics and one interval solve.
        assert_eq!(torques.enclosure_ops(), None, "without the interval forms");
        let torques = torques.with_interval_dynamics(gen::dynamics::<Interval>, gen::dynamics::<Dual<Interval>>);
        let enclosure = torques.enclosure_ops().expect("stated with every part");
        let solve = cbfgen::interval::solve_linear_ops(NU);
        assert!(enclosure.field.total() > dynamics.total() + solve.total(), "{enclosure:?}");
        assert!(enclosure.refine.total() > on_duals.total() + 2 * solve.total(), "{enclosure:?}");
        println!("{n} obstacle(s) per sphere: rows {stated}; dynamics {dynamics}");
    }
}
