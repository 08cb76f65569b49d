//! What the two layers share about OSQP: a sparse matrix built once from a dense
//! description, and the solver settings (results are read by `QpStatus::of`).

use std::borrow::Cow;

use osqp::CscMatrix;

use crate::error::{within, CbfError};

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
    /// OSQP's absolute tolerance.
    pub eps_abs: f64,
    /// OSQP's relative tolerance.
    pub eps_rel: f64,
    /// OSQP's limit on ADMM iterations per solve.
    pub max_iter: u32,
    /// OSQP's own Ruiz scaling iterations: right when the matrices are constant (the MPC),
    /// off (0) when they change every cycle (the CBF-QP normalises its row itself).
    pub scaling: u32,
}

impl LayerSolverSettings {
    /// Most Ruiz scaling passes (OSQP's default is 10).
    pub const MAX_SCALING: u32 = 100;

    /// The same ranges as the filter's [`SolverSettings`](crate::filter::SolverSettings):
    /// tolerances in `[1e-12, 1e3]`, `1 ≤ max_iter ≤ MAX_ITERATIONS`, so a solve ends.
    ///
    /// # Errors
    /// A value outside those ranges, or `scaling >` [`Self::MAX_SCALING`].
    pub fn validate(&self) -> Result<(), CbfError> {
        use crate::filter::SolverSettings as S;
        within("eps_abs", self.eps_abs, S::MIN_TOLERANCE, S::MAX_TOLERANCE, "[1e-12, 1e3]")?;
        within("eps_rel", self.eps_rel, S::MIN_TOLERANCE, S::MAX_TOLERANCE, "[1e-12, 1e3]")?;
        if self.max_iter == 0 {
            return Err(CbfError::NotPositive { what: "max_iter", value: 0.0 });
        }
        if self.max_iter > S::MAX_ITERATIONS {
            return Err(CbfError::TooLarge {
                what: "max_iter",
                value: self.max_iter as usize,
                max: S::MAX_ITERATIONS as usize,
            });
        }
        if self.scaling > Self::MAX_SCALING {
            return Err(CbfError::TooLarge {
                what: "scaling",
                value: self.scaling as usize,
                max: Self::MAX_SCALING as usize,
            });
        }
        Ok(())
    }

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
