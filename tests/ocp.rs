//! The optimal-control QP against Clarabel on the same problem written out densely, on
//! random horizons, sizes, sparsity patterns and row kinds (equalities, one- and two-sided
//! rows, unused rows); entries outside the declared pattern hold garbage that must be
//! ignored. And bad data is a status, after which the next good solve is unharmed.

// Index loops mirror the formulas.
#![allow(clippy::needless_range_loop)]

use cbfgen::qp::ocp::{Ocp, OcpShape};
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
    let (n, nx, nu, m) =
        (rng.random_range(1..=6), rng.random_range(1..=4), rng.random_range(0..=3), rng.random_range(0..=3));
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
        let a = if inner { masked(rng, &shape.a) } else { vec![] };
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
    let mut rng = ChaCha8Rng::seed_from_u64(38);
    let (mut compared, mut skipped, mut same_point) = (0, 0, 0);
    for case in 0..300 {
        let problem = random_problem(&mut rng);
        let Answer::Solved(reference) = clarabel(&problem) else {
            skipped += 1;
            continue;
        };
        let mut ocp = Ocp::new(problem.shape.clone(), tight()).expect("set-up");
        stage(&mut ocp, &problem, &mut rng);
        // Twice: the second solve runs on the updated (same) data, warm.
        for _ in 0..2 {
            let status = ocp.solve();
            assert_eq!(status, QpStatus::Solved, "case {case}: {status:?}");
            // Random rows can meet at thin angles, where a point 1e-7 outside moves the
            // cost visibly: so the verdict is feasibility and cost, and the points
            // themselves must agree on most problems.
            let (violation, cost) = violation_and_cost(&problem, ocp.solution());
            let (clarabel_violation, clarabel_cost) = violation_and_cost(&problem, &reference);
            assert!(violation < 1e-5, "case {case}: OSQP's point violates a row by {violation:e}");
            assert!(
                clarabel_violation < 1e-8,
                "case {case}: Clarabel's point violates a row by {clarabel_violation:e}"
            );
            assert!(
                cost <= clarabel_cost + 1e-5 * (1.0 + clarabel_cost.abs()),
                "case {case}: OSQP's cost {cost} is above Clarabel's {clarabel_cost}"
            );
        }
        let worst =
            ocp.solution().iter().zip(&reference).map(|(a, b)| (a - b).abs() / (1.0 + b.abs())).fold(0.0, f64::max);
        if worst < 1e-4 {
            same_point += 1;
        }
        compared += 1;
    }
    assert!(compared >= 250, "only {compared} compared ({skipped} without a Clarabel answer)");
    assert!(same_point * 100 >= compared * 95, "the points agree to 1e-4 on only {same_point} of {compared}");
}

#[test]
fn bad_data_is_a_status_and_the_next_good_solve_is_unharmed() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let problem = loop {
        let p = random_problem(&mut rng);
        if p.shape.horizon >= 2 && matches!(clarabel(&p), Answer::Solved(_)) {
            break p;
        }
    };
    let Answer::Solved(reference) = clarabel(&problem) else { unreachable!() };
    let mut ocp = Ocp::new(problem.shape.clone(), tight()).expect("set-up");
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
