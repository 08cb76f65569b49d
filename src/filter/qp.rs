//! The ECBF quadratic program with priority tiers: solved lexicographically and exactly in
//! input space ([`crate::qp::lexicographic`]), with OSQP as the fallback and the reference
//! backend ([`Solver`]).
//!
//! ```text
//! rows:  L_g L_f^{r−1} h_i · u + L_f^r h_i + Σ_k k_{i,k} L_f^k h_i ≥ 0   (active rows, tier τ_i)
//! box:   u_min ≤ u ≤ u_max
//! ```
//!
//! Tier 0 is met exactly whenever the box allows it, else with the least violation; then
//! tier 1 in what room remains, and so on; among the inputs that do all that, the answer is
//! the closest to `u_ref` in `Σ_j w_j (u_j − u_ref,j)²`.
//!
//! OSQP sees only the first stage — every row hard — in scaled variables `ũ = √w ∘ u`, so
//! that `P = I`, with each row divided by its norm every cycle (exact, and it tracks the
//! rows as they change, which OSQP's set-up-time scaling cannot). A spec's objective
//! replaces the weights by a cost matrix `P = L Lᵀ` ([`crate::qp::metric`]): the scaled
//! variables are then `ũ = Lᵀ u`, every row and the box rows dense in them
//! ([`EcbfQp::with_cost_matrix`] lays them out so). Its answer is never
//! handed on as an optimum: the dense solve, started from the face OSQP's iterate suggests,
//! verifies it (and runs the cascade when the rows do not fit), or the cycle is flagged
//! [`QpStatus::MaxIterations`]. Inactive rows keep their place with bounds `(−∞, ∞)` and
//! zero coefficients.

// Index loops mirror the formulas (rows × inputs).
#![allow(clippy::needless_range_loop)]
use osqp::Problem;

use super::settings::{domain, validate_inputs, validate_nominal};
use crate::error::CbfError;
use crate::qp::csc::Csc;
use crate::qp::dual_active_set::{ActiveRow, Side};
use crate::qp::lexicographic::{Cause, LexicographicSolver, Outcome, TieredRow};
use crate::qp::metric::InputMetric;
use crate::qp::osqp_workspace::{self, OsqpQp};
use crate::qp::recorded::{RecordedQp, RecordedRow};
use crate::qp::{Backend, Iterate, QpStatus, Solver, SolverSettings, INFINITY as INF};
use crate::system::{Gains, Row};

/// One ECBF row's fixed description.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowSpec<'a> {
    /// Input columns `L_g L_f h` may touch (structural non-zeros).
    pub columns: &'a [usize],
    /// The ECBF gains; their count is the row's relative degree.
    pub gains: Gains,
    /// The row's priority tier, `0..`[`TIERS`](crate::qp::lexicographic::TIERS): 0 is met first.
    pub priority: u8,
}

/// A row counts as met when `a·u + b ≥ −`this` · (|b| + Σ_j |a_j| (1 + |u_j|))`: ten times
/// the dense solver's own feasibility tolerance, so that rounding in a verified answer
/// (and the padding of a relaxation by it) is never reported as a relaxation.
pub const MET_TOLERANCE: f64 = 1e-8;

/// How far below 0 a row `a·u + b` may read at `u` and still count as met:
/// [`MET_TOLERANCE`]` · (|b| + Σ_j |a_j| (1 + |u_j|))`, rounding and nothing more. The
/// verdict's measure, and the sampled-data certificate's.
pub(crate) fn met_allowance<const NU: usize>(a: &[f64; NU], b: f64, u: &[f64; NU]) -> f64 {
    MET_TOLERANCE * a.iter().zip(u).fold(b.abs(), |s, (aj, uj)| s + aj.abs() * (1.0 + uj.abs()))
}

/// The most work one QP solve can take ([`EcbfQp::worst_case`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SolveWorstCase {
    /// Dense-solver trips.
    pub dense_trips: u64,
    /// OSQP iterations.
    pub osqp_iterations: u32,
}

/// The QP, its solvers, and the last answer and its assessment.
pub struct EcbfQp<const NU: usize> {
    rows: usize,
    /// The cost's metric: the weights', or the last one [`EcbfQp::set_metric`] gave.
    metric: InputMetric<NU>,
    /// Laid out for any metric (every row and the box dense in OSQP's matrix).
    general: bool,
    gains: Vec<Gains>,
    priority: Vec<u8>,
    /// OSQP's constraint matrix (ECBF rows, then the box).
    a: Csc,
    /// Row `i`'s entries are `row_entries[row_start[i]..row_start[i + 1]]`: (index into
    /// `a.data`, input column); the box rows follow as rows `rows..rows + NU`.
    row_start: Vec<usize>,
    row_entries: Vec<(usize, usize)>,
    /// This cycle's rows as the dense solve takes them (`b = L_f^r h + Σ k_i L_f^i h`),
    /// and which take part.
    tiered: Vec<TieredRow<NU>>,
    active: Vec<bool>,
    /// Per row: asked of it beyond the ECBF bound, `a·u + b ≥ margin` (the sampled-data
    /// certificate's; 0 otherwise).
    margins: Vec<f64>,
    dense: LexicographicSolver<NU>,
    /// OSQP's suggested face, for the dense solve started from it.
    osqp_face: Vec<ActiveRow>,
    /// This cycle's nominal input (for [`EcbfQp::recorded`]).
    u_ref: [f64; NU],
    backend: Option<Backend>,
    dense_steps: u32,
    /// Dense-solver trips of the last solve, over both its dense solves.
    dense_work: u64,
    elastic_stages: u32,
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
    /// Whether `u` is the dense solve's verified answer (its causes apply).
    verified: bool,
    /// Per row at the assessed input: the slack `max(0, −(a·u + b))`, and why a row
    /// missed beyond [`MET_TOLERANCE`] was relaxed.
    delta: Vec<f64>,
    relative: Vec<f64>,
    relaxed: Vec<Option<Cause>>,
    status: QpStatus,
    iterations: u32,
    polished: bool,
}

impl<const NU: usize> std::fmt::Debug for EcbfQp<NU> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EcbfQp")
            .field("rows", &self.rows)
            .field("nnz", &self.a.data.len())
            .field("status", &self.status)
            .field("iterations", &self.iterations)
            .field("polished", &self.polished)
            .finish_non_exhaustive()
    }
}

impl<const NU: usize> EcbfQp<NU> {
    /// Lay out the QP for `rows` and set OSQP up once (unless the backend is
    /// [`Solver::Dense`]).
    ///
    /// # Errors
    /// Weights, limits, gains (`0 ≤ k ≤` [`domain::MAX_GAIN`]), priorities (`<`
    /// [`TIERS`](crate::qp::lexicographic::TIERS)) or settings outside their documented domain ([`domain`],
    /// [`SolverSettings::validate`]), a row naming an input column twice or beyond `NU`,
    /// or OSQP refusing the set-up.
    pub fn new(
        rows: &[RowSpec<'_>],
        input_weights: &[f64; NU],
        input_min: &[f64; NU],
        input_max: &[f64; NU],
        settings: SolverSettings,
    ) -> Result<Self, CbfError> {
        Self::build(rows, input_weights, input_min, input_max, settings, false)
    }

    /// As [`EcbfQp::new`], for a cost matrix that changes every cycle
    /// ([`EcbfQp::set_metric`]; unit weights until then): OSQP's matrix holds every row
    /// and the box dense, since `L⁻¹` fills a row's pattern in.
    ///
    /// # Errors
    /// As [`EcbfQp::new`].
    pub fn with_cost_matrix(
        rows: &[RowSpec<'_>],
        input_min: &[f64; NU],
        input_max: &[f64; NU],
        settings: SolverSettings,
    ) -> Result<Self, CbfError> {
        Self::build(rows, &[1.0; NU], input_min, input_max, settings, true)
    }

    fn build(
        rows: &[RowSpec<'_>],
        input_weights: &[f64; NU],
        input_min: &[f64; NU],
        input_max: &[f64; NU],
        settings: SolverSettings,
        general: bool,
    ) -> Result<Self, CbfError> {
        settings.validate()?;
        validate_inputs(input_weights, input_min, input_max)?;
        let m = rows.len();
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
            domain::priority(r.priority)?;
        }

        // A is (m ECBF rows + NU box rows) × NU inputs; row i's entries, then the box (the
        // rows of L⁻ᵀ, upper triangular, for a general metric).
        let mut entries = Vec::new();
        let mut row_cols: Vec<Vec<usize>> = vec![Vec::new(); m + NU];
        for (i, r) in rows.iter().enumerate() {
            row_cols[i] = (0..NU).filter(|j| general || r.columns.contains(j)).collect();
        }
        for j in 0..NU {
            row_cols[m + j] = if general { (j..NU).collect() } else { vec![j] };
        }
        for (i, cols) in row_cols.iter().enumerate() {
            entries.extend(cols.iter().map(|&j| (i, j)));
        }
        let (a, slots) = Csc::from_entries(m + NU, NU, &entries);
        let mut row_start = Vec::with_capacity(m + NU + 1);
        let mut row_entries = Vec::with_capacity(entries.len());
        row_start.push(0);
        for cols in &row_cols {
            let first = row_entries.len();
            row_entries.extend(cols.iter().enumerate().map(|(k, &j)| (slots[first + k], j)));
            row_start.push(row_entries.len());
        }
        let empty = TieredRow { a: [0.0; NU], b: 0.0, tier: 0 };
        let mut qp = Self {
            rows: m,
            metric: InputMetric::from_weights(input_weights),
            general,
            gains: rows.iter().map(|r| r.gains).collect(),
            priority: rows.iter().map(|r| r.priority).collect(),
            a,
            row_start,
            row_entries,
            tiered: rows.iter().map(|r| TieredRow { tier: r.priority, ..empty }).collect(),
            active: vec![false; m],
            dense: {
                let mut dense = LexicographicSolver::new(m, input_weights, input_min, input_max)?;
                dense.set_max_work(settings.dense_max_work);
                dense
            },
            osqp_face: Vec::with_capacity(NU),
            u_ref: [0.0; NU],
            backend: None,
            dense_steps: 0,
            dense_work: 0,
            elastic_stages: 0,
            dense_fallback: false,
            input_weights: *input_weights,
            input_min: *input_min,
            input_max: *input_max,
            q: vec![0.0; NU],
            lower: vec![-INF; m + NU],
            upper: vec![INF; m + NU],
            settings,
            problem: None,
            u: [0.0; NU],
            verified: false,
            delta: vec![0.0; m],
            margins: vec![0.0; m],
            relative: vec![0.0; m],
            relaxed: vec![None; m],
            status: QpStatus::Solved,
            iterations: 0,
            polished: false,
        };
        qp.write_osqp_box();
        // OSQP is set up whenever it may run, so that its first run allocates nothing.
        if settings.backend != Solver::Dense {
            osqp_workspace::set_up(&mut qp)?;
        }
        Ok(qp)
    }

    /// Measure the distance to the nominal input in `metric` from the next solve on
    /// (input weights' diagonal metric until then): what a spec's objective sets each
    /// cycle, with its centre as the nominal input ([`InputMetric::objective`]).
    /// Allocation-free, `O(NU²)`.
    ///
    /// # Errors
    /// A metric that is not diagonal on a QP laid out by [`EcbfQp::new`] (OSQP's matrix
    /// has no room for it: lay it out with [`EcbfQp::with_cost_matrix`]).
    pub fn set_metric(&mut self, metric: &InputMetric<NU>) -> Result<(), CbfError> {
        if !self.general && !metric.is_diagonal() {
            return Err(CbfError::OutOfRange {
                what: "cost matrix of a QP laid out for input weights (EcbfQp::with_cost_matrix lays one out)",
                value: f64::NAN,
                range: "diagonal",
            });
        }
        self.metric = *metric;
        self.dense.set_metric(metric);
        self.write_osqp_box();
        Ok(())
    }

    /// The box rows of OSQP's scaled problem: `√w_j min_j ≤ ũ_j ≤ √w_j max_j` for a
    /// diagonal metric, `min_j ≤ (L⁻ᵀ ũ)_j ≤ max_j` for any other.
    fn write_osqp_box(&mut self) {
        for j in 0..NU {
            let row = self.rows + j;
            for &(k, c) in &self.row_entries[self.row_start[row]..self.row_start[row + 1]] {
                self.a.data[k] = if self.metric.is_diagonal() {
                    if c == j {
                        1.0
                    } else {
                        0.0
                    }
                } else {
                    self.metric.box_row(j)[c]
                };
            }
            let scale = if self.metric.is_diagonal() { self.metric.root_weight(j) } else { 1.0 };
            (self.lower[row], self.upper[row]) = (scale * self.input_min[j], scale * self.input_max[j]);
        }
    }

    /// From the next [`EcbfQp::solve`] on, row `i` asks `a·u + b ≥ margins[i]`: the
    /// sampled-data certificate's margins ([`crate::filter::between_samples`]), in the rows'
    /// units. A slice of another length, or a margin that is negative or not finite, is
    /// ignored (the rows keep the margins they had): the filter never gives one.
    pub fn set_margins(&mut self, margins: &[f64]) {
        if margins.len() == self.rows && margins.iter().all(|m| m.is_finite() && *m >= 0.0) {
            self.margins.copy_from_slice(margins);
        }
    }

    /// Number of ECBF rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Non-zeros of OSQP's constraint matrix (ECBF rows and the input box).
    pub fn nnz(&self) -> usize {
        self.a.data.len()
    }

    /// Solve for `u_ref` and this cycle's `rows`; only rows with `active[i]` constrain
    /// (`Row::active` is not read, so a caller can narrow it without copying rows). Does not
    /// allocate unless the previous call reported [`QpStatus::SolverFault`].
    ///
    /// Under the default [`Solver::DenseThenOsqp`] the dense solve answers; OSQP runs only
    /// when the dense solve's first stage has not verified within `dense_max_steps`
    /// ([`EcbfQp::dense_fallback`]), and the dense solve then starts again from OSQP's
    /// face. [`EcbfQp::backend`] says who answered, [`EcbfQp::verified`] whether the answer
    /// is the verified optimum. Then [`EcbfQp::assess`] the input actually applied.
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
            if on && !(r.lg.iter().all(|v| v.is_finite()) && self.gains[i].bound(&r.lie).is_finite()) {
                return Err(CbfError::NonFiniteRow { row: i });
            }
        }
        self.u_ref = *u_ref;
        for (i, (r, &on)) in rows.iter().zip(active).enumerate() {
            self.active[i] = on;
            if on {
                self.tiered[i].a = r.lg;
                self.tiered[i].b = self.gains[i].bound(&r.lie) - self.margins[i];
            }
        }
        (self.backend, self.dense_steps, self.elastic_stages, self.dense_fallback, self.polished, self.iterations) =
            (None, 0, 0, false, false, 0);
        self.dense_work = 0;
        self.verified = false;
        let max_steps = self.settings.dense_max_steps;

        if self.settings.backend != Solver::Osqp {
            let outcome = self.dense_solve(u_ref, max_steps);
            let first_stage_failed = outcome == Outcome::StepLimit && self.dense.elastic_stages() == 0;
            if self.settings.backend == Solver::Dense || !first_stage_failed {
                self.backend = Some(Backend::Dense);
                self.status = self.take_dense(outcome);
                return Ok(self.status);
            }
            self.dense_fallback = true;
        }

        // OSQP on the first stage, then the dense solve from its face.
        self.load_osqp(u_ref);
        let osqp = osqp_workspace::solve(self);
        self.backend = Some(Backend::Osqp);
        let has_iterate = matches!(
            osqp,
            QpStatus::Solved | QpStatus::SolvedInaccurate | QpStatus::MaxIterations | QpStatus::TimeLimit
        );
        if self.settings.polish && (has_iterate || osqp == QpStatus::PrimalInfeasible) {
            let steps_before = self.dense_steps;
            self.dense.suggest_first_face(&self.osqp_face);
            let outcome = self.dense_solve(u_ref, max_steps);
            self.dense_steps += steps_before;
            if outcome == Outcome::Verified {
                self.polished = true;
                self.status = self.take_dense(outcome);
                return Ok(self.status);
            }
        }
        // No verified answer: OSQP's iterate where it has one (read into `u` already),
        // flagged as what it is.
        self.status = match osqp {
            QpStatus::Solved | QpStatus::SolvedInaccurate => QpStatus::MaxIterations,
            other => other,
        };
        Ok(self.status)
    }

    /// The dense lexicographic solve of this cycle's rows.
    fn dense_solve(&mut self, u_ref: &[f64; NU], max_steps: u32) -> Outcome {
        // The rows were checked on the way in (finite, tiers in range, lengths), so the
        // solver's own checks cannot fail; if they ever did, the answer is "no answer".
        let outcome = self.dense.solve(u_ref, &self.tiered, &self.active, max_steps).unwrap_or(Outcome::NonFinite);
        self.dense_steps = self.dense.steps();
        self.dense_work += self.dense.work();
        self.elastic_stages = self.dense.elastic_stages();
        outcome
    }

    /// The dense solve's point as this cycle's `u` (unless it is not finite), and its
    /// status.
    fn take_dense(&mut self, outcome: Outcome) -> QpStatus {
        match outcome {
            Outcome::Verified => {
                self.u = *self.dense.u();
                self.verified = true;
                QpStatus::Solved
            }
            Outcome::StepLimit => {
                self.u = *self.dense.u();
                QpStatus::MaxIterations
            }
            Outcome::NonFinite => QpStatus::NonFinite,
        }
    }

    /// Measure every active row at the input `u` the filter applies: its slack, relative
    /// size, and — beyond [`MET_TOLERANCE`] — why it was relaxed (the dense solve's cause
    /// when `u` is its verified answer, else [`Cause::Unsolved`]; a row without authority
    /// always says so). Returns how many rows were relaxed. Allocation-free.
    pub fn assess(&mut self, u: &[f64; NU]) -> usize {
        let answered = self.verified && u == &self.u;
        let mut relaxed = 0;
        for i in 0..self.rows {
            (self.delta[i], self.relative[i], self.relaxed[i]) = (0.0, 0.0, None);
            if !self.active[i] {
                continue;
            }
            let row = &self.tiered[i];
            let (mut value, mut terms) = (row.b, row.b.abs());
            for j in 0..NU {
                value += row.a[j] * u[j];
                terms += (row.a[j] * u[j]).abs();
            }
            let slack = (-value).max(0.0);
            self.delta[i] = slack;
            if slack > met_allowance(&row.a, row.b, u) {
                self.relative[i] = if terms > 0.0 { slack / terms } else { f64::INFINITY };
                let cause = self.dense.causes()[i];
                self.relaxed[i] = Some(match cause {
                    Some(Cause::NoAuthority) => Cause::NoAuthority,
                    Some(c) if answered => c,
                    _ => Cause::Unsolved,
                });
                relaxed += 1;
            }
        }
        relaxed
    }

    /// Forget the last assessment: no row assessed (a cycle whose rows were not finite).
    pub fn clear_assessment(&mut self) {
        self.delta.fill(0.0);
        self.relative.fill(0.0);
        self.relaxed.fill(None);
    }

    /// Write this cycle's scaled first stage into OSQP's data: each active row divided by
    /// its norm (scaled variables), inactive rows unbounded with zero coefficients.
    fn load_osqp(&mut self, u_ref: &[f64; NU]) {
        for (q, centre) in self.q.iter_mut().zip(self.metric.scaled(u_ref)) {
            *q = -centre;
        }
        for i in 0..self.rows {
            let entries = &self.row_entries[self.row_start[i]..self.row_start[i + 1]];
            let row = &self.tiered[i];
            if !self.active[i] {
                for &(k, _) in entries {
                    self.a.data[k] = 0.0;
                }
                self.lower[i] = -INF;
                continue;
            }
            // The row's 2-norm in scaled variables, computed relative to its largest entry
            // so that squaring cannot overflow for any finite row.
            let scaled = self.metric.scaled_row(&row.a);
            let largest = entries.iter().map(|&(_, c)| scaled[c].abs()).fold(0.0, f64::max);
            if largest == 0.0 {
                for &(k, _) in entries {
                    self.a.data[k] = 0.0;
                }
                self.lower[i] = -INF; // no input acts: nothing for OSQP to do with it
                continue;
            }
            let norm2 = entries.iter().map(|&(_, c)| (scaled[c] / largest).powi(2)).sum::<f64>();
            let scale = 1.0 / (largest * norm2.sqrt());
            for &(k, c) in entries {
                self.a.data[k] = scaled[c] * scale;
            }
            // A bound this large is a row that cannot bind; clamp so OSQP reads it as one.
            self.lower[i] = (-row.b * scale).clamp(-INF, INF);
        }
    }

    /// OSQP's own polish rule, as the dense solve's starting face: a row or input bound is
    /// active when `A z − l < −y` (lower) or `u − A z < y` (upper), scaled problem.
    fn guess_face(&mut self, z: &[f64], y: &[f64]) {
        self.osqp_face.clear();
        for i in 0..self.rows {
            if !self.active[i] || self.osqp_face.len() == NU {
                continue;
            }
            let entries = &self.row_entries[self.row_start[i]..self.row_start[i + 1]];
            let value = entries.iter().map(|&(e, c)| self.a.data[e] * z[c]).sum::<f64>();
            if value - self.lower[i] < -y[i] {
                self.osqp_face.push(ActiveRow { row: i, side: Side::Lower });
            }
        }
        for j in 0..NU {
            if self.osqp_face.len() == NU {
                break;
            }
            let row = self.rows + j;
            let entries = &self.row_entries[self.row_start[row]..self.row_start[row + 1]];
            let (value, dual) = (entries.iter().map(|&(e, c)| self.a.data[e] * z[c]).sum::<f64>(), y[row]);
            if value - self.lower[self.rows + j] < -dual {
                self.osqp_face.push(ActiveRow { row: self.rows + j, side: Side::Lower });
            } else if self.upper[self.rows + j] - value < dual {
                self.osqp_face.push(ActiveRow { row: self.rows + j, side: Side::Upper });
            }
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
            cost_matrix: (!self.metric.is_diagonal()).then(|| self.metric.matrix().concat()),
            input_min: self.input_min.to_vec(),
            input_max: self.input_max.to_vec(),
            rows: (0..self.rows)
                .filter(|&i| self.active[i])
                .map(|i| {
                    let r = &self.tiered[i];
                    RecordedRow { index: i, a: r.a.to_vec(), b: r.b, tier: r.tier }
                })
                .collect(),
        }
    }

    /// Which backend answered the last solve; `None` before the first or after an `Err`.
    pub fn backend(&self) -> Option<Backend> {
        self.backend
    }

    /// Active-set changes of the last dense solve, over all its stages (0 when it did not
    /// run).
    pub fn dense_steps(&self) -> u32 {
        self.dense_steps
    }

    /// Dense-solver trips of the last solve ([`crate::qp::dual_active_set::DualActiveSet::work`]),
    /// over both its dense solves (the first, and the one from OSQP's face); 0 when none ran.
    pub fn dense_work(&self) -> u64 {
        self.dense_work
    }

    /// The most one [`EcbfQp::solve`] can do with these settings: its dense solves (the
    /// first, and the polish from OSQP's face when OSQP may run), each within
    /// [`SolverSettings::dense_max_work`] and what a stage may do past it, and OSQP's
    /// iterations.
    pub fn worst_case(&self) -> SolveWorstCase {
        let s = &self.settings;
        let dense_solves = match s.backend {
            Solver::Dense => 1,
            Solver::DenseThenOsqp => 1 + u64::from(s.polish),
            Solver::Osqp => u64::from(s.polish),
        };
        SolveWorstCase {
            dense_trips: dense_solves.saturating_mul(self.dense.worst_case_work()),
            osqp_iterations: if s.backend == Solver::Dense { 0 } else { s.max_iter },
        }
    }

    /// Elastic (least-violation) stages of the last dense solve: 0 when every row fitted.
    pub fn elastic_stages(&self) -> u32 {
        self.elastic_stages
    }

    /// Whether the last dense solve's first stage ran and did not verify within its
    /// budget, so that under [`Solver::DenseThenOsqp`] OSQP ran.
    pub fn dense_fallback(&self) -> bool {
        self.dense_fallback
    }

    /// The input of the last answer: the verified optimum, or the point a solver stopped
    /// at (see [`EcbfQp::verified`]).
    pub fn u(&self) -> &[f64; NU] {
        &self.u
    }

    /// Whether [`EcbfQp::u`] is the dense solve's verified lexicographic optimum.
    pub fn verified(&self) -> bool {
        self.verified
    }

    /// Per row, at the last assessed input: the slack `max(0, −(a·u + b))` in the row's
    /// units (0 for inactive rows).
    pub fn delta(&self) -> &[f64] {
        &self.delta
    }

    /// Per row: the slack relative to the row's terms `|b| + Σ_j |a_j u_j|`, for rows
    /// relaxed beyond [`MET_TOLERANCE`] (0 otherwise).
    pub fn relative_slack(&self) -> &[f64] {
        &self.relative
    }

    /// Per row: why it was relaxed, for rows missed beyond [`MET_TOLERANCE`] at the last
    /// assessed input; `None` for rows met or inactive.
    pub fn relaxed(&self) -> &[Option<Cause>] {
        &self.relaxed
    }

    /// Per row: its priority tier.
    pub fn priorities(&self) -> &[u8] {
        &self.priority
    }

    /// How the last solve ended ([`QpStatus::Solved`] before the first; a call that
    /// returned `Err` leaves it unchanged).
    pub fn status(&self) -> QpStatus {
        self.status
    }

    /// Whether the last answer came from OSQP's face, verified by the dense solve.
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
        let p = Csc::identity(NU);
        Problem::new(p.view(), &self.q, self.a.view(), &self.lower, &self.upper, &self.settings.to_osqp())
            .map_err(|e| CbfError::SolverSetup { reason: e.to_string() })
    }

    fn update(&self, problem: &mut Problem) {
        problem.update_lin_cost(&self.q);
        problem.update_bounds(&self.lower, &self.upper);
        problem.update_A(self.a.view());
    }

    fn read(&mut self, _status: QpStatus, iterate: Option<Iterate<'_>>, iterations: u32) {
        self.iterations = iterations;
        self.osqp_face.clear();
        if let Some((z, y)) = iterate {
            self.u = self.metric.unscaled(z);
            self.guess_face(z, y);
        }
    }
}
