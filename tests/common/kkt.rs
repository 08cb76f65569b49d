//! Independent truths about one filter update, shared by the filter tests: the same QP
//! written out in original units and solved by Clarabel (an interior-point solver), and
//! the KKT conditions checked from the returned input and slacks alone.
#![allow(dead_code)]
// Index loops mirror the formulas (rows × inputs).
#![allow(clippy::needless_range_loop)]

use cbfgen::systems::tachyon3::catalog::Tachyon3Filter;
use cbfgen::systems::tachyon3::model::{Input, NU};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus};

/// The filter's QP rebuilt from its rows and settings in original units — cost
/// `Σ w (u − u_ref)² + Σ w_δ δ²`, rows `−(L_g L_f h · u + δ) ≤ L_f² h + k1 L_f h + k0 h`,
/// the input box — and solved by Clarabel. Returns `u`.
pub fn clarabel_reference(filter: &Tachyon3Filter, u_ref: &Input) -> Input {
    clarabel_solution(filter, u_ref).expect("clarabel must solve the reference")
}

/// [`clarabel_reference`], or `None` where Clarabel does not report the problem solved.
pub fn clarabel_solution(filter: &Tachyon3Filter, u_ref: &Input) -> Option<Input> {
    let s = filter.settings();
    let rows: Vec<(&[f64], f64, f64)> = (0..filter.rows().len())
        .filter(|&i| filter.active()[i])
        .map(|i| {
            let row = &filter.rows()[i];
            let f = s.family(filter.slot(i).family.index());
            let &[p1, p2] = f.poles.as_slice() else { panic!("two poles") };
            let b = row.lie[2] + (p1 + p2) * row.lie[1] + p1 * p2 * row.lie[0];
            (&row.lg[..], b, f.slack_weight)
        })
        .collect();
    match clarabel_soft_qp(&s.input_weights, u_ref, &s.input_min, &s.input_max, &rows) {
        Some((u, true)) => Some(std::array::from_fn(|j| u[j])),
        _ => None,
    }
}

/// Clarabel on the soft-row QP lifted to `(u, δ)`: cost `Σ w (u − r)² + Σ s δ²`, rows
/// `−(a·u + δ) ≤ b` (one per `(a, b, s)`), the box `min ≤ u ≤ max`; tolerances 1e-10,
/// far below the default 1e-8, so that the reference is tighter than the exact solves'
/// 1e-6 comparison through stiff slack weights. Its `u` and whether Clarabel reported it
/// solved (else the point it stopped at, still a feasible `u` whose cost an exact optimum
/// cannot exceed); `None` if Clarabel refused or returned a point outside the box.
pub fn clarabel_soft_qp(
    weights: &[f64],
    u_ref: &[f64],
    input_min: &[f64],
    input_max: &[f64],
    rows: &[(&[f64], f64, f64)],
) -> Option<(Vec<f64>, bool)> {
    let nu = weights.len();
    let n = nu + rows.len();
    // P = 2 diag(w, s) (upper triangular CSC of a diagonal).
    let mut p_diag: Vec<f64> = weights.iter().map(|w| 2.0 * w).collect();
    p_diag.extend(rows.iter().map(|r| 2.0 * r.2));
    let p = CscMatrix::new(n, n, (0..=n).collect(), (0..n).collect(), p_diag);
    let mut q = vec![0.0; n];
    for j in 0..nu {
        q[j] = -2.0 * weights[j] * u_ref[j];
    }
    // Dense rows, then CSC: the soft rows, then u ≤ max, then −u ≤ −min.
    let m = rows.len() + 2 * nu;
    let mut dense = vec![vec![0.0; n]; m];
    let mut b = vec![0.0; m];
    for (k, (a, bound, _)) in rows.iter().enumerate() {
        for j in 0..nu {
            dense[k][j] = -a[j];
        }
        dense[k][nu + k] = -1.0;
        b[k] = *bound;
    }
    for j in 0..nu {
        dense[rows.len() + j][j] = 1.0;
        b[rows.len() + j] = input_max[j];
        dense[rows.len() + nu + j][j] = -1.0;
        b[rows.len() + nu + j] = -input_min[j];
    }
    let (mut colptr, mut rowval, mut nzval) = (vec![0], vec![], vec![]);
    for c in 0..n {
        for (r, row) in dense.iter().enumerate() {
            if row[c] != 0.0 {
                rowval.push(r);
                nzval.push(row[c]);
            }
        }
        colptr.push(rowval.len());
    }
    let a = CscMatrix::new(m, n, colptr, rowval, nzval);
    let settings = DefaultSettings {
        verbose: false,
        tol_gap_abs: 1e-10,
        tol_gap_rel: 1e-10,
        tol_feas: 1e-10,
        tol_ktratio: 1e-8,
        max_iter: 500,
        ..DefaultSettings::default()
    };
    let mut solver = DefaultSolver::new(&p, &q, &a, &b, &[NonnegativeConeT(m)], settings).ok()?;
    solver.solve();
    let x = solver.solution.x[..nu].to_vec();
    let inside = (0..nu).all(|j| (input_min[j] - 1e-9..=input_max[j] + 1e-9).contains(&x[j]));
    (x.iter().all(|v| v.is_finite()) && inside).then_some((x, solver.solution.status == SolverStatus::Solved))
}

/// The filter's cost at `u` with every active row's slack at its optimum for that `u`
/// (`δ_i = max(0, −(a_i·u + b_i))`): `Σ w (u − u_ref)² + Σ w_δ δ²`. Convex in `u`, so a
/// `u` inside the box whose cost is no higher than another solver's is optimal too.
pub fn objective(filter: &Tachyon3Filter, u: &Input, u_ref: &Input) -> f64 {
    let s = filter.settings();
    let mut cost = (0..NU).map(|j| s.input_weights[j] * (u[j] - u_ref[j]).powi(2)).sum::<f64>();
    for (i, row) in filter.rows().iter().enumerate() {
        if filter.active()[i] {
            let f = s.family(filter.slot(i).family.index());
            let &[p1, p2] = f.poles.as_slice() else { panic!("two poles") };
            let b = row.lie[2] + (p1 + p2) * row.lie[1] + p1 * p2 * row.lie[0];
            let value = (0..NU).map(|j| row.lg[j] * u[j]).sum::<f64>() + b;
            cost += f.slack_weight * value.min(0.0).powi(2);
        }
    }
    cost
}

/// What the KKT check allows (see `kkt_violation`): ten times the default `eps_abs`.
/// OSQP stops once its residuals in the scaled problem (rows divided by their norms)
/// are below `eps_abs` 1e-4 plus `eps_rel` 1e-5 times the size of the terms.
pub const KKT_TOLERANCE: f64 = 1e-3;

/// Worst violation of the KKT conditions by the filter's `u`, `δ`, with the multipliers
/// recovered from the slacks (`λ_i = 2 w_δ δ_i`, from ∂/∂δ_i of the Lagrangian):
/// primal feasibility, `δ ≥ 0`, complementarity `δ_i (row_i) = 0`, and stationarity in
/// `u` (zero inside the box, signed at a bound). Row residuals are divided by the row's
/// norm (the scale OSQP's tolerance applies to); stationarity by the size of the input
/// terms.
pub fn kkt_violation(filter: &Tachyon3Filter, u: &Input, u_ref: &Input) -> f64 {
    let s = filter.settings();
    let delta = filter.delta();
    let mut worst: f64 = 0.0;
    let mut stationarity: [f64; NU] = std::array::from_fn(|j| s.input_weights[j] * (u[j] - u_ref[j]));
    // The size of the rows' terms in each stationarity entry: the residual is judged
    // relative to every term that enters it, rows included (stiff rows cancel).
    let mut row_terms = [0.0; NU];
    for (i, row) in filter.rows().iter().enumerate() {
        if !filter.active()[i] {
            continue;
        }
        let f = s.family(filter.slot(i).family.index());
        let &[p1, p2] = f.poles.as_slice() else { panic!("two poles") };
        let b = row.lie[2] + (p1 + p2) * row.lie[1] + p1 * p2 * row.lie[0];
        let lhs = (0..NU).map(|j| row.lg[j] * u[j]).sum::<f64>() + delta[i] + b;
        // In the row's own scale, as OSQP sees it (each row divided by its norm), and
        // relative to the terms that cancel in it (a huge b met by a huge slack).
        let magnitude = b.abs() + delta[i].abs() + (0..NU).map(|j| (row.lg[j] * u[j]).abs()).sum::<f64>();
        let size = row.lg.iter().map(|v| v * v).sum::<f64>().sqrt().max(1.0) + 1e-6 * magnitude;
        worst = worst.max(-lhs / size); // primal
        worst = worst.max(-delta[i] * f.slack_weight.sqrt()); // δ ≥ 0, in units of √w_δ δ
        if delta[i] * f.slack_weight.sqrt() > 1e-3 {
            worst = worst.max(lhs.abs() / size); // complementarity
        }
        for j in 0..NU {
            stationarity[j] -= f.slack_weight * delta[i] * row.lg[j];
            row_terms[j] += (f.slack_weight * delta[i] * row.lg[j]).abs();
        }
    }
    for j in 0..NU {
        let (lo, hi) = (s.input_min[j], s.input_max[j]);
        let size = 1.0 + s.input_weights[j] * (u[j].abs() + u_ref[j].abs());
        worst = worst.max((u[j] - hi) / size).max((lo - u[j]) / size);
        let r = stationarity[j] / (size + row_terms[j]);
        // "At a bound" to the solver's tolerance in the input's own units (a tolerance in
        // gradient units would exceed a small box and mistake one bound for the other);
        // in a box narrower than that, either bound may hold the input.
        let tol_bound = KKT_TOLERANCE * (1.0 + lo.abs().max(hi.abs()));
        let (to_hi, to_lo) = (hi - u[j], u[j] - lo);
        worst = worst.max(if hi - lo <= tol_bound {
            0.0
        } else if to_hi <= tol_bound && to_hi <= to_lo {
            r.max(0.0) // at the upper bound the cost may still pull up
        } else if to_lo <= tol_bound {
            (-r).max(0.0)
        } else {
            r.abs()
        });
    }
    worst
}
