//! Composed rows: what generated pair rows are assembled with.
//!
//! A family declared `compose=True` in its spec builds each row h(x) = φ(y_A(x), y_B(x))
//! from *pose kernels* (a box's pose y and its Lie derivatives, shared by every row that
//! places the box the same way) and one *chain kernel* per family (φ and its Lie
//! derivatives in the poses). The chain rule's input part, L_g L_f^(r-1) h =
//! ∇φ · L_g L_f^(r-1) y, is the contraction below (`symbolic/codegen/composition.py`
//! derives the rest).
//!
//! Generic over the [`Scalar`] like the kernels they join: `f64` in the filter, intervals
//! in the sampled-data certificate.

use crate::ops::OpCount;
use crate::scalar::Scalar;

/// Adds `Σ_i grad[i] · lg[i][j]` to `out[at[j]]` for every input column `j` of one pose
/// kernel: `grad` is the chain kernel's gradient in that pose, `lg` the pose kernel's
/// L_g L_f^(r-1) y and `at` where its columns sit among the row's. An `at` entry past
/// `out` is skipped (generated code never has one).
#[inline]
pub fn accumulate_columns<S: Scalar, const N: usize, const J: usize, const C: usize>(
    grad: &[S; N],
    lg: &[[S; J]; N],
    at: &[usize; J],
    out: &mut [S; C],
) {
    for (&g, row) in grad.iter().zip(lg) {
        for (&column, &v) in at.iter().zip(row) {
            if let Some(o) = out.get_mut(column) {
                *o = *o + g * v;
            }
        }
    }
}

/// What one [`accumulate_columns`] performs: a multiply-add per gradient entry (`n`) and
/// input column (`columns`). Generated `evaluation_ops` add it to a composed row's chain.
pub const fn accumulate_columns_ops(n: usize, columns: usize) -> OpCount {
    let pairs = (n * columns) as u64;
    OpCount { add: pairs, mul: pairs, ..OpCount::ZERO }
}

/// The rows of `m` one after the other: a frame's input columns as the kernel of the
/// next node along the kinematic tree reads them. `N` must be `R * C` (checked when it
/// compiles).
#[inline]
pub fn flatten<T: Copy, const R: usize, const C: usize, const N: usize>(m: &[[T; C]; R]) -> [T; N] {
    const { assert!(R * C == N, "flatten: N must be R * C") };
    std::array::from_fn(|k| m[k / C][k % C])
}

/// Where a body sits in a frame it is fixed in: generated as one named constant per body,
/// read by every pose function that places it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// The body's origin, in the frame's axes \[m\].
    pub offset: [f64; 3],
    /// The body's axes, row by row: column j is the body's axis j in the frame.
    pub axes: [f64; 9],
}

/// The pose of a body at `placement` in a frame, from the frame's pose y = (p, R)
/// (centre, then rotation row by row): (p + R offset, R axes). Linear in y, so a jet's
/// derivatives and input columns are carried by the same map.
#[inline]
pub fn place_pose<S: Scalar>(frame: &[S; 12], placement: &Placement) -> [S; 12] {
    let Placement { offset, axes } = placement;
    let (offset, axes) = (offset.map(S::from), axes.map(S::from));
    let mut out = frame.to_owned();
    for i in 0..3 {
        let row = &frame[3 + 3 * i..6 + 3 * i];
        out[i] = frame[i] + row[0] * offset[0] + row[1] * offset[1] + row[2] * offset[2];
        for j in 0..3 {
            out[3 + 3 * i + j] = row[0] * axes[j] + row[1] * axes[3 + j] + row[2] * axes[6 + j];
        }
    }
    out
}

/// What one [`place_pose`] performs: for each of the 3 centre entries 3 multiply-adds,
/// for each of the 9 rotation entries a 3-term dot product (the placement's numbers are
/// constants, free).
pub const PLACE_POSE_OPS: OpCount = OpCount { add: 3 * 3 + 9 * 2, mul: 3 * 3 + 9 * 3, ..OpCount::ZERO };

/// What one [`place_jet`] performs on a jet of `rates` drift-derivative entries (12 per
/// derivative) and `columns` input columns: [`place_pose`] on the pose, on each derivative
/// block and on each column.
pub const fn place_jet_ops(rates: usize, columns: usize) -> OpCount {
    PLACE_POSE_OPS.times((1 + rates / 12 + columns) as u64)
}

/// [`place_pose`] for a whole jet: the frame's pose, its drift derivatives (`L` entries,
/// 12 per derivative) and its input columns (12 rows of `C`), each carried to the body.
#[inline]
#[allow(clippy::type_complexity)]
pub fn place_jet<S: Scalar, const L: usize, const C: usize>(
    frame: &([S; 12], [S; L], [[S; C]; 12]),
    placement: &Placement,
) -> ([S; 12], [S; L], [[S; C]; 12]) {
    let mut rates = frame.1;
    for (out, block) in rates.chunks_exact_mut(12).zip(frame.1.chunks_exact(12)) {
        let y: [S; 12] = std::array::from_fn(|i| block[i]);
        out.copy_from_slice(&place_pose(&y, placement));
    }
    let mut lg = frame.2;
    for c in 0..C {
        let column = place_pose(&std::array::from_fn(|i| frame.2[i][c]), placement);
        for (row, v) in lg.iter_mut().zip(column) {
            row[c] = v;
        }
    }
    (place_pose(&frame.0, placement), rates, lg)
}

#[cfg(test)]
mod tests {
    use super::{
        accumulate_columns, accumulate_columns_ops, flatten, place_jet, place_jet_ops, place_pose, Placement,
        PLACE_POSE_OPS,
    };
    use crate::ops::Counted;

    #[test]
    fn places_a_body_by_hand() {
        // Frame at (1, 2, 3) turned 90 degrees about z; body 0.5 along the frame's x, its
        // axes the frame's turned 90 degrees about x.
        let frame = [1.0, 2.0, 3.0, 0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        let placement = Placement { offset: [0.5, 0.0, 0.0], axes: [1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0] };
        let body = place_pose(&frame, &placement);
        // Centre: (1, 2, 3) + 0.5 * (frame x = world y). Rotation: Rz(90) Rx(90).
        let expected = [1.0, 2.5, 3.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        assert_eq!(body, expected);
        // The jet's derivative blocks and columns are carried linearly: no centre offset.
        let (pose, rates, lg) = place_jet(&(frame, frame, [[1.0]; 12]), &placement);
        assert_eq!((pose, rates), (expected, expected));
        let ones = place_pose(&[1.0; 12], &placement);
        assert_eq!(lg.map(|row| row[0]), ones);
    }

    #[test]
    fn flattens_row_by_row() {
        let m = [[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]];
        assert_eq!(flatten::<_, 3, 2, 6>(&m), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    }

    #[test]
    fn contracts_a_gradient_with_scattered_columns() {
        // grad . lg by hand: column 0 of lg lands at out[2], column 1 at out[0].
        let grad = [2.0, -1.0, 0.5];
        let lg = [[1.0, 3.0], [4.0, -2.0], [6.0, 8.0]];
        let mut out = [10.0, 0.0, 0.0];
        accumulate_columns(&grad, &lg, &[2, 0], &mut out);
        assert_eq!(out, [10.0 + 6.0 + 2.0 + 4.0, 0.0, 2.0 - 4.0 + 3.0]);
    }

    #[test]
    fn the_stated_operations_are_what_the_functions_perform() {
        // Run on numbers that count, against the constants the generated evaluation_ops sum.
        let placement = Placement { offset: [0.1, -0.2, 0.3], axes: [0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0] };
        let frame: [Counted; 12] = std::array::from_fn(|i| Counted(0.1 * i as f64));
        let (_, pose) = Counted::measure(|| place_pose(&frame, &placement));
        assert_eq!(pose, PLACE_POSE_OPS);
        let jet = (frame, [Counted(0.5); 36], [[Counted(-1.0); 4]; 12]);
        let (_, placed) = Counted::measure(|| place_jet::<_, 36, 4>(&jet, &placement));
        assert_eq!(placed, place_jet_ops(36, 4));
        let (grad, lg) = ([Counted(2.0); 12], [[Counted(3.0); 5]; 12]);
        let mut out = [Counted(0.0); 7];
        let ((), accumulated) = Counted::measure(|| accumulate_columns(&grad, &lg, &[6, 0, 2, 3, 1], &mut out));
        assert_eq!(accumulated, accumulate_columns_ops(12, 5));
    }
}
