//! The 7-DoF arm (`systems/panda/spec/panda.py`) against independent truths: its forward
//! kinematics against a plain Denavit–Hartenberg product written here from Franka's
//! published table; every row's Lie derivatives against finite differences along f and g;
//! the closed loop against the exact SAT (and parry3d's distance at its closest cycles);
//! the ECBF condition of every active row at the returned input, recomputed each cycle.

use cbfgen::filter::InputSource;
use cbfgen::system::BarrierSet;
use cbfgen::CbfError;
use cbfgen_panda::generated::{self as gen, Barriers, Capacity, ObstacleParams, Params, NU, NX};
use cbfgen_panda::{scenario::link_boxes, Scenario, Simulation};
use nalgebra::{Matrix4, Rotation3, UnitQuaternion, Vector3, Vector4};
use parry3d_f64::math::{Pose, Rot3, Vec3};
use parry3d_f64::query;
use parry3d_f64::shape::Cuboid;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Franka's published Craig DH table: (a_{i-1} [m], d_i [m], alpha_{i-1} [rad]), typed in
/// here from the datasheet, not read from the spec.
const FRANKA_DH: [(f64, f64, f64); 7] = [
    (0.0, 0.333, 0.0),
    (0.0, 0.0, -std::f64::consts::FRAC_PI_2),
    (0.0, 0.316, std::f64::consts::FRAC_PI_2),
    (0.0825, 0.0, std::f64::consts::FRAC_PI_2),
    (-0.0825, 0.384, -std::f64::consts::FRAC_PI_2),
    (0.0, 0.0, std::f64::consts::FRAC_PI_2),
    (0.088, 0.0, std::f64::consts::FRAC_PI_2),
];
const FRANKA_FLANGE: f64 = 0.107;
/// Franka Hand: each finger's frame sits this far along the hand's z axis [m], and slides
/// along ±y by the opening.
const FRANKA_FINGER_OFFSET: f64 = 0.0584;
/// Obstacle members: every link box but the base's.
const MEMBERS: usize = gen::OBSTACLE_LINKS.len();

fn rot_x(a: f64) -> Matrix4<f64> {
    let (s, c) = a.sin_cos();
    Matrix4::new(1.0, 0.0, 0.0, 0.0, 0.0, c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0)
}

fn rot_z(a: f64) -> Matrix4<f64> {
    let (s, c) = a.sin_cos();
    Matrix4::new(c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)
}

fn translate(x: f64, y: f64, z: f64) -> Matrix4<f64> {
    Matrix4::new_translation(&Vector3::new(x, y, z))
}

/// Frames 0 (the base), 1–7, the flange (8), the hand (9) and the fingers (10, 11) as
/// homogeneous transforms.
fn dh_frames(q: &[f64]) -> Vec<Matrix4<f64>> {
    let mut t = Matrix4::identity();
    let mut out = vec![t];
    for (i, &(a, d, alpha)) in FRANKA_DH.iter().enumerate() {
        t = t * rot_x(alpha) * translate(a, 0.0, 0.0) * rot_z(q[i]) * translate(0.0, 0.0, d);
        out.push(t);
    }
    let flange = t * translate(0.0, 0.0, FRANKA_FLANGE);
    out.push(flange);
    let hand = flange * rot_z(-std::f64::consts::FRAC_PI_4);
    out.push(hand);
    let opening = gen::FINGER_OPENING;
    out.push(hand * translate(0.0, opening, FRANKA_FINGER_OFFSET));
    out.push(hand * translate(0.0, -opening, FRANKA_FINGER_OFFSET));
    out
}

fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// q uniform inside the limits, q̇ uniform inside the rate limits.
fn random_state(r: &mut impl Rng) -> [f64; NX] {
    let mut x = [0.0; NX];
    for j in 0..7 {
        x[j] = r.random_range(gen::Q_MIN[j]..gen::Q_MAX[j]);
        x[7 + j] = r.random_range(-gen::QD_MAX[j]..gen::QD_MAX[j]);
    }
    x
}

fn random_rotation(r: &mut impl Rng) -> Rotation3<f64> {
    let axis = Vector3::new(r.random_range(-1.0..1.0), r.random_range(-1.0..1.0), r.random_range(-1.0..1.0));
    Rotation3::new(axis.normalize() * r.random_range(0.0..std::f64::consts::PI))
}

#[test]
fn forward_kinematics_match_a_plain_dh_product() {
    let mut r = rng(1);
    let mut worst: f64 = 0.0;
    for _ in 0..2000 {
        let x = random_state(&mut r);
        let frames = dh_frames(&x[..7]);
        let origins = gen::frame_origins(&x);
        for (k, t) in frames[1..].iter().enumerate() {
            for i in 0..3 {
                worst = worst.max((origins[k][i] - t[(i, 3)]).abs());
            }
        }
        // Each link box: its frame's transform applied to the box's centre, and the frame's
        // rotation times the box's rotation in that frame.
        let (centers, rotations) = gen::link_boxes(&x);
        for (k, &frame) in gen::LINK_FRAMES.iter().enumerate() {
            let t = frames[frame];
            let [cx, cy, cz] = gen::LINK_CENTERS[k];
            let c = t * Vector4::new(cx, cy, cz, 1.0);
            let r = t.fixed_view::<3, 3>(0, 0) * nalgebra::Matrix3::from_row_slice(&gen::LINK_ROTATIONS[k]);
            for i in 0..3 {
                worst = worst.max((centers[k][i] - c[i]).abs());
                for j in 0..3 {
                    worst = worst.max((rotations[k][3 * i + j] - r[(i, j)]).abs());
                }
            }
        }
    }
    assert!(worst < 1e-12, "generated kinematics differ from the DH product by {worst:e}");
    // A hand-checked pose: all joints zero puts the flange 0.088 m forward and
    // 0.333 + 0.316 + 0.384 - 0.107 = 0.926 m up.
    let o = gen::frame_origins(&[0.0; NX]);
    assert!((o[7][0] - 0.088).abs() < 1e-15 && o[7][1].abs() < 1e-15 && (o[7][2] - 0.926).abs() < 1e-15);
}

/// Barriers with every link checked against `obstacles`.
fn barriers_with(obstacles: &[ObstacleParams]) -> (Barriers, Params) {
    let capacity = Capacity { obstacle: [obstacles.len(); MEMBERS] };
    let mut params = Params::new(capacity).unwrap();
    for o in obstacles {
        for link in &mut params.obstacle {
            link.push(*o).unwrap();
        }
    }
    (Barriers::new(capacity).unwrap(), params)
}

fn rows_at(b: &mut Barriers, p: &Params, x: &[f64; NX]) -> Vec<cbfgen::system::Row<NU>> {
    b.evaluate(0.0, x, p).unwrap();
    b.rows().to_vec()
}

fn shifted(x: &[f64; NX], d: &[f64; NX], eps: f64) -> [f64; NX] {
    std::array::from_fn(|i| x[i] + eps * d[i])
}

/// Central difference of values of magnitude `scale` with step `step`: truncation 1e-6
/// relative plus rounding ~1e-14 · scale / step.
fn assert_close(numeric: f64, analytic: f64, scale: f64, step: f64, what: &str) {
    let tol = 1e-6 * analytic.abs().max(1.0) + 1e-14 * scale / step;
    assert!((numeric - analytic).abs() <= tol, "{what}: analytic {analytic} vs FD {numeric} (tol {tol:e})");
}

#[test]
fn every_row_matches_finite_differences_along_f_and_g() {
    let mut r = rng(2);
    let (eps_f, eps_g) = (2e-5, 1e-3);
    let mut checked = [0usize; 4];
    for _ in 0..300 {
        let x = random_state(&mut r);
        let obstacle = ObstacleParams {
            center: Vector3::new(r.random_range(-0.8..0.8), r.random_range(-0.8..0.8), r.random_range(0.0..1.0)),
            rotation: *random_rotation(&mut r).matrix(),
            half: Vector3::new(r.random_range(0.02..0.3), r.random_range(0.02..0.3), r.random_range(0.02..0.3)),
        };
        let (mut b, p) = barriers_with(&[obstacle]);
        let at = rows_at(&mut b, &p, &x);
        let f = gen::drift(&x);
        let (plus, minus) =
            (rows_at(&mut b, &p, &shifted(&x, &f, eps_f)), rows_at(&mut b, &p, &shifted(&x, &f, -eps_f)));
        let (half_plus, half_minus) =
            (rows_at(&mut b, &p, &shifted(&x, &f, eps_f / 2.0)), rows_at(&mut b, &p, &shifted(&x, &f, -eps_f / 2.0)));
        let layout = b.layout().to_vec();
        for (k, row) in at.iter().enumerate() {
            let family = layout[k].family;
            let degree = gen::FAMILIES[family].relative_degree;
            let what = format!("{} row {k}", gen::FAMILIES[family].name);
            // L_f^i h for i = 1..degree: the derivative of L_f^{i-1} h along f.
            for i in 1..=degree {
                let central = |p: &[cbfgen::system::Row<NU>], m: &[cbfgen::system::Row<NU>], e: f64| {
                    (p[k].lie[i - 1] - m[k].lie[i - 1]) / (2.0 * e)
                };
                // Richardson: the SSAT's sharp smooth |.| (alpha = 400 /m) has third
                // derivatives of order alpha^3, too large for a plain central difference.
                let fd = (4.0 * central(&half_plus, &half_minus, eps_f / 2.0) - central(&plus, &minus, eps_f)) / 3.0;
                let scale = plus[k].lie[i - 1].abs().max(minus[k].lie[i - 1].abs());
                assert_close(fd, row.lie[i], scale, eps_f / 2.0, &format!("{what}: L_f^{i} h"));
            }
            // L_g L_f^{r-1} h: the derivative of L_f^{r-1} h along each input column, and
            // nothing below degree r sees the input.
            for u in 0..NU {
                let mut g = [0.0; NX];
                g[7 + u] = 1.0;
                let (p_u, m_u) =
                    (rows_at(&mut b, &p, &shifted(&x, &g, eps_g)), rows_at(&mut b, &p, &shifted(&x, &g, -eps_g)));
                for i in 0..degree - 1 {
                    assert_eq!(p_u[k].lie[i], m_u[k].lie[i], "{what}: L_f^{i} h depends on input {u}");
                }
                let fd = (p_u[k].lie[degree - 1] - m_u[k].lie[degree - 1]) / (2.0 * eps_g);
                let scale = p_u[k].lie[degree - 1].abs().max(m_u[k].lie[degree - 1].abs());
                assert_close(fd, row.lg[u], scale, eps_g, &format!("{what}: L_g L_f h[{u}]"));
            }
            checked[family] += 1;
        }
    }
    assert_eq!(checked, [300 * 14, 300 * 14, 300 * MEMBERS, 300 * gen::SELF_PAIRS.len()], "rows checked per family");
}

fn parry_distance(a: &cbfgen::OrientedBox, b: &cbfgen::OrientedBox) -> f64 {
    let pose = |o: &cbfgen::OrientedBox| {
        let q = UnitQuaternion::from_rotation_matrix(o.rotation());
        let c = o.center();
        Pose::from_parts(Vec3::new(c.x, c.y, c.z), Rot3::from_xyzw(q.i, q.j, q.k, q.w))
    };
    let cuboid = |o: &cbfgen::OrientedBox| {
        let h = o.half_extents();
        Cuboid::new(Vec3::new(h.x, h.y, h.z))
    };
    // With an infinite prediction distance, contact always reports: its `dist` is the
    // signed distance (negative: penetration depth).
    query::contact(&pose(a), &cuboid(a), &pose(b), &cuboid(b), f64::INFINITY)
        .expect("cuboid pairs are supported")
        .expect("an infinite prediction always reports")
        .dist
}

#[test]
fn the_filter_keeps_every_pair_apart_and_every_joint_inside_and_without_it_they_are_not() {
    let scenario = Scenario::standard();
    let with = cbfgen_panda::run(&scenario).unwrap();
    let without = cbfgen_panda::run(&scenario.clone().without_filter()).unwrap();
    let names = scenario.pair_names();
    let s = &with.summary;
    for (k, &(d, t)) in s.min_separation.iter().enumerate() {
        assert!(d >= -1e-3, "with the filter, {} overlaps by {:.2} mm at {t:.3} s", names[k], -d * 1e3);
    }
    assert!(s.min_joint_margin >= -1e-4, "a joint passed its limit by {} rad", -s.min_joint_margin);
    assert_eq!(s.not_qp, 0, "every input came from the QP");
    // The exact SAT against parry3d at the closest cycle of every pair.
    for (k, &(_, t)) in s.min_separation.iter().enumerate() {
        let sample = &with.samples[(t / cbfgen_panda::DT).round() as usize];
        let links = link_boxes(&sample.x).unwrap();
        let obstacles = scenario.obstacles.len() * MEMBERS;
        let (a, b) = if k < obstacles {
            (scenario.obstacles[k / MEMBERS].shape, links[gen::OBSTACLE_LINKS[k % MEMBERS]])
        } else {
            let [i, j] = gen::SELF_PAIRS[k - obstacles];
            (links[i], links[j])
        };
        let d = parry_distance(&a, &b);
        assert!(d >= -1e-3, "parry3d: {} overlaps by {:.2} mm at {t:.3} s", names[k], -d * 1e3);
    }
    // Without the filter the same PD drives the forearm through the box, the hand and
    // wrist into the shoulder and upper arm, and joints past their limits.
    let w = &without.summary;
    let overlap =
        |prefix: &str| names.iter().zip(&w.min_separation).any(|(n, &(d, _))| n.starts_with(prefix) && d < -0.01);
    assert!(overlap("box/"), "without the filter the box must be penetrated");
    assert!(overlap("link1/") || overlap("link2/"), "without the filter the hand must reach the shoulder");
    assert!(w.min_joint_margin < -0.1, "without the filter a joint must pass its limit");
    // With it, the run comes close (the rows are doing the work, not distance).
    // (The certified margin at these sharpnesses is about 3 cm.)
    assert!(s.min_separation.iter().any(|p| p.0 < 0.04), "some pair must come within 4 cm");
    assert!(s.min_joint_margin < 0.01, "some joint must come within 0.01 rad of its limit");
}

#[test]
fn every_active_row_meets_its_ecbf_condition_at_the_returned_input() {
    let scenario = Scenario::standard();
    let mut sim = Simulation::new(&scenario).unwrap();
    let poles: Vec<Vec<f64>> = scenario.settings.families.iter().map(|f| f.poles.as_slice().to_vec()).collect();
    let (mut fresh, params) = (Barriers::new(sim.params().capacity()).unwrap(), sim.params().clone());
    let mut checked = [0usize; 4];
    let mut worst_ratio: f64 = 0.0;
    while sim.time() < scenario.duration {
        let x = *sim.state();
        let sample = sim.step().unwrap();
        assert_eq!(sample.source, Some(InputSource::Qp));
        fresh.evaluate(0.0, &x, &params).unwrap();
        for (k, (row, layout)) in fresh.rows().iter().zip(fresh.layout()).enumerate() {
            if !sim.filter().active()[k] {
                continue;
            }
            // h^(r) + sum_i k_i h^(i) >= 0 with the gains of (s + p1)(s + p2)...
            let bound = match poles[layout.family].as_slice() {
                &[p] => row.lie[1] + p * row.lie[0],
                &[p1, p2] => row.lie[2] + (p1 + p2) * row.lie[1] + p1 * p2 * row.lie[0],
                other => panic!("unexpected poles {other:?}"),
            };
            let lhs = bound + row.lg.iter().zip(&sample.u).map(|(g, u)| g * u).sum::<f64>();
            let size = bound.abs() + row.lg.iter().zip(&sample.u).map(|(g, u)| g.abs() * (1.0 + u.abs())).sum::<f64>();
            // Every row is hard where the input box allows it: met to the solver's rounding
            // (1e-8 of its terms), or reported relaxed.
            let violation = (-lhs).max(0.0);
            worst_ratio = worst_ratio.max(violation / size);
            assert!(
                violation <= 1e-8 * size || sim.filter().relaxed()[k].is_some(),
                "t = {:.3} s, {} row {k}: ECBF condition {lhs:e} < 0 (size {size:e}) and reported met",
                sample.t,
                gen::FAMILIES[layout.family].name
            );
            checked[layout.family] += 1;
        }
    }
    assert!(checked.iter().all(|&c| c > 100), "every family must have been active: {checked:?}");
    println!("rows checked per family {checked:?}; largest violation / the row's size {worst_ratio:e}");
}

#[test]
fn bad_scenarios_are_typed_errors() {
    let base = Scenario::standard();
    let cases: Vec<(Scenario, &str)> = vec![
        (Scenario { start: [f64::NAN; 7], ..base.clone() }, "start"),
        (Scenario { start: [0.0; 7], ..base.clone() }, "start outside q4's limits"),
        (Scenario { waypoints: vec![], ..base.clone() }, "no waypoints"),
        (Scenario { duration: 1e300, ..base.clone() }, "duration"),
        (Scenario { kp: f64::INFINITY, ..base.clone() }, "kp"),
        (Scenario { kd: -1.0, ..base.clone() }, "kd"),
        (
            Scenario {
                waypoints: vec![
                    cbfgen_panda::Waypoint { from: 1.0, q: [0.0; 7] },
                    cbfgen_panda::Waypoint { from: 0.5, q: [0.0; 7] },
                ],
                ..base.clone()
            },
            "waypoints out of order",
        ),
        (
            Scenario { waypoints: vec![cbfgen_panda::Waypoint { from: 0.0, q: [f64::MAX; 7] }], ..base.clone() },
            "waypoint angle",
        ),
        (Scenario { obstacles: vec![base.obstacles[0].clone(); 65], ..base.clone() }, "too many obstacles"),
    ];
    for (scenario, what) in cases {
        let err = Simulation::new(&scenario).err();
        assert!(
            matches!(
                err,
                Some(
                    CbfError::NonFinite { .. }
                        | CbfError::OutOfRange { .. }
                        | CbfError::NotPositive { .. }
                        | CbfError::TooLarge { .. }
                )
            ),
            "{what}: {err:?}"
        );
    }
}

#[test]
fn a_small_dense_budget_keeps_making_progress_on_a_hard_state() {
    // Issue 32's reproducer: `Solver::Dense` with a budget of 10, one ordinary cycle, then
    // a state the budget cannot finish from a cold start (the sweep at t = 0.986 s, where
    // a budget of 10 left the old solve unverified from cold) given again and again. The
    // old solve restarted each cycle from its last verified answer and handed back the
    // same unconverged iterate forever; each cycle now continues from where the last
    // stopped, and the answer is the full-budget one.
    let scenario = Scenario::standard();
    let mut sim = Simulation::new(&scenario).expect("simulation");
    while sim.time() < 0.986 {
        sim.step().expect("step");
    }
    let (x, u_ref) = (*sim.state(), scenario.nominal(sim.time(), sim.state()));
    let capacity = Capacity { obstacle: [scenario.obstacles.len(); MEMBERS] };
    let mut settings = gen::default_settings();
    settings.solver.backend = cbfgen::filter::Solver::Dense;
    settings.solver.dense_max_steps = 10;
    let mut small = cbfgen::filter::EcbfFilter::new(Barriers::new(capacity).unwrap(), settings).unwrap();
    let mut start = [0.0; NX];
    start[..7].copy_from_slice(&scenario.start);
    small.update(&start, &[0.0; NU], sim.params()).expect("an ordinary cycle");
    let mut full = cbfgen::filter::EcbfFilter::new(Barriers::new(capacity).unwrap(), gen::default_settings()).unwrap();
    let reference = *full.update(&x, &u_ref, sim.params()).expect("reference");
    assert_eq!(reference.source, InputSource::Qp);
    let mut qp = 0;
    for cycle in 0..1000 {
        let out = *small.update(&x, &u_ref, sim.params()).expect("update");
        if out.source == InputSource::Qp {
            qp += 1;
            let du = (0..NU).map(|j| (out.u[j] - reference.u[j]).abs()).fold(0.0, f64::max);
            assert!(du <= 1e-7, "cycle {cycle}: the small budget's answer is {du:.2e} from the full one");
        }
    }
    assert!(qp >= 990, "only {qp} of 1000 cycles verified with a budget of 10");
}

#[test]
fn a_small_dense_budget_keeps_making_progress_and_every_qp_answer_is_the_full_budget_one() {
    // Issue 32: under `Solver::Dense` with a budget of 10, the old solve restarted from its
    // last verified answer every cycle, so after one unfinished cycle every later one
    // handed back the same unconverged iterate. Each stage now continues from where it
    // stopped: the arm's whole course, re-solved cycle by cycle by a full-budget filter on
    // the same states, gives the same answer wherever the small budget says `qp`, and
    // unverified cycles stay rare and short.
    let mut scenario = Scenario::standard();
    scenario.settings.solver.backend = cbfgen::filter::Solver::Dense;
    scenario.settings.solver.dense_max_steps = 10;
    let mut sim = Simulation::new(&scenario).expect("simulation");
    let mut full = cbfgen::filter::EcbfFilter::new(
        Barriers::new(Capacity { obstacle: [scenario.obstacles.len(); MEMBERS] }).expect("barriers"),
        gen::default_settings(),
    )
    .expect("filter");
    let (mut unconverged, mut run, mut longest, mut cycles) = (0, 0, 0, 0);
    while sim.time() < scenario.duration {
        let x = *sim.state();
        let sample = sim.step().expect("step");
        cycles += 1;
        let reference = *full.update(&x, &sample.u_ref, sim.params()).expect("reference");
        assert_eq!(reference.source, InputSource::Qp);
        if sample.source == Some(InputSource::Qp) {
            run = 0;
            // Both answers pass the dense solver's KKT check (1e-9, scale-aware; its
            // stationarity test is floored at 1e-4 of the largest gradient term), so where
            // large multipliers meet inputs at their box they may differ by a few 1e-7 of
            // the inputs' 20 rad/s² (seen: 1.8e-6), with objectives equal to 1e-7.
            let du = (0..NU).map(|j| (sample.u[j] - reference.u[j]).abs()).fold(0.0, f64::max);
            assert!(du <= 1e-5, "t = {:.3}: the small budget's qp answer is {du:.2e} from the full one", sample.t);
            let w = &scenario.settings.input_weights;
            let cost = |u: &[f64; NU]| (0..NU).map(|j| w[j] * (u[j] - sample.u_ref[j]).powi(2)).sum::<f64>();
            let (small_cost, full_cost) = (cost(&sample.u), cost(&reference.u));
            assert!(
                (small_cost - full_cost).abs() <= 1e-7 * (1.0 + full_cost),
                "t = {:.3}: objective {small_cost} against the full budget's {full_cost}",
                sample.t
            );
        } else {
            unconverged += 1;
            run += 1;
            longest = longest.max(run);
        }
    }
    eprintln!("{cycles} cycles, {unconverged} unconverged (longest run {longest})");
    assert!(longest <= 3, "{longest} unconverged cycles in a row");
    assert!(unconverged * 100 <= cycles, "{unconverged} of {cycles} cycles unconverged");
}

/// One obstacle row by the member's one-instance kernel: `[h, L_f h, L_f² h]`.
fn one_instance(member: usize, x: &[f64; NX], o: &ObstacleParams) -> [f64; 3] {
    let (c, rot, h) = (&o.center, &o.rotation, &o.half);
    // Each member's kernel has its own input columns, so its own type: one arm each.
    match member {
        0 => gen::obstacle_link1(x, c, rot, h).0[0],
        1 => gen::obstacle_link2(x, c, rot, h).0[0],
        2 => gen::obstacle_link3(x, c, rot, h).0[0],
        3 => gen::obstacle_link4(x, c, rot, h).0[0],
        4 => gen::obstacle_link5(x, c, rot, h).0[0],
        5 => gen::obstacle_link6(x, c, rot, h).0[0],
        6 => gen::obstacle_link7(x, c, rot, h).0[0],
        7 => gen::obstacle_hand(x, c, rot, h).0[0],
        8 => gen::obstacle_leftfinger(x, c, rot, h).0[0],
        _ => gen::obstacle_rightfinger(x, c, rot, h).0[0],
    }
}

#[test]
fn far_obstacles_are_culled_and_the_rest_are_the_kernels_rows() {
    // Obstacles beyond the activation distance of a link are culled by the SSAT lower
    // bound: every culled row holds a bound below its h, every evaluated row the member
    // kernel's bits for that obstacle (so the rows sit where they belong).
    let mut r = rng(343);
    let thresholds: Vec<f64> = gen::default_settings().families.iter().map(|f| f.activation).collect();
    let (mut culled, mut evaluated) = (0, 0);
    for case in 0..200 {
        let obstacles: Vec<ObstacleParams> = (0..1 + case % 9)
            .map(|_| ObstacleParams {
                center: Vector3::new(r.random_range(-1.2..1.2), r.random_range(-1.2..1.2), r.random_range(-0.3..1.5)),
                rotation: *random_rotation(&mut r).matrix(),
                half: Vector3::new(r.random_range(0.02..0.3), r.random_range(0.02..0.3), r.random_range(0.02..0.3)),
            })
            .collect();
        let (mut barriers, params) = barriers_with(&obstacles);
        barriers.cull_above(&thresholds);
        let x = random_state(&mut r);
        let rows = rows_at(&mut barriers, &params, &x);
        for (row, at) in rows.iter().zip(barriers.layout()) {
            if at.family != gen::family::OBSTACLE {
                continue;
            }
            let want = one_instance(at.member, &x, &obstacles[at.instance]);
            if row.culled {
                culled += 1;
                assert!(row.h() <= want[0], "member {}: bound {} above h {}", at.member, row.h(), want[0]);
            } else {
                evaluated += 1;
                assert_eq!(
                    row.lie[..3].iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    want.map(f64::to_bits),
                    "{at:?}"
                );
            }
        }
    }
    assert!(culled > 500 && evaluated > 500, "culled {culled}, evaluated {evaluated}");
}

#[test]
fn far_self_collision_pairs_are_culled_by_a_true_bound() {
    // The self-collision members have no parameters: each is one instance, culled by its
    // own SSAT lower bound. Against the same barriers with culling off, every culled row
    // holds a bound at or below the full h, and every other row is bit-identical.
    let mut r = rng(344);
    let thresholds: Vec<f64> = gen::default_settings().families.iter().map(|f| f.activation).collect();
    let (mut culling, params) = barriers_with(&[]);
    let (mut full, _) = barriers_with(&[]);
    culling.cull_above(&thresholds);
    let (mut culled, mut evaluated) = (0, 0);
    for _ in 0..2000 {
        let x = random_state(&mut r);
        let (a, b) = (rows_at(&mut culling, &params, &x), rows_at(&mut full, &params, &x));
        for ((fast, slow), at) in a.iter().zip(&b).zip(culling.layout()) {
            assert!(!slow.culled);
            if fast.culled {
                assert_eq!(at.family, gen::family::SELF_COLLISION);
                culled += 1;
                assert!(fast.h() <= slow.h(), "member {}: bound {} above h {}", at.member, fast.h(), slow.h());
            } else {
                evaluated += usize::from(at.family == gen::family::SELF_COLLISION);
                assert_eq!(fast.lie.map(f64::to_bits), slow.lie.map(f64::to_bits), "{at:?}");
                assert_eq!(fast.lg.map(f64::to_bits), slow.lg.map(f64::to_bits), "{at:?}");
            }
        }
    }
    assert!(culled > 10_000 && evaluated > 1_000, "culled {culled}, evaluated {evaluated}");
}

#[test]
fn the_generated_dynamics_are_symmetric_positive_definite_and_passive() {
    // Independent of how M and the bias were built: M(q) = M(q)ᵀ ≻ 0, and the rigid-body
    // passivity identity q̇ᵀ (C(q, q̇) q̇) = ½ q̇ᵀ Ṁ q̇, with C q̇ = bias(q, q̇) − bias(q, 0)
    // and Ṁ = dM/dt along q̇ by Richardson-extrapolated central differences.
    let mut r = rng(352);
    let mut worst: f64 = 0.0;
    for _ in 0..1000 {
        let x = random_state(&mut r);
        let (m, bias) = gen::dynamics(&x);
        let mass = nalgebra::SMatrix::<f64, 7, 7>::from_fn(|i, j| m[i][j]);
        assert!((mass - mass.transpose()).abs().max() <= 1e-15 * mass.abs().max(), "M is not symmetric");
        assert!(mass.cholesky().is_some(), "M is not positive definite at {x:?}");
        let mut still = x;
        still[7..].fill(0.0);
        let gravity = gen::dynamics(&still).1;
        let qd = nalgebra::SVector::<f64, 7>::from_fn(|i, _| x[7 + i]);
        let coriolis_power: f64 = (0..7).map(|i| qd[i] * (bias[i] - gravity[i])).sum();
        let mass_at = |eps: f64| {
            let mut y = x;
            for i in 0..7 {
                y[i] += eps * x[7 + i];
            }
            let m = gen::dynamics(&y).0;
            nalgebra::SMatrix::<f64, 7, 7>::from_fn(|i, j| m[i][j])
        };
        let eps = 1e-4;
        let central = |e: f64| (mass_at(e) - mass_at(-e)) / (2.0 * e);
        let m_dot = (4.0 * central(eps / 2.0) - central(eps)) / 3.0;
        let half_power = 0.5 * (qd.transpose() * m_dot * qd)[(0, 0)];
        let scale = 1.0 + coriolis_power.abs() + (qd.transpose() * mass * qd)[(0, 0)];
        worst = worst.max((coriolis_power - half_power).abs() / scale);
    }
    assert!(worst <= 1e-8, "q̇ᵀ C q̇ differs from ½ q̇ᵀ Ṁ q̇ by {worst:e} of its scale");
}

#[test]
fn every_straight_line_kernel_performs_the_operations_its_table_states() {
    // Run on numbers that count (cbfgen::ops::Counted), against the generator's count; the
    // kernels assembled from others (the walked dynamics) state none.
    let checked = cbfgen::ops::check_stated(gen::run_counted_kernels::<cbfgen::ops::Counted>)
        .unwrap_or_else(|m| panic!("{m:#?}"));
    assert_eq!(checked, gen::KERNELS.iter().filter(|k| k.ops.is_some()).count());
    assert!(checked >= 20, "{checked} kernels counted");
}

#[test]
fn evaluation_ops_is_what_evaluate_performs_in_its_kernels_and_poses_with_every_slot_filled() {
    // evaluate's calls replayed on numbers that count (cbfgen::ops::Counted): each node of
    // the kinematic tree once (its jet and its value), each box placed once in its link's
    // frame, each member's lower bound and chain from those poses, per obstacle slot. Every
    // row the replay computes is the one evaluate stored, bit for bit, so the calls are
    // evaluate's own; with every slot filled and nothing culled, the stated count is exact.
    use cbfgen::compose::{place_jet, place_pose};
    use cbfgen::ops::Counted;
    use cbfgen::system::Row;

    fn counted<const N: usize>(a: &[f64; N]) -> [Counted; N] {
        a.map(Counted)
    }
    // One row as evaluate stores it.
    fn row<const L: usize, const C: usize>(lie: &[Counted; L], lg: &[Counted; C], columns: &[usize; C]) -> Row<NU> {
        let mut row = Row::ZERO;
        row.store(&lie.map(|v| v.0), &lg.map(|v| v.0), columns);
        row
    }

    let mut r = rng(62);
    for slots in [1, 3] {
        let obstacles: Vec<ObstacleParams> = (0..slots)
            .map(|_| ObstacleParams {
                center: Vector3::new(r.random_range(-0.8..0.8), r.random_range(-0.8..0.8), r.random_range(0.0..1.0)),
                rotation: *random_rotation(&mut r).matrix(),
                half: Vector3::new(r.random_range(0.02..0.3), r.random_range(0.02..0.3), r.random_range(0.02..0.3)),
            })
            .collect();
        let (mut barriers, params) = barriers_with(&obstacles);
        let stated = barriers.evaluation_ops().expect("every Panda kernel states its count");
        let x = random_state(&mut r);
        let rows = rows_at(&mut barriers, &params, &x);
        let (replayed, count) = Counted::measure(|| {
            let xc = counted(&x);
            let mut out: Vec<Row<NU>> = Vec::new();
            let (lie, lg) = gen::joint_limits(&xc);
            out.extend(lie.iter().zip(&lg).map(|(l, g)| row(l, g, &gen::JOINT_LIMITS_INPUT_COLUMNS)));
            let (lie, lg) = gen::velocity_limits(&xc);
            out.extend(lie.iter().zip(&lg).map(|(l, g)| row(l, g, &gen::VELOCITY_LIMITS_INPUT_COLUMNS)));
            // The tree, node by node: jets and values.
            let ((j1, j2, j3, j4, j5, j6, j7), [v1, v2, v3, v4, v5, v6, v7]) = cbfgen_testkit::panda_tree!(gen, &xc);
            // Each box placed once: its jet and its value.
            macro_rules! placed {
                ($jet:ident, $value:ident, $placement:ident) => {
                    (place_jet(&$jet, &gen::$placement), place_pose(&$value, &gen::$placement))
                };
            }
            let link1 = placed!(j1, v1, LINK1_PLACEMENT);
            let link2 = placed!(j2, v2, LINK2_PLACEMENT);
            let link3 = placed!(j3, v3, LINK3_PLACEMENT);
            let link4 = placed!(j4, v4, LINK4_PLACEMENT);
            let link5 = placed!(j5, v5, LINK5_PLACEMENT);
            let link6 = placed!(j6, v6, LINK6_PLACEMENT);
            let link7 = placed!(j7, v7, LINK7_PLACEMENT);
            let hand = placed!(j7, v7, HAND_PLACEMENT);
            let leftfinger = placed!(j7, v7, LEFTFINGER_PLACEMENT);
            let rightfinger = placed!(j7, v7, RIGHTFINGER_PLACEMENT);
            // Obstacle rows, member by member, slot by slot: the bound, then the row.
            // Obstacle rows, member by member, slot by slot: the bound, then the row. (Braces:
            // one member a line.)
            macro_rules! obstacles {
                ($($pose:ident $bound:ident $member:ident $columns:ident;)*) => {$(
                    for o in &obstacles {
                        let (c, rot, h) = (o.center.map(Counted), o.rotation.map(Counted), o.half.map(Counted));
                        let _ = gen::$bound(&$pose.1, &c, &rot, &h);
                        let (lie, lg) = gen::$member(&$pose.0, &c, &rot, &h);
                        out.push(row(&lie[0], &lg[0], &gen::$columns));
                    }
                )*};
            }
            obstacles! {
                link1 obstacle_link1_lower_bound_from_poses obstacle_link1_from_poses OBSTACLE_LINK1_INPUT_COLUMNS;
                link2 obstacle_link2_lower_bound_from_poses obstacle_link2_from_poses OBSTACLE_LINK2_INPUT_COLUMNS;
                link3 obstacle_link3_lower_bound_from_poses obstacle_link3_from_poses OBSTACLE_LINK3_INPUT_COLUMNS;
                link4 obstacle_link4_lower_bound_from_poses obstacle_link4_from_poses OBSTACLE_LINK4_INPUT_COLUMNS;
                link5 obstacle_link5_lower_bound_from_poses obstacle_link5_from_poses OBSTACLE_LINK5_INPUT_COLUMNS;
                link6 obstacle_link6_lower_bound_from_poses obstacle_link6_from_poses OBSTACLE_LINK6_INPUT_COLUMNS;
                link7 obstacle_link7_lower_bound_from_poses obstacle_link7_from_poses OBSTACLE_LINK7_INPUT_COLUMNS;
                hand obstacle_hand_lower_bound_from_poses obstacle_hand_from_poses OBSTACLE_HAND_INPUT_COLUMNS;
                leftfinger obstacle_leftfinger_lower_bound_from_poses obstacle_leftfinger_from_poses OBSTACLE_LEFTFINGER_INPUT_COLUMNS;
                rightfinger obstacle_rightfinger_lower_bound_from_poses obstacle_rightfinger_from_poses OBSTACLE_RIGHTFINGER_INPUT_COLUMNS;
            }
            // Self-collision pairs: link 0 is fixed (its box is in the chain as numbers).
            macro_rules! pair {
                (link0, $b:ident, $bound:ident, $member:ident, $columns:ident) => {
                    let _ = gen::$bound(&$b.1);
                    let (lie, lg) = gen::$member(&$b.0);
                    out.push(row(&lie[0], &lg[0], &gen::$columns));
                };
                ($a:ident, $b:ident, $bound:ident, $member:ident, $columns:ident) => {
                    let _ = gen::$bound(&$a.1, &$b.1);
                    let (lie, lg) = gen::$member(&$a.0, &$b.0);
                    out.push(row(&lie[0], &lg[0], &gen::$columns));
                };
            }
            macro_rules! pairs {
                ($($a:ident $b:ident $bound:ident $member:ident $columns:ident;)*) => {$(
                    pair!($a, $b, $bound, $member, $columns);
                )*};
            }
            pairs! {
                link0 link5 self_collision_link0_link5_lower_bound_from_poses self_collision_link0_link5_from_poses SELF_COLLISION_LINK0_LINK5_INPUT_COLUMNS;
                link0 link6 self_collision_link0_link6_lower_bound_from_poses self_collision_link0_link6_from_poses SELF_COLLISION_LINK0_LINK6_INPUT_COLUMNS;
                link0 link7 self_collision_link0_link7_lower_bound_from_poses self_collision_link0_link7_from_poses SELF_COLLISION_LINK0_LINK7_INPUT_COLUMNS;
                link0 hand self_collision_link0_hand_lower_bound_from_poses self_collision_link0_hand_from_poses SELF_COLLISION_LINK0_HAND_INPUT_COLUMNS;
                link0 leftfinger self_collision_link0_leftfinger_lower_bound_from_poses self_collision_link0_leftfinger_from_poses SELF_COLLISION_LINK0_LEFTFINGER_INPUT_COLUMNS;
                link0 rightfinger self_collision_link0_rightfinger_lower_bound_from_poses self_collision_link0_rightfinger_from_poses SELF_COLLISION_LINK0_RIGHTFINGER_INPUT_COLUMNS;
                link1 link5 self_collision_link1_link5_lower_bound_from_poses self_collision_link1_link5_from_poses SELF_COLLISION_LINK1_LINK5_INPUT_COLUMNS;
                link1 link6 self_collision_link1_link6_lower_bound_from_poses self_collision_link1_link6_from_poses SELF_COLLISION_LINK1_LINK6_INPUT_COLUMNS;
                link1 link7 self_collision_link1_link7_lower_bound_from_poses self_collision_link1_link7_from_poses SELF_COLLISION_LINK1_LINK7_INPUT_COLUMNS;
                link1 hand self_collision_link1_hand_lower_bound_from_poses self_collision_link1_hand_from_poses SELF_COLLISION_LINK1_HAND_INPUT_COLUMNS;
                link1 leftfinger self_collision_link1_leftfinger_lower_bound_from_poses self_collision_link1_leftfinger_from_poses SELF_COLLISION_LINK1_LEFTFINGER_INPUT_COLUMNS;
                link1 rightfinger self_collision_link1_rightfinger_lower_bound_from_poses self_collision_link1_rightfinger_from_poses SELF_COLLISION_LINK1_RIGHTFINGER_INPUT_COLUMNS;
                link2 link5 self_collision_link2_link5_lower_bound_from_poses self_collision_link2_link5_from_poses SELF_COLLISION_LINK2_LINK5_INPUT_COLUMNS;
                link2 link6 self_collision_link2_link6_lower_bound_from_poses self_collision_link2_link6_from_poses SELF_COLLISION_LINK2_LINK6_INPUT_COLUMNS;
                link2 link7 self_collision_link2_link7_lower_bound_from_poses self_collision_link2_link7_from_poses SELF_COLLISION_LINK2_LINK7_INPUT_COLUMNS;
                link2 hand self_collision_link2_hand_lower_bound_from_poses self_collision_link2_hand_from_poses SELF_COLLISION_LINK2_HAND_INPUT_COLUMNS;
                link2 leftfinger self_collision_link2_leftfinger_lower_bound_from_poses self_collision_link2_leftfinger_from_poses SELF_COLLISION_LINK2_LEFTFINGER_INPUT_COLUMNS;
                link2 rightfinger self_collision_link2_rightfinger_lower_bound_from_poses self_collision_link2_rightfinger_from_poses SELF_COLLISION_LINK2_RIGHTFINGER_INPUT_COLUMNS;
                link5 leftfinger self_collision_link5_leftfinger_lower_bound_from_poses self_collision_link5_leftfinger_from_poses SELF_COLLISION_LINK5_LEFTFINGER_INPUT_COLUMNS;
                link5 rightfinger self_collision_link5_rightfinger_lower_bound_from_poses self_collision_link5_rightfinger_from_poses SELF_COLLISION_LINK5_RIGHTFINGER_INPUT_COLUMNS;
            }
            out
        });
        assert_eq!(replayed.len(), rows.len(), "{slots} slots");
        for (k, (row, replayed)) in rows.iter().zip(&replayed).enumerate() {
            assert!(row.active && !row.culled, "{slots} slots: row {k}");
            assert_eq!((row.lie, row.lg), (replayed.lie, replayed.lg), "{slots} slots: row {k}");
        }
        assert_eq!(stated, count, "{slots} slots: stated {stated}, counted {count}");
        println!("{slots} obstacle(s) per link: {stated}");
    }
}
