//! Far rows are culled, never rows that could act: the spec's lower bounds
//! (`body_edge_lower_bound`, `toe_edge_lower_bound`) are never above any row's `h` over
//! random states and edge cuboids — near, touching, overlapping and far —, the catalog
//! puts every evaluated instance's rows where the one-instance kernel's belong, and a
//! filter that culls and one that evaluates every row give the same input, bit for bit,
//! on the stairs run.

use crate::tachyon3_state;
use cbfgen_testkit::boxes::{random_rotation, rng};

use cbfgen::system::BarrierSet;
use cbfgen::OrientedBox;
use cbfgen_tachyon3::catalog::{self, Capacity, Catalog, EdgeCuboid, Environment, Family};
use cbfgen_tachyon3::generated as gen;
use cbfgen_tachyon3::sim::{self, Scenario, SimConfig};
use nalgebra::Vector3;
use rand::Rng;
use tachyon3_state::random_state;

#[test]
fn lower_bounds_are_never_above_the_rows_they_stand_for() {
    let mut r = rng(34);
    let activation = gen::default_settings();
    let [body_threshold, toe_threshold] =
        [Family::BodyEdge, Family::ToeEdge].map(|f| activation.family(f.index()).activation);
    let (mut body_culled, mut toe_culled, mut tightest) = (0, 0, f64::INFINITY);
    let cases = 200_000;
    for k in 0..cases {
        let x = random_state(&mut r);
        let (body, _, _) = gen::world_kinematics(&x);
        // Most cuboids near the robot (touching and overlapping among them), a quarter far.
        let spread = if k % 4 == 0 { 4.0 } else { 0.8 };
        let (c, rot, half) = random_edge(&mut r, &body, spread).kernel_args();

        let bound = gen::body_edge_lower_bound(&x, &c, &rot, &half);
        let (lie, _) = gen::body_edge(&x, &c, &rot, &half);
        let h = lie[0][0];
        assert!(bound <= h, "body: bound {bound} above h {h} at x {x:?}, cuboid {c:?} {rot:?} {half:?}");
        tightest = tightest.min(h - bound);
        body_culled += usize::from(bound > body_threshold);

        let bound = gen::toe_edge_lower_bound(&x, &c, &rot, &half);
        let (lie, _) = gen::toe_edge(&x, &c, &rot, &half);
        for (leg, row) in lie.iter().enumerate() {
            assert!(bound <= row[0], "toe {leg}: bound {bound} above h {} at x {x:?}, cuboid {c:?}", row[0]);
        }
        toe_culled += usize::from(bound > toe_threshold);
    }
    // Not vacuous: both bounds cull a good share of these cases, and the body's comes
    // within a centimetre of h somewhere.
    assert!(body_culled > cases / 10 && toe_culled > cases / 10, "culled {body_culled}, {toe_culled} of {cases}");
    assert!(tightest < 1e-2, "the body bound never came near h: {tightest}");
}

/// An edge cuboid with its centre within `spread` m of the body centre, a uniformly random
/// orientation and half extents from 5 mm to 1 m.
fn random_edge(r: &mut impl Rng, body: &[f64; 3], spread: f64) -> EdgeCuboid {
    let c = Vector3::from(*body) + Vector3::from_fn(|_, _| r.random_range(-spread..spread));
    let half = Vector3::from_fn(|_, _| 10f64.powf(r.random_range(-2.3..0.0)));
    EdgeCuboid::from_box(&OrientedBox::new(c, random_rotation(r), half).expect("valid box"))
}

fn bits<const R: usize, const C: usize>(m: &[[f64; C]; R]) -> Vec<u64> {
    m.iter().flatten().map(|v| v.to_bits()).collect()
}

#[test]
fn the_catalog_culls_far_instances_and_evaluates_the_rest_in_place() {
    let mut r = rng(342);
    let capacity = Capacity::PAPER_WORST_CASE;
    let mut catalog = Catalog::new(capacity).expect("rows");
    let thresholds: Vec<f64> = catalog::default_settings().families.iter().map(|f| f.activation).collect();
    catalog.cull_above(&thresholds);
    let (mut culled, mut evaluated) = (0, 0);
    for case in 0..300 {
        let x = random_state(&mut r);
        let (body, _, _) = gen::world_kinematics(&x);
        let mut env = Environment::new(capacity).expect("environment");
        // From none to all 20 edges, culled ones among them.
        for _ in 0..case % (capacity.body_edge + 1) {
            env.push_edge(random_edge(&mut r, &body, 1.5)).expect("capacity");
        }
        catalog.evaluate(&x, &env).expect("finite");
        for (row, slot) in catalog.rows().iter().zip(catalog.slots()) {
            let Some(edge) = env.edges().get(slot.instance) else { continue };
            let (c, rot, h) = edge.kernel_args();
            let want = match slot.family {
                Family::BodyEdge => gen::body_edge(&x, &c, &rot, &h).0[0],
                Family::ToeEdge => gen::toe_edge(&x, &c, &rot, &h).0[slot.leg.expect("a toe row has a leg")],
                _ => continue,
            };
            if row.culled {
                culled += 1;
                assert!(row.h() <= want[0]);
            } else {
                evaluated += 1;
                assert_eq!(row.lie[..3].iter().map(|v| v.to_bits()).collect::<Vec<_>>(), bits(&[want]));
            }
        }
    }
    assert!(culled > 1000 && evaluated > 1000, "culled {culled}, evaluated {evaluated}");
}

#[test]
fn culling_changes_no_input_on_the_stairs_run() {
    let culled = SimConfig::new(Scenario::Stairs, true);
    assert!(culled.filter.cull_far_rows, "culling is the default");
    let mut full = culled.clone();
    full.filter.cull_far_rows = false;
    let [a, b] = [&culled, &full].map(|c| sim::run(c, |_| {}).expect("simulation"));
    assert_eq!(a.samples.len(), b.samples.len());
    for (sa, sb) in a.samples.iter().zip(&b.samples) {
        // Same state every cycle means the same input every cycle before it.
        assert_eq!(sa.x.map(f64::to_bits), sb.x.map(f64::to_bits), "t = {}", sa.t);
        assert_eq!((sa.source, sa.active_rows, sa.relaxed_rows), (sb.source, sb.active_rows, sb.relaxed_rows));
    }
    assert!(a.summary.completed);
}

#[test]
fn a_filter_without_culling_evaluates_every_row_whatever_its_barriers_were_told() {
    // Thresholds set on the catalog before the filter takes it are overridden: with
    // cull_far_rows off, nothing is culled, and on the same state the culling filter is.
    let config = SimConfig::new(Scenario::Stairs, true);
    let mut course = sim::Course::new(config.scenario, config.gait).expect("course");
    let x = course.initial_state(config.start_gap);
    let u_ref = course.plan(0.0, &x).expect("plan").u_ref;
    let mut counts = Vec::new();
    for cull_far_rows in [false, true] {
        let mut catalog = Catalog::new(sim::Course::CAPACITY).expect("rows");
        catalog.cull_above(&[0.0; 6]); // would cull nearly everything
        let settings = cbfgen::filter::FilterSettings { cull_far_rows, ..config.filter.clone() };
        let mut filter = cbfgen::filter::EcbfFilter::new(catalog, settings).expect("filter");
        filter.update(&x, &u_ref, course.environment()).expect("finite");
        counts.push(filter.rows().iter().filter(|r| r.culled).count());
    }
    assert_eq!(counts[0], 0);
    assert!(counts[1] > 0, "the stairs' far edges are culled by the default filter");
}
