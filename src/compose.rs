//! Composed rows: what generated pair rows are assembled with.
//!
//! A family declared `compose=True` in its spec builds each row h(x) = φ(y_A(x), y_B(x))
//! from *pose kernels* (a box's pose y and its Lie derivatives, shared by every row that
//! places the box the same way) and one *chain kernel* per family (φ and its Lie
//! derivatives in the poses). The chain rule's input part, L_g L_f^(r-1) h =
//! ∇φ · L_g L_f^(r-1) y, is the contraction below (`symbolic/codegen/composition.py`
//! derives the rest).

/// Adds `Σ_i grad[i] · lg[i][j]` to `out[at[j]]` for every input column `j` of one pose
/// kernel: `grad` is the chain kernel's gradient in that pose, `lg` the pose kernel's
/// L_g L_f^(r-1) y and `at` where its columns sit among the row's. An `at` entry past
/// `out` is skipped (generated code never has one).
#[inline]
pub fn accumulate_columns<const N: usize, const J: usize, const C: usize>(
    grad: &[f64; N],
    lg: &[[f64; J]; N],
    at: &[usize; J],
    out: &mut [f64; C],
) {
    for (g, row) in grad.iter().zip(lg) {
        for (&column, v) in at.iter().zip(row) {
            if let Some(o) = out.get_mut(column) {
                *o += g * v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::accumulate_columns;

    #[test]
    fn contracts_a_gradient_with_scattered_columns() {
        // grad . lg by hand: column 0 of lg lands at out[2], column 1 at out[0].
        let grad = [2.0, -1.0, 0.5];
        let lg = [[1.0, 3.0], [4.0, -2.0], [6.0, 8.0]];
        let mut out = [10.0, 0.0, 0.0];
        accumulate_columns(&grad, &lg, &[2, 0], &mut out);
        assert_eq!(out, [10.0 + 6.0 + 2.0 + 4.0, 0.0, 2.0 - 4.0 + 3.0]);
    }
}
