//! The ECBF quadratic program: solved exactly in input space ([`crate::qp::input_space`]),
//! with OSQP as the fallback and the reference backend ([`Solver`]).
//!
//! ```text
//! minimise   Σ_j w_j (u_j − u_ref,j)² + Σ_i w_δ,i δ_i²
//! subject to L_g L_f^{r−1} h_i · u + δ_i ≥ −(L_f^r h_i + Σ_k k_{i,k} L_f^k h_i)   (active rows)
//!            u_min ≤ u ≤ u_max
//! ```
//!
//! The dense solve eliminates the slacks and works in the `NU` inputs, warm-started from
//! the previous answer's violated rows and saturated inputs. OSQP sees the QP with its
//! sparsity fixed at construction, in scaled variables `ũ = √w ∘ u`, `s = √w_δ ∘ δ`, so that `P = I`, and with
//! every ECBF row divided by its norm each cycle. The scaling is exact (the optimum is the
//! same) and tracks the rows as they change, which OSQP's own set-up-time scaling cannot.
//! Inactive rows keep their place with bounds `(−∞, ∞)` and zero coefficients.

use std::borrow::Cow;

use osqp::{CscMatrix, Problem, Status};

use super::settings::{domain, validate_inputs, validate_nominal, Solver, SolverSettings};
use crate::error::CbfError;
use crate::qp::input_space::{self, Bound, InputSpaceSolver, Outcome, SoftRow, Start};
use crate::qp::osqp_workspace::{self, OsqpQp};
use crate::qp::recorded::{RecordedQp, RecordedRow};
use crate::system::{Gains, Row};

/// One ECBF row's fixed description.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowSpec<'a> {
    /// Input columns `L_g L_f h` may touch (structural non-zeros).
    pub columns: &'a [usize],
    /// The ECBF gains; their count is the row's relative degree.
    pub gains: Gains,
    /// `w_δ` of this row's slack.
    pub slack_weight: f64,
}

/// OSQP's primal and dual iterates, borrowed from its workspace.
pub(crate) type Iterate<'a> = (&'a [f64], &'a [f64]);

/// How a solve ended, as OSQP reported it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum QpStatus {
    /// The dense solve verified its KKT conditions, or OSQP met its tolerances
    /// (`eps_abs`, `eps_rel`).
    Solved,
    /// Met the tolerances ×10 only (OSQP's "solved inaccurate").
    SolvedInaccurate,
    /// Stopped at `max_iter` (OSQP) or `dense_max_steps` (the dense solve, under
    /// [`Solver::Dense`]) before meeting the tolerances, with the iterate it reached.
    MaxIterations,
    /// Stopped at `time_limit` before meeting the tolerances, with the iterate it reached.
    TimeLimit,
    /// OSQP reported the constraints infeasible (accurately or not); no iterate. For the
    /// ECBF QP, whose slacks make it feasible, this is a solver report, not a property.
    PrimalInfeasible,
    /// OSQP reported the cost unbounded below (accurately or not); no iterate.
    DualInfeasible,
    /// OSQP reported the cost matrix not positive semidefinite; no iterate.
    NonConvex,
    /// The solver wrapper panicked (a violated internal invariant); the solver is rebuilt
    /// on the next call.
    SolverFault,
    /// OSQP reported an iterate, or the dense solve a row, step or gradient, with a NaN or
    /// infinite entry.
    /// It is discarded like a fault: the caller falls back, and the workspace (warm
    /// start, ρ) is rebuilt on the next call so the bad iterate cannot seed later cycles.
    NonFinite,
}

impl QpStatus {
    /// Whether the returned iterate is an optimum to the set tolerances.
    pub fn is_solved(self) -> bool {
        matches!(self, QpStatus::Solved | QpStatus::SolvedInaccurate)
    }

    /// OSQP's report, with the primal and dual iterates where it returned them: an
    /// optimum, or the point it stopped at on an iteration or time limit. Shared by every
    /// OSQP problem in the crate.
    ///
    /// An iterate with a NaN or infinite entry is never handed on: it reads as
    /// [`QpStatus::NonFinite`], without an iterate, whatever OSQP called it (OSQP's
    /// residual check passes NaN).
    pub(crate) fn of<'a>(result: &'a Status<'a>) -> (QpStatus, Option<Iterate<'a>>) {
        match Self::of_unchecked(result) {
            (_, Some((x, y))) if !x.iter().chain(y).all(|v| v.is_finite()) => (QpStatus::NonFinite, None),
            read => read,
        }
    }

    /// Whether the solver's workspace must be rebuilt before the next solve: after a
    /// fault, or after a non-finite iterate (its warm start and ρ may hold NaN).
    pub(crate) fn needs_rebuild(self) -> bool {
        matches!(self, QpStatus::SolverFault | QpStatus::NonFinite)
    }

    fn of_unchecked<'a>(result: &'a Status<'a>) -> (QpStatus, Option<Iterate<'a>>) {
        match result {
            Status::Solved(s) => (QpStatus::Solved, Some((s.x(), s.y()))),
            Status::SolvedInaccurate(s) => (QpStatus::SolvedInaccurate, Some((s.x(), s.y()))),
            Status::MaxIterationsReached(s) => (QpStatus::MaxIterations, Some((s.x(), s.y()))),
            Status::TimeLimitReached(s) => (QpStatus::TimeLimit, Some((s.x(), s.y()))),
            Status::PrimalInfeasible(_) | Status::PrimalInfeasibleInaccurate(_) => (QpStatus::PrimalInfeasible, None),
            Status::DualInfeasible(_) | Status::DualInfeasibleInaccurate(_) => (QpStatus::DualInfeasible, None),
            Status::NonConvex(_) => (QpStatus::NonConvex, None),
            _ => (QpStatus::SolverFault, None),
        }
    }

    /// Snake-case name, as shown in Python.
    pub const fn name(self) -> &'static str {
        match self {
            QpStatus::Solved => "solved",
            QpStatus::SolvedInaccurate => "solved_inaccurate",
            QpStatus::MaxIterations => "max_iterations",
            QpStatus::TimeLimit => "time_limit",
            QpStatus::PrimalInfeasible => "primal_infeasible",
            QpStatus::DualInfeasible => "dual_infeasible",
            QpStatus::NonConvex => "non_convex",
            QpStatus::SolverFault => "solver_fault",
            QpStatus::NonFinite => "non_finite",
        }
    }
}

/// Which solver produced an answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Backend {
    /// The exact input-space solve ([`crate::qp::input_space`]).
    Dense,
    /// OSQP (ADMM), polished by the dense solve where that verified.
    Osqp,
}

impl Backend {
    /// Snake-case name, as written to CSV and shown in Python.
    pub const fn name(self) -> &'static str {
        match self {
            Backend::Dense => "dense",
            Backend::Osqp => "osqp",
        }
    }
}

/// A borrowed view of the constraint matrix (no copy, no allocation).
fn constraint_matrix<'a, const NU: usize>(
    rows: usize,
    indptr: &'a [usize],
    indices: &'a [usize],
    data: &'a [f64],
) -> CscMatrix<'a> {
    CscMatrix {
        nrows: rows + NU,
        ncols: NU + rows,
        indptr: Cow::Borrowed(indptr),
        indices: Cow::Borrowed(indices),
        data: Cow::Borrowed(data),
    }
}

/// OSQP's `l`/`u` infinity.
const INF: f64 = 1e30;

/// OSQP's primal-infeasibility tolerance for the ECBF QP: small enough that no certificate
/// ever passes (OSQP requires it positive).
const PRIMAL_INFEASIBILITY_OFF: f64 = 1e-300;

/// The QP, its OSQP workspace, and the last solution.
pub struct EcbfQp<const NU: usize> {
    rows: usize,
    sqrt_w: [f64; NU],
    gains: Vec<Gains>,
    /// `1/√w_δ,i`: the slack's coefficient in its row, in scaled variables.
    slack_coef: Vec<f64>,
    a_indptr: Vec<usize>,
    a_indices: Vec<usize>,
    a_data: Vec<f64>,
    /// Row `i`'s entries are `row_entries[row_start[i]..row_start[i + 1]]`: (index into
    /// `a_data`, input column).
    row_start: Vec<usize>,
    row_entries: Vec<(usize, usize)>,
    slack_entry: Vec<usize>,
    /// Per row: `w_δ`, and this cycle's `b = L_f^r h + Σ k_i L_f^i h` (original units).
    slack_weight: Vec<f64>,
    row_bound: Vec<f64>,
    /// The dense solve, and this cycle's active rows packed for it (with their indices).
    dense: InputSpaceSolver<NU>,
    packed: Vec<SoftRow<NU>>,
    packed_row: Vec<usize>,
    /// This cycle's nominal input (for [`EcbfQp::recorded`]).
    u_ref: [f64; NU],
    /// Per packed row: whether the previous answer had it violated (the warm start).
    guess: Vec<bool>,
    /// The last answer's violated rows (per row) and saturated inputs, when there is one.
    warm_violated: Vec<bool>,
    warm_held: [Bound; NU],
    warm: bool,
    /// The inputs OSQP's iterate holds at a bound (the polish's starting face).
    osqp_held: [Bound; NU],
    backend: Option<Backend>,
    dense_steps: u32,
    dense_fallback: bool,
    input_weights: [f64; NU],
    input_min: [f64; NU],
    input_max: [f64; NU],
    q: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    settings: SolverSettings,
    problem: Option<Problem>,
    u: [f64; NU],
    delta: Vec<f64>,
    status: QpStatus,
    iterations: u32,
    polished: bool,
}

impl<const NU: usize> std::fmt::Debug for EcbfQp<NU> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EcbfQp")
            .field("rows", &self.rows)
            .field("nnz", &self.a_data.len())
            .field("status", &self.status)
            .field("iterations", &self.iterations)
            .field("polished", &self.polished)
            .finish_non_exhaustive()
    }
}

impl<const NU: usize> EcbfQp<NU> {
    /// Lay out the QP for `rows` and set OSQP up once.
    ///
    /// # Errors
    /// Weights, limits, gains (`0 ≤ k ≤` [`domain::MAX_GAIN`]) or settings outside their
    /// documented domain ([`domain`], [`SolverSettings::validate`]), a row naming an input
    /// column twice or beyond `NU`, or OSQP refusing the set-up.
    pub fn new(
        rows: &[RowSpec<'_>],
        input_weights: &[f64; NU],
        input_min: &[f64; NU],
        input_max: &[f64; NU],
        settings: SolverSettings,
    ) -> Result<Self, CbfError> {
        settings.validate()?;
        validate_inputs(input_weights, input_min, input_max)?;
        let m = rows.len();
        let sqrt_w = input_weights.map(f64::sqrt);
        let mut gains = Vec::with_capacity(m);
        let mut slack_coef = Vec::with_capacity(m);
        for (i, r) in rows.iter().enumerate() {
            let mut seen = [false; NU];
            for &c in r.columns {
                if c >= NU || seen[c] {
                    return Err(CbfError::BadRowPattern { row: i, column: c });
                }
                seen[c] = true;
            }
            for &g in r.gains.as_slice() {
                domain::gain(g)?;
            }
            gains.push(r.gains);
            slack_coef.push(1.0 / domain::slack_weight(r.slack_weight)?.sqrt());
        }

        // A is (m ECBF rows + NU box rows) × (NU inputs + m slacks), column-major.
        let nnz = rows.iter().map(|r| r.columns.len() + 1).sum::<usize>() + NU;
        let mut a_indptr = Vec::with_capacity(NU + m + 1);
        let mut a_indices = Vec::with_capacity(nnz);
        let mut row_cols: Vec<Vec<(usize, usize)>> = vec![Vec::new(); m];
        a_indptr.push(0);
        for j in 0..NU {
            for (i, r) in rows.iter().enumerate() {
                if r.columns.contains(&j) {
                    row_cols[i].push((a_indices.len(), j));
                    a_indices.push(i);
                }
            }
            a_indices.push(m + j);
            a_indptr.push(a_indices.len());
        }
        let mut slack_entry = Vec::with_capacity(m);
        for i in 0..m {
            slack_entry.push(a_indices.len());
            a_indices.push(i);
            a_indptr.push(a_indices.len());
        }
        let mut row_start = Vec::with_capacity(m + 1);
        let mut row_entries = Vec::with_capacity(nnz);
        row_start.push(0);
        for entries in &row_cols {
            row_entries.extend_from_slice(entries);
            row_start.push(row_entries.len());
        }
        let mut a_data = vec![0.0; a_indices.len()];
        for i in 0..m {
            a_data[slack_entry[i]] = slack_coef[i];
        }
        for j in 0..NU {
            a_data[a_indptr[j + 1] - 1] = 1.0; // box row
        }

        let n = NU + m;
        let mut lower = vec![-INF; m + NU];
        let mut upper = vec![INF; m + NU];
        for j in 0..NU {
            lower[m + j] = sqrt_w[j] * input_min[j];
            upper[m + j] = sqrt_w[j] * input_max[j];
        }
        let q = vec![0.0; n];
        let mut qp = Self {
            rows: m,
            sqrt_w,
            gains,
            slack_coef,
            a_indptr,
            a_indices,
            a_data,
            row_start,
            row_entries,
            slack_entry,
            slack_weight: rows.iter().map(|r| r.slack_weight).collect(),
            row_bound: vec![0.0; m],
            dense: InputSpaceSolver::new(m),
            packed: Vec::with_capacity(m),
            packed_row: Vec::with_capacity(m),
            u_ref: [0.0; NU],
            guess: Vec::with_capacity(m),
            warm_violated: vec![false; m],
            warm_held: [Bound::Free; NU],
            warm: false,
            osqp_held: [Bound::Free; NU],
            backend: None,
            dense_steps: 0,
            dense_fallback: false,
            input_weights: *input_weights,
            input_min: *input_min,
            input_max: *input_max,
            q,
            lower,
            upper,
            settings,
            problem: None,
            u: [0.0; NU],
            delta: vec![0.0; m],
            status: QpStatus::Solved,
            iterations: 0,
            polished: false,
        };
        // OSQP is set up whenever it may run, so that its first run allocates nothing.
        if settings.backend != Solver::Dense {
            osqp_workspace::set_up(&mut qp)?;
        }
        Ok(qp)
    }

    /// Number of ECBF rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Non-zeros of the constraint matrix (ECBF rows, slacks and the input box).
    pub fn nnz(&self) -> usize {
        self.a_data.len()
    }

    /// Solve for `u_ref` and this cycle's `rows`; only rows with `active[i]` constrain
    /// (`Row::active` is not read, so a caller can narrow it without copying rows). Does not
    /// allocate unless the previous call reported [`QpStatus::SolverFault`].
    ///
    /// Under the default [`Solver::DenseThenOsqp`] the dense solve answers, warm-started
    /// from the last answer; OSQP runs only when it has not verified within
    /// `dense_max_steps` ([`EcbfQp::dense_fallback`]), and its iterate is then polished by
    /// the dense solve started from it. [`EcbfQp::backend`] says who answered.
    ///
    /// On a status with an iterate (solved, inaccurate, iteration or time limit)
    /// [`EcbfQp::u`] and [`EcbfQp::delta`] hold it, always finite: an iterate with a NaN or
    /// infinite entry is reported as [`QpStatus::NonFinite`] and they keep the last one.
    ///
    /// # Errors
    /// `u_ref` outside its domain (finite, `|u_j| ≤` [`domain::MAX_INPUT`]), an active row
    /// whose values or ECBF bound are not finite, or `rows`/`active` of the wrong length.
    /// Nothing is changed then.
    pub fn solve(&mut self, u_ref: &[f64; NU], rows: &[Row<NU>], active: &[bool]) -> Result<QpStatus, CbfError> {
        if rows.len() != self.rows {
            return Err(CbfError::LengthMismatch { what: "constraint rows", expected: self.rows, got: rows.len() });
        }
        if active.len() != self.rows {
            return Err(CbfError::LengthMismatch { what: "active flags", expected: self.rows, got: active.len() });
        }
        validate_nominal(u_ref)?;
        for (i, (r, &on)) in rows.iter().zip(active).enumerate() {
            // Finite values can still overflow in the bound b = L_f^r h + Σ k_i L_f^i h.
            if on && !(r.lg.iter().all(|v| v.is_finite()) && self.ecbf_bound(i, r).is_finite()) {
                return Err(CbfError::NonFiniteRow { row: i });
            }
        }
        self.u_ref = *u_ref;
        self.packed.clear();
        self.packed_row.clear();
        self.guess.clear();
        for (i, (r, &on)) in rows.iter().zip(active).enumerate() {
            if on {
                self.row_bound[i] = self.ecbf_bound(i, r);
                self.packed.push(SoftRow { a: r.lg, b: self.row_bound[i], weight: self.slack_weight[i] });
                self.packed_row.push(i);
                self.guess.push(self.warm_violated[i]);
            }
        }
        (self.backend, self.dense_steps, self.dense_fallback, self.polished, self.iterations) =
            (None, 0, false, false, 0);

        if self.settings.backend != Solver::Osqp {
            let outcome = self.dense_solve(u_ref, true);
            self.dense_steps = self.dense.steps();
            let status = match outcome {
                Outcome::Verified => QpStatus::Solved,
                Outcome::StepLimit => QpStatus::MaxIterations,
                Outcome::NonFinite => QpStatus::NonFinite,
            };
            self.dense_fallback = outcome != Outcome::Verified;
            if outcome == Outcome::Verified || self.settings.backend == Solver::Dense {
                if outcome != Outcome::NonFinite {
                    self.keep_dense_answer(outcome == Outcome::Verified);
                }
                self.backend = Some(Backend::Dense);
                self.status = status;
                return Ok(status);
            }
        }

        self.load_osqp(u_ref, rows, active);
        let status = osqp_workspace::solve(self);
        self.backend = Some(Backend::Osqp);
        if self.settings.polish
            && matches!(
                status,
                QpStatus::Solved | QpStatus::SolvedInaccurate | QpStatus::MaxIterations | QpStatus::TimeLimit
            )
            && self.dense_solve(u_ref, false) == Outcome::Verified
        {
            self.polished = true;
            self.keep_dense_answer(true);
        }
        // `u` and `δ` are finite by construction: OSQP's iterate is read only when finite
        // (`QpStatus::of`), and the dense solve's answer only when verified or inside the box.
        self.status = status;
        Ok(status)
    }

    /// The dense solve of the packed rows: warm-started from the last answer (`warm`), or
    /// from the face OSQP's iterate suggests (a polish).
    fn dense_solve(&mut self, u_ref: &[f64; NU], warm: bool) -> Outcome {
        let problem = input_space::Problem {
            weights: &self.input_weights,
            u_ref,
            input_min: &self.input_min,
            input_max: &self.input_max,
            rows: &self.packed,
        };
        let start = match (warm, self.warm) {
            (true, true) => Start::Guess { violated: &self.guess, held: &self.warm_held },
            (true, false) => Start::Cold,
            (false, _) => Start::Guess { violated: &self.guess, held: &self.osqp_held },
        };
        let max_steps = self.settings.dense_max_steps;
        // The data were checked on the way in (weights, limits, u_ref, finite rows), so the
        // solver's own checks cannot fail; if they ever did, the answer is "no answer".
        self.dense.solve(&problem, start, max_steps).unwrap_or(Outcome::NonFinite)
    }

    /// Take the dense solve's point as this cycle's `u` and `δ`; a verified one also
    /// becomes the next cycle's warm start.
    fn keep_dense_answer(&mut self, verified: bool) {
        self.u = *self.dense.u();
        self.delta.fill(0.0);
        for (k, &i) in self.packed_row.iter().enumerate() {
            self.delta[i] = (-self.dense.row_values()[k]).max(0.0);
        }
        if verified {
            self.warm_violated.fill(false);
            for (k, &i) in self.packed_row.iter().enumerate() {
                self.warm_violated[i] = self.dense.violated()[k];
            }
            self.warm_held = *self.dense.held();
            self.warm = true;
        }
    }

    /// Write this cycle's scaled problem into OSQP's data: each active row divided by its
    /// norm (scaled variables), inactive rows unbounded with zero coefficients.
    fn load_osqp(&mut self, u_ref: &[f64; NU], rows: &[Row<NU>], active: &[bool]) {
        for ((q, w), r) in self.q.iter_mut().zip(&self.sqrt_w).zip(u_ref) {
            *q = -w * r;
        }
        for (i, (r, &on)) in rows.iter().zip(active).enumerate() {
            let entries = &self.row_entries[self.row_start[i]..self.row_start[i + 1]];
            if !on {
                for &(k, _) in entries {
                    self.a_data[k] = 0.0;
                }
                self.a_data[self.slack_entry[i]] = self.slack_coef[i];
                self.lower[i] = -INF;
                continue;
            }
            let bound = -self.row_bound[i];
            // The row's 2-norm, computed relative to its largest entry so that squaring
            // cannot overflow for any finite row.
            let largest =
                entries.iter().map(|&(_, c)| (r.lg[c] / self.sqrt_w[c]).abs()).fold(self.slack_coef[i], f64::max);
            let mut norm2 = (self.slack_coef[i] / largest).powi(2);
            for &(_, c) in entries {
                norm2 += (r.lg[c] / self.sqrt_w[c] / largest).powi(2);
            }
            let scale = 1.0 / (largest * norm2.sqrt());
            for &(k, c) in entries {
                self.a_data[k] = r.lg[c] / self.sqrt_w[c] * scale;
            }
            self.a_data[self.slack_entry[i]] = self.slack_coef[i] * scale;
            // A bound this large is a row that cannot bind; clamp so OSQP reads it as one.
            self.lower[i] = (bound * scale).clamp(-INF, INF);
        }
    }

    /// `b = L_f^r h + Σ k_i L_f^i h` of row `i` (≥ 0 when the ECBF condition holds at
    /// `u = 0`).
    fn ecbf_bound(&self, i: usize, r: &Row<NU>) -> f64 {
        self.gains[i].bound(&r.lie)
    }

    /// OSQP's own polish rule, as the dense solve's starting face: a row binds (its slack
    /// is positive: violated in input space) when `A z − l < −y`, an input is held at its
    /// lower bound when `z − l < −y`, at its upper when `u − z < y` (scaled problem).
    fn guess_active_set(&mut self, z: &[f64], y: &[f64]) {
        for (k, &i) in self.packed_row.iter().enumerate() {
            let entries = &self.row_entries[self.row_start[i]..self.row_start[i + 1]];
            let value = entries.iter().map(|&(e, c)| self.a_data[e] * z[c]).sum::<f64>()
                + self.a_data[self.slack_entry[i]] * z[NU + i];
            self.guess[k] = value - self.lower[i] < -y[i];
        }
        for j in 0..NU {
            let (value, dual) = (z[j], y[self.rows + j]);
            self.osqp_held[j] = if value - self.lower[self.rows + j] < -dual {
                Bound::Lower
            } else if self.upper[self.rows + j] - value < dual {
                Bound::Upper
            } else {
                Bound::Free
            };
        }
    }

    /// The last solve's problem, active rows only, to replay against any solver
    /// (allocates: not for the control path).
    pub fn recorded(&self, t: f64) -> RecordedQp {
        RecordedQp {
            t,
            layout_rows: self.rows,
            weights: self.input_weights.to_vec(),
            u_ref: self.u_ref.to_vec(),
            input_min: self.input_min.to_vec(),
            input_max: self.input_max.to_vec(),
            rows: self
                .packed
                .iter()
                .zip(&self.packed_row)
                .map(|(r, &index)| RecordedRow { index, a: r.a.to_vec(), b: r.b, weight: r.weight })
                .collect(),
        }
    }

    /// Which backend answered the last solve; `None` before the first or after an `Err`.
    pub fn backend(&self) -> Option<Backend> {
        self.backend
    }

    /// Newton steps of the last dense solve (0 when it did not run).
    pub fn dense_steps(&self) -> u32 {
        self.dense_steps
    }

    /// Whether the last dense solve ran and did not verify (within its budget, or with a
    /// non-finite step): under [`Solver::DenseThenOsqp`] OSQP then answered.
    pub fn dense_fallback(&self) -> bool {
        self.dense_fallback
    }

    /// The input of the last answer.
    pub fn u(&self) -> &[f64; NU] {
        &self.u
    }

    /// Slacks `δ` of the last iterate, one per row (≈ 0 for rows that hold).
    pub fn delta(&self) -> &[f64] {
        &self.delta
    }

    /// How the last solve ended ([`QpStatus::Solved`] before the first; a call that
    /// returned `Err` leaves it unchanged).
    pub fn status(&self) -> QpStatus {
        self.status
    }

    /// Whether the last answer is OSQP's iterate polished: the dense solve, started from
    /// it, verified the optimum (see [`crate::qp::input_space`]).
    pub fn polished(&self) -> bool {
        self.polished
    }

    /// ADMM iterations of the last solve (0 when OSQP did not run).
    pub fn iterations(&self) -> u32 {
        self.iterations
    }
}

impl<const NU: usize> OsqpQp for EcbfQp<NU> {
    fn workspace(&mut self) -> &mut Option<Problem> {
        &mut self.problem
    }

    fn setup(&self) -> Result<Problem, CbfError> {
        let n = NU + self.rows;
        let p = CscMatrix {
            nrows: n,
            ncols: n,
            indptr: Cow::Owned((0..=n).collect()),
            indices: Cow::Owned((0..n).collect()),
            data: Cow::Owned(vec![1.0; n]),
        };
        let a = constraint_matrix::<NU>(self.rows, &self.a_indptr, &self.a_indices, &self.a_data);
        // Every row has a slack, so this QP is feasible for any data: an infeasibility
        // "certificate" can only be OSQP's test passing on a stiff slack's small column
        // (w_δ = 1e8 makes it 1e-4 after scaling). The test is made unreachable, not
        // trusted.
        let settings = self.settings.to_osqp().eps_prim_inf(PRIMAL_INFEASIBILITY_OFF);
        Problem::new(p, &self.q, a, &self.lower, &self.upper, &settings)
            .map_err(|e| CbfError::SolverSetup { reason: e.to_string() })
    }

    fn update(&self, problem: &mut Problem) {
        problem.update_lin_cost(&self.q);
        problem.update_bounds(&self.lower, &self.upper);
        problem.update_A(constraint_matrix::<NU>(self.rows, &self.a_indptr, &self.a_indices, &self.a_data));
    }

    fn read(&mut self, _status: QpStatus, iterate: Option<Iterate<'_>>, iterations: u32) {
        self.iterations = iterations;
        if let Some((z, y)) = iterate {
            for ((u, z), w) in self.u.iter_mut().zip(z).zip(&self.sqrt_w) {
                *u = z / w;
            }
            for i in 0..self.rows {
                self.delta[i] = z[NU + i] * self.slack_coef[i];
            }
            self.guess_active_set(z, y);
        }
    }
}
