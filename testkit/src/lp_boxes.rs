//! An optimisation-based box–box separation query, Table I's "LP" column: the growth
//! distance of two oriented boxes as a linear program, solved by Clarabel.
//!
//! Grow both boxes about their centres by the same factor `t` until they first share a
//! point `x`:
//!
//! ```text
//! minimise t  over (x ∈ R³, t)
//! subject to  |R_Aᵀ(x − c_A)| ≤ t·h_A  and  |R_Bᵀ(x − c_B)| ≤ t·h_B  (componentwise)
//! ```
//!
//! 12 rows, 4 variables. `t* > 1` means the boxes are apart, `t* < 1` that they overlap,
//! `t* = 1` that they touch. It is the kind of query an optimisation-based CBF solves
//! once per box pair per cycle, so [`growth_distance`] builds the problem and the solver
//! afresh on each call (Clarabel's `DefaultSolver::new` then `solve`), and the timing
//! includes that setup.

use cbfgen::OrientedBox;
use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus};

/// Clarabel's default settings without its printout: what a user would start from.
pub fn settings() -> DefaultSettings<f64> {
    DefaultSettings { verbose: false, ..DefaultSettings::default() }
}

/// The growth distance `t*` of `a` and `b` (> 1: apart, < 1: overlapping), or `None`
/// when Clarabel reports anything but solved (or almost solved, its reduced tolerances).
pub fn growth_distance(a: &OrientedBox, b: &OrientedBox, settings: DefaultSettings<f64>) -> Option<f64> {
    // Rows `±r_kᵀ x − h_k t ≤ ±r_k·c` for each box's three axes `r_k` (columns of R),
    // in Clarabel's `A z + s = b, s ≥ 0` form; assembled column by column (CSC).
    let mut rows = [[0.0; 4]; 12];
    let mut rhs = [0.0; 12];
    for (j, bx) in [a, b].into_iter().enumerate() {
        let (c, r, h) = (bx.center(), bx.rotation().matrix(), bx.half_extents());
        for k in 0..3 {
            let axis = r.column(k);
            for (s, sign) in [1.0, -1.0].into_iter().enumerate() {
                let i = 6 * j + 2 * k + s;
                rows[i] = [sign * axis.x, sign * axis.y, sign * axis.z, -h[k]];
                rhs[i] = sign * axis.dot(c);
            }
        }
    }
    let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::with_capacity(48), Vec::with_capacity(48));
    for col in 0..4 {
        for (i, row) in rows.iter().enumerate() {
            if row[col] != 0.0 {
                rowval.push(i);
                nzval.push(row[col]);
            }
        }
        colptr.push(rowval.len());
    }
    let a_mat = CscMatrix::new(12, 4, colptr, rowval, nzval);
    let p = CscMatrix::zeros((4, 4));
    let q = [0.0, 0.0, 0.0, 1.0];
    let mut solver = DefaultSolver::new(&p, &q, &a_mat, &rhs, &[NonnegativeConeT(12)], settings).ok()?;
    solver.solve();
    match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => Some(solver.solution.x[3]),
        _ => None,
    }
}
