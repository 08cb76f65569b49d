//! Parameter domains (issue 32): every built-in family refuses geometry that is not
//! geometry — half extents ≤ 0, matrices that are not proper rotations, normals that are
//! not unit, NaN — through the run-time door (`cbfgen::dynamic`), the typed helpers and
//! the typed barrier set and filter, with a `ParamOutOfDomain` naming family, member,
//! instance and parameter, and changes nothing. The truths: the hand-written path
//! (`OrientedBox::new`, which Tachyon 3's `Environment::push_edge` goes through) refuses
//! and accepts exactly the same edge cuboids, the exact SAT shows what a refused box
//! would have been certified as, and the domains written out by hand.

use cbfgen::dynamic::{CapacityCount, DynSystem, Registry};
use cbfgen::geometry::{MAX_HALF_EXTENT, MIN_HALF_EXTENT, ROTATION_TOLERANCE};
use cbfgen::param_domain::{Domain, Found};
use cbfgen::system::BarrierSet;
use cbfgen::{sat, CbfError, OrientedBox};
use cbfgen_double_integrator as di;
use cbfgen_panda::generated as panda;
use cbfgen_tachyon3::catalog::{self, Capacity, Catalog, EdgeCuboid, Environment, HalfPlane};
use cbfgen_tachyon3::generated as t3;
use cbfgen_tachyon3::model::standard_posture;
use nalgebra::{Matrix3, Rotation3, Vector3};

const EDGE_ROTATION: Domain = Domain::Rotation { tolerance: ROTATION_TOLERANCE };
const EDGE_HALF: Domain = Domain::Interval { lo: MIN_HALF_EXTENT, hi: MAX_HALF_EXTENT };

static SYSTEMS: Registry = Registry::new(&[di::SYSTEM, panda::SYSTEM, t3::SYSTEM]);

fn system(name: &str) -> &'static dyn DynSystem {
    SYSTEMS.get(name).expect("built in")
}

/// A box's 15 numbers in the kernels' layout: centre, rotation row by row, half extents.
fn flat(center: Vector3<f64>, rotation: &Matrix3<f64>, half: Vector3<f64>) -> Vec<f64> {
    let row = |i: usize| [rotation[(i, 0)], rotation[(i, 1)], rotation[(i, 2)]];
    [[center.x, center.y, center.z], row(0), row(1), row(2), [half.x, half.y, half.z]].concat()
}

/// An edge cuboid that is no box, what its domain refuses in it and what is found there.
struct Bad {
    what: &'static str,
    center: Vector3<f64>,
    rotation: Matrix3<f64>,
    half: Vector3<f64>,
    param: &'static str,
    domain: Domain,
    found: Found,
}

fn bad_edges() -> Vec<Bad> {
    let center = Vector3::new(0.8, 0.0, 0.06);
    let half = Vector3::new(0.02, 1.0, 0.02);
    let id = Matrix3::identity();
    let mut skewed = id;
    skewed[(0, 1)] = 1e-7; // column 0 · column 1 = 1e-7, 100 × the tolerance
    let entry = |index, value| Found::Entry { index, value };
    let bad =
        |what, center, rotation, half, param, domain, found| Bad { what, center, rotation, half, param, domain, found };
    vec![
        bad("negative half extents", center, id, Vector3::new(-0.3, -1.0, -0.3), "half", EDGE_HALF, entry(0, -0.3)),
        bad("a zero half extent", center, id, Vector3::new(0.02, 0.0, 0.02), "half", EDGE_HALF, entry(1, 0.0)),
        bad(
            "a half extent below the smallest",
            center,
            id,
            Vector3::new(0.02, 1.0, 1e-7),
            "half",
            EDGE_HALF,
            entry(2, 1e-7),
        ),
        bad(
            "a half extent above the largest",
            center,
            id,
            Vector3::new(2e4, 1.0, 0.02),
            "half",
            EDGE_HALF,
            entry(0, 2e4),
        ),
        bad("2 I", center, id * 2.0, half, "rotation", EDGE_ROTATION, Found::Orthonormality(3.0)),
        bad(
            "a reflection",
            center,
            Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0)),
            half,
            "rotation",
            EDGE_ROTATION,
            Found::Determinant(-1.0),
        ),
        bad("the zero matrix", center, Matrix3::zeros(), half, "rotation", EDGE_ROTATION, Found::Orthonormality(1.0)),
        bad(
            "a rotation skewed beyond the tolerance",
            center,
            skewed,
            half,
            "rotation",
            EDGE_ROTATION,
            Found::Orthonormality(1e-7),
        ),
        bad(
            "a centre beyond PARAM_LIMIT",
            Vector3::new(0.8, 2e6, 0.06),
            id,
            half,
            "center",
            Domain::Real,
            entry(1, 2e6),
        ),
    ]
}

/// Proper rotations within the tolerance: built from angles, and skewed by half the tolerance.
fn good_rotations() -> [Matrix3<f64>; 2] {
    let mut skewed = Matrix3::identity();
    skewed[(0, 1)] = 0.5 * ROTATION_TOLERANCE;
    [*Rotation3::from_euler_angles(0.3, -0.2, 0.5).matrix(), skewed]
}

fn refusal(family: &'static str, member: Option<&'static str>, instance: usize, b: &Bad) -> CbfError {
    CbfError::ParamOutOfDomain {
        family,
        member,
        instance: Some(instance),
        param: b.param,
        domain: b.domain,
        found: b.found,
    }
}

#[test]
fn the_edge_domains_are_the_oriented_box_domains() {
    // The spec's (systems/tachyon3/spec/tachyon3.py) against the hand-written constants.
    let want = [("center", Domain::Real), ("rotation", EDGE_ROTATION), ("half", EDGE_HALF)];
    assert_eq!(t3::BodyEdgeParams::DOMAINS, want);
    assert_eq!(t3::ToeEdgeParams::DOMAINS, want);
    assert_eq!(t3::FootholdParams::DOMAINS[0], ("normal", Domain::UnitVector { tolerance: 1e-9 }));
    // The arm declares none: prim.Box gives its obstacle boxes theirs.
    let from_prim = [("center", Domain::Real), ("rotation", EDGE_ROTATION), ("half", Domain::Positive)];
    assert_eq!(panda::ObstacleParams::DOMAINS, from_prim);
    assert_eq!(di::SineBarrierParams::DOMAINS.map(|(_, d)| d), [Domain::Real; 3]);
}

#[test]
fn a_box_through_the_body_with_negative_half_extents_would_read_certified_clear_and_is_refused() -> Result<(), CbfError>
{
    // The reproducer: a box centred in the body with half extents (−0.3, −1, −0.3).
    let x = standard_posture();
    let (body_center, body_rotation, _) = t3::world_kinematics(&x);
    let center = Vector3::from(body_center);
    let half = Vector3::new(-0.3, -1.0, -0.3);
    let (lie, _) = t3::body_edge(&x, &center, &Matrix3::identity(), &half);
    assert!(lie[0][0] > 0.5, "the kernel reads the box as clear: h = {}", lie[0][0]);
    // The box it stands for (|half|) overlaps the body by the exact SAT.
    let rows = |r: [[f64; 3]; 3]| Matrix3::from_fn(|i, j| r[i][j]);
    let body = OrientedBox::new(
        center,
        Rotation3::from_matrix_unchecked(rows(body_rotation)),
        Vector3::from(t3::BODY_HALF_EXTENTS),
    )?;
    let abs_box = OrientedBox::axis_aligned(center, half.abs())?;
    assert!(sat::overlaps(&body, &abs_box));

    // Refused by both doors, and the filter never sees it.
    let sys = system("tachyon3");
    let body_edge = sys.family_index("body_edge")?;
    let mut p = sys.params(&[CapacityCount { family: body_edge, member: 0, count: 2 }])?;
    let pushed = p.push(body_edge, 0, &flat(center, &Matrix3::identity(), half));
    let b = &bad_edges()[0];
    assert_eq!(pushed, Err(refusal("body_edge", None, 0, b)));
    assert_eq!(
        pushed.unwrap_err().to_string(),
        "body_edge instance 0: parameter half is outside its domain (in [1e-6, 10000]): half[0] = -0.3"
    );
    assert_eq!(p.store(body_edge, 0)?.len(), 0);
    let mut env = Environment::new(Capacity::edges(2, [0; 6]))?;
    let cuboid = EdgeCuboid { center, rotation: Matrix3::identity(), half };
    assert_eq!(env.push_edge(cuboid), Err(refusal("body_edge", None, 0, b)));
    assert!(env.edges().is_empty() && env.toe_edge.as_slice().is_empty());
    Ok(())
}

#[test]
fn every_edge_family_refuses_what_oriented_box_refuses_and_keeps_its_parameters() -> Result<(), CbfError> {
    let sys = system("tachyon3");
    let good = OrientedBox::new(
        Vector3::new(0.8, 0.0, 0.06),
        Rotation3::from_euler_angles(0.0, 0.0, 0.05),
        Vector3::new(0.02, 1.0, 0.02),
    )?;
    let good_numbers = flat(*good.center(), good.rotation().matrix(), *good.half_extents());
    for family in ["body_edge", "toe_edge"] {
        let f = sys.family_index(family)?;
        let mut p = sys.params(&[CapacityCount { family: f, member: 0, count: 3 }])?;
        p.push(f, 0, &good_numbers)?;
        let before = p.clone_box();
        for b in bad_edges() {
            // The hand-written path refuses the same box.
            let oriented = OrientedBox::new(b.center, Rotation3::from_matrix_unchecked(b.rotation), b.half);
            assert!(oriented.is_err(), "{}: OrientedBox::new accepts it", b.what);
            let numbers = flat(b.center, &b.rotation, b.half);
            assert_eq!(p.push(f, 0, &numbers), Err(refusal(family, None, 1, &b)), "{family}: push {}", b.what);
            assert_eq!(p.set(f, 0, 0, &numbers), Err(refusal(family, None, 0, &b)), "{family}: set {}", b.what);
            assert_eq!(
                p.downcast_ref::<t3::Params>(),
                before.downcast_ref::<t3::Params>(),
                "{family}: {} changed the parameters",
                b.what
            );
        }
        // NaN anywhere: refused as not finite, naming the entry.
        let mut numbers = good_numbers.clone();
        numbers[13] = f64::NAN; // half extent 1
        let nan = p.set(f, 0, 0, &numbers).expect_err("NaN refused");
        assert!(
            matches!(nan, CbfError::ParamOutOfDomain { param: "half", instance: Some(0), domain: Domain::Real,
                found: Found::Entry { index: 1, value }, .. } if value.is_nan()),
            "{nan:?}"
        );
        // Proper rotations within the tolerance are accepted, as OrientedBox accepts them.
        for rotation in good_rotations() {
            let half = Vector3::new(0.02, 1.0, 0.02);
            OrientedBox::new(good.center().to_owned(), Rotation3::from_matrix_unchecked(rotation), half)?;
            p.set(f, 0, 0, &flat(*good.center(), &rotation, half))?;
            let mut got = vec![0.0; 15];
            p.store(f, 0)?.get(0, &mut got)?;
            assert_eq!(got, flat(*good.center(), &rotation, half));
        }
        p.push(f, 0, &flat(*good.center(), &good_rotations()[1], Vector3::new(MIN_HALF_EXTENT, MAX_HALF_EXTENT, 1.0)))?;
    }
    Ok(())
}

#[test]
fn foothold_normals_must_be_unit_and_the_member_is_named() -> Result<(), CbfError> {
    let sys = system("tachyon3");
    let hold = sys.family_index("foothold")?;
    let mut p = sys.params(&[CapacityCount { family: hold, member: 2, count: 2 }])?;
    let plane = HalfPlane::new([3.0, -4.0], 1.0)?; // stored as the unit normal (0.6, −0.8)
    p.push(hold, 2, &[plane.normal.x, plane.normal.y, plane.offset])?;
    let normal = |value| CbfError::ParamOutOfDomain {
        family: "foothold",
        member: Some("rf"),
        instance: Some(1),
        param: "normal",
        domain: Domain::UnitVector { tolerance: 1e-9 },
        found: Found::Norm(value),
    };
    assert_eq!(p.push(hold, 2, &[3.0, -4.0, 1.0]), Err(normal(5.0)));
    assert_eq!(p.push(hold, 2, &[0.0, 0.0, 1.0]), Err(normal(0.0)));
    assert_eq!(p.store(hold, 2)?.len(), 1);
    // A full list and a missing slot are refused as such, whatever the values.
    p.push(hold, 2, &[1.0, 0.0, 0.5])?;
    let full = CbfError::CapacityExceeded { what: "foothold", capacity: 2 };
    assert_eq!(p.push(hold, 2, &[0.0, 0.0, 1.0]), Err(full));
    assert_eq!(p.set(hold, 2, 2, &[0.0, 0.0, 1.0]), Err(CbfError::NoSuchIndex { what: "instance", index: 2, len: 2 }));
    Ok(())
}

#[test]
fn typed_parameters_written_directly_are_refused_when_evaluated_and_by_the_filter() -> Result<(), CbfError> {
    let capacity = Capacity::edges(2, [0; 6]);
    let mut env = Environment::new(capacity)?;
    let good = OrientedBox::axis_aligned(Vector3::new(0.8, 0.0, 0.06), Vector3::new(0.02, 1.0, 0.02))?;
    env.push_edge(EdgeCuboid::from_box(&good))?;
    env.push_edge(EdgeCuboid::from_box(&good))?;
    let mut catalog = Catalog::new(capacity)?;
    let mut filter = t3::Filter::new(Catalog::new(capacity)?, catalog::default_settings())?;
    let x = standard_posture();
    let u_ref = [0.0; t3::NU];
    filter.update(&x, &u_ref, &env)?;
    let before = *filter.output();
    for b in bad_edges() {
        let mut bad = env.clone();
        let edge = &mut bad.toe_edge.as_mut_slice()[1];
        (edge.center, edge.rotation, edge.half) = (b.center, b.rotation, b.half);
        let want = refusal("toe_edge", None, 1, &b);
        assert_eq!(catalog.evaluate(&x, &bad), Err(want.clone()), "{}", b.what);
        assert_eq!(filter.update(&x, &u_ref, &bad).map(|o| o.u), Err(want), "{}", b.what);
        assert_eq!(*filter.output(), before, "{} changed the filter", b.what);
    }
    Ok(())
}

#[test]
fn the_arm_refuses_obstacle_boxes_that_are_not_boxes_naming_the_link() -> Result<(), CbfError> {
    let sys = system("panda");
    let obstacle = sys.family_index("obstacle")?;
    let link3 = 2;
    let mut p = sys.params(&[CapacityCount { family: obstacle, member: link3, count: 2 }])?;
    let center = Vector3::new(0.5, 0.0, 0.3);
    let (id, half) = (Matrix3::identity(), Vector3::new(0.1, 0.2, 0.3));
    p.push(obstacle, link3, &flat(center, &id, half))?;
    let before = p.clone_box();
    let refused = |param, domain, found| CbfError::ParamOutOfDomain {
        family: "obstacle",
        member: Some("link3"),
        instance: Some(1),
        param,
        domain,
        found,
    };
    let reflection = Matrix3::from_diagonal(&Vector3::new(-1.0, 1.0, 1.0));
    let cases = [
        (id, Vector3::new(0.1, -0.2, 0.3), refused("half", Domain::Positive, Found::Entry { index: 1, value: -0.2 })),
        (id, Vector3::new(0.0, 0.2, 0.3), refused("half", Domain::Positive, Found::Entry { index: 0, value: 0.0 })),
        (id * 2.0, half, refused("rotation", EDGE_ROTATION, Found::Orthonormality(3.0))),
        (reflection, half, refused("rotation", EDGE_ROTATION, Found::Determinant(-1.0))),
        (Matrix3::zeros(), half, refused("rotation", EDGE_ROTATION, Found::Orthonormality(1.0))),
    ];
    for (rotation, half, want) in cases {
        assert_eq!(p.push(obstacle, link3, &flat(center, &rotation, half)), Err(want));
    }
    assert_eq!(p.downcast_ref::<panda::Params>(), before.downcast_ref::<panda::Params>());
    for rotation in good_rotations() {
        p.set(obstacle, link3, 0, &flat(center, &rotation, half))?;
    }

    // The typed barrier set re-checks what was written past the door, naming the link.
    let mut counts = [0; panda::OBSTACLE_MEMBERS.len()];
    counts[link3] = 1;
    let mut typed = panda::Params::new(panda::Capacity { obstacle: counts })?;
    typed.obstacle[link3].push(panda::ObstacleParams { center, rotation: reflection, half })?;
    let mut barriers = panda::Barriers::new(typed.capacity())?;
    let got = barriers.evaluate(0.0, &[0.0; panda::NX], &typed);
    assert!(
        matches!(got, Err(CbfError::ParamOutOfDomain { member: Some("link3"), instance: Some(0), param: "rotation",
            found: Found::Determinant(d), .. }) if d == -1.0),
        "{got:?}"
    );
    Ok(())
}

#[test]
fn a_non_finite_scalar_parameter_is_refused_by_name() -> Result<(), CbfError> {
    let sys = system("double_integrator");
    let mut p = sys.params(&[])?;
    let sine = sys.family_index("sine_barrier")?;
    p.set(sine, 0, 0, &[0.2, 2.0, -0.5])?;
    let got = p.set(sine, 0, 0, &[0.2, f64::INFINITY, -0.5]);
    assert_eq!(
        got,
        Err(CbfError::ParamOutOfDomain {
            family: "sine_barrier",
            member: None,
            instance: Some(0),
            param: "omega",
            domain: Domain::Real,
            found: Found::Value(f64::INFINITY),
        })
    );
    let mut out = [0.0; 3];
    p.store(sine, 0)?.get(0, &mut out)?;
    assert_eq!(out, [0.2, 2.0, -0.5]);
    Ok(())
}
