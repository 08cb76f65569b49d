//! The generated constraint rows against numerical Lie derivatives and hand-built cases.

use crate::tachyon3_state;
use cbfgen::ops::{Counted, OpCount};
use cbfgen::system::BarrierSet;
use cbfgen_testkit::boxes as common;

use cbfgen_tachyon3::catalog::{Capacity, Catalog, EdgeCuboid, Environment, Family, HalfPlane, StabilityBound};
use cbfgen_tachyon3::generated::{self as gen, FootholdPullParams};
use cbfgen_tachyon3::model::{self, State, BODY_PITCH, BODY_X, BODY_Z, NU, NX, TOE_BLOCK};
use common::{random_rotation, random_vector, rng};
use nalgebra::{Matrix3, Rotation3, Vector2, Vector3};
use rand::Rng;
use tachyon3_state::random_state;

/// One kernel's rows at a state: per row [h, L_f h, L_f² h] and the dense L_g L_f h.
type Rows = Vec<([f64; 3], [f64; NU])>;
type RowFn = Box<dyn Fn(&State) -> Rows>;

fn dense<const C: usize>(lg: &[f64; C], columns: &[usize]) -> [f64; NU] {
    let mut out = [0.0; NU];
    for (&c, &v) in columns.iter().zip(lg) {
        out[c] = v;
    }
    out
}

fn rows_of<const R: usize, const C: usize>(out: ([[f64; 3]; R], [[f64; C]; R]), columns: &[usize]) -> Rows {
    (0..R).map(|i| (out.0[i], dense(&out.1[i], columns))).collect()
}

/// An edge cuboid near the robot in the kernels' argument layout: centre, row-major
/// rotation (yaw-only half of the time, like stair edges), half extents.
fn random_edge(r: &mut impl Rng) -> (Vector3<f64>, Matrix3<f64>, Vector3<f64>) {
    let rot = if r.random_bool(0.5) {
        Rotation3::from_euler_angles(0.0, 0.0, r.random_range(-3.0..3.0))
    } else {
        random_rotation(r)
    };
    let (c, h, m) = (random_vector(r, -1.5, 1.5), random_vector(r, 0.02, 0.5), rot.matrix());
    (c, *m, h)
}

/// Every row kernel of the model with freshly drawn runtime parameters.
fn kernels_with_random_params(r: &mut impl Rng) -> Vec<(String, RowFn)> {
    let mut out: Vec<(String, RowFn)> = Vec::new();
    let (ca, ra, ha) = random_edge(r);
    out.push((
        "body_edge_ssat".into(),
        Box::new(move |x| rows_of(gen::body_edge(x, &ca, &ra, &ha), &gen::BODY_EDGE_INPUT_COLUMNS)),
    ));
    let normal = {
        let a: f64 = r.random_range(-3.2..3.2);
        Vector2::new(a.cos(), a.sin())
    };
    let offset = r.random_range(-1.0..1.0);
    let floor = r.random_range(-0.2..0.2);
    let (sa, sb) = (if r.random_bool(0.5) { 1.0 } else { -1.0 }, r.random_range(-0.5..0.5));
    for leg in 0..6 {
        let name = gen::LEG_NAMES[leg];
        out.push((
            format!("joint_limits[{name}]"),
            Box::new(move |x| rows_of(gen::JOINT_LIMITS[leg](x), gen::JOINT_LIMITS_INPUT_COLUMNS[leg])),
        ));
        out.push((
            format!("toe_edge[{name}]"),
            Box::new(move |x| {
                // One kernel gives every toe's row, on the union of their columns.
                let (lie, lg) = gen::toe_edge(x, &ca, &ra, &ha);
                rows_of(([lie[leg]], [lg[leg]]), &gen::TOE_EDGE_INPUT_COLUMNS)
            }),
        ));
        out.push((
            format!("foothold[{name}]"),
            Box::new(move |x| rows_of(gen::FOOTHOLD[leg](x, &normal, offset), gen::FOOTHOLD_INPUT_COLUMNS[leg])),
        ));
        out.push((
            format!("foot_height[{name}]"),
            Box::new(move |x| rows_of(gen::FOOT_HEIGHT[leg](x, floor), gen::FOOT_HEIGHT_INPUT_COLUMNS[leg])),
        ));
        out.push((
            format!("stability[{name}]"),
            Box::new(move |x| rows_of(gen::STABILITY[leg](x, sa, sb), gen::STABILITY_INPUT_COLUMNS[leg])),
        ));
    }
    out
}

fn shifted(x: &State, dir: &State, eps: f64) -> State {
    std::array::from_fn(|k| x[k] + eps * dir[k])
}

/// Column u of g(x) as a state-space direction.
fn g_column(x: &State, u: usize) -> State {
    let mut dir = [0.0; NX];
    for (&(row, col), v) in gen::INPUT_MATRIX_PATTERN.iter().zip(gen::input_matrix_nonzeros(x)) {
        if col == u {
            dir[row] = v;
        }
    }
    dir
}

/// A central difference of values of magnitude `scale` with step `step` is trusted to
/// 1e-6 relative (truncation) plus its rounding error, ~1e-15 * scale / step.
fn assert_close(numeric: f64, analytic: f64, scale: f64, step: f64, what: &str) {
    let tol = 1e-6 * analytic.abs().max(1.0) + 1e-15 * scale / step;
    assert!((numeric - analytic).abs() <= tol, "{what}: analytic {analytic} vs FD {numeric} (tol {tol:e})");
}

#[test]
fn lie_derivatives_match_finite_differences_along_f_and_g() {
    let mut r = rng(17);
    let eps = 1e-6;
    // L_f h is linear in the velocity states g moves, so a long step along g is exact.
    let eps_g = 1e-3;
    let mut checked = 0usize;
    let mut nonzero_seen: std::collections::HashMap<(String, usize), bool> = Default::default();
    for _ in 0..1000 {
        let x = random_state(&mut r);
        let f = gen::drift(&x);
        for (name, kernel) in kernels_with_random_params(&mut r) {
            let at = kernel(&x);
            let plus_f = kernel(&shifted(&x, &f, eps));
            let minus_f = kernel(&shifted(&x, &f, -eps));
            for (k, (lie, lg)) in at.iter().enumerate() {
                // L_f h and L_f^2 h: derivatives along f of the kernel's own h and L_f h.
                let lf_fd = (plus_f[k].0[0] - minus_f[k].0[0]) / (2.0 * eps);
                let lf2_fd = (plus_f[k].0[1] - minus_f[k].0[1]) / (2.0 * eps);
                let h_scale = plus_f[k].0[0].abs().max(minus_f[k].0[0].abs());
                let lf_scale = plus_f[k].0[1].abs().max(minus_f[k].0[1].abs());
                assert_close(lf_fd, lie[1], h_scale, eps, &format!("{name} row {k}: L_f h"));
                assert_close(lf2_fd, lie[2], lf_scale, eps, &format!("{name} row {k}: L_f^2 h"));
                for (u, &lg_u) in lg.iter().enumerate() {
                    let gu = g_column(&x, u);
                    let (p, m) = (kernel(&shifted(&x, &gu, eps_g)), kernel(&shifted(&x, &gu, -eps_g)));
                    // Relative degree 2: h itself does not see the input...
                    assert_eq!(p[k].0[0], m[k].0[0], "{name} row {k}: h depends on input {u}");
                    // ...and L_g L_f h is zero outside the listed columns, right inside them.
                    let lglf_fd = (p[k].0[1] - m[k].0[1]) / (2.0 * eps_g);
                    let scale = p[k].0[1].abs().max(m[k].0[1].abs());
                    assert_close(lglf_fd, lg_u, scale, eps_g, &format!("{name} row {k}: L_g L_f h[{u}]"));
                    if lg_u.abs() > 1e-9 {
                        nonzero_seen.insert((name.clone(), u), true);
                    }
                }
                checked += 1;
            }
        }
    }
    assert!(checked >= 1000 * 34);
    // Every listed column is structurally non-zero: it was seen non-zero somewhere.
    for leg in 0..6 {
        let n = gen::LEG_NAMES[leg];
        for (family, cols) in [
            ("joint_limits", gen::JOINT_LIMITS_INPUT_COLUMNS[leg]),
            ("toe_edge", gen::TOE_EDGE_ROW_COLUMNS[leg]),
            ("foothold", gen::FOOTHOLD_INPUT_COLUMNS[leg]),
            ("foot_height", gen::FOOT_HEIGHT_INPUT_COLUMNS[leg]),
            ("stability", gen::STABILITY_INPUT_COLUMNS[leg]),
        ] {
            for &u in cols {
                assert!(
                    nonzero_seen.contains_key(&(format!("{family}[{n}]"), u)),
                    "{family}[{n}] column {u} never non-zero"
                );
            }
        }
    }
    for &u in &gen::BODY_EDGE_INPUT_COLUMNS {
        assert!(
            nonzero_seen.contains_key(&("body_edge_ssat".to_string(), u)),
            "body_edge_ssat column {u} never non-zero"
        );
    }
}

/// Place toe `leg` so its knee length is `length` and its hip angle (positive outward)
/// is `angle`, computing the geometry with nalgebra rotations, not the generated code.
fn place_toe(x: &mut State, leg: usize, length: f64, angle: f64) {
    let pitch = Rotation3::from_euler_angles(0.0, x[BODY_PITCH], 0.0);
    let hip_body = nalgebra::Vector3::from(model::HIP_POSITIONS[leg]);
    let hip = nalgebra::Vector3::new(x[BODY_X], 0.0, x[BODY_Z]) + pitch * hip_body;
    let leg_body = nalgebra::Vector3::new(model::HIP_OUTWARD[leg] * length * angle.sin(), 0.0, -length * angle.cos());
    let toe = hip + pitch * leg_body;
    x[TOE_BLOCK + 4 * leg] = toe.x;
    x[TOE_BLOCK + 4 * leg + 1] = toe.z;
}

#[test]
fn joint_rows_vanish_exactly_at_each_limit() {
    let [kmin, kmax] = model::KNEE_RANGE;
    for leg in 0..6 {
        let [hmin, hmax] = model::HIP_RANGES[leg];
        let mut x = model::standard_posture();
        x[BODY_X] = 0.05;
        x[BODY_Z] = 0.35;
        x[BODY_PITCH] = 0.2;
        // (row that must vanish, knee length, hip angle)
        for (row, length, angle) in [(0, kmin, 0.1), (1, kmax, 0.1), (2, 0.3, hmin), (3, 0.3, hmax)] {
            place_toe(&mut x, leg, length, angle);
            let (lie, _) = gen::JOINT_LIMITS[leg](&x);
            assert!(lie[row][0].abs() < 1e-12, "leg {leg} row {row}: h = {}", lie[row][0]);
            for other in (0..4).filter(|&o| o != row) {
                assert!(lie[other][0] > 0.0, "leg {leg}: row {other} should hold strictly");
            }
        }
    }
}

#[test]
fn toe_on_a_foothold_edge_and_on_the_floor_gives_zero() {
    let mut x = model::standard_posture();
    x[0] = 0.3;
    x[1] = -0.2;
    x[2] = 0.05;
    x[3] = 0.7; // yaw
    for leg in 0..6 {
        let y_hip = model::HIP_POSITIONS[leg][1];
        let (s, c) = x[3].sin_cos();
        // Foothold edge: world x <= 1.2, i.e. (-1, 0) . p + 1.2 >= 0; put the toe on it.
        x[TOE_BLOCK + 4 * leg] = (1.2 - x[0] + y_hip * s) / c;
        let (lie, _) = gen::FOOTHOLD[leg](&x, &Vector2::new(-1.0, 0.0), 1.2);
        assert!(lie[0][0].abs() < 1e-12, "foothold leg {leg}: h = {}", lie[0][0]);
        // Floor at z = 0.13: wheel centre one radius above it.
        x[TOE_BLOCK + 4 * leg + 1] = 0.13 + model::TOE_RADIUS - x[2];
        let (lie, _) = gen::FOOT_HEIGHT[leg](&x, 0.13);
        assert!(lie[0][0].abs() < 1e-12, "foot height leg {leg}: h = {}", lie[0][0]);
    }
}

fn full_environment(r: &mut impl Rng) -> Environment {
    let cap = Capacity::PAPER_WORST_CASE;
    let mut env = Environment::new(cap).unwrap();
    for _ in 0..cap.body_edge {
        let (c, rot, h) = random_edge(r);
        let b = cbfgen::OrientedBox::new(c, Rotation3::from_matrix_unchecked(rot), h).unwrap();
        env.push_edge(EdgeCuboid::from_box(&b)).unwrap();
    }
    for leg in 0..6 {
        let planes: Vec<_> = (0..cap.foothold[leg])
            .map(|k| {
                let a = k as f64 * 0.4;
                HalfPlane::new([a.cos(), a.sin()], 1.0).unwrap()
            })
            .collect();
        env.set_foothold(leg, &planes).unwrap();
        env.stability[leg] = [Some(StabilityBound { a: 1.0, b: 0.3 }), Some(StabilityBound { a: -1.0, b: 0.3 })];
    }
    env.set_swing([true; 6]);
    // The pull too (guide_toe never switches it on beside the leg's foothold rows, but the
    // catalog evaluates whatever it is given).
    for leg in 0..6 {
        env.foothold_pull[leg] =
            [Some(FootholdPullParams { target: Vector2::new(1.0, 0.5), direction: Vector2::new(0.6, 0.8) })];
    }
    env.set_floors([-0.01; 6]);
    env
}

#[test]
fn the_paper_worst_case_has_269_barrier_rows_and_6_pull_rows_all_evaluated() {
    let mut r = rng(4);
    let env = full_environment(&mut r);
    let mut catalog = Catalog::new(Capacity::PAPER_WORST_CASE).unwrap();
    assert_eq!(catalog.len(), 269 + 6);
    let x = random_state(&mut r);
    catalog.evaluate(&x, &env).unwrap();
    assert!(catalog.rows().iter().all(|row| row.active && row.lie.iter().all(|v| v.is_finite())));
    let count = |f: Family| catalog.slots().filter(|s| s.family == f).count();
    assert_eq!(count(Family::BodyEdge) + count(Family::ToeEdge), 140);
    assert_eq!((count(Family::JointLimits), count(Family::FootHeight), count(Family::Stability)), (24, 6, 12));
    assert_eq!((count(Family::Foothold), count(Family::FootholdPull)), (87, 6));
    // Each slot holds what its own kernel returns for its own parameters.
    for (slot, row) in catalog.slots().zip(catalog.rows()) {
        let e = slot.instance;
        let expected = match slot.family {
            Family::BodyEdge => {
                let (c, r, h) = env.edges()[e].kernel_args();
                gen::body_edge(&x, &c, &r, &h).0[0]
            }
            Family::ToeEdge => {
                let (c, r, h) = env.edges()[e].kernel_args();
                gen::toe_edge(&x, &c, &r, &h).0[slot.leg.unwrap()]
            }
            Family::JointLimits => gen::JOINT_LIMITS[slot.leg.unwrap()](&x).0[e],
            _ => continue,
        };
        assert_eq!(row.lie[..3], expected, "{slot:?}");
        assert_eq!(row.lie[3..], [0.0; 2], "{slot:?}");
        for (u, v) in row.lg.iter().enumerate() {
            assert!(*v == 0.0 || slot.columns.contains(&u), "{slot:?}: value outside its columns");
        }
    }
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let mut r = rng(5);
    let env = full_environment(&mut r);
    let mut catalog = Catalog::new(Capacity::PAPER_WORST_CASE).unwrap();
    let mut x = model::standard_posture();
    x[7] = f64::NAN;
    assert!(catalog.evaluate(&x, &env).is_err());
    x[7] = f64::INFINITY;
    assert!(catalog.evaluate(&x, &env).is_err());
    let mut small = Environment::new(Capacity::edges(1, [1; 6])).unwrap();
    assert!(catalog.evaluate(&model::standard_posture(), &small).is_err(), "capacity mismatch");
    let edge = env.edges()[0];
    small.push_edge(edge).unwrap();
    assert!(small.push_edge(edge).is_err());
    assert!(small.set_foothold(6, &[]).is_err());
    assert!(HalfPlane::new([0.0, 0.0], 1.0).is_err());
}

#[test]
fn world_kinematics_matches_an_independent_pose_and_the_body_row() {
    // Body: p + Rz(yaw)(bx, 0, bz), rotation Rz(yaw) Ry(pitch); toes: p + Rz(yaw)(x, hip_y, z).
    // And the body-edge row's h equals the exact smooth SAT of that pose minus its margin.
    let mut r = rng(41);
    for _ in 0..500 {
        let x = random_state(&mut r);
        let (center, rotation, toes) = gen::world_kinematics(&x);
        let p = nalgebra::Vector3::new(x[0], x[1], x[2]);
        let rz = Rotation3::from_axis_angle(&nalgebra::Vector3::z_axis(), x[3]);
        let ry = Rotation3::from_axis_angle(&nalgebra::Vector3::y_axis(), x[BODY_PITCH]);
        let want_center = p + rz * nalgebra::Vector3::new(x[BODY_X], 0.0, x[BODY_Z]);
        let want_rotation = rz * ry;
        for i in 0..3 {
            assert!((center[i] - want_center[i]).abs() < 1e-12);
            for j in 0..3 {
                assert!((rotation[i][j] - want_rotation[(i, j)]).abs() < 1e-12);
            }
        }
        for (leg, toe) in toes.iter().enumerate() {
            let rel = nalgebra::Vector3::new(
                x[TOE_BLOCK + 4 * leg],
                model::HIP_POSITIONS[leg][1],
                x[TOE_BLOCK + 4 * leg + 1],
            );
            let want = p + rz * rel;
            assert!((0..3).all(|i| (toe[i] - want[i]).abs() < 1e-12), "toe {leg}");
        }
        let (ec, er, eh) = random_edge(&mut r);
        let edge = cbfgen::OrientedBox::new(ec, Rotation3::from_matrix_unchecked(er), eh).expect("valid edge");
        let rot = nalgebra::Matrix3::from_fn(|i, j| rotation[i][j]);
        let half = nalgebra::Vector3::from(model::BODY_HALF_EXTENTS);
        let body =
            cbfgen::OrientedBox::new(nalgebra::Vector3::from(center), Rotation3::from_matrix_unchecked(rot), half)
                .expect("valid body");
        let params = cbfgen::ssat::SmoothParams::default();
        let want_h = cbfgen::ssat::ssat(&edge, &body, &params) - cbfgen::ssat::certified_margin(&edge, &body, &params);
        let (lie, _) = gen::body_edge(&x, &ec, &er, &eh);
        assert!((lie[0][0] - want_h).abs() <= 1e-9 * (1.0 + want_h.abs()), "{} vs {want_h}", lie[0][0]);
    }
}

#[test]
fn roll_clearance_is_the_farthest_a_corner_moves() {
    // Independently: every corner of the body box turned about the body's x axis.
    let half = Vector3::from(model::BODY_HALF_EXTENTS);
    for k in 0..=90 {
        let roll = -1.5 + k as f64 / 30.0;
        let turn = Rotation3::from_axis_angle(&Vector3::x_axis(), roll);
        let farthest = (0..8)
            .map(|c| {
                let corner = Vector3::new(
                    half.x * if c & 1 == 0 { 1.0 } else { -1.0 },
                    half.y * if c & 2 == 0 { 1.0 } else { -1.0 },
                    half.z * if c & 4 == 0 { 1.0 } else { -1.0 },
                );
                (turn * corner - corner).norm()
            })
            .fold(0.0, f64::max);
        assert!((model::roll_clearance(roll) - farthest).abs() < 1e-12, "roll {roll}");
    }
}

#[test]
fn body_rows_with_the_roll_clearance_keep_the_rolled_body_clear() {
    // The claim of Course::set_body_roll, against the exact SAT: wherever the body row
    // holds (h >= 0) on cuboids grown by roll_clearance(roll), the body turned by that
    // roll does not overlap the true cuboid. And the clearance is needed: without it the
    // row holds at poses where the rolled body does overlap.
    let mut r = rng(43);
    let (mut held, mut needed) = (0, 0);
    let half = Vector3::from(model::BODY_HALF_EXTENTS);
    for _ in 0..20_000 {
        let x = random_state(&mut r);
        let roll = r.random_range(-0.4..0.4);
        let (ec, er, eh) = random_edge(&mut r);
        let edge = cbfgen::OrientedBox::new(ec, Rotation3::from_matrix_unchecked(er), eh).unwrap();
        let mut env = Environment::new(Capacity::edges(1, [1; 6])).unwrap();
        env.push_edge(EdgeCuboid::from_box(&edge)).unwrap();
        let h_model = {
            let (c, rot, h) = env.edges()[0].kernel_args();
            gen::body_edge(&x, &c, &rot, &h).0[0][0]
        };
        env.set_body_clearance(model::roll_clearance(roll)).unwrap();
        let (c, rot, h) = env.edges()[0].kernel_args();
        assert!((h - eh).iter().all(|d| (d - model::roll_clearance(roll)).abs() < 1e-15), "grown by the clearance");
        assert_eq!(env.toe_edge.as_slice()[0].half, eh, "the toe rows keep the true cuboid");
        let h_rolled = gen::body_edge(&x, &c, &rot, &h).0[0][0];
        let (center, rotation, _) = gen::world_kinematics(&x);
        let turned = Matrix3::from_fn(|i, j| rotation[i][j]) * Rotation3::from_axis_angle(&Vector3::x_axis(), roll);
        let body =
            cbfgen::OrientedBox::new(Vector3::from(center), Rotation3::from_matrix_unchecked(turned), half).unwrap();
        let rolled_overlaps = cbfgen::sat::overlaps(&edge, &body);
        if h_rolled >= 0.0 {
            held += 1;
            assert!(!rolled_overlaps, "row holds with the clearance, but the rolled body overlaps the edge");
        }
        if h_model >= 0.0 && rolled_overlaps {
            needed += 1;
        }
    }
    assert!(held > 1000 && needed > 10, "vacuous: {held} held, {needed} needed the clearance");
}

#[test]
fn a_body_clearance_out_of_its_domain_is_refused_and_changes_nothing() {
    let mut r = rng(44);
    let (ec, er, eh) = random_edge(&mut r);
    let edge = cbfgen::OrientedBox::new(ec, Rotation3::from_matrix_unchecked(er), eh).unwrap();
    let mut env = Environment::new(Capacity::edges(1, [1; 6])).unwrap();
    env.push_edge(EdgeCuboid::from_box(&edge)).unwrap();
    env.set_body_clearance(0.05).unwrap();
    for bad in [-1e-3, f64::NAN, f64::INFINITY, 1e9] {
        assert!(env.set_body_clearance(bad).is_err(), "{bad}");
        assert!((env.edges()[0].half - eh).iter().all(|d| (d - 0.05).abs() < 1e-15), "{bad} changed the edges");
    }
    env.set_body_clearance(0.0).unwrap();
    assert_eq!(env.edges()[0].half, eh, "0 restores the true cuboid");
}

#[test]
fn every_kernel_performs_the_operations_its_table_states() {
    // Counted by running each kernel on numbers that count (cbfgen::ops::Counted), against
    // the count the generator printed with it; every Tachyon 3 kernel is one straight line.
    let checked = cbfgen::ops::check_stated(gen::run_counted_kernels::<cbfgen::ops::Counted>)
        .unwrap_or_else(|m| panic!("{m:#?}"));
    assert_eq!(checked, gen::KERNELS.len());
}

/// A kernel's rows on counting numbers, as `evaluate` stores them (`[h, L_f h]` of the
/// pull's relative degree 1 followed by a zero).
fn counted_rows<const L: usize, const R: usize, const C: usize>(
    out: ([[Counted; L]; R], [[Counted; C]; R]),
    columns: &[usize],
) -> Rows {
    let lie = out.0.map(|r| std::array::from_fn(|i| r.get(i).map_or(0.0, |v| v.0)));
    rows_of((lie, out.1.map(|r| r.map(|v| v.0))), columns)
}

/// The rows of an instance culled at `bound`, as [`cbfgen::system::Row::cull`] stores them.
fn culled_rows(bound: Counted, n: usize) -> Rows {
    vec![([bound.0, 0.0, 0.0], [0.0; NU]); n]
}

/// One member of a family as `evaluate` runs it: the state part once, when an instance
/// first needs it, and the instance part once per instance. Its rows, in order, and the
/// operations performed on the way, counted as they ran.
fn run_member<K, P>(instances: &[P], state: impl Fn() -> K, instance: impl Fn(&K, &P) -> Rows) -> (Rows, OpCount) {
    if instances.is_empty() {
        return (Vec::new(), OpCount::ZERO);
    }
    let (part, mut ops) = Counted::measure(state);
    let mut rows = Vec::new();
    for p in instances {
        let (r, n) = Counted::measure(|| instance(&part, p));
        rows.extend(r);
        ops = ops + n;
    }
    (rows, ops)
}

/// [`run_member`] for member `$m` of a family of one member per leg, given each leg's state
/// part, instance part and input columns in leg order: `$args` are the instance part's
/// arguments, in terms of the state part `$s` and one instance's parameters `$p`.
macro_rules! leg_member {
    ($m:expr, $instances:expr, $x:expr, |$s:ident, $p:ident| $args:tt,
     [$(($state:path, $instance:path, $columns:expr)),+ $(,)?]) => {{
        let mut out = None;
        let runs = [$((&|| run_member($instances, || $state($x), |$s, $p| counted_rows($instance $args, &$columns)))
            as &dyn Fn() -> (Rows, OpCount)),+];
        for (k, run) in runs.into_iter().enumerate() {
            if k == $m {
                out = Some(run());
            }
        }
        out.expect("a leg")
    }};
}

/// Every slot of `capacity` filled with valid parameters.
fn filled_environment(capacity: Capacity, r: &mut impl Rng) -> Environment {
    let mut env = Environment::new(capacity).unwrap();
    for _ in 0..capacity.body_edge {
        let (c, rot, h) = random_edge(r);
        env.push_edge(EdgeCuboid { center: c, rotation: rot, half: h }).unwrap();
    }
    for leg in 0..6 {
        let planes: Vec<_> = (0..capacity.foothold[leg])
            .map(|_| {
                let a: f64 = r.random_range(-3.2..3.2);
                HalfPlane::new([a.cos(), a.sin()], r.random_range(-1.0..1.0)).unwrap()
            })
            .collect();
        env.set_foothold(leg, &planes).unwrap();
        let (b0, b1) = (r.random_range(-0.5..0.5), r.random_range(-0.5..0.5));
        env.stability[leg] = [Some(StabilityBound { a: 1.0, b: b0 }), Some(StabilityBound { a: -1.0, b: b1 })];
        let a: f64 = r.random_range(-3.2..3.2);
        let target = Vector2::new(r.random_range(-1.0..1.0), r.random_range(-1.0..1.0));
        env.foothold_pull[leg] = [Some(FootholdPullParams { target, direction: Vector2::new(a.cos(), a.sin()) })];
    }
    env.set_floors(std::array::from_fn(|_| r.random_range(-0.2..0.2)));
    env
}

/// Evaluate `catalog` at `x` with `env` (culling every instance it can when `cull`), and
/// run on counting numbers every kernel `evaluate` calls, as it calls them: per family and
/// member, as many instances as the catalog's layout has, with the environment's
/// parameters. Returns the rows the counting run computed, in row order, and the
/// operations it performed.
fn count_evaluation(catalog: &mut Catalog, x: &State, env: &Environment, cull: bool) -> (Rows, OpCount) {
    use gen::family::*;
    let thresholds = [if cull { f64::NEG_INFINITY } else { f64::INFINITY }; gen::FAMILIES.len()];
    BarrierSet::cull_above(catalog, &thresholds);
    catalog.evaluate(x, env).unwrap();
    let xc = x.map(Counted);
    let layout = catalog.layout();
    // The instances `evaluate` runs for a member: as many as the layout has, from `all`.
    fn slots<P>(layout: &[cbfgen::system::RowLayout], family: usize, member: usize, all: Vec<P>) -> Vec<P> {
        let n = layout.iter().filter(|l| l.family == family && l.member == member && l.row == 0).count();
        assert!(all.len() >= n, "family {family} member {member}: {n} slots, {} instances", all.len());
        all.into_iter().take(n).collect()
    }
    let (mut rows, mut ops) = (Vec::new(), OpCount::ZERO);
    let mut add = |(r, n): (Rows, OpCount)| {
        rows.extend(r);
        ops = ops + n;
    };
    // No parameters: one call per member (a state part of nothing, the kernel per instance).
    for m in 0..6 {
        add(leg_member!(
            m,
            &slots(layout, JOINT_LIMITS, m, vec![()]),
            &xc,
            |_s, _p| (&xc),
            [
                (no_state_part, gen::joint_limits_lf, gen::JOINT_LIMITS_LF_INPUT_COLUMNS),
                (no_state_part, gen::joint_limits_mf, gen::JOINT_LIMITS_MF_INPUT_COLUMNS),
                (no_state_part, gen::joint_limits_rf, gen::JOINT_LIMITS_RF_INPUT_COLUMNS),
                (no_state_part, gen::joint_limits_lr, gen::JOINT_LIMITS_LR_INPUT_COLUMNS),
                (no_state_part, gen::joint_limits_mr, gen::JOINT_LIMITS_MR_INPUT_COLUMNS),
                (no_state_part, gen::joint_limits_rr, gen::JOINT_LIMITS_RR_INPUT_COLUMNS),
            ]
        ));
    }
    for m in 0..6 {
        add(leg_member!(
            m,
            &slots(layout, FOOT_HEIGHT, m, env.foot_height[m].to_vec()),
            &xc,
            |s, p| (s, Counted(p.floor_z)),
            [
                (gen::foot_height_lf_state, gen::foot_height_lf_instance, gen::FOOT_HEIGHT_LF_INPUT_COLUMNS),
                (gen::foot_height_mf_state, gen::foot_height_mf_instance, gen::FOOT_HEIGHT_MF_INPUT_COLUMNS),
                (gen::foot_height_rf_state, gen::foot_height_rf_instance, gen::FOOT_HEIGHT_RF_INPUT_COLUMNS),
                (gen::foot_height_lr_state, gen::foot_height_lr_instance, gen::FOOT_HEIGHT_LR_INPUT_COLUMNS),
                (gen::foot_height_mr_state, gen::foot_height_mr_instance, gen::FOOT_HEIGHT_MR_INPUT_COLUMNS),
                (gen::foot_height_rr_state, gen::foot_height_rr_instance, gen::FOOT_HEIGHT_RR_INPUT_COLUMNS),
            ]
        ));
    }
    for m in 0..6 {
        let bounds = slots(layout, STABILITY, m, env.stability[m].iter().map(|p| p.unwrap()).collect());
        add(leg_member!(
            m,
            &bounds,
            &xc,
            |s, p| (s, Counted(p.a), Counted(p.b)),
            [
                (gen::stability_lf_state, gen::stability_lf_instance, gen::STABILITY_LF_INPUT_COLUMNS),
                (gen::stability_mf_state, gen::stability_mf_instance, gen::STABILITY_MF_INPUT_COLUMNS),
                (gen::stability_rf_state, gen::stability_rf_instance, gen::STABILITY_RF_INPUT_COLUMNS),
                (gen::stability_lr_state, gen::stability_lr_instance, gen::STABILITY_LR_INPUT_COLUMNS),
                (gen::stability_mr_state, gen::stability_mr_instance, gen::STABILITY_MR_INPUT_COLUMNS),
                (gen::stability_rr_state, gen::stability_rr_instance, gen::STABILITY_RR_INPUT_COLUMNS),
            ]
        ));
    }
    // The edges: the lower bound first, then (not culled) the rows.
    let edges =
        |p: (&Vector3<f64>, &Matrix3<f64>, &Vector3<f64>)| (p.0.map(Counted), p.1.map(Counted), p.2.map(Counted));
    let body = slots(
        layout,
        BODY_EDGE,
        0,
        env.body_edge.as_slice().iter().map(|p| edges((&p.center, &p.rotation, &p.half))).collect(),
    );
    add(run_member(
        &body,
        || (gen::body_edge_lower_bound_state(&xc), (!cull).then(|| gen::body_edge_state(&xc))),
        |(b, s), (c, rot, h)| {
            let bound = gen::body_edge_lower_bound_instance(b, c, rot, h);
            match s {
                Some(s) => counted_rows(gen::body_edge_instance(s, c, rot, h), &gen::BODY_EDGE_INPUT_COLUMNS),
                None => culled_rows(bound, gen::BODY_EDGE_ROW_NAMES.len()),
            }
        },
    ));
    let toe = slots(
        layout,
        TOE_EDGE,
        0,
        env.toe_edge.as_slice().iter().map(|p| edges((&p.center, &p.rotation, &p.half))).collect(),
    );
    add(run_member(
        &toe,
        || (gen::toe_edge_lower_bound_state(&xc), (!cull).then(|| gen::toe_edge_state(&xc))),
        |(b, s), (c, rot, h)| {
            let bound = gen::toe_edge_lower_bound_instance(b, c, rot, h);
            match s {
                Some(s) => counted_rows(gen::toe_edge_instance(s, c, rot, h), &gen::TOE_EDGE_INPUT_COLUMNS),
                None => culled_rows(bound, gen::TOE_EDGE_ROW_NAMES.len()),
            }
        },
    ));
    for m in 0..6 {
        let planes = slots(layout, FOOTHOLD, m, env.foothold[m].as_slice().to_vec());
        add(leg_member!(
            m,
            &planes,
            &xc,
            |s, p| (s, &p.normal.map(Counted), Counted(p.offset)),
            [
                (gen::foothold_lf_state, gen::foothold_lf_instance, gen::FOOTHOLD_LF_INPUT_COLUMNS),
                (gen::foothold_mf_state, gen::foothold_mf_instance, gen::FOOTHOLD_MF_INPUT_COLUMNS),
                (gen::foothold_rf_state, gen::foothold_rf_instance, gen::FOOTHOLD_RF_INPUT_COLUMNS),
                (gen::foothold_lr_state, gen::foothold_lr_instance, gen::FOOTHOLD_LR_INPUT_COLUMNS),
                (gen::foothold_mr_state, gen::foothold_mr_instance, gen::FOOTHOLD_MR_INPUT_COLUMNS),
                (gen::foothold_rr_state, gen::foothold_rr_instance, gen::FOOTHOLD_RR_INPUT_COLUMNS),
            ]
        ));
    }
    for m in 0..6 {
        let pulls = slots(layout, FOOTHOLD_PULL, m, env.foothold_pull[m].iter().map(|p| p.unwrap()).collect());
        add(leg_member!(
            m,
            &pulls,
            &xc,
            |s, p| (s, &p.target.map(Counted), &p.direction.map(Counted)),
            [
                (gen::foothold_pull_lf_state, gen::foothold_pull_lf_instance, gen::FOOTHOLD_PULL_LF_INPUT_COLUMNS),
                (gen::foothold_pull_mf_state, gen::foothold_pull_mf_instance, gen::FOOTHOLD_PULL_MF_INPUT_COLUMNS),
                (gen::foothold_pull_rf_state, gen::foothold_pull_rf_instance, gen::FOOTHOLD_PULL_RF_INPUT_COLUMNS),
                (gen::foothold_pull_lr_state, gen::foothold_pull_lr_instance, gen::FOOTHOLD_PULL_LR_INPUT_COLUMNS),
                (gen::foothold_pull_mr_state, gen::foothold_pull_mr_instance, gen::FOOTHOLD_PULL_MR_INPUT_COLUMNS),
                (gen::foothold_pull_rr_state, gen::foothold_pull_rr_instance, gen::FOOTHOLD_PULL_RR_INPUT_COLUMNS),
            ]
        ));
    }
    (rows, ops)
}

/// The state part of a kernel without one.
fn no_state_part<T>(_: T) {}

/// Whether every field of `bound` is at least `done`'s.
fn covers(bound: OpCount, done: OpCount) -> bool {
    bound.to_array().iter().zip(done.to_array()).all(|(b, d)| *b >= d)
}

#[test]
fn evaluation_ops_is_what_evaluate_performs_in_its_kernels_with_every_slot_filled() {
    // The operations the kernels evaluate calls perform, counted as they run (on
    // cbfgen::ops::Counted, with the state and parameters evaluate was given), summed over
    // the calls it makes: the count of calls from the catalog's layout, and every row the
    // counting run computes the one evaluate stored (so the calls are evaluate's own).
    let mut r = rng(63);
    let small = Capacity::edges(3, [2, 0, 1, 0, 4, 1]); // two legs without a foothold slot
    for capacity in [Capacity::PAPER_WORST_CASE, small, Capacity::edges(0, [0; 6])] {
        let mut catalog = Catalog::new(capacity).unwrap();
        let stated = catalog.evaluation_ops().expect("every Tachyon 3 kernel states its count");
        for _ in 0..3 {
            let (x, env) = (random_state(&mut r), filled_environment(capacity, &mut r));
            for cull in [false, true] {
                let (rows, counted) = count_evaluation(&mut catalog, &x, &env, cull);
                assert_eq!(rows.len(), catalog.rows().len(), "{capacity:?}");
                for (k, (row, (lie, lg))) in catalog.rows().iter().zip(&rows).enumerate() {
                    let family = catalog.layout()[k].family;
                    let edge = family == gen::family::BODY_EDGE || family == gen::family::TOE_EDGE;
                    assert!(row.active && row.culled == (cull && edge), "{capacity:?} cull {cull}: row {k}");
                    assert_eq!((&row.lie[..3], &row.lg), (&lie[..], lg), "{capacity:?} cull {cull}: row {k}");
                }
                if cull {
                    // Every edge culled: less than the bound, which ignores culling.
                    let edges = catalog.rows().iter().filter(|row| row.culled).count();
                    assert_eq!(edges, 7 * capacity.body_edge, "{capacity:?}");
                    assert!(covers(stated, counted), "{capacity:?}: stated {stated}, counted {counted}");
                    assert!(edges == 0 || counted.total() < stated.total(), "{capacity:?}: {counted}");
                } else {
                    assert_eq!(stated, counted, "{capacity:?}: stated {stated}, counted {counted}");
                }
            }
        }
        println!("{capacity:?}: {stated}");
    }
}
