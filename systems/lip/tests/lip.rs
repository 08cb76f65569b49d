//! The 3D-LIP navigation stack against independent truths: numerical integration for the
//! step matrices, hand-computed frames, exact point–rectangle distances for safety, and
//! every MPC row recomputed from the applied plan.

use cbfgen_lip::{Frame, Lip};

/// `p̈ = β²(p − f)` integrated over `T` with classical RK4 in 20 000 sub-steps.
fn integrate_axis(beta: f64, t: f64, p0: f64, v0: f64, f: f64) -> (f64, f64) {
    let steps = 20_000;
    let h = t / steps as f64;
    let deriv = |p: f64, v: f64| (v, beta * beta * (p - f));
    let (mut p, mut v) = (p0, v0);
    for _ in 0..steps {
        let k1 = deriv(p, v);
        let k2 = deriv(p + 0.5 * h * k1.0, v + 0.5 * h * k1.1);
        let k3 = deriv(p + 0.5 * h * k2.0, v + 0.5 * h * k2.1);
        let k4 = deriv(p + h * k3.0, v + h * k3.1);
        p += h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
        v += h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
    }
    (p, v)
}

#[test]
fn closed_form_step_matches_numerical_integration_of_the_pendulum() {
    for (height, t) in [(1.0, 0.4), (0.8, 0.3), (1.1, 0.5)] {
        let lip = Lip::new(height, t).expect("lip");
        assert!((lip.beta - (9.81f64 / height).sqrt()).abs() < 1e-15);
        for &(p0, v0, f) in &[(0.0, 0.0, 0.1), (0.05, 0.4, -0.1), (-0.2, -0.3, 0.25), (1.3, 0.6, 1.45)] {
            let (p, v) = integrate_axis(lip.beta, t, p0, v0, f);
            let (pc, vc) = lip.axis_step(p0, v0, f);
            assert!((p - pc).abs() < 1e-9 && (v - vc).abs() < 1e-9, "H {height} T {t}: ({pc}, {vc}) vs RK4 ({p}, {v})");
        }
        // The full step applies the same per axis and integrates the heading.
        let x = lip.step(&[0.05, 0.4, -0.2, -0.3, 0.3], &[0.1, -0.1, 0.5]);
        let (px, vx) = integrate_axis(lip.beta, t, 0.05, 0.4, 0.1);
        let (py, vy) = integrate_axis(lip.beta, t, -0.2, -0.3, -0.1);
        for (got, want) in x.iter().zip([px, vx, py, vy, 0.3 + 0.5 * t]) {
            assert!((got - want).abs() < 1e-9, "{x:?}");
        }
    }
    assert!(Lip::new(f64::NAN, 0.4).is_err() && Lip::new(1.0, 0.0).is_err());
}

#[test]
fn frames_match_a_hand_computed_case_and_round_trip() {
    // Frame at (1, 2) turned by 90°: local +x is global +y.
    let frame = Frame::new([1.0, 2.0], std::f64::consts::FRAC_PI_2).expect("frame");
    let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12;
    assert!(close(frame.point_to_global([1.0, 0.0]), [1.0, 3.0]));
    assert!(close(frame.point_to_global([0.5, -2.0]), [3.0, 2.5]));
    assert!(close(frame.vector_to_global([0.3, 0.0]), [0.0, 0.3]), "velocities rotate, never shift");
    let x = frame.state_to_global(&[1.0, 0.3, 0.0, 0.1, 0.2]);
    for (got, want) in x.iter().zip([1.0, -0.1, 3.0, 0.3, std::f64::consts::FRAC_PI_2 + 0.2]) {
        assert!((got - want).abs() < 1e-12, "{x:?}");
    }
    // The next frame sits at the new CoM with the accumulated heading.
    let next = frame.following(&[1.0, 0.3, 0.0, 0.1, 0.2]);
    assert!(close(next.origin, [1.0, 3.0]) && (next.heading - (std::f64::consts::FRAC_PI_2 + 0.2)).abs() < 1e-12);

    // Round trips in a skewed frame.
    let frame = Frame::new([-0.7, 3.1], 2.3).expect("frame");
    let state = [0.4, -0.2, 1.7, 0.6, -0.9];
    let back = frame.state_to_local(&frame.state_to_global(&state));
    assert!(back.iter().zip(state).all(|(a, b)| (a - b).abs() < 1e-12), "{back:?}");
    assert!(close(frame.point_to_local(frame.point_to_global([2.0, -1.0])), [2.0, -1.0]));
    assert!(Frame::new([f64::NAN, 0.0], 0.0).is_err());
}

use cbfgen::CbfError;
use cbfgen_lip::mpc::{wrap_angle, QpView};
use cbfgen_lip::scenario::{run, Scenario, Walker};
use cbfgen_lip::{BarrierForm, HeadingRule, LipMpc, LipParams, LipState, Rectangle};

/// Distance from `p` to the rectangle, by cases on the nine regions around it (written
/// apart from the crate's clamp-based version).
fn point_rectangle_distance(p: [f64; 2], r: &Rectangle) -> f64 {
    let gap = |v: f64, lo: f64, hi: f64| {
        if v < lo {
            lo - v
        } else if v > hi {
            v - hi
        } else {
            0.0
        }
    };
    (gap(p[0], r.min[0], r.max[0]).powi(2) + gap(p[1], r.min[1], r.max[1]).powi(2)).sqrt()
}

#[test]
fn the_standard_scenario_reaches_the_goal_within_its_step_budget() {
    let scenario = Scenario::standard();
    let result = run(&scenario).expect("run");
    assert!(result.failure.is_none(), "MPC failed: {:?}", result.failure);
    assert!(result.reached_goal, "not at the goal after {} steps", result.steps.len());
    assert!(result.steps.len() <= 80, "{} steps", result.steps.len());
    let last = result.com_path.last().expect("path");
    let to_goal = (last[0] - scenario.goal[0]).hypot(last[1] - scenario.goal[1]);
    assert!(to_goal <= scenario.goal_tolerance);
    // The straight line really is blocked: some point of it lies inside an obstacle.
    let blocked = (0..=100).map(|i| i as f64 / 100.0).any(|s| {
        let p = [scenario.goal[0] * s, scenario.goal[1] * s];
        scenario.obstacles.iter().any(|r| point_rectangle_distance(p, r) == 0.0)
    });
    assert!(blocked && scenario.obstacles.len() >= 3);
}

#[test]
fn the_com_never_comes_closer_than_delta_to_any_obstacle() {
    let scenario = Scenario::standard();
    let result = run(&scenario).expect("run");
    let delta = scenario.params.delta;
    let mut closest = f64::INFINITY;
    for p in &result.com_path {
        for r in &scenario.obstacles {
            let d = point_rectangle_distance(*p, r);
            closest = closest.min(d);
            assert!(d >= delta - 1e-4, "CoM {p:?} is {d:.5} m from {r:?} (δ = {delta})");
        }
    }
    // …and the barrier mattered: the path came near δ somewhere.
    assert!(closest < delta + 0.1, "closest approach {closest}");
    assert!((closest - result.min_clearance()).abs() < 1e-12);
}

/// Recompute every row of the MPC from the plan's feet, the model, and the preprocessing
/// done again here; return the largest violation.
fn plan_violation(walker: &Walker) -> [f64; 2] {
    let mpc = walker.mpc();
    let (p, plan) = (mpc.params(), mpc.plan());
    let x0 = *walker.local_start();
    let goal = walker.frame().point_to_local(walker.scenario().goal);
    let t = p.lip.step_time;
    // Heading preprocessing, again.
    let bearing = (goal[1] - x0[2]).atan2(goal[0] - x0[0]);
    let (mut theta, mut worst) = (x0[4], [0.0f64; 2]);
    let mut x = x0;
    for (k, u) in plan.inputs().iter().enumerate() {
        let error = match p.heading {
            HeadingRule::PerStepRate => wrap_angle(bearing - theta) / t,
            // The report: the start's angle error, used as a rate, for every step.
            HeadingRule::Report => wrap_angle(bearing - x0[4]),
        };
        let omega = error.clamp(p.omega_bounds[0], p.omega_bounds[1]);
        assert!((omega - u[2]).abs() < 1e-12, "step {k}: ω {} vs {omega}", u[2]);
        assert!((plan.states()[k][4] - theta).abs() < 1e-12, "θ_{k}");
        let (px, vx) = p.lip.axis_step(x[0], x[1], u[0]);
        let (py, vy) = p.lip.axis_step(x[2], x[3], u[1]);
        let sv = plan.stance_signs()[0] * if k % 2 == 0 { 1.0 } else { -1.0 };
        assert_eq!(sv, plan.stance_signs()[k]);
        let (s, c) = theta.sin_cos();
        let forward = c * vx + s * vy;
        let lateral = sv * (-s * vx + c * vy);
        let along = c * (px - x[0]) + s * (py - x[2]);
        let across = -s * (px - x[0]) + c * (py - x[2]);
        let slot = usize::from(k > 0);
        let mut over = |v: f64, lo: f64, hi: f64| worst[slot] = worst[slot].max(lo - v).max(v - hi);
        over(forward, p.vx_bounds[0], p.vx_bounds[1]);
        over(lateral, p.vy_bounds[0], p.vy_bounds[1]);
        over(along, -p.leg_reach, p.leg_reach);
        over(across, -p.leg_reach, p.leg_reach);
        over(forward, f64::NEG_INFINITY, p.vx_bounds[1] - p.alpha / std::f64::consts::PI * omega.abs());
        for plane in walker.planes() {
            let h = |q: [f64; 2]| {
                plane.normal[0] * (q[0] - plane.point[0]) + plane.normal[1] * (q[1] - plane.point[1]) - p.delta
            };
            over(h([px, py]) - (1.0 - p.gamma) * h([x[0], x[2]]), 0.0, f64::INFINITY);
        }
        x = [px, vx, py, vy, theta + omega * t];
        theta += omega * t;
    }
    worst
}

#[test]
fn every_applied_plan_satisfies_velocity_reach_maneuver_and_cbf_rows() {
    let base = Scenario::standard();
    let report =
        LipParams { barrier: BarrierForm::ReportNormal, delta: 0.09, heading: HeadingRule::Report, ..base.params };
    for scenario in [base.clone(), Scenario { params: report, ..base }] {
        every_applied_plan_satisfies_its_rows(scenario);
    }
}

fn every_applied_plan_satisfies_its_rows(scenario: Scenario) {
    let mut walker = Walker::new(scenario).expect("walker");
    let mut steps = 0;
    while !walker.at_goal() && steps < 100 {
        let outcome = walker.step().expect("step");
        assert!(outcome.advanced, "step {steps}: {:?}", outcome.status);
        let [first, later] = plan_violation(&walker);
        assert!(first <= 1e-5, "step {steps}: a row of the applied step is violated by {first:.2e}");
        assert!(later <= 1e-3, "step {steps}: a row later in the horizon is violated by {later:.2e}");
        // The step applied is the plan's first: the CoM moved to x_1.
        let x1 = walker.mpc().plan().states()[1];
        let moved = walker.frame().point_to_global([x1[0], x1[2]]);
        assert!((moved[0] - walker.com()[0]).abs() < 1e-12 && (moved[1] - walker.com()[1]).abs() < 1e-12);
        steps += 1;
    }
    assert!(walker.at_goal());
}

/// The same QP on Clarabel (interior point), `l ≤ Az ≤ u` split into cones.
fn clarabel_solution(qp: &QpView) -> Vec<f64> {
    clarabel_solution_with(qp, clarabel::solver::DefaultSettings { verbose: false, ..Default::default() })
}

/// [`clarabel_solution`] to tolerances 1e-11 (its defaults are 1e-8): along feet late in
/// the horizon the cost is nearly flat, and Clarabel's gap tolerance then leaves those
/// feet 1e-6 from the optimum.
fn clarabel_tight_solution(qp: &QpView) -> Vec<f64> {
    clarabel_solution_with(
        qp,
        clarabel::solver::DefaultSettings {
            verbose: false,
            tol_gap_abs: 1e-11,
            tol_gap_rel: 1e-11,
            tol_feas: 1e-11,
            tol_ktratio: 1e-9,
            ..Default::default()
        },
    )
}

fn clarabel_solution_with(qp: &QpView, settings: clarabel::solver::DefaultSettings<f64>) -> Vec<f64> {
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus};
    let n = qp.q.len();
    let p = CscMatrix::new(n, n, qp.p_indptr.to_vec(), qp.p_indices.to_vec(), qp.p_data.to_vec());
    let mut rows: Vec<Vec<(usize, f64)>> = vec![Vec::new(); qp.lower.len()];
    for c in 0..n {
        for k in qp.a_indptr[c]..qp.a_indptr[c + 1] {
            rows[qp.a_indices[k]].push((c, qp.a_data[k]));
        }
    }
    // Each finite bound is one row of A' z ≤ b.
    let mut ineq: Vec<(Vec<(usize, f64)>, f64)> = Vec::new();
    for (row, (&lower, &upper)) in rows.iter().zip(qp.lower.iter().zip(qp.upper)) {
        if upper < qp.infinity {
            ineq.push((row.clone(), upper));
        }
        if lower > -qp.infinity {
            ineq.push((row.iter().map(|&(c, v)| (c, -v)).collect(), -lower));
        }
    }
    let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::new(), Vec::new());
    for c in 0..n {
        for (r, (row, _)) in ineq.iter().enumerate() {
            if let Some(&(_, v)) = row.iter().find(|(col, _)| *col == c) {
                rowval.push(r);
                nzval.push(v);
            }
        }
        colptr.push(rowval.len());
    }
    let a = CscMatrix::new(ineq.len(), n, colptr, rowval, nzval);
    let b: Vec<f64> = ineq.iter().map(|(_, b)| *b).collect();
    let mut solver =
        DefaultSolver::new(&p, qp.q, &a, &b, &[NonnegativeConeT(ineq.len())], settings).expect("clarabel setup");
    solver.solve();
    assert_eq!(solver.solution.status, SolverStatus::Solved);
    solver.solution.x.clone()
}

#[test]
fn osqp_plans_agree_with_clarabel_on_the_same_qp() {
    let osqp =
        cbfgen::filter::SolverSettings { backend: cbfgen::filter::Solver::Osqp, ..LipMpc::default_solver_settings() };
    let mut walker = Walker::new(Scenario { solver: osqp, ..Scenario::standard() }).expect("walker");
    for step in 0..30 {
        walker.step().expect("step");
        let reference = clarabel_solution(&walker.mpc().qp());
        let feet: Vec<f64> = walker.mpc().plan().inputs().iter().flat_map(|u| [u[0], u[1]]).collect();
        let gap = |range: std::ops::Range<usize>| range.map(|i| (feet[i] - reference[i]).abs()).fold(0.0, f64::max);
        let (first, all) = (gap(0..2), gap(0..feet.len()));
        let qp = walker.mpc().qp();
        let objective = |z: &[f64]| {
            let mut v: f64 = z.iter().zip(qp.q).map(|(a, b)| a * b).sum();
            for c in 0..z.len() {
                for k in qp.p_indptr[c]..qp.p_indptr[c + 1] {
                    let r = qp.p_indices[k];
                    let w = if r == c { 0.5 } else { 1.0 };
                    v += w * qp.p_data[k] * z[r] * z[c];
                }
            }
            v
        };
        // The goal cost is flat along feet late in the horizon (they barely move p_N), so
        // the optimum is compared by its value; the feet only loosely.
        let (ours, theirs) = (objective(&feet), objective(&reference));
        assert!((ours - theirs).abs() <= 1e-4 * theirs.abs().max(1.0), "step {step}: objective {ours} vs {theirs}");
        assert!(first <= 1e-2, "step {step}: the applied foot differs from Clarabel's by {first:.2e} m");
        assert!(all <= 5e-2, "step {step}: a planned foot differs from Clarabel's by {all:.2e} m");
    }
}

#[test]
fn non_finite_input_is_an_error_and_an_obstacle_overlap_is_handled() {
    let mut walker = Walker::new(Scenario::standard()).expect("walker");
    walker.set_state([0.0, f64::NAN, 0.0, 0.0, 0.0]);
    assert!(matches!(walker.step(), Err(CbfError::NonFinite { .. })));

    let mut mpc = LipMpc::new(Default::default(), 1, LipMpc::default_solver_settings()).expect("mpc");
    let x0 = [0.0; 5];
    assert!(matches!(mpc.solve(&x0, [f64::INFINITY, 0.0], 1.0, &[]), Err(CbfError::NonFinite { .. })));
    let plane = Rectangle::new(1.0, 2.0, -1.0, 1.0).expect("rect").half_plane([0.0, 0.0], 0.3, BarrierForm::UnitNormal);
    let bad = cbfgen_lip::HalfPlane { normal: [f64::NAN, 0.0], ..plane };
    assert!(mpc.solve(&x0, [3.0, 0.0], 1.0, &[bad]).is_err());
    assert!(mpc.solve(&x0, [3.0, 0.0], 0.5, &[plane]).is_err(), "stance sign must be ±1");
    assert!(mpc.solve(&x0, [3.0, 0.0], 1.0, &[plane, plane]).is_err(), "capacity 1");
    assert!(mpc.solve(&x0, [3.0, 0.0], 1.0, &[plane]).expect("valid").is_solved());

    // A CoM inside an obstacle: the half-plane of the nearest edge, flagged, h < 0, no panic.
    let rect = Rectangle::new(1.0, 2.0, -1.0, 1.0).expect("rect");
    let inside = rect.half_plane([1.1, 0.2], 0.3, BarrierForm::UnitNormal);
    assert!(inside.inside && inside.normal == [-1.0, 0.0] && inside.point == [1.0, 0.2]);
    assert!((inside.h([1.1, 0.2]) - (-0.1 - 0.3)).abs() < 1e-12);
    let on_edge = rect.half_plane([2.0, 0.5], 0.3, BarrierForm::UnitNormal);
    assert!(on_edge.inside && on_edge.normal == [1.0, 0.0]);
    let scenario = Scenario { start: [1.1, 0.0, 0.2, 0.0, 0.0], obstacles: vec![rect], ..Scenario::standard() };
    let mut walker = Walker::new(scenario).expect("walker");
    let outcome = walker.step().expect("no error inside an obstacle");
    assert!(outcome.inside);
}

use cbfgen::filter::{Backend, QpStatus, Solver, SolverSettings};
use cbfgen::qp::dual_active_set::{DenseStatus, KKT_TOLERANCE};

/// The feet of the current plan, as the QP's variables `z`.
fn plan_feet(mpc: &LipMpc) -> Vec<f64> {
    mpc.plan().inputs().iter().flat_map(|u| [u[0], u[1]]).collect()
}

/// `½ zᵀPz + qᵀz` of the MPC's QP.
fn qp_objective(qp: &QpView, z: &[f64]) -> f64 {
    let mut v: f64 = z.iter().zip(qp.q).map(|(a, b)| a * b).sum();
    for c in 0..z.len() {
        for k in qp.p_indptr[c]..qp.p_indptr[c + 1] {
            let r = qp.p_indices[k];
            let w = if r == c { 0.5 } else { 1.0 };
            v += w * qp.p_data[k] * z[r] * z[c];
        }
    }
    v
}

/// The largest violation of a row of the MPC's QP at `z`, each relative to the size of
/// its terms (the dense solver's documented scale, recomputed here).
fn qp_row_violation(qp: &QpView, z: &[f64]) -> f64 {
    let mut value = vec![0.0; qp.lower.len()];
    let mut size = vec![0.0; qp.lower.len()];
    for (c, &zc) in z.iter().enumerate() {
        for k in qp.a_indptr[c]..qp.a_indptr[c + 1] {
            value[qp.a_indices[k]] += qp.a_data[k] * zc;
            size[qp.a_indices[k]] += qp.a_data[k].abs() * (1.0 + zc.abs());
        }
    }
    let mut worst = 0.0f64;
    for i in 0..value.len() {
        let (l, u) = (qp.lower[i], qp.upper[i]);
        if l > -qp.infinity {
            worst = worst.max((l - value[i]) / (l.abs() + size[i]).max(f64::MIN_POSITIVE));
        }
        if u < qp.infinity {
            worst = worst.max((value[i] - u) / (u.abs() + size[i]).max(f64::MIN_POSITIVE));
        }
    }
    worst
}

/// The worst stationarity residual `|Pz + q + Aᵀy|_j` of the MPC's QP, each relative to
/// the size of its terms, and whether every multiplier has the sign of a bound its row is
/// at (`y ≤ 0` at a lower bound, `≥ 0` at an upper one, to the same relative tolerance).
fn qp_dual_residual(qp: &QpView, z: &[f64], y: &[f64]) -> (f64, bool) {
    let n = z.len();
    let (mut gradient, mut size) = (qp.q.to_vec(), qp.q.iter().map(|v| v.abs()).collect::<Vec<_>>());
    for c in 0..n {
        for k in qp.p_indptr[c]..qp.p_indptr[c + 1] {
            let r = qp.p_indices[k];
            let mut add = |i: usize, t: f64| {
                gradient[i] += t;
                size[i] += t.abs();
            };
            add(r, qp.p_data[k] * z[c]);
            if r != c {
                add(c, qp.p_data[k] * z[r]);
            }
        }
    }
    let mut value = vec![0.0; y.len()];
    let mut row_size = vec![0.0; y.len()];
    for c in 0..n {
        for k in qp.a_indptr[c]..qp.a_indptr[c + 1] {
            let i = qp.a_indices[k];
            gradient[c] += y[i] * qp.a_data[k];
            size[c] += (y[i] * qp.a_data[k]).abs();
            value[i] += qp.a_data[k] * z[c];
            row_size[i] += qp.a_data[k].abs() * (1.0 + z[c].abs());
        }
    }
    let at =
        |i: usize, b: f64| b.abs() < qp.infinity && (value[i] - b).abs() <= KKT_TOLERANCE * (b.abs() + row_size[i]);
    let signs =
        (0..y.len()).all(|i| y[i] == 0.0 || (y[i] < 0.0 && at(i, qp.lower[i])) || (y[i] > 0.0 && at(i, qp.upper[i])));
    let worst =
        gradient.iter().zip(&size).map(|(g, s)| if *s > 0.0 { g.abs() / s } else { g.abs() }).fold(0.0, f64::max);
    (worst, signs)
}

#[test]
fn dense_plans_agree_with_clarabel_on_every_step_of_the_standard_course() {
    let scenario = Scenario::standard();
    assert_eq!(scenario.solver.backend, Solver::DenseThenOsqp, "the default");
    let mut walker = Walker::new(scenario).expect("walker");
    let (mut steps, mut dense_steps, mut worst_gap, mut worst_violation) = (0, Vec::new(), 0.0f64, 0.0f64);
    let (mut worst_stationarity, mut clarabel_short) = (0.0f64, 0);
    while !walker.at_goal() && steps < 100 {
        let outcome = walker.step().expect("step");
        let mpc = walker.mpc();
        assert_eq!((outcome.status, outcome.answered_by), (QpStatus::Solved, Backend::Dense), "step {steps}");
        assert_eq!((outcome.iterations, mpc.dense_status()), (0, Some(DenseStatus::Solved)), "OSQP never ran");
        dense_steps.push(outcome.dense_steps);
        let qp = mpc.qp();
        let feet = plan_feet(mpc);
        let violation = qp_row_violation(&qp, &feet);
        worst_violation = worst_violation.max(violation);
        assert!(violation <= KKT_TOLERANCE, "step {steps}: a row is violated by {violation:.2e}");
        // Optimal: the KKT conditions, recomputed here from the QP and the multipliers.
        let dense = mpc.dense_solver().expect("a dense solver");
        let (stationarity, signs) = qp_dual_residual(&qp, &feet, dense.row_multipliers());
        worst_stationarity = worst_stationarity.max(stationarity);
        assert!(stationarity <= KKT_TOLERANCE && signs, "step {steps}: stationarity {stationarity:.1e}, signs {signs}");
        // And Clarabel's answer: the same feet, except along directions where the cost is
        // so flat (|f| ≈ 4e4, differences of 1e-7) that Clarabel's gap tolerance leaves its
        // feet short: its point then holds every row and costs more than ours.
        let reference = clarabel_tight_solution(&qp);
        let (ours, theirs) = (qp_objective(&qp, &feet), qp_objective(&qp, &reference));
        let scale = 1.0 + reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let gap = feet.iter().zip(&reference).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        if gap <= 1e-6 * scale {
            worst_gap = worst_gap.max(gap / scale);
        } else {
            let holds = qp_row_violation(&qp, &reference) <= KKT_TOLERANCE;
            assert!(holds && ours < theirs, "step {steps}: the feet differ from Clarabel's by {gap:.2e}");
            clarabel_short += 1;
        }
        steps += 1;
    }
    assert!(walker.at_goal());
    println!(
        "{steps} steps; dense steps per solve {dense_steps:?}; worst row {worst_violation:.1e} and stationarity \
         {worst_stationarity:.1e} (of their terms); feet within {worst_gap:.1e} of Clarabel's (of the scale) on {} \
         steps, Clarabel short of the optimum on {clarabel_short}",
        steps - clarabel_short
    );
    assert!(clarabel_short * 4 <= steps, "Clarabel short on {clarabel_short} of {steps} steps");
}

#[test]
fn both_backends_walk_the_course_and_the_default_never_needs_osqp_or_settles_for_inaccurate() {
    let default = Scenario::standard();
    let osqp = Scenario {
        solver: SolverSettings { backend: Solver::Osqp, ..LipMpc::default_solver_settings() },
        ..Scenario::standard()
    };
    let dense = run(&default).expect("dense run");
    let reference = run(&osqp).expect("OSQP run");
    for (name, result) in [("dense", &dense), ("OSQP", &reference)] {
        assert!(result.reached_goal && result.failure.is_none(), "{name}: {:?}", result.failure);
    }
    assert!(dense
        .steps
        .iter()
        .all(|s| s.outcome.status == QpStatus::Solved && s.outcome.answered_by == Backend::Dense));
    assert!(dense.steps.iter().all(|s| s.outcome.iterations == 0 && s.outcome.dense_steps <= 100));
    assert!(reference.steps.iter().all(|s| s.outcome.answered_by == Backend::Osqp && s.outcome.dense_steps == 0));
    // (The two walks are not compared step by step: OSQP's plans are optimal only to its
    // tolerances, and the closed loop carries a millimetre's difference on.)
    assert!(dense.summary().contains("OSQP answered 0 of"), "{}", dense.summary());
}

/// The standard course's first problem, in the start frame with its obstacles' half-planes.
fn first_problem() -> (LipState, [f64; 2], f64, Vec<cbfgen_lip::HalfPlane>) {
    let s = Scenario::standard();
    let p = [s.start[0], s.start[2]];
    let planes = s.obstacles.iter().map(|r| r.half_plane(p, s.params.delta, s.params.barrier)).collect();
    (s.start, s.goal, s.first_stance, planes)
}

#[test]
fn out_of_dense_steps_is_flagged_or_handed_to_osqp() {
    let (x0, goal, stance, planes) = first_problem();
    let budget =
        |backend, dense_max_steps| SolverSettings { backend, dense_max_steps, ..LipMpc::default_solver_settings() };
    let params = Scenario::standard().params;
    let mut exact = LipMpc::new(params, planes.len(), budget(Solver::Dense, 100)).expect("mpc");
    assert_eq!(exact.solve(&x0, goal, stance, &planes).expect("solve"), QpStatus::Solved);
    // The budget counts rows added to the active set (the drops on the way are free).
    let needed = exact.dense_solver().expect("dense").rows_added();
    assert!(needed > 1, "a cold solve of the course's first problem adds {needed} rows");

    // Dense only, one step short: flagged, no plan, OSQP never set up or run.
    let mut short = LipMpc::new(params, planes.len(), budget(Solver::Dense, needed - 1)).expect("mpc");
    let empty = short.plan().clone();
    assert_eq!(short.solve(&x0, goal, stance, &planes).expect("solve"), QpStatus::MaxIterations);
    assert_eq!(
        (short.answered_by(), short.dense_status(), short.iterations()),
        (Backend::Dense, Some(DenseStatus::MaxSteps), 0)
    );
    assert_eq!(short.dense_solver().expect("dense").rows_added(), needed - 1);
    assert_eq!(short.plan(), &empty, "an unconverged iterate is not a plan");

    // Dense then OSQP, one step short: OSQP answers, with the same feet to its tolerance.
    let mut fallback = LipMpc::new(params, planes.len(), budget(Solver::DenseThenOsqp, needed - 1)).expect("mpc");
    assert!(fallback.solve(&x0, goal, stance, &planes).expect("solve").is_solved());
    assert_eq!((fallback.answered_by(), fallback.dense_status()), (Backend::Osqp, Some(DenseStatus::MaxSteps)));
    assert!(fallback.iterations() > 0);
    let (a, b) = (plan_feet(&exact), plan_feet(&fallback));
    let gap = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    assert!(gap < 1e-3, "OSQP's feet differ from the dense ones by {gap:.1e}");
}

#[test]
fn contradicting_half_planes_are_infeasible_for_both_solvers() {
    // h₁ = (x − 5) − δ and h₂ = −(x + 5) − δ, both −5.3 at the origin: the first step's
    // CBF rows h(p₁) ≥ (1 − γ) h(p₀) = −3.71 ask x₁ ≥ 1.59 and x₁ ≤ −1.59. No plan exists.
    use cbfgen_lip::HalfPlane;
    let planes = [
        HalfPlane { normal: [1.0, 0.0], point: [5.0, 0.0], delta: 0.3, inside: true },
        HalfPlane { normal: [-1.0, 0.0], point: [-5.0, 0.0], delta: 0.3, inside: true },
    ];
    let params = Scenario::standard().params;
    for backend in [Solver::Dense, Solver::DenseThenOsqp] {
        let settings = SolverSettings { backend, ..LipMpc::default_solver_settings() };
        let mut mpc = LipMpc::new(params, 2, settings).expect("mpc");
        assert!(mpc.solve(&[0.0; 5], [3.0, 0.0], 1.0, &[]).expect("solve").is_solved());
        let plan = mpc.plan().clone();
        let status = mpc.solve(&[0.0; 5], [3.0, 0.0], 1.0, &planes).expect("solve");
        assert_eq!(mpc.dense_status(), Some(DenseStatus::Infeasible), "{backend:?}");
        assert_eq!(status, QpStatus::PrimalInfeasible, "{backend:?}: {:?}", mpc.answered_by());
        let expected = if backend == Solver::Dense { Backend::Dense } else { Backend::Osqp };
        assert_eq!(mpc.answered_by(), expected);
        assert_eq!(mpc.plan(), &plan, "{backend:?}: the last plan is kept");
    }
}

/// Whether `p` is on or inside `r`, by comparisons only.
fn on_or_inside(p: [f64; 2], r: &Rectangle) -> bool {
    r.min[0] <= p[0] && p[0] <= r.max[0] && r.min[1] <= p[1] && p[1] <= r.max[1]
}

#[test]
fn with_delta_zero_feet_land_on_the_corner_block_and_with_delta_positive_none_does() {
    // The report's section 5.3.3: δ = 0 keeps the CoM off the obstacle but not the feet,
    // which sway out from the CoM; δ > 0 keeps both off.
    let course = Scenario::corner();
    let ours = run(&course).expect("δ > 0");
    let peng = run(&course.with_delta(0.0)).expect("δ = 0");
    let block = &course.obstacles[0];
    for r in [&ours, &peng] {
        assert!(r.reached_goal && r.failure.is_none(), "δ = {}: {:?}", r.scenario.params.delta, r.failure);
        // The CoM stays out of the block in both (to δ, up to the solver's tolerance).
        let closest = r.com_path.iter().map(|p| point_rectangle_distance(*p, block)).fold(f64::INFINITY, f64::min);
        assert!(closest >= r.scenario.params.delta - 1e-4, "δ = {}: CoM {closest}", r.scenario.params.delta);
    }
    let landed = |r: &cbfgen_lip::scenario::RunResult| r.footsteps().filter(|f| on_or_inside(*f, block)).count();
    assert!(landed(&peng) >= 1, "δ = 0: no foot on the block; min foot clearance {}", peng.min_footstep_clearance());
    assert_eq!(landed(&ours), 0);
    let foot_clearance = ours.footsteps().map(|f| point_rectangle_distance(f, block)).fold(f64::INFINITY, f64::min);
    assert!(foot_clearance > 0.1, "δ = 0.3: closest foot {foot_clearance} m");
    // The crate's own counts agree with the comparisons above.
    assert_eq!(peng.footsteps_on_obstacles().count(), landed(&peng));
    assert!((ours.min_footstep_clearance() - foot_clearance).abs() < 1e-12);
}

#[test]
fn the_reports_normal_makes_h_the_squared_distance_minus_delta_at_the_com() {
    let rect = Rectangle::new(1.0, 2.0, -1.0, 1.0).expect("rect");
    // Corner region: c = (1, 1), x − c = (−0.6, 0.8), ‖x − c‖ = 1.
    let (x, delta) = ([0.4, 1.8], 0.09);
    let report = rect.half_plane(x, delta, BarrierForm::ReportNormal);
    assert_eq!(report.point, [1.0, 1.0]);
    assert!((report.normal[0] + 0.6).abs() < 1e-12 && (report.normal[1] - 0.8).abs() < 1e-12);
    assert!((report.h(x) - (1.0 - delta)).abs() < 1e-12);
    // Face region at distance 0.5: h = 0.25 − δ (m²); the unit form gives 0.5 − δ (m).
    let face = [0.5, 0.0];
    assert!((rect.half_plane(face, delta, BarrierForm::ReportNormal).h(face) - (0.25 - delta)).abs() < 1e-12);
    assert!((rect.half_plane(face, delta, BarrierForm::UnitNormal).h(face) - (0.5 - delta)).abs() < 1e-12);
    // Signed distance: outside, on an edge, inside.
    assert!((rect.signed_distance(x) - 1.0).abs() < 1e-12);
    assert_eq!(rect.signed_distance([1.0, 0.3]), 0.0);
    assert!((rect.signed_distance([1.2, 0.9]) + 0.1).abs() < 1e-12);
}

#[test]
fn the_reports_forms_walk_the_course_keeping_the_com_root_delta_away() {
    // With η = x − c, h ≥ 0 at the CoM is ‖x − c‖ ≥ √δ: δ = 0.09 m² keeps 0.3 m.
    let base = Scenario::standard();
    for heading in [HeadingRule::PerStepRate, HeadingRule::Report] {
        let params = LipParams { barrier: BarrierForm::ReportNormal, delta: 0.09, heading, ..base.params };
        let r = run(&Scenario { params, ..base.clone() }).expect("run");
        assert!(r.reached_goal, "{heading:?}: {:?} after {} steps", r.failure, r.steps.len());
        for p in &r.com_path {
            for o in &base.obstacles {
                assert!(point_rectangle_distance(*p, o) >= 0.3 - 1e-4, "{heading:?}: CoM {p:?}");
            }
        }
    }
}
