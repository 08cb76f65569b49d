//! One iteration of a nonlinear MPC: the QP of a discrete-time optimal-control problem,
//! linearised by its caller, solved on a sparsity laid out once by OSQP (ADMM) or by a
//! Riccati-recursion interior-point method ([`OcpMethod`]).
//!
//! Variables are the states and inputs of every stage, interleaved
//! `z = (x₀, u₀, x₁, u₁, …, x_{N−1}, u_{N−1}, x_N)` so that the KKT matrix is banded. The
//! rows are the initial state `x₀ = x̂`, then per stage `k` the dynamics
//! `x_{k+1} = A_k x_k + B_k u_k + c_k` and the stage's constraints
//! `l_k ≤ C_k x_k + D_k u_k ≤ u_k`, then the terminal stage's `l_N ≤ C_N x_N ≤ u_N`. The
//! cost is `½ Σ_k (x_k − r_k)ᵀ Q_k (x_k − r_k) + (u_k − s_k)ᵀ R_k (u_k − s_k)` with
//! diagonal `Q_k`, `R_k`.
//!
//! The caller fixes at construction which entries of `A`, `B`, `C` and `D` can be non-zero
//! ([`OcpShape`]); each iteration it writes the values into dense per-stage blocks
//! ([`Ocp::stage_mut`]) and [`Ocp::solve`] gathers them into OSQP's matrices in place (no
//! allocation, one refactorisation), or runs the interior-point method on them where they
//! lie. A stage uses as many constraint rows as it needs and
//! leaves the rest free (`±∞`, zero coefficients): the pattern is the union over stages.
//! A real-time iteration scheme (one QP per control period on the dynamics linearised at
//! the last plan, shifted) is this plus the caller's linearisation.
//!
//! A double integrator brought from rest at 0 to rest at 1 m in 2 s with the least
//! `Σ u²` and `|u| ≤ 1 m/s²` (the bound binds: without it the peak is 1.5 m/s²), by both
//! methods:
//!
//! ```
//! use cbfgen::qp::ocp::{Ocp, OcpMethod, OcpShape};
//! use cbfgen::qp::{QpStatus, SolverSettings};
//!
//! let (n, dt) = (20, 0.1);
//! let settings = SolverSettings { eps_abs: 1e-8, eps_rel: 1e-8, max_iter: 10_000, ..SolverSettings::DEFAULT };
//! let mut plans = Vec::new();
//! for method in [OcpMethod::InteriorPoint, OcpMethod::Admm] {
//!     // Two rows per stage: the input's bound; on the terminal stage, position and velocity.
//!     let mut ocp = Ocp::with_method(OcpShape::dense(n, 2, 1, 2), settings, method)?;
//!     ocp.initial_state_mut().copy_from_slice(&[0.0, 0.0]);
//!     for k in 0..=n {
//!         let mut s = ocp.stage_mut(k);
//!         s.free_rows();
//!         s.q.fill(0.0);
//!         if k < n {
//!             s.a.copy_from_slice(&[1.0, dt, 0.0, 1.0]);
//!             s.b.copy_from_slice(&[0.5 * dt * dt, dt]);
//!             s.offset.fill(0.0);
//!             (s.r[0], s.u_ref[0]) = (1.0, 0.0);
//!             s.d[0] = 1.0;
//!             (s.lower[0], s.upper[0]) = (-1.0, 1.0);
//!         } else {
//!             s.c.copy_from_slice(&[1.0, 0.0, 0.0, 1.0]);
//!             s.lower.copy_from_slice(&[1.0, 0.0]);
//!             s.upper.copy_from_slice(&[1.0, 0.0]);
//!         }
//!     }
//!     assert_eq!(ocp.solve(), QpStatus::Solved);
//!     assert!((ocp.state(n)[0] - 1.0).abs() < 1e-6 && ocp.state(n)[1].abs() < 1e-6);
//!     assert!((0..n).all(|k| ocp.input(k)[0].abs() <= 1.0 + 1e-6));
//!     assert!((ocp.input(0)[0] - 1.0).abs() < 1e-6, "full thrust at the start");
//!     plans.push(ocp.solution().to_vec());
//! }
//! // The two methods agree on the plan.
//! assert!(plans[0].iter().zip(&plans[1]).all(|(a, b)| (a - b).abs() < 1e-4));
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

use osqp::Problem;

use super::csc::Csc;
use super::osqp_workspace::{self, OsqpQp};
use super::riccati_ipm::{self, RiccatiIpm};
use super::{Iterate, QpStatus, SolverSettings, INFINITY};
use crate::error::CbfError;

/// Most stages an [`Ocp`] takes (the layout is sized by it at construction).
pub const MAX_HORIZON: usize = 10_000;

/// What an [`Ocp`] is made of: its horizon, its sizes and which entries of the stage
/// matrices can be non-zero (row-major masks; `true` where an entry may be non-zero at
/// some iteration).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OcpShape {
    /// Stages `N` (inputs `u₀ … u_{N−1}`, states `x₀ … x_N`), at least 1.
    pub horizon: usize,
    /// States per stage.
    pub states: usize,
    /// Inputs per stage.
    pub inputs: usize,
    /// Constraint rows per stage (at most; the terminal stage has as many, on `x_N` only).
    pub rows: usize,
    /// `A`'s pattern, `states × states`.
    pub a: Vec<bool>,
    /// `B`'s pattern, `states × inputs`.
    pub b: Vec<bool>,
    /// `C`'s pattern, `rows × states`.
    pub c: Vec<bool>,
    /// `D`'s pattern, `rows × inputs`.
    pub d: Vec<bool>,
}

impl OcpShape {
    /// Every entry of every matrix may be non-zero.
    pub fn dense(horizon: usize, states: usize, inputs: usize, rows: usize) -> Self {
        Self {
            horizon,
            states,
            inputs,
            rows,
            a: vec![true; states * states],
            b: vec![true; states * inputs],
            c: vec![true; rows * states],
            d: vec![true; rows * inputs],
        }
    }

    fn check(&self) -> Result<(), CbfError> {
        if self.horizon == 0 {
            return Err(CbfError::OutOfRange { what: "OCP horizon", value: 0.0, range: "[1, 10000]" });
        }
        if self.horizon > MAX_HORIZON {
            return Err(CbfError::TooLarge { what: "OCP horizon", value: self.horizon, max: MAX_HORIZON });
        }
        if self.states == 0 {
            return Err(CbfError::OutOfRange { what: "OCP states", value: 0.0, range: "[1, ∞)" });
        }
        for (what, mask, expected) in [
            ("OCP pattern A", &self.a, self.states * self.states),
            ("OCP pattern B", &self.b, self.states * self.inputs),
            ("OCP pattern C", &self.c, self.rows * self.states),
            ("OCP pattern D", &self.d, self.rows * self.inputs),
        ] {
            if mask.len() != expected {
                return Err(CbfError::LengthMismatch { what, expected, got: mask.len() });
            }
        }
        Ok(())
    }
}

/// One stage's data, written by the caller before [`Ocp::solve`]. Matrices are dense and
/// row-major; entries outside the [`OcpShape`] pattern are ignored. Constraint rows a
/// stage does not use keep bounds `±∞` (as after [`Stage::free_rows`]). The terminal
/// stage has no `b`, `offset`, `d`, `r` or `u_ref` (empty slices).
#[derive(Debug)]
pub struct Stage<'a> {
    /// `A_k`, `states × states`.
    pub a: &'a mut [f64],
    /// `B_k`, `states × inputs`.
    pub b: &'a mut [f64],
    /// `c_k`: `x_{k+1} = A_k x_k + B_k u_k + c_k`.
    pub offset: &'a mut [f64],
    /// `C_k`, `rows × states`.
    pub c: &'a mut [f64],
    /// `D_k`, `rows × inputs`.
    pub d: &'a mut [f64],
    /// Row lower bounds (`-INFINITY` for none).
    pub lower: &'a mut [f64],
    /// Row upper bounds (`INFINITY` for none).
    pub upper: &'a mut [f64],
    /// `Q_k`'s diagonal (≥ 0).
    pub q: &'a mut [f64],
    /// `R_k`'s diagonal (> 0 keeps the QP strictly convex in the inputs).
    pub r: &'a mut [f64],
    /// `r_k`: the state reference.
    pub x_ref: &'a mut [f64],
    /// `s_k`: the input reference.
    pub u_ref: &'a mut [f64],
}

impl Stage<'_> {
    /// Zero every constraint row's coefficients and free its bounds.
    pub fn free_rows(&mut self) {
        self.c.fill(0.0);
        self.d.fill(0.0);
        self.lower.fill(-INFINITY);
        self.upper.fill(INFINITY);
    }
}

/// Where each stage's blocks live in the flat staging buffers.
#[derive(Debug, Clone, Copy)]
struct Sizes {
    nx: usize,
    nu: usize,
    rows: usize,
}

/// The QP of one MPC iteration (module docs).
pub struct Ocp {
    shape: OcpShape,
    settings: SolverSettings,
    /// The staged data, stage `k`'s block of each at `k * size` (`A`, `B`, `c`, `D`, `R`
    /// and `u_ref` for the N inner stages; the rest also for the terminal one).
    a: Vec<f64>,
    b: Vec<f64>,
    offset: Vec<f64>,
    c: Vec<f64>,
    d: Vec<f64>,
    row_lower: Vec<f64>,
    row_upper: Vec<f64>,
    q: Vec<f64>,
    r: Vec<f64>,
    x_ref: Vec<f64>,
    u_ref: Vec<f64>,
    initial: Vec<f64>,
    /// OSQP's data.
    p: Csc,
    linear: Vec<f64>,
    matrix: Csc,
    lower: Vec<f64>,
    upper: Vec<f64>,
    /// `(slot in matrix.data, sign, buffer, index in it)` for every entry of the
    /// constraint matrix that the stages write.
    gather: Vec<(usize, f64, Source, usize)>,
    problem: Option<Problem>,
    /// The interior-point workspace, under [`OcpMethod::InteriorPoint`].
    ipm: Option<Box<RiccatiIpm>>,
    solution: Vec<f64>,
    duals: Vec<f64>,
    has_solution: bool,
    status: QpStatus,
    iterations: u32,
}

/// Which method solves an [`Ocp`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OcpMethod {
    /// OSQP's ADMM on the whole sparse KKT system, warm-started from the last solution:
    /// cheap iterations, but their number grows with how hard the rows bind. Takes every
    /// [`SolverSettings`] field that concerns OSQP.
    #[default]
    Admm,
    /// Mehrotra's primal-dual interior-point method, each Newton step a Riccati recursion
    /// along the horizon (linear in `N`, the patterns used in every product): tens of
    /// steps whatever the conditioning, from a cold start. Reads `eps_abs` (the largest
    /// residual and the mean complementarity accepted) and `max_iter` (Newton steps) of
    /// [`SolverSettings`]; needs every `R_k` positive (a singular input Hessian reads as
    /// [`QpStatus::SolverFault`]). Rows with no common point read as
    /// [`QpStatus::PrimalInfeasible`] once a multiplier passes 10¹², and the iterate is
    /// still handed back (it is not an optimum).
    InteriorPoint,
}

/// Which staged matrix an entry of OSQP's constraint matrix comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Source {
    A,
    B,
    C,
    D,
}

impl std::fmt::Debug for Ocp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ocp").field("shape", &self.shape).field("status", &self.status).finish_non_exhaustive()
    }
}

impl Ocp {
    /// Lay out the QP of `shape` and set OSQP up on it (all stage data zero, rows free,
    /// `Q = 0`, `R = I`). OSQP's data scaling stays off whatever `settings.scaling` says
    /// (it would be computed on this first data only): choose units in which states,
    /// inputs and rows are of comparable size.
    ///
    /// # Errors
    /// A horizon outside `[1, MAX_HORIZON]`, no states, a pattern of the wrong length,
    /// settings outside their ranges, or OSQP refusing the set-up.
    pub fn new(shape: OcpShape, settings: SolverSettings) -> Result<Self, CbfError> {
        Self::with_method(shape, settings, OcpMethod::Admm)
    }

    /// As [`Ocp::new`], solved by `method`.
    ///
    /// # Errors
    /// As [`Ocp::new`] (OSQP is set up only for [`OcpMethod::Admm`]).
    pub fn with_method(shape: OcpShape, settings: SolverSettings, method: OcpMethod) -> Result<Self, CbfError> {
        shape.check()?;
        settings.validate()?;
        let (n, nx, nu, m) = (shape.horizon, shape.states, shape.inputs, shape.rows);
        let stride = nx + nu;
        let vars = n * stride + nx;
        let xi = |k: usize| k * stride;
        let ui = |k: usize| k * stride + nx;
        // Rows: x₀, then per stage dynamics and constraints, then the terminal constraints.
        let stage_row = |k: usize| nx + k * (nx + m);
        let rows = nx + n * (nx + m) + m;

        let mut entries = Vec::new();
        let mut fixed = Vec::new(); // (entry index, value)
        let mut sources = Vec::new(); // (entry index, sign, source, index)
        for i in 0..nx {
            fixed.push((entries.len(), 1.0));
            entries.push((i, xi(0) + i));
        }
        for k in 0..=n {
            let top = stage_row(k);
            if k < n {
                for i in 0..nx {
                    fixed.push((entries.len(), 1.0));
                    entries.push((top + i, xi(k + 1) + i));
                    for j in (0..nx).filter(|&j| shape.a[i * nx + j]) {
                        sources.push((entries.len(), -1.0, Source::A, k * nx * nx + i * nx + j));
                        entries.push((top + i, xi(k) + j));
                    }
                    for j in (0..nu).filter(|&j| shape.b[i * nu + j]) {
                        sources.push((entries.len(), -1.0, Source::B, k * nx * nu + i * nu + j));
                        entries.push((top + i, ui(k) + j));
                    }
                }
            }
            let top = if k < n { top + nx } else { top };
            for i in 0..m {
                for j in (0..nx).filter(|&j| shape.c[i * nx + j]) {
                    sources.push((entries.len(), 1.0, Source::C, k * m * nx + i * nx + j));
                    entries.push((top + i, xi(k) + j));
                }
                if k < n {
                    for j in (0..nu).filter(|&j| shape.d[i * nu + j]) {
                        sources.push((entries.len(), 1.0, Source::D, k * m * nu + i * nu + j));
                        entries.push((top + i, ui(k) + j));
                    }
                }
            }
        }
        let (mut matrix, slots) = Csc::from_entries(rows, vars, &entries);
        for &(e, v) in &fixed {
            matrix.data[slots[e]] = v;
        }
        let gather = sources.iter().map(|&(e, sign, source, index)| (slots[e], sign, source, index)).collect();
        let p = Csc::identity(vars);
        let mut ocp = Self {
            settings,
            a: vec![0.0; n * nx * nx],
            b: vec![0.0; n * nx * nu],
            offset: vec![0.0; n * nx],
            c: vec![0.0; (n + 1) * m * nx],
            d: vec![0.0; n * m * nu],
            row_lower: vec![-INFINITY; (n + 1) * m],
            row_upper: vec![INFINITY; (n + 1) * m],
            q: vec![0.0; (n + 1) * nx],
            r: vec![1.0; n * nu],
            x_ref: vec![0.0; (n + 1) * nx],
            u_ref: vec![0.0; n * nu],
            initial: vec![0.0; nx],
            linear: vec![0.0; vars],
            lower: vec![0.0; rows],
            upper: vec![0.0; rows],
            p,
            matrix,
            gather,
            problem: None,
            ipm: None,
            solution: vec![0.0; vars],
            duals: vec![0.0; rows],
            has_solution: false,
            status: QpStatus::SolverFault,
            iterations: 0,
            shape,
        };
        match method {
            OcpMethod::Admm => {
                ocp.assemble();
                osqp_workspace::set_up(&mut ocp)?;
            }
            OcpMethod::InteriorPoint => {
                let s = &ocp.shape;
                ocp.ipm = Some(Box::new(RiccatiIpm::new(n, nx, nu, m, &s.a, &s.b, &s.c, &s.d)));
            }
        }
        Ok(ocp)
    }

    /// The shape it was built with.
    pub fn shape(&self) -> &OcpShape {
        &self.shape
    }

    fn sizes(&self) -> Sizes {
        Sizes { nx: self.shape.states, nu: self.shape.inputs, rows: self.shape.rows }
    }

    /// The initial state `x̂` (`x₀` is pinned to it).
    pub fn initial_state_mut(&mut self) -> &mut [f64] {
        &mut self.initial
    }

    /// Stage `k`'s data, `k ≤ N` (stage `N` is terminal: only `C`, bounds, `Q`, `x_ref`).
    ///
    /// # Panics
    /// `k > N` (a caller's indexing error).
    pub fn stage_mut(&mut self, k: usize) -> Stage<'_> {
        let n = self.shape.horizon;
        assert!(k <= n, "stage {k} of a horizon of {n}");
        let Sizes { nx, nu, rows: m } = self.sizes();
        let inner = if k < n { 1 } else { 0 };
        let span = |size: usize| k * size..k * size + size * inner;
        Stage {
            a: &mut self.a[span(nx * nx)],
            b: &mut self.b[span(nx * nu)],
            offset: &mut self.offset[span(nx)],
            c: &mut self.c[k * m * nx..(k + 1) * m * nx],
            d: &mut self.d[span(m * nu)],
            lower: &mut self.row_lower[k * m..(k + 1) * m],
            upper: &mut self.row_upper[k * m..(k + 1) * m],
            q: &mut self.q[k * nx..(k + 1) * nx],
            r: &mut self.r[span(nu)],
            x_ref: &mut self.x_ref[k * nx..(k + 1) * nx],
            u_ref: &mut self.u_ref[span(nu)],
        }
    }

    /// Gather the staged data into OSQP's matrices and vectors (no allocation).
    fn assemble(&mut self) {
        let Sizes { nx, nu, rows: m } = self.sizes();
        let n = self.shape.horizon;
        let stride = nx + nu;
        for &(slot, sign, source, index) in &self.gather {
            let value = match source {
                Source::A => self.a[index],
                Source::B => self.b[index],
                Source::C => self.c[index],
                Source::D => self.d[index],
            };
            self.matrix.data[slot] = sign * value;
        }
        // P = diag(Q, R, …); the linear term −Q r, −R s.
        for k in 0..=n {
            for i in 0..nx {
                let (w, target) = (self.q[k * nx + i], self.x_ref[k * nx + i]);
                self.p.data[k * stride + i] = w;
                self.linear[k * stride + i] = -w * target;
            }
            if k < n {
                for j in 0..nu {
                    let (w, target) = (self.r[k * nu + j], self.u_ref[k * nu + j]);
                    self.p.data[k * stride + nx + j] = w;
                    self.linear[k * stride + nx + j] = -w * target;
                }
            }
        }
        self.lower[..nx].copy_from_slice(&self.initial);
        self.upper[..nx].copy_from_slice(&self.initial);
        for k in 0..=n {
            let mut top = nx + k * (nx + m);
            if k < n {
                self.lower[top..top + nx].copy_from_slice(&self.offset[k * nx..(k + 1) * nx]);
                self.upper[top..top + nx].copy_from_slice(&self.offset[k * nx..(k + 1) * nx]);
                top += nx;
            }
            for i in 0..m {
                self.lower[top + i] = self.row_lower[k * m + i].max(-INFINITY);
                self.upper[top + i] = self.row_upper[k * m + i].min(INFINITY);
            }
        }
    }

    /// The method it solves with.
    pub fn method(&self) -> OcpMethod {
        if self.ipm.is_some() {
            OcpMethod::InteriorPoint
        } else {
            OcpMethod::Admm
        }
    }

    /// Solve the QP as staged. ADMM gathers the data, refactorises and runs OSQP
    /// warm-started from the last solution; the interior-point method starts from the
    /// last solution (or the warm start) with fresh slacks and multipliers.
    /// Allocation-free unless a fault rebuilt OSQP's workspace. Data with
    /// a NaN or infinity (bounds aside: `±∞` is no bound) reads as [`QpStatus::NonFinite`]
    /// and a negative weight as [`QpStatus::NonConvex`], before OSQP sees either; the next
    /// solve on good data is unaffected.
    pub fn solve(&mut self) -> QpStatus {
        let finite = [&self.a, &self.b, &self.offset, &self.c, &self.d, &self.q, &self.r, &self.x_ref]
            .iter()
            .all(|v| v.iter().all(|e| e.is_finite()))
            && self.u_ref.iter().chain(&self.initial).all(|e| e.is_finite())
            && self.row_lower.iter().chain(&self.row_upper).all(|e| !e.is_nan());
        let convex = self.q.iter().chain(&self.r).all(|&w| w >= 0.0);
        if !finite || !convex {
            self.status = if finite { QpStatus::NonConvex } else { QpStatus::NonFinite };
            self.has_solution = false;
            return self.status;
        }
        if let Some(ipm) = self.ipm.as_mut() {
            let data = riccati_ipm::Data {
                a: &self.a,
                b: &self.b,
                offset: &self.offset,
                c: &self.c,
                d: &self.d,
                lower: &self.row_lower,
                upper: &self.row_upper,
                q: &self.q,
                r: &self.r,
                x_ref: &self.x_ref,
                u_ref: &self.u_ref,
                initial: &self.initial,
            };
            self.status =
                ipm.solve(&data, self.settings.eps_abs, self.settings.max_iter, &mut self.solution, &mut self.duals);
            self.iterations = ipm.iterations();
            self.has_solution = self.status != QpStatus::NonFinite && self.status != QpStatus::SolverFault;
            return self.status;
        }
        self.assemble();
        self.status = osqp_workspace::solve(self);
        self.status
    }

    /// How the last solve ended.
    pub fn status(&self) -> QpStatus {
        self.status
    }

    /// Iterations of the last solve (ADMM's, or the interior-point method's Newton steps).
    pub fn iterations(&self) -> u32 {
        self.iterations
    }

    /// Whether the last solve left an iterate ([`Ocp::state`], [`Ocp::input`]): an optimum
    /// when [`QpStatus::is_solved`], else the point OSQP stopped at.
    pub fn has_solution(&self) -> bool {
        self.has_solution
    }

    /// `x_k` of the last iterate, `k ≤ N`.
    ///
    /// # Panics
    /// `k > N`.
    pub fn state(&self, k: usize) -> &[f64] {
        let Sizes { nx, nu, .. } = self.sizes();
        &self.solution[k * (nx + nu)..k * (nx + nu) + nx]
    }

    /// `u_k` of the last iterate, `k < N`.
    ///
    /// # Panics
    /// `k ≥ N`.
    pub fn input(&self, k: usize) -> &[f64] {
        let Sizes { nx, nu, .. } = self.sizes();
        assert!(k < self.shape.horizon, "input {k} of a horizon of {}", self.shape.horizon);
        &self.solution[k * (nx + nu) + nx..(k + 1) * (nx + nu)]
    }

    /// The multipliers of stage `k`'s constraint rows (OSQP's sign: positive on an active
    /// upper bound, negative on an active lower bound).
    pub fn row_duals(&self, k: usize) -> &[f64] {
        let Sizes { nx, rows: m, .. } = self.sizes();
        let top = nx + k * (nx + m) + if k < self.shape.horizon { nx } else { 0 };
        &self.duals[top..top + m]
    }

    /// Warm-start the next solve from a guess of every stage's state and input (`z` laid
    /// out as the variables, module docs), for example the last plan shifted by one stage.
    ///
    /// # Errors
    /// `z` of the wrong length or not finite.
    pub fn warm_start(&mut self, z: &[f64]) -> Result<(), CbfError> {
        if z.len() != self.solution.len() {
            return Err(CbfError::LengthMismatch {
                what: "OCP warm start",
                expected: self.solution.len(),
                got: z.len(),
            });
        }
        if let Some(&value) = z.iter().find(|v| !v.is_finite()) {
            return Err(CbfError::NonFinite { what: "OCP warm start", value });
        }
        if let Some(problem) = self.problem.as_mut() {
            problem.warm_start_x(z);
        }
        if let Some(ipm) = self.ipm.as_mut() {
            ipm.warm_start(z);
        }
        Ok(())
    }

    /// The last iterate, laid out as the variables (module docs).
    pub fn solution(&self) -> &[f64] {
        &self.solution
    }
}

impl OsqpQp for Ocp {
    fn workspace(&mut self) -> &mut Option<Problem> {
        &mut self.problem
    }

    fn setup(&self) -> Result<Problem, CbfError> {
        // OSQP's own scaling is computed once, at set-up, and its matrix updates rescale
        // with it: on an iteration's new data that stalled re-solves at the iteration
        // limit in the tests. The caller chooses its units instead.
        let settings = self.settings.to_osqp().scaling(None);
        Problem::new(self.p.view(), &self.linear, self.matrix.view(), &self.lower, &self.upper, &settings)
            .map_err(|e| CbfError::SolverSetup { reason: e.to_string() })
    }

    fn update(&self, problem: &mut Problem) {
        problem.update_P_A(self.p.view(), self.matrix.view());
        problem.update_lin_cost(&self.linear);
        problem.update_bounds(&self.lower, &self.upper);
    }

    fn read(&mut self, _status: QpStatus, iterate: Option<Iterate<'_>>, iterations: u32) {
        self.iterations = iterations;
        self.has_solution = iterate.is_some();
        if let Some((z, y)) = iterate {
            self.solution.copy_from_slice(z);
            self.duals.copy_from_slice(y);
        }
    }
}
