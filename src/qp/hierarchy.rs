//! A strict hierarchy of least-squares tasks and inequalities (hierarchical, or
//! lexicographic, QP), solved level by level in the null space of the levels above: the
//! form a whole-body controller's priorities take (seed 004, Table I).
//!
//! Level `k` holds
//!
//! * a **task** `A_k z ≈ b_k` (least squares; its residual is what lower levels must not
//!   change),
//! * **hard** rows `l ≤ D z ≤ u` that must hold (physical limits: torques, friction), and
//! * **soft** rows of the same form that may give way, each by a slack `s` that the level
//!   minimises with its task (`l ≤ D z − s ≤ u`); a row that gave way is reported with its
//!   slack, never hidden (a barrier row is soft: it yields to the physics above it, and
//!   says so).
//!
//! Level `k` solves, over `z = z* + Z ξ` (`z*` the solution so far, `Z` an orthonormal
//! basis of the null space of every task above),
//!
//! ```text
//! minimise   ½ ‖A_k (z* + Z ξ) − b_k‖² + ½ ‖s‖² + ½ ε ‖ξ‖²
//! subject to its own hard rows and soft rows (with s), and every row of the levels above
//!            held where those levels left it (a soft row kept within its slack),
//! ```
//!
//! with [`DualActiveSet`] (exact, KKT-verified). Then `z* ← z* + Z ξ` and `Z` shrinks to
//! the null space of `A_k Z` (Householder QR with column pivoting; rank decided at
//! [`RANK_TOLERANCE`] of the largest pivot), so every later level keeps `A_k z` exactly
//! and every row above inside its bounds, or where the level above left it when that was past
//! a bound by no more than the tolerance its solve was verified to ([`PIN_ROOM`] of its
//! terms): a lower priority cannot change a higher one's residual, nor move a row further
//! past its bound. `ε = `[`REGULARISATION`]` · max(1, max diag ZᵀA_kᵀA_kZ)` makes each level's
//! minimiser unique (the smallest step among a level's optima); it moves a level's answer
//! by about `ε` relative, and keeps its cost matrix's condition below `1/ε`, where the
//! dual active-set solver's KKT check is reliable (at `1e-9` some random hierarchies ended
//! unverified).
//!
//! A level whose hard rows cannot hold with those above ends the solve there: its status
//! says so and `z*` is the last level's answer. Sizes are fixed at construction; a solve
//! does not allocate.
//!
//! # Example
//!
//! Two variables; priority 0 asks `z₀ + z₁ = 2` with `z₀ ≤ 0.5` hard, priority 1 asks
//! `z₀ = z₁`. Priority 0 leaves the line, and on it priority 1 would pick `(1, 1)`, which
//! the hard row forbids: `(0.5, 1.5)`. Priority 0's residual stays 0.
//!
//! ```
//! use cbfgen::qp::hierarchy::{Hierarchy, LevelShape, LevelStatus};
//!
//! let shapes = [LevelShape { tasks: 1, hard: 1, soft: 0 }, LevelShape { tasks: 1, hard: 0, soft: 0 }];
//! let mut qp = Hierarchy::new(2, &shapes)?;
//! let top = qp.level_mut(0);
//! top.task.copy_from_slice(&[1.0, 1.0]);
//! top.target[0] = 2.0;
//! top.rows.copy_from_slice(&[1.0, 0.0]);
//! top.lower[0] = f64::NEG_INFINITY;
//! top.upper[0] = 0.5;
//! let next = qp.level_mut(1);
//! next.task.copy_from_slice(&[1.0, -1.0]);
//! next.target[0] = 0.0;
//! qp.solve();
//! assert!(qp.reports().iter().all(|r| r.status == LevelStatus::Solved));
//! let z = qp.solution();
//! // Exact up to the regularisation ε (about 1e-7 of the task here).
//! assert!((z[0] - 0.5).abs() < 1e-6 && (z[1] - 1.5).abs() < 1e-6);
//! assert!(qp.reports()[0].residual < 1e-6);
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

// Index loops mirror the matrix formulas.
#![allow(clippy::needless_range_loop)]
use super::dual_active_set::{DenseStatus, DualActiveSet, WarmStart};
use crate::error::CbfError;

/// `ε` of each level's regularisation, relative to its task's largest diagonal (module docs).
pub const REGULARISATION: f64 = 1e-7;

/// A pivot of the task's QR below this fraction of the largest counts as zero: that
/// direction is not pinned (module docs).
pub const RANK_TOLERANCE: f64 = 1e-10;

/// A row of a level above that `z*` is past a bound of by no more than this, relative to the
/// size of its terms at `z*`, is held where `z*` puts it: the primal tolerance the dense
/// solver verified the level's answer to ([`KKT_TOLERANCE`](super::dual_active_set::KKT_TOLERANCE)).
pub const PIN_ROOM: f64 = super::dual_active_set::KKT_TOLERANCE;

/// Most steps one level's QP may take (rows added to its active set).
pub const MAX_STEPS: u32 = 500;

/// Rows of one level.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LevelShape {
    /// Rows of the least-squares task `A z ≈ b`.
    pub tasks: usize,
    /// Inequality rows that must hold.
    pub hard: usize,
    /// Inequality rows that may give way by a minimised slack.
    pub soft: usize,
}

/// One level's data, written before each [`Hierarchy::solve`] (kept between solves).
/// Matrices are row-major with `vars` columns; inequality rows are the hard ones first,
/// then the soft ones. An unused row is all zeros with infinite bounds (or zero target).
#[derive(Debug)]
pub struct LevelData<'a> {
    /// `A`, `tasks × vars`.
    pub task: &'a mut [f64],
    /// `b`, `tasks`.
    pub target: &'a mut [f64],
    /// `D`, `(hard + soft) × vars`.
    pub rows: &'a mut [f64],
    /// `l`, `hard + soft` (`−∞` for none).
    pub lower: &'a mut [f64],
    /// `u`, `hard + soft` (`+∞` for none).
    pub upper: &'a mut [f64],
}

/// How a level's solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LevelStatus {
    /// Solved and KKT-verified.
    Solved,
    /// Not attempted: a level above failed.
    Skipped,
    /// The level's solver ended otherwise (its hard rows cannot hold with the levels
    /// above: `Infeasible`; bad data; out of steps; unverified).
    Failed(DenseStatus),
}

/// What a level achieved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelReport {
    /// How its solve ended.
    pub status: LevelStatus,
    /// `‖A z − b‖` at the level's solution.
    pub residual: f64,
    /// The largest slack any of its soft rows needed (0 when every one held).
    pub largest_slack: f64,
    /// Directions of `z` still free below it.
    pub free: usize,
    /// The regularisation `ε` it used.
    pub regularisation: f64,
}

#[derive(Debug, Clone)]
struct Level {
    shape: LevelShape,
    task: Vec<f64>,
    target: Vec<f64>,
    rows: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    slack: Vec<f64>,
    /// One solver per count of free directions it may meet (`free + soft` variables, so a
    /// level works on its own size, not the whole `n`); `None` where that is 0, or a count
    /// the level cannot meet (the top level always has all `n`).
    solvers: Vec<Option<DualActiveSet>>,
    hessian: Vec<f64>,
}

/// The solver: every level's data and buffers.
#[derive(Debug, Clone)]
pub struct Hierarchy {
    n: usize,
    levels: Vec<Level>,
    reports: Vec<LevelReport>,
    z: Vec<f64>,
    /// `Z`, column-major `n × free` (the first `free` columns of an `n × n` buffer).
    basis: Vec<f64>,
    free: usize,
    /// Scratch: `A Z` (tasks × free, row-major), the QR's matrix, its reflectors and their
    /// β, the null-space columns of `Q`, the next `Z` and one reflector.
    projected: Vec<f64>,
    qr: Vec<f64>,
    reflectors: Vec<f64>,
    betas: Vec<f64>,
    null: Vec<f64>,
    next_basis: Vec<f64>,
    column: Vec<f64>,
}

impl Hierarchy {
    /// A hierarchy over `vars` variables with the levels `shapes`, highest priority first.
    /// Allocates every buffer a solve uses.
    ///
    /// # Errors
    /// `vars == 0` or no level.
    pub fn new(vars: usize, shapes: &[LevelShape]) -> Result<Self, CbfError> {
        if vars == 0 {
            return Err(CbfError::NotPositive { what: "hierarchy variables", value: 0.0 });
        }
        if shapes.is_empty() {
            return Err(CbfError::NotPositive { what: "hierarchy levels", value: 0.0 });
        }
        let n = vars;
        let mut above = 0;
        let mut levels = Vec::with_capacity(shapes.len());
        let mut widest_task = 0;
        for shape in shapes {
            let inequalities = shape.hard + shape.soft;
            above += inequalities;
            widest_task = widest_task.max(shape.tasks);
            let top = levels.is_empty();
            let mut solvers = Vec::with_capacity(n + 1);
            for free in 0..=n {
                let size = free + shape.soft;
                solvers.push(if size == 0 || (top && free != n) {
                    None
                } else {
                    let identity: Vec<f64> =
                        (0..size * size).map(|k| f64::from(u8::from(k % (size + 1) == 0))).collect();
                    Some(DualActiveSet::new(&identity, size, above)?)
                });
            }
            let widest = n + shape.soft;
            levels.push(Level {
                shape: *shape,
                task: vec![0.0; shape.tasks * n],
                target: vec![0.0; shape.tasks],
                rows: vec![0.0; inequalities * n],
                lower: vec![f64::NEG_INFINITY; inequalities],
                upper: vec![f64::INFINITY; inequalities],
                slack: vec![0.0; shape.soft],
                solvers,
                hessian: vec![0.0; widest * widest],
            });
        }
        let report = LevelReport {
            status: LevelStatus::Skipped,
            residual: 0.0,
            largest_slack: 0.0,
            free: n,
            regularisation: 0.0,
        };
        Ok(Self {
            n,
            reports: vec![report; levels.len()],
            levels,
            z: vec![0.0; n],
            basis: vec![0.0; n * n],
            free: n,
            projected: vec![0.0; widest_task.max(1) * n],
            qr: vec![0.0; n * widest_task.max(1)],
            reflectors: vec![0.0; n * n],
            betas: vec![0.0; n],
            null: vec![0.0; n * n],
            next_basis: vec![0.0; n * n],
            column: vec![0.0; n],
        })
    }

    /// Variables.
    pub fn vars(&self) -> usize {
        self.n
    }

    /// Levels.
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// Level `k`'s data to write (panics if `k` is not a level: a programming error).
    pub fn level_mut(&mut self, k: usize) -> LevelData<'_> {
        let level = &mut self.levels[k];
        LevelData {
            task: &mut level.task,
            target: &mut level.target,
            rows: &mut level.rows,
            lower: &mut level.lower,
            upper: &mut level.upper,
        }
    }

    /// The solution reached: every level's if all were solved, else the last solved one's.
    pub fn solution(&self) -> &[f64] {
        &self.z
    }

    /// Each level's outcome, highest priority first.
    pub fn reports(&self) -> &[LevelReport] {
        &self.reports
    }

    /// The slacks level `k`'s soft rows took (0 for a row that held).
    pub fn slacks(&self, k: usize) -> &[f64] {
        &self.levels[k].slack
    }

    /// Solve every level in order (module docs). Never panics; the solution stays finite.
    pub fn solve(&mut self) {
        let n = self.n;
        self.z.fill(0.0);
        self.basis.fill(0.0);
        for i in 0..n {
            self.basis[i * n + i] = 1.0;
        }
        self.free = n;
        for report in &mut self.reports {
            *report = LevelReport {
                status: LevelStatus::Skipped,
                residual: 0.0,
                largest_slack: 0.0,
                free: n,
                regularisation: 0.0,
            };
        }
        for level in &mut self.levels {
            level.slack.fill(0.0);
        }
        for k in 0..self.levels.len() {
            let status = self.solve_level(k);
            self.reports[k].status = status;
            if status != LevelStatus::Solved {
                return;
            }
            self.reports[k].residual = self.residual(k);
            self.pin_task(k);
            self.reports[k].free = self.free;
        }
    }

    fn residual(&self, k: usize) -> f64 {
        let level = &self.levels[k];
        let n = self.n;
        (0..level.shape.tasks)
            .map(|i| {
                let r: f64 = level.task[i * n..(i + 1) * n].iter().zip(&self.z).map(|(a, z)| a * z).sum::<f64>()
                    - level.target[i];
                r * r
            })
            .sum::<f64>()
            .sqrt()
    }

    /// `out = M Z` for row-major `M` (`rows × n`), `out` row-major `rows × free`; a copy
    /// while `Z` is still the identity (`free == n`: nothing pinned yet).
    fn project(basis: &[f64], n: usize, free: usize, m: &[f64], rows: usize, out: &mut [f64]) {
        if free == n {
            out[..rows * n].copy_from_slice(&m[..rows * n]);
            return;
        }
        for i in 0..rows {
            Self::project_row(basis, n, free, &m[i * n..(i + 1) * n], &mut out[i * free..(i + 1) * free]);
        }
    }

    /// One row: `out = dᵀ Z`.
    fn project_row(basis: &[f64], n: usize, free: usize, d: &[f64], out: &mut [f64]) {
        if free == n {
            out[..n].copy_from_slice(d);
            return;
        }
        for (c, o) in out[..free].iter_mut().enumerate() {
            *o = d.iter().zip(&basis[c * n..(c + 1) * n]).map(|(a, b)| a * b).sum();
        }
    }

    fn solve_level(&mut self, k: usize) -> LevelStatus {
        let (n, free) = (self.n, self.free);
        let shape = self.levels[k].shape;
        let size = free + shape.soft;
        if size == 0 {
            // Nothing left to move, no slack to take: the rows above hold at z*.
            return LevelStatus::Solved;
        }
        // Cost: ξ block ZᵀAᵀAZ + εI over the free directions, slack block I.
        let tasks = shape.tasks;
        Self::project(&self.basis, n, free, &self.levels[k].task, tasks, &mut self.projected);
        let level = &mut self.levels[k];
        level.hessian.fill(0.0);
        let mut largest = 1.0_f64;
        for a in 0..free {
            let mut d = 0.0;
            for i in 0..tasks {
                d += self.projected[i * free + a] * self.projected[i * free + a];
            }
            largest = largest.max(d);
        }
        let eps = REGULARISATION * largest;
        self.reports[k].regularisation = eps;
        // Σᵢ pᵢ pᵢᵀ over the rows pᵢ of AZ, upper triangle (all the solver reads), row by row.
        for p in self.projected[..tasks * free].chunks_exact(free) {
            for (a, &pa) in p.iter().enumerate() {
                if pa != 0.0 {
                    let row = &mut level.hessian[a * size + a..a * size + free];
                    for (h, pb) in row.iter_mut().zip(&p[a..]) {
                        *h += pa * pb;
                    }
                }
            }
        }
        for a in 0..free {
            level.hessian[a * size + a] += eps;
        }
        for a in free..size {
            level.hessian[a * size + a] = 1.0;
        }
        let Some(solver) = level.solvers[free].as_mut() else {
            return LevelStatus::Failed(DenseStatus::Unverified); // unreachable: sized for every count
        };
        if solver.set_hessian(&level.hessian[..size * size]).is_err() {
            return LevelStatus::Failed(DenseStatus::NonFiniteData);
        }
        // Linear cost: −(AZ)ᵀ (b − A z*).
        let data = solver.data_mut();
        data.q.fill(0.0);
        for i in 0..tasks {
            let row = &level.task[i * n..(i + 1) * n];
            let gap = level.target[i] - row.iter().zip(&self.z).map(|(a, z)| a * z).sum::<f64>();
            for a in 0..free {
                data.q[a] -= self.projected[i * free + a] * gap;
            }
        }
        // Rows: every level's inequalities down to this one, in D Z ξ (− s for this level's
        // soft rows), shifted by D z*; a level above keeps its soft rows within their slack.
        let (above, current) = self.levels.split_at_mut(k);
        let Level { shape: own, rows: own_rows, lower: own_lower, upper: own_upper, solvers, slack: own_slack, .. } =
            &mut current[0];
        let Some(solver) = solvers[free].as_mut() else {
            return LevelStatus::Failed(DenseStatus::Unverified);
        };
        let data = solver.data_mut();
        let sources = above
            .iter()
            .map(|l| (&l.shape, &l.rows, &l.lower, &l.upper, Some(&l.slack)))
            .chain(std::iter::once((&*own, &*own_rows, &*own_lower, &*own_upper, None)));
        let mut r = 0;
        for (shape, rows, lower, upper, kept) in sources {
            for i in 0..shape.hard + shape.soft {
                let d = &rows[i * n..(i + 1) * n];
                let shift: f64 = d.iter().zip(&self.z).map(|(a, z)| a * z).sum();
                let out = &mut data.a[r * size..(r + 1) * size];
                out.fill(0.0);
                Self::project_row(&self.basis, n, free, d, out);
                let slack = match kept {
                    Some(kept) if i >= shape.hard => kept[i - shape.hard],
                    _ => 0.0,
                };
                if kept.is_none() && i >= shape.hard {
                    out[free + i - shape.hard] = -1.0;
                }
                let (mut lower, mut upper) = (lower[i] + slack - shift, upper[i] + slack - shift);
                if kept.is_some() {
                    // A row above holds at z* (ξ = 0) up to the tolerance of the solve that
                    // put z* there: a bound z* is past by no more than that is moved to z*
                    // (held where it is, never loosened further, so the levels below cannot
                    // compound it), and a row no free direction moves beyond the rank
                    // decision's rounding is pinned (its rounding, scaled to a unit row,
                    // would read as a real constraint).
                    let terms: f64 = d.iter().zip(&self.z).map(|(a, z)| a.abs() * (1.0 + z.abs())).sum();
                    let room = PIN_ROOM * terms;
                    if lower > 0.0 && lower <= room {
                        lower = 0.0;
                    }
                    if upper < 0.0 && upper >= -room {
                        upper = 0.0;
                    }
                    let full = d.iter().map(|v| v * v).sum::<f64>().sqrt();
                    let moved = out[..free].iter().map(|v| v * v).sum::<f64>().sqrt();
                    if moved <= RANK_TOLERANCE * full {
                        out[..free].fill(0.0);
                    }
                }
                data.lower[r] = lower;
                data.upper[r] = upper;
                r += 1;
            }
        }
        solver.set_rows_in_use(r);
        let status = solver.solve(WarmStart::Previous, MAX_STEPS);
        if status != DenseStatus::Solved {
            return LevelStatus::Failed(status);
        }
        let x = solver.solution();
        for c in 0..free {
            let col = &self.basis[c * n..(c + 1) * n];
            for (z, b) in self.z.iter_mut().zip(col) {
                *z += b * x[c];
            }
        }
        own_slack.copy_from_slice(&x[free..free + shape.soft]);
        self.reports[k].largest_slack = own_slack.iter().fold(0.0_f64, |m, s| m.max(s.abs()));
        LevelStatus::Solved
    }

    /// Shrink `Z` to the null space of `A_k Z`: Householder QR with column pivoting of
    /// `(A_k Z)ᵀ` (`free × tasks`), `Q`'s columns past the rank span what stays free.
    fn pin_task(&mut self, k: usize) {
        let (n, free) = (self.n, self.free);
        let tasks = self.levels[k].shape.tasks;
        if tasks == 0 || free == 0 || k + 1 == self.levels.len() {
            return;
        }
        Self::project(&self.basis, n, free, &self.levels[k].task, tasks, &mut self.projected);
        // C = (A Z)ᵀ, column-major free × tasks: column i is task row i.
        let c = &mut self.qr;
        c[..free * tasks].copy_from_slice(&self.projected[..tasks * free]);
        // The reflectors, kept to form only the null-space columns of Q afterwards: step k's
        // v in column k of `reflectors` (rows k..free), its β in `betas`.
        let reflectors = &mut self.reflectors;
        let v = &mut self.column;
        let mut first = 0.0_f64;
        let mut rank = 0;
        for step in 0..free.min(tasks) {
            // Pivot: the remaining column of largest norm below row `step`.
            let (mut best, mut best_norm) = (step, -1.0);
            for j in step..tasks {
                let s: f64 = c[j * free + step..(j + 1) * free].iter().map(|x| x * x).sum();
                if s > best_norm {
                    (best, best_norm) = (j, s);
                }
            }
            let norm = best_norm.max(0.0).sqrt();
            if step == 0 {
                first = norm;
            }
            if norm == 0.0 || norm <= RANK_TOLERANCE * first || !norm.is_finite() {
                break;
            }
            if best != step {
                for i in 0..free {
                    c.swap(best * free + i, step * free + i);
                }
            }
            // Reflector H = I − β v vᵀ sending the column's tail to (α, 0, …).
            let x0 = c[step * free + step];
            let alpha = if x0 >= 0.0 { -norm } else { norm };
            v[step] = x0 - alpha;
            v[step + 1..free].copy_from_slice(&c[step * free + step + 1..(step + 1) * free]);
            let vv: f64 = v[step..free].iter().map(|x| x * x).sum();
            let beta = if vv > 0.0 { 2.0 / vv } else { 0.0 };
            for j in step..tasks {
                let col = &mut c[j * free..(j + 1) * free];
                let s: f64 = (step..free).map(|i| v[i] * col[i]).sum::<f64>() * beta;
                for i in step..free {
                    col[i] -= s * v[i];
                }
            }
            reflectors[step * free + step..(step + 1) * free].copy_from_slice(&v[step..free]);
            self.betas[step] = beta;
            rank = step + 1;
        }
        // N = Q[:, rank..] = H₀ H₁ … E (E the last columns of the identity), the reflectors
        // applied last to first; then Z ← Z N (N itself while Z is the identity).
        let remaining = free - rank;
        let null = &mut self.null;
        for c_out in 0..remaining {
            let col = &mut null[c_out * free..(c_out + 1) * free];
            col.fill(0.0);
            col[rank + c_out] = 1.0;
            for step in (0..rank).rev() {
                let r = &reflectors[step * free + step..(step + 1) * free];
                let s: f64 = r.iter().zip(&col[step..]).map(|(a, b)| a * b).sum::<f64>() * self.betas[step];
                for (x, a) in col[step..].iter_mut().zip(r) {
                    *x -= s * a;
                }
            }
        }
        if free == n {
            self.next_basis[..remaining * n].copy_from_slice(&null[..remaining * n]);
        } else {
            for c_out in 0..remaining {
                let weights = &null[c_out * free..(c_out + 1) * free];
                let out = &mut self.next_basis[c_out * n..(c_out + 1) * n];
                out.fill(0.0);
                for (l, &w) in weights.iter().enumerate() {
                    let zcol = &self.basis[l * n..(l + 1) * n];
                    for (o, b) in out.iter_mut().zip(zcol) {
                        *o += b * w;
                    }
                }
            }
        }
        self.basis[..remaining * n].copy_from_slice(&self.next_basis[..remaining * n]);
        self.free = remaining;
    }
}
