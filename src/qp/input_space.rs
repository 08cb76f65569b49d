//! The ECBF QP solved exactly in its `NU` inputs.
//!
//! The filter's QP has one penalised slack per row:
//!
//! ```text
//! minimise   Σ_j w_j (u_j − r_j)² + Σ_i s_i δ_i²
//! subject to a_i·u + b_i + δ_i ≥ 0,   lo ≤ u ≤ hi
//! ```
//!
//! For any `u` the best slack is `δ_i = max(0, −(a_i·u + b_i))`, so the QP is the same as
//!
//! ```text
//! minimise   F(u) = Σ_j w_j (u_j − r_j)² + Σ_i s_i max(0, −(a_i·u + b_i))²   over lo ≤ u ≤ hi:
//! ```
//!
//! a strongly convex, continuously differentiable, piecewise-quadratic function of `NU`
//! variables (17 for Tachyon 3) over a box, however many rows there are. On each piece —
//! a set `V` of violated rows — it is one quadratic with Hessian
//! `H_V = 2 W + 2 Σ_{i∈V} s_i a_i a_iᵀ`, so one Newton step lands on the exact optimum
//! once the right piece and the right saturated inputs are known.
//!
//! # The method, and why this one
//! A semi-smooth Newton / active-set method on `F`, kept inside the box:
//! 1. at `u`, the violated rows give the piece and the gradient; an input at a bound
//!    whose gradient pushes outward is held there, the others are free;
//! 2. the Newton step on the free inputs solves `H_V d = −∇F` (one `NU × NU` Cholesky
//!    factorisation on the stack);
//! 3. an **exact line search** along `d` minimises `F` over the segment that stays in the
//!    box: `F` along a line is a convex piecewise quadratic whose pieces change where a
//!    row's value crosses zero, so the minimiser is found by walking those crossings in
//!    order (at most one visit each) instead of guessing a step length.
//!
//! The held inputs are a working set, as in a primal active-set method: an input joins
//! it when a step runs into its bound, and leaves it only at a point that is optimal on
//! the current face and whose multiplier for that input has the wrong sign (all such
//! inputs at once). (Releasing an input whenever its gradient points inward lets the
//! coupling drag it back to the bound on the next step: a zigzag that approaches the
//! answer only geometrically.) Every step decreases `F` (a Newton direction on a positive
//! definite model, with an exact search), so no face is visited twice with the same rows;
//! once the piece and the held inputs are right the next step is exact. A step budget
//! bounds the work; a solve that has not verified within it says so, and the filter falls
//! back to OSQP.
//!
//! **Rows on their kink.** An exact line search often stops where a row's value crosses
//! zero. There `F` has two curvatures, and the Newton model takes the row's stiffness only
//! if the step moves the row into violation (see `InputSpaceSolver::model`); the test for
//! releasing a held input does the same along the release. A stiff row counted on the
//! side where it does not act shrinks the step to nothing and lets a wrong face pass for
//! optimal.
//!
//! A dual active-set method (Goldfarb–Idnani) was the alternative. It terminates finitely
//! too, but works in the space of the constraints: every violated row adds a slack
//! variable and a rank-one update to an `(NU + k)`-sized factorisation, where this method
//! only ever factorises `NU × NU`, whatever the number of rows. With the slacks
//! eliminated there is also no infeasibility to detect: every `u` in the box has a
//! finite cost.
//!
//! # Warm start
//! The filter's rows keep their places from cycle to cycle, so the previous answer's
//! piece (violated rows) and saturated inputs are a guess at this cycle's: the first step
//! solves that face directly ([`Start::Guess`]). On a 1 kHz loop the guess is usually
//! right and the solve ends after that one step.
//!
//! # When an answer is accepted
//! A point is accepted only when its KKT conditions hold, judged in each input's own
//! units, which no weight or row scale can make loose:
//! * **free inputs**: the Newton step that would still remain, `|d_j|`, is below
//!   [`STEP_TOLERANCE`] `· (1 + |u_j| + |r_j|)`. For stiff rows (`s_i |a_i|²` up to 10¹⁰
//!   here) the gradient carries rounding of `s_i |a_i| · ε |b_i|`, large in gradient
//!   units, but it moves `u` only by that over `2 s_i |a_i|²`, and the Newton step
//!   measures exactly that. (A per-entry gradient test relative to its terms' size is not
//!   enough: a stiff row on its kink inflates every entry's size, and residuals in
//!   directions of small curvature pass.)
//! * **held inputs**: the move a held input would make inward if released, with the free
//!   inputs re-optimised (its pull over the Schur complement of the free block), is below
//!   the same tolerance.
//!
//! Where the rounding of the row values alone moves the step by more than that (stiff
//! rows in conflict, `a` and nearly `−a`, both violated), a step within that rounding
//! counts as zero, but only up to [`ROUNDING_LIMIT`] `· (1 + |u_j| + |r_j|)`: beyond it the
//! point is not accepted at all (rows of `1e150` can end at [`Outcome::StepLimit`] that
//! way, the flagged fallback, rather than with an answer nobody can confirm).
//!
//! The distance to the true optimum is then about the size of the step not taken, in each
//! input's own units. (A tolerance on the row values, as a polish of an ADMM active set
//! uses, is in the wrong units for stiff rows: a row value within `1e-9 |b|` can be a
//! multiplier large enough to move `u` by metres per second squared.)
//!
//! `tests/input_space.rs` checks all of this against Clarabel, exact optima of reduced
//! cases (rational arithmetic) and warm against cold starts, on random and degenerate
//! instances including stiff rows on their kinks and stiff rows in conflict.

use nalgebra::{Cholesky, Const, SMatrix, SVector};

use crate::error::CbfError;

/// A gradient entry within this fraction of its terms' size is zero to rounding (used to
/// pick the starting working set).
const ROUNDING_TOLERANCE: f64 = 1e-13;

/// Relative tolerance of the Newton-step test, in each input's units.
pub const STEP_TOLERANCE: f64 = 1e-10;

/// The most rounding a verified answer may carry, relative to `1 + |u_j| + |r_j|`:
/// a step within the rounding of the row values is accepted as zero only while that
/// rounding is below this (else the point is no answer, only a place where the gradient
/// is noise).
pub const ROUNDING_LIMIT: f64 = 1e-8;

/// A row value within this fraction of its terms' size counts as on its kink (zero).
const KINK_TOLERANCE: f64 = 1e-13;

/// The rounding of a row value, as a fraction of its terms' size (a few units of
/// round-off for the dot product of up to a few dozen terms).
const VALUE_ROUNDING: f64 = 8.0 * f64::EPSILON;

/// One soft row: it holds when `a·u + b ≥ 0`; a violation `δ = −(a·u + b) > 0` costs
/// `weight · δ²`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoftRow<const NU: usize> {
    /// The row's input coefficients (`L_g L_f^{r−1} h` for an ECBF row).
    pub a: [f64; NU],
    /// The row's value at `u = 0` (`L_f^r h + Σ k_i L_f^i h`).
    pub b: f64,
    /// The slack weight `s > 0`.
    pub weight: f64,
}

/// One problem instance, borrowed.
#[derive(Debug, Clone, Copy)]
pub struct Problem<'a, const NU: usize> {
    /// Input weights `w_j > 0`.
    pub weights: &'a [f64; NU],
    /// The nominal input `r`.
    pub u_ref: &'a [f64; NU],
    /// Lower box limits.
    pub input_min: &'a [f64; NU],
    /// Upper box limits (`≥ input_min`).
    pub input_max: &'a [f64; NU],
    /// The soft rows.
    pub rows: &'a [SoftRow<NU>],
}

/// Where an input sits in the answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Bound {
    /// Strictly between its limits, or at one with no pull outward.
    Free,
    /// Held at its lower limit.
    Lower,
    /// Held at its upper limit.
    Upper,
}

/// Where a solve starts.
#[derive(Debug, Clone, Copy)]
pub enum Start<'a, const NU: usize> {
    /// From the nominal input, clipped to the box.
    Cold,
    /// From the optimum of a guessed face: these rows violated (one flag per row), these
    /// inputs held (a previous answer's [`InputSpaceSolver::violated`] and
    /// [`InputSpaceSolver::held`]).
    Guess {
        /// Per row, whether it is guessed violated.
        violated: &'a [bool],
        /// Per input, where it is guessed held.
        held: &'a [Bound; NU],
    },
    /// From a point (another solver's iterate), clipped to the box.
    Point(&'a [f64; NU]),
}

/// How a solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Outcome {
    /// The answer satisfies the KKT conditions (see the [module docs](self)).
    Verified,
    /// The step budget ran out first; the iterate reached is inside the box and no worse
    /// than the start, but not verified.
    StepLimit,
    /// A row value, the gradient or a step was not finite (rows too large for double
    /// precision); no answer.
    NonFinite,
}

/// The solver's workspace: buffers for `capacity` rows, allocated once.
#[derive(Debug, Clone)]
pub struct InputSpaceSolver<const NU: usize> {
    capacity: usize,
    /// Rows of the last solve.
    rows: usize,
    /// `a_i·u + b_i` at the current point.
    value: Vec<f64>,
    /// `|b_i| + Σ_k |a_ik u_k|`: the size of the terms of `value`.
    magnitude: Vec<f64>,
    /// `a_i·d` along the search direction.
    rate: Vec<f64>,
    /// Per row: its curvature is in the Newton model (violated, or on its kink and
    /// violated by the step).
    in_model: Vec<bool>,
    /// Per row: violated at the answer (`a_i·u + b_i < 0`).
    violated: Vec<bool>,
    held: [Bound; NU],
    u: [f64; NU],
    steps: u32,
    outcome: Outcome,
}

impl<const NU: usize> InputSpaceSolver<NU> {
    /// A workspace for problems of up to `capacity` rows.
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity,
            rows: 0,
            value: vec![0.0; capacity],
            magnitude: vec![0.0; capacity],
            rate: vec![0.0; capacity],
            in_model: vec![false; capacity],
            violated: vec![false; capacity],
            held: [Bound::Free; NU],
            u: [0.0; NU],
            steps: 0,
            outcome: Outcome::Verified,
        }
    }

    /// Rows this workspace holds.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Solve `p` from `start` in at most `max_steps` Newton steps (the face solve of
    /// [`Start::Guess`] counts as one). Allocation-free.
    ///
    /// # Errors
    /// More rows than the capacity, a guess of another length, a weight that is not
    /// finite and positive, a box limit that is not finite or `input_min > input_max`, or
    /// a nominal input that is not finite. Nothing changes then. Rows whose values are
    /// not finite are not an error: the outcome is [`Outcome::NonFinite`].
    pub fn solve(&mut self, p: &Problem<'_, NU>, start: Start<'_, NU>, max_steps: u32) -> Result<Outcome, CbfError> {
        check(p, self.capacity)?;
        if let Start::Guess { violated, .. } = start {
            if violated.len() != p.rows.len() {
                return Err(CbfError::LengthMismatch {
                    what: "guessed violated rows",
                    expected: p.rows.len(),
                    got: violated.len(),
                });
            }
        }
        let m = p.rows.len();
        self.steps = 0;
        let mut u = clip(p.u_ref, p);
        // The working set of held inputs: from the guess, or from the first point's
        // gradient. After that an input joins it when a step runs into its bound, and
        // leaves it only at a point optimal on the current face whose multiplier for it
        // has the wrong sign — one at a time, the primal active-set rule that keeps the
        // method from zigzagging between a bound and the inside of the box.
        let mut held_from_gradient = true;
        match start {
            Start::Cold => {}
            Start::Point(x) => {
                if x.iter().all(|v| v.is_finite()) {
                    u = clip(x, p);
                }
            }
            Start::Guess { violated, held } => {
                self.steps = 1;
                if let Some(x) = face_optimum(p, violated, held) {
                    u = clip(&x, p);
                    self.held = *held;
                    held_from_gradient = false;
                }
            }
        }
        self.outcome = loop {
            if !self.evaluate(p, &u) {
                break Outcome::NonFinite;
            }
            let (gradient, scale) = self.gradient(p, &u);
            if !gradient.iter().all(|g| g.is_finite()) {
                break Outcome::NonFinite;
            }
            if held_from_gradient {
                self.hold(p, &u, &gradient, &scale);
                held_from_gradient = false;
            }
            // Optimal on this face when the Newton step that remains is below the step
            // tolerance in each input's units, or within what rounding of the row values
            // can explain (module docs).
            let Some(model) = self.model(p, &gradient) else {
                break Outcome::NonFinite;
            };
            let step = model.step;
            let unit = |j: usize| 1.0 + u[j].abs() + p.u_ref[j].abs();
            let tolerance: [f64; NU] = std::array::from_fn(|j| STEP_TOLERANCE * unit(j));
            let face_optimal = (0..NU).all(|j| step[j].abs() <= tolerance[j])
                || (0..NU).all(|j| step[j].abs() <= tolerance[j] + ROUNDING_LIMIT * unit(j)) && {
                    // Only a step this small can be rounding: worth the inverse it takes.
                    let noise = self.step_rounding(p, &u, &model);
                    (0..NU).all(|j| {
                        let allowance = noise[j].min(ROUNDING_LIMIT * unit(j));
                        step[j].abs() <= tolerance[j] + allowance
                    })
                };
            if face_optimal {
                // Optimal on this face: verified if no held input would rather move inward.
                if self.steps >= max_steps {
                    // Out of budget: verified only if nothing is left to release.
                    let held = self.held;
                    let released = self.release_wrong_bounds(p, &u, &gradient, &model, &tolerance);
                    self.held = held;
                    break if released { Outcome::StepLimit } else { Outcome::Verified };
                }
                if !self.release_wrong_bounds(p, &u, &gradient, &model, &tolerance) {
                    break Outcome::Verified;
                }
                self.steps += 1;
                continue;
            }
            let d = step;
            if self.steps >= max_steps {
                break Outcome::StepLimit;
            }
            self.steps += 1;
            let (reach, blocking) = box_reach(p, &u, &d);
            let Some(j) = blocking.filter(|_| reach <= 0.0) else {
                let t = self.line_search(p, &u, &d, reach);
                if !(t > 0.0 && t.is_finite()) {
                    break Outcome::StepLimit;
                }
                for k in 0..NU {
                    u[k] += t * d[k];
                }
                if let (Some(j), true) = (blocking, t >= reach) {
                    self.hold_at(p, &mut u, j, d[j]);
                }
                u = clip(&u, p);
                continue;
            };
            // The step would leave the box at once through input j's bound: hold it there.
            self.hold_at(p, &mut u, j, d[j]);
        };
        if self.outcome != Outcome::NonFinite {
            self.rows = m;
            self.u = u;
            for i in 0..m {
                self.violated[i] = self.value[i] < 0.0;
            }
        }
        Ok(self.outcome)
    }

    /// Row values `a_i·u + b_i` and their magnitudes at `u`; `false` if one is not finite.
    fn evaluate(&mut self, p: &Problem<'_, NU>, u: &[f64; NU]) -> bool {
        let mut finite = true;
        for (i, row) in p.rows.iter().enumerate() {
            let mut value = row.b;
            let mut magnitude = row.b.abs();
            for (a, x) in row.a.iter().zip(u) {
                let term = a * x;
                value += term;
                magnitude += term.abs();
            }
            self.value[i] = value;
            self.magnitude[i] = magnitude;
            finite &= value.is_finite() && magnitude.is_finite();
        }
        finite
    }

    /// `∇F` at the evaluated point, and the size of its terms per entry.
    fn gradient(&self, p: &Problem<'_, NU>, u: &[f64; NU]) -> ([f64; NU], [f64; NU]) {
        let mut g = [0.0; NU];
        let mut scale = [0.0; NU];
        for j in 0..NU {
            g[j] = 2.0 * p.weights[j] * (u[j] - p.u_ref[j]);
            scale[j] = 2.0 * p.weights[j] * (u[j].abs() + p.u_ref[j].abs());
        }
        for (i, row) in p.rows.iter().enumerate() {
            let value = self.value[i];
            if value < 0.0 {
                let (pull, size) = (2.0 * row.weight * value, 2.0 * row.weight * self.magnitude[i]);
                for j in 0..NU {
                    g[j] += pull * row.a[j];
                    scale[j] += size * row.a[j].abs();
                }
            }
        }
        (g, scale)
    }

    /// The starting working set: each input at a bound whose gradient pushes outward, or
    /// is zero within rounding; the rest free.
    fn hold(&mut self, p: &Problem<'_, NU>, u: &[f64; NU], gradient: &[f64; NU], scale: &[f64; NU]) {
        for j in 0..NU {
            let slack = ROUNDING_TOLERANCE * scale[j];
            // A box of zero width holds its input whatever the gradient says.
            let pinned = p.input_min[j] == p.input_max[j];
            self.held[j] = if pinned || (u[j] <= p.input_min[j] && gradient[j] >= -slack) {
                Bound::Lower
            } else if u[j] >= p.input_max[j] && gradient[j] <= slack {
                Bound::Upper
            } else {
                Bound::Free
            };
        }
    }

    /// The Newton model at the evaluated point: `H_V` over the violated rows and the
    /// rows on their kink that the step would violate, and the step `H_V d = −∇F` on the
    /// free inputs (`d = 0` on held ones); `None` if not finite.
    ///
    /// An exact line search often ends exactly on a kink: a row crossing zero. Such a row
    /// is in the model when the step moves it into violation: left out, its curvature
    /// would be missing from the step, which would run into the same kink again after no
    /// progress — a stall. It is out when the step moves it clear: in, its stiffness
    /// would shrink a step that the function, flat on that side, does not resist, and a
    /// wrong face could pass for optimal. One row's step keeps its sign whether or not
    /// the row is in (Sherman–Morrison: `a·d` only shrinks by `1 + s aᵀH⁻¹a`), so rows the
    /// step clears are dropped until none is left: at most one pass per kink row.
    fn model(&mut self, p: &Problem<'_, NU>, gradient: &[f64; NU]) -> Option<Model<NU>> {
        let violated = hessian_of(p, |i| self.value[i] < -KINK_TOLERANCE * self.magnitude[i]);
        for i in 0..p.rows.len() {
            self.in_model[i] = self.value[i] <= KINK_TOLERANCE * self.magnitude[i];
        }
        let rhs = -SVector::<f64, NU>::from_row_slice(gradient);
        loop {
            let hessian = with_rows(violated, p, |i| self.in_model[i] && self.on_kink(i));
            let factor = factor_free(&hessian, &self.held)?;
            let step = factor.solve(&on_free(&rhs, &self.held));
            if !step.iter().all(|v| v.is_finite()) {
                return None;
            }
            let mut dropped = false;
            for (i, row) in p.rows.iter().enumerate() {
                if self.in_model[i]
                    && self.on_kink(i)
                    && row.a.iter().zip(step.iter()).map(|(a, d)| a * d).sum::<f64>() > 0.0
                {
                    self.in_model[i] = false;
                    dropped = true;
                }
            }
            if !dropped {
                return Some(Model { violated, hessian, factor, step });
            }
        }
    }

    /// Row `i`'s value is zero within the rounding of its terms.
    fn on_kink(&self, i: usize) -> bool {
        self.value[i].abs() <= KINK_TOLERANCE * self.magnitude[i]
    }

    /// Per input, how far rounding can move the Newton step — the accuracy the problem
    /// itself allows. Two sources, each mapped through `H⁻¹` on the free inputs:
    /// * each model row's value carries an error of about `VALUE_ROUNDING · |terms|`,
    ///   which enters the gradient as `2 s_i · error · a_i`;
    /// * each gradient entry is a sum of terms `2 s_i v_i a_ij` that may cancel, with an
    ///   error of about `VALUE_ROUNDING` times their absolute sum (bounded through
    ///   `|H⁻¹|`, since its direction is unknown).
    ///
    /// With conflicting stiff rows (`a` and nearly `−a`, both violated) the second term
    /// moves the optimum along the soft direction between them by more than the step
    /// tolerance: without this allowance the solve would chase rounding until the line
    /// search finds no descent. Where rows are mild both terms are far below the
    /// tolerance, so the allowance never excuses a real step. Only computed when the
    /// plain test fails (one `NU × NU` inverse).
    fn step_rounding(&self, p: &Problem<'_, NU>, u: &[f64; NU], model: &Model<NU>) -> [f64; NU] {
        let inverse = model.factor.inverse();
        let free = |j: usize| self.held[j] == Bound::Free;
        let mut noise = [0.0; NU];
        let mut sum_rounding: [f64; NU] =
            std::array::from_fn(|k| VALUE_ROUNDING * 2.0 * p.weights[k] * (u[k].abs() + p.u_ref[k].abs()));
        for (i, row) in p.rows.iter().enumerate() {
            if !self.in_model[i] {
                continue;
            }
            let direction = inverse * on_free(&SVector::from_row_slice(&row.a), &self.held);
            let value_rounding = 2.0 * row.weight * VALUE_ROUNDING * self.magnitude[i];
            let pull = 2.0 * row.weight * VALUE_ROUNDING * self.value[i].abs();
            for j in 0..NU {
                noise[j] += direction[j].abs() * value_rounding;
                sum_rounding[j] += pull * row.a[j].abs();
            }
        }
        for j in (0..NU).filter(|&j| free(j)) {
            noise[j] += (0..NU).filter(|&k| free(k)).map(|k| inverse[(j, k)].abs() * sum_rounding[k]).sum::<f64>();
        }
        noise
    }

    /// Put input `j` at the bound its step `direction` runs into, and hold it there.
    fn hold_at(&mut self, p: &Problem<'_, NU>, u: &mut [f64; NU], j: usize, direction: f64) {
        (u[j], self.held[j]) =
            if direction > 0.0 { (p.input_max[j], Bound::Upper) } else { (p.input_min[j], Bound::Lower) };
    }

    /// Release every held input whose multiplier has the wrong sign; `false` if there is
    /// none (the face optimum is the answer).
    ///
    /// Judged in input units: released alone, with the free inputs re-optimised, input
    /// `j` would move inward by `pull_j / S_jj`, where `pull_j = ∂F/∂u_j + H_jF d_F` is its
    /// gradient corrected by the free inputs' remaining step and `S_jj` is the Schur
    /// complement of the free block (the curvature left along `j` once the free inputs
    /// compensate). That move must stay below the step tolerance, or the pull within its
    /// rounding. (`H_jj` alone would not do: a stiff row through `j` makes `H_jj` huge
    /// while the free inputs can keep that row where it is, and a real pull would pass
    /// as small.) The rounding of row `i`'s value moves the pull by its component
    /// `a_ij − H_jF H_FF⁻¹ a_iF` left after that compensation — small for a stiff row the
    /// free inputs can follow, however large `a_ij` — so huge rows do not excuse a pull.
    /// A box of zero width is never released.
    ///
    /// All wrong inputs go at once: every step still decreases `F`, and releasing them
    /// one by one costs a face solve each (a cold start with many saturated inputs took
    /// up to a third more steps that way).
    fn release_wrong_bounds(
        &mut self,
        p: &Problem<'_, NU>,
        u: &[f64; NU],
        gradient: &[f64; NU],
        model: &Model<NU>,
        tolerance: &[f64; NU],
    ) -> bool {
        let lowest_curvature = 2.0 * p.weights.iter().copied().fold(f64::INFINITY, f64::min);
        let mut release = [false; NU];
        for j in 0..NU {
            let outward = match self.held[j] {
                Bound::Free => continue,
                _ if p.input_min[j] == p.input_max[j] => continue,
                Bound::Lower => 1.0,
                Bound::Upper => -1.0,
            };
            let coupling = on_free(&model.hessian.column(j).into_owned(), &self.held);
            // The pull inward (against the bound): positive means the bound is wrong.
            let inward = -outward * (gradient[j] + coupling.dot(&model.step));
            if inward <= 0.0 {
                continue;
            }
            // How the free inputs follow input j (`H_FF⁻¹ H_Fj`).
            let mut compensated = model.factor.solve(&coupling);
            let mut hessian = model.hessian;
            // A row on its kink that the release would move clear does not resist it:
            // judge this input without it (rare, so refactorised only then).
            let clears = |i: usize, compensated: &SVector<f64, NU>| {
                self.in_model[i]
                    && self.on_kink(i)
                    && -outward * uncompensated(&p.rows[i].a, j, compensated, &self.held) > 0.0
            };
            if (0..p.rows.len()).any(|i| clears(i, &compensated)) {
                hessian =
                    with_rows(model.violated, p, |i| self.in_model[i] && self.on_kink(i) && !clears(i, &compensated));
                let Some(factor) = factor_free(&hessian, &self.held) else { continue };
                compensated = factor.solve(&on_free(&hessian.column(j).into_owned(), &self.held));
            }
            let coupling = on_free(&hessian.column(j).into_owned(), &self.held);
            // Strong convexity bounds S_jj below by the smallest 2 w; the subtraction can
            // round under it.
            let schur = (hessian[(j, j)] - coupling.dot(&compensated)).max(lowest_curvature);
            let mut rounding = VALUE_ROUNDING * 2.0 * p.weights[j] * (u[j].abs() + p.u_ref[j].abs());
            for (i, row) in p.rows.iter().enumerate().filter(|&(i, _)| self.in_model[i]) {
                let left = uncompensated(&row.a, j, &compensated, &self.held);
                rounding += 2.0 * row.weight * VALUE_ROUNDING * self.magnitude[i] * left.abs();
            }
            // As for the step: rounding excuses a move only up to ROUNDING_LIMIT.
            let unit = 1.0 + u[j].abs() + p.u_ref[j].abs();
            release[j] = inward / schur > tolerance[j] + (rounding / schur).min(ROUNDING_LIMIT * unit);
        }
        for (held, _) in self.held.iter_mut().zip(release).filter(|&(_, release)| release) {
            *held = Bound::Free;
        }
        release.contains(&true)
    }

    /// The minimiser of `F(u + t d)` over `0 ≤ t ≤ reach` (`reach` may be infinite).
    ///
    /// `φ'(t) = 2 Σ_j w_j (u_j + t d_j − r_j) d_j + 2 Σ_i s_i min(0, c_i + t e_i) e_i` is
    /// non-decreasing and piecewise linear, with a kink where a row's value
    /// `c_i + t e_i` crosses zero. From `t = 0` (where `φ' < 0`) the walk solves the
    /// current piece's linear `φ'` for its root and stops if the root comes before the
    /// next crossing, else moves to that crossing: at most one visit per row.
    fn line_search(&mut self, p: &Problem<'_, NU>, u: &[f64; NU], d: &SVector<f64, NU>, reach: f64) -> f64 {
        let rows = p.rows.len();
        for (i, row) in p.rows.iter().enumerate() {
            self.rate[i] = (0..NU).map(|j| row.a[j] * d[j]).sum();
        }
        let (mut input_slope, mut input_deriv0) = (0.0, 0.0);
        for j in 0..NU {
            input_slope += 2.0 * p.weights[j] * d[j] * d[j];
            input_deriv0 += 2.0 * p.weights[j] * (u[j] - p.u_ref[j]) * d[j];
        }
        let mut t = 0.0;
        for _ in 0..=rows {
            // Rows violated just after t, the derivative at t and the slope beyond it.
            let (mut deriv, mut slope, mut next) = (input_deriv0 + input_slope * t, input_slope, f64::INFINITY);
            for i in 0..rows {
                let (c, e, s) = (self.value[i], self.rate[i], p.rows[i].weight);
                let violated_after = if e == 0.0 {
                    c < 0.0
                } else {
                    let crossing = -c / e;
                    if crossing > t {
                        next = next.min(crossing);
                    }
                    if e < 0.0 {
                        crossing <= t
                    } else {
                        crossing > t
                    }
                };
                if violated_after {
                    deriv += 2.0 * s * (c + t * e) * e;
                    slope += 2.0 * s * e * e;
                }
            }
            if deriv >= 0.0 {
                return t;
            }
            let root = t - deriv / slope;
            let end = next.min(reach);
            if root <= end {
                return root;
            }
            if reach <= next {
                return reach;
            }
            t = next;
        }
        t
    }

    /// The input of the last solve (inside the box); the last answer kept when the last
    /// outcome was [`Outcome::NonFinite`].
    pub fn u(&self) -> &[f64; NU] {
        &self.u
    }

    /// Per row of the last solve: violated at the answer (`a_i·u + b_i < 0`).
    pub fn violated(&self) -> &[bool] {
        &self.violated[..self.rows]
    }

    /// `a_i·u + b_i` per row at the last answer: the slack is `max(0, −value)`.
    pub fn row_values(&self) -> &[f64] {
        &self.value[..self.rows]
    }

    /// Where each input sits at the last answer.
    pub fn held(&self) -> &[Bound; NU] {
        &self.held
    }

    /// Newton steps of the last solve (the face solve of a guess included).
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// How the last solve ended.
    pub fn outcome(&self) -> Outcome {
        self.outcome
    }
}

/// The Newton model at one point (see [`InputSpaceSolver::model`]).
struct Model<const NU: usize> {
    /// `H` over the strictly violated rows only.
    violated: SMatrix<f64, NU, NU>,
    /// `H` over the model's rows, before the held inputs are fixed.
    hessian: SMatrix<f64, NU, NU>,
    /// The Cholesky factor of `H` with the held inputs' rows and columns replaced by the
    /// identity: solves on the free inputs.
    factor: Cholesky<f64, Const<NU>>,
    /// The Newton step (zero on held inputs).
    step: SVector<f64, NU>,
}

fn check<const NU: usize>(p: &Problem<'_, NU>, capacity: usize) -> Result<(), CbfError> {
    if p.rows.len() > capacity {
        return Err(CbfError::TooLarge { what: "soft rows", value: p.rows.len(), max: capacity });
    }
    for j in 0..NU {
        if !(p.weights[j] > 0.0 && p.weights[j].is_finite()) {
            return Err(CbfError::NotPositive { what: "input weight", value: p.weights[j] });
        }
        for (what, v) in
            [("nominal input", p.u_ref[j]), ("input limit", p.input_min[j]), ("input limit", p.input_max[j])]
        {
            if !v.is_finite() {
                return Err(CbfError::NonFinite { what, value: v });
            }
        }
        if p.input_min[j] > p.input_max[j] {
            return Err(CbfError::OutOfRange {
                what: "input_min (must not exceed input_max)",
                value: p.input_min[j],
                range: "[-inf, input_max]",
            });
        }
    }
    for row in p.rows {
        if !(row.weight > 0.0 && row.weight.is_finite()) {
            return Err(CbfError::NotPositive { what: "slack weight", value: row.weight });
        }
    }
    Ok(())
}

fn clip<const NU: usize>(x: &[f64; NU], p: &Problem<'_, NU>) -> [f64; NU] {
    std::array::from_fn(|j| x[j].clamp(p.input_min[j], p.input_max[j]))
}

/// `2 W + 2 Σ_{i: violated(i)} s_i a_i a_iᵀ`.
fn hessian_of<const NU: usize>(p: &Problem<'_, NU>, violated: impl Fn(usize) -> bool) -> SMatrix<f64, NU, NU> {
    let diagonal = SVector::<f64, NU>::from_fn(|j, _| 2.0 * p.weights[j]);
    with_rows(SMatrix::from_diagonal(&diagonal), p, violated)
}

/// `h + 2 Σ_{i: include(i)} s_i a_i a_iᵀ`.
fn with_rows<const NU: usize>(
    mut h: SMatrix<f64, NU, NU>,
    p: &Problem<'_, NU>,
    include: impl Fn(usize) -> bool,
) -> SMatrix<f64, NU, NU> {
    for (_, row) in p.rows.iter().enumerate().filter(|&(i, _)| include(i)) {
        let a = SVector::<f64, NU>::from_row_slice(&row.a);
        h.ger(2.0 * row.weight, &a, &a, 1.0);
    }
    h
}

/// `x` on the free inputs, zero on the held ones.
fn on_free<const NU: usize>(x: &SVector<f64, NU>, held: &[Bound; NU]) -> SVector<f64, NU> {
    SVector::from_fn(|k, _| if held[k] == Bound::Free { x[k] } else { 0.0 })
}

/// The Cholesky factor of `h` with the held inputs' rows and columns replaced by the
/// identity: it solves on the free inputs (a right-hand side zero on the held ones gives
/// a solution zero there).
fn factor_free<const NU: usize>(h: &SMatrix<f64, NU, NU>, held: &[Bound; NU]) -> Option<Cholesky<f64, Const<NU>>> {
    let mut fixed = *h;
    fix_held(&mut fixed, &mut SVector::zeros(), held, &[0.0; NU]);
    fixed.cholesky()
}

/// A row's coefficient on input `j` left once the free inputs follow `j` by
/// `compensated`: `a_j − Σ_{k free} compensated_k a_k`.
fn uncompensated<const NU: usize>(a: &[f64; NU], j: usize, compensated: &SVector<f64, NU>, held: &[Bound; NU]) -> f64 {
    a[j] - (0..NU).filter(|&k| held[k] == Bound::Free).map(|k| compensated[k] * a[k]).sum::<f64>()
}

/// Fix held inputs at `values`: their columns move to the right-hand side, their rows
/// become the identity.
fn fix_held<const NU: usize>(
    h: &mut SMatrix<f64, NU, NU>,
    rhs: &mut SVector<f64, NU>,
    held: &[Bound; NU],
    values: &[f64; NU],
) {
    for j in 0..NU {
        if held[j] == Bound::Free {
            continue;
        }
        for k in 0..NU {
            rhs[k] -= h[(k, j)] * values[j];
            h[(k, j)] = 0.0;
            h[(j, k)] = 0.0;
        }
        h[(j, j)] = 1.0;
        rhs[j] = values[j];
    }
}

/// The optimum of the face where `violated` rows are violated and `held` inputs sit at
/// their bounds; `None` if it is not finite.
fn face_optimum<const NU: usize>(p: &Problem<'_, NU>, violated: &[bool], held: &[Bound; NU]) -> Option<[f64; NU]> {
    let mut h = hessian_of(p, |i| violated[i]);
    let mut rhs = SVector::<f64, NU>::from_fn(|j, _| 2.0 * p.weights[j] * p.u_ref[j]);
    for (row, _) in p.rows.iter().zip(violated).filter(|(_, &v)| v) {
        let a = SVector::<f64, NU>::from_row_slice(&row.a);
        rhs.axpy(-2.0 * row.weight * row.b, &a, 1.0);
    }
    let values: [f64; NU] = std::array::from_fn(|j| match held[j] {
        Bound::Lower => p.input_min[j],
        Bound::Upper => p.input_max[j],
        Bound::Free => 0.0,
    });
    fix_held(&mut h, &mut rhs, held, &values);
    let x = h.cholesky()?.solve(&rhs);
    x.iter().all(|v| v.is_finite()).then(|| std::array::from_fn(|j| x[j]))
}

/// How far `u + t d` stays in the box (`∞` if it never leaves), and the free input that
/// leaves first.
fn box_reach<const NU: usize>(p: &Problem<'_, NU>, u: &[f64; NU], d: &SVector<f64, NU>) -> (f64, Option<usize>) {
    let (mut reach, mut blocking) = (f64::INFINITY, None);
    for j in 0..NU {
        let room = if d[j] > 0.0 {
            (p.input_max[j] - u[j]) / d[j]
        } else if d[j] < 0.0 {
            (p.input_min[j] - u[j]) / d[j]
        } else {
            continue;
        };
        if room < reach {
            (reach, blocking) = (room.max(0.0), Some(j));
        }
    }
    (reach, blocking)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problem<'a>(rows: &'a [SoftRow<2>], lo: &'a [f64; 2], hi: &'a [f64; 2]) -> Problem<'a, 2> {
        Problem { weights: &[1.0, 1.0], u_ref: &[0.0, 0.0], input_min: lo, input_max: hi, rows }
    }

    #[test]
    fn one_stiff_row_by_hand() {
        // min u1² + u2² + s max(0, 1 − u1)²: optimum u1 = s / (1 + s), u2 = 0.
        let s = 1e4;
        let rows = [SoftRow { a: [1.0, 0.0], b: -1.0, weight: s }];
        let p = problem(&rows, &[-10.0, -10.0], &[10.0, 10.0]);
        let mut solver = InputSpaceSolver::<2>::new(4);
        assert_eq!(solver.solve(&p, Start::Cold, 20).unwrap(), Outcome::Verified);
        assert!((solver.u()[0] - s / (1.0 + s)).abs() < 1e-14);
        assert_eq!(solver.u()[1], 0.0);
        assert_eq!(solver.violated(), &[true]);
    }

    #[test]
    fn row_against_a_saturated_input_by_hand() {
        // The row wants u1 ≥ 1 but u1 ≤ 0.5: held at 0.5, the slack takes the rest.
        let rows = [SoftRow { a: [1.0, 0.0], b: -1.0, weight: 1e2 }];
        let p = problem(&rows, &[-1.0, -1.0], &[0.5, 1.0]);
        let mut solver = InputSpaceSolver::<2>::new(1);
        assert_eq!(solver.solve(&p, Start::Cold, 20).unwrap(), Outcome::Verified);
        assert_eq!(solver.u(), &[0.5, 0.0]);
        assert_eq!(solver.held(), &[Bound::Upper, Bound::Free]);
        assert!((solver.row_values()[0] + 0.5).abs() < 1e-15);
    }

    #[test]
    fn bad_data_is_an_error_and_changes_nothing() {
        let rows = [SoftRow { a: [1.0, 0.0], b: -1.0, weight: 0.0 }];
        let p = problem(&rows, &[-1.0, -1.0], &[1.0, 1.0]);
        let mut solver = InputSpaceSolver::<2>::new(1);
        assert!(solver.solve(&p, Start::Cold, 20).is_err());
        let rows = [SoftRow { a: [1.0, 0.0], b: -1.0, weight: 1.0 }; 2];
        assert!(solver.solve(&problem(&rows, &[-1.0, -1.0], &[1.0, 1.0]), Start::Cold, 20).is_err());
        assert_eq!(solver.u(), &[0.0, 0.0]);
    }

    #[test]
    fn overflowing_rows_are_non_finite_not_a_panic() {
        let rows = [SoftRow { a: [1e300, 1e300], b: -1e300, weight: 1e8 }];
        let p = problem(&rows, &[-1e6, -1e6], &[1e6, 1e6]);
        let mut solver = InputSpaceSolver::<2>::new(1);
        let outcome = solver.solve(&p, Start::Cold, 20).unwrap();
        assert_eq!(outcome, Outcome::NonFinite);
    }
}
