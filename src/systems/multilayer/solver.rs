//! What the two layers share about OSQP: a sparse matrix built once from a dense
//! description (settings are the crate's [`SolverSettings`](crate::filter::SolverSettings),
//! results are read by `QpStatus::of`).

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
