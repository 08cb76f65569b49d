//! The safety filter's QP with priority tiers, solved lexicographically in its `NU`
//! inputs.
//!
//! Each row `i` asks `a_i·u + b_i ≥ 0` and belongs to a tier `τ_i` (0 first). The answer
//! is the input that
//! 1. meets every row of tier 0 exactly when the input box allows it, and otherwise
//!    relaxes them as little as possible;
//! 2. then does the same for tier 1 in the room tier 0 leaves, and so on;
//! 3. and among the inputs that achieve all that, is the closest to the nominal input
//!    `r` in the weighted norm `Σ_j w_j (u_j − r_j)²` — or, with a cost matrix `P` set by
//!    [`LexicographicSolver::set_metric`], in `(u − c)ᵀ P (u − c)`.
//!
//! No weight ratio stands in for a priority: a lower tier never buys anything with a
//! higher tier's violation, whatever the units its rows are written in.
//!
//! # Stages
//! Every stage is a small strictly convex QP with hard rows, solved exactly by the dense
//! dual active-set method ([`DualActiveSet`], KKT-verified before it answers). Stages work
//! in the scaled inputs `z_j = √w_j u_j`, where the weights appear only in the rows
//! (`a_ij / √w_j`) and the box, and every cost matrix is the identity: weights however far
//! apart leave the solver's conditioning, and its checks, as they are. A general cost
//! matrix `P = L Lᵀ` works the same way in `z = Lᵀ u` ([`crate::qp::metric`]): the rows
//! read `L⁻¹ a`, and the box becomes the rows of `L⁻ᵀ`.
//! * **H (hard)**: `min ½ Σ w_j (u_j − r_j)²` over the box with every row hard at its
//!   current relaxation, `a_i·u + b_i + ρ_i ≥ 0` (`ρ_i = 0` until a stage fixes it). When
//!   the rows and the box are compatible — the usual case — this one solve is the answer:
//!   every row met.
//! * **E (elastic)**, when H is infeasible (the solver's certificate): for the highest
//!   tier `k` not yet settled, the least violation of its rows. Violation is measured in
//!   input units: a row missed by `s` is `s / σ_i` away in input space, with
//!   `σ_i = ‖a_i‖_{W⁻¹} = (Σ_j a_ij² / w_j)^{1/2}`, so scaling a barrier by any constant
//!   changes nothing. The stage minimises the largest such distance `t` over tier `k`'s
//!   unsettled rows, with higher tiers hard at their relaxations and lower tiers left
//!   out: `min t s.t. a_i·u + b_i + σ_i t ≥ 0`. The rows that bind at the optimum (non-zero
//!   multipliers) are fixed at `ρ_i = σ_i t*`; the stage repeats for the rest of the tier
//!   (which may need less), until they fit with `t = 0`. This is the lexicographic
//!   minimax ("least largest violation first") within the tier; then H is tried again
//!   with the next tiers hard.
//!
//! The elastic stage's `min t` is a linear program; it is solved as the proximal QP
//! `min μ t + ½ t² + ½ Σ_j w_j (u_j − c_j)²`, re-centred on its own answer `c ← u` until
//! neither `t` nor `u` moves: a proximal-point iteration with an exact penalty. The linear
//! term makes the minimum sharp, so once `μ` (= [`PENALTY`] times the inputs' scale)
//! outweighs the pull of the proximal term, the stage's `t` is the linear program's own
//! (not a regularised approximation of it), usually in the first round; the second
//! confirms it and starts from the last active set, taking no step.
//!
//! # Why a row was relaxed
//! A row fixed by an elastic stage records what held it back, read from the stage's
//! multipliers: a higher-tier row (the one pulling hardest), an input at its limit
//! (which, which side), another row of its own tier, or — decided before any stage — no
//! control authority: the inputs cannot move the row's value beyond rounding of it
//! (`Σ_j |a_ij| (max_j − min_j) ≤` [`AUTHORITY_FRACTION`]` · |b_i|`), so no input helps
//! and the row takes no part.
//!
//! # Rounding
//! A tier is fixed at exactly the least violation its stage found, so the answer is exact
//! to rounding. Rows meeting at a vertex can then leave a later stage infeasible by a
//! rounding error alone; a cascade that ends unverified is run once more with every fixed
//! relaxation padded by the dense solver's own feasibility tolerance (1e-9 of the row's
//! terms). A warm start that leaves a point whose check drowns in rounding (nearly
//! dependent rows seeded together) is retried from nothing.
//!
//! # One answer per problem
//! The first stage H starts from the active set its last solve reached (the rows of a
//! control loop change little from cycle to cycle), and its answer, where the rows fit,
//! is the unique optimum whatever it started from. The cascade that settles the tiers
//! when they do not fit starts from nothing at every solve: rows of one tier that bind
//! together at its least violation have multipliers that are not unique, a warm start
//! from another problem would fix another subset of them first, and the answer would end
//! within rounding of another, which the lower tiers magnify (18 inputs, 60 rows: up to
//! 1.3e-5 of the inputs' scale, in 8 of 2 115 random problems after random histories).
//! Started cold, a problem gets the same answer whatever was solved before
//! (`tests/integration/ecbf_qp.rs`, to 1e-10 of the inputs' scale).
//!
//! # Allocation, budget, bad data
//! Everything is laid out by [`LexicographicSolver::new`]; a solve allocates nothing.
//! Each stage may add `max_steps` rows to its active set. The first stage keeps its warm
//! start (the active set it reached, verified or not), so when it runs out it continues
//! where it stopped at the next solve; a cascade that runs out starts again from nothing
//! at the next. Either ends this solve with [`Outcome::StepLimit`] and the point it
//! reached. The row data are the caller's to check (finite values); a non-finite stage
//! reports [`Outcome::NonFinite`].

// Index loops mirror the formulas (rows × inputs).
#![allow(clippy::needless_range_loop)]
use super::dual_active_set::{ActiveRow, DenseStatus, DualActiveSet, WarmStart, KKT_TOLERANCE};
use super::metric::InputMetric;
use crate::error::CbfError;

/// The elastic stage's linear cost on the violation `t`, relative to the inputs' scale
/// `1 + max_j √w_j max(|min_j|, |max_j|, |r_j|)` (see the module docs): far above what
/// the proximal term can pull, so a round lands on the linear program's optimum.
pub const PENALTY: f64 = 1e3;

/// Each proximal round multiplies the penalty by this, up to [`MAX_PENALTY`].
const PENALTY_GROWTH: f64 = 100.0;

/// The largest penalty (relative to the inputs' scale): the rounding of the stage's
/// stationarity grows with it, and beyond about 10⁷ the dense solver's check starts to
/// refuse answers on it.
const MAX_PENALTY: f64 = 1e7;

/// Most re-centrings of one elastic stage.
const PROXIMAL_ROUNDS: u32 = 8;

/// A row whose inputs can move its value by no more than this fraction of `|b|` over the
/// whole input box has no control authority (see the module docs).
pub const AUTHORITY_FRACTION: f64 = 1e-12;

/// An elastic stage fixes a row only when its multiplier (times its norm) is above this
/// fraction of the largest: a row binding with a smaller multiplier may be held there by
/// the proximal term alone, and is left to the next round of the tier, which fixes it
/// too if it really cannot do better (fixing too few rows is safe, too many is not).
const MULTIPLIER_FRACTION: f64 = 1e-2;

/// An input limit, for [`Cause::InputLimit`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Limit {
    /// The input sits at its lower limit.
    Min,
    /// The input sits at its upper limit.
    Max,
}

impl Limit {
    /// Lower-case name, as shown in Python and written to CSV.
    pub const fn name(self) -> &'static str {
        match self {
            Limit::Min => "min",
            Limit::Max => "max",
        }
    }
}

/// Why a row was relaxed: what a user can act on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Cause {
    /// The inputs cannot move the row at this state (`L_g L_f^{r−1} h` vanishes relative
    /// to the row's size): no input meets it.
    NoAuthority,
    /// Held back by an input at its limit.
    InputLimit {
        /// The input's index.
        input: usize,
        /// Which limit.
        limit: Limit,
    },
    /// Held back by a row of a higher priority (a lower tier number): the one pulling
    /// hardest against it.
    HigherPriority {
        /// That row's index.
        row: usize,
    },
    /// In conflict with another row of its own priority (the one pulling hardest).
    SamePriority {
        /// That row's index.
        row: usize,
    },
    /// The solver did not finish: the input is an unverified iterate or a fallback, and
    /// this row is not met at it.
    Unsolved,
}

impl Cause {
    /// Snake-case name of the kind of cause, as shown in Python and written to CSV.
    pub const fn name(self) -> &'static str {
        match self {
            Cause::NoAuthority => "no_authority",
            Cause::InputLimit { .. } => "input_limit",
            Cause::HigherPriority { .. } => "higher_priority",
            Cause::SamePriority { .. } => "same_priority",
            Cause::Unsolved => "unsolved",
        }
    }
}

/// One row: it holds when `a·u + b ≥ 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TieredRow<const NU: usize> {
    /// Input coefficients (`L_g L_f^{r−1} h` for an ECBF row).
    pub a: [f64; NU],
    /// The value at `u = 0` (`L_f^r h + Σ k_i L_f^i h`).
    pub b: f64,
    /// Priority tier, `0..`[`TIERS`]: 0 first, higher numbers yield first.
    pub tier: u8,
}

/// How a solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Outcome {
    /// Every stage verified: [`LexicographicSolver::u`] is the lexicographic optimum.
    Verified,
    /// A stage ran out of steps, or ended unverified (rounding on a degenerate stage):
    /// [`LexicographicSolver::u`] is the point it reached, not an answer.
    StepLimit,
    /// A stage's data or answer was not finite; [`LexicographicSolver::u`] is unchanged.
    NonFinite,
}

/// Where a row stands in the current solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Standing {
    /// Not in this solve.
    Inactive,
    /// No control authority: left out of every stage.
    NoAuthority,
    /// Hard at its current relaxation (0 until an elastic stage fixes it).
    Hard,
}

/// One stage's dense solver with its rows packed at the front: the input box first (rows
/// `0..NU`), then `fixed` more rows that never change (stage E's `t ≥ 0`), then the rows
/// of this solve, so a solve costs what its rows cost, not what the capacity does. Warm
/// starts are kept in problem coordinates (a row's own index, `capacity + j` for input
/// `j`'s bound, `capacity + NU` for `t ≥ 0`) and translated through the packing.
#[derive(Debug, Clone)]
struct PackedStage {
    qp: DualActiveSet,
    /// Variables (`NU`, or `NU + 1` with `t`).
    n: usize,
    /// Rows before the packed ones: the box and the fixed rows.
    head: usize,
    capacity: usize,
    /// Problem row of each packed row, and packed row of each problem row (`NONE`).
    row_of: Vec<usize>,
    packed_of: Vec<usize>,
    /// Rows packed this solve.
    count: usize,
    /// Each place in the cascade's warm start (see [`WarmSlot`]): the active set its last
    /// solve there reached, verified or not, so that a small step budget keeps making
    /// progress from cycle to cycle.
    warm: WarmStarts,
    translated: Vec<ActiveRow>,
    reached: Vec<ActiveRow>,
    /// Whether this stage has solved since [`LexicographicSolver::solve`] began (its point
    /// is this problem's, not a former one's).
    ran: bool,
}

const NONE: usize = usize::MAX;

impl PackedStage {
    fn new(hessian: &[f64], n: usize, head: usize, capacity: usize, slots: usize) -> Result<Self, CbfError> {
        Ok(Self {
            qp: DualActiveSet::new(hessian, n, head + capacity)?,
            n,
            head,
            capacity,
            row_of: vec![NONE; head + capacity],
            packed_of: vec![NONE; capacity + head],
            count: 0,
            warm: WarmStarts::new(slots, n),
            translated: Vec::with_capacity(n),
            reached: Vec::with_capacity(n),
            ran: false,
        })
    }

    /// Start packing this solve's rows.
    fn clear(&mut self) {
        for p in self.head..self.head + self.count {
            self.packed_of[self.row_of[p]] = NONE;
            self.row_of[p] = NONE;
        }
        self.count = 0;
    }

    /// Pack problem row `row`: `a·u + elastic t ≥ lower`.
    fn push<const NU: usize>(&mut self, row: usize, a: &[f64; NU], elastic: f64, lower: f64) {
        let p = self.head + self.count;
        self.count += 1;
        let data = self.qp.data_mut();
        data.a[p * self.n..p * self.n + NU].copy_from_slice(a);
        if self.n > NU {
            data.a[p * self.n + NU] = elastic;
        }
        data.lower[p] = lower;
        self.row_of[p] = row;
        self.packed_of[row] = p;
    }

    /// Solve the rows packed, warm-started from `slot`, within `max_work` (> 0); adds the
    /// work done to `*spent`.
    fn solve(&mut self, slot: usize, max_steps: u32, max_work: u64, spent: &mut u64) -> DenseStatus {
        let count = self.count;
        self.qp.set_rows_in_use(self.head + count);
        self.translated.clear();
        for &ActiveRow { row, side } in self.warm.get(slot) {
            let packed = if row >= self.capacity { row - self.capacity } else { self.packed_of[row] };
            if packed != NONE && packed < self.head + count {
                self.translated.push(ActiveRow { row: packed, side });
            }
        }
        self.ran = true;
        let mut status = self.qp.solve_within(WarmStart::Given(&self.translated), max_steps, max_work);
        *spent += self.qp.work();
        let left = max_work.saturating_sub(self.qp.work());
        if status == DenseStatus::Unverified && !self.translated.is_empty() && left > 0 {
            // A warm start of nearly dependent rows can leave a point whose check drowns
            // in the rounding of their factorisation; from nothing, the method adds rows
            // only as they are needed.
            status = self.qp.solve_within(WarmStart::Cold, max_steps, left);
            *spent += self.qp.work();
        }
        if status != DenseStatus::NonFiniteData {
            self.reached.clear();
            for &ActiveRow { row, side } in self.qp.active_set() {
                let problem = if row < self.head { self.capacity + row } else { self.row_of[row] };
                self.reached.push(ActiveRow { row: problem, side });
            }
            self.warm.set(slot, &self.reached);
        }
        status
    }

    /// The multiplier of problem row `row` times its packed row's norm (0 when it is not
    /// packed): how hard it pulls at the optimum.
    fn pull(&self, row: usize) -> f64 {
        let p = if row >= self.capacity { row - self.capacity } else { self.packed_of[row] };
        if p == NONE {
            return 0.0;
        }
        let a = &self.qp.constraints()[p * self.n..(p + 1) * self.n];
        self.qp.row_multipliers()[p].abs() * a.iter().map(|v| v * v).sum::<f64>().sqrt()
    }

    /// The signed multiplier of problem row `row` (0 when it is not packed).
    fn multiplier(&self, row: usize) -> f64 {
        let p = if row >= self.capacity { row - self.capacity } else { self.packed_of[row] };
        if p == NONE {
            0.0
        } else {
            self.qp.row_multipliers()[p]
        }
    }
}

/// The solver: the box, the weights and the buffers of both stages, laid out once.
#[derive(Debug, Clone)]
pub struct LexicographicSolver<const NU: usize> {
    /// `P = L Lᵀ`: every stage works in the scaled inputs `z = Lᵀ u` (`z_j = √w_j u_j`
    /// for input weights; module docs).
    metric: InputMetric<NU>,
    input_min: [f64; NU],
    input_max: [f64; NU],
    rows: usize,
    /// Stage H: `NU` variables; the box, then the rows of this solve.
    hard: PackedStage,
    /// Stage E: `NU + 1` variables (`u`, `t`); the box, `t ≥ 0`, then the rows.
    elastic: PackedStage,
    standing: Vec<Standing>,
    /// Per row: `σ_i`, the relaxation `ρ_i`, whether a stage has fixed it, and why.
    sigma: Vec<f64>,
    relaxation: Vec<f64>,
    fixed: Vec<bool>,
    cause: Vec<Option<Cause>>,
    /// Tiers present this solve, ascending.
    tiers: Vec<u8>,
    u: [f64; NU],
    /// The padding of fixed relaxations, relative to a row's terms (see
    /// [`LexicographicSolver::rounding_pad`]).
    pad: f64,
    steps: u32,
    elastic_stages: u32,
    outcome: Outcome,
    /// The work budget of one solve, and the work the current one has done (dense-solver
    /// trips, [`DualActiveSet::work`]).
    max_work: u64,
    work: u64,
}

impl<const NU: usize> LexicographicSolver<NU> {
    /// A solver for up to `rows` rows over the box `input_min ≤ u ≤ input_max` with input
    /// weights `weights`.
    ///
    /// # Errors
    /// A weight that is not finite and positive, a limit that is not finite or
    /// `input_min > input_max`.
    pub fn new(
        rows: usize,
        weights: &[f64; NU],
        input_min: &[f64; NU],
        input_max: &[f64; NU],
    ) -> Result<Self, CbfError> {
        for j in 0..NU {
            if !(weights[j] > 0.0 && weights[j].is_finite()) {
                return Err(CbfError::NotPositive { what: "input weight", value: weights[j] });
            }
            crate::error::finite("input limit", input_min[j])?;
            crate::error::finite("input limit", input_max[j])?;
            if input_min[j] > input_max[j] {
                return Err(CbfError::OutOfRange {
                    what: "input_min (must not exceed input_max)",
                    value: input_min[j],
                    range: "[-inf, input_max]",
                });
            }
        }
        let hard = PackedStage::new(&identity(NU), NU, NU, rows, HARD_SLOTS)?;
        let elastic = PackedStage::new(&identity(NU + 1), NU + 1, NU + 1, rows, TIERS)?;
        let mut solver = Self {
            metric: InputMetric::from_weights(weights),
            input_min: *input_min,
            input_max: *input_max,
            rows,
            hard,
            elastic,
            standing: vec![Standing::Inactive; rows],
            sigma: vec![0.0; rows],
            relaxation: vec![0.0; rows],
            fixed: vec![false; rows],
            cause: vec![None; rows],
            tiers: Vec::with_capacity(rows),
            u: [0.0; NU],
            pad: 0.0,
            steps: 0,
            elastic_stages: 0,
            outcome: Outcome::Verified,
            max_work: u64::MAX,
            work: 0,
        };
        solver.write_box();
        let data = solver.elastic.qp.data_mut();
        data.a[NU * (NU + 1) + NU] = 1.0;
        data.lower[NU] = 0.0;
        Ok(solver)
    }

    /// Measure the distance to the nominal input in `metric` from now on (the weights'
    /// diagonal one until then): the box rows change with it, nothing else does, and the
    /// warm starts stay (they name rows, not points). Allocation-free; `O(NU²)`.
    pub fn set_metric(&mut self, metric: &InputMetric<NU>) {
        self.metric = *metric;
        self.write_box();
    }

    /// The box rows of both stages in the scaled inputs: `√w_j min_j ≤ z_j ≤ √w_j max_j`
    /// for a diagonal metric, `min_j ≤ (L⁻ᵀ z)_j ≤ max_j` for any other.
    fn write_box(&mut self) {
        for stage in [&mut self.hard, &mut self.elastic] {
            let n = stage.n;
            let data = stage.qp.data_mut();
            for j in 0..NU {
                let row = &mut data.a[j * n..j * n + NU];
                if self.metric.is_diagonal() {
                    row.fill(0.0);
                    row[j] = 1.0;
                    let root = self.metric.root_weight(j);
                    (data.lower[j], data.upper[j]) = (root * self.input_min[j], root * self.input_max[j]);
                } else {
                    row.copy_from_slice(self.metric.box_row(j));
                    (data.lower[j], data.upper[j]) = (self.input_min[j], self.input_max[j]);
                }
            }
        }
    }

    /// Rows this solver holds.
    pub fn capacity(&self) -> usize {
        self.rows
    }

    /// Bound each later solve's work, summed over all its stages, by `max_work` dense-solver
    /// trips (at least 1; no bound at first). A stage starts only while work is left, and
    /// each gets what is left as its own budget ([`DualActiveSet::solve_within`]); a solve
    /// that runs out ends [`Outcome::StepLimit`] with stage H's point, as a step budget
    /// does.
    pub fn set_max_work(&mut self, max_work: u64) {
        self.max_work = max_work.max(1);
    }

    /// The last solve's work over all its stages, in dense-solver trips.
    pub fn work(&self) -> u64 {
        self.work
    }

    /// The most work one solve can do under its work budget ([`Self::set_max_work`]): the
    /// budget, and what the stage that spends it can do past it
    /// ([`DualActiveSet::work_overshoot`] of the larger stage, E, at full capacity).
    pub fn worst_case_work(&self) -> u64 {
        self.max_work.saturating_add(DualActiveSet::work_overshoot(NU + 1, self.elastic.head + self.rows))
    }

    /// Solve for nominal input `u_ref` and `rows`; only rows with `active[i]` take part.
    /// Each stage may add up to `max_steps` rows to its active set. Allocation-free.
    ///
    /// # Errors
    /// `rows` or `active` of another length than the capacity, a nominal input that is
    /// not finite, or a tier beyond [`TIERS`]. Nothing changes then. Non-finite row data
    /// are not an error: the outcome is [`Outcome::NonFinite`].
    pub fn solve(
        &mut self,
        u_ref: &[f64; NU],
        rows: &[TieredRow<NU>],
        active: &[bool],
        max_steps: u32,
    ) -> Result<Outcome, CbfError> {
        for (what, len) in [("rows", rows.len()), ("active flags", active.len())] {
            if len != self.rows {
                return Err(CbfError::LengthMismatch { what, expected: self.rows, got: len });
            }
        }
        for &v in u_ref {
            crate::error::finite("nominal input", v)?;
        }
        if let Some(row) = rows.iter().find(|r| usize::from(r.tier) >= TIERS) {
            return Err(CbfError::TooLarge { what: "priority tier", value: usize::from(row.tier), max: TIERS - 1 });
        }
        self.steps = 0;
        self.elastic_stages = 0;
        self.work = 0;
        self.hard.ran = false;
        self.elastic.ran = false;
        self.outcome = self.run(u_ref, rows, active, max_steps);
        Ok(self.outcome)
    }

    fn run(&mut self, u_ref: &[f64; NU], rows: &[TieredRow<NU>], active: &[bool], max_steps: u32) -> Outcome {
        self.pad = 0.0;
        let outcome = self.cascade(u_ref, rows, active, max_steps);
        if outcome != Outcome::StepLimit || self.elastic_stages == 0 || self.work >= self.max_work {
            return outcome;
        }
        // A tier settled at exactly its least violation can leave the next stage
        // infeasible by rounding (rows meeting at a vertex): settle again with every
        // relaxation padded by the rounding a verified stage may leave.
        self.pad = KKT_TOLERANCE;
        self.cascade(u_ref, rows, active, max_steps)
    }

    fn cascade(&mut self, u_ref: &[f64; NU], rows: &[TieredRow<NU>], active: &[bool], max_steps: u32) -> Outcome {
        self.classify(rows, active);
        {
            let centre = self.metric.scaled(u_ref);
            let data = self.hard.qp.data_mut();
            for j in 0..NU {
                data.q[j] = -centre[j];
            }
        }
        match self.solve_hard(rows, u8::MAX, WarmSlot::First.index(), max_steps) {
            DenseStatus::Solved => return self.answer(),
            DenseStatus::Infeasible => {}
            DenseStatus::NonFiniteData => return Outcome::NonFinite,
            _ => return self.reached(),
        }
        // The rows do not fit: settle the tiers in order, each in the room the higher
        // ones leave, until the rest fit as they are, from nothing (module docs: one
        // answer per problem).
        self.hard.warm.forget_from(WarmSlot::First.index() + 1);
        self.elastic.warm.forget_from(0);
        for k in 0..self.tiers.len() {
            match self.settle(self.tiers[k], u_ref, rows, max_steps) {
                Outcome::Verified => {}
                other => return other,
            }
            match self.solve_hard(rows, u8::MAX, WarmSlot::After(self.tiers[k]).index(), max_steps) {
                DenseStatus::Solved => return self.answer(),
                DenseStatus::Infeasible => {}
                DenseStatus::NonFiniteData => return Outcome::NonFinite,
                _ => return self.reached(),
            }
        }
        // Every tier settled and still infeasible: rounding on a degenerate problem.
        self.reached()
    }

    /// Stage H's answer, as the solve's.
    fn answer(&mut self) -> Outcome {
        self.take_hard_point();
        Outcome::Verified
    }

    /// Stage H's point, reached but not verified (out of steps, or rounding).
    fn reached(&mut self) -> Outcome {
        self.take_hard_point();
        Outcome::StepLimit
    }

    /// Stage H's point as `u`, inside the box (the dense solver meets the box only to its
    /// tolerance).
    fn take_hard_point(&mut self) {
        self.u = self.inputs(self.hard.qp.solution());
    }

    /// Stage E's point as `u` (a stage that did not finish), or stage H's where stage E
    /// has not run in this solve (its budget was spent first).
    fn take_elastic_point(&mut self) -> Outcome {
        if !self.elastic.ran {
            return self.reached();
        }
        self.u = self.inputs(self.elastic.qp.solution());
        Outcome::StepLimit
    }

    /// The inputs `u = L⁻ᵀ z` of a stage's scaled point, inside the box (the dense solver
    /// meets the box only to its tolerance).
    fn inputs(&self, z: &[f64]) -> [f64; NU] {
        let u = self.metric.unscaled(z);
        std::array::from_fn(|j| u[j].clamp(self.input_min[j], self.input_max[j]))
    }

    /// Row `a` in the scaled inputs: `L⁻¹ a` (`a_j / √w_j`).
    fn scaled_row(&self, a: &[f64; NU]) -> [f64; NU] {
        self.metric.scaled_row(a)
    }

    /// Which rows take part, their `σ`, and the tiers present; every relaxation back to 0.
    fn classify(&mut self, rows: &[TieredRow<NU>], active: &[bool]) {
        self.tiers.clear();
        for (i, (row, &on)) in rows.iter().zip(active).enumerate() {
            self.relaxation[i] = 0.0;
            self.fixed[i] = false;
            self.cause[i] = None;
            if !on {
                self.standing[i] = Standing::Inactive;
                continue;
            }
            let reach: f64 = (0..NU).map(|j| row.a[j].abs() * (self.input_max[j] - self.input_min[j])).sum();
            if reach <= AUTHORITY_FRACTION * row.b.abs() {
                self.standing[i] = Standing::NoAuthority;
                self.cause[i] = Some(Cause::NoAuthority);
                continue;
            }
            self.standing[i] = Standing::Hard;
            if !self.tiers.contains(&row.tier) {
                self.tiers.push(row.tier);
            }
        }
        self.tiers.sort_unstable();
    }

    /// Stage H on the current relaxations, over the tiers up to `through`, warm-started
    /// from where its last solve at this place of the cascade got to.
    fn solve_hard(&mut self, rows: &[TieredRow<NU>], through: u8, slot: usize, max_steps: u32) -> DenseStatus {
        self.hard.clear();
        for (i, row) in rows.iter().enumerate() {
            if self.standing[i] == Standing::Hard && row.tier <= through {
                let a = self.scaled_row(&row.a);
                self.hard.push(i, &a, 0.0, -row.b - self.relaxation[i]);
            }
        }
        if self.work >= self.max_work {
            return DenseStatus::MaxWork;
        }
        let status = self.hard.solve(slot, max_steps, self.max_work - self.work, &mut self.work);
        self.steps += self.hard.qp.steps();
        status
    }

    /// Stage E for `tier`, repeated until every row of the tier is fixed or the rest fit
    /// (module docs). `Verified` when the tier is settled.
    fn settle(&mut self, tier: u8, u_ref: &[f64; NU], rows: &[TieredRow<NU>], max_steps: u32) -> Outcome {
        let m = self.rows;
        loop {
            // Do the tier's unfixed rows fit, with the higher tiers and its fixed rows?
            match self.solve_hard(rows, tier, WarmSlot::Restricted(tier).index(), max_steps) {
                DenseStatus::Solved => {
                    let u = self.inputs(self.hard.qp.solution());
                    for i in 0..m {
                        if self.unfixed(i, rows, tier) {
                            self.relaxation[i] = self.rounding_pad(&rows[i], &u);
                            self.fixed[i] = true;
                        }
                    }
                    return Outcome::Verified;
                }
                DenseStatus::Infeasible => {}
                DenseStatus::NonFiniteData => return Outcome::NonFinite,
                _ => return self.reached(),
            }
            // Rows: higher tiers and this tier's fixed rows hard at their relaxation, this
            // tier's other rows elastic (by σ, needed only here), lower tiers out.
            for i in 0..m {
                if self.unfixed(i, rows, tier) {
                    self.sigma[i] = self.metric.row_norm(&rows[i].a);
                }
            }
            self.elastic.clear();
            for (i, row) in rows.iter().enumerate() {
                if self.standing[i] != Standing::Hard || row.tier > tier {
                    continue;
                }
                let elastic = if self.unfixed(i, rows, tier) { self.sigma[i] } else { 0.0 };
                let a = self.scaled_row(&row.a);
                self.elastic.push(i, &a, elastic, -row.b - self.relaxation[i]);
            }
            // The proximal rounds, centred first on the nominal input, then each on the
            // last answer, until a round does not move: its multipliers are then the
            // linear program's, free of the proximal term's pull. While the answer still
            // moves, the penalty grows a hundredfold a round (a degenerate program's
            // optimum can lie far along a direction where t falls slowly, 1e-7 a round
            // at the first penalty). A round that does not verify ends them, and the last
            // verified round is solved again for its multipliers.
            let mut centre = *u_ref;
            let mut previous: Option<([f64; NU], f64, f64)> = None;
            let mut penalty = PENALTY;
            for _ in 0..PROXIMAL_ROUNDS {
                match (self.solve_elastic(tier, &centre, penalty, max_steps), previous) {
                    (DenseStatus::Solved, _) => {}
                    (DenseStatus::NonFiniteData, _) => return Outcome::NonFinite,
                    (_, Some((last_centre, _, last_penalty))) => {
                        if self.solve_elastic(tier, &last_centre, last_penalty, max_steps) != DenseStatus::Solved {
                            return self.take_elastic_point();
                        }
                        break;
                    }
                    // Higher tiers are hard only where an earlier stage met them, so an
                    // infeasible elastic stage is rounding, as an unverified one is.
                    (_, None) => return self.take_elastic_point(),
                }
                let z = self.elastic.qp.solution();
                let t = z[NU];
                let u = self.inputs(z);
                let tolerance = self.t_tolerance(&u, u_ref);
                let scaled_centre = self.metric.scaled(&centre);
                let moved = (0..NU).map(|j| (z[j] - scaled_centre[j]).abs()).fold(0.0, f64::max);
                if moved <= tolerance {
                    break;
                }
                previous = Some((centre, t, penalty));
                penalty = (penalty * PENALTY_GROWTH).min(MAX_PENALTY);
                centre = self.metric.unscaled(z);
            }
            self.elastic_stages += 1;
            let (t, u) = (self.elastic.qp.solution()[NU], self.inputs(self.elastic.qp.solution()));
            // Fix the rows that bind at t (non-zero multipliers) at σ t (plus the rounding
            // pad on a second attempt). Should the stage have found no conflict after all
            // (t within rounding of 0) or no binding row (rounding), every row of the tier
            // is fixed at its distance, which ends the tier.
            let fits = t <= self.t_tolerance(&u, u_ref);
            let threshold = MULTIPLIER_FRACTION * (0..m).map(|r| self.elastic.pull(r)).fold(0.0, f64::max);
            let mut fixed_any = false;
            for i in 0..m {
                if fits || !self.unfixed(i, rows, tier) {
                    continue;
                }
                if self.elastic.multiplier(i) < 0.0 && self.elastic.pull(i) > threshold {
                    self.relaxation[i] = self.sigma[i] * t + self.rounding_pad(&rows[i], &u);
                    self.fixed[i] = true;
                    self.cause[i] = Some(self.stage_cause(i, tier, rows));
                    fixed_any = true;
                }
            }
            if fits || !fixed_any {
                for i in 0..m {
                    if self.unfixed(i, rows, tier) {
                        let value = dot(&rows[i].a, &u) + rows[i].b;
                        self.relaxation[i] = (-value).max(0.0) + self.rounding_pad(&rows[i], &u);
                        self.fixed[i] = true;
                        if value < 0.0 {
                            self.cause[i] = Some(self.stage_cause(i, tier, rows));
                        }
                    }
                }
                return Outcome::Verified;
            }
        }
    }

    /// What a verified stage may leave a row off by (the dense solver's feasibility
    /// tolerance on it, times `pad`: 0 at first, see [`LexicographicSolver::run`]), added
    /// to a fixed relaxation so that the next stage, with the row hard, is not made
    /// infeasible by rounding.
    fn rounding_pad(&self, row: &TieredRow<NU>, u: &[f64; NU]) -> f64 {
        self.pad * (row.b.abs() + (0..NU).map(|j| row.a[j].abs() * (1.0 + u[j].abs())).sum::<f64>())
    }

    /// Whether row `i` is a hard row of `tier` that no stage has fixed yet.
    fn unfixed(&self, i: usize, rows: &[TieredRow<NU>], tier: u8) -> bool {
        self.standing[i] == Standing::Hard && rows[i].tier == tier && !self.fixed[i]
    }

    /// One proximal round of stage E centred on `centre`, warm-started from the last.
    fn solve_elastic(&mut self, tier: u8, centre: &[f64; NU], penalty: f64, max_steps: u32) -> DenseStatus {
        let reach = std::array::from_fn(|j| self.input_min[j].abs().max(self.input_max[j].abs()).max(centre[j].abs()));
        let scale = self.metric.scaled_size(&reach).into_iter().fold(1.0, f64::max);
        let scaled_centre = self.metric.scaled(centre);
        let data = self.elastic.qp.data_mut();
        for j in 0..NU {
            data.q[j] = -scaled_centre[j];
        }
        data.q[NU] = penalty * scale;
        if self.work >= self.max_work {
            return DenseStatus::MaxWork;
        }
        let status = self.elastic.solve(usize::from(tier), max_steps, self.max_work - self.work, &mut self.work);
        self.steps += self.elastic.qp.steps();
        status
    }

    /// `t` within rounding of 0: the dense solver's tolerance in the units of `t`
    /// (weighted input).
    fn t_tolerance(&self, u: &[f64], u_ref: &[f64; NU]) -> f64 {
        let (u, u_ref) = (
            self.metric.scaled_size(&std::array::from_fn(|j| u[j].abs())),
            self.metric.scaled_size(&u_ref.map(f64::abs)),
        );
        let size = (0..NU).map(|j| u[j] + u_ref[j]).fold(0.0, f64::max);
        KKT_TOLERANCE * (1.0 + size)
    }

    /// What held row `i` of `tier` back in the last elastic stage: the hardest-pulling
    /// higher-tier row, else an input at its limit, else another row of the tier.
    fn stage_cause(&self, i: usize, tier: u8, rows: &[TieredRow<NU>]) -> Cause {
        let m = self.rows;
        let pull = |r: usize| self.elastic.pull(r);
        let threshold = MULTIPLIER_FRACTION * (0..m + NU).map(pull).fold(0.0, f64::max);
        let strongest = |candidates: &mut dyn Iterator<Item = usize>| {
            candidates.filter(|&r| pull(r) > threshold).max_by(|&p, &q| pull(p).total_cmp(&pull(q)))
        };
        let hard = |r: usize| self.standing[r] == Standing::Hard;
        if let Some(row) = strongest(&mut (0..m).filter(|&r| hard(r) && rows[r].tier < tier)) {
            return Cause::HigherPriority { row };
        }
        if let Some(j) = strongest(&mut (m..m + NU)) {
            let limit = if self.elastic.multiplier(j) < 0.0 { Limit::Min } else { Limit::Max };
            return Cause::InputLimit { input: j - m, limit };
        }
        if let Some(row) = strongest(&mut (0..m).filter(|&r| r != i && hard(r) && rows[r].tier == tier)) {
            return Cause::SamePriority { row };
        }
        Cause::NoAuthority
    }

    /// Start the next solve's first stage from this face (another solver's guess at the
    /// active rows and input bounds: rows `0..capacity`, then input `j` as row
    /// `capacity + j`) instead of where the last solve's first stage got to.
    pub fn suggest_first_face(&mut self, face: &[ActiveRow]) {
        self.hard.warm.set(WarmSlot::First.index(), face);
    }

    /// The input of the last solve: the answer when [`Outcome::Verified`], the point a
    /// stage reached when [`Outcome::StepLimit`] (unchanged on [`Outcome::NonFinite`]);
    /// inside the box.
    pub fn u(&self) -> &[f64; NU] {
        &self.u
    }

    /// Per row, the relaxation its tier's stage allowed (0 for rows that were met, not in
    /// the solve, or never relaxed).
    pub fn relaxation(&self) -> &[f64] {
        &self.relaxation
    }

    /// Per row, why it was relaxed, where a stage relaxed it or it has no authority.
    pub fn causes(&self) -> &[Option<Cause>] {
        &self.cause
    }

    /// Active-set changes over every stage of the last solve.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// Elastic stages the last solve needed (0 when every row fitted).
    pub fn elastic_stages(&self) -> u32 {
        self.elastic_stages
    }

    /// How the last solve ended.
    pub fn outcome(&self) -> Outcome {
        self.outcome
    }
}

fn dot<const NU: usize>(a: &[f64; NU], u: &[f64; NU]) -> f64 {
    (0..NU).map(|j| a[j] * u[j]).sum()
}

/// Most priority tiers: tiers are `0..TIERS`.
pub const TIERS: usize = 16;

/// Stage H's places in the cascade: the first solve, and per tier the solve restricted to
/// it and the ones above, and the full solve after it is settled.
const HARD_SLOTS: usize = 1 + 2 * TIERS;

/// Where in the cascade a stage-H solve is, for its warm start.
#[derive(Debug, Clone, Copy)]
enum WarmSlot {
    First,
    Restricted(u8),
    After(u8),
}

impl WarmSlot {
    fn index(self) -> usize {
        match self {
            WarmSlot::First => 0,
            WarmSlot::Restricted(tier) => 1 + 2 * usize::from(tier),
            WarmSlot::After(tier) => 2 + 2 * usize::from(tier),
        }
    }
}

/// Active sets of up to `width` rows, one per slot, in one buffer allocated once.
#[derive(Debug, Clone)]
struct WarmStarts {
    width: usize,
    rows: Vec<ActiveRow>,
    len: Vec<usize>,
}

impl WarmStarts {
    fn new(slots: usize, width: usize) -> Self {
        let empty = ActiveRow { row: 0, side: super::dual_active_set::Side::Lower };
        Self { width, rows: vec![empty; slots * width], len: vec![0; slots] }
    }

    fn get(&self, slot: usize) -> &[ActiveRow] {
        &self.rows[slot * self.width..slot * self.width + self.len[slot]]
    }

    fn set(&mut self, slot: usize, active: &[ActiveRow]) {
        let n = active.len().min(self.width);
        self.rows[slot * self.width..slot * self.width + n].copy_from_slice(&active[..n]);
        self.len[slot] = n;
    }

    /// Forget every slot from `first` on.
    fn forget_from(&mut self, first: usize) {
        self.len[first..].fill(0);
    }
}

/// The `n × n` identity, row-major.
fn identity(n: usize) -> Vec<f64> {
    let mut m = vec![0.0; n * n];
    for k in 0..n {
        m[k * n + k] = 1.0;
    }
    m
}
