//! A user's spec (`boxed_robot`) gets its parameters' domains from the primitives it uses,
//! with no declaration: the generated checks refuse boxes that are not boxes, negative
//! radii and inflations, non-unit normals and NaN, through the run-time door and the typed
//! barrier set, naming family, member, instance and parameter; a fixed instance never set
//! (the zero box) is refused when the rows are evaluated or the filter updated, not
//! filtered against. The truths: the domains written out by hand from the primitives'
//! documentation, and the values handed in.

use cbfgen::dynamic::{CapacityCount, DynSystem};
use cbfgen::nalgebra::{Matrix3, Vector2, Vector3};
use cbfgen::param_domain::{Domain, Found};
use cbfgen::system::BarrierSet;
use cbfgen::CbfError;
use spec_crate::boxed_robot as br;

const ROTATION: Domain = Domain::Rotation { tolerance: 1e-9 };

fn refused(family: &'static str, instance: usize, param: &'static str, domain: Domain, found: Found) -> CbfError {
    CbfError::ParamOutOfDomain { family, member: None, instance: Some(instance), param, domain, found }
}

/// A box's 15 numbers: centre, rotation row by row, half extents.
fn boxed(center: [f64; 3], rotation: &Matrix3<f64>, half: [f64; 3]) -> Vec<f64> {
    let r: Vec<f64> = (0..3).flat_map(|i| (0..3).map(move |j| rotation[(i, j)])).collect();
    [&center[..], &r, &half[..]].concat()
}

#[test]
fn the_primitives_give_the_parameters_their_domains() {
    use Domain::{NonNegative, Positive, Real};
    assert_eq!(br::PillarParams::DOMAINS, [("center", Real), ("rotation", ROTATION), ("half_extents", Positive)]);
    let post = [("center", Real), ("yaw", Real), ("hx", Positive), ("hy", Positive), ("hz", Positive), ("radius", Positive)];
    assert_eq!(br::PostParams::DOMAINS, post);
    let blob = [("center", Real), ("rotation", ROTATION), ("half", Positive), ("margin", NonNegative)];
    assert_eq!(br::BlobParams::DOMAINS, blob);
    let fence = [("normal", Domain::UnitVector { tolerance: 1e-9 }), ("offset", Real)];
    assert_eq!(br::FenceParams::DOMAINS, fence);
    assert_eq!(br::SpeedLimitParams::DOMAINS, [("vmax", Domain::Interval { lo: 0.1, hi: 5.0 })]);
}

#[test]
fn an_unset_fixed_box_is_refused_by_name_not_filtered_against() -> Result<(), CbfError> {
    let capacity = br::Capacity { post: 1, blob: 1 };
    let mut params = br::Params::new(capacity)?;
    let mut barriers = br::Barriers::new(capacity)?;
    let mut filter = br::Filter::new(br::Barriers::new(capacity)?, br::default_settings())?;
    let (x, u_ref) = ([0.0, 0.0, 0.5, 0.0], [1.0, 0.0]);
    // The pillar's centre was never set (the spec gives no default): refused, by name.
    let unset = refused("pillar", 0, "center", Domain::Real, Found::NotSet);
    assert_eq!(barriers.evaluate(0.0, &x, &params), Err(unset.clone()));
    assert_eq!(filter.update(&x, &u_ref, &params).map(|o| o.u), Err(unset.clone()));
    assert!(unset.to_string().starts_with("pillar instance 0: parameter center was never set"), "{unset}");
    params.pillar[0].center = Vector3::new(2.0, 0.0, 0.0);
    // Then its extents; its rotation starts at the spec's default, the identity.
    let extents = refused("pillar", 0, "half_extents", Domain::Positive, Found::NotSet);
    assert_eq!(filter.update(&x, &u_ref, &params).map(|o| o.u), Err(extents));
    assert_eq!(params.pillar[0].rotation, Matrix3::identity());
    params.pillar[0].half_extents = Vector3::new(0.3, 0.3, 0.5);
    // The speed limit starts at its default, 2 m/s (a zero would be outside its interval).
    assert_eq!(params.speed_limit[0].vmax, 2.0);
    let out = *filter.update(&x, &u_ref, &params)?;
    assert!(out.u.iter().all(|u| u.is_finite()));
    // Typed values written past the door are refused when evaluated, naming the instance.
    params.blob.push(br::BlobParams {
        center: Vector3::new(-2.0, 0.0, 0.0),
        rotation: Matrix3::identity(),
        half: Vector3::new(0.2, 0.2, 0.2),
        margin: -0.05,
    })?;
    let margin = refused("blob", 0, "margin", Domain::NonNegative, Found::Value(-0.05));
    assert_eq!(barriers.evaluate(0.0, &x, &params), Err(margin));
    Ok(())
}

#[test]
fn the_run_time_door_refuses_what_the_primitives_exclude_and_changes_nothing() -> Result<(), CbfError> {
    let sys: &dyn DynSystem = br::SYSTEM;
    let [pillar, post, blob, fence] = ["pillar", "post", "blob", "fence"].map(|n| sys.family_index(n).unwrap());
    let counts = [CapacityCount { family: post, member: 0, count: 2 }, CapacityCount { family: blob, member: 0, count: 2 }];
    let mut p = sys.params(&counts)?;
    let id = Matrix3::identity();
    p.set(pillar, 0, 0, &boxed([2.0, 0.0, 0.0], &id, [0.3, 0.3, 0.5]))?;
    // post: centre, yaw, hx, hy, hz, radius.
    p.push(post, 0, &[1.0, 1.0, 0.0, 0.3, 0.1, 0.1, 0.2, 0.15])?;
    p.push(blob, 0, &[boxed([-2.0, 0.0, 0.0], &id, [0.2, 0.2, 0.2]), vec![0.0]].concat())?;
    p.set(fence, 0, 1, &[0.6, 0.8, 1.5])?;
    let before = p.clone_box();
    let same = |q: &dyn cbfgen::dynamic::DynParams| {
        assert_eq!(q.downcast_ref::<br::Params>(), before.downcast_ref::<br::Params>());
    };

    let entry = |index, value| Found::Entry { index, value };
    let mut skewed = id;
    skewed[(2, 0)] = -1e-6;
    let reflection = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, 1.0));
    let pillar_cases = [
        (id, [-0.3, 0.3, 0.5], "half_extents", Domain::Positive, entry(0, -0.3)),
        (id, [0.3, 0.0, 0.5], "half_extents", Domain::Positive, entry(1, 0.0)),
        (id * 2.0, [0.3, 0.3, 0.5], "rotation", ROTATION, Found::Orthonormality(3.0)),
        (reflection, [0.3, 0.3, 0.5], "rotation", ROTATION, Found::Determinant(-1.0)),
        (Matrix3::zeros(), [0.3, 0.3, 0.5], "rotation", ROTATION, Found::Orthonormality(1.0)),
        (skewed, [0.3, 0.3, 0.5], "rotation", ROTATION, Found::Orthonormality(1e-6)),
    ];
    for (rotation, half, param, domain, found) in pillar_cases {
        assert_eq!(p.set(pillar, 0, 0, &boxed([2.0, 0.0, 0.0], &rotation, half)), Err(refused("pillar", 0, param, domain, found)));
    }
    let radius = refused("post", 1, "radius", Domain::Positive, Found::Value(-0.15));
    assert_eq!(p.push(post, 0, &[1.0, 1.0, 0.0, 0.3, 0.1, 0.1, 0.2, -0.15]), Err(radius));
    let hy = refused("post", 0, "hy", Domain::Positive, Found::Value(-0.1));
    assert_eq!(p.set(post, 0, 0, &[1.0, 1.0, 0.0, 0.3, 0.1, -0.1, 0.2, 0.15]), Err(hy));
    let margin = refused("blob", 1, "margin", Domain::NonNegative, Found::Value(-1e-3));
    assert_eq!(p.push(blob, 0, &[boxed([-2.0, 0.0, 0.0], &id, [0.2, 0.2, 0.2]), vec![-1e-3]].concat()), Err(margin));
    let normal = refused("fence", 0, "normal", Domain::UnitVector { tolerance: 1e-9 }, Found::Norm(2f64.sqrt()));
    assert_eq!(p.set(fence, 0, 0, &[1.0, 1.0, 1.5]), Err(normal));
    let nan = p.set(pillar, 0, 0, &boxed([2.0, f64::NAN, 0.0], &id, [0.3, 0.3, 0.5])).expect_err("NaN refused");
    assert!(
        matches!(nan, CbfError::ParamOutOfDomain { family: "pillar", instance: Some(0), param: "center",
            domain: Domain::Real, found: Found::Entry { index: 1, value }, .. } if value.is_nan()),
        "{nan:?}"
    );
    same(p.as_ref());

    // Accepted: a proper rotation within the tolerance, an inflation of zero, a unit normal.
    let mut nearly = id;
    nearly[(2, 0)] = -4e-10;
    p.set(pillar, 0, 0, &boxed([2.0, 0.0, 0.0], &nearly, [0.3, 0.3, 0.5]))?;
    p.set(fence, 0, 0, &[0.0, -1.0, 1.5])?;
    let typed = p.downcast_ref::<br::Params>().expect("boxed_robot's");
    assert_eq!(typed.pillar[0].rotation, nearly);
    assert_eq!(typed.fence[0], Some(br::FenceParams { normal: Vector2::new(0.0, -1.0), offset: 1.5 }));
    Ok(())
}
