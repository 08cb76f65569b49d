//! The optimal-control QP against Clarabel on the same problem written out densely, on
//! random horizons, sizes, sparsity patterns and row kinds (equalities, one- and two-sided
//! rows, unused rows); entries outside the declared pattern hold garbage that must be
//! ignored. And bad data is a status, after which the next good solve is unharmed.

// Index loops mirror the formulas.
#![allow(clippy::needless_range_loop)]

use cbfgen::qp::ocp::{Ocp, OcpMethod, OcpShape};
use cbfgen::qp::{QpStatus, SolverSettings, INFINITY};
use cbfgen_testkit::clarabel_qp::{self, Answer, Row};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A random problem: its shape and every stage's data, dense, zero outside the pattern.
struct Problem {
    shape: OcpShape,
    initial: Vec<f64>,
    /// Per stage k ≤ N: (A, B, c, C, D, lower, upper, Q, R, x_ref, u_ref).
    stages: Vec<StageData>,
}

#[derive(Clone)]
struct StageData {
    a: Vec<f64>,
    b: Vec<f64>,
    offset: Vec<f64>,
    c: Vec<f64>,
    d: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    q: Vec<f64>,
    r: Vec<f64>,
    x_ref: Vec<f64>,
    u_ref: Vec<f64>,
}

fn mask(rng: &mut ChaCha8Rng, len: usize, density: f64) -> Vec<bool> {
    (0..len).map(|_| rng.random_bool(density)).collect()
}

fn masked(rng: &mut ChaCha8Rng, pattern: &[bool]) -> Vec<f64> {
    pattern.iter().map(|&on| if on { rng.random_range(-1.0..1.0) } else { 0.0 }).collect()
}

fn random_problem(rng: &mut ChaCha8Rng) -> Problem {
    random_problem_up_to(rng, [6, 4, 3, 3], false)
}

/// A random problem of at most `[horizon, states, inputs, rows]`; `contractive` scales
/// every `A_k` to an ∞-norm of at most 0.95, so that a long horizon's states stay of the
/// size of its inputs (as an MPC's do), not `‖A‖ᴺ`.
fn random_problem_up_to(rng: &mut ChaCha8Rng, most: [usize; 4], contractive: bool) -> Problem {
    let (n, nx, nu, m) = (
        rng.random_range(1..=most[0]),
        rng.random_range(1..=most[1]),
        rng.random_range(0..=most[2]),
        rng.random_range(0..=most[3]),
    );
    let density = rng.random_range(0.3..1.0);
    let shape = OcpShape {
        horizon: n,
        states: nx,
        inputs: nu,
        rows: m,
        a: mask(rng, nx * nx, density),
        b: mask(rng, nx * nu, density),
        c: mask(rng, m * nx, density),
        d: mask(rng, m * nu, density),
    };
    // A trajectory every row holds at, so that the problem is feasible.
    let initial: Vec<f64> = (0..nx).map(|_| rng.random_range(-1.0..1.0)).collect();
    let mut x = initial.clone();
    let mut stages = Vec::new();
    for k in 0..=n {
        let inner = k < n;
        let u: Vec<f64> = (0..if inner { nu } else { 0 }).map(|_| rng.random_range(-1.0..1.0)).collect();
        let mut a = if inner { masked(rng, &shape.a) } else { vec![] };
        if contractive {
            for row in a.chunks_mut(nx) {
                let norm: f64 = row.iter().map(|v| v.abs()).sum();
                if norm > 0.95 {
                    row.iter_mut().for_each(|v| *v *= 0.95 / norm);
                }
            }
        }
        let b = if inner { masked(rng, &shape.b) } else { vec![] };
        let offset: Vec<f64> = (0..if inner { nx } else { 0 }).map(|_| rng.random_range(-0.5..0.5)).collect();
        let c = masked(rng, &shape.c);
        let d = if inner { masked(rng, &shape.d) } else { vec![] };
        let (mut lower, mut upper) = (vec![-INFINITY; m], vec![INFINITY; m]);
        for i in 0..m {
            let value: f64 = (0..nx).map(|j| c[i * nx + j] * x[j]).sum::<f64>()
                + (0..u.len()).map(|j| d[i * nu + j] * u[j]).sum::<f64>();
            match rng.random_range(0..5) {
                0 => (lower[i], upper[i]) = (value, value),
                1 => upper[i] = value + rng.random_range(0.05..0.3),
                2 => lower[i] = value - rng.random_range(0.05..0.3),
                3 => (lower[i], upper[i]) = (value - rng.random_range(0.05..0.3), value + rng.random_range(0.05..0.3)),
                _ => {}
            }
        }
        let q: Vec<f64> =
            (0..nx).map(|_| if rng.random_bool(0.2) { 0.0 } else { rng.random_range(0.1..10.0) }).collect();
        let r: Vec<f64> = (0..u.len()).map(|_| rng.random_range(0.1..10.0)).collect();
        let x_ref = (0..nx).map(|_| rng.random_range(-2.0..2.0)).collect();
        let u_ref = (0..u.len()).map(|_| rng.random_range(-2.0..2.0)).collect();
        if inner {
            x = (0..nx)
                .map(|i| {
                    (0..nx).map(|j| a[i * nx + j] * x[j]).sum::<f64>()
                        + (0..nu).map(|j| b[i * nu + j] * u[j]).sum::<f64>()
                        + offset[i]
                })
                .collect();
        }
        stages.push(StageData { a, b, offset, c, d, lower, upper, q, r, x_ref, u_ref });
    }
    Problem { shape, initial, stages }
}

/// Write the problem into `ocp`, with garbage wherever the pattern says zero.
fn stage(ocp: &mut Ocp, problem: &Problem, rng: &mut ChaCha8Rng) {
    ocp.initial_state_mut().copy_from_slice(&problem.initial);
    let shape = problem.shape.clone();
    for (k, data) in problem.stages.iter().enumerate() {
        let s = ocp.stage_mut(k);
        let fill = |dst: &mut [f64], src: &[f64], pattern: &[bool], rng: &mut ChaCha8Rng| {
            for (t, v) in dst.iter_mut().enumerate() {
                *v = if pattern[t] { src[t] } else { rng.random_range(-1e3..1e3) };
            }
        };
        fill(s.a, &data.a, &shape.a, rng);
        fill(s.b, &data.b, &shape.b, rng);
        fill(s.c, &data.c, &shape.c, rng);
        fill(s.d, &data.d, &shape.d, rng);
        s.offset.copy_from_slice(&data.offset);
        s.lower.copy_from_slice(&data.lower);
        s.upper.copy_from_slice(&data.upper);
        s.q.copy_from_slice(&data.q);
        s.r.copy_from_slice(&data.r);
        s.x_ref.copy_from_slice(&data.x_ref);
        s.u_ref.copy_from_slice(&data.u_ref);
    }
}

/// The same problem for Clarabel, in the OCP's variable layout.
fn clarabel(problem: &Problem) -> Answer {
    let s = &problem.shape;
    let (n, nx, nu, m) = (s.horizon, s.states, s.inputs, s.rows);
    let stride = nx + nu;
    let vars = n * stride + nx;
    let mut p = vec![0.0; vars * vars];
    let mut q = vec![0.0; vars];
    let (mut equalities, mut inequalities): (Vec<Row>, Vec<Row>) = (Vec::new(), Vec::new());
    let unit = |i: usize| {
        let mut row = vec![0.0; vars];
        row[i] = 1.0;
        row
    };
    for i in 0..nx {
        equalities.push((unit(i), problem.initial[i]));
    }
    for (k, data) in problem.stages.iter().enumerate() {
        let (xi, ui) = (k * stride, k * stride + nx);
        for i in 0..nx {
            p[(xi + i) * vars + xi + i] = data.q[i];
            q[xi + i] = -data.q[i] * data.x_ref[i];
        }
        for j in 0..data.r.len() {
            p[(ui + j) * vars + ui + j] = data.r[j];
            q[ui + j] = -data.r[j] * data.u_ref[j];
        }
        if k < n {
            for i in 0..nx {
                let mut row = unit((k + 1) * stride + i);
                for j in 0..nx {
                    row[xi + j] -= data.a[i * nx + j];
                }
                for j in 0..nu {
                    row[ui + j] -= data.b[i * nu + j];
                }
                equalities.push((row, data.offset[i]));
            }
        }
        for i in 0..m {
            let mut row = vec![0.0; vars];
            for j in 0..nx {
                row[xi + j] = data.c[i * nx + j];
            }
            for j in 0..data.d.len() / m.max(1) {
                row[ui + j] = data.d[i * nu + j];
            }
            if data.lower[i] == data.upper[i] {
                equalities.push((row, data.lower[i]));
                continue;
            }
            if data.upper[i] < INFINITY {
                inequalities.push((row.clone(), data.upper[i]));
            }
            if data.lower[i] > -INFINITY {
                inequalities.push((row.iter().map(|v| -v).collect(), -data.lower[i]));
            }
        }
    }
    // Clarabel needs P ≻ 0 on no variable it can leave free; a state with Q = 0 is pinned
    // by the dynamics, so the problem is bounded as posed.
    clarabel_qp::solve(vars, &p, &q, &equalities, &inequalities, clarabel_qp::tight_settings())
}

fn tight() -> SolverSettings {
    SolverSettings {
        eps_abs: 1e-7,
        eps_rel: 1e-7,
        max_iter: SolverSettings::MAX_ITERATIONS,
        ..SolverSettings::default()
    }
}

#[test]
fn random_problems_agree_with_clarabel_and_ignore_entries_outside_the_pattern() {
    for method in [OcpMethod::Admm, OcpMethod::InteriorPoint] {
        agree_with_clarabel(method);
    }
}

fn agree_with_clarabel(method: OcpMethod) {
    let mut rng = ChaCha8Rng::seed_from_u64(38);
    let (mut compared, mut skipped, mut same_point) = (0, 0, 0);
    let mut newton_steps = Vec::new();
    for case in 0..300 {
        let problem = random_problem(&mut rng);
        let Answer::Solved(reference) = clarabel(&problem) else {
            skipped += 1;
            continue;
        };
        let mut ocp = Ocp::with_method(problem.shape.clone(), tight(), method).expect("set-up");
        stage(&mut ocp, &problem, &mut rng);
        // Twice: the second solve runs on the updated (same) data, warm.
        for _ in 0..2 {
            let status = ocp.solve();
            assert_eq!(status, QpStatus::Solved, "{method:?}, case {case}: {status:?}");
            // Random rows can meet at thin angles, where a point 1e-7 outside moves the
            // cost visibly: so the verdict is feasibility and cost, and the points
            // themselves must agree on most problems.
            let (violation, cost) = violation_and_cost(&problem, ocp.solution());
            let (clarabel_violation, clarabel_cost) = violation_and_cost(&problem, &reference);
            assert!(violation < 1e-5, "{method:?}, case {case}: the point violates a row by {violation:e}");
            assert!(
                clarabel_violation < 1e-8,
                "case {case}: Clarabel's point violates a row by {clarabel_violation:e}"
            );
            assert!(
                cost <= clarabel_cost + 1e-5 * (1.0 + clarabel_cost.abs()),
                "{method:?}, case {case}: the cost {cost} is above Clarabel's {clarabel_cost}"
            );
            if method == OcpMethod::InteriorPoint {
                assert_duals_close_the_kkt_conditions(&problem, &ocp, case);
                newton_steps.push(ocp.iterations());
            }
        }
        let worst =
            ocp.solution().iter().zip(&reference).map(|(a, b)| (a - b).abs() / (1.0 + b.abs())).fold(0.0, f64::max);
        if worst < 1e-4 {
            same_point += 1;
        }
        compared += 1;
    }
    assert!(compared >= 250, "only {compared} compared ({skipped} without a Clarabel answer)");
    assert!(
        same_point * 100 >= compared * 95,
        "{method:?}: the points agree to 1e-4 on only {same_point} of {compared}"
    );
    if method == OcpMethod::InteriorPoint {
        newton_steps.sort_unstable();
        let median = newton_steps[newton_steps.len() / 2];
        eprintln!("interior point: median {median} Newton steps, most {}", newton_steps.last().unwrap());
        // Mehrotra's method takes tens of steps whatever the data; hundreds would mean the
        // centring or the step length is broken.
        assert!(median <= 40, "median {median} Newton steps");
    }
}

#[test]
fn the_interior_point_method_agrees_with_clarabel_on_long_horizons() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let mut compared = 0;
    for case in 0..40 {
        let problem = random_problem_up_to(&mut rng, [40, 12, 8, 12], true);
        let Answer::Solved(reference) = clarabel(&problem) else { continue };
        let mut ocp = Ocp::with_method(problem.shape.clone(), tight(), OcpMethod::InteriorPoint).expect("set-up");
        stage(&mut ocp, &problem, &mut rng);
        let status = ocp.solve();
        let big = reference.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert_eq!(status, QpStatus::Solved, "case {case}: largest |z| {big:e}");
        let (violation, cost) = violation_and_cost(&problem, ocp.solution());
        let (_, clarabel_cost) = violation_and_cost(&problem, &reference);
        assert!(violation < 1e-5, "case {case}: the point violates a row by {violation:e}");
        assert!(
            (cost - clarabel_cost).abs() <= 1e-5 * (1.0 + clarabel_cost.abs()),
            "case {case}: cost {cost} against Clarabel's {clarabel_cost}"
        );
        // (No multiplier check here: recovering the dynamics' multipliers backwards through
        // 40 random, often unstable, A_kᵀ amplifies rounding past any tolerance.)
        compared += 1;
    }
    assert!(compared >= 30, "only {compared} compared");
}

#[test]
fn an_infeasible_problem_is_reported_as_such_and_the_next_solve_is_unharmed() {
    // x_{k+1} = x_k + u_k from x₀ = 0, |u_k| ≤ 1, and x_3 = 5 on the terminal row: no
    // input reaches it. Then x_3 = 2, which u = (1, 1, 0) … reaches.
    let shape = OcpShape::dense(3, 1, 1, 1);
    let mut ocp = Ocp::with_method(shape, tight(), OcpMethod::InteriorPoint).expect("set-up");
    let write = |ocp: &mut Ocp, target: f64| {
        ocp.initial_state_mut()[0] = 0.0;
        for k in 0..=3 {
            let s = ocp.stage_mut(k);
            s.q[0] = 1.0;
            s.x_ref[0] = 0.0;
            if k < 3 {
                (s.a[0], s.b[0], s.offset[0], s.r[0], s.u_ref[0]) = (1.0, 1.0, 0.0, 1.0, 0.0);
                (s.c[0], s.d[0], s.lower[0], s.upper[0]) = (0.0, 1.0, -1.0, 1.0);
            } else {
                (s.c[0], s.lower[0], s.upper[0]) = (1.0, target, target);
            }
        }
    };
    write(&mut ocp, 5.0);
    let status = ocp.solve();
    assert_eq!(status, QpStatus::PrimalInfeasible);
    assert!(!status.is_solved());
    write(&mut ocp, 2.0);
    assert_eq!(ocp.solve(), QpStatus::Solved);
    // Hand-solved: minimise ½ Σ (x_k² + u_k²) with x = (0, u₀, u₀ + u₁, 2). Without
    // bounds u = (1/4, 1/2, 5/4); u₂ = 1 then binds and u₀ + u₁ = 1 gives u = (1/3, 2/3, 1),
    // x = (0, 1/3, 1, 2).
    let expected = [0.0, 1.0 / 3.0, 1.0 / 3.0, 2.0 / 3.0, 1.0, 1.0, 2.0];
    for (got, want) in ocp.solution().iter().zip(expected) {
        assert!((got - want).abs() < 1e-6, "{:?} against {expected:?}", ocp.solution());
    }
    assert!(ocp.row_duals(2)[0] > 0.0, "u₂ ≤ 1 binds: its multiplier is positive");
}

/// The interior-point solver's multipliers, read back through `row_duals`, satisfy the
/// stationarity of the Lagrangian in every input (with the dynamics' multipliers solved
/// from the state equations backwards) and complementarity: a row's multiplier is
/// positive only at its upper bound, negative only at its lower.
fn assert_duals_close_the_kkt_conditions(problem: &Problem, ocp: &Ocp, case: usize) {
    let s = &problem.shape;
    let (n, nx, nu, m) = (s.horizon, s.states, s.inputs, s.rows);
    // π_N from x_N's stationarity, then π_k from x_k's: Q(x − r) + Cᵀν + π_k − Aᵀπ_{k+1} = 0.
    let mut pi_next = vec![0.0; nx];
    let mut worst = 0.0_f64;
    let scale = 1.0 + (0..=n).flat_map(|k| ocp.row_duals(k).to_vec()).fold(0.0_f64, |w, v| w.max(v.abs()));
    for k in (0..=n).rev() {
        let d = &problem.stages[k];
        let x = ocp.state(k);
        let nu_k = ocp.row_duals(k);
        for i in 0..m {
            let v = (0..nx).map(|j| d.c[i * nx + j] * x[j]).sum::<f64>()
                + if k < n { (0..nu).map(|j| d.d[i * nu + j] * ocp.input(k)[j]).sum::<f64>() } else { 0.0 };
            let slack = if nu_k[i] > 0.0 { d.upper[i] - v } else { v - d.lower[i] };
            worst = worst.max((nu_k[i].abs() * slack).abs() / scale);
        }
        if k < n {
            let u = ocp.input(k);
            for j in 0..nu {
                let r = d.r[j] * (u[j] - d.u_ref[j]) + (0..m).map(|i| d.d[i * nu + j] * nu_k[i]).sum::<f64>()
                    - (0..nx).map(|i| d.b[i * nu + j] * pi_next[i]).sum::<f64>();
                worst = worst.max(r.abs() / scale);
            }
        }
        if k == 0 {
            break;
        }
        let pi_k: Vec<f64> = (0..nx)
            .map(|i| {
                -(d.q[i] * (x[i] - d.x_ref[i]) + (0..m).map(|r| d.c[r * nx + i] * nu_k[r]).sum::<f64>()
                    - if k < n { (0..nx).map(|l| d.a[l * nx + i] * pi_next[l]).sum::<f64>() } else { 0.0 })
            })
            .collect();
        pi_next = pi_k;
    }
    assert!(worst < 1e-5, "case {case}: the KKT conditions are off by {worst:e} (relative to the largest multiplier)");
}

#[test]
fn bad_data_is_a_status_and_the_next_good_solve_is_unharmed() {
    for method in [OcpMethod::Admm, OcpMethod::InteriorPoint] {
        bad_data_then_good(method);
    }
}

fn bad_data_then_good(method: OcpMethod) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let problem = loop {
        let p = random_problem(&mut rng);
        if p.shape.horizon >= 2 && matches!(clarabel(&p), Answer::Solved(_)) {
            break p;
        }
    };
    let Answer::Solved(reference) = clarabel(&problem) else { unreachable!() };
    let mut ocp = Ocp::with_method(problem.shape.clone(), tight(), method).expect("set-up");
    stage(&mut ocp, &problem, &mut rng);
    ocp.stage_mut(1).offset[0] = f64::NAN;
    assert_eq!(ocp.solve(), QpStatus::NonFinite);
    assert!(!ocp.has_solution());
    stage(&mut ocp, &problem, &mut rng);
    ocp.stage_mut(0).q[0] = -1.0;
    assert_eq!(ocp.solve(), QpStatus::NonConvex);
    stage(&mut ocp, &problem, &mut rng);
    assert_eq!(ocp.solve(), QpStatus::Solved);
    let worst = ocp.solution().iter().zip(&reference).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(worst < 1e-4 * (1.0 + reference.iter().fold(0.0_f64, |m, v| m.max(v.abs()))));
    assert!(Ocp::new(OcpShape::dense(0, 2, 1, 0), tight()).is_err());
    let mut wrong = OcpShape::dense(2, 2, 1, 1);
    wrong.c.pop();
    assert!(Ocp::new(wrong, tight()).is_err());
}

/// A point's worst violation of the problem's rows (the initial state, dynamics, stage
/// rows) and its cost, from the problem's data alone.
fn violation_and_cost(problem: &Problem, z: &[f64]) -> (f64, f64) {
    let s = &problem.shape;
    let (n, nx, nu, m) = (s.horizon, s.states, s.inputs, s.rows);
    let stride = nx + nu;
    let (mut worst, mut cost) = (0.0_f64, 0.0);
    for i in 0..nx {
        worst = worst.max((z[i] - problem.initial[i]).abs());
    }
    for (k, d) in problem.stages.iter().enumerate() {
        let x = &z[k * stride..k * stride + nx];
        let u = if k < n { &z[k * stride + nx..(k + 1) * stride] } else { &[][..] };
        for i in 0..nx {
            cost += 0.5 * d.q[i] * (x[i] - d.x_ref[i]).powi(2);
        }
        for j in 0..u.len() {
            cost += 0.5 * d.r[j] * (u[j] - d.u_ref[j]).powi(2);
        }
        if k < n {
            for i in 0..nx {
                let next = (0..nx).map(|j| d.a[i * nx + j] * x[j]).sum::<f64>()
                    + (0..nu).map(|j| d.b[i * nu + j] * u[j]).sum::<f64>()
                    + d.offset[i];
                worst = worst.max((z[(k + 1) * stride + i] - next).abs());
            }
        }
        for i in 0..m {
            let v = (0..nx).map(|j| d.c[i * nx + j] * x[j]).sum::<f64>()
                + (0..u.len()).map(|j| d.d[i * nu + j] * u[j]).sum::<f64>();
            worst = worst.max(d.lower[i] - v).max(v - d.upper[i]);
        }
    }
    (worst, cost)
}
