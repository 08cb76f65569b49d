//! The certified sphere–box clearance (`cbfgen::sphere_box`, Tachyon 3's toe–edge rows)
//! against exact sphere–box distance: on over a million random and adversarial pairs, no
//! pair the barrier certifies (h ≥ 0) overlaps, and the conservatism stays within the
//! documented bound. The exact distance is checked against a second, world-frame
//! implementation everywhere and against parry3d on a subset.

use crate::tachyon3_state;
use cbfgen_testkit::boxes as common;

use cbfgen::geometry::{MAX_COORDINATE, MAX_HALF_EXTENT, MIN_HALF_EXTENT};
use cbfgen::sphere_box::{self, Smoothing, Sphere, ALPHA_MAX, ALPHA_MIN, DEFAULT_ALPHA};
use cbfgen::{CbfError, OrientedBox};
use cbfgen_tachyon3::catalog::{Capacity, Catalog, EdgeCuboid, Environment, Family};
use cbfgen_tachyon3::generated as gen;
use cbfgen_tachyon3::model::TOE_RADIUS;
use common::{random_rotation, rng};
use nalgebra::{Rotation3, Vector3};
use parry3d_f64::math::{Pose, Rot3, Vec3};
use parry3d_f64::query::contact;
use parry3d_f64::shape::{Ball, Cuboid};
use rand::Rng;
use std::f64::consts::PI;
use tachyon3_state::random_state;

// ---------------------------------------------------------------------- truths

/// The exact signed distance computed a second way: the closest point of the box by
/// clamping along each world-frame axis, and the depth to the nearest face inside.
fn world_frame_distance(center: &Vector3<f64>, radius: f64, b: &OrientedBox) -> f64 {
    let r = b.rotation().matrix();
    let offset = center - b.center();
    let mut closest = *b.center();
    let mut depth = f64::INFINITY;
    for k in 0..3 {
        let axis = r.column(k);
        let t = offset.dot(&axis);
        let a = b.half_extents()[k];
        closest += axis * t.clamp(-a, a);
        depth = depth.min(a - t.abs());
    }
    if depth > 0.0 {
        -depth - radius
    } else {
        (center - closest).norm() - radius
    }
}

/// parry3d's signed contact distance between a ball and a cuboid (negative: penetration).
fn parry_distance(center: &Vector3<f64>, radius: f64, b: &OrientedBox) -> f64 {
    let q = nalgebra::UnitQuaternion::from_rotation_matrix(b.rotation());
    let c = b.center();
    let box_pose = Pose::from_parts(Vec3::new(c.x, c.y, c.z), Rot3::from_xyzw(q.i, q.j, q.k, q.w));
    let ball_pose = Pose::from_parts(Vec3::new(center.x, center.y, center.z), Rot3::IDENTITY);
    let h = b.half_extents();
    contact(&ball_pose, &Ball::new(radius), &box_pose, &Cuboid::new(Vec3::new(h.x, h.y, h.z)), f64::INFINITY)
        .expect("ball-cuboid is supported")
        .expect("an infinite prediction always reports")
        .dist
}

/// The problem's scale, for rounding tolerances (the rounding guard's `S` without h).
fn scale(center: &Vector3<f64>, radius: f64, b: &OrientedBox) -> f64 {
    (center - b.center()).abs().sum() + b.half_extents().sum() + radius
}

// ------------------------------------------------------------------ generators

/// Where a case's sphere centre was put, relative to the box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Near {
    Face,
    Edge,
    Corner,
    Inside,
    Anywhere,
}

const NEAR: [Near; 5] = [Near::Face, Near::Edge, Near::Corner, Near::Inside, Near::Anywhere];

/// Box half extents: the stair nosing (5 cm and 2.5 cm square sections), thin, flat,
/// long and tiny boxes, cubes, and random log-uniform ones.
fn random_half(r: &mut impl Rng) -> Vector3<f64> {
    let log = |r: &mut dyn rand::RngCore, lo: f64, hi: f64| 10f64.powf(r.random_range(lo..hi));
    let mut h = match r.random_range(0..8) {
        0 => Vector3::new(0.025, 1.0, 0.025),
        1 => Vector3::new(0.0125, 0.5, 0.0125),
        2 => Vector3::new(log(r, -4.0, -2.0), log(r, -1.0, 0.5), log(r, -1.0, 0.5)), // plate
        3 => Vector3::new(log(r, -4.0, -2.0), log(r, -4.0, -2.0), log(r, -0.5, 1.0)), // rod
        4 => Vector3::repeat(log(r, -3.0, 0.5)),                                     // cube
        5 => Vector3::new(log(r, -6.0, -4.0), log(r, -6.0, -4.0), log(r, -6.0, -4.0)), // tiny
        _ => Vector3::new(log(r, -3.0, 0.5), log(r, -3.0, 0.5), log(r, -3.0, 0.5)),
    };
    // Shuffle the axes so the thin direction is not always x.
    let k = r.random_range(0..3);
    h.swap_rows(0, k);
    h
}

fn random_box_rotation(r: &mut impl Rng) -> Rotation3<f64> {
    match r.random_range(0..4) {
        0 => Rotation3::identity(),
        1 => Rotation3::from_euler_angles(0.0, 0.0, r.random_range(-PI..PI)), // stair edges: yaw only
        2 => Rotation3::from_euler_angles(1e-7 * r.random_range(-1.0..1.0), 0.0, 1e-7), // nearly aligned
        _ => random_rotation(r),
    }
}

/// A gap to aim for between the sphere's surface and the box (its exact distance).
fn random_gap(r: &mut impl Rng, radius: f64, margin: f64) -> f64 {
    let sign = if r.random_bool(0.5) { 1.0 } else { -1.0 };
    let tiny = 10f64.powf(r.random_range(-9.0..-4.0));
    match r.random_range(0..6) {
        0 => sign * tiny,                                    // touching, either side
        1 => margin + sign * tiny,                           // where the certificate switches on
        2 => margin * r.random_range(0.0..3.0),              // within a few margins
        3 => r.random_range(-radius..0.05),                  // the ECBF's working range
        4 => 2.0 * margin + r.random_range(0.0..2.0) * 1e-3, // the conservatism bound's range
        _ => r.random_range(-radius..1.0),
    }
}

fn random_radius(r: &mut impl Rng) -> f64 {
    match r.random_range(0..4) {
        0 => 0.0, // a point: the margin's worst case sits at the corners
        1 => 10f64.powf(r.random_range(-6.0..-3.0)),
        2 => TOE_RADIUS,
        _ => r.random_range(0.0..0.5),
    }
}

/// A unit vector with non-negative entries.
fn positive_direction(r: &mut impl Rng, dims: usize) -> [f64; 3] {
    let mut v = [0.0; 3];
    for x in v.iter_mut().take(dims) {
        *x = r.random_range(0.0..1.0f64);
    }
    let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if n < 1e-12 {
        return [1.0, 0.0, 0.0];
    }
    v.map(|x| x / n)
}

/// A sphere centre in the box frame whose exact outside distance is `d` (≥ 0) beyond the
/// chosen feature, or a point inside for `Near::Inside`.
fn local_centre(r: &mut impl Rng, near: Near, half: &Vector3<f64>, d: f64) -> Vector3<f64> {
    let sign = |r: &mut dyn rand::RngCore| if r.random_bool(0.5) { 1.0 } else { -1.0 };
    // A coordinate within the face, sometimes right at its rim.
    let within = |r: &mut dyn rand::RngCore, a: f64| {
        let u: f64 = if r.random_bool(0.2) { 1.0 - 10f64.powf(r.random_range(-12.0..-2.0)) } else { r.random() };
        sign(r) * a * u
    };
    let axes = {
        let mut a = [0usize, 1, 2];
        let k = r.random_range(0..3);
        a.swap(0, k);
        if r.random_bool(0.5) {
            a.swap(1, 2);
        }
        a
    };
    let mut p = Vector3::zeros();
    match near {
        Near::Face => {
            p[axes[0]] = sign(r) * (half[axes[0]] + d);
            p[axes[1]] = within(r, half[axes[1]]);
            p[axes[2]] = within(r, half[axes[2]]);
        }
        Near::Edge => {
            let n = positive_direction(r, 2);
            p[axes[0]] = sign(r) * (half[axes[0]] + d * n[0]);
            p[axes[1]] = sign(r) * (half[axes[1]] + d * n[1]);
            p[axes[2]] = within(r, half[axes[2]]);
        }
        Near::Corner => {
            let n = positive_direction(r, 3);
            for k in 0..3 {
                p[k] = sign(r) * (half[k] + d * n[k]);
            }
        }
        Near::Inside => {
            for k in 0..3 {
                p[k] = within(r, half[k]);
            }
        }
        Near::Anywhere => {
            for k in 0..3 {
                p[k] = r.random_range(-1.0..1.0) * (half[k] + 3.0 * d + 0.01);
            }
        }
    }
    p
}

struct Case {
    sphere: Sphere,
    edge: OrientedBox,
    smoothing: Smoothing,
    near: Near,
}

fn random_case(r: &mut impl Rng, far: bool) -> Case {
    let half = random_half(r);
    let rotation = random_box_rotation(r);
    let centre = if far {
        Vector3::from_fn(|_, _| r.random_range(-1e3..1e3))
    } else {
        Vector3::from_fn(|_, _| r.random_range(-2.0..2.0))
    };
    let edge = OrientedBox::new(centre, rotation, half).expect("valid box");
    let alpha = if r.random_bool(0.7) { DEFAULT_ALPHA } else { 10f64.powf(r.random_range(1.0..5.0)) };
    let smoothing = Smoothing::new(alpha).expect("alpha in domain");
    let radius = random_radius(r);
    let near = NEAR[r.random_range(0..NEAR.len())];
    let gap = if far { r.random_range(5e2..1.5e3) } else { random_gap(r, radius, sphere_box::margin(&smoothing)) };
    // The outside distance of the centre; a negative one goes inside.
    let d = radius + gap;
    let (near, d) = if d < 0.0 { (Near::Inside, 0.0) } else { (near, d) };
    let local = local_centre(r, near, &half, d);
    let sphere = Sphere::new(centre + rotation * local, radius).expect("valid sphere");
    Case { sphere, edge, smoothing, near }
}

// ------------------------------------------------------------------------ tests

#[derive(Default)]
struct Tally {
    pairs: usize,
    certified: usize,
    certified_within_two_margins: usize,
    overlapping: usize,
    tiny_gaps: [usize; 2],
    inside: usize,
    far: usize,
    parry_checked: usize,
    worst_conservatism_ratio: f64,
    worst_truth_disagreement: f64,
    failures: Vec<String>,
}

fn check(case: &Case, t: &mut Tally, with_parry: bool) {
    let (s, b, p) = (&case.sphere, &case.edge, &case.smoothing);
    let (c, radius) = (s.center(), s.radius());
    let exact = sphere_box::exact_distance(c, radius, b);
    let other = world_frame_distance(c, radius, b);
    let sc = scale(c, radius, b);
    // The world-frame closest point carries the rounding of the world coordinates too.
    let world = sc + c.abs().sum() + b.center().abs().sum();
    t.worst_truth_disagreement = t.worst_truth_disagreement.max((exact - other).abs() / world);
    assert!((exact - other).abs() <= 64.0 * f64::EPSILON * world, "two exact distances disagree: {exact} vs {other}");
    if with_parry && radius > 0.0 {
        let theirs = parry_distance(c, radius, b);
        // parry reports a centre on the box surface (within its epsilon) as penetrating
        // by the full radius, so centres that close to the surface are left out.
        if (exact + radius).abs() > 1e-6 * sc.max(1.0) {
            assert!((exact - theirs).abs() <= 1e-9 * sc.max(1.0), "parry {theirs} vs exact {exact}");
            t.parry_checked += 1;
        }
    }

    let h = sphere_box::clearance(s, b, p);
    let guarded = sphere_box::certified_clearance(s, b, p);
    let (m, bound) = (sphere_box::margin(p), sphere_box::conservatism(p));
    // Rounding of h, on the rounding guard's scale S (see `cbfgen::sphere_box`).
    let rounding = 64.0 * f64::EPSILON * (sc + h.abs() + m);
    let derivatives = sphere_box::clearance_with_derivatives(s, b, p);
    assert!(h.is_finite() && guarded <= h, "h {h}, guarded {guarded}");
    assert!(
        derivatives.value.to_bits() == h.to_bits() || (derivatives.value - h).abs() <= rounding,
        "{} vs {h}",
        derivatives.value
    );
    assert!(derivatives.gradient.iter().chain(derivatives.hessian.iter()).all(|v| v.is_finite()));

    t.pairs += 1;
    t.overlapping += usize::from(exact < 0.0);
    if exact != 0.0 && exact.abs() <= 1e-4 {
        t.tiny_gaps[usize::from(exact > 0.0)] += 1;
    }
    // The certificate: the raw value (exact arithmetic's claim) and the guarded one.
    for (what, value) in [("h", h), ("certified_clearance", guarded)] {
        if value >= 0.0 && (exact < 0.0 || other < 0.0) {
            t.failures.push(format!(
                "{what} = {value:e} certifies an overlap: exact {exact:e} / {other:e}, sphere {s:?}, box {b:?}, alpha {}",
                p.alpha()
            ));
        }
    }
    if guarded >= 0.0 {
        t.certified += 1;
        t.certified_within_two_margins += usize::from(exact < 2.0 * m);
    }
    let outside = exact + radius > 0.0;
    if outside {
        // h ≤ exact ≤ h + conservatism, up to rounding.
        assert!(h <= exact + rounding, "h {h:e} above exact {exact:e} ({:?})", case.near);
        assert!(exact - h <= bound + rounding, "exact - h = {:e} above the bound {bound:e}", exact - h);
        t.worst_conservatism_ratio = t.worst_conservatism_ratio.max((exact - h) / bound);
    } else {
        t.inside += 1;
        assert!(h >= -radius - m - rounding && h <= -radius + rounding, "inside: h {h:e}, r {radius}, m {m:e}");
    }
}

#[test]
fn certified_clearance_never_certifies_an_overlap_on_a_million_pairs() {
    let mut r = rng(2024);
    let mut t = Tally::default();
    let n = 1_000_000;
    for i in 0..n {
        let far = i % 50 == 0;
        let case = random_case(&mut r, far);
        t.far += usize::from(far);
        check(&case, &mut t, i % 10 == 0);
    }
    println!(
        "{} pairs: {} overlapping, {} inside, {} far, tiny gaps {} below / {} above, {} certified ({} of them \
         within two margins of contact), parry compared on {}; worst (exact - h) / bound {:.4}; worst disagreement \
         of the two exact distances {:.1e} of the scale",
        t.pairs,
        t.overlapping,
        t.inside,
        t.far,
        t.tiny_gaps[0],
        t.tiny_gaps[1],
        t.certified,
        t.certified_within_two_margins,
        t.parry_checked,
        t.worst_conservatism_ratio,
        t.worst_truth_disagreement
    );
    assert!(t.failures.is_empty(), "{} failures, first: {}", t.failures.len(), t.failures[0]);
    // The sample reaches every regime the certificate must hold in.
    assert!(t.pairs >= 1_000_000 && t.far >= 10_000 && t.inside >= 50_000 && t.parry_checked >= 50_000);
    assert!(t.overlapping >= 100_000 && t.certified >= 100_000, "{} / {}", t.overlapping, t.certified);
    assert!(t.tiny_gaps.iter().all(|&k| k >= 10_000), "{:?}", t.tiny_gaps);
    // Pairs certified barely beyond the margin: the certificate is tested where it is tight.
    assert!(t.certified_within_two_margins >= 10_000, "{}", t.certified_within_two_margins);
    // The bound is approached, not merely respected.
    assert!(t.worst_conservatism_ratio > 0.5, "{}", t.worst_conservatism_ratio);
}

/// The margin's worst case: a point (r = 0) at a box corner, where all three axes'
/// smooth maxima overshoot at once. Along the corner's diagonal h must cross 0 outside
/// the box (the certificate) and within the conservatism bound; the crossing shows how
/// tight the margin is there. Along a face the same holds.
#[test]
fn h_crosses_zero_within_the_documented_bounds_at_corners_and_faces() {
    let p = Smoothing::default();
    let (m, bound) = (sphere_box::margin(&p), sphere_box::conservatism(&p));
    let b = OrientedBox::axis_aligned(Vector3::zeros(), Vector3::new(0.0125, 0.5, 0.0125)).unwrap();
    let h_at = |v: Vector3<f64>| sphere_box::clearance(&Sphere::new(v, 0.0).unwrap(), &b, &p);
    let corner = Vector3::new(0.0125, 0.5, 0.0125);
    for (what, start, direction) in [
        ("corner", corner, Vector3::repeat(1.0).normalize()),
        ("face", Vector3::new(0.0125, 0.0, 0.0), Vector3::x()),
        ("edge", Vector3::new(0.0125, 0.0, 0.0125), Vector3::new(1.0, 0.0, 1.0).normalize()),
    ] {
        let (mut lo, mut hi) = (0.0, 2.0 * bound);
        assert!(h_at(start) < 0.0 && h_at(start + direction * hi) > 0.0, "{what}");
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if h_at(start + direction * mid) < 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        println!(
            "{what}: h crosses 0 at {:.4} mm from contact (margin {:.4} mm, bound {:.4} mm)",
            hi * 1e3,
            m * 1e3,
            bound * 1e3
        );
        assert!(hi > 0.0 && hi <= bound, "{what}: {hi:e}");
        // The margin is what the corner needs: h = 0 there lies within a few % of m
        // (the smooth |.|'s slack ε²/2a moves it in by ~3 % on the 1.25 cm side).
        if what == "corner" {
            assert!((hi - m).abs() <= 0.05 * m, "corner crossing {hi:e} vs margin {m:e}");
        }
    }
}

#[test]
fn clearance_derivatives_match_finite_differences() {
    let mut r = rng(7);
    let step = 1e-6;
    for _ in 0..5_000 {
        let case = random_case(&mut r, false);
        let (s, b, p) = (&case.sphere, &case.edge, &case.smoothing);
        if b.half_extents().min() < 1e-3 || p.alpha() > 3e3 {
            continue; // curvature ~alpha / extent: a 1e-6 step is not small there
        }
        let d = sphere_box::clearance_with_derivatives(s, b, p);
        let at = |v: Vector3<f64>| sphere_box::clearance_with_derivatives(&Sphere::new(v, s.radius()).unwrap(), b, p);
        for k in 0..3 {
            let e = Vector3::ith(k, step);
            let (plus, minus) = (at(s.center() + e), at(s.center() - e));
            let fd_grad = (plus.value - minus.value) / (2.0 * step);
            let fd_hess = (plus.gradient - minus.gradient) / (2.0 * step);
            let curvature = d.hessian.abs().max().max(1.0);
            assert!(
                (fd_grad - d.gradient[k]).abs() <= 1e-6 * curvature,
                "gradient {k}: {fd_grad} vs {}",
                d.gradient[k]
            );
            for j in 0..3 {
                let third = 1e-5 * curvature * curvature.max(p.alpha());
                assert!(
                    (fd_hess[j] - d.hessian[(j, k)]).abs() <= 1e-4 * curvature + third * step,
                    "hessian ({j}, {k}): {} vs {}",
                    fd_hess[j],
                    d.hessian[(j, k)]
                );
            }
        }
        // Well outside the box (many smoothing lengths) the gradient is nearly a unit
        // vector, a distance's slope.
        if sphere_box::exact_distance(s.center(), 0.0, b) > 50.0 / p.alpha() {
            assert!((d.gradient.norm() - 1.0).abs() < 1e-2, "|grad h| = {}", d.gradient.norm());
        }
    }
}

// ------------------------------------------------------------ domain and errors

#[test]
fn inputs_are_validated_with_typed_errors() {
    assert!(matches!(Sphere::new(Vector3::new(f64::NAN, 0.0, 0.0), 0.1), Err(CbfError::NonFinite { .. })));
    assert!(matches!(Sphere::new(Vector3::zeros(), f64::INFINITY), Err(CbfError::NonFinite { .. })));
    assert!(matches!(Sphere::new(Vector3::zeros(), -1e-3), Err(CbfError::OutOfRange { .. })));
    assert!(matches!(Sphere::new(Vector3::new(0.0, 2e6, 0.0), 0.1), Err(CbfError::OutOfRange { .. })));
    assert!(matches!(Sphere::new(Vector3::zeros(), 2e4), Err(CbfError::OutOfRange { .. })));
    assert!(matches!(Smoothing::new(f64::NAN), Err(CbfError::NonFinite { .. })));
    for alpha in [0.0, -1.0, ALPHA_MIN / 2.0, ALPHA_MAX * 2.0] {
        assert!(matches!(Smoothing::new(alpha), Err(CbfError::OutOfRange { .. })), "{alpha}");
    }
    // The exact distance takes anything and says NaN, not a number, for non-finite input.
    let b = OrientedBox::axis_aligned(Vector3::zeros(), Vector3::repeat(1.0)).unwrap();
    for (c, r) in
        [(Vector3::new(f64::NAN, 0.0, 0.0), 0.1), (Vector3::repeat(f64::INFINITY), 0.1), (Vector3::zeros(), f64::NAN)]
    {
        assert!(sphere_box::exact_distance(&c, r, &b).is_nan());
    }
    assert_eq!(sphere_box::exact_distance(&Vector3::new(3.0, 0.0, 0.0), 0.5, &b), 1.5);
    assert_eq!(sphere_box::exact_distance(&Vector3::new(0.25, 0.0, 0.0), 0.5, &b), -1.25);
}

/// At the corners of the documented domain every output is finite and the certificate
/// holds (the guarded value; the raw one may lose the margin to rounding at α = 1e9
/// and 1e6 m coordinates, which is what the guard is for).
#[test]
fn outputs_are_finite_and_certified_at_the_domain_corners() {
    let mut r = rng(99);
    let coordinates = [0.0, 1.0, MAX_COORDINATE];
    let extents = [MIN_HALF_EXTENT, 0.0125, 1.0, MAX_HALF_EXTENT];
    let (mut cases, mut certified) = (0, 0);
    for &alpha in &[ALPHA_MIN, 1.0, DEFAULT_ALPHA, ALPHA_MAX] {
        let p = Smoothing::new(alpha).unwrap();
        for &c in &coordinates {
            for &a in &extents {
                for &radius in &[0.0, TOE_RADIUS, MAX_HALF_EXTENT] {
                    for _ in 0..20 {
                        let rot = random_rotation(&mut r);
                        let centre = Vector3::new(c, -c, c);
                        let b = OrientedBox::new(centre, rot, Vector3::new(a, 0.5 * a + MIN_HALF_EXTENT, a)).unwrap();
                        let spread = (a + radius) * 3.0 + 1.0;
                        let raw = centre + Vector3::from_fn(|_, _| r.random_range(-spread..spread));
                        let point = raw.map(|v| v.clamp(-MAX_COORDINATE, MAX_COORDINATE));
                        let s = Sphere::new(point, radius).unwrap();
                        let h = sphere_box::clearance(&s, &b, &p);
                        let d = sphere_box::clearance_with_derivatives(&s, &b, &p);
                        let all = [h, sphere_box::margin(&p), sphere_box::conservatism(&p), d.value];
                        assert!(all.iter().chain(d.gradient.iter()).chain(d.hessian.iter()).all(|v| v.is_finite()));
                        if sphere_box::certified_separated(&s, &b, &p) {
                            certified += 1;
                            assert!(sphere_box::exact_distance(s.center(), radius, &b) >= 0.0, "{s:?} {b:?} {alpha}");
                        }
                        cases += 1;
                    }
                }
            }
        }
    }
    println!("{certified} of {cases} domain-corner cases certified");
    assert!(certified > 0);
}

// ----------------------------------------------------- the catalog's toe rows

/// Every toe–edge row of the catalog that reads h ≥ 0 has its toe sphere clear of its
/// edge cuboid by exact distance, for edges placed against a random toe (faces, edges,
/// corners, within a few margins), and the rows are the library's clearance.
#[test]
fn every_nonnegative_toe_row_of_the_catalog_is_clear_by_exact_distance() {
    let mut r = rng(31);
    let edges = 4;
    let capacity = Capacity::edges(edges, [1; 6]);
    let mut catalog = Catalog::new(capacity).unwrap();
    let mut env = Environment::new(capacity).unwrap();
    let p = Smoothing::new(gen::TOE_ALPHA).unwrap();
    let m = sphere_box::margin(&p);
    let (mut rows, mut certified, mut tight, mut overlapping) = (0, 0, 0, 0);
    for _ in 0..20_000 {
        let x = random_state(&mut r);
        let (_, _, toes) = gen::world_kinematics(&x);
        env.clear_edges();
        let mut boxes = Vec::new();
        for _ in 0..edges {
            // An edge cuboid placed so a chosen toe sits near one of its features.
            let toe = Vector3::from(toes[r.random_range(0..6)]);
            let half = random_half(&mut r).map(|v| v.clamp(1e-3, 1.0));
            let rotation = random_box_rotation(&mut r);
            let near = [Near::Face, Near::Edge, Near::Corner][r.random_range(0..3)];
            let d = (TOE_RADIUS + random_gap(&mut r, TOE_RADIUS, m)).max(0.0);
            let local = local_centre(&mut r, near, &half, d);
            let b = OrientedBox::new(toe - rotation * local, rotation, half).unwrap();
            env.push_edge(EdgeCuboid::from_box(&b)).unwrap();
            boxes.push(b);
        }
        catalog.evaluate(&x, &env).unwrap();
        for (slot, row) in catalog.slots().zip(catalog.rows()) {
            if slot.family != Family::ToeEdge {
                continue;
            }
            let (leg, b) = (slot.leg.expect("toe rows name their leg"), &boxes[slot.instance]);
            let toe = Vector3::from(toes[leg]);
            let exact = sphere_box::exact_distance(&toe, TOE_RADIUS, b);
            let library = sphere_box::clearance(&Sphere::new(toe, TOE_RADIUS).unwrap(), b, &p);
            let h = row.h();
            assert!((h - library).abs() <= 1e-12, "row {h} vs library {library}");
            assert!(row.lie.iter().chain(row.lg.iter()).all(|v| v.is_finite()));
            if h >= 0.0 {
                certified += 1;
                tight += usize::from(exact < 2.0 * m);
                assert!(exact >= 0.0, "toe {leg} row h = {h:e} but exact distance {exact:e}: {b:?}");
            }
            overlapping += usize::from(exact < 0.0);
            rows += 1;
        }
    }
    println!(
        "{rows} toe rows: {certified} with h >= 0 ({tight} within two margins of contact), {overlapping} overlapping"
    );
    assert!(certified > rows / 10 && overlapping > rows / 20 && tight > 1_000, "{certified} {overlapping} {tight}");
}
