//! The optimal-control QP's interior-point solver: Mehrotra's predictor–corrector on the
//! QP of [`super::ocp`], each Newton system solved by a Riccati recursion along the
//! horizon.
//!
//! Why a second solver: ADMM's iteration count grows with how hard the rows bind (a
//! legged MPC's foothold rows took OSQP 600–1 300 iterations per QP, against 90 without
//! them). An interior-point method takes a few tens of Newton steps whatever the
//! conditioning, and the Riccati recursion solves each in time linear in the horizon,
//! using the dynamics' and rows' sparsity patterns for every product.
//!
//! Each finite side of a row `l ≤ C x + D u ≤ u` has a slack and a multiplier (an
//! equality row `l = u` has two of each, both slacks driven to zero). Eliminating them
//! leaves an equality-constrained LQR problem whose stage cost carries the rows' barrier
//! curvature `Cᵀ Σ C`; the recursion factorises it once per iteration and the corrector
//! reuses the factors. The centring keeps the mean complementarity from falling far below
//! the tolerance: past it, `Σ = λ/s` only grows (on an equality row's vanishing slacks
//! fastest) into what double precision cannot factorise.
//!
//! An equality row with its own regularised multiplier (`C dz − δ dν = −r`, curvature
//! `1/δ`) was tried instead: on degenerate rows its residual contracted by 1 − 10⁻¹¹ a
//! step and stalled. `x₀` is pinned to the initial state from the start, so its step is
//! zero and the first stage needs no value function.

use super::{QpStatus, INFINITY};

/// The staged data of one OCP, borrowed from [`super::ocp::Ocp`] (row-major blocks, stage
/// `k` at `k * size`).
pub(super) struct Data<'a> {
    pub a: &'a [f64],
    pub b: &'a [f64],
    pub offset: &'a [f64],
    pub c: &'a [f64],
    pub d: &'a [f64],
    pub lower: &'a [f64],
    pub upper: &'a [f64],
    pub q: &'a [f64],
    pub r: &'a [f64],
    pub x_ref: &'a [f64],
    pub u_ref: &'a [f64],
    pub initial: &'a [f64],
}

/// A row-major pattern's non-zero columns, row by row.
#[derive(Debug, Clone)]
struct Pattern {
    start: Vec<usize>,
    columns: Vec<usize>,
}

impl Pattern {
    fn new(mask: &[bool], rows: usize, cols: usize) -> Self {
        let mut start = Vec::with_capacity(rows + 1);
        let mut columns = Vec::new();
        start.push(0);
        for i in 0..rows {
            columns.extend((0..cols).filter(|&j| mask[i * cols + j]));
            start.push(columns.len());
        }
        Self { start, columns }
    }

    fn row(&self, i: usize) -> &[usize] {
        &self.columns[self.start[i]..self.start[i + 1]]
    }
}

/// Multipliers beyond this (in the caller's units, chosen comparable) mean the rows have
/// no common point: a feasible problem's stay near its cost's gradients, an infeasible
/// one's grow without bound as the slacks of the contradicting rows vanish, until the
/// barrier curvature (their ratio) exceeds what double precision can factorise.
const DIVERGED: f64 = 1e12;

/// The lowest complementarity the centring aims at, as a fraction of the tolerance (at
/// 0.1 a degenerate random problem of `tests/integration/ocp.rs` stalled; with no floor the
/// kino-dynamic MPC's equality rows drove `Σ` to 10¹⁵).
const MU_FLOOR: f64 = 0.01;

/// The fraction of the way to the boundary a step goes (Mehrotra's damping).
const TO_BOUNDARY: f64 = 0.995;

/// The slacks and multipliers every present side starts from: slacks at least this, all
/// multipliers this (a cold start; units are the caller's, chosen comparable, see
/// [`super::ocp::Ocp::new`]).
const START: f64 = 1.0;

/// The solver's workspace, sized once (module docs).
#[derive(Debug, Clone)]
pub(super) struct RiccatiIpm {
    n: usize,
    nx: usize,
    nu: usize,
    m: usize,
    a_pattern: Pattern,
    b_pattern: Pattern,
    c_pattern: Pattern,
    d_pattern: Pattern,
    // The iterate: states, inputs, dynamics multipliers (π_{k+1} at k), row values, and
    // per side slacks and multipliers with which sides are present.
    x: Vec<f64>,
    u: Vec<f64>,
    pi: Vec<f64>,
    g: Vec<f64>,
    s_lo: Vec<f64>,
    s_hi: Vec<f64>,
    lam_lo: Vec<f64>,
    lam_hi: Vec<f64>,
    has_lo: Vec<bool>,
    has_hi: Vec<bool>,
    // Residuals: dynamics, each side's, the complementarity targets.
    e: Vec<f64>,
    r_lo: Vec<f64>,
    r_hi: Vec<f64>,
    rc_lo: Vec<f64>,
    rc_hi: Vec<f64>,
    // The step.
    dx: Vec<f64>,
    du: Vec<f64>,
    pi_new: Vec<f64>,
    dg: Vec<f64>,
    ds_lo: Vec<f64>,
    ds_hi: Vec<f64>,
    dlam_lo: Vec<f64>,
    dlam_hi: Vec<f64>,
    // Each row's barrier curvature Σ and the multiplier ν̂ its gradient is taken with.
    sigma: Vec<f64>,
    nu_hat: Vec<f64>,
    // The recursion's factors: the value functions' P_k = L_k L_kᵀ (L_k kept) and p_k,
    // Cholesky factors of the input Hessians, gains K_k, feed-forwards.
    p_chol: Vec<f64>,
    p_vec: Vec<f64>,
    chol: Vec<f64>,
    gain: Vec<f64>,
    feed: Vec<f64>,
    // Scratch: M = Lᵀ[B A] and the stage's [u; x] Hessian, then its factor.
    m_ba: Vec<f64>,
    stage_hessian: Vec<f64>,
    cholesky_scratch: Vec<f64>,
    t: Vec<f64>,
    v: Vec<f64>,
    hx: Vec<f64>,
    hu: Vec<f64>,
    /// Where the next solve starts (the caller's warm start, else the last iterate).
    start_z: Vec<f64>,
    iterations: u32,
}

impl RiccatiIpm {
    /// Size the workspace for a horizon `n`, `nx` states, `nu` inputs and `m` rows per
    /// stage with the given row-major sparsity masks.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        n: usize,
        nx: usize,
        nu: usize,
        m: usize,
        a: &[bool],
        b: &[bool],
        c: &[bool],
        d: &[bool],
    ) -> Self {
        let rows = (n + 1) * m;
        Self {
            n,
            nx,
            nu,
            m,
            a_pattern: Pattern::new(a, nx, nx),
            b_pattern: Pattern::new(b, nx, nu),
            c_pattern: Pattern::new(c, m, nx),
            d_pattern: Pattern::new(d, m, nu),
            x: vec![0.0; (n + 1) * nx],
            u: vec![0.0; n * nu],
            pi: vec![0.0; n * nx],
            g: vec![0.0; rows],
            s_lo: vec![0.0; rows],
            s_hi: vec![0.0; rows],
            lam_lo: vec![0.0; rows],
            lam_hi: vec![0.0; rows],
            has_lo: vec![false; rows],
            has_hi: vec![false; rows],
            e: vec![0.0; n * nx],
            r_lo: vec![0.0; rows],
            r_hi: vec![0.0; rows],
            rc_lo: vec![0.0; rows],
            rc_hi: vec![0.0; rows],
            dx: vec![0.0; (n + 1) * nx],
            du: vec![0.0; n * nu],
            pi_new: vec![0.0; n * nx],
            dg: vec![0.0; rows],
            ds_lo: vec![0.0; rows],
            ds_hi: vec![0.0; rows],
            dlam_lo: vec![0.0; rows],
            dlam_hi: vec![0.0; rows],
            sigma: vec![0.0; rows],
            nu_hat: vec![0.0; rows],
            p_chol: vec![0.0; (n + 1) * nx * nx],
            p_vec: vec![0.0; (n + 1) * nx],
            chol: vec![0.0; n * nu * nu],
            gain: vec![0.0; n * nu * nx],
            feed: vec![0.0; n * nu],
            m_ba: vec![0.0; nx * (nu + nx)],
            stage_hessian: vec![0.0; (nu + nx) * (nu + nx)],
            cholesky_scratch: vec![0.0; 2 * (nu + nx)],
            t: vec![0.0; nx],
            v: vec![0.0; nx],
            hx: vec![0.0; nx],
            hu: vec![0.0; nu],
            start_z: vec![0.0; n * (nx + nu) + nx],
            iterations: 0,
        }
    }

    /// Start the next solve from `z` (the variables' layout, checked by the caller).
    pub(super) fn warm_start(&mut self, z: &[f64]) {
        self.start_z.copy_from_slice(z);
    }

    /// Newton iterations of the last solve.
    pub(super) fn iterations(&self) -> u32 {
        self.iterations
    }

    /// Solve to `tolerance` on every residual (stationarity, dynamics, rows) and on the
    /// mean complementarity, in at most `max_iter` Newton steps. Writes the iterate into
    /// `z` and the multipliers into `y` (OSQP's layout and sign, see
    /// [`super::ocp::Ocp::row_duals`]) whatever the status, when they are finite.
    pub(super) fn solve(
        &mut self,
        data: &Data<'_>,
        tolerance: f64,
        max_iter: u32,
        z: &mut [f64],
        y: &mut [f64],
    ) -> QpStatus {
        self.initialise(data);
        let mut status = QpStatus::MaxIterations;
        self.iterations = 0;
        for _ in 0..max_iter {
            let (residual, mu) = self.residuals(data);
            if !residual.is_finite() || !mu.is_finite() {
                status = QpStatus::NonFinite;
                break;
            }
            if residual <= tolerance && mu <= tolerance {
                status = QpStatus::Solved;
                break;
            }
            if self.lam_lo.iter().chain(&self.lam_hi).any(|&l| l > DIVERGED) {
                status = QpStatus::PrimalInfeasible;
                break;
            }
            self.iterations += 1;
            if !self.factorise(data) {
                status = QpStatus::SolverFault;
                break;
            }
            // Predictor: the affine-scaling step (complementarity targets zero).
            for i in 0..self.g.len() {
                self.rc_lo[i] = -self.lam_lo[i] * self.s_lo[i];
                self.rc_hi[i] = -self.lam_hi[i] * self.s_hi[i];
            }
            self.direction(data);
            let alpha = self.step_to_boundary();
            let count = self.sides();
            if count == 0 {
                // No inequality at all: one Newton step solves the LQR problem.
                self.take(1.0);
                continue;
            }
            let mut affine = 0.0;
            for i in 0..self.g.len() {
                if self.has_lo[i] {
                    affine += (self.s_lo[i] + alpha * self.ds_lo[i]) * (self.lam_lo[i] + alpha * self.dlam_lo[i]);
                }
                if self.has_hi[i] {
                    affine += (self.s_hi[i] + alpha * self.ds_hi[i]) * (self.lam_hi[i] + alpha * self.dlam_hi[i]);
                }
            }
            // Complementarity is not driven far below the tolerance: past it, the barrier
            // curvature λ/s only grows into what double precision cannot factorise.
            let centring = ((affine / count as f64 / mu).clamp(0.0, 1.0).powi(3) * mu).max(MU_FLOOR * tolerance);
            // Corrector: centred, with the affine step's second-order term.
            for i in 0..self.g.len() {
                self.rc_lo[i] = centring - self.lam_lo[i] * self.s_lo[i] - self.ds_lo[i] * self.dlam_lo[i];
                self.rc_hi[i] = centring - self.lam_hi[i] * self.s_hi[i] - self.ds_hi[i] * self.dlam_hi[i];
            }
            self.direction(data);
            let alpha = (TO_BOUNDARY * self.step_to_boundary()).min(1.0);
            self.take(alpha);
        }
        self.write(data, z, y);
        if status != QpStatus::NonFinite && !z.iter().chain(y.iter()).all(|v| v.is_finite()) {
            status = QpStatus::NonFinite;
        }
        // The next solve starts where this one ended unless the caller says otherwise.
        if status != QpStatus::NonFinite {
            self.start_z.copy_from_slice(z);
        }
        status
    }

    /// The number of present sides.
    fn sides(&self) -> usize {
        self.has_lo.iter().chain(&self.has_hi).filter(|&&h| h).count()
    }

    /// States and inputs from the start point (`x₀` pinned), rows' values, slacks at least
    /// [`START`] and multipliers [`START`] on the present sides, dynamics multipliers zero.
    fn initialise(&mut self, data: &Data<'_>) {
        let (n, nx, nu, m) = (self.n, self.nx, self.nu, self.m);
        let stride = nx + nu;
        for k in 0..=n {
            let at = k * stride;
            self.x[k * nx..(k + 1) * nx].copy_from_slice(&self.start_z[at..at + nx]);
            if k < n {
                self.u[k * nu..(k + 1) * nu].copy_from_slice(&self.start_z[at + nx..at + stride]);
            }
        }
        self.x[..nx].copy_from_slice(data.initial);
        self.pi.fill(0.0);
        for k in 0..=n {
            self.row_values(data, k);
        }
        for i in 0..(n + 1) * m {
            self.has_lo[i] = data.lower[i] > -INFINITY;
            self.has_hi[i] = data.upper[i] < INFINITY;
            let (lo, hi) = (self.g[i] - data.lower[i], data.upper[i] - self.g[i]);
            self.s_lo[i] = if self.has_lo[i] { lo.max(START) } else { 0.0 };
            self.s_hi[i] = if self.has_hi[i] { hi.max(START) } else { 0.0 };
            self.lam_lo[i] = if self.has_lo[i] { START } else { 0.0 };
            self.lam_hi[i] = if self.has_hi[i] { START } else { 0.0 };
        }
    }

    /// `g = C x + D u` of stage `k`'s rows.
    fn row_values(&mut self, data: &Data<'_>, k: usize) {
        let (n, nx, nu, m) = (self.n, self.nx, self.nu, self.m);
        let x = &self.x[k * nx..(k + 1) * nx];
        let u = (k < n).then(|| &self.u[k * nu..(k + 1) * nu]);
        stage_rows([&self.c_pattern, &self.d_pattern], data, k, x, u, &mut self.g[k * m..(k + 1) * m]);
    }

    /// The residuals at the current iterate (writes `e`, `r_lo`, `r_hi`, and `nu_hat` as
    /// the rows' net multipliers): the largest absolute one of stationarity, dynamics and
    /// rows, and the mean complementarity.
    fn residuals(&mut self, data: &Data<'_>) -> (f64, f64) {
        let (n, nx, nu, m) = (self.n, self.nx, self.nu, self.m);
        let mut worst = 0.0_f64;
        for k in 0..n {
            let (x, u) = (&self.x[k * nx..(k + 1) * nx], &self.u[k * nu..(k + 1) * nu]);
            let e = &mut self.e[k * nx..(k + 1) * nx];
            times(&self.a_pattern, &data.a[k * nx * nx..], nx, x, e);
            add_times(&self.b_pattern, &data.b[k * nx * nu..], nu, u, e);
            let (offset, next) = (&data.offset[k * nx..(k + 1) * nx], &self.x[(k + 1) * nx..(k + 2) * nx]);
            for ((e, c), x) in e.iter_mut().zip(offset).zip(next) {
                *e += c - x;
                worst = worst.max(e.abs());
            }
        }
        let (mut gap, mut count) = (0.0, 0usize);
        for i in 0..(n + 1) * m {
            self.r_lo[i] = if self.has_lo[i] { self.g[i] - data.lower[i] - self.s_lo[i] } else { 0.0 };
            self.r_hi[i] = if self.has_hi[i] { data.upper[i] - self.g[i] - self.s_hi[i] } else { 0.0 };
            worst = worst.max(self.r_lo[i].abs()).max(self.r_hi[i].abs());
            if self.has_lo[i] {
                gap += self.s_lo[i] * self.lam_lo[i];
                count += 1;
            }
            if self.has_hi[i] {
                gap += self.s_hi[i] * self.lam_hi[i];
                count += 1;
            }
            self.nu_hat[i] = self.lam_hi[i] - self.lam_lo[i];
        }
        // Stationarity in every x_k (k ≥ 1) and u_k: the cost's and rows' gradient plus
        // the dynamics' multipliers.
        for k in 1..=n {
            self.gradient_x(data, k);
            for i in 0..nx {
                self.hx[i] += self.pi[(k - 1) * nx + i];
            }
            if k < n {
                add_transpose_times(
                    &self.a_pattern,
                    &data.a[k * nx * nx..],
                    nx,
                    &self.pi[k * nx..(k + 1) * nx],
                    &mut self.hx,
                    -1.0,
                );
            }
            worst = worst.max(max_abs(&self.hx));
        }
        for k in 0..n {
            self.gradient_u(data, k);
            add_transpose_times(
                &self.b_pattern,
                &data.b[k * nx * nu..],
                nu,
                &self.pi[k * nx..(k + 1) * nx],
                &mut self.hu,
                -1.0,
            );
            worst = worst.max(max_abs(&self.hu));
        }
        (worst, if count == 0 { 0.0 } else { gap / count as f64 })
    }

    /// `hx = Q_k (x_k − r_k) + C_kᵀ ν̂_k`.
    fn gradient_x(&mut self, data: &Data<'_>, k: usize) {
        let (nx, m) = (self.nx, self.m);
        let span = k * nx..(k + 1) * nx;
        let rows = Rows {
            pattern: &self.c_pattern,
            matrix: &data.c[k * m * nx..],
            multipliers: &self.nu_hat[k * m..(k + 1) * m],
        };
        stage_gradient(&data.q[span.clone()], &self.x[span.clone()], &data.x_ref[span], rows, &mut self.hx);
    }

    /// `hu = R_k (u_k − s_k) + D_kᵀ ν̂_k`.
    fn gradient_u(&mut self, data: &Data<'_>, k: usize) {
        let (nu, m) = (self.nu, self.m);
        let span = k * nu..(k + 1) * nu;
        let rows = Rows {
            pattern: &self.d_pattern,
            matrix: &data.d[k * m * nu..],
            multipliers: &self.nu_hat[k * m..(k + 1) * m],
        };
        stage_gradient(&data.r[span.clone()], &self.u[span.clone()], &data.u_ref[span], rows, &mut self.hu);
    }

    /// The barrier curvature of every row and the Riccati recursion's factors, in square-
    /// root form: with `P_{k+1} = L Lᵀ` and `M = Lᵀ [B A]`, one Cholesky factorisation of
    /// the stage's `[u; x]` Hessian `[R̃ S̃ᵀ; S̃ Q̃] + MᵀM` yields the input Hessian's
    /// factor, the gain and `P_k`'s factor (its Schur complement) at once. `P_k` is never
    /// formed by subtraction, so it cannot lose its semi-definiteness to rounding when the
    /// barrier curvature is large. `false` when an input Hessian is not positive definite.
    fn factorise(&mut self, data: &Data<'_>) -> bool {
        let (n, nx, nu, m) = (self.n, self.nx, self.nu, self.m);
        let w = nu + nx;
        for i in 0..(n + 1) * m {
            let lo = if self.has_lo[i] { self.lam_lo[i] / self.s_lo[i] } else { 0.0 };
            let hi = if self.has_hi[i] { self.lam_hi[i] / self.s_hi[i] } else { 0.0 };
            self.sigma[i] = lo + hi;
        }
        // P_N = Q_N + C_Nᵀ Σ_N C_N, factorised.
        let terminal = &mut self.p_chol[n * nx * nx..(n + 1) * nx * nx];
        terminal.fill(0.0);
        for i in 0..nx {
            terminal[i * nx + i] = data.q[n * nx + i];
        }
        for i in 0..m {
            let s = self.sigma[n * m + i];
            if s != 0.0 {
                let c = &data.c[(n * m + i) * nx..(n * m + i + 1) * nx];
                outer(self.c_pattern.row(i), c, self.c_pattern.row(i), c, s, terminal, nx);
            }
        }
        if !cholesky(terminal, nx, 0, &mut self.cholesky_scratch) {
            return false;
        }
        for k in (0..n).rev() {
            let (a, b) = (&data.a[k * nx * nx..(k + 1) * nx * nx], &data.b[k * nx * nu..(k + 1) * nx * nu]);
            let l = &self.p_chol[(k + 1) * nx * nx..(k + 2) * nx * nx];
            // M = Lᵀ [B A], row r of Lᵀ being column r of L (non-zero for i ≥ r).
            self.m_ba.fill(0.0);
            for i in 0..nx {
                let l_row = &l[i * nx..i * nx + i + 1];
                for &j in self.b_pattern.row(i) {
                    let v = b[i * nu + j];
                    for (r, &lir) in l_row.iter().enumerate() {
                        self.m_ba[r * w + j] += lir * v;
                    }
                }
                for &j in self.a_pattern.row(i) {
                    let v = a[i * nx + j];
                    for (r, &lir) in l_row.iter().enumerate() {
                        self.m_ba[r * w + nu + j] += lir * v;
                    }
                }
            }
            // W = diag(R, Q) + MᵀM + the rows' Σ terms (lower triangle).
            self.stage_hessian.fill(0.0);
            for j in 0..nu {
                self.stage_hessian[j * w + j] = data.r[k * nu + j];
            }
            for i in 0..nx {
                self.stage_hessian[(nu + i) * w + nu + i] = data.q[k * nx + i];
            }
            for r in 0..nx {
                let row = &self.m_ba[r * w..(r + 1) * w];
                for (i, &mi) in row.iter().enumerate() {
                    if mi != 0.0 {
                        axpy(mi, &row[..=i], &mut self.stage_hessian[i * w..i * w + i + 1]);
                    }
                }
            }
            for i in 0..m {
                let s = self.sigma[k * m + i];
                if s == 0.0 {
                    continue;
                }
                let (cp, dp) = (self.c_pattern.row(i), self.d_pattern.row(i));
                let c = &data.c[(k * m + i) * nx..(k * m + i + 1) * nx];
                let d = &data.d[(k * m + i) * nu..(k * m + i + 1) * nu];
                outer(dp, d, dp, d, s, &mut self.stage_hessian, w);
                for &x in cp {
                    let f = s * c[x];
                    for &u in dp {
                        self.stage_hessian[(nu + x) * w + u] += f * d[u];
                    }
                    for &x2 in cp.iter().filter(|&&x2| x2 <= x) {
                        self.stage_hessian[(nu + x) * w + nu + x2] += f * c[x2];
                    }
                }
            }
            // Its factor: [L_uu 0; Z L_k], Z = Hxu L_uu⁻ᵀ.
            if !cholesky(&mut self.stage_hessian, w, nu, &mut self.cholesky_scratch) {
                return false;
            }
            let chol = &mut self.chol[k * nu * nu..(k + 1) * nu * nu];
            for i in 0..nu {
                chol[i * nu..(i + 1) * nu].copy_from_slice(&self.stage_hessian[i * w..i * w + nu]);
            }
            if k >= 1 {
                let p = &mut self.p_chol[k * nx * nx..(k + 1) * nx * nx];
                for i in 0..nx {
                    p[i * nx..(i + 1) * nx].copy_from_slice(&self.stage_hessian[(nu + i) * w + nu..(nu + i + 1) * w]);
                }
            }
            // K = −L_uu⁻ᵀ Zᵀ: solve L_uuᵀ K = −Zᵀ from the last row up.
            let gain = &mut self.gain[k * nu * nx..(k + 1) * nu * nx];
            for i in 0..nu {
                for x in 0..nx {
                    gain[i * nx + x] = -self.stage_hessian[(nu + x) * w + i];
                }
            }
            for i in (0..nu).rev() {
                for l in i + 1..nu {
                    let f = chol[l * nu + i];
                    if f != 0.0 {
                        let (head, tail) = gain.split_at_mut(l * nx);
                        axpy(-f, &tail[..nx], &mut head[i * nx..(i + 1) * nx]);
                    }
                }
                let inv = 1.0 / chol[i * nu + i];
                gain[i * nx..(i + 1) * nx].iter_mut().for_each(|v| *v *= inv);
            }
        }
        true
    }

    /// The Newton step for the complementarity targets `rc_lo`, `rc_hi` on the factors of
    /// [`Self::factorise`]: `dx`, `du`, the new dynamics multipliers, and every side's
    /// slack and multiplier steps.
    fn direction(&mut self, data: &Data<'_>) {
        let (n, nx, nu, m) = (self.n, self.nx, self.nu, self.m);
        // The rows' multipliers the step's gradient is taken with (module docs).
        for i in 0..(n + 1) * m {
            let mut v = self.lam_hi[i] - self.lam_lo[i];
            if self.has_lo[i] {
                v += (self.lam_lo[i] * self.r_lo[i] - self.rc_lo[i]) / self.s_lo[i];
            }
            if self.has_hi[i] {
                v += (self.rc_hi[i] - self.lam_hi[i] * self.r_hi[i]) / self.s_hi[i];
            }
            self.nu_hat[i] = v;
        }
        // Backward: p_N = Q_N (x_N − r_N) + C_Nᵀ ν̂_N, then stage by stage.
        self.gradient_x(data, n);
        self.p_vec[n * nx..(n + 1) * nx].copy_from_slice(&self.hx);
        for k in (0..n).rev() {
            // t = P_{k+1} e_k + p_{k+1} = L (Lᵀ e_k) + p_{k+1}.
            let l = &self.p_chol[(k + 1) * nx * nx..(k + 2) * nx * nx];
            factor_product(l, nx, &self.e[k * nx..(k + 1) * nx], &mut self.v, &mut self.t);
            axpy(1.0, &self.p_vec[(k + 1) * nx..(k + 2) * nx], &mut self.t);
            self.gradient_u(data, k);
            add_transpose_times(&self.b_pattern, &data.b[k * nx * nu..], nu, &self.t, &mut self.hu, 1.0);
            let l = &self.chol[k * nu * nu..(k + 1) * nu * nu];
            let feed = &mut self.feed[k * nu..(k + 1) * nu];
            feed.copy_from_slice(&self.hu);
            cholesky_solve(l, nu, feed);
            feed.iter_mut().for_each(|v| *v = -*v);
            if k >= 1 {
                self.gradient_x(data, k);
                add_transpose_times(&self.a_pattern, &data.a[k * nx * nx..], nx, &self.t, &mut self.hx, 1.0);
                // p_k = hx + Kᵀ hu.
                let gain = &self.gain[k * nu * nx..(k + 1) * nu * nx];
                for j in 0..nu {
                    axpy(self.hu[j], &gain[j * nx..(j + 1) * nx], &mut self.hx);
                }
                self.p_vec[k * nx..(k + 1) * nx].copy_from_slice(&self.hx);
            }
        }
        // Forward: dx₀ = 0, du_k = K_k dx_k + k_k, dx_{k+1} = A dx + B du + e,
        // π_{k+1} = −(P_{k+1} dx_{k+1} + p_{k+1}).
        self.dx[..nx].fill(0.0);
        for k in 0..n {
            let (dx, rest) = self.dx.split_at_mut((k + 1) * nx);
            let dx = &dx[k * nx..];
            let du = &mut self.du[k * nu..(k + 1) * nu];
            let gain = &self.gain[k * nu * nx..(k + 1) * nu * nx];
            for j in 0..nu {
                du[j] =
                    self.feed[k * nu + j] + gain[j * nx..(j + 1) * nx].iter().zip(dx).map(|(g, d)| g * d).sum::<f64>();
            }
            let next = &mut rest[..nx];
            times(&self.a_pattern, &data.a[k * nx * nx..], nx, dx, next);
            add_times(&self.b_pattern, &data.b[k * nx * nu..], nu, du, next);
            axpy(1.0, &self.e[k * nx..(k + 1) * nx], next);
            let l = &self.p_chol[(k + 1) * nx * nx..(k + 2) * nx * nx];
            let pi = &mut self.pi_new[k * nx..(k + 1) * nx];
            factor_product(l, nx, next, &mut self.v, pi);
            for (p, q) in pi.iter_mut().zip(&self.p_vec[(k + 1) * nx..(k + 2) * nx]) {
                *p = -(*p + q);
            }
        }
        // The rows' steps, then each side's slack and multiplier.
        for k in 0..=n {
            let dx = &self.dx[k * nx..(k + 1) * nx];
            let du = (k < n).then(|| &self.du[k * nu..(k + 1) * nu]);
            stage_rows([&self.c_pattern, &self.d_pattern], data, k, dx, du, &mut self.dg[k * m..(k + 1) * m]);
        }
        for i in 0..(n + 1) * m {
            if self.has_lo[i] {
                self.ds_lo[i] = self.dg[i] + self.r_lo[i];
                self.dlam_lo[i] = (self.rc_lo[i] - self.lam_lo[i] * self.ds_lo[i]) / self.s_lo[i];
            }
            if self.has_hi[i] {
                self.ds_hi[i] = self.r_hi[i] - self.dg[i];
                self.dlam_hi[i] = (self.rc_hi[i] - self.lam_hi[i] * self.ds_hi[i]) / self.s_hi[i];
            }
        }
    }

    /// The longest step (at most 1) that keeps every present slack and multiplier
    /// non-negative.
    fn step_to_boundary(&self) -> f64 {
        let mut alpha = 1.0_f64;
        let mut limit = |v: f64, dv: f64| {
            if dv < 0.0 {
                alpha = alpha.min(-v / dv);
            }
        };
        for i in 0..self.g.len() {
            if self.has_lo[i] {
                limit(self.s_lo[i], self.ds_lo[i]);
                limit(self.lam_lo[i], self.dlam_lo[i]);
            }
            if self.has_hi[i] {
                limit(self.s_hi[i], self.ds_hi[i]);
                limit(self.lam_hi[i], self.dlam_hi[i]);
            }
        }
        alpha
    }

    /// Move the iterate `alpha` along the step.
    fn take(&mut self, alpha: f64) {
        let nx = self.nx;
        axpy(alpha, &self.dx[nx..], &mut self.x[nx..]);
        axpy(alpha, &self.du, &mut self.u);
        for (p, q) in self.pi.iter_mut().zip(&self.pi_new) {
            *p += alpha * (q - *p);
        }
        for i in 0..self.g.len() {
            if self.has_lo[i] {
                self.s_lo[i] += alpha * self.ds_lo[i];
                self.lam_lo[i] += alpha * self.dlam_lo[i];
            }
            if self.has_hi[i] {
                self.s_hi[i] += alpha * self.ds_hi[i];
                self.lam_hi[i] += alpha * self.dlam_hi[i];
            }
            self.g[i] += alpha * self.dg[i];
        }
    }

    /// The iterate in the OCP's layout: `z = (x₀, u₀, …, x_N)`; `y` in OSQP's rows (the
    /// initial state, then per stage the dynamics and the rows, then the terminal rows).
    fn write(&mut self, data: &Data<'_>, z: &mut [f64], y: &mut [f64]) {
        let (n, nx, nu, m) = (self.n, self.nx, self.nu, self.m);
        let stride = nx + nu;
        for k in 0..=n {
            z[k * stride..k * stride + nx].copy_from_slice(&self.x[k * nx..(k + 1) * nx]);
            if k < n {
                z[k * stride + nx..(k + 1) * stride].copy_from_slice(&self.u[k * nu..(k + 1) * nu]);
            }
        }
        for i in 0..(n + 1) * m {
            self.nu_hat[i] = self.lam_hi[i] - self.lam_lo[i];
        }
        // x₀'s multiplier closes its stationarity: y₀ = A₀ᵀ π₁ − Q₀ (x₀ − r₀) − C₀ᵀ ν₀.
        self.gradient_x(data, 0);
        self.hx.iter_mut().for_each(|v| *v = -*v);
        add_transpose_times(&self.a_pattern, data.a, nx, &self.pi[..nx], &mut self.hx, 1.0);
        y[..nx].copy_from_slice(&self.hx);
        for k in 0..=n {
            let mut top = nx + k * (nx + m);
            if k < n {
                y[top..top + nx].copy_from_slice(&self.pi[k * nx..(k + 1) * nx]);
                top += nx;
            }
            y[top..top + m].copy_from_slice(&self.nu_hat[k * m..(k + 1) * m]);
        }
    }
}

/// A stage's rows as one block of variables sees them: its pattern, its row-major matrix
/// and the rows' multipliers.
struct Rows<'a> {
    pattern: &'a Pattern,
    matrix: &'a [f64],
    multipliers: &'a [f64],
}

/// `out = W (v − target) + Mᵀ ν` for a diagonal weight `W` and one block of rows.
fn stage_gradient(weights: &[f64], v: &[f64], target: &[f64], rows: Rows<'_>, out: &mut [f64]) {
    for (((o, w), v), t) in out.iter_mut().zip(weights).zip(v).zip(target) {
        *o = w * (v - t);
    }
    add_transpose_times(rows.pattern, rows.matrix, weights.len(), rows.multipliers, out, 1.0);
}

/// `out = C_k x + D_k u` for stage `k`'s rows (`C`, `D` patterns; no `u` on the terminal
/// stage).
fn stage_rows(patterns: [&Pattern; 2], data: &Data<'_>, k: usize, x: &[f64], u: Option<&[f64]>, out: &mut [f64]) {
    let (nx, m) = (x.len(), out.len());
    times(patterns[0], &data.c[k * m * nx..], nx, x, out);
    if let Some(u) = u {
        add_times(patterns[1], &data.d[k * m * u.len()..], u.len(), u, out);
    }
}

/// `out = M v` for a row-major `M` with `cols` columns and the given pattern.
fn times(pattern: &Pattern, mat: &[f64], cols: usize, v: &[f64], out: &mut [f64]) {
    for (i, o) in out.iter_mut().enumerate() {
        *o = pattern.row(i).iter().map(|&j| mat[i * cols + j] * v[j]).sum();
    }
}

/// `out += M v`.
fn add_times(pattern: &Pattern, mat: &[f64], cols: usize, v: &[f64], out: &mut [f64]) {
    for (i, o) in out.iter_mut().enumerate() {
        *o += pattern.row(i).iter().map(|&j| mat[i * cols + j] * v[j]).sum::<f64>();
    }
}

/// `out += sign · Mᵀ v` (`v` has one entry per row of `M`).
fn add_transpose_times(pattern: &Pattern, mat: &[f64], cols: usize, v: &[f64], out: &mut [f64], sign: f64) {
    for (i, &vi) in v.iter().enumerate() {
        if vi == 0.0 {
            continue;
        }
        for &j in pattern.row(i) {
            out[j] += sign * mat[i * cols + j] * vi;
        }
    }
}

/// `out[i][j] += s · a_i b_j` over the patterns' entries (`out` row-major, `cols` wide).
fn outer(a_cols: &[usize], a: &[f64], b_cols: &[usize], b: &[f64], s: f64, out: &mut [f64], cols: usize) {
    for &i in a_cols {
        let f = s * a[i];
        for &j in b_cols {
            out[i * cols + j] += f * b[j];
        }
    }
}

/// `y += a x`.
fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (y, x) in y.iter_mut().zip(x) {
        *y += a * x;
    }
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |w, x| w.max(x.abs()))
}

/// The lower Cholesky factor of the row-major `n × n` matrix `a` (its lower triangle
/// read), in place, the upper triangle zeroed. The first `strict` pivots must be positive
/// (else `false`: not positive definite, or not finite); a later pivot at rounding level
/// zeroes its column instead, so that a semi-definite trailing block (a value function
/// with unweighted states) keeps an exact factor `L Lᵀ`. Right-looking, so that every
/// update is an `axpy` along a contiguous row (vectorised; a dot product's fixed order of
/// additions is not); `scratch` holds `2n` values.
fn cholesky(a: &mut [f64], n: usize, strict: usize, scratch: &mut [f64]) -> bool {
    let (column, diagonal) = scratch[..2 * n].split_at_mut(n);
    for (j, d) in diagonal.iter_mut().enumerate() {
        *d = a[j * n + j].abs();
    }
    for j in 0..n {
        let d = a[j * n + j];
        if d.is_nan() || (j < strict && d <= 0.0) {
            return false;
        }
        if j >= strict && d <= 1e-13 * diagonal[j] {
            for i in j..n {
                a[i * n + j] = 0.0;
            }
            continue;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            a[i * n + j] /= d;
            column[i] = a[i * n + j];
        }
        for i in j + 1..n {
            let f = column[i];
            if f != 0.0 {
                axpy(-f, &column[j + 1..=i], &mut a[i * n + j + 1..=i * n + i]);
            }
        }
    }
    for i in 0..n {
        a[i * n + i + 1..(i + 1) * n].fill(0.0);
    }
    true
}

/// `out = L (Lᵀ v)` for a lower factor `l` (`w` is scratch).
fn factor_product(l: &[f64], n: usize, v: &[f64], w: &mut [f64], out: &mut [f64]) {
    for (r, wr) in w.iter_mut().enumerate() {
        *wr = (r..n).map(|i| l[i * n + r] * v[i]).sum();
    }
    for (i, o) in out.iter_mut().enumerate() {
        *o = l[i * n..i * n + i + 1].iter().zip(&w[..=i]).map(|(a, b)| a * b).sum();
    }
}

/// Solve `L Lᵀ v = b` in place for the lower factor `l`.
fn cholesky_solve(l: &[f64], n: usize, v: &mut [f64]) {
    for i in 0..n {
        let s: f64 = (0..i).map(|k| l[i * n + k] * v[k]).sum();
        v[i] = (v[i] - s) / l[i * n + i];
    }
    for i in (0..n).rev() {
        let s: f64 = (i + 1..n).map(|k| l[k * n + i] * v[k]).sum();
        v[i] = (v[i] - s) / l[i * n + i];
    }
}
