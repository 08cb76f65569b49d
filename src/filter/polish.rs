//! Exact solution from ADMM's active set, allocation-free.
//!
//! OSQP's iterate tells which rows bind; given that set the ECBF QP is an unconstrained
//! least-squares problem in the `NU` inputs (binding rows' slacks are `δ = −(a·u + b)`),
//! plus inputs held at a box bound. One dense `NU`×`NU` Cholesky solves it. The result is
//! accepted only if it satisfies every KKT condition — feasible rows, non-negative
//! slacks, correctly signed box multipliers — so an accepted polish is the optimum, not
//! an approximation, whatever ADMM's tolerance. OSQP has a polish step of its own, but it
//! allocates and factorises a second sparse system on every solve.

use nalgebra::{SMatrix, SVector};

use crate::system::Row;

/// Which bound an input is held at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Held {
    Free,
    Lower,
    Upper,
}

/// The problem data the polish needs, in original units.
pub(crate) struct Problem<'a, const NU: usize> {
    pub weights: &'a [f64; NU],
    pub u_ref: &'a [f64; NU],
    pub input_min: &'a [f64; NU],
    pub input_max: &'a [f64; NU],
    pub rows: &'a [Row<NU>],
    pub active: &'a [bool],
    /// `b_i = L_f^r h + Σ k_i L_f^i h` per row (only read for active rows).
    pub bounds: &'a [f64],
    pub slack_weights: &'a [f64],
}

/// Relative tolerance of the KKT acceptance test: loose enough for rounding in a
/// small dense solve, far tighter than any ADMM stopping rule.
const TOLERANCE: f64 = 1e-9;

/// Active-set corrections tried after ADMM's guess before giving up.
const MAX_CORRECTIONS: usize = 6;

/// Solve from ADMM's active set guess (`binding`, `held`, corrected in place). When the
/// guess fails the KKT test, the rows and inputs that broke it swap sides — a binding
/// row whose slack came out negative is released, a violated free row binds, an input
/// past its bound is held there, a held input pulled inward is freed — and the solve is
/// repeated, a few times at most. Writes `u` and `delta` and returns `true` only for a
/// solution that satisfies every KKT condition.
pub(crate) fn polish<const NU: usize>(
    p: &Problem<'_, NU>,
    binding: &mut [bool],
    held: &mut [Held; NU],
    u: &mut [f64; NU],
    delta: &mut [f64],
) -> bool {
    for _ in 0..=MAX_CORRECTIONS {
        match solve_active_set(p, binding, held) {
            Some(x) if correct(p, &x, binding, held) == 0 => {
                // A solution whose rows do not evaluate finitely is not verified (the KKT
                // comparisons pass NaN), and its slacks would not be finite.
                let finite =
                    p.rows.iter().enumerate().all(|(i, row)| !p.active[i] || row_value(p, row, i, &x).is_finite());
                if !finite {
                    return false;
                }
                for (i, row) in p.rows.iter().enumerate() {
                    delta[i] = if p.active[i] && binding[i] { (-row_value(p, row, i, &x)).max(0.0) } else { 0.0 };
                }
                u.copy_from_slice(x.as_slice());
                return true;
            }
            Some(_) => {}
            None => return false,
        }
    }
    false
}

/// The size of the terms in each entry of the objective's gradient at `x`:
/// `input_pull_j = w_j (|x_j| + |r_j|)` plus `Σ w_δ |a_i·x + b_i| |a_ij|` over binding rows
/// (never 0). An
/// entry's rounding error is a small multiple of ε times this, so a multiplier's sign is
/// judged against it; a stiff row far from input `j` does not loosen input `j`'s test.
fn gradient_scale<const NU: usize>(
    p: &Problem<'_, NU>,
    x: &SVector<f64, NU>,
    binding: &[bool],
    input_pull: &[f64; NU],
) -> [f64; NU] {
    let mut scale = *input_pull;
    for (i, row) in p.rows.iter().enumerate() {
        if p.active[i] && binding[i] {
            let pull = p.slack_weights[i] * row_value(p, row, i, x).abs();
            for (s, a) in scale.iter_mut().zip(&row.lg) {
                *s += pull * a.abs();
            }
        }
    }
    scale.map(|s| s.max(f64::MIN_POSITIVE))
}

/// `a·u + b` of row `i`: ≥ 0 when the row holds without slack.
fn row_value<const NU: usize>(p: &Problem<'_, NU>, row: &Row<NU>, i: usize, x: &SVector<f64, NU>) -> f64 {
    (0..NU).map(|j| row.lg[j] * x[j]).sum::<f64>() + p.bounds[i]
}

/// The optimum for a fixed active set, or `None` if the system is singular or not finite.
fn solve_active_set<const NU: usize>(
    p: &Problem<'_, NU>,
    binding: &[bool],
    held: &[Held; NU],
) -> Option<SVector<f64, NU>> {
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
    let x = h.cholesky()?.solve(&g);
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Check the KKT conditions at `x` (stationarity holds by construction) and move every
/// row and input that breaks one to the other side. Returns how many moved.
fn correct<const NU: usize>(
    p: &Problem<'_, NU>,
    x: &SVector<f64, NU>,
    binding: &mut [bool],
    held: &mut [Held; NU],
) -> usize {
    let mut moved = 0;
    // Gradient of the objective with the binding rows' slacks eliminated; on a held
    // input it is minus that bound's multiplier.
    let mut gradient = SVector::<f64, NU>::zeros();
    for j in 0..NU {
        gradient[j] = p.weights[j] * (x[j] - p.u_ref[j]);
    }
    for (i, row) in p.rows.iter().enumerate() {
        if p.active[i] && binding[i] {
            let a = SVector::<f64, NU>::from_row_slice(&row.lg);
            gradient.axpy(p.slack_weights[i] * row_value(p, row, i, x), &a, 1.0);
        }
    }
    // Each test in its own units, so that no weight's size makes it loose: bounds in the
    // input's units, multipliers relative to the largest term of the gradient (an
    // absolute floor there would accept any active set once every weight is small).
    // The cost's own pull on each input, `w_j (|x_j| + |r_j|)`; its largest entry also
    // scales the binding rows' multiplier test below.
    let input_pull: [f64; NU] = std::array::from_fn(|j| p.weights[j] * (x[j].abs() + p.u_ref[j].abs()));
    let input_gradient_scale = input_pull.iter().copied().fold(f64::MIN_POSITIVE, f64::max);
    let gradient_scale = gradient_scale(p, x, binding, &input_pull);
    for j in 0..NU {
        let input_scale = 1.0 + x[j].abs() + p.input_min[j].abs().max(p.input_max[j].abs());
        let (tol_u, tol_g) = (TOLERANCE * input_scale, TOLERANCE * gradient_scale[j]);
        let next = match held[j] {
            Held::Free if x[j] > p.input_max[j] + tol_u => Held::Upper,
            Held::Free if x[j] < p.input_min[j] - tol_u => Held::Lower,
            Held::Upper if gradient[j] > tol_g => Held::Free,
            Held::Lower if gradient[j] < -tol_g => Held::Free,
            same => same,
        };
        moved += usize::from(next != held[j]);
        held[j] = next;
    }
    for (i, row) in p.rows.iter().enumerate() {
        if !p.active[i] {
            continue;
        }
        let value = row_value(p, row, i, x);
        let scale = 1.0 + p.bounds[i].abs() + row.lg.iter().zip(x.iter()).map(|(a, v)| (a * v).abs()).sum::<f64>();
        // A free row must hold on its own (row units). A binding row's multiplier
        // 2 w_δ δ = −2 w_δ value must be ≥ 0, judged in gradient units: a stiff row
        // (large w_δ ‖a‖) turns a value within row rounding into a multiplier of the
        // wrong sign large enough to move the optimum, so its tolerance shrinks with
        // w_δ ‖a‖∞ (never looser than the row-unit one).
        let flip = if binding[i] {
            let stiffness = p.slack_weights[i] * row.lg.iter().fold(0.0, |m: f64, a| m.max(a.abs()));
            let tol = (TOLERANCE * scale).min(TOLERANCE * input_gradient_scale / stiffness.max(f64::MIN_POSITIVE));
            value > tol
        } else {
            value < -TOLERANCE * scale
        };
        if flip {
            binding[i] = !binding[i];
            moved += 1;
        }
    }
    moved
}
