//! Far rows are culled, never rows that could act: the spec's lower bounds
//! (`body_edge_lower_bound`, `toe_edge_lower_bound`) are never above any row's `h` over
//! random states and edge cuboids — near, touching, overlapping and far — and a filter
//! that culls and one that evaluates every row give the same input, bit for bit, on the
//! stairs run.

use cbfgen_testkit::boxes::{random_rotation, rng};
#[path = "common/tachyon3_state.rs"]
mod tachyon3_state;

use cbfgen_tachyon3::catalog::Family;
use cbfgen_tachyon3::generated as gen;
use cbfgen_tachyon3::sim::{self, Scenario, SimConfig};
use nalgebra::Vector3;
use rand::Rng;
use tachyon3_state::random_state;

/// An edge cuboid's kernel arguments: centre within `spread` m of the body centre, a
/// uniformly random orientation, half extents from 5 mm to 1 m.
fn random_cuboid(r: &mut impl Rng, body: &[f64; 3], spread: f64) -> ([f64; 3], [f64; 9], [f64; 3]) {
    let c = Vector3::from(*body) + Vector3::from_fn(|_, _| r.random_range(-spread..spread));
    let m = random_rotation(r).into_inner();
    let half = [0.0; 3].map(|_: f64| 10f64.powf(r.random_range(-2.3..0.0)));
    (
        c.into(),
        [m[(0, 0)], m[(0, 1)], m[(0, 2)], m[(1, 0)], m[(1, 1)], m[(1, 2)], m[(2, 0)], m[(2, 1)], m[(2, 2)]],
        half,
    )
}

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
        let (c, rot, half) = random_cuboid(&mut r, &body, spread);

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
