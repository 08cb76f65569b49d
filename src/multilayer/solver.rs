//! What the two layers share about OSQP: a sparse matrix built once from a dense
//! description, and the solver settings (results are read by `QpStatus::of`).

use std::borrow::Cow;

use osqp::CscMatrix;


/// OSQP's infinity for `l`/`u`.
pub(crate) const INF: f64 = 1e30;

/// Column-major sparse storage of `value(r, c)` over `rows × cols`, keeping the entries
/// where `keep(r, c)` holds (the structural pattern, even where the value is 0 now).
pub(crate) struct Csc {
    pub rows: usize,
    pub cols: usize,
    pub indptr: Vec<usize>,
    pub indices: Vec<usize>,
    pub data: Vec<f64>,
}

impl Csc {
    pub fn new(
        rows: usize,
        cols: usize,
        keep: impl Fn(usize, usize) -> bool,
        value: impl Fn(usize, usize) -> f64,
    ) -> Self {
        let (mut indptr, mut indices, mut data) = (vec![0], Vec::new(), Vec::new());
        for c in 0..cols {
            for r in (0..rows).filter(|&r| keep(r, c)) {
                indices.push(r);
                data.push(value(r, c));
            }
            indptr.push(indices.len());
        }
        Self { rows, cols, indptr, indices, data }
    }

    /// A borrowed view for OSQP (no copy).
    pub fn view(&self) -> CscMatrix<'_> {
        CscMatrix {
            nrows: self.rows,
            ncols: self.cols,
            indptr: Cow::Borrowed(&self.indptr),
            indices: Cow::Borrowed(&self.indices),
            data: Cow::Borrowed(&self.data),
        }
    }
}

/// OSQP settings of one layer.
///
/// Polish is off (OSQP's allocates); ρ adapts on a fixed iteration interval so runs are
/// reproducible; warm start carries each cycle's solution into the next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerSolverSettings {
    pub eps_abs: f64,
    pub eps_rel: f64,
    pub max_iter: u32,
    /// OSQP's own Ruiz scaling iterations: right when the matrices are constant (the MPC),
    /// off (0) when they change every cycle (the CBF-QP normalises its row itself).
    pub scaling: u32,
}

impl LayerSolverSettings {
    pub(crate) fn to_osqp(self) -> osqp::Settings {
        osqp::Settings::default()
            .verbose(false)
            .polish(false)
            .scaling(if self.scaling == 0 { None } else { Some(self.scaling) })
            .warm_start(true)
            .eps_abs(self.eps_abs)
            .eps_rel(self.eps_rel)
            .max_iter(self.max_iter)
            .adaptive_rho(true)
            .adaptive_rho_interval(Some(25))
            .check_termination(Some(5))
    }
}
