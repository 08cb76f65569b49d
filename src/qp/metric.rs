//! The metric of the filter's cost, and the scaled inputs every solver works in.
//!
//! The filter minimises `½ (u − c)ᵀ P (u − c)` over what its rows and the input box allow.
//! With `P = L Lᵀ` (Cholesky), the scaled inputs `z = Lᵀ u` make that `½ ‖z − Lᵀ c‖²`:
//! the cost matrix is the identity whatever `P` is, a row `a·u` reads `(L⁻¹ a)·z`, and the
//! box `min ≤ u ≤ max` reads as the rows of `L⁻ᵀ`. Input weights are the diagonal case,
//! `L = diag √w`, where the box stays a box (`√w_j min_j ≤ z_j ≤ √w_j max_j`) and every
//! map is one multiplication per input.
//!
//! A spec's objective `½ uᵀ P(x) u + q(x)ᵀ u` ([`Objective`](crate::system::Objective)) is
//! taken about the nominal input: `½ (u − u_ref)ᵀ P (u − u_ref) + qᵀ u`, which over any set
//! has the minimiser of the metric `P` about the centre `c = u_ref − P⁻¹ q`
//! ([`InputMetric::objective`]). `P` is divided by its largest diagonal entry first (the
//! minimiser does not change), so the solvers' tolerances see the same scale whatever
//! units the spec writes its cost in; it is refused when a Cholesky pivot falls below
//! [`MIN_PIVOT`] of that entry.

// Index loops mirror the triangular formulas.
#![allow(clippy::needless_range_loop)]
use crate::error::CbfError;

/// Smallest Cholesky pivot accepted, relative to the cost matrix's largest diagonal entry:
/// the spread input weights may have (`[1e-3, 1e3]`) squared. Below it the factor's own
/// rounding, amplified by the inverse, reaches the solvers' tolerances.
pub const MIN_PIVOT: f64 = 1e-6;

/// Most an objective may move the cost's centre away from the nominal input, per input
/// (the nominal input's own domain, [`MAX_INPUT`](crate::filter::domain::MAX_INPUT)).
const MAX_CENTRE: f64 = 1e6;

/// `P = L Lᵀ` and what the solvers need of it (module docs). Plain data, sized in the type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputMetric<const NU: usize> {
    diagonal: bool,
    /// `Lᵀ`, upper triangular.
    upper: [[f64; NU]; NU],
    /// `L⁻ᵀ`, upper triangular.
    inverse: [[f64; NU]; NU],
}

impl<const NU: usize> InputMetric<NU> {
    /// The diagonal metric of input weights `w_j > 0` (checked by the caller):
    /// `Σ_j w_j (u_j − c_j)²`.
    pub fn from_weights(weights: &[f64; NU]) -> Self {
        let mut metric = Self { diagonal: true, upper: [[0.0; NU]; NU], inverse: [[0.0; NU]; NU] };
        for j in 0..NU {
            metric.upper[j][j] = weights[j].sqrt();
            metric.inverse[j][j] = 1.0 / metric.upper[j][j];
        }
        metric
    }

    /// The metric of a spec's objective `½ uᵀ P u + qᵀ u` about the nominal input `u_ref`,
    /// and its centre `c = u_ref − P⁻¹ q` (module docs). Allocation-free.
    ///
    /// # Errors
    /// [`CbfError::NotPositiveDefinite`] for a `P` that is not finite, not symmetric (to
    /// 1e-9 of its largest diagonal entry) or not positive definite with every pivot at
    /// least [`MIN_PIVOT`]; [`CbfError::NonFinite`] for a `q` that is not finite;
    /// [`CbfError::OutOfRange`] for a centre beyond ±1e6 (a `q` that asks for an input no
    /// box holds).
    pub fn objective(p: &[[f64; NU]; NU], q: &[f64; NU], u_ref: &[f64; NU]) -> Result<(Self, [f64; NU]), CbfError> {
        const WHAT: &str = "the objective's P(x)";
        let not_symmetric =
            |index| CbfError::NotPositiveDefinite { what: WHAT, index, value: f64::NAN, required: MIN_PIVOT };
        let scale = (0..NU).map(|j| p[j][j]).fold(0.0, f64::max);
        if !(scale > 0.0 && scale.is_finite()) {
            return Err(CbfError::NotPositiveDefinite { what: WHAT, index: 0, value: scale, required: MIN_PIVOT });
        }
        for i in 0..NU {
            for j in 0..NU {
                if !p[i][j].is_finite() || (p[i][j] - p[j][i]).abs() > 1e-9 * scale {
                    return Err(not_symmetric(i));
                }
            }
        }
        for &v in q {
            crate::error::finite("the objective's q(x)", v)?;
        }
        // Cholesky of P / scale, upper factor U = Lᵀ, from the upper triangle.
        let mut metric = Self { diagonal: false, upper: [[0.0; NU]; NU], inverse: [[0.0; NU]; NU] };
        let u = &mut metric.upper;
        for j in 0..NU {
            let pivot = p[j][j] / scale - (0..j).map(|k| u[k][j] * u[k][j]).sum::<f64>();
            if pivot.is_nan() || pivot < MIN_PIVOT {
                return Err(CbfError::NotPositiveDefinite { what: WHAT, index: j, value: pivot, required: MIN_PIVOT });
            }
            u[j][j] = pivot.sqrt();
            for i in j + 1..NU {
                u[j][i] = (p[j][i] / scale - (0..j).map(|k| u[k][j] * u[k][i]).sum::<f64>()) / u[j][j];
            }
        }
        // V = U⁻¹ (upper), column by column, by back substitution.
        for j in 0..NU {
            metric.inverse[j][j] = 1.0 / metric.upper[j][j];
            for i in (0..j).rev() {
                let sum: f64 = (i + 1..=j).map(|k| metric.upper[i][k] * metric.inverse[k][j]).sum();
                metric.inverse[i][j] = -sum / metric.upper[i][i];
            }
        }
        let scaled_q = q.map(|v| v / scale);
        let pull = metric.unscaled(&metric.scaled_row(&scaled_q)); // P⁻¹ q
        let centre: [f64; NU] = std::array::from_fn(|j| u_ref[j] - pull[j]);
        for &c in &centre {
            if c.is_nan() || c.abs() > MAX_CENTRE {
                return Err(CbfError::OutOfRange {
                    what: "the objective's unconstrained minimiser u_ref - P(x)^-1 q(x)",
                    value: c,
                    range: "[-1e6, 1e6]",
                });
            }
        }
        Ok((metric, centre))
    }

    /// Whether `P` is diagonal (input weights): the box is then a box in `z`.
    pub fn is_diagonal(&self) -> bool {
        self.diagonal
    }

    /// `z = Lᵀ u`.
    pub fn scaled(&self, u: &[f64; NU]) -> [f64; NU] {
        if self.diagonal {
            return std::array::from_fn(|i| self.upper[i][i] * u[i]);
        }
        std::array::from_fn(|i| (i..NU).map(|k| self.upper[i][k] * u[k]).sum())
    }

    /// `u = L⁻ᵀ z` (the first `NU` entries of `z`).
    pub fn unscaled(&self, z: &[f64]) -> [f64; NU] {
        if self.diagonal {
            return std::array::from_fn(|i| z[i] / self.upper[i][i]);
        }
        std::array::from_fn(|i| (i..NU).map(|k| self.inverse[i][k] * z[k]).sum())
    }

    /// A row `a·u` in the scaled inputs: `L⁻¹ a`.
    pub fn scaled_row(&self, a: &[f64; NU]) -> [f64; NU] {
        if self.diagonal {
            return std::array::from_fn(|i| a[i] / self.upper[i][i]);
        }
        std::array::from_fn(|i| (0..=i).map(|k| self.inverse[k][i] * a[k]).sum())
    }

    /// Input `j` in the scaled inputs, `u_j = (L⁻ᵀ)_j · z`: the box row of a metric that is
    /// not diagonal.
    pub fn box_row(&self, j: usize) -> &[f64; NU] {
        &self.inverse[j]
    }

    /// The cost matrix `L Lᵀ` (for a spec's objective, `P` scaled to a largest diagonal
    /// entry of 1; for weights, `diag w`).
    pub fn matrix(&self) -> [[f64; NU]; NU] {
        std::array::from_fn(|i| {
            std::array::from_fn(|j| (0..=i.min(j)).map(|k| self.upper[k][i] * self.upper[k][j]).sum())
        })
    }

    /// `√P_jj` of a diagonal metric (`√w_j`); of any metric, `(Lᵀ)_jj`.
    pub fn root_weight(&self, j: usize) -> f64 {
        self.upper[j][j]
    }

    /// A bound on `|Lᵀ v|` entry by entry, for `v ≥ 0` entry by entry: `|Lᵀ| v`, what the
    /// solvers' scale-aware tolerances measure a size with.
    pub fn scaled_size(&self, v: &[f64; NU]) -> [f64; NU] {
        if self.diagonal {
            return std::array::from_fn(|i| self.upper[i][i] * v[i]);
        }
        std::array::from_fn(|i| (i..NU).map(|k| self.upper[i][k].abs() * v[k]).sum())
    }

    /// `‖L⁻¹ a‖ = (aᵀ P⁻¹ a)^{1/2}`, without overflow for any finite row.
    pub fn row_norm(&self, a: &[f64; NU]) -> f64 {
        let scaled = self.scaled_row(a);
        let largest = scaled.iter().map(|v| v.abs()).fold(0.0, f64::max);
        if largest == 0.0 || !largest.is_finite() {
            return largest;
        }
        largest * scaled.iter().map(|v| (v / largest).powi(2)).sum::<f64>().sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_close(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() <= tol * (1.0 + a.abs().max(b.abs())), "{a} vs {b}");
    }

    #[test]
    fn the_factor_reproduces_a_hand_factored_matrix_and_its_maps_invert_each_other() {
        // P = L Lᵀ with L = [[2, 0, 0], [1, 3, 0], [-1, 0.5, 1]] (chosen, then multiplied by hand).
        let p = [[4.0, 2.0, -2.0], [2.0, 10.0, 0.5], [-2.0, 0.5, 2.25]];
        let (m, centre) = InputMetric::objective(&p, &[0.0; 3], &[1.0, 2.0, 3.0]).unwrap();
        assert_eq!(centre, [1.0, 2.0, 3.0]);
        // Scaled by the largest diagonal entry, 10: Lᵀ/√10.
        let lt = [[2.0, 1.0, -1.0], [0.0, 3.0, 0.5], [0.0, 0.0, 1.0]];
        for i in 0..3 {
            for j in 0..3 {
                assert_close(m.upper[i][j], lt[i][j] / 10f64.sqrt(), 1e-14);
            }
        }
        let u = [0.3, -1.2, 2.5];
        let z = m.scaled(&u);
        let back = m.unscaled(&z);
        for j in 0..3 {
            assert_close(back[j], u[j], 1e-14);
        }
        // a·u = (L⁻¹a)·z, and ‖L⁻¹ a‖² = aᵀ (P/10)⁻¹ a.
        let a = [1.5, -0.5, 2.0];
        let az = m.scaled_row(&a);
        assert_close((0..3).map(|j| a[j] * u[j]).sum(), (0..3).map(|j| az[j] * z[j]).sum(), 1e-14);
        let x = m.unscaled(&m.scaled_row(&a)); // (P/10)⁻¹ a
        let ax: f64 = (0..3).map(|j| (0..3).map(|k| p[j][k] / 10.0 * x[k]).sum::<f64>() - a[j]).map(f64::abs).sum();
        assert!(ax < 1e-13, "P x = a off by {ax}");
        assert_close(m.row_norm(&a).powi(2), (0..3).map(|j| a[j] * x[j]).sum(), 1e-13);
        // Box row j gives u_j from z.
        for j in 0..3 {
            assert_close((0..3).map(|k| m.box_row(j)[k] * z[k]).sum(), u[j], 1e-14);
        }
    }

    #[test]
    fn the_centre_is_the_unconstrained_minimiser_of_the_objective() {
        // ½ (u − r)ᵀ P (u − r) + qᵀ u is minimal where P (u − r) + q = 0.
        let p = [[2.0, 0.5], [0.5, 1.0]];
        let (q, r) = ([1.0, -3.0], [0.5, 0.25]);
        let (_, c) = InputMetric::objective(&p, &q, &r).unwrap();
        for j in 0..2 {
            let gradient = p[j][0] * (c[0] - r[0]) + p[j][1] * (c[1] - r[1]) + q[j];
            assert!(gradient.abs() < 1e-14, "{gradient}");
        }
    }

    #[test]
    fn weights_are_the_diagonal_metric() {
        let m = InputMetric::from_weights(&[4.0, 0.25]);
        assert!(m.is_diagonal());
        assert_eq!(m.scaled(&[1.0, 1.0]), [2.0, 0.5]);
        assert_eq!(m.scaled_row(&[1.0, 1.0]), [0.5, 2.0]);
        assert_eq!(m.unscaled(&[2.0, 0.5]), [1.0, 1.0]);
        assert_close(m.row_norm(&[1.0, 1.0]), (0.25f64 + 4.0).sqrt(), 1e-15);
    }

    #[test]
    fn indefinite_asymmetric_non_finite_and_runaway_objectives_are_refused() {
        let refused = |p: [[f64; 2]; 2], q: [f64; 2]| InputMetric::objective(&p, &q, &[0.0; 2]).unwrap_err();
        // Eigenvalues 3 and −1: the second pivot is 1 − 4 = −3 (of the largest diagonal, 1).
        match refused([[1.0, 2.0], [2.0, 1.0]], [0.0; 2]) {
            CbfError::NotPositiveDefinite { index: 1, value, .. } => assert_close(value, -3.0, 1e-15),
            other => panic!("{other}"),
        }
        // Positive semidefinite is not enough: a pivot of exactly 0.
        assert!(matches!(refused([[1.0, 1.0], [1.0, 1.0]], [0.0; 2]), CbfError::NotPositiveDefinite { index: 1, .. }));
        // Definite, but a pivot of 1e-8 of the diagonal.
        assert!(matches!(refused([[1.0, 0.0], [0.0, 1e-8]], [0.0; 2]), CbfError::NotPositiveDefinite { .. }));
        assert!(matches!(refused([[0.0, 0.0], [0.0, -1.0]], [0.0; 2]), CbfError::NotPositiveDefinite { index: 0, .. }));
        assert!(matches!(refused([[1.0, 0.5], [0.4, 1.0]], [0.0; 2]), CbfError::NotPositiveDefinite { .. }));
        assert!(matches!(refused([[1.0, f64::NAN], [0.0, 1.0]], [0.0; 2]), CbfError::NotPositiveDefinite { .. }));
        assert!(matches!(refused([[1.0, 0.0], [0.0, 1.0]], [f64::INFINITY, 0.0]), CbfError::NonFinite { .. }));
        assert!(matches!(refused([[1.0, 0.0], [0.0, 1.0]], [-1e7, 0.0]), CbfError::OutOfRange { .. }));
        let message = refused([[1.0, 2.0], [2.0, 1.0]], [0.0; 2]).to_string();
        assert!(message.contains("P(x)") && message.contains("pivot 1"), "{message}");
    }
}
