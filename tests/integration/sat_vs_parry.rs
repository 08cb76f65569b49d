//! The exact SAT agrees with an independent collision library (parry3d-f64).

use cbfgen_testkit::boxes as common;

use cbfgen::{sat, OrientedBox};
use parry3d_f64::math::{Pose, Rot3, Vec3};
use parry3d_f64::query::intersection_test;
use parry3d_f64::shape::Cuboid;

fn parry_overlaps(a: &OrientedBox, b: &OrientedBox) -> bool {
    let pose = |x: &OrientedBox| {
        let q = nalgebra::UnitQuaternion::from_rotation_matrix(x.rotation());
        let c = x.center();
        Pose::from_parts(Vec3::new(c.x, c.y, c.z), Rot3::from_xyzw(q.i, q.j, q.k, q.w))
    };
    let cuboid = |x: &OrientedBox| {
        let h = x.half_extents();
        Cuboid::new(Vec3::new(h.x, h.y, h.z))
    };
    intersection_test(&pose(a), &cuboid(a), &pose(b), &cuboid(b)).expect("cuboids are supported").intersecting
}

#[test]
fn exact_sat_matches_parry_on_random_pairs() {
    let pairs = common::random_pairs(11, 20_000, 0.6);
    let (mut compared, mut overlapping) = (0, 0);
    for (a, b) in &pairs {
        let s = sat::separation(a, b);
        if s.abs() < 1e-9 {
            continue; // touching within rounding: either answer is right
        }
        let ours = sat::overlaps(a, b);
        assert_eq!(ours, parry_overlaps(a, b), "disagree on {a:?} / {b:?} (separation {s})");
        compared += 1;
        overlapping += ours as usize;
    }
    assert!(compared >= 10_000);
    // Both outcomes must be well represented, or the comparison proves little.
    assert!(overlapping > compared / 5 && overlapping < compared * 4 / 5, "{overlapping} of {compared}");
}

#[test]
fn exact_sat_separation_is_the_gap_for_axis_aligned_boxes() {
    // Hand-computed: boxes of half size 1 and 0.5, centres 2 m apart along x: gap 0.5.
    let a = OrientedBox::axis_aligned(nalgebra::Vector3::zeros(), nalgebra::Vector3::new(1.0, 1.0, 1.0)).unwrap();
    let b = OrientedBox::axis_aligned(nalgebra::Vector3::new(2.0, 0.2, 0.0), nalgebra::Vector3::new(0.5, 0.5, 0.5))
        .unwrap();
    assert!((sat::separation(&a, &b) - 0.5).abs() < 1e-12);
    let c = OrientedBox::axis_aligned(nalgebra::Vector3::new(1.2, 0.0, 0.0), nalgebra::Vector3::new(0.5, 0.5, 0.5))
        .unwrap();
    assert!((sat::separation(&a, &c) + 0.3).abs() < 1e-12);
}
