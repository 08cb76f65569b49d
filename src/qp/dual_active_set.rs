//! A dense Goldfarb–Idnani dual active-set solver for small, strictly convex QPs
//!
//! ```text
//! minimise   ½ zᵀ P z + qᵀ z
//! subject to l ≤ A z ≤ u          (P positive definite, n variables, m rows)
//! ```
//!
//! Each row is two-sided; `l_i = u_i` makes it an equality, and a bound that is infinite
//! or beyond [`INFINITY`] in magnitude (`l_i ≤ −1e30`, `u_i ≥ 1e30`) is no bound. A lower
//! bound at `+∞` or an upper one at `−∞`, `l_i > u_i`, and an all-zero row whose bounds
//! exclude 0 make the problem infeasible.
//!
//! # Why a dual active-set method for the MPCs
//!
//! The MPC QPs of this crate (the LIP MPC's 12 feet, the multi-layer MPC's 29 condensed
//! velocities) have *hard* rows (no slack: a plan either meets every row or there is no
//! plan), few variables, and a cost matrix `P` that never changes. Goldfarb and Idnani's
//! dual method (Math. Programming 27, 1983) fits them:
//!
//! * it starts from the unconstrained minimum `−P⁻¹q` and adds violated rows one at a
//!   time, so it needs no feasible starting point and works on exactly the rows that bind;
//! * `P` is factorised once (`P = L Lᵀ`, `J = L⁻ᵀ`, at construction or on
//!   [`DualActiveSet::set_hessian`]); a solve only updates the orthogonal factorisation
//!   `Jᵀ N = [R; 0]` of the active normals `N` by Givens rotations of `J`'s columns and
//!   `R`'s rows (the numerically stable form of the method: no normal equations, no
//!   explicit inverse of `NᵀP⁻¹N`), O(n²) per active-set change on buffers sized at
//!   construction, plus O(mn) per added row to find the most violated one. After each
//!   full step the iterate and multipliers are recomputed from the factors
//!   (`x = J₁R⁻ᵀb − J₂J₂ᵀq`), not accumulated, so rounding does not build up;
//! * it terminates finitely: each full step strictly increases the dual objective, so no
//!   active set repeats;
//! * it detects infeasibility exactly: a violated row whose normal is a non-positive
//!   combination of the active rows' is a Farkas certificate, which is checked before
//!   it is reported;
//! * the previous solve's active set is a warm start: its rows are put into the
//!   factorisation first, the rows that are linearly dependent on those before them are
//!   left out, and rows with negative multipliers are dropped (most negative first) until
//!   the start is dual feasible, as the method requires. Each such drop counts as a step.
//!
//! # Verification and tolerance
//!
//! "Solved" means the answer passed a KKT check on the data as given (not on the solver's
//! internal scaled copy), with `ε` = [`KKT_TOLERANCE`] = 1e-9 in scale-aware units:
//!
//! * primal feasibility, every row: `l_i − a_iᵀz ≤ ε (|l_i| + Σ_j |a_ij| (1 + |z_j|))`, the
//!   same for `u_i`; the sum is the size of the row's terms, and the `1` the rounding of a
//!   variable near zero, so the test does not depend on how a row is scaled;
//! * complementarity: a row with a non-zero multiplier is at its bound to the same tolerance;
//! * dual signs: with OSQP's convention `P z + q + Aᵀ y = 0`, `y_i ≤ 0` on an active lower
//!   bound, `y_i ≥ 0` on an active upper bound, any sign on an equality, 0 elsewhere;
//! * stationarity, every variable: `|(P z + q + Aᵀ y)_j| ≤ ε (s_j + 10⁻⁴ max_k s_k)` with
//!   `s_j = Σ_k |P_jk z_k| + |q_j| + Σ_i |y_i a_ij|` the size of the gradient terms it
//!   sums, each variable's in units of `√P_jj`; the floor, a part in 10⁴ of the largest,
//!   is the rounding the factorisation carries from one variable into another whose own
//!   terms nearly vanish.
//!
//! Internally each row is divided by its Euclidean norm, so rows of very different scale
//! compete fairly when the most violated one is chosen, and a row counts as violated when
//! it is off by more than a tenth of the tolerance above (so the answer passes the check
//! with room for the final recomputation's rounding). "Infeasible" is reported only with a
//! certificate `y` (`y_p = 1` on the violated row, `−r ≥ 0` on the active inequalities)
//! whose combination of normals `e = Σ y_i n_i` is so small against its bound gap
//! `g = Σ y_i b_i > 0` that every feasible point would lie beyond `10⁶ (1 + ‖z‖_∞)`
//! (`g > 10⁶ (1 + ‖z‖_∞) ‖e‖₁`, `z` the iterate). Without a certificate, a row that
//! depends on the active ones and is violated by no more than the check allows (a vertex
//! of nearly parallel rows, off by their rounding) is left to the check instead of added;
//! one violated by more ends the solve [`DenseStatus::Unverified`].
//!
//! # Budget, bad data, allocation
//!
//! A step is one row added to or dropped from the active set. The budget `max_steps`
//! counts the rows added: a solve that would add one more stops with
//! [`DenseStatus::MaxSteps`] and the (dual-feasible, finite) iterate it reached, whose
//! active set, as a warm start, puts the next solve where this one stopped — so a small
//! budget still makes progress from solve to solve. (The drops an addition makes on the
//! way, at most one per active row, are not budgeted: counting them, a budget below one
//! addition's drops would stop every solve at the same place.) The budget bounds the work
//! too: [`DualActiveSet::work`] counts a solve's inner-loop trips as it runs, and
//! [`DualActiveSet::worst_case_work`] states the most any solve of a size and budget can
//! take (every loop at its longest, each run as often as the method allows; checked on
//! 18 000 random solves, the largest of which used 27 % of it). NaN in any datum, or an infinite entry of `q` or `A`, gives
//! [`DenseStatus::NonFiniteData`] before any arithmetic; a solve never panics and never
//! hands back a non-finite point. Nothing allocates after [`DualActiveSet::new`].
//!
//! # Example
//!
//! `min (z₁ − 2)² + (z₂ − 2)²` (i.e. `P = 2I`, `q = (−4, −4)`) subject to `z₁ + z₂ ≤ 2` and
//! `0 ≤ z₁ ≤ 0.5`. On the line `z₁ + z₂ = 2` the closest point to `(2, 2)` is `(1, 1)`,
//! which breaks `z₁ ≤ 0.5`; with both rows binding, `z = (0.5, 1.5)`, the gradient there is
//! `(−3, −1)`, and `(3, 1) = y₁ (1, 1) + y₂ (1, 0)` gives `y = (1, 2)`, both ≥ 0 as two
//! active upper bounds need: the optimum.
//!
//! ```
//! use cbfgen::qp::dual_active_set::{DenseStatus, DualActiveSet, WarmStart};
//!
//! let hessian = [2.0, 0.0, 0.0, 2.0]; // row-major; only the upper triangle is read
//! let mut qp = DualActiveSet::new(&hessian, 2, 2)?;
//! let data = qp.data_mut();
//! data.q.copy_from_slice(&[-4.0, -4.0]);
//! data.a.copy_from_slice(&[1.0, 1.0, /* second row */ 1.0, 0.0]); // row-major
//! data.lower.copy_from_slice(&[f64::NEG_INFINITY, 0.0]);
//! data.upper.copy_from_slice(&[2.0, 0.5]);
//! assert_eq!(qp.solve(WarmStart::Cold, 100), DenseStatus::Solved);
//! let z = qp.solution();
//! assert!((z[0] - 0.5).abs() < 1e-12 && (z[1] - 1.5).abs() < 1e-12);
//! let y = qp.row_multipliers();
//! assert!((y[0] - 1.0).abs() < 1e-12 && (y[1] - 2.0).abs() < 1e-12);
//! // Warm-started from its own active set, the same answer without a single step.
//! assert_eq!(qp.solve(WarmStart::Previous, 100), DenseStatus::Solved);
//! assert_eq!(qp.steps(), 0);
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

use super::QpStatus;
pub use super::INFINITY;
use crate::error::CbfError;

/// `ε` of the KKT check (see the module docs): relative to the size of the terms.
pub const KKT_TOLERANCE: f64 = 1e-9;

/// The stationarity check's floor, as a fraction of the largest gradient term (all in
/// units of `√P_jj`-scaled variables): see the module docs.
const STATIONARITY_FLOOR: f64 = 1e-4;

/// A row counts as violated, and is added, beyond this fraction of the KKT tolerance.
const SELECT_FRACTION: f64 = 0.1;

/// A row whose normal keeps less than this fraction of its length outside the span of the
/// active normals (in the metric of `P⁻¹`) is treated as linearly dependent on them.
const DEPENDENCE_TOLERANCE: f64 = 1e-10;

/// A multiplier more negative than this fraction of the largest is dropped; a smaller
/// negative one is rounding and reads as 0.
const NEGATIVE_MULTIPLIER_FRACTION: f64 = 1e-12;

/// Infeasibility is certified when feasible points would have to lie this many times
/// farther out than the iterate (see the module docs).
const CERTIFICATE_REACH: f64 = 1e6;

/// Which bound of a row is active.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Side {
    /// `a_iᵀ z = l_i`.
    Lower,
    /// `a_iᵀ z = u_i`.
    Upper,
}

/// One row of an active set, as [`DualActiveSet::active_set`] reports it and a warm start
/// takes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ActiveRow {
    /// Index of the row in `A`.
    pub row: usize,
    /// The bound it holds at (for an equality row, either).
    pub side: Side,
}

/// Where a solve starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WarmStart<'a> {
    /// From the unconstrained minimum (and the equality rows).
    Cold,
    /// From the active set of the last solve that ended [`DenseStatus::Solved`] (cold if
    /// there was none).
    Previous,
    /// From these rows (a hint: rows out of range, repeated, without the named bound or
    /// beyond the first `n` are left out).
    Given(&'a [ActiveRow]),
}

/// How a solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DenseStatus {
    /// The answer passed the KKT check (module docs).
    Solved,
    /// The rows cannot all hold: a certificate was found and checked.
    Infeasible,
    /// The step budget ran out; [`DualActiveSet::solution`] is the finite iterate reached,
    /// optimal for a subset of the rows but not feasible for all.
    MaxSteps,
    /// The work budget ran out ([`DualActiveSet::solve_within`]); the iterate is as
    /// `MaxSteps` leaves it.
    MaxWork,
    /// The method ended, but its answer failed the KKT check or its infeasibility
    /// certificate failed its check (rounding on a nearly degenerate problem); the
    /// solution is the finite point reached, or zeros.
    Unverified,
    /// NaN in the data, or an infinite entry of `q` or `A`; nothing was computed.
    NonFiniteData,
}

impl DenseStatus {
    /// The crate's QP status for this outcome: `Solved`; `PrimalInfeasible`;
    /// `MaxIterations` for an iterate that is not a verified optimum (out of steps or
    /// unverified); `NonFinite` for bad data.
    pub fn qp_status(self) -> QpStatus {
        match self {
            DenseStatus::Solved => QpStatus::Solved,
            DenseStatus::Infeasible => QpStatus::PrimalInfeasible,
            DenseStatus::MaxSteps | DenseStatus::MaxWork | DenseStatus::Unverified => QpStatus::MaxIterations,
            DenseStatus::NonFiniteData => QpStatus::NonFinite,
        }
    }
}

/// The problem's data, to be written before each [`DualActiveSet::solve`]; sizes fixed.
#[derive(Debug)]
pub struct QpData<'a> {
    /// The linear cost, `n` entries.
    pub q: &'a mut [f64],
    /// `A`, row-major, `m × n` entries.
    pub a: &'a mut [f64],
    /// `l`, `m` entries (`−∞` or ≤ −1e30 for none).
    pub lower: &'a mut [f64],
    /// `u`, `m` entries (`+∞` or ≥ 1e30 for none).
    pub upper: &'a mut [f64],
}

/// An active row inside a solve: the row, the sign of its normal (+1: `a_iᵀz ≥ l_i`;
/// −1: `−a_iᵀz ≥ −u_i`), and whether it is an equality (never dropped, any multiplier sign).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Constraint {
    row: usize,
    sign: f64,
    equality: bool,
}

impl Constraint {
    fn side(&self) -> Side {
        if self.sign > 0.0 {
            Side::Lower
        } else {
            Side::Upper
        }
    }
}

/// The most work (trips) each primitive of a solve of `n` variables and at most `m` rows
/// in use counts, with every loop at its longest (`q ≤ n` active rows): what
/// [`DualActiveSet::worst_case_work`] and [`DualActiveSet::work_overshoot`] add up. Each is
/// the largest increment the primitive adds to [`DualActiveSet::work`].
struct Primitives {
    /// Checking and normalising the rows.
    prepare: u64,
    /// The equality rows' and the warm start's seeding projections and pushes.
    seeding: u64,
    /// Pushing one row onto the factorisation.
    push: u64,
    /// Dropping one row from it.
    drop: u64,
    /// The equality-constrained optimum of the active set.
    optimum: u64,
    /// The search for the most negative multiplier.
    negative: u64,
    /// The search for the most violated row.
    violated: u64,
    /// One step inside an addition.
    inner: u64,
    /// Checking an infeasibility certificate.
    certificate: u64,
    /// The final KKT check.
    verify: u64,
}

impl Primitives {
    fn of(vars: usize, rows: usize) -> Self {
        let (n, m) = (vars as u64, rows as u64);
        let project = n + n * n;
        let push = (n + 1) * n + n + 1;
        Self {
            prepare: n + m * (4 * n + 2),
            seeding: (m + n) * project + n * push,
            push,
            drop: n * (3 * n + 1),
            optimum: 3 * n * n + 2 * n,
            negative: 2 * n,
            violated: m * (n + 1),
            inner: 3 * n * n + 6 * n,
            certificate: n * n + 6 * n,
            verify: 2 * n + m * (n + 1) + n * (2 * n + 1),
        }
    }
}

/// What ended the inner loop that adds one violated row.
enum AddOutcome {
    Added,
    Infeasible,
    NotCertified,
}

/// The solver: the problem's data, `P`'s factor, and every buffer a solve uses.
#[derive(Debug, Clone)]
pub struct DualActiveSet {
    n: usize,
    m: usize,
    /// Rows in use: the first `live` of the `m` (see [`DualActiveSet::set_rows_in_use`]).
    live: usize,
    /// `P`, full symmetric, row-major (mirrored from the upper triangle given).
    hessian: Vec<f64>,
    /// `L⁻ᵀ` for `P = L Lᵀ`, column-major: the `J` every solve starts from.
    j_start: Vec<f64>,
    q: Vec<f64>,
    /// `A` as given, row-major.
    a: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    /// Each row divided by its norm (row-major), and the norms.
    unit: Vec<f64>,
    norm: Vec<f64>,
    /// Normalised bounds, `−∞`/`+∞` where there is none.
    unit_lower: Vec<f64>,
    unit_upper: Vec<f64>,
    /// Whether each row is in the active set.
    is_active: Vec<bool>,
    /// Rows violated within the KKT tolerance that cannot be added (dependent on the active
    /// rows, without a certificate): left out of the search, left to the check.
    tolerated: Vec<bool>,
    /// `J = L⁻ᵀ Q`, column-major `n × n`.
    j: Vec<f64>,
    /// `R`, column-major `n × n`, upper triangle of the first `active.len()` columns.
    r: Vec<f64>,
    /// The active set, in the order of `R`'s columns (capacity `n`).
    active: Vec<Constraint>,
    /// Their multipliers (for the normalised, signed normals), same order.
    u: Vec<f64>,
    /// The iterate.
    x: Vec<f64>,
    /// The non-zero entries' indices of the row being projected.
    nonzero: Vec<usize>,
    /// Scratch: `Jᵀ n_p`, the primal step, the dual step, and two more.
    d: Vec<f64>,
    step: Vec<f64>,
    dual_step: Vec<f64>,
    w: Vec<f64>,
    c: Vec<f64>,
    /// Per row, OSQP's multiplier convention: `P z + q + Aᵀ y = 0`.
    y: Vec<f64>,
    /// The active set of the last solved problem, or a given warm start.
    warm: Vec<ActiveRow>,
    /// The rows reported by [`DualActiveSet::active_set`].
    report: Vec<ActiveRow>,
    steps: u32,
    /// Rows added in this solve: what the budget counts.
    added: u32,
    /// Work of this solve, in inner-loop trips ([`DualActiveSet::work`]).
    work: u64,
    status: DenseStatus,
}

impl DualActiveSet {
    /// A solver for `vars` variables and `rows` rows with cost matrix `hessian` (`vars ×
    /// vars`, row-major; only the upper triangle is read, like OSQP). The data start at
    /// zero with every bound at ±∞. Allocates every buffer a solve will use.
    ///
    /// # Errors
    /// `vars == 0`, a `hessian` of the wrong length, a non-finite entry, or a matrix that
    /// is not positive definite to working precision (see [`DualActiveSet::set_hessian`]).
    pub fn new(hessian: &[f64], vars: usize, rows: usize) -> Result<Self, CbfError> {
        if vars == 0 {
            return Err(CbfError::NotPositive { what: "QP variables", value: 0.0 });
        }
        let (n, m) = (vars, rows);
        let mut solver = Self {
            n,
            m,
            live: m,
            hessian: vec![0.0; n * n],
            j_start: vec![0.0; n * n],
            q: vec![0.0; n],
            a: vec![0.0; m * n],
            lower: vec![f64::NEG_INFINITY; m],
            upper: vec![f64::INFINITY; m],
            unit: vec![0.0; m * n],
            norm: vec![0.0; m],
            unit_lower: vec![f64::NEG_INFINITY; m],
            unit_upper: vec![f64::INFINITY; m],
            is_active: vec![false; m],
            tolerated: vec![false; m],
            j: vec![0.0; n * n],
            r: vec![0.0; n * n],
            active: Vec::with_capacity(n),
            u: Vec::with_capacity(n),
            x: vec![0.0; n],
            nonzero: Vec::with_capacity(n),
            d: vec![0.0; n],
            step: vec![0.0; n],
            dual_step: vec![0.0; n],
            w: vec![0.0; n],
            c: vec![0.0; n],
            y: vec![0.0; m],
            warm: Vec::with_capacity(n),
            report: Vec::with_capacity(n),
            steps: 0,
            added: 0,
            work: 0,
            status: DenseStatus::Unverified,
        };
        solver.set_hessian(hessian)?;
        Ok(solver)
    }

    /// Replace `P` (row-major, upper triangle read) and factorise it: `P = L Lᵀ`, then
    /// `J = L⁻ᵀ`. Does not allocate. On an error the previous `P` is kept.
    ///
    /// # Errors
    /// Wrong length, a non-finite entry, or a Cholesky pivot `L_kk² ≤ 1e-14 P_kk` (not
    /// positive definite to working precision: a condition number beyond about 10¹⁴).
    pub fn set_hessian(&mut self, hessian: &[f64]) -> Result<(), CbfError> {
        let n = self.n;
        if hessian.len() != n * n {
            return Err(CbfError::LengthMismatch { what: "QP Hessian", expected: n * n, got: hessian.len() });
        }
        for row in 0..n {
            for col in row..n {
                crate::error::finite("QP Hessian entry", hessian[row * n + col])?;
            }
        }
        // Cholesky into `r` (scratch between solves), lower triangle, row-major.
        let l = &mut self.r;
        for i in 0..n {
            for k in 0..=i {
                // P is read from its upper triangle: P_ik = hessian[min·n + max].
                let mut v = hessian[k * n + i];
                for t in 0..k {
                    v -= l[i * n + t] * l[k * n + t];
                }
                if k == i {
                    let diagonal = hessian[i * n + i];
                    // NaN fails the comparison too.
                    let positive = v > 1e-14 * diagonal && v.is_finite();
                    if !positive {
                        return Err(CbfError::NotPositive { what: "QP Hessian Cholesky pivot", value: v });
                    }
                    l[i * n + i] = v.sqrt();
                } else {
                    l[i * n + k] = v / l[k * n + k];
                }
            }
        }
        // J = L⁻ᵀ, column-major: J[row, col] sits at j_start[col·n + row] and equals
        // (L⁻¹)[col, row], so (L⁻¹)[i, c] sits at j_start[i·n + c]. Column c of L⁻¹ by
        // forward substitution, L (L⁻¹)[·, c] = e_c.
        let j = &mut self.j_start;
        j.fill(0.0);
        for c in 0..n {
            // (L⁻¹)[i, c] for i ≥ c.
            for i in c..n {
                let mut v = if i == c { 1.0 } else { 0.0 };
                for t in c..i {
                    v -= l[i * n + t] * j[t * n + c];
                }
                j[i * n + c] = v / l[i * n + i];
            }
        }
        for row in 0..n {
            for col in row..n {
                let v = hessian[row * n + col];
                self.hessian[row * n + col] = v;
                self.hessian[col * n + row] = v;
            }
        }
        self.warm.clear();
        Ok(())
    }

    /// Number of variables `n`.
    pub fn vars(&self) -> usize {
        self.n
    }

    /// Number of rows `m`.
    pub fn rows(&self) -> usize {
        self.m
    }

    /// Solve with only the first `rows` rows (at most `m`): the others are ignored, data
    /// and all, until this is called again. For a caller that packs the rows it needs this
    /// time at the front, so that a solve costs what they cost, not what the capacity does.
    pub fn set_rows_in_use(&mut self, rows: usize) {
        self.live = rows.min(self.m);
    }

    /// The data to write before a solve (kept between solves).
    pub fn data_mut(&mut self) -> QpData<'_> {
        QpData { q: &mut self.q, a: &mut self.a, lower: &mut self.lower, upper: &mut self.upper }
    }

    /// `A` as last written, row-major (`m × n`).
    pub fn constraints(&self) -> &[f64] {
        &self.a
    }

    /// `P`, full and row-major, as factorised.
    pub fn hessian(&self) -> &[f64] {
        &self.hessian
    }

    /// The last solve's point: the optimum when [`DenseStatus::Solved`], the iterate reached
    /// when `MaxSteps` or `Unverified`; always finite.
    pub fn solution(&self) -> &[f64] {
        &self.x
    }

    /// The last solve's multipliers, one per row, in OSQP's convention `P z + q + Aᵀ y = 0`
    /// (`y_i ≤ 0` at a lower bound, `≥ 0` at an upper bound, 0 on inactive rows).
    pub fn row_multipliers(&self) -> &[f64] {
        &self.y
    }

    /// The last solve's active set (the rows holding at a bound, in the order they entered).
    pub fn active_set(&self) -> &[ActiveRow] {
        &self.report
    }

    /// Active-set changes (rows added or dropped) the last solve took.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// The last solve's work, counted as it ran: the trips of its inner loops, each a
    /// multiply–add or a few flops on one entry of a row, a column or a factor. Never above
    /// [`DualActiveSet::worst_case_work`] for its size and budget.
    pub fn work(&self) -> u64 {
        self.work
    }

    /// The most work ([`DualActiveSet::work`]) one solve of `vars` variables and at most
    /// `rows` rows in use can take when it may add `max_steps` rows, whatever its data and
    /// warm start: every loop at its longest (`q ≤ n` active rows, every row live), and
    /// each loop run as often as the method allows —
    /// * at most `rows + vars` seeding projections (the equality rows and the warm start's),
    /// * at most `max_steps + 1 + rows` passes of the outer loop (one per row added, the
    ///   last, one per row left to the check),
    /// * at most `vars + max_steps` drops in all (a row leaves only after it came in: a
    ///   seed or an addition),
    /// * at most `3·max_steps + vars + 1 + rows` steps inside the additions (each ends in
    ///   an addition, a drop, or the end of its addition).
    pub fn worst_case_work(vars: usize, rows: usize, max_steps: u32) -> u64 {
        let w = Primitives::of(vars, rows);
        let (n, m, s) = (vars as u64, rows as u64, u64::from(max_steps));
        let (outer, drops, steps) = (s + 1 + m, n + s, 3 * s + n + 1 + m);
        w.prepare
            + w.seeding
            + outer * (w.optimum + w.negative + w.violated + w.certificate)
            + drops * (w.drop + w.optimum + w.negative)
            + steps * w.inner
            + s * w.push
            + w.verify
    }

    /// The most work a solve can do past a work budget it checks
    /// ([`DualActiveSet::solve_within`]): the set-up and seeding it does before its first
    /// check, the one addition (with every drop on its way, at most one per active row) and
    /// the pass of drops and search after the last check, and the final verification. A
    /// solve of `vars` variables and at most `rows` rows within `max_work` therefore never
    /// works more than `max_work + work_overshoot(vars, rows)`.
    pub fn work_overshoot(vars: usize, rows: usize) -> u64 {
        let w = Primitives::of(vars, rows);
        let n = vars as u64;
        // An addition: up to n partial steps, each dropping a row, then the full step.
        let addition = (n + 1) * w.inner + n * w.drop + w.push + w.certificate + n;
        // The pass after it: its drops back to dual feasibility, and the search.
        let pass = (n + 1) * (w.optimum + w.negative) + n * w.drop + w.violated;
        w.prepare + w.seeding + pass + addition + pass + w.verify
    }

    /// Rows the last solve added to the active set: what `max_steps` bounds.
    pub fn rows_added(&self) -> u32 {
        self.added
    }

    /// How the last solve ended.
    pub fn status(&self) -> DenseStatus {
        self.status
    }

    /// Solve the QP in its current data from `start`, adding at most `max_steps` rows to
    /// the active set (module docs). Does not allocate.
    pub fn solve(&mut self, start: WarmStart<'_>, max_steps: u32) -> DenseStatus {
        self.solve_within(start, max_steps, u64::MAX)
    }

    /// [`DualActiveSet::solve`] that also stops, [`DenseStatus::MaxWork`], once its work
    /// ([`DualActiveSet::work`]) has reached `max_work`. The budget is checked where the
    /// step budget is, before each addition, so the iterate it stops at is dual feasible
    /// and a warm start from it goes on; the most a solve does past it is
    /// [`DualActiveSet::work_overshoot`]. Does not allocate.
    pub fn solve_within(&mut self, start: WarmStart<'_>, max_steps: u32, max_work: u64) -> DenseStatus {
        self.steps = 0;
        self.added = 0;
        self.work = 0;
        self.status = self.run(start, max_steps, max_work);
        if !self.x.iter().all(|v| v.is_finite()) {
            self.x.fill(0.0);
            if self.status != DenseStatus::NonFiniteData {
                self.status = DenseStatus::Unverified;
            }
        }
        self.report.clear();
        self.report.extend(self.active.iter().map(|c| ActiveRow { row: c.row, side: c.side() }));
        if self.status == DenseStatus::Solved {
            self.warm.clear();
            self.warm.extend_from_slice(&self.report);
        } else {
            self.y.fill(0.0);
        }
        self.status
    }

    fn run(&mut self, start: WarmStart<'_>, max_steps: u32, max_work: u64) -> DenseStatus {
        if let Some(status) = self.prepare_rows() {
            self.x.fill(0.0);
            self.active.clear();
            return status;
        }
        // Equality rows first (they are never dropped), then the warm start's rows. The
        // last solved set is taken out for the seeding and put back (no allocation).
        self.j.copy_from_slice(&self.j_start);
        self.active.clear();
        self.u.clear();
        self.is_active.fill(false);
        self.tolerated.fill(false);
        for row in 0..self.live {
            if self.norm[row] > 0.0 && self.unit_lower[row] == self.unit_upper[row] {
                self.seed(Constraint { row, sign: 1.0, equality: true });
            }
        }
        let previous = std::mem::take(&mut self.warm);
        let hint: &[ActiveRow] = match start {
            WarmStart::Cold => &[],
            WarmStart::Previous => &previous,
            WarmStart::Given(rows) => rows,
        };
        for &ActiveRow { row, side } in hint.iter().take(self.n) {
            if row >= self.live || self.is_active[row] || self.norm[row] == 0.0 {
                continue;
            }
            let (lower, upper) = (self.unit_lower[row], self.unit_upper[row]);
            let sign = match side {
                Side::Lower if lower > f64::NEG_INFINITY => 1.0,
                Side::Upper if upper < f64::INFINITY => -1.0,
                _ => continue,
            };
            self.seed(Constraint { row, sign, equality: lower == upper });
        }
        self.warm = previous;
        loop {
            // x and u for the active set as equalities; drop rows with negative multipliers
            // until the pair is dual feasible (only a warm start or rounding needs this).
            loop {
                self.equality_optimum();
                self.work += 2 * self.active.len() as u64;
                let Some(k) = self.most_negative_multiplier() else { break };
                self.steps += 1;
                self.drop_active(k);
            }
            self.work += (self.live * (self.n + 1)) as u64;
            let Some(p) = self.most_violated() else {
                return self.verify();
            };
            // Out of budget before the addition starts, not half-way through its drops, so
            // the active set reached is dual feasible and a warm start from it goes on.
            if self.added >= max_steps {
                return DenseStatus::MaxSteps;
            }
            if self.work >= max_work {
                return DenseStatus::MaxWork;
            }
            match self.add(p) {
                AddOutcome::Added => {}
                AddOutcome::Infeasible => return DenseStatus::Infeasible,
                // A dependent row off by less than the check allows is rounding of the
                // rows it depends on (a vertex of nearly parallel rows): the check decides.
                AddOutcome::NotCertified if self.within_check(p) => {
                    self.work += self.n as u64;
                    self.tolerated[p.row] = true;
                }
                AddOutcome::NotCertified => return DenseStatus::Unverified,
            }
        }
    }

    /// Check the data and normalise the rows. `Some(status)` when the solve ends here.
    fn prepare_rows(&mut self) -> Option<DenseStatus> {
        let n = self.n;
        let live = self.live;
        self.work += (n + live * (4 * n + 2)) as u64;
        if !self.q.iter().chain(&self.a[..live * n]).all(|v| v.is_finite())
            || self.lower[..live].iter().chain(&self.upper[..live]).any(|v| v.is_nan())
        {
            return Some(DenseStatus::NonFiniteData);
        }
        let mut infeasible = false;
        for i in 0..self.live {
            let row = &self.a[i * n..(i + 1) * n];
            let (lower, upper) = (self.lower[i], self.upper[i]);
            let has_lower = lower > -INFINITY;
            let has_upper = upper < INFINITY;
            // A lower bound at +∞ or an upper one at −∞ cannot hold; nor can l > u.
            infeasible |= lower >= INFINITY || upper <= -INFINITY || (has_lower && has_upper && lower > upper);
            // Euclidean norm without overflow or underflow: scaled by the largest entry
            // when squaring could leave double precision's range.
            let largest = row.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let norm = if (1e-100..=1e100).contains(&largest) {
                row.iter().map(|v| v * v).sum::<f64>().sqrt()
            } else if largest > 0.0 {
                let inverse = 1.0 / largest;
                largest * row.iter().map(|v| (v * inverse) * (v * inverse)).sum::<f64>().sqrt()
            } else {
                0.0
            };
            self.norm[i] = norm;
            if norm == 0.0 {
                // 0 must lie within the bounds.
                infeasible |= (has_lower && lower > 0.0) || (has_upper && upper < 0.0);
                self.unit[i * n..(i + 1) * n].fill(0.0);
                (self.unit_lower[i], self.unit_upper[i]) = (f64::NEG_INFINITY, f64::INFINITY);
                continue;
            }
            let inverse = 1.0 / norm;
            for (unit, v) in self.unit[i * n..(i + 1) * n].iter_mut().zip(row) {
                *unit = v * inverse;
            }
            // A bound that overflows when divided by a tiny norm stays an (unreachable) bound.
            self.unit_lower[i] = if has_lower { lower / norm } else { f64::NEG_INFINITY };
            self.unit_upper[i] = if has_upper { upper / norm } else { f64::INFINITY };
            if lower == upper && has_lower {
                self.unit_upper[i] = self.unit_lower[i];
            }
        }
        infeasible.then_some(DenseStatus::Infeasible)
    }

    /// Normalised signed normal of `c`, entry `k`.
    fn normal(&self, c: Constraint) -> &[f64] {
        &self.unit[c.row * self.n..(c.row + 1) * self.n]
    }

    /// The bound of `c` in its normalised, signed form: `n_cᵀ z ≥ b_c`.
    fn bound(&self, c: Constraint) -> f64 {
        if c.sign > 0.0 {
            self.unit_lower[c.row]
        } else {
            -self.unit_upper[c.row]
        }
    }

    /// `d = Jᵀ n_c`; returns `(‖d‖, ‖d₂‖)`, `d₂` the part beyond the active columns.
    fn project(&mut self, c: Constraint) -> (f64, f64) {
        let n = self.n;
        let q = self.active.len();
        // Rows are often sparse (an input bound has one entry, a robot's row a few): sum
        // over the non-zeros only.
        let normal = &self.unit[c.row * n..(c.row + 1) * n];
        self.nonzero.clear();
        self.nonzero.extend((0..n).filter(|&i| normal[i] != 0.0));
        self.work += (n + n * self.nonzero.len()) as u64;
        let (mut all, mut free) = (0.0, 0.0);
        for k in 0..n {
            let col = &self.j[k * n..(k + 1) * n];
            let v = c.sign * self.nonzero.iter().map(|&i| col[i] * normal[i]).sum::<f64>();
            self.d[k] = v;
            all += v * v;
            if k >= q {
                free += v * v;
            }
        }
        (all.sqrt(), free.sqrt())
    }

    /// Put `c` into the factorisation without moving `x` (seeding): skipped when it is
    /// linearly dependent on the rows already in, or the set is full.
    fn seed(&mut self, c: Constraint) {
        if self.active.len() >= self.n {
            return;
        }
        let (all, free) = self.project(c);
        if free > DEPENDENCE_TOLERANCE * all {
            self.push_active(c, 0.0);
        }
    }

    /// Append `c` to the active set, `d = Jᵀ n_c` already computed: rotate `d`'s tail
    /// into its entry `q` (the same rotations on `J`'s columns), and make `d[..=q]` the new
    /// column of `R`.
    fn push_active(&mut self, c: Constraint, multiplier: f64) {
        let n = self.n;
        let q = self.active.len();
        for k in (q + 1..n).rev() {
            let (a, b) = (self.d[k - 1], self.d[k]);
            if b == 0.0 {
                continue;
            }
            let h = a.hypot(b);
            let (cos, sin) = (a / h, b / h);
            self.work += n as u64 + 1;
            self.d[k - 1] = h;
            self.d[k] = 0.0;
            let (left, right) = self.j.split_at_mut(k * n);
            rotate(&mut left[(k - 1) * n..], &mut right[..n], cos, sin);
        }
        self.r[q * n..q * n + q + 1].copy_from_slice(&self.d[..=q]);
        self.work += q as u64 + 1;
        self.active.push(c);
        self.u.push(multiplier);
        self.is_active[c.row] = true;
    }

    /// Remove the `k`-th active row: shift `R`'s later columns left and restore the
    /// triangle with rotations of neighbouring rows (applied to `J`'s columns too).
    fn drop_active(&mut self, k: usize) {
        let n = self.n;
        let q = self.active.len();
        self.is_active[self.active[k].row] = false;
        self.active.remove(k);
        self.u.remove(k);
        for col in k..q - 1 {
            self.r.copy_within((col + 1) * n..(col + 1) * n + col + 2, col * n);
            self.work += col as u64 + 2;
        }
        // Column `col` (≥ k) now has a sub-diagonal entry at `col + 1`.
        for col in k..q - 1 {
            let (a, b) = (self.r[col * n + col], self.r[col * n + col + 1]);
            if b == 0.0 {
                continue;
            }
            let h = a.hypot(b);
            let (cos, sin) = (a / h, b / h);
            self.work += (q - col + n + 1) as u64;
            self.r[col * n + col] = h;
            self.r[col * n + col + 1] = 0.0;
            for later in col + 1..q - 1 {
                let (ra, rb) = (self.r[later * n + col], self.r[later * n + col + 1]);
                self.r[later * n + col] = cos * ra + sin * rb;
                self.r[later * n + col + 1] = -sin * ra + cos * rb;
            }
            let (left, right) = self.j.split_at_mut((col + 1) * n);
            rotate(&mut left[col * n..], &mut right[..n], cos, sin);
        }
    }

    /// The optimum with the active rows as equalities, and its multipliers:
    /// `x = J₁ R⁻ᵀ b − J₂ J₂ᵀ q`, `u = R⁻¹ (R⁻ᵀ b + J₁ᵀ q)`. Recomputed from the factors
    /// (not accumulated over steps), so rounding does not build up.
    fn equality_optimum(&mut self) {
        let n = self.n;
        let q = self.active.len();
        self.work += (q * q + q + 2 * n * n + n) as u64;
        // w = R⁻ᵀ b (forward substitution with Rᵀ).
        for i in 0..q {
            let mut v = self.bound(self.active[i]);
            for k in 0..i {
                v -= self.r[i * n + k] * self.w[k];
            }
            self.w[i] = v / self.r[i * n + i];
        }
        for k in 0..n {
            self.c[k] = dot(&self.j[k * n..(k + 1) * n], &self.q);
        }
        self.x.fill(0.0);
        for k in 0..n {
            let coef = if k < q { self.w[k] } else { -self.c[k] };
            axpy(&mut self.x, coef, &self.j[k * n..(k + 1) * n]);
        }
        for i in 0..q {
            self.w[i] += self.c[i];
        }
        back_substitute(&self.r, n, q, &mut self.w);
        self.u.copy_from_slice(&self.w[..q]);
    }

    /// The inequality with the most negative multiplier beyond rounding; smaller negatives
    /// are set to 0.
    fn most_negative_multiplier(&mut self) -> Option<usize> {
        let largest = self.u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut worst: Option<usize> = None;
        for (k, c) in self.active.iter().enumerate() {
            if c.equality || self.u[k] >= 0.0 {
                continue;
            }
            if self.u[k] >= -NEGATIVE_MULTIPLIER_FRACTION * largest {
                self.u[k] = 0.0;
            } else if worst.is_none_or(|w| self.u[k] < self.u[w]) {
                worst = Some(k);
            }
        }
        worst
    }

    /// `n_cᵀ x − b_c` and the tolerance it is held to.
    fn slack(&self, c: Constraint) -> (f64, f64) {
        let normal = self.normal(c);
        let (mut value, mut size) = (0.0, 0.0);
        for (a, x) in normal.iter().zip(&self.x) {
            value += a * x;
            size += a.abs() * (1.0 + x.abs());
        }
        let b = self.bound(c);
        (c.sign * value - b, KKT_TOLERANCE * SELECT_FRACTION * (b.abs() + size))
    }

    /// The inactive row violated the most (normalised units) beyond its tolerance, with
    /// the bound it breaks.
    fn most_violated(&self) -> Option<Constraint> {
        let n = self.n;
        let mut best: Option<(Constraint, f64)> = None;
        for row in 0..self.live {
            if self.is_active[row] || self.tolerated[row] || self.norm[row] == 0.0 {
                continue;
            }
            let (mut value, mut size) = (0.0, 0.0);
            for (a, x) in self.unit[row * n..(row + 1) * n].iter().zip(&self.x) {
                value += a * x;
                size += a.abs() * (1.0 + x.abs());
            }
            let (lower, upper) = (self.unit_lower[row], self.unit_upper[row]);
            let tolerance = |bound: f64| KKT_TOLERANCE * SELECT_FRACTION * (bound.abs() + size);
            let equality = lower == upper;
            // At most one side is violated (l ≤ u); an absent bound is ±∞ and never is.
            let (violation, sign, bound) =
                if lower - value > 0.0 { (lower - value, 1.0, lower) } else { (value - upper, -1.0, upper) };
            if violation > tolerance(bound) && best.is_none_or(|(_, worst)| violation > worst) {
                best = Some((Constraint { row, sign, equality }, violation));
            }
        }
        best.map(|(c, _)| c)
    }

    /// Steps of the dual method that make the violated row `p` active (dropping rows on
    /// the way), from a dual-feasible pair.
    fn add(&mut self, p: Constraint) -> AddOutcome {
        let n = self.n;
        let mut multiplier = 0.0;
        loop {
            let q = self.active.len();
            // The step, the dual step's substitution, the scan, the slack, the move.
            self.work += ((n - q) * n + q * q + 2 * q + 3 * n + q) as u64;
            let (all, free) = self.project(p);
            // Primal step direction z = J₂ d₂ and dual step r = R⁻¹ d₁.
            self.step.fill(0.0);
            for k in q..n {
                let coef = self.d[k];
                axpy(&mut self.step, coef, &self.j[k * n..(k + 1) * n]);
            }
            self.dual_step[..q].copy_from_slice(&self.d[..q]);
            back_substitute(&self.r, n, q, &mut self.dual_step);
            // Partial step: the largest move keeping every inequality multiplier ≥ 0.
            let mut partial = f64::INFINITY;
            let mut blocking = None;
            for k in 0..q {
                let r = self.dual_step[k];
                if !self.active[k].equality && r > 0.0 {
                    let t = self.u[k] / r;
                    if t < partial {
                        (partial, blocking) = (t, Some(k));
                    }
                }
            }
            let dependent = free <= DEPENDENCE_TOLERANCE * all;
            let (slack, _) = self.slack(p);
            // zᵀ n_p = ‖d₂‖², the full step makes row p hold.
            let full = if dependent { f64::INFINITY } else { -slack / (free * free) };
            let Some(k) = blocking.filter(|_| partial < full) else {
                if dependent {
                    return if self.certified_infeasible(p) {
                        AddOutcome::Infeasible
                    } else {
                        AddOutcome::NotCertified
                    };
                }
                self.steps += 1;
                self.added += 1;
                // Full step: p joins the active set.
                axpy(&mut self.x, full, &self.step);
                for i in 0..q {
                    self.u[i] -= full * self.dual_step[i];
                }
                self.push_active(p, multiplier + full);
                return AddOutcome::Added;
            };
            self.steps += 1;
            // Partial step (a pure dual step when p depends on the active rows), then the
            // blocking row leaves.
            if !dependent {
                axpy(&mut self.x, partial, &self.step);
            }
            for i in 0..q {
                self.u[i] -= partial * self.dual_step[i];
            }
            multiplier += partial;
            self.drop_active(k);
        }
    }

    /// Whether `y = (1 on p, −r on the active rows)` proves the rows infeasible: every
    /// active inequality's weight `−r_k ≥ 0` (so the combination keeps the inequalities'
    /// direction), the bound gap `g = b_p − Σ r_k b_k > 0`, and the combined normal
    /// `e = n_p − Σ r_k n_k` so small that a feasible point would need
    /// `‖z‖_∞ ≥ g / ‖e‖₁ > 10⁶ (1 + ‖x‖_∞)`.
    fn certified_infeasible(&mut self, p: Constraint) -> bool {
        let n = self.n;
        let q = self.active.len();
        self.work += (q + 3 * n + q * (n + 1)) as u64;
        if (0..q).any(|k| !self.active[k].equality && self.dual_step[k] > 0.0) {
            return false;
        }
        let mut gap = self.bound(p);
        self.w.copy_from_slice(&self.unit[p.row * n..(p.row + 1) * n]);
        for v in self.w.iter_mut() {
            *v *= p.sign;
        }
        for k in 0..q {
            let c = self.active[k];
            let r = self.dual_step[k];
            gap -= r * self.bound(c);
            for j in 0..n {
                self.w[j] -= r * c.sign * self.unit[c.row * n + j];
            }
        }
        let residual: f64 = self.w.iter().map(|v| v.abs()).sum();
        let reach = 1.0 + self.x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        gap > 0.0 && gap > CERTIFICATE_REACH * reach * residual
    }

    /// Whether row `p`'s violation at the iterate is within the KKT check's tolerance (on
    /// the data as given).
    fn within_check(&self, p: Constraint) -> bool {
        let n = self.n;
        let row = &self.a[p.row * n..(p.row + 1) * n];
        let (mut value, mut size) = (0.0, 0.0);
        for (a, x) in row.iter().zip(&self.x) {
            value += a * x;
            size += a.abs() * (1.0 + x.abs());
        }
        let bound = if p.sign > 0.0 { self.lower[p.row] } else { self.upper[p.row] };
        p.sign * (bound - value) <= KKT_TOLERANCE * (bound.abs() + size)
    }

    /// The KKT check of the module docs, on the data as given; fills `y`.
    fn verify(&mut self) -> DenseStatus {
        let n = self.n;
        let q = self.active.len();
        self.work += (q + self.live * (n + 1) + n * (n + q + 1) + n) as u64;
        self.y.fill(0.0);
        for (k, c) in self.active.iter().enumerate() {
            // u multiplies the normalised signed normal: P x + q = Σ u n, n = σ a / ‖a‖.
            self.y[c.row] = -self.u[k] * c.sign / self.norm[c.row];
        }
        for i in 0..self.live {
            let row = &self.a[i * n..(i + 1) * n];
            let (mut value, mut size) = (0.0, 0.0);
            for (a, x) in row.iter().zip(&self.x) {
                value += a * x;
                size += a.abs() * (1.0 + x.abs());
            }
            let (lower, upper) = (self.lower[i], self.upper[i]);
            let tolerance = |bound: f64| KKT_TOLERANCE * (bound.abs() + size);
            // False for NaN as well.
            let within = |gap: f64, bound: f64| gap <= tolerance(bound);
            if (lower > -INFINITY && !within(lower - value, lower))
                || (upper < INFINITY && !within(value - upper, upper))
            {
                return DenseStatus::Unverified;
            }
            let y = self.y[i];
            let equality = lower == upper;
            let at_lower = lower > -INFINITY && (value - lower).abs() <= tolerance(lower);
            let at_upper = upper < INFINITY && (value - upper).abs() <= tolerance(upper);
            let consistent = y == 0.0 || equality || (y < 0.0 && at_lower) || (y > 0.0 && at_upper);
            if !consistent || !y.is_finite() {
                return DenseStatus::Unverified;
            }
        }
        // Gradient and the size of its terms per variable, in `w` and `c` (scratch here),
        // both divided by √P_jj so that variables of different weights compare.
        let mut largest: f64 = 0.0;
        for j in 0..n {
            let (mut gradient, mut size) = (self.q[j], self.q[j].abs());
            for k in 0..n {
                let t = self.hessian[j * n + k] * self.x[k];
                gradient += t;
                size += t.abs();
            }
            for c in &self.active {
                let t = self.y[c.row] * self.a[c.row * n + j];
                gradient += t;
                size += t.abs();
            }
            let scale = self.hessian[j * n + j].sqrt();
            (self.w[j], self.c[j]) = (gradient / scale, size / scale);
            largest = largest.max(self.c[j]);
        }
        for j in 0..n {
            // A variable whose own terms nearly vanish still carries the rounding of the
            // others (the factorisation mixes them): a floor of STATIONARITY_FLOOR of the
            // largest term keeps that from failing an exact answer.
            let allowed = KKT_TOLERANCE * (self.c[j] + STATIONARITY_FLOOR * largest);
            if self.w[j].abs() > allowed || self.w[j].is_nan() {
                return DenseStatus::Unverified;
            }
        }
        DenseStatus::Solved
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `y += a x`.
fn axpy(y: &mut [f64], a: f64, x: &[f64]) {
    for (y, x) in y.iter_mut().zip(x) {
        *y += a * x;
    }
}

/// The rotation `[c s; −s c]` applied to two columns: `(a, b) ← (c a + s b, −s a + c b)`.
fn rotate(a: &mut [f64], b: &mut [f64], cos: f64, sin: f64) {
    for (a, b) in a.iter_mut().zip(b.iter_mut()) {
        let (va, vb) = (*a, *b);
        *a = cos * va + sin * vb;
        *b = -sin * va + cos * vb;
    }
}

/// Solve `R v = v` in place for the leading `q × q` upper triangle of column-major `r`.
fn back_substitute(r: &[f64], n: usize, q: usize, v: &mut [f64]) {
    for i in (0..q).rev() {
        let mut s = v[i];
        for k in i + 1..q {
            s -= r[k * n + i] * v[k];
        }
        v[i] = s / r[i * n + i];
    }
}
