//! Exact solution from ADMM's active set, allocation-free.
//!
//! OSQP's iterate tells which rows bind; given that set the ECBF QP is an unconstrained
//! least-squares problem in the 17 inputs (binding rows' slacks are `δ = −(a·u + b)`),
//! plus inputs held at a box bound. One dense 17×17 Cholesky solves it. The result is
//! accepted only if it satisfies every KKT condition — feasible rows, non-negative
//! slacks, correctly signed box multipliers — so an accepted polish is the optimum, not
//! an approximation, whatever ADMM's tolerance. OSQP has a polish step of its own, but it
//! allocates and factorises a second sparse system on every solve.

use nalgebra::{SMatrix, SVector};

use crate::catalog::Row;
use crate::model::{Input, NU};

/// Which bound an input is held at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Held {
    Free,
    Lower,
    Upper,
}

/// The problem data the polish needs, in original units.
pub(crate) struct Problem<'a> {
    pub weights: &'a [f64; NU],
    pub u_ref: &'a Input,
    pub input_min: &'a Input,
    pub input_max: &'a Input,
    pub rows: &'a [Row],
    pub active: &'a [bool],
    /// `b_i = L_f² h + k1 L_f h + k0 h` per row (only read for active rows).
    pub bounds: &'a [f64],
    pub slack_weights: &'a [f64],
}

/// Relative tolerance of the KKT acceptance test: loose enough for rounding in a
/// 17×17 solve, far tighter than any ADMM stopping rule.
const TOLERANCE: f64 = 1e-9;

/// Solve with rows `binding[i]` held as equalities and inputs held as `held`. Writes
/// `u` and `delta` and returns `true` only if the result satisfies the KKT conditions.
pub(crate) fn polish(p: &Problem<'_>, binding: &[bool], held: &[Held; NU], u: &mut Input, delta: &mut [f64]) -> bool {
    // H u = g with H = W + Σ w_δ a aᵀ, g = W u_ref − Σ w_δ b a over binding rows.
    let mut h = SMatrix::<f64, NU, NU>::zeros();
    let mut g = SVector::<f64, NU>::zeros();
    for j in 0..NU {
        h[(j, j)] = p.weights[j];
        g[j] = p.weights[j] * p.u_ref[j];
    }
    for (i, row) in p.rows.iter().enumerate() {
        if !(p.active[i] && binding[i]) {
            continue;
        }
        let w = p.slack_weights[i];
        let a = SVector::<f64, NU>::from_row_slice(&row.lg);
        h.ger(w, &a, &a, 1.0);
        g.axpy(-w * p.bounds[i], &a, 1.0);
    }
    let full_h = h;
    let full_g = g;
    // Held inputs: fix them at their bound and move their columns to the right side.
    for j in 0..NU {
        let value = match held[j] {
            Held::Free => continue,
            Held::Lower => p.input_min[j],
            Held::Upper => p.input_max[j],
        };
        for k in 0..NU {
            g[k] -= h[(k, j)] * value;
            h[(k, j)] = 0.0;
            h[(j, k)] = 0.0;
        }
        h[(j, j)] = 1.0;
        g[j] = value;
    }
    let Some(chol) = h.cholesky() else { return false };
    let x = chol.solve(&g);
    if !x.iter().all(|v| v.is_finite()) {
        return false;
    }

    // KKT: stationarity holds by construction; check the rest.
    let residual = full_h * x - full_g; // = −(box multipliers) on held inputs
    for j in 0..NU {
        let scale = 1.0 + full_g[j].abs() + (full_h[(j, j)] * x[j]).abs();
        let ok = match held[j] {
            Held::Free => x[j] >= p.input_min[j] - TOLERANCE * scale && x[j] <= p.input_max[j] + TOLERANCE * scale,
            Held::Upper => residual[j] <= TOLERANCE * scale,
            Held::Lower => residual[j] >= -TOLERANCE * scale,
        };
        if !ok {
            return false;
        }
    }
    let row_value = |row: &Row, i: usize| (0..NU).map(|j| row.lg[j] * x[j]).sum::<f64>() + p.bounds[i];
    for (i, row) in p.rows.iter().enumerate() {
        if !p.active[i] {
            continue;
        }
        let value = row_value(row, i);
        let scale = 1.0 + p.bounds[i].abs() + row.lg.iter().zip(x.iter()).map(|(a, v)| (a * v).abs()).sum::<f64>();
        // Binding rows: the slack −value must be ≥ 0 (its multiplier is 2 w_δ δ).
        // Others must hold on their own.
        let ok = if binding[i] { value <= TOLERANCE * scale } else { value >= -TOLERANCE * scale };
        if !ok {
            return false;
        }
    }
    for (i, row) in p.rows.iter().enumerate() {
        delta[i] = if p.active[i] && binding[i] { (-row_value(row, i)).max(0.0) } else { 0.0 };
    }
    for j in 0..NU {
        u[j] = x[j];
    }
    true
}
