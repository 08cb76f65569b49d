//! The LIP-MPC, in condensed form: the feet are the only variables. It is solved exactly
//! by the dense dual active-set method ([`cbfgen::qp::dual_active_set`]), with OSQP as the
//! fallback and reference ([`SolverSettings::backend`]).
//!
//! ```text
//! z = [f_x,0, f_y,0, …, f_x,N−1, f_y,N−1]
//! ```
//!
//! Per axis the states follow from `x_0` and the feet in closed form,
//! `[p; v]_k = A_d^k [p; v]_0 + Σ_{i<k} A_d^{k−1−i} B_d f_i`, so the dynamics hold exactly
//! and need no rows. (A sparse form with the states as variables and the dynamics as
//! equality rows was tried first: OSQP needed thousands of iterations on it, because the
//! pendulum is unstable, `cosh βT ≈ 1.9` per step, and ADMM satisfies the equality chain
//! only approximately. Condensed, `P` is positive definite and a solve takes tens of
//! iterations.)
//!
//! The heading is not a variable: before each solve the turning rates are fixed
//! ([`HeadingRule`], after the report's section 5.1), with the bearing
//! `ψ = atan2(g − p_0)` to the goal. By default
//!
//! ```text
//! ω_k = clip(wrap(ψ − θ_k) / T, ω_min, ω_max),   θ_{k+1} = θ_k + ω_k T
//! ```
//!
//! The report instead clips the angle error at the start, `ψ − θ_0`, to the rate bounds
//! and uses that one rate for the whole horizon ([`HeadingRule::Report`]); dividing the
//! error by `T` per step makes it a rate, so the planned heading settles on the bearing
//! instead of turning past it when the error is smaller than one step's turn. With `θ_k`
//! known every row is linear in `z`:
//!
//! | rows | per step `k = 0..N−1` |
//! |---|---|
//! | walking velocity | `v_min ≤ [R(θ_k)ᵀ v_{k+1}] ∘ [1, s_v,k] ≤ v_max` |
//! | leg reachability | `−l_max ≤ R(θ_k)ᵀ (p_{k+1} − p_k) ≤ l_max` |
//! | maneuverability | `[R(θ_k)ᵀ v_{k+1}]_x ≤ v_x,max − (α/π)|ω_k|` |
//! | CBF, per obstacle | `ηᵀ p_{k+1} − (1 − γ) ηᵀ p_k ≥ γ (ηᵀ c + δ)`, i.e. `h(p_{k+1}) ≥ (1 − γ) h(p_k)` |
//!
//! Three readings of the report are ours. Its lateral sign `s_v` multiplies the lateral
//! velocity *after* rotation into the heading frame (the report writes it before; both agree
//! at `θ_k = 0`, and ours leaves the forward bound independent of the stance side).
//! Reachability bounds the CoM's move over the step, `p_{k+1} − p_k`: in the report each
//! position is measured from the previous CoM, which our single frame per solve writes out.
//! Maneuverability bounds the velocity the step produces, `v_{k+1}`: the report's `k = 0`
//! row would constrain only the measured `v_0`, which no input can change.
//!
//! `s_v,k = s_v,0 (−1)^k`: the stance foot alternates each step.
//!
//! Every row is first written on the states (`Σ c · x_k[component]`, as in the table) and
//! then expanded onto the feet, the known free response `A_d^k x_0` going to the bounds. Cost
//! `Σ_k ‖p_k − g‖²` becomes `½ zᵀ P z + qᵀ z` with `P = 2 Σ_k G_kᵀ G_k` (constant: `G_k`
//! maps the feet to `p_k`) and `q = 2 Σ_k G_kᵀ (free p_k − g)`. The constraint matrix's
//! sparsity is fixed at construction: a row on `x_k` touches the feet `f_0..f_{k−1}` of the
//! axes it uses, whatever its coefficients; unused obstacle slots keep their rows with zero
//! coefficients and bounds `(−∞, ∞)`. Each solve rewrites values only.
//!
//! The dense solve fits this QP: 2N variables (12 by default), hard rows, and a `P` that
//! never changes, so it is factorised once at construction; each solve starts from the
//! previous solve's active set moved one step along the horizon (typically two active-set
//! changes then finish it), and its answer is checked against the KKT conditions before
//! it is used. ADMM, by contrast, needed up to 4000 iterations here and sometimes
//! stopped only at its "inaccurate" tolerances. Under [`Solver::DenseThenOsqp`] (the
//! default) OSQP runs only when the dense solve has no verified answer (out of steps, or
//! rounding on a degenerate problem); it then receives the same data (`update_lin_cost`,
//! `update_A`, `update_bounds`) and warm-starts from its previous iterate. After
//! construction nothing allocates, on either path.

use std::f64::consts::PI;

use osqp::Problem;

use super::model::{LipInput, LipState};
use super::obstacles::HalfPlane;
use super::LipParams;
use cbfgen::error::CbfError;
use cbfgen::qp::csc::Csc;
use cbfgen::qp::dual_active_set::{ActiveRow, DenseStatus, DualActiveSet, WarmStart};
use cbfgen::qp::osqp_workspace::{self, OsqpQp};
use cbfgen::qp::{Backend, Iterate, QpStatus, Solver, SolverSettings, INFINITY as INF};

/// How the turning rates `ω_k` are fixed before each solve, with `ψ` the bearing to the
/// goal from the CoM and `θ` the current heading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum HeadingRule {
    /// `ω_k = clip(wrap(ψ − θ_k) / T, ω_min, ω_max)` per step: each step's turn closes
    /// the remaining error when it can, and the planned heading settles on `ψ` (ours).
    #[default]
    PerStepRate,
    /// `ω_k = clip(wrap(ψ − θ), ω_min, ω_max)` for every `k`, as the report writes it: one
    /// rate for the whole horizon, from the angle error itself. Within the rate bounds a
    /// step turns `T·(ψ − θ)`, so the plan's later steps keep turning past `ψ`.
    Report,
}

impl HeadingRule {
    /// `"per-step"` or `"report"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::PerStepRate => "per-step",
            Self::Report => "report",
        }
    }
}

/// An obstacle slot that does not constrain: zero normal (its rows get bounds (−∞, ∞)).
const UNUSED_PLANE: HalfPlane = HalfPlane { normal: [0.0, 0.0], point: [0.0, 0.0], delta: 0.0, inside: false };

/// The last solved plan, in the frame the MPC was given its state in.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    states: Vec<LipState>,
    inputs: Vec<LipInput>,
    stance_signs: Vec<f64>,
    planes: Vec<HalfPlane>,
    plane_count: usize,
    goal: [f64; 2],
}

impl Plan {
    /// `x_0 … x_N`; positions and velocities from the QP, `θ_k` from the preprocessing.
    pub fn states(&self) -> &[LipState] {
        &self.states
    }

    /// `u_0 … u_{N−1}`: feet from the QP, `ω_k` from the preprocessing.
    pub fn inputs(&self) -> &[LipInput] {
        &self.inputs
    }

    /// `s_v,k` for each step of the horizon.
    pub fn stance_signs(&self) -> &[f64] {
        &self.stance_signs
    }

    /// The obstacle half-planes the plan respects.
    pub fn planes(&self) -> &[HalfPlane] {
        &self.planes[..self.plane_count]
    }

    /// The goal the plan steers to.
    pub fn goal(&self) -> [f64; 2] {
        self.goal
    }
}

/// Sizes and row offsets of each constraint group (see the module docs' table).
#[derive(Debug, Clone, Copy)]
struct Layout {
    n: usize,
    obstacles: usize,
}

impl Layout {
    fn foot_var(&self, k: usize, axis: usize) -> usize {
        2 * k + axis
    }
    fn vars(&self) -> usize {
        2 * self.n
    }
    fn rows(&self) -> usize {
        self.n * self.rows_per_step()
    }
    /// Rows of one step of the horizon (they come step by step, in the same order).
    fn rows_per_step(&self) -> usize {
        5 + self.obstacles
    }
}

/// One term `coef · x_step[component]` of a row written on the states; `component` indexes
/// `[p_x, v_x, p_y, v_y]`.
#[derive(Debug, Clone, Copy)]
struct Term {
    step: usize,
    component: usize,
    coef: f64,
}

const fn term(step: usize, component: usize, coef: f64) -> Term {
    Term { step, component, coef }
}

/// This step's linearisation: the preprocessed headings and signs, the obstacles'
/// half-planes (padded with unused ones), and the free response of `x_0`.
#[derive(Debug, Clone)]
struct Linearisation {
    params: LipParams,
    layout: Layout,
    /// `gain[k][i]` = `A_d^{k−1−i} B_d` (per axis: effect of `f_i` on `[p, v]_k`), `i < k`.
    gain: Vec<Vec<[f64; 2]>>,
    /// `free[k][axis]` = `A_d^k [p; v]_0` of that axis.
    free: Vec<[[f64; 2]; 2]>,
    headings: Vec<f64>,
    omegas: Vec<f64>,
    signs: Vec<f64>,
    planes: Vec<HalfPlane>,
    plane_count: usize,
    x0: LipState,
    goal: [f64; 2],
}

impl Linearisation {
    fn new(params: LipParams, max_obstacles: usize) -> Self {
        let layout = Layout { n: params.horizon, obstacles: max_obstacles };
        let n = layout.n;
        let lip = params.lip;
        let mut gain = vec![Vec::new(); n + 1];
        for k in 1..=n {
            // f_{k−1} acts through B_d; older feet through one more A_d each.
            let mut g = vec![[0.0; 2]; k];
            g[k - 1] = lip.b_d;
            for i in (0..k - 1).rev() {
                let [p, v] = g[i + 1];
                g[i] = [lip.a_d[0][0] * p + lip.a_d[0][1] * v, lip.a_d[1][0] * p + lip.a_d[1][1] * v];
            }
            gain[k] = g;
        }
        Self {
            params,
            layout,
            gain,
            free: vec![[[0.0; 2]; 2]; n + 1],
            headings: vec![0.0; n + 1],
            omegas: vec![0.0; n],
            signs: vec![1.0; n],
            planes: vec![UNUSED_PLANE; max_obstacles],
            plane_count: 0,
            x0: [0.0; 5],
            goal: [0.0; 2],
        }
    }

    /// The heading preprocessing ([`HeadingRule`]), the alternating stance signs and the
    /// free response of `x0`.
    fn preprocess(&mut self, x0: &LipState, goal: [f64; 2], stance_sign: f64) {
        let (lip, [w_min, w_max]) = (self.params.lip, self.params.omega_bounds);
        let bearing = (goal[1] - x0[2]).atan2(goal[0] - x0[0]);
        self.x0 = *x0;
        self.goal = goal;
        self.headings[0] = x0[4];
        for k in 0..self.layout.n {
            self.omegas[k] = match self.params.heading {
                HeadingRule::PerStepRate => {
                    (wrap_angle(bearing - self.headings[k]) / lip.step_time).clamp(w_min, w_max)
                }
                HeadingRule::Report => wrap_angle(bearing - x0[4]).clamp(w_min, w_max),
            };
            self.headings[k + 1] = self.headings[k] + self.omegas[k] * lip.step_time;
            self.signs[k] = if k % 2 == 0 { stance_sign } else { -stance_sign };
        }
        self.free[0] = [[x0[0], x0[1]], [x0[2], x0[3]]];
        for k in 0..self.layout.n {
            for axis in 0..2 {
                let (p, v) = lip.axis_step(self.free[k][axis][0], self.free[k][axis][1], 0.0);
                self.free[k + 1][axis] = [p, v];
            }
        }
    }

    /// Every row written on the states, with its bounds, always in the same order.
    fn for_each_row(&self, mut row: impl FnMut(&[Term], f64, f64)) {
        let p = &self.params;
        let (n, gamma) = (self.layout.n, p.gamma);
        for k in 0..n {
            let (s, c) = self.headings[k].sin_cos();
            let sv = self.signs[k];
            let next = k + 1;
            // Walking velocity on v_{k+1}: forward, then s_v · lateral.
            row(&[term(next, 1, c), term(next, 3, s)], p.vx_bounds[0], p.vx_bounds[1]);
            row(&[term(next, 1, -sv * s), term(next, 3, sv * c)], p.vy_bounds[0], p.vy_bounds[1]);
            // Leg reachability on p_{k+1} − p_k, along and across the heading.
            for [ax, ay] in [[c, s], [-s, c]] {
                let terms = [term(next, 0, ax), term(next, 2, ay), term(k, 0, -ax), term(k, 2, -ay)];
                row(&terms, -p.leg_reach, p.leg_reach);
            }
            // Maneuverability: forward velocity capped by the turn.
            row(&[term(next, 1, c), term(next, 3, s)], -INF, p.maneuver_limit(self.omegas[k]));
            // CBF: ηᵀ p_{k+1} − (1 − γ) ηᵀ p_k ≥ γ (ηᵀ c + δ).
            for (j, plane) in self.planes.iter().enumerate() {
                let [ex, ey] = plane.normal;
                let terms = [
                    term(next, 0, ex),
                    term(next, 2, ey),
                    term(k, 0, -(1.0 - gamma) * ex),
                    term(k, 2, -(1.0 - gamma) * ey),
                ];
                let offset = ex * plane.point[0] + ey * plane.point[1] + plane.delta;
                let lower = if j < self.plane_count { gamma * offset } else { -INF };
                row(&terms, lower, INF);
            }
        }
    }

    /// Expand every row onto the feet: `entry(row, foot variable, coefficient)` for each
    /// structural entry in a fixed order, and `bounds(row, lower, upper)` with the free
    /// response moved over. `scratch` holds one row's coefficients (length `2N`).
    fn expand(
        &self,
        scratch: &mut [f64],
        mut entry: impl FnMut(usize, usize, f64),
        mut bounds: impl FnMut(usize, f64, f64),
    ) {
        let l = self.layout;
        let mut index = 0;
        self.for_each_row(|terms, lower, upper| {
            scratch.fill(0.0);
            let mut known = 0.0;
            let mut feet = [0usize; 2]; // per axis: this row touches f_0..f_{feet−1}
            for t in terms {
                let (axis, pv) = (t.component / 2, t.component % 2);
                known += t.coef * self.free[t.step][axis][pv];
                for (i, g) in self.gain[t.step].iter().enumerate() {
                    scratch[l.foot_var(i, axis)] += t.coef * g[pv];
                }
                feet[axis] = feet[axis].max(t.step);
            }
            // Each row divided by its norm: an exact rescaling that keeps rows on feet far
            // back (gains grow like cosh^k βT) from dominating ADMM's residuals.
            let norm = scratch.iter().map(|v| v * v).sum::<f64>().sqrt();
            let scale = if norm > 0.0 { 1.0 / norm } else { 1.0 };
            for i in 0..l.n {
                for (axis, &count) in feet.iter().enumerate() {
                    if i < count {
                        entry(index, l.foot_var(i, axis), scale * scratch[l.foot_var(i, axis)]);
                    }
                }
            }
            let shift = |b: f64| if b.abs() >= INF { b } else { scale * (b - known) };
            bounds(index, shift(lower), shift(upper));
            index += 1;
        });
    }

    /// `P = 2 Σ_k G_kᵀ G_k` (the same for both axes), upper triangle, column-major.
    fn hessian(&self) -> Csc {
        let l = self.layout;
        // Feet f_i and f_j (i ≤ j) both move p_k for k > j; an axis meets only itself.
        let value = |r: usize, c: usize| -> f64 {
            let (i, j) = (r / 2, c / 2);
            (j + 1..=l.n).map(|k| 2.0 * self.gain[k][i][0] * self.gain[k][j][0]).sum()
        };
        Csc::new(l.vars(), l.vars(), |r, c| r <= c && r % 2 == c % 2, value)
    }

    /// `q = 2 Σ_k G_kᵀ (free p_k − g)`.
    fn write_linear_cost(&self, q: &mut [f64]) {
        let l = self.layout;
        for (col, q) in q.iter_mut().enumerate() {
            let (i, axis) = (col / 2, col % 2);
            *q = (i + 1..=l.n).map(|k| 2.0 * self.gain[k][i][0] * (self.free[k][axis][0] - self.goal[axis])).sum();
        }
    }

    /// States `x_0..x_N` under the feet `z`, by the model, with the preprocessed headings.
    fn states(&self, z: &[f64], out: &mut [LipState]) {
        let lip = self.params.lip;
        out[0] = self.x0;
        for k in 0..self.layout.n {
            let u = [z[2 * k], z[2 * k + 1], self.omegas[k]];
            out[k + 1] = lip.step(&out[k], &u);
            out[k + 1][4] = self.headings[k + 1];
        }
    }
}

/// `a` wrapped into `(−π, π]`.
pub fn wrap_angle(a: f64) -> f64 {
    let w = (a + PI).rem_euclid(2.0 * PI) - PI;
    if w <= -PI {
        w + 2.0 * PI
    } else {
        w
    }
}

/// The LIP-MPC with its dense solver and OSQP workspace (each set up when
/// [`SolverSettings::backend`] can use it).
pub struct LipMpc {
    lin: Linearisation,
    p: Csc,
    /// `a.data[entry_slot[t]]` is the `t`-th coefficient [`Linearisation::expand`] yields.
    entry_slot: Vec<usize>,
    a: Csc,
    scratch: Vec<f64>,
    q: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    problem: Option<Problem>,
    /// The dense solver, holding `P`'s factor and a dense copy of the data.
    dense: Option<DualActiveSet>,
    /// The next dense solve's warm start: the last solved active set, one step on (room
    /// for two entries per active row: the last step's rows are kept as well).
    warm: Vec<ActiveRow>,
    settings: SolverSettings,
    plan: Plan,
    status: QpStatus,
    /// ADMM iterations of the last solve (0 when OSQP did not run).
    iterations: u32,
    /// Active-set changes of the last solve's dense attempt (0 when it did not run).
    dense_steps: u32,
    /// How the last dense attempt ended (`None` when it did not run).
    dense_status: Option<DenseStatus>,
    /// Which solver produced the last status.
    answered_by: Backend,
}

impl std::fmt::Debug for LipMpc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LipMpc")
            .field("horizon", &self.lin.layout.n)
            .field("obstacles", &self.lin.layout.obstacles)
            .field("rows", &self.lin.layout.rows())
            .field("nnz", &self.a.data.len())
            .field("status", &self.status)
            .field("answered_by", &self.answered_by)
            .finish_non_exhaustive()
    }
}

impl LipMpc {
    /// Solver settings for this QP: the dense solve first, with a budget of 100 active-set
    /// changes, then OSQP as the fallback with tight tolerances (the plan is checked row by
    /// row, and a step every 0.4 s leaves ample time), up to 4000 iterations, no polish
    /// (OSQP's allocates, and this crate's polish is for the ECBF filter's QP).
    pub fn default_solver_settings() -> SolverSettings {
        SolverSettings {
            backend: Solver::DenseThenOsqp,
            dense_max_steps: 100,
            eps_abs: 1e-6,
            eps_rel: 1e-6,
            max_iter: 4000,
            polish: false,
            ..SolverSettings::default()
        }
    }

    /// Lay the QP out for `params.horizon` steps and up to `max_obstacles` obstacles, and
    /// set up the solvers `settings.backend` can use: the dense one (`P` factorised once)
    /// and OSQP's workspace, so that neither allocates when it runs.
    ///
    /// # Errors
    /// Invalid parameters or settings, or a solver refusing the set-up.
    pub fn new(params: LipParams, max_obstacles: usize, settings: SolverSettings) -> Result<Self, CbfError> {
        params.validate()?;
        settings.validate()?;
        let lin = Linearisation::new(params, max_obstacles);
        let layout = lin.layout;
        let n = layout.n;
        // The pattern: every entry the value pass will ever write, sorted column-major.
        let mut scratch = vec![0.0; layout.vars()];
        let mut entries = Vec::new();
        lin.expand(&mut scratch, |row, col, _| entries.push((row, col)), |_, _, _| {});
        let (a, entry_slot) = Csc::from_entries(layout.rows(), layout.vars(), &entries);
        let p = lin.hessian();
        let mut mpc = Self {
            lin,
            p,
            entry_slot,
            a,
            scratch,
            q: vec![0.0; layout.vars()],
            lower: vec![-INF; layout.rows()],
            upper: vec![INF; layout.rows()],
            problem: None,
            dense: None,
            warm: Vec::with_capacity(2 * layout.vars()),
            settings,
            plan: Plan {
                states: vec![[0.0; 5]; n + 1],
                inputs: vec![[0.0; 3]; n],
                stance_signs: vec![1.0; n],
                planes: vec![UNUSED_PLANE; max_obstacles],
                plane_count: 0,
                goal: [0.0; 2],
            },
            status: QpStatus::Solved,
            iterations: 0,
            dense_steps: 0,
            dense_status: None,
            answered_by: if settings.backend == Solver::Osqp { Backend::Osqp } else { Backend::Dense },
        };
        mpc.write_values();
        if settings.backend != Solver::Osqp {
            let vars = layout.vars();
            // P dense from its upper triangle (the dense solver reads only that half).
            let mut hessian = vec![0.0; vars * vars];
            for col in 0..vars {
                for k in mpc.p.indptr[col]..mpc.p.indptr[col + 1] {
                    hessian[mpc.p.indices[k] * vars + col] = mpc.p.data[k];
                }
            }
            mpc.dense = Some(DualActiveSet::new(&hessian, vars, layout.rows())?);
        }
        if settings.backend != Solver::Dense {
            osqp_workspace::set_up(&mut mpc)?;
        }
        Ok(mpc)
    }

    /// Rewrite `A`, `q` and the bounds from the current linearisation.
    fn write_values(&mut self) {
        let (slots, data, lower, upper) = (&self.entry_slot, &mut self.a.data, &mut self.lower, &mut self.upper);
        let mut t = 0;
        self.lin.expand(
            &mut self.scratch,
            |_, _, v| {
                data[slots[t]] = v;
                t += 1;
            },
            |row, lo, hi| (lower[row], upper[row]) = (lo, hi),
        );
        self.lin.write_linear_cost(&mut self.q);
    }

    /// Plan from local state `x0` to `goal` past the obstacles `planes` (all in one frame),
    /// with stance sign `s_v,0 = stance_sign` (+1: right foot, −1: left).
    ///
    /// Returns the status of the solver that answered ([`LipMpc::answered_by`]): the dense
    /// solve's ([`DenseStatus::qp_status`]: `Solved` only when its KKT check passed) or,
    /// when it ran, OSQP's. On `Solved`/`SolvedInaccurate` [`LipMpc::plan`] is the new
    /// plan; on any other status it keeps the last solved one, which was made in an
    /// earlier frame: the caller must not apply it as is. Does not allocate unless OSQP
    /// runs after a call that reported [`QpStatus::SolverFault`] or [`QpStatus::NonFinite`]
    /// from it (its workspace is then rebuilt).
    ///
    /// # Errors
    /// NaN/inf in `x0`, `goal` or a plane, or an entry beyond
    /// [`STATE_LIMIT`](cbfgen::system::STATE_LIMIT); `stance_sign` not ±1, or more planes than the
    /// MPC was built for. Nothing is changed then.
    pub fn solve(
        &mut self,
        x0: &LipState,
        goal: [f64; 2],
        stance_sign: f64,
        planes: &[HalfPlane],
    ) -> Result<QpStatus, CbfError> {
        // The legged model's domain: no coordinate whose products in the condensed QP
        // could overflow.
        for &v in x0 {
            cbfgen::system::coordinate("LIP state", v)?;
        }
        cbfgen::system::coordinate("goal x", goal[0])?;
        cbfgen::system::coordinate("goal y", goal[1])?;
        if stance_sign != 1.0 && stance_sign != -1.0 {
            return Err(CbfError::OutOfRange { what: "stance sign", value: stance_sign, range: "{−1, +1}" });
        }
        if planes.len() > self.lin.planes.len() {
            return Err(CbfError::CapacityExceeded { what: "obstacles", capacity: self.lin.planes.len() });
        }
        for plane in planes {
            for v in plane.normal.into_iter().chain(plane.point).chain([plane.delta]) {
                cbfgen::system::coordinate("obstacle half-plane", v)?;
            }
        }

        self.lin.preprocess(x0, goal, stance_sign);
        self.lin.plane_count = planes.len();
        for (slot, plane) in self.lin.planes.iter_mut().zip(planes.iter().chain(std::iter::repeat(&UNUSED_PLANE))) {
            *slot = *plane;
        }
        self.write_values();
        (self.iterations, self.dense_steps, self.dense_status) = (0, 0, None);
        let status;
        (status, self.answered_by) = self.settings.backend.run(self, Self::solve_dense, osqp_workspace::solve);
        self.status = status;
        Ok(status)
    }

    /// The dense solve, warm-started from the last solved active set moved one step along
    /// the horizon (the robot has taken the plan's first step, so what bound at step
    /// `k + 1` is likely to bind at step `k` now; the last step keeps its own rows too).
    /// Keeps the plan only when the KKT check passed.
    fn solve_dense(&mut self) -> QpStatus {
        let Some(dense) = self.dense.as_mut() else { return QpStatus::SolverFault };
        let vars = self.lin.layout.vars();
        let data = dense.data_mut();
        for col in 0..vars {
            for k in self.a.indptr[col]..self.a.indptr[col + 1] {
                data.a[self.a.indices[k] * vars + col] = self.a.data[k];
            }
        }
        data.q.copy_from_slice(&self.q);
        data.lower.copy_from_slice(&self.lower);
        data.upper.copy_from_slice(&self.upper);
        let status = dense.solve_within(
            WarmStart::Given(&self.warm),
            self.settings.dense_max_steps,
            self.settings.dense_max_work,
        );
        self.dense_steps = dense.steps();
        self.dense_status = Some(status);
        if status == DenseStatus::Solved {
            store_plan(&self.lin, &mut self.plan, dense.solution());
            let (per_step, rows) = (self.lin.layout.rows_per_step(), self.lin.layout.rows());
            self.warm.clear();
            for &ActiveRow { row, side } in dense.active_set() {
                if row >= per_step {
                    self.warm.push(ActiveRow { row: row - per_step, side });
                }
                if row >= rows - per_step {
                    self.warm.push(ActiveRow { row, side });
                }
            }
        }
        status.qp_status()
    }

    /// The last solved plan.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// Status of the last solve, from the solver that answered ([`LipMpc::answered_by`]).
    pub fn status(&self) -> QpStatus {
        self.status
    }

    /// ADMM iterations of the last solve (0 when OSQP did not run).
    pub fn iterations(&self) -> u32 {
        self.iterations
    }

    /// Active-set changes the last solve's dense attempt took (0 when it did not run).
    pub fn dense_steps(&self) -> u32 {
        self.dense_steps
    }

    /// How the last solve's dense attempt ended (`None` when it did not run).
    pub fn dense_status(&self) -> Option<DenseStatus> {
        self.dense_status
    }

    /// The dense solver (`None` when the backend is OSQP): its last solution, row
    /// multipliers and active set, for diagnostics and cross-checks.
    pub fn dense_solver(&self) -> Option<&DualActiveSet> {
        self.dense.as_ref()
    }

    /// Which solver gave the last status: [`Backend::Osqp`] when OSQP is the backend or
    /// ran as the fallback.
    pub fn answered_by(&self) -> Backend {
        self.answered_by
    }

    /// The parameters the MPC was built with.
    pub fn params(&self) -> &LipParams {
        &self.lin.params
    }

    /// The QP of the last call to [`LipMpc::solve`] as OSQP received it, for cross-checks
    /// with other solvers: `min ½ zᵀPz + qᵀz s.t. l ≤ Az ≤ u`, `z` the feet.
    pub fn qp(&self) -> QpView<'_> {
        QpView {
            p_indptr: &self.p.indptr,
            p_indices: &self.p.indices,
            p_data: &self.p.data,
            q: &self.q,
            a_indptr: &self.a.indptr,
            a_indices: &self.a.indices,
            a_data: &self.a.data,
            lower: &self.lower,
            upper: &self.upper,
            infinity: INF,
        }
    }

    /// Constraint rows (including unused obstacle slots) and variables of the QP.
    pub fn dimensions(&self) -> (usize, usize) {
        (self.lin.layout.rows(), self.lin.layout.vars())
    }
}

/// A read-only view of the QP (see [`LipMpc::qp`]); `P` (upper triangle) and `A` are
/// column-major (CSC).
#[derive(Debug, Clone, PartialEq)]
pub struct QpView<'a> {
    /// Column pointers of `P` (one per variable, plus one).
    pub p_indptr: &'a [usize],
    /// Row index of each stored entry of `P`.
    pub p_indices: &'a [usize],
    /// Value of each stored entry of `P` (upper triangle).
    pub p_data: &'a [f64],
    /// The linear cost `q`, one entry per variable (the feet, `f_x,0, f_y,0, …`).
    pub q: &'a [f64],
    /// Column pointers of `A` (one per variable, plus one).
    pub a_indptr: &'a [usize],
    /// Row index of each stored entry of `A`.
    pub a_indices: &'a [usize],
    /// Value of each stored entry of `A` (each row divided by its norm).
    pub a_data: &'a [f64],
    /// Lower bound `l` of each row; [`QpView::infinity`] negated for none.
    pub lower: &'a [f64],
    /// Upper bound `u` of each row; [`QpView::infinity`] for none.
    pub upper: &'a [f64],
    /// The value standing for ±∞ in `lower`/`upper`.
    pub infinity: f64,
}

impl OsqpQp for LipMpc {
    fn workspace(&mut self) -> &mut Option<Problem> {
        &mut self.problem
    }

    fn setup(&self) -> Result<Problem, CbfError> {
        Problem::new(self.p.view(), &self.q, self.a.view(), &self.lower, &self.upper, &self.settings.to_osqp())
            .map_err(|e| CbfError::SolverSetup { reason: e.to_string() })
    }

    fn update(&self, problem: &mut Problem) {
        problem.update_lin_cost(&self.q);
        problem.update_A(self.a.view());
        problem.update_bounds(&self.lower, &self.upper);
    }

    fn read(&mut self, status: QpStatus, iterate: Option<Iterate<'_>>, iterations: u32) {
        self.iterations = iterations;
        // A plan is kept only when solved: an iterate stopped at a limit is not a plan.
        if let Some((z, _)) = iterate.filter(|_| status.is_solved()) {
            store_plan(&self.lin, &mut self.plan, z);
        }
    }
}

/// Keep the feet `z` as the plan, with the states, headings and obstacles it was made for.
fn store_plan(lin: &Linearisation, plan: &mut Plan, z: &[f64]) {
    lin.states(z, &mut plan.states);
    for (k, u) in plan.inputs.iter_mut().enumerate() {
        *u = [z[2 * k], z[2 * k + 1], lin.omegas[k]];
    }
    plan.stance_signs.copy_from_slice(&lin.signs);
    plan.planes.copy_from_slice(&lin.planes);
    plan.plane_count = lin.plane_count;
    plan.goal = lin.goal;
}
