//! The smooth SAT at the edges of its documented domain (issue 12): typed errors outside
//! it; inside it, finite outputs, derivatives that match finite differences at every
//! scale, and a certificate that the exact SAT never contradicts.
//!
//! CI runs a few thousand cases per property with a fixed seed (about a second in
//! release); a campaign is `PROPTEST_CASES=100000 PROPTEST_RNG_SEED=<n> cargo test
//! --release --test integration ssat_domain`.

use cbfgen::generated::ssat as kernels;
use cbfgen::geometry::{MAX_COORDINATE, MAX_HALF_EXTENT, MIN_HALF_EXTENT, ROTATION_TOLERANCE};
use cbfgen::ssat::{self, SmoothAbs, SmoothMax, SmoothParams, ALPHA_MAX, ALPHA_MIN, ROUNDING_GUARD};
use cbfgen::{sat, CbfError, OrientedBox};
use nalgebra::{Matrix3, Quaternion, Rotation3, Unit, UnitQuaternion, Vector3};
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{Config, RngSeed, TestRunner};
use std::f64::consts::PI;

const VARIANTS: [(SmoothMax, SmoothAbs); 4] = [
    (SmoothMax::Lse, SmoothAbs::XTanh),
    (SmoothMax::Lse, SmoothAbs::Sqrt),
    (SmoothMax::Boltzmann, SmoothAbs::XTanh),
    (SmoothMax::Boltzmann, SmoothAbs::Sqrt),
];

fn params(alpha: f64, alpha_rot: f64, (max, abs): (SmoothMax, SmoothAbs)) -> SmoothParams {
    SmoothParams::new(alpha, alpha_rot).expect("alpha in its domain").with_variant(max, abs)
}

fn offset_and_extents(a: &OrientedBox, b: &OrientedBox) -> f64 {
    (b.center() - a.center()).abs().sum() + a.half_extents().sum() + b.half_extents().sum()
}

/// The rounding guard as the `ssat` module documents it: `ROUNDING_GUARD · S`.
fn documented_guard(a: &OrientedBox, b: &OrientedBox, h: f64, m: f64) -> f64 {
    ROUNDING_GUARD * (offset_and_extents(a, b) + h.abs() + m)
}

/// Rounding of the exact SAT itself: a handful of operations on the offset and extents.
fn sat_rounding(a: &OrientedBox, b: &OrientedBox) -> f64 {
    64.0 * f64::EPSILON * offset_and_extents(a, b)
}

fn out_of_range(result: Result<impl std::fmt::Debug, CbfError>, what: &str) -> String {
    match result {
        Err(e @ CbfError::OutOfRange { what: w, .. }) if w == what => e.to_string(),
        other => panic!("expected OutOfRange for {what}, got {other:?}"),
    }
}

// ---------------------------------------------------------------------------------------
// Regressions: each input below was accepted before issue 12.

/// α = 1e300 gave a NaN Hessian.
#[test]
fn alpha_of_1e300_is_out_of_range() {
    out_of_range(SmoothParams::new(1e300, 200.0), "SSAT alpha");
    out_of_range(SmoothParams::new(200.0, 1e300), "SSAT alpha_rot");
}

/// α = 5e-324 (the smallest subnormal) gave an infinite value.
#[test]
fn alpha_of_5e_324_is_out_of_range() {
    out_of_range(SmoothParams::new(5e-324, 200.0), "SSAT alpha");
    out_of_range(SmoothParams::new(200.0, 5e-324), "SSAT alpha_rot");
}

/// Boxes of 1e-16 m: rounding made an overlapping pair's `h − m` exactly 0, certified.
#[test]
fn boxes_below_the_extent_domain_are_rejected() {
    for tiny in [1e-16, MIN_HALF_EXTENT.next_down()] {
        let half = Vector3::new(0.5, tiny, 0.5);
        out_of_range(OrientedBox::axis_aligned(Vector3::zeros(), half), "box half extent");
    }
    assert!(matches!(
        OrientedBox::axis_aligned(Vector3::zeros(), Vector3::new(0.5, 0.0, 0.5)),
        Err(CbfError::NotPositive { .. })
    ));
}

/// Extents of 1e14 m: the √ variants' margin `1/α` fell below the rounding of an extent.
#[test]
fn sqrt_variant_extents_of_1e14_m_are_rejected() {
    for huge in [1e14, MAX_HALF_EXTENT.next_up()] {
        out_of_range(OrientedBox::axis_aligned(Vector3::zeros(), Vector3::repeat(huge)), "box half extent");
    }
}

#[test]
fn centres_beyond_the_coordinate_domain_are_rejected() {
    let half = Vector3::repeat(1.0);
    for c in [MAX_COORDINATE.next_up(), -1e7, 1e300] {
        out_of_range(OrientedBox::axis_aligned(Vector3::new(0.0, c, 0.0), half), "box centre coordinate");
    }
    let inside = OrientedBox::axis_aligned(Vector3::zeros(), half).unwrap();
    out_of_range(inside.with_center(Vector3::new(0.0, 0.0, -2e6)), "box centre coordinate");
}

/// The bounds themselves are accepted, and the errors name the documented range.
#[test]
fn domain_bounds_are_inclusive_and_named_in_errors() {
    SmoothParams::new(ALPHA_MIN, ALPHA_MAX).unwrap();
    SmoothParams::new(ALPHA_MAX, ALPHA_MIN).unwrap();
    let corner = Vector3::new(MAX_COORDINATE, -MAX_COORDINATE, MAX_COORDINATE);
    OrientedBox::axis_aligned(corner, Vector3::new(MIN_HALF_EXTENT, MAX_HALF_EXTENT, 1.0)).unwrap();

    let alpha_message = out_of_range(SmoothParams::new(ALPHA_MAX * 2.0, 1.0), "SSAT alpha");
    let extent_message = out_of_range(
        OrientedBox::axis_aligned(Vector3::zeros(), Vector3::repeat(MIN_HALF_EXTENT / 2.0)),
        "box half extent",
    );
    let centre_message =
        out_of_range(OrientedBox::axis_aligned(corner * 2.0, Vector3::repeat(1.0)), "box centre coordinate");
    for (message, bounds) in [
        (alpha_message, [ALPHA_MIN, ALPHA_MAX]),
        (extent_message, [MIN_HALF_EXTENT, MAX_HALF_EXTENT]),
        (centre_message, [-MAX_COORDINATE, MAX_COORDINATE]),
    ] {
        for bound in bounds {
            assert!(message.contains(&format!("{bound:e}")), "{message:?} does not name {bound:e}");
        }
    }
    // Non-positive and non-finite values keep their own, more specific errors.
    assert!(matches!(SmoothParams::new(-1.0, 1.0), Err(CbfError::NotPositive { .. })));
    assert!(matches!(SmoothParams::new(1.0, f64::NAN), Err(CbfError::NonFinite { .. })));
}

/// A reflection is orthonormal (deviation 0), so the message used to read
/// "deviation 0.000e0" and nothing else; it now reports the determinant.
#[test]
fn reflected_rotation_reports_its_determinant() {
    let generic = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
    for reflection in [
        Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0)),
        generic.matrix() * Matrix3::from_diagonal(&Vector3::new(-1.0, 1.0, 1.0)),
    ] {
        let err =
            OrientedBox::new(Vector3::zeros(), Rotation3::from_matrix_unchecked(reflection), Vector3::repeat(1.0))
                .unwrap_err();
        match err {
            CbfError::NotARotation { deviation, determinant } => {
                assert!(deviation < 1e-15, "a reflection is orthonormal, deviation {deviation}");
                assert!((determinant + 1.0).abs() < 1e-12, "determinant {determinant}");
            }
            other => panic!("expected NotARotation, got {other:?}"),
        }
        assert!(err.to_string().contains("det R = -1.000000"), "{err}");
    }
}

/// A rotation scaled by 1 − 4.5e-10 is within the rotation tolerance. The kernels assume
/// `RᵀR = I`, so it shrank a 10 km box's projections by ~6 µm and the certificate held
/// for a pair whose proper boxes overlap by 1 µm. It is now stored as its nearest proper
/// rotation, which for a uniformly scaled rotation is the rotation itself.
#[test]
fn skewed_rotation_is_stored_as_its_nearest_rotation() {
    let h = 1e4;
    let proper: Rotation3<f64> = Rotation3::from_euler_angles(0.3, -0.4, 0.5);
    let skewed = Rotation3::from_matrix_unchecked(proper.matrix() * (1.0 - 4.5e-10));
    let a = OrientedBox::axis_aligned(Vector3::zeros(), Vector3::repeat(h)).unwrap();
    // B along A's x axis, its projection onto that axis overlapping A's face by 1 µm.
    let reach = h * (0..3).map(|j| proper.matrix()[(0, j)].abs()).sum::<f64>();
    let center = Vector3::new(h + reach - 1e-6, 0.0, 0.0);
    let b = OrientedBox::new(center, skewed, Vector3::repeat(h)).unwrap();

    let stored = b.rotation().matrix();
    assert!((stored - proper.matrix()).abs().max() < 1e-15);
    assert!((stored.transpose() * stored - Matrix3::identity()).abs().max() <= 8.0 * f64::EPSILON);
    let exact = sat::separation(&a, &b);
    assert!(exact < -0.9e-6, "the proper boxes overlap by 1 µm, SAT says {exact}");
    for alpha in [1e8, ALPHA_MAX] {
        for variant in VARIANTS {
            let p = params(alpha, ALPHA_MAX, variant);
            assert!(!ssat::certified_separated(&a, &b, &p), "{variant:?} at alpha {alpha:e} certifies the overlap");
        }
    }
    // Rotations already orthonormal to rounding are stored bit for bit.
    let generic = Rotation3::from_euler_angles(1.0, 2.0, 3.0);
    assert_eq!(OrientedBox::new(Vector3::zeros(), generic, Vector3::repeat(1.0)).unwrap().rotation(), &generic);
}

/// The smallest boxes of the domain, overlapping by anything from their whole size down
/// to a rounding step, at the origin and at the far corner of the coordinate domain: no
/// variant at any α certifies them; apart by ten sizes, the sharpest α still does.
#[test]
fn overlapping_tiny_boxes_in_the_domain_are_never_certified() {
    let s = MIN_HALF_EXTENT;
    let rotations = [Rotation3::identity(), Rotation3::from_euler_angles(0.3, -1.1, 2.0)];
    let mut overlapping = 0;
    for origin in [Vector3::zeros(), Vector3::repeat(MAX_COORDINATE - 10.0 * s)] {
        for ra in rotations {
            for rb in rotations {
                let a = OrientedBox::new(origin, ra, Vector3::new(s, 2.0 * s, 3.0 * s)).unwrap();
                let half_b = Vector3::new(2.0 * s, s, s);
                let direction = Vector3::new(-1.0, -0.5, -0.25).normalize();
                let touching = touching_distance(&a, &rb, &half_b, &direction);
                for fraction in [0.0, 0.5, 1.0 - 1e-6, 1.0 - 1e-12, 1.0 - 1e-15, 10.0] {
                    let b = OrientedBox::new(origin + direction * (touching * fraction), rb, half_b).unwrap();
                    let apart = fraction > 1.0;
                    overlapping += usize::from(!apart && sat::overlaps(&a, &b));
                    for alpha in [ALPHA_MIN, 1.0, 200.0, ALPHA_MAX] {
                        for variant in VARIANTS {
                            let certified = ssat::certified_separated(&a, &b, &params(alpha, alpha, variant));
                            if sat::overlaps(&a, &b) {
                                assert!(!certified, "{variant:?} alpha {alpha:e} certifies {a:?} {b:?}");
                            }
                            if apart && alpha == ALPHA_MAX {
                                assert!(certified, "{variant:?}: tiny boxes ten sizes apart are not certified");
                            }
                        }
                    }
                }
            }
        }
    }
    assert!(overlapping >= 24, "only {overlapping} overlapping pairs");
}

// ---------------------------------------------------------------------------------------
// Evidence for the α domain: its corners are finite, with decades of headroom.

fn signed_permutations() -> Vec<Rotation3<f64>> {
    let orders = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
    let mut out = Vec::new();
    for order in orders {
        for signs in 0..8 {
            let m = Matrix3::from_fn(|i, j| match (order[j] == i, signs >> j & 1) {
                (false, _) => 0.0,
                (true, 0) => 1.0,
                (true, _) => -1.0,
            });
            if m.determinant() > 0.0 {
                out.push(Rotation3::from_matrix_unchecked(m));
            }
        }
    }
    out
}

/// The distance along the unit `direction` from `a`'s centre at which a box with this
/// rotation and these half extents stops overlapping `a`, by bisection on the exact SAT
/// (overlap is monotone along a ray from a common centre: the Minkowski difference is
/// convex). The far end is where the bounding spheres touch.
fn touching_distance(a: &OrientedBox, rotation: &Rotation3<f64>, half: &Vector3<f64>, direction: &Vector3<f64>) -> f64 {
    let overlaps_at = |t: f64| {
        let b = OrientedBox::new(a.center() + direction * t, *rotation, *half).expect("bisection stays in the domain");
        sat::overlaps(a, &b)
    };
    let (mut inside, mut outside) = (0.0, a.half_extents().norm() + half.norm());
    loop {
        let mid = 0.5 * (inside + outside);
        if mid <= inside || mid >= outside {
            return outside;
        }
        if overlaps_at(mid) {
            inside = mid;
        } else {
            outside = mid;
        }
    }
}

/// Pairs at the corners of the box domain: extreme and mixed extents, exact and generic
/// rotations, centres at the origin and at the corners of the coordinate domain, B
/// coincident with, touching, or as far from A as the domain allows.
fn corner_pairs() -> Vec<(OrientedBox, OrientedBox)> {
    let extents = [
        Vector3::repeat(MIN_HALF_EXTENT),
        Vector3::repeat(MAX_HALF_EXTENT),
        Vector3::new(MIN_HALF_EXTENT, 1.0, MAX_HALF_EXTENT),
    ];
    let rotations = [
        Rotation3::identity(),
        signed_permutations()[5],
        Rotation3::from_euler_angles(0.3, -1.1, 2.0),
        Rotation3::from_axis_angle(&Vector3::y_axis(), 1e-12),
    ];
    let (c, far) = (MAX_COORDINATE, MAX_COORDINATE - 2.0 * MAX_HALF_EXTENT);
    let centres = [Vector3::zeros(), Vector3::new(-c, -c, -c), Vector3::new(c, -c, c)];
    let mut pairs = Vec::new();
    for ha in extents {
        for hb in extents {
            for ra in rotations {
                for rb in rotations {
                    for ca in centres {
                        let a = OrientedBox::new(ca, ra, ha).unwrap();
                        // Toward the origin, so that B stays in the domain.
                        let inward = if ca == Vector3::zeros() { Vector3::x() } else { -ca.normalize() };
                        let touching = ca + inward * touching_distance(&a, &rb, &hb, &inward);
                        let opposite =
                            if ca == Vector3::zeros() { Vector3::repeat(c) } else { -ca.map(|x| x.signum() * far) };
                        for cb in [ca, touching, opposite] {
                            pairs.push((a, OrientedBox::new(cb.map(|x| x.clamp(-c, c)), rb, hb).unwrap()));
                        }
                    }
                }
            }
        }
    }
    pairs
}

/// Every output of the raw kernels for one variant: value, value + gradient + Hessian,
/// margin.
fn raw_outputs(
    variant: (SmoothMax, SmoothAbs),
    a: &OrientedBox,
    b: &OrientedBox,
    alpha: f64,
    alpha_rot: f64,
) -> Vec<f64> {
    let ((pa, ra, ha), (pb, rb, hb)) = (a.kernel_args(), b.kernel_args());
    let (value, (dv, g, h), margin) = match variant {
        (SmoothMax::Lse, SmoothAbs::XTanh) => (
            kernels::ssat_lse_xtanh(&pa, &ra, &ha, &pb, &rb, &hb, alpha, alpha_rot),
            kernels::ssat_lse_xtanh_derivatives(&pa, &ra, &ha, &pb, &rb, &hb, alpha, alpha_rot),
            kernels::ssat_lse_xtanh_margin(&ha, &hb, alpha, alpha_rot),
        ),
        (SmoothMax::Lse, SmoothAbs::Sqrt) => (
            kernels::ssat_lse_sqrt(&pa, &ra, &ha, &pb, &rb, &hb, alpha, alpha_rot),
            kernels::ssat_lse_sqrt_derivatives(&pa, &ra, &ha, &pb, &rb, &hb, alpha, alpha_rot),
            kernels::ssat_lse_sqrt_margin(&ha, &hb, alpha, alpha_rot),
        ),
        (SmoothMax::Boltzmann, SmoothAbs::XTanh) => (
            kernels::ssat_boltzmann_xtanh(&pa, &ra, &ha, &pb, &rb, &hb, alpha, alpha_rot),
            kernels::ssat_boltzmann_xtanh_derivatives(&pa, &ra, &ha, &pb, &rb, &hb, alpha, alpha_rot),
            kernels::ssat_boltzmann_xtanh_margin(&ha, &hb, alpha, alpha_rot),
        ),
        (SmoothMax::Boltzmann, SmoothAbs::Sqrt) => (
            kernels::ssat_boltzmann_sqrt(&pa, &ra, &ha, &pb, &rb, &hb, alpha, alpha_rot),
            kernels::ssat_boltzmann_sqrt_derivatives(&pa, &ra, &ha, &pb, &rb, &hb, alpha, alpha_rot),
            kernels::ssat_boltzmann_sqrt_margin(&ha, &hb, alpha, alpha_rot),
        ),
    };
    [value, dv, margin].into_iter().chain(g).chain(h.into_iter().flatten()).collect()
}

/// Finite outputs and a sound certificate through the public API at every corner of the
/// box and α domains.
#[test]
fn domain_corners_are_finite_and_sound() {
    let pairs = corner_pairs();
    let mut certified = 0;
    for (a, b) in &pairs {
        for alpha in [ALPHA_MIN, ALPHA_MAX] {
            for alpha_rot in [ALPHA_MIN, ALPHA_MAX] {
                for variant in VARIANTS {
                    let p = params(alpha, alpha_rot, variant);
                    check_finite(a, b, &p).unwrap();
                    check_certificate(a, b, &p).unwrap();
                    certified += usize::from(ssat::certified_separated(a, b, &p));
                }
            }
        }
    }
    assert!(certified > pairs.len(), "the corners exercise the certificate: {certified} certified");
}

/// The kernels stay finite 60 decades above [`ALPHA_MAX`] and 140 below [`ALPHA_MIN`] on
/// the same corners (they break near 1e78 and 1e-155): the domain is chosen for meaning,
/// not cut at the edge of what works.
#[test]
fn kernels_have_decades_of_headroom_beyond_the_alpha_domain() {
    let pairs = corner_pairs();
    for (a, b) in &pairs {
        for alpha in [ALPHA_MIN * 1e-140, ALPHA_MAX * 1e60] {
            for alpha_rot in [ALPHA_MIN * 1e-140, ALPHA_MAX * 1e60] {
                for variant in VARIANTS {
                    let out = raw_outputs(variant, a, b, alpha, alpha_rot);
                    assert!(
                        out.iter().all(|x| x.is_finite()),
                        "{variant:?} alpha {alpha:e} alpha_rot {alpha_rot:e}: {out:?}\n{a:?}\n{b:?}"
                    );
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Properties over the whole domain.

/// `PROPTEST_CASES` and `PROPTEST_RNG_SEED` as proptest reads them; without a seed the
/// draws are fixed, so CI runs the same cases every time (as systems/tachyon3/tests/integration/filter_properties.rs).
fn config(ci_cases: u32) -> Config {
    let base = Config::default();
    let cases = std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(ci_cases);
    let rng_seed = if std::env::var_os("PROPTEST_RNG_SEED").is_some() { base.rng_seed } else { RngSeed::Fixed(12) };
    Config { cases, rng_seed, failure_persistence: None, ..base }
}

/// Log-uniform on `[lo, hi]`, with both ends drawn exactly one time in ten each.
fn log_uniform(lo: f64, hi: f64) -> impl Strategy<Value = f64> + Clone {
    prop_oneof![
        1 => Just(lo),
        1 => Just(hi),
        8 => (lo.ln()..=hi.ln()).prop_map(move |x| x.exp().clamp(lo, hi)),
    ]
}

fn sharpness() -> impl Strategy<Value = (f64, f64)> {
    (log_uniform(ALPHA_MIN, ALPHA_MAX), log_uniform(ALPHA_MIN, ALPHA_MAX))
}

fn coordinate() -> impl Strategy<Value = f64> {
    let signed_magnitude = (log_uniform(MIN_HALF_EXTENT, MAX_COORDINATE), any::<bool>());
    prop_oneof![
        Just(0.0),
        Just(MAX_COORDINATE),
        Just(-MAX_COORDINATE),
        -MAX_COORDINATE..=MAX_COORDINATE,
        signed_magnitude.prop_map(|(x, negative)| if negative { -x } else { x }),
    ]
}

fn half_extents() -> impl Strategy<Value = Vector3<f64>> {
    let size = log_uniform(MIN_HALF_EXTENT, MAX_HALF_EXTENT);
    prop_oneof![
        (size.clone(), size.clone(), size.clone()).prop_map(|(x, y, z)| Vector3::new(x, y, z)),
        size.prop_map(Vector3::repeat),
    ]
}

fn unit_vector() -> impl Strategy<Value = Vector3<f64>> {
    prop_oneof![
        (0..3usize, any::<bool>()).prop_map(|(k, negative)| {
            let mut v = Vector3::zeros();
            v[k] = if negative { -1.0 } else { 1.0 };
            v
        }),
        (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64).prop_map(|(x, y, z)| {
            let v = Vector3::new(x, y, z);
            if v.norm() > 1e-3 {
                v.normalize()
            } else {
                Vector3::x()
            }
        }),
    ]
}

/// Uniform on SO(3) from three uniforms (Shoemake's subgroup algorithm).
fn uniform_rotation(u1: f64, u2: f64, u3: f64) -> Rotation3<f64> {
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let q = Quaternion::new(
        b * (2.0 * PI * u3).cos(),
        a * (2.0 * PI * u2).sin(),
        a * (2.0 * PI * u2).cos(),
        b * (2.0 * PI * u3).sin(),
    );
    UnitQuaternion::from_quaternion(q).to_rotation_matrix()
}

/// Exact signed permutations (entries exactly 0 and ±1), yaw only, uniform, a hair off
/// the identity, and uniform but skewed up to the rotation tolerance.
fn rotation() -> impl Strategy<Value = Rotation3<f64>> {
    let uniform = (0.0..1.0f64, 0.0..1.0f64, 0.0..1.0f64).prop_map(|(u1, u2, u3)| uniform_rotation(u1, u2, u3));
    // Entries of up to a quarter of the tolerance keep |RᵀR − I| within √3/2 of it.
    let skew =
        proptest::array::uniform9(-1.0..1.0f64).prop_map(|e| Matrix3::from_row_slice(&e) * (ROTATION_TOLERANCE / 4.0));
    prop_oneof![
        proptest::sample::select(signed_permutations()),
        (-PI..PI).prop_map(|yaw| Rotation3::from_euler_angles(0.0, 0.0, yaw)),
        uniform.clone(),
        (log_uniform(1e-15, 1e-3), unit_vector())
            .prop_map(|(angle, axis)| Rotation3::from_axis_angle(&Unit::new_normalize(axis), angle)),
        (uniform, skew).prop_map(|(r, e)| Rotation3::from_matrix_unchecked(r.matrix() + e)),
    ]
}

/// Where B goes along a direction from A's centre, relative to the distance `t` at which
/// the exact SAT first reads the boxes apart.
#[derive(Debug, Clone, Copy)]
enum Placement {
    /// `fraction · t`: overlapping.
    Deep(f64),
    /// `(1 − x)·t`, x down to 1e-16: overlapping by a hair.
    JustInside(f64),
    /// `t`: touching.
    Touching,
    /// `(1 + x)·t`: apart, by a hair up to ten times `t`.
    JustOutside(f64),
    /// As far along the direction as the coordinate domain reaches.
    Far,
}

fn placement() -> impl Strategy<Value = Placement> {
    prop_oneof![
        2 => (0.0..1.0f64).prop_map(Placement::Deep),
        3 => log_uniform(1e-16, 1e-1).prop_map(Placement::JustInside),
        1 => Just(Placement::Touching),
        4 => log_uniform(1e-16, 1e1).prop_map(Placement::JustOutside),
        1 => Just(Placement::Far),
    ]
}

fn place_pair(
    a: OrientedBox,
    rotation_b: Rotation3<f64>,
    half_b: Vector3<f64>,
    direction: Vector3<f64>,
    place: Placement,
) -> (OrientedBox, OrientedBox) {
    // Where A sits in the outer half of the domain, head inward so that B stays inside.
    let direction =
        direction.zip_map(a.center(), |d, c| if c.abs() > MAX_COORDINATE / 2.0 { -d.abs() * c.signum() } else { d });
    let t = touching_distance(&a, &rotation_b, &half_b, &direction);
    let distance = match place {
        Placement::Deep(fraction) => fraction * t,
        Placement::JustInside(x) => (1.0 - x) * t,
        Placement::Touching => t,
        Placement::JustOutside(x) => (1.0 + x) * t,
        Placement::Far => (0..3)
            .filter(|&k| direction[k] != 0.0)
            .map(|k| (MAX_COORDINATE * direction[k].signum() - a.center()[k]) / direction[k])
            .fold(f64::INFINITY, f64::min),
    };
    let center = (a.center() + direction * distance).map(|x| x.clamp(-MAX_COORDINATE, MAX_COORDINATE));
    (a, OrientedBox::new(center, rotation_b, half_b).expect("B is in the domain"))
}

/// Two boxes anywhere in the domain, B placed relative to where it touches A.
fn box_pair() -> impl Strategy<Value = (OrientedBox, OrientedBox)> {
    let centre = (coordinate(), coordinate(), coordinate()).prop_map(|(x, y, z)| Vector3::new(x, y, z));
    (centre, rotation(), half_extents(), rotation(), half_extents(), unit_vector(), placement()).prop_map(
        |(ca, ra, ha, rb, hb, direction, place)| {
            let a = OrientedBox::new(ca, ra, ha).expect("A is in the domain");
            // B's stored rotation, so the bisection and the pair see the same box.
            let rb = *OrientedBox::new(ca, rb, hb).expect("B's rotation is accepted").rotation();
            place_pair(a, rb, hb, direction, place)
        },
    )
}

fn check_finite(a: &OrientedBox, b: &OrientedBox, p: &SmoothParams) -> Result<(), TestCaseError> {
    let h = ssat::ssat(a, b, p);
    let d = ssat::ssat_with_derivatives(a, b, p);
    let m = ssat::certified_margin(a, b, p);
    let clearance = ssat::certified_clearance(a, b, p);
    let all = [h, d.value, m, clearance].into_iter().chain(d.gradient.iter().copied()).chain(d.hessian.iter().copied());
    prop_assert!(all.clone().all(f64::is_finite), "{:?}: {:?}", p.variant(), all.collect::<Vec<_>>());
    // The value kernel and the derivatives kernel are separate code paths: they agree to rounding.
    prop_assert!((h - d.value).abs() <= documented_guard(a, b, h, m), "{:?}: h {h} vs {}", p.variant(), d.value);
    Ok(())
}

fn check_certificate(a: &OrientedBox, b: &OrientedBox, p: &SmoothParams) -> Result<(), TestCaseError> {
    if ssat::certified_separated(a, b, p) {
        let exact = sat::separation(a, b);
        prop_assert!(
            exact >= -sat_rounding(a, b),
            "{:?} certifies a pair the exact SAT puts {exact:e} apart",
            p.variant()
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(config(5000))]

    /// Value, gradient, Hessian, margin and clearance are finite for every variant.
    #[test]
    fn every_output_is_finite_in_the_domain((a, b) in box_pair(), (alpha, alpha_rot) in sharpness()) {
        for variant in VARIANTS {
            check_finite(&a, &b, &params(alpha, alpha_rot, variant))?;
        }
    }

    /// `certified_separated` ⇒ the exact SAT reads the boxes apart or touching.
    #[test]
    fn certificate_never_contradicts_the_exact_sat((a, b) in box_pair(), (alpha, alpha_rot) in sharpness()) {
        for variant in VARIANTS {
            check_certificate(&a, &b, &params(alpha, alpha_rot, variant))?;
        }
    }

    /// `h − m` is symmetric in A and B but computed along different paths (A's frame or
    /// B's), so the two results differ by rounding only; the guard covers both. The
    /// clearance is `h − m` less the documented guard.
    #[test]
    fn rounding_stays_inside_the_guard((a, b) in box_pair(), (alpha, alpha_rot) in sharpness()) {
        for variant in VARIANTS {
            let p = params(alpha, alpha_rot, variant);
            let (h_ab, m_ab) = (ssat::ssat(&a, &b, &p), ssat::certified_margin(&a, &b, &p));
            let (h_ba, m_ba) = (ssat::ssat(&b, &a, &p), ssat::certified_margin(&b, &a, &p));
            let (g_ab, g_ba) = (documented_guard(&a, &b, h_ab, m_ab), documented_guard(&b, &a, h_ba, m_ba));
            let asymmetry = ((h_ab - m_ab) - (h_ba - m_ba)).abs();
            prop_assert!(
                asymmetry <= g_ab + g_ba,
                "{variant:?}: |Δ(h − m)| = {asymmetry:e} > guards {:e}",
                g_ab + g_ba
            );
            let clearance = ssat::certified_clearance(&a, &b, &p);
            let want = h_ab - m_ab - g_ab;
            let subtraction_rounding = 4.0 * f64::EPSILON * (h_ab.abs() + m_ab + g_ab);
            prop_assert!(
                (clearance - want).abs() <= subtraction_rounding,
                "{variant:?}: clearance {clearance} vs {want}"
            );
        }
    }
}

/// A pair at one scale `s` with `α·s` between 1e-2 and 1e3, B within a few sizes of A,
/// A within a thousand sizes of the origin: conditioned so that a central difference
/// with step `1e-3/α` resolves the derivatives. Across `s` from the smallest to the
/// largest box, `α` spans its whole domain.
fn scaled_case() -> impl Strategy<Value = (OrientedBox, OrientedBox, f64, f64)> {
    let unit_cube = || (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64).prop_map(|(x, y, z)| Vector3::new(x, y, z));
    let shape = || (0.2..1.0f64, 0.2..1.0f64, 0.2..1.0f64).prop_map(|(x, y, z)| Vector3::new(x, y, z));
    (
        log_uniform(MIN_HALF_EXTENT, MAX_HALF_EXTENT),
        log_uniform(1e-2, 1e3),
        log_uniform(1e-2, ALPHA_MAX),
        unit_cube(),
        unit_cube(),
        rotation(),
        rotation(),
        shape(),
        shape(),
    )
        .prop_map(|(s, alpha_s, alpha_rot, ua, ub, ra, rb, sa, sb)| {
            let room = MAX_COORDINATE - 10.0 * s;
            let ca = (ua * 1e3 * s).map(|x| x.clamp(-room, room));
            let half = |shape: Vector3<f64>| (shape * s).map(|x| x.clamp(MIN_HALF_EXTENT, MAX_HALF_EXTENT));
            let a = OrientedBox::new(ca, ra, half(sa)).unwrap();
            let b = OrientedBox::new(ca + ub * 3.0 * s, rb, half(sb)).unwrap();
            (a, b, (alpha_s / s).clamp(ALPHA_MIN, ALPHA_MAX), alpha_rot)
        })
}

proptest! {
    #![proptest_config(config(2000))]

    /// Gradient against central differences of the value, Hessian against central
    /// differences of the gradient, at every scale of the domain.
    #[test]
    fn derivatives_match_finite_differences_at_every_scale((a, b, alpha, alpha_rot) in scaled_case()) {
        let step = 1e-3 / alpha;
        for variant in VARIANTS {
            let p = params(alpha, alpha_rot, variant);
            let d = ssat::ssat_with_derivatives(&a, &b, &p);
            let mut fd_gradient = Vector3::zeros();
            let mut fd_hessian = Matrix3::zeros();
            for k in 0..3 {
                let (mut plus, mut minus) = (*b.center(), *b.center());
                plus[k] += step;
                minus[k] -= step;
                let width = plus[k] - minus[k]; // the step as represented
                let (bp, bm) = (b.with_center(plus).unwrap(), b.with_center(minus).unwrap());
                fd_gradient[k] = (ssat::ssat(&a, &bp, &p) - ssat::ssat(&a, &bm, &p)) / width;
                let gradient_at = |b: &OrientedBox| ssat::ssat_with_derivatives(&a, b, &p).gradient;
                fd_hessian.set_column(k, &((gradient_at(&bp) - gradient_at(&bm)) / width));
            }
            let gradient_error = (fd_gradient - d.gradient).abs().max();
            prop_assert!(gradient_error <= 1e-5 * d.gradient.abs().max().max(1.0),
                "{variant:?}: gradient {:?} vs central differences {:?}", d.gradient, fd_gradient);
            // The Hessian's natural scale is the sharpness α (curvature 1/smoothing length).
            let hessian_error = (fd_hessian - d.hessian).abs().max();
            prop_assert!(hessian_error <= 1e-4 * alpha.max(d.hessian.abs().max()),
                "{variant:?}: Hessian error {hessian_error:e} at alpha {alpha:e}");
        }
    }
}

/// The pair strategy reaches what the properties are about: overlapping, touching and
/// certified pairs, the extremes of every bound. Otherwise they would pass vacuously.
#[test]
fn generated_pairs_reach_the_interesting_cases() {
    let n = 2000;
    let mut runner = TestRunner::deterministic();
    let strategy = (box_pair(), sharpness());
    let (mut overlapping, mut near_touching, mut certified, mut extreme_extent, mut corner_coordinate) =
        (0, 0, 0, 0, 0);
    for _ in 0..n {
        let ((a, b), (alpha, alpha_rot)) = strategy.new_tree(&mut runner).unwrap().current();
        let exact = sat::separation(&a, &b);
        overlapping += usize::from(exact < 0.0);
        near_touching += usize::from(exact.abs() <= 1e-9 * offset_and_extents(&a, &b));
        certified +=
            usize::from(VARIANTS.into_iter().any(|v| ssat::certified_separated(&a, &b, &params(alpha, alpha_rot, v))));
        let extents = a.half_extents().iter().chain(b.half_extents().iter());
        extreme_extent += usize::from(extents.into_iter().any(|&h| h == MIN_HALF_EXTENT || h == MAX_HALF_EXTENT));
        corner_coordinate += usize::from(a.center().iter().any(|c| c.abs() == MAX_COORDINATE));
    }
    for (what, count) in [
        ("overlapping", overlapping),
        ("near touching", near_touching),
        ("certified", certified),
        ("at an extent bound", extreme_extent),
        ("at a coordinate bound", corner_coordinate),
    ] {
        assert!(count >= n / 10, "only {count} of {n} generated pairs are {what}");
    }
}
