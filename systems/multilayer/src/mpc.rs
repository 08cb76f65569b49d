//! The low-rate kinematic MPC: positions are states, velocities are its inputs.
//!
//! At time `t` with measured `[q̂, v̂]`, sample time `δt` and horizon `N`:
//!
//! ```text
//! minimise   Σ_{k=1..N} w_q (q_k − q_ref)² + Σ_{k=0..N−1} w_v v_k² + Σ_{k=1..N−1} w_a ((v_k − v_{k−1}) / δt)²
//! subject to q_0 = q̂,   v_0 = v̂,   q_{k+1} = q_k + δt v_k                        (k = 0..N−1)
//!            and, by [`MpcMode`], for k = 2..N with t_k = t + k δt and h_k = q_k − s(t_k):
//!            DiscreteCbf:      h_k ≥ (1 − γ) h_{k−1}   i.e. q_k − (1 − γ) q_{k−1} ≥ s(t_k) − (1 − γ) s(t_{k−1})
//!            StateConstraint:  h_k ≥ 0                 i.e. q_k ≥ s(t_k)
//!            Unconstrained:    nothing
//! ```
//!
//! `v_0 = v̂` hands the tracking layer a reference continuous with the measured velocity;
//! the desired acceleration is the finite difference `a_des = (v_1 − v_0) / δt`. The
//! barrier rows start at k = 2 because `q_1 = q̂ + δt v̂` is fixed by the measurement:
//! a row on it could only be trivially true or infeasible. From k = 2 on every row has a
//! free velocity in it and velocities are unbounded, so the QP is always feasible.
//!
//! Both matrices are constant (the barrier is linear in `q` and its time dependence is in
//! the bounds), so a cycle only updates `l`/`u` and OSQP keeps its factorisation.
//!
//! # The dense solve
//!
//! OSQP sees the sparse form above (`2N + 1` variables, the dynamics as `N + 2` equality
//! rows, whose `P` is singular in `q_0`). The dense dual active-set solve
//! ([`cbfgen::qp::dual_active_set`]) needs a positive definite `P`, so it gets the condensed
//! form: with `q_k = q̂ + δt v̂ + δt Σ_{1≤i<k} v_i` the only variables are
//! `w = [v_1 … v_{N−1}]` (29 by default), the cost is
//!
//! ```text
//! ½ wᵀ H w + gᵀ w,  H = 2 w_q δt² [N − max(i, j)]_ij + 2 w_v I + 2 (w_a/δt²) D,
//!                   g_i = 2 w_q δt (N − i)(q̂ + δt v̂ − q_ref) − [i = 1] 2 (w_a/δt²) v̂
//! ```
//!
//! (`D` the difference matrix of `Σ (v_k − v_{k−1})²`: 2 on the diagonal, 1 in its last
//! entry, −1 beside it), and barrier row `k` reads `δt (1 − κ) Σ_{i≤k−2} w_i + δt w_{k−1} ≥
//! s(t_k) − κ s(t_{k−1}) − (1 − κ)(q̂ + δt v̂)` with `κ = 1 − γ` (0 for the state
//! constraint). `H` and the rows are constant: `H` is factorised once, each cycle writes
//! `g` and the bounds, and the dynamics hold exactly. Each solve starts from the last
//! solved active set moved one step along the horizon (one re-plan is one `δt` on). The
//! plan is then written back in the sparse form's layout.

use osqp::Problem;

use super::barrier::{check_state, SineBarrier, State};
use cbfgen::error::{within, CbfError};
use cbfgen::qp::csc::Csc;
use cbfgen::qp::dual_active_set::{ActiveRow, DenseStatus, DualActiveSet, WarmStart};
use cbfgen::qp::osqp_workspace::{self, OsqpQp};
use cbfgen::qp::INFINITY as INF;
use cbfgen::qp::{Backend, Iterate, QpStatus, Solver, SolverSettings};

/// Longest MPC horizon accepted (steps): the condensed QP grows with its square.
pub const MAX_HORIZON: usize = 1000;

/// What the MPC knows of the barrier.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MpcMode {
    /// The discrete-time CBF `h_{k} ≥ (1 − γ) h_{k−1}`, `γ ∈ (0, 1]` (the paper's proposal).
    DiscreteCbf {
        /// Decay `γ ∈ (0, 1]` per MPC step: `h` may shrink by at most this fraction of itself
        /// from one step to the next (1: only `h_k ≥ 0`).
        gamma: f64,
    },
    /// The state constraint `h(q_k, t_k) ≥ 0`.
    StateConstraint,
    /// No barrier information: only the high-rate CBF-QP keeps the system safe.
    Unconstrained,
}

impl MpcMode {
    /// Short name for tables and legends.
    pub fn name(&self) -> &'static str {
        match self {
            MpcMode::DiscreteCbf { .. } => "CBF in MPC + CBF-QP",
            MpcMode::StateConstraint => "state constraint in MPC + CBF-QP",
            MpcMode::Unconstrained => "no constraint in MPC + CBF-QP",
        }
    }
}

/// Horizon, weights and solver settings of the MPC.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MpcSettings {
    /// Sample time `δt` \[s\], also the re-planning period.
    pub dt: f64,
    /// Number of steps `N` (≥ 2).
    pub horizon: usize,
    /// The position it drives to \[m\].
    pub q_ref: f64,
    /// Weight `w_q` of the squared position error `(q_k − q_ref)²`.
    pub w_q: f64,
    /// Weight `w_v` of the squared planned velocity `v_k²`.
    pub w_v: f64,
    /// Weight `w_a` of the squared planned acceleration `((v_k − v_{k−1}) / δt)²`.
    pub w_a: f64,
    /// Solver settings of this layer: which solver, the dense budget, OSQP's settings.
    pub solver: SolverSettings,
}

impl Default for MpcSettings {
    /// 20 Hz over 1.5 s. The weights make it reach the reference in about two seconds
    /// with accelerations of about 2 m/s²; all are assumed (the paper gives none). The
    /// condensed QP's dense solve answers (a budget of 100 active-set changes; a cold
    /// solve with ten barrier rows binding takes about fifteen), OSQP only
    /// when it has no verified answer, to 1e-6 in up to 4000 iterations.
    fn default() -> Self {
        Self {
            dt: 0.05,
            horizon: 30,
            q_ref: 0.0,
            w_q: 10.0,
            w_v: 1.0,
            w_a: 2.0,
            solver: SolverSettings {
                backend: Solver::DenseThenOsqp,
                dense_max_steps: 100,
                eps_abs: 1e-6,
                eps_rel: 1e-6,
                max_iter: 4000,
                scaling: 10,
                ..SolverSettings::default()
            },
        }
    }
}

/// One MPC solution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MpcOutput {
    /// `(v_1 − v_0) / δt` [m/s²].
    pub desired_accel: f64,
    /// `Solved`, `SolvedInaccurate`, or a limit (its iterate, flagged), from the solver
    /// that answered.
    pub status: QpStatus,
    /// Which solver answered.
    pub answered_by: Backend,
    /// OSQP's ADMM iterations in this solve (0 when OSQP did not run).
    pub iterations: u32,
    /// The dense solve's active-set changes in this solve (0 when it did not run).
    pub dense_steps: u32,
}

/// The kinematic MPC, laid out once; [`KinematicMpc::solve`] only updates bounds.
pub struct KinematicMpc {
    settings: MpcSettings,
    mode: MpcMode,
    barrier: SineBarrier,
    p: Csc,
    a: Csc,
    q_lin: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    problem: Option<Problem>,
    /// The condensed QP's dense solver (see the module docs), when the backend uses it.
    dense: Option<DualActiveSet>,
    /// The next dense solve's warm start: the last solved active set, one row on.
    warm: Vec<ActiveRow>,
    z: Vec<f64>,
    /// ADMM iterations of the last solve (0 when OSQP did not run).
    iterations: u32,
    /// Active-set changes of the last dense solve (0 when it did not run).
    dense_steps: u32,
    /// How the last dense solve ended (`None` when it did not run).
    dense_status: Option<DenseStatus>,
    /// First barrier row.
    barrier_row: usize,
}

impl std::fmt::Debug for KinematicMpc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KinematicMpc")
            .field("mode", &self.mode)
            .field("settings", &self.settings)
            .finish_non_exhaustive()
    }
}

impl KinematicMpc {
    /// Sets up what `settings.solver.backend` can use: the condensed QP's dense solver
    /// (its `H` factorised once) and OSQP's workspace.
    ///
    /// # Errors
    /// A non-positive sample time, weight or γ outside (0, 1], a horizon below 2, or a
    /// solver refusing the set-up.
    pub fn new(settings: MpcSettings, mode: MpcMode, barrier: SineBarrier) -> Result<Self, CbfError> {
        let s = settings;
        s.solver.validate()?;
        // Ranges that keep w/dt² and the condensed products finite.
        within("MPC sample time", s.dt, 1e-4, 10.0, "[1e-4, 10] s")?;
        within("MPC position weight", s.w_q, 1e-6, 1e6, "[1e-6, 1e6]")?;
        within("MPC velocity weight", s.w_v, 1e-6, 1e6, "[1e-6, 1e6]")?;
        within("MPC acceleration weight", s.w_a, 1e-6, 1e6, "[1e-6, 1e6]")?;
        cbfgen::system::coordinate("MPC reference", s.q_ref)?;
        if s.horizon < 2 {
            return Err(CbfError::OutOfRange { what: "MPC horizon", value: s.horizon as f64, range: "[2, ∞)" });
        }
        if s.horizon > MAX_HORIZON {
            return Err(CbfError::TooLarge { what: "MPC horizon", value: s.horizon, max: MAX_HORIZON });
        }
        if let MpcMode::DiscreteCbf { gamma } = mode {
            if !(gamma > 0.0 && gamma <= 1.0) {
                return Err(CbfError::OutOfRange { what: "discrete CBF gamma", value: gamma, range: "(0, 1]" });
            }
        }
        let n = s.horizon;
        let (qi, vi) = (|k: usize| k, move |k: usize| n + 1 + k);
        let vars = 2 * n + 1;

        // Cost ½ zᵀ P z + q_linᵀ z; P upper triangle.
        let wa = s.w_a / (s.dt * s.dt);
        let p_value = |r: usize, c: usize| -> f64 {
            if r == c {
                if (1..=n).contains(&r) {
                    return 2.0 * s.w_q;
                }
                if r > n {
                    let k = r - (n + 1);
                    let neighbours = usize::from(k >= 1) + usize::from(k < n - 1);
                    return 2.0 * s.w_v + 2.0 * wa * neighbours as f64;
                }
                return 0.0;
            }
            if r > n && c == r + 1 {
                return -2.0 * wa;
            }
            0.0
        };
        let p = Csc::new(vars, vars, |r, c| c >= r && p_value(r, c) != 0.0, p_value);
        let mut q_lin = vec![0.0; vars];
        for k in 1..=n {
            q_lin[qi(k)] = -2.0 * s.w_q * s.q_ref;
        }

        // Rows: q_0, v_0, N dynamics rows, then the barrier rows.
        let barrier_rows = match mode {
            MpcMode::Unconstrained => 0,
            _ => n - 1,
        };
        let rows = 2 + n + barrier_rows;
        let keep_factor = match mode {
            MpcMode::DiscreteCbf { gamma } => 1.0 - gamma,
            _ => 0.0,
        };
        let a_value = move |r: usize, c: usize| -> f64 {
            match r {
                0 => f64::from(u8::from(c == qi(0))),
                1 => f64::from(u8::from(c == vi(0))),
                r if r < 2 + n => {
                    let k = r - 2;
                    if c == qi(k + 1) {
                        1.0
                    } else if c == qi(k) {
                        -1.0
                    } else if c == vi(k) {
                        -s.dt
                    } else {
                        0.0
                    }
                }
                r => {
                    let k = r - (2 + n) + 2;
                    if c == qi(k) {
                        1.0
                    } else if c == qi(k - 1) {
                        -keep_factor
                    } else {
                        0.0
                    }
                }
            }
        };
        let a = Csc::new(rows, vars, |r, c| a_value(r, c) != 0.0, a_value);
        let mut lower = vec![0.0; rows];
        let mut upper = vec![0.0; rows];
        for r in 2 + n..rows {
            (lower[r], upper[r]) = (-INF, INF);
        }
        let dense = match s.solver.backend {
            Solver::Osqp => None,
            _ => Some(condensed_solver(&s, keep_factor, barrier_rows)?),
        };
        let mut mpc = Self {
            settings,
            mode,
            barrier,
            p,
            a,
            q_lin,
            lower,
            upper,
            problem: None,
            dense,
            warm: Vec::with_capacity(2 * n),
            z: vec![0.0; vars],
            iterations: 0,
            dense_steps: 0,
            dense_status: None,
            barrier_row: 2 + n,
        };
        if s.solver.backend != Solver::Dense {
            osqp_workspace::set_up(&mut mpc)?;
        }
        Ok(mpc)
    }

    /// What the MPC knows of the barrier.
    pub fn mode(&self) -> MpcMode {
        self.mode
    }

    /// The settings it was built with.
    pub fn settings(&self) -> &MpcSettings {
        &self.settings
    }

    /// Plan from state `x` at time `t`, by the solver `settings.solver.backend` names
    /// (under [`Solver::DenseThenOsqp`] OSQP runs only when the dense solve has no verified
    /// answer). Allocation-free unless OSQP runs after a call that ended in a fault of
    /// its own (its workspace is then rebuilt).
    ///
    /// # Errors
    /// `x` or `t` not finite (nothing changes), or no usable iterate
    /// ([`CbfError::QpFailed`]).
    pub fn solve(&mut self, t: f64, x: &State) -> Result<MpcOutput, CbfError> {
        check_state(x, t)?;
        let n = self.settings.horizon;
        let dt = self.settings.dt;
        (self.lower[0], self.upper[0]) = (x[0], x[0]);
        (self.lower[1], self.upper[1]) = (x[1], x[1]);
        let keep = match self.mode {
            MpcMode::DiscreteCbf { gamma } => 1.0 - gamma,
            _ => 0.0,
        };
        if self.mode != MpcMode::Unconstrained {
            for k in 2..=n {
                let s_k = self.barrier.boundary(t + k as f64 * dt);
                let s_prev = self.barrier.boundary(t + (k - 1) as f64 * dt);
                self.lower[self.barrier_row + k - 2] = s_k - keep * s_prev;
            }
        }
        (self.iterations, self.dense_steps, self.dense_status) = (0, 0, None);
        let (status, answered_by) =
            self.settings.solver.backend.run(self, |mpc| mpc.solve_dense(x), osqp_workspace::solve);
        let (iterations, dense_steps) = (self.iterations, self.dense_steps);
        if !matches!(
            status,
            QpStatus::Solved | QpStatus::SolvedInaccurate | QpStatus::MaxIterations | QpStatus::TimeLimit
        ) {
            return Err(CbfError::QpFailed { layer: "kinematic MPC", status: status.name() });
        }
        let (v0, v1) = (self.z[n + 1], self.z[n + 2]);
        let desired_accel = (v1 - v0) / dt;
        if !desired_accel.is_finite() {
            return Err(CbfError::QpFailed { layer: "kinematic MPC", status: QpStatus::NonFinite.name() });
        }
        Ok(MpcOutput { desired_accel, status, answered_by, iterations, dense_steps })
    }

    /// The condensed QP (module docs) from `x`, with the barrier bounds [`Self::solve`]
    /// wrote for the sparse form, solved densely; on `Solved` (and on
    /// an iterate flagged `MaxIterations`) the plan is written back in the sparse layout.
    fn solve_dense(&mut self, x: &State) -> QpStatus {
        let Some(dense) = self.dense.as_mut() else { return QpStatus::SolverFault };
        let s = &self.settings;
        let (n, dt) = (s.horizon, s.dt);
        let wa = s.w_a / (dt * dt);
        let keep = match self.mode {
            MpcMode::DiscreteCbf { gamma } => 1.0 - gamma,
            _ => 0.0,
        };
        // q_k = c + δt Σ_{1≤i<k} w_i for k ≥ 1.
        let c = x[0] + dt * x[1];
        let data = dense.data_mut();
        for (j, g) in data.q.iter_mut().enumerate() {
            let i = j + 1;
            *g = 2.0 * s.w_q * dt * (n - i) as f64 * (c - s.q_ref);
        }
        data.q[0] -= 2.0 * wa * x[1];
        for (r, lower) in data.lower.iter_mut().enumerate() {
            // The same bound the sparse form's row k gets, with the fixed part moved over.
            *lower = self.lower[self.barrier_row + r] - (1.0 - keep) * c;
        }
        let status =
            dense.solve_within(WarmStart::Given(&self.warm), s.solver.dense_max_steps, s.solver.dense_max_work);
        self.dense_steps = dense.steps();
        self.dense_status = Some(status);
        if matches!(
            status,
            DenseStatus::Solved | DenseStatus::MaxSteps | DenseStatus::MaxWork | DenseStatus::Unverified
        ) {
            let w = dense.solution();
            self.z[0] = x[0];
            self.z[n + 1] = x[1];
            self.z[n + 2..].copy_from_slice(w);
            for k in 0..n {
                self.z[k + 1] = self.z[k] + dt * self.z[n + 1 + k];
            }
        }
        if status == DenseStatus::Solved {
            let rows = dense.rows();
            self.warm.clear();
            for &ActiveRow { row, side } in dense.active_set() {
                if row >= 1 {
                    self.warm.push(ActiveRow { row: row - 1, side });
                }
                if row + 1 == rows {
                    self.warm.push(ActiveRow { row, side });
                }
            }
        }
        status.qp_status()
    }

    /// Active-set changes of the last solve's dense attempt (0 when it did not run).
    pub fn dense_steps(&self) -> u32 {
        self.dense_steps
    }

    /// How the last solve's dense attempt ended (`None` when it did not run).
    pub fn dense_status(&self) -> Option<DenseStatus> {
        self.dense_status
    }

    /// The condensed QP's dense solver (`None` when the backend is OSQP), for diagnostics
    /// and cross-checks: `w = [v_1 … v_{N−1}]`, its multipliers and active set.
    pub fn dense_solver(&self) -> Option<&DualActiveSet> {
        self.dense.as_ref()
    }

    /// The last plan's positions `q_0..q_N` \[m\].
    pub fn planned_positions(&self) -> &[f64] {
        &self.z[..=self.settings.horizon]
    }

    /// The last plan's velocities `v_0..v_{N−1}` [m/s].
    pub fn planned_velocities(&self) -> &[f64] {
        &self.z[self.settings.horizon + 1..]
    }
}

impl OsqpQp for KinematicMpc {
    fn workspace(&mut self) -> &mut Option<Problem> {
        &mut self.problem
    }

    fn setup(&self) -> Result<Problem, CbfError> {
        Problem::new(
            self.p.view(),
            &self.q_lin,
            self.a.view(),
            &self.lower,
            &self.upper,
            &self.settings.solver.to_osqp(),
        )
        .map_err(|e| CbfError::SolverSetup { reason: e.to_string() })
    }

    fn update(&self, problem: &mut Problem) {
        problem.update_bounds(&self.lower, &self.upper);
    }

    fn read(&mut self, _status: QpStatus, iterate: Option<Iterate<'_>>, iterations: u32) {
        self.iterations = iterations;
        if let Some((z, _)) = iterate {
            self.z.copy_from_slice(z);
        }
    }
}

/// The condensed QP's solver (module docs): `H` built and factorised, the barrier rows
/// written (constant); `g` and the bounds are written per solve.
fn condensed_solver(s: &MpcSettings, keep: f64, barrier_rows: usize) -> Result<DualActiveSet, CbfError> {
    let (n, dt) = (s.horizon, s.dt);
    let vars = n - 1;
    let wa = s.w_a / (dt * dt);
    let mut hessian = vec![0.0; vars * vars];
    for a in 0..vars {
        for b in 0..vars {
            let (i, j) = (a + 1, b + 1);
            let mut h = 2.0 * s.w_q * dt * dt * (n - i.max(j)) as f64;
            if a == b {
                let differences = 1.0 + f64::from(u8::from(i < n - 1));
                h += 2.0 * s.w_v + 2.0 * wa * differences;
            } else if a.abs_diff(b) == 1 {
                h -= 2.0 * wa;
            }
            hessian[a * vars + b] = h;
        }
    }
    let mut dense = DualActiveSet::new(&hessian, vars, barrier_rows)?;
    let data = dense.data_mut();
    for r in 0..barrier_rows {
        let k = r + 2;
        let row = &mut data.a[r * vars..(r + 1) * vars];
        for (j, entry) in row.iter_mut().enumerate() {
            let i = j + 1;
            *entry = if i + 2 <= k {
                dt * (1.0 - keep)
            } else if i + 1 == k {
                dt
            } else {
                0.0
            };
        }
        data.upper[r] = f64::INFINITY;
    }
    Ok(dense)
}
