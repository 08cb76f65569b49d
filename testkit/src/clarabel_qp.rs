//! Clarabel (an interior-point solver) on a dense QP: the second solver the QP tests
//! compare against.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, SupportedConeT, ZeroConeT,
};

/// A row `a · z` with its right-hand side `b`.
pub type Row = (Vec<f64>, f64);

/// What Clarabel made of a QP.
#[derive(Debug, Clone, PartialEq)]
pub enum Answer {
    /// Solved (or almost solved, Clarabel's reduced tolerances): the point.
    Solved(Vec<f64>),
    /// The rows cannot hold together.
    Infeasible,
    /// No verdict: an iteration limit, a numerical error, no progress.
    Other,
}

/// Tolerances tight enough to compare points to 1e-6 and closer.
pub fn tight_settings() -> DefaultSettings<f64> {
    DefaultSettings {
        verbose: false,
        tol_gap_abs: 1e-11,
        tol_gap_rel: 1e-11,
        tol_feas: 1e-11,
        tol_ktratio: 1e-9,
        max_iter: 400,
        ..DefaultSettings::default()
    }
}

/// `min ½ zᵀ P z + qᵀ z` over `n` variables subject to `a · z = b` for each of
/// `equalities` and `a · z ≤ b` for each of `inequalities`. `p` is `n × n`, row-major;
/// its upper triangle is read.
pub fn solve(
    n: usize,
    p: &[f64],
    q: &[f64],
    equalities: &[Row],
    inequalities: &[Row],
    settings: DefaultSettings<f64>,
) -> Answer {
    let rows: Vec<&Row> = equalities.iter().chain(inequalities).collect();
    let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::new(), Vec::new());
    for c in 0..n {
        for (r, (row, _)) in rows.iter().enumerate() {
            if row[c] != 0.0 {
                rowval.push(r);
                nzval.push(row[c]);
            }
        }
        colptr.push(rowval.len());
    }
    let a = CscMatrix::new(rows.len(), n, colptr, rowval, nzval);
    let b: Vec<f64> = rows.iter().map(|(_, b)| *b).collect();
    let (mut pcol, mut prow, mut pval) = (vec![0], Vec::new(), Vec::new());
    for c in 0..n {
        for r in 0..=c {
            if p[r * n + c] != 0.0 {
                prow.push(r);
                pval.push(p[r * n + c]);
            }
        }
        pcol.push(prow.len());
    }
    let p = CscMatrix::new(n, n, pcol, prow, pval);
    let mut cones: Vec<SupportedConeT<f64>> = Vec::new();
    if !equalities.is_empty() {
        cones.push(ZeroConeT(equalities.len()));
    }
    if !inequalities.is_empty() {
        cones.push(NonnegativeConeT(inequalities.len()));
    }
    let Ok(mut solver) = DefaultSolver::new(&p, q, &a, &b, &cones, settings) else {
        return Answer::Other;
    };
    solver.solve();
    match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => Answer::Solved(solver.solution.x.clone()),
        SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => Answer::Infeasible,
        _ => Answer::Other,
    }
}
