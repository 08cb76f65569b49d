//! Smooth SAT against the exact SAT and against finite differences.

use cbfgen_testkit::boxes as common;

use cbfgen::ssat::{self, SmoothAbs, SmoothMax, SmoothParams};
use cbfgen::{sat, OrientedBox};
use common::{random_box, random_rotation, random_vector, rng};
use nalgebra::{Rotation3, Vector3};
use rand::Rng;

const VARIANTS: [(SmoothMax, SmoothAbs); 4] = [
    (SmoothMax::Lse, SmoothAbs::XTanh),
    (SmoothMax::Lse, SmoothAbs::Sqrt),
    (SmoothMax::Boltzmann, SmoothAbs::XTanh),
    (SmoothMax::Boltzmann, SmoothAbs::Sqrt),
];
const ALPHAS: [f64; 3] = [20.0, 200.0, 2000.0];

fn all_params() -> impl Iterator<Item = SmoothParams> {
    ALPHAS
        .into_iter()
        .flat_map(|a| VARIANTS.into_iter().map(move |(m, s)| SmoothParams::new(a, a).unwrap().with_variant(m, s)))
}

fn boxed(center: Vector3<f64>, rotation: Rotation3<f64>, half: Vector3<f64>) -> OrientedBox {
    OrientedBox::new(center, rotation, half).unwrap()
}

/// The margin's promise, checked pair by pair. Returns how many pairs overlapped.
fn assert_never_certifies_overlap(pairs: &[(OrientedBox, OrientedBox)], set: &str) -> usize {
    let mut overlapping = 0;
    for (a, b) in pairs {
        let exact = sat::separation(a, b);
        if exact >= 0.0 {
            continue;
        }
        overlapping += 1;
        for p in all_params() {
            let (h, m) = (ssat::ssat(a, b, &p), ssat::certified_margin(a, b, &p));
            assert!(h.is_finite() && m > 0.0);
            assert!(
                h - m < 0.0,
                "{set}: {:?} certifies an overlap (exact {exact}, h {h}, m {m})\n{a:?}\n{b:?}",
                p.variant()
            );
        }
    }
    overlapping
}

/// Far enough apart along a face normal, every variant must certify the separation:
/// the margin is not vacuous. (A face axis's smoothed y is within 10/alpha of its gap for
/// every variant, and the smooth maxima are within ln 15/alpha of the max.)
fn assert_face_separated_pairs_are_certified(pairs: &[(OrientedBox, OrientedBox)]) -> usize {
    let mut checked = 0;
    for (a, b) in pairs {
        let face_gap = face_axis_gap(a, b);
        for p in all_params() {
            let m = ssat::certified_margin(a, b, &p);
            if face_gap > 2.0 * m + 10.0 / p.alpha() {
                checked += 1;
                assert!(
                    ssat::certified_separated(a, b, &p),
                    "{:?} fails to certify a face gap {face_gap}",
                    p.variant()
                );
            }
        }
    }
    checked
}

/// The largest gap along the six face normals (exact, unit axes).
fn face_axis_gap(a: &OrientedBox, b: &OrientedBox) -> f64 {
    let radius = |x: &OrientedBox, n: &Vector3<f64>| -> f64 {
        (0..3).map(|k| x.half_extents()[k] * n.dot(&x.rotation().matrix().column(k)).abs()).sum()
    };
    let d = b.center() - a.center();
    (0..3)
        .flat_map(|k| [a.rotation().matrix().column(k).into_owned(), b.rotation().matrix().column(k).into_owned()])
        .map(|n| d.dot(&n).abs() - radius(a, &n) - radius(b, &n))
        .fold(f64::NEG_INFINITY, f64::max)
}

#[test]
fn margin_never_certifies_an_overlap_on_random_pairs() {
    let pairs = common::random_pairs(3, 100_000, 0.8);
    let overlapping = assert_never_certifies_overlap(&pairs, "random");
    assert!(overlapping > 20_000, "only {overlapping} overlapping pairs");
    assert!(assert_face_separated_pairs_are_certified(&pairs) > 100_000);
}

/// Degenerate configurations where the smooth formula is most likely to go wrong.
fn degenerate_sets() -> Vec<(&'static str, Vec<(OrientedBox, OrientedBox)>)> {
    let mut r = rng(5);
    let n = 2_000;
    let mut sets = Vec::new();

    let identical: Vec<_> = (0..n)
        .map(|_| {
            let rot = random_rotation(&mut r);
            (
                boxed(random_vector(&mut r, -0.6, 0.6), rot, random_vector(&mut r, 0.05, 0.6)),
                boxed(random_vector(&mut r, -0.6, 0.6), rot, random_vector(&mut r, 0.05, 0.6)),
            )
        })
        .collect();
    sets.push(("identical orientations", identical));

    let shared_axis: Vec<_> = (0..n)
        .map(|_| {
            let yaw = r.random_range(-3.0..3.0);
            let pitch = r.random_range(-0.5..0.5);
            let ra = Rotation3::from_euler_angles(0.0, 0.0, yaw);
            let rb = ra * Rotation3::from_euler_angles(0.0, pitch, 0.0);
            (
                boxed(random_vector(&mut r, -0.6, 0.6), ra, random_vector(&mut r, 0.05, 0.6)),
                boxed(random_vector(&mut r, -0.6, 0.6), rb, random_vector(&mut r, 0.05, 0.6)),
            )
        })
        .collect();
    sets.push(("yaw-aligned, pitched", shared_axis));

    let touching: Vec<_> = (0..n)
        .map(|_| {
            let rot = random_rotation(&mut r);
            let (ha, hb) = (random_vector(&mut r, 0.05, 0.6), random_vector(&mut r, 0.05, 0.6));
            let axis = r.random_range(0..3);
            let mut offset = random_vector(&mut r, -0.05, 0.05);
            offset[axis] = ha[axis] + hb[axis];
            let ca = random_vector(&mut r, -1.0, 1.0);
            (boxed(ca, rot, ha), boxed(ca + rot * offset, rot, hb))
        })
        .collect();
    sets.push(("exactly touching faces", touching));

    let inside: Vec<_> = (0..n)
        .map(|_| {
            let ha = random_vector(&mut r, 0.4, 0.8);
            let hb = random_vector(&mut r, 0.05, 0.3);
            let c = random_vector(&mut r, -0.1, 0.1);
            (boxed(Vector3::zeros(), random_rotation(&mut r), ha), boxed(c, random_rotation(&mut r), hb))
        })
        .collect();
    sets.push(("one inside the other", inside));

    // A 0.9 x 0.5 x 0.2 m body at heights from 20 cm below to 20 cm above a 4 cm stair-edge
    // cuboid, exactly axis-aligned or off by a hair of yaw and pitch.
    let edge = boxed(Vector3::new(0.0, 0.0, -0.02), Rotation3::identity(), Vector3::new(0.02, 1.0, 0.02));
    let stack: Vec<_> = (0..n)
        .map(|i| {
            let tilt = [0.0, 1e-12, 1e-9, 1e-6][i % 4];
            let body_rot = Rotation3::from_euler_angles(0.0, tilt, -tilt);
            let c = Vector3::new(r.random_range(-0.6..0.6), r.random_range(-0.2..0.2), r.random_range(-0.1..0.3));
            (edge, boxed(c, body_rot, Vector3::new(0.45, 0.25, 0.10)))
        })
        .collect();
    sets.push(("body over stair edge", stack));
    sets
}

#[test]
fn margin_never_certifies_an_overlap_in_degenerate_sets() {
    for (name, pairs) in degenerate_sets() {
        let overlapping = assert_never_certifies_overlap(&pairs, name);
        assert!(overlapping > 0 || name == "exactly touching faces", "{name}: no overlapping pair");
    }
}

/// With aligned edges a vanishing cross axis must not pin h near 0: h tracks the exact
/// separation, overlapping pairs included.
#[test]
fn parallel_edges_do_not_hide_overlap() {
    let aligned = ["identical orientations", "exactly touching faces", "body over stair edge"];
    let mut deep = 0;
    for (name, pairs) in degenerate_sets().into_iter().filter(|(n, _)| aligned.contains(n)) {
        for (a, b) in &pairs {
            let exact = sat::separation(a, b);
            for p in all_params() {
                let h = ssat::ssat(a, b, &p);
                let m = ssat::certified_margin(a, b, &p);
                let slack = m + 10.0 / p.alpha();
                assert!((h - exact).abs() <= slack, "{name}: {:?} h {h} vs exact {exact} (slack {slack})", p.variant());
                if exact < -slack {
                    deep += 1;
                    assert!(h < 0.0);
                }
            }
        }
    }
    assert!(deep > 1000);
}

#[test]
fn finite_and_sensible_far_apart() {
    let mut r = rng(9);
    for _ in 0..500 {
        let a = random_box(&mut r, 1.0);
        let dir = random_vector(&mut r, -1.0, 1.0).normalize();
        let b = random_box(&mut r, 1.0);
        let b = b.with_center(a.center() + dir * 1.0e3).unwrap();
        let exact = sat::separation(&a, &b);
        for alpha in [1.0, 100.0, 1000.0] {
            for (m, s) in VARIANTS {
                let p = SmoothParams::new(alpha, alpha).unwrap().with_variant(m, s);
                let d = ssat::ssat_with_derivatives(&a, &b, &p);
                let margin = ssat::certified_margin(&a, &b, &p);
                assert!(d.value.is_finite() && d.gradient.iter().all(|g| g.is_finite()));
                assert!(d.hessian.iter().all(|g| g.is_finite()));
                assert!((d.hessian - d.hessian.transpose()).abs().max() <= 1e-9 * (1.0 + d.hessian.abs().max()));
                // h is a lower bound on the distance (up to the margin) and within the face
                // axes' reach of it; its gradient pushes B away from A with unit-ish slope.
                assert!(d.value <= exact + margin, "h {} > exact {exact} + {margin}", d.value);
                assert!(d.value >= face_axis_gap(&a, &b) - margin - 10.0 / alpha);
                assert!(d.gradient.dot(&dir) > 0.0);
                assert!(d.gradient.norm() < 1.25, "|grad| = {}", d.gradient.norm());
                let plain = ssat::ssat(&a, &b, &p);
                assert!((d.value - plain).abs() <= 1e-12 * plain.abs().max(1.0));
            }
        }
    }
}

#[test]
fn derivatives_match_central_differences() {
    let mut r = rng(21);
    let step = 1e-6;
    let mut checked = 0;
    for _ in 0..400 {
        let (a, b) = (random_box(&mut r, 1.0), random_box(&mut r, 1.0));
        for (m, s) in VARIANTS {
            let p = SmoothParams::new(50.0, 50.0).unwrap().with_variant(m, s);
            let d = ssat::ssat_with_derivatives(&a, &b, &p);
            let mut fd_grad = Vector3::zeros();
            let mut fd_hess = nalgebra::Matrix3::zeros();
            for k in 0..3 {
                let mut e = Vector3::zeros();
                e[k] = step;
                let plus = b.with_center(b.center() + e).unwrap();
                let minus = b.with_center(b.center() - e).unwrap();
                fd_grad[k] = (ssat::ssat(&a, &plus, &p) - ssat::ssat(&a, &minus, &p)) / (2.0 * step);
                let gp = ssat::ssat_with_derivatives(&a, &plus, &p).gradient;
                let gm = ssat::ssat_with_derivatives(&a, &minus, &p).gradient;
                fd_hess.set_column(k, &((gp - gm) / (2.0 * step)));
            }
            let grad_err = (fd_grad - d.gradient).abs().max() / d.gradient.abs().max().max(1.0);
            let hess_err = (fd_hess - d.hessian).abs().max() / d.hessian.abs().max().max(1.0);
            assert!(grad_err <= 1e-6, "{:?}: gradient rel. error {grad_err:e}", p.variant());
            assert!(hess_err <= 1e-6, "{:?}: Hessian rel. error {hess_err:e}", p.variant());
            checked += 1;
        }
    }
    assert_eq!(checked, 1600);
}

#[test]
fn invalid_parameters_are_rejected() {
    assert!(SmoothParams::new(0.0, 1.0).is_err());
    assert!(SmoothParams::new(f64::NAN, 1.0).is_err());
    assert!(SmoothParams::new(1.0, f64::INFINITY).is_err());
    let bad_rot = Rotation3::from_matrix_unchecked(nalgebra::Matrix3::new(1.0, 0.1, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0));
    assert!(OrientedBox::new(Vector3::zeros(), bad_rot, Vector3::new(1.0, 1.0, 1.0)).is_err());
    assert!(OrientedBox::axis_aligned(Vector3::zeros(), Vector3::new(1.0, 0.0, 1.0)).is_err());
    assert!(OrientedBox::axis_aligned(Vector3::new(f64::NAN, 0.0, 0.0), Vector3::new(1.0, 1.0, 1.0)).is_err());
}

#[test]
fn the_default_has_the_smaller_certified_margin_of_the_two_lse_variants() {
    // The reason stated for the default (src/ssat.rs, docs/ssat.md): LSE + √ is faster,
    // but LSE + x·tanh needs less margin for boxes of the robot's size. At the stair
    // body–edge pair of docs/ssat.md, α = α_rot = 200: 15.9 mm against 18.5 mm.
    let edge = OrientedBox::axis_aligned(Vector3::new(0.0, 0.0, -0.02), Vector3::new(0.02, 1.0, 0.02)).unwrap();
    let body = OrientedBox::axis_aligned(Vector3::new(0.0, 0.0, 0.175), Vector3::new(0.45, 0.25, 0.10)).unwrap();
    let p = SmoothParams::default();
    assert_eq!(p.variant(), (SmoothMax::Lse, SmoothAbs::XTanh));
    let (xtanh, sqrt) = (
        ssat::certified_margin(&edge, &body, &p),
        ssat::certified_margin(&edge, &body, &p.with_variant(SmoothMax::Lse, SmoothAbs::Sqrt)),
    );
    assert!((xtanh - 0.0159).abs() < 5e-5 && (sqrt - 0.0185).abs() < 5e-5, "{xtanh} {sqrt}");
    // Beyond the robot's size it turns: x·tanh's bound grows with the extents, √'s not
    // (3.6 m of summed half extents on the worst axis at α = α_rot).
    let big = |h: f64| OrientedBox::axis_aligned(Vector3::zeros(), Vector3::new(h, h, h)).unwrap();
    let (xtanh, sqrt) = (
        ssat::certified_margin(&big(1.0), &big(1.0), &p),
        ssat::certified_margin(&big(1.0), &big(1.0), &p.with_variant(SmoothMax::Lse, SmoothAbs::Sqrt)),
    );
    assert!(xtanh > sqrt, "{xtanh} {sqrt}");
}
