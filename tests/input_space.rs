//! The exact input-space solve of the ECBF QP (`cbfgen::qp::input_space`, issue 14) on
//! random and degenerate instances, each answer checked against truths computed here,
//! apart from the solver (only its `u` is read):
//! * Clarabel (an interior-point method) on the lifted QP in `(u, δ)`;
//! * the dense cost `F(u)`, row values summed in compensated arithmetic (`Dot2`), so that
//!   comparing two costs measures the points and not the rounding of stiff rows;
//! * the KKT conditions recomputed from `u` alone and judged as Newton steps in input units
//!   (see [`kkt`] for why);
//! * closed-form optima of small hand-built cases.
//!
//! Every group prints one summary line (`cargo test --release --test input_space --
//! --nocapture` shows them).
#![allow(clippy::needless_range_loop)]

mod common;
#[path = "common/kkt.rs"]
mod kkt;

use std::panic::{catch_unwind, AssertUnwindSafe};

use cbfgen::qp::input_space::{Bound, InputSpaceSolver, Outcome, Problem, SoftRow, Start};
use nalgebra::{DMatrix, DVector};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// The solver's step budget the filter uses by default.
const MAX_STEPS: u32 = 100;
/// Agreement with Clarabel's `u`, relative to the input scale `1 + max(|lo_j|, |hi_j|)`.
const CLARABEL_AGREEMENT: f64 = 1e-6;
/// The exact optimum costs no more than Clarabel's point (clipped to the box) plus this
/// times `1 + F`.
const COST_SLACK: f64 = 1e-12;
/// The KKT measure's bound, in units of `1 + |u_j| + |r_j|` (see [`kkt`]).
const KKT_TOLERANCE: f64 = 1e-8;
/// Warm and cold starts agree to this, relative to the input scale.
const WARM_AGREEMENT: f64 = 1e-9;
/// Rows per workspace: more than any instance here has.
const CAPACITY: usize = 80;
/// Failures printed in full (as Rust data) when a group fails.
const SHOWN_FAILURES: usize = 3;

/// `x ≤ tol`, false for NaN: every check below fails on a value that is not a number.
fn within(x: f64, tol: f64) -> bool {
    x <= tol
}

/// One problem, owned; `Debug` prints it as the Rust data that rebuilds it.
#[derive(Debug, Clone)]
struct Instance<const NU: usize> {
    kind: &'static str,
    weights: [f64; NU],
    u_ref: [f64; NU],
    lo: [f64; NU],
    hi: [f64; NU],
    rows: Vec<SoftRow<NU>>,
}

impl<const NU: usize> Instance<NU> {
    fn problem(&self) -> Problem<'_, NU> {
        Problem {
            weights: &self.weights,
            u_ref: &self.u_ref,
            input_min: &self.lo,
            input_max: &self.hi,
            rows: &self.rows,
        }
    }

    /// `1 + max(|lo_j|, |hi_j|)`: the size of input `j`.
    fn input_scale(&self, j: usize) -> f64 {
        1.0 + self.lo[j].abs().max(self.hi[j].abs())
    }

    /// Largest `|x_j − y_j|` over the input scale.
    fn distance(&self, x: &[f64; NU], y: &[f64; NU]) -> f64 {
        (0..NU).map(|j| (x[j] - y[j]).abs() / self.input_scale(j)).fold(0.0, f64::max)
    }

    fn in_box(&self, u: &[f64; NU]) -> bool {
        (0..NU).all(|j| self.lo[j] <= u[j] && u[j] <= self.hi[j])
    }

    fn clip(&self, x: &[f64; NU]) -> [f64; NU] {
        std::array::from_fn(|j| x[j].clamp(self.lo[j], self.hi[j]))
    }
}

// ---------------------------------------------------------------------------------------
// Independent truths
// ---------------------------------------------------------------------------------------

/// `a + b` and its rounding error, exactly (Knuth's TwoSum).
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// A sum with its rounding errors carried along (Neumaier).
fn compensated_sum(terms: impl IntoIterator<Item = f64>) -> f64 {
    let (mut s, mut c) = (0.0, 0.0);
    for t in terms {
        let (x, e) = two_sum(s, t);
        s = x;
        c += e;
    }
    s + c
}

/// `a·u + b` as if computed in twice the working precision (Ogita–Rump–Oishi `Dot2`):
/// a stiff row's value is a small difference of large terms, and its square is weighted
/// by up to 1e8 in the cost.
fn row_value<const NU: usize>(row: &SoftRow<NU>, u: &[f64; NU]) -> f64 {
    let (mut s, mut c) = (row.b, 0.0);
    for j in 0..NU {
        let p = row.a[j] * u[j];
        let p_err = row.a[j].mul_add(u[j], -p);
        let (t, e) = two_sum(s, p);
        s = t;
        c += p_err + e;
    }
    s + c
}

/// `F(u) = Σ w_j (u_j − r_j)² + Σ s_i max(0, −(a_i·u + b_i))²`, the cost with every slack
/// at its best for `u`. Every term is non-negative, so the sum is accurate to a few ulps
/// once the row values are.
fn cost<const NU: usize>(inst: &Instance<NU>, u: &[f64; NU]) -> f64 {
    let inputs: f64 = (0..NU).map(|j| inst.weights[j] * (u[j] - inst.u_ref[j]).powi(2)).sum();
    let rows: f64 = inst.rows.iter().map(|row| row.weight * row_value(row, u).min(0.0).powi(2)).sum();
    inputs + rows
}

/// The rounding a double-precision evaluation of a row value `a·u + b` may carry, relative
/// to its terms' size `|b| + Σ_j |a_j u_j|`: `γ = (NU + 1) ε`, the standard bound for a
/// dot product of `NU + 1` terms.
fn row_rounding<const NU: usize>() -> f64 {
    (NU as f64 + 1.0) * f64::EPSILON
}

/// The first-order data of `F` at `u`, computed here from the instance alone: row values
/// (`Dot2`) and their terms' sizes, and `∇F`.
struct Model<'a, const NU: usize> {
    inst: &'a Instance<NU>,
    values: Vec<f64>,
    sizes: Vec<f64>,
    /// `∇F = 2 W (u − r) − 2 Σ_i s_i δ_i a_i`, `δ_i = max(0, −(a_i·u + b_i))`, each entry a
    /// compensated sum.
    g: [f64; NU],
    /// The size of each entry's terms, `2 w_j |u_j − r_j| + Σ_i 2 s_i δ_i |a_ij|`.
    g_size: [f64; NU],
}

impl<'a, const NU: usize> Model<'a, NU> {
    fn at(inst: &'a Instance<NU>, u: &[f64; NU]) -> Self {
        let values: Vec<f64> = inst.rows.iter().map(|row| row_value(row, u)).collect();
        let sizes = inst.rows.iter().map(|row| row.b.abs() + (0..NU).map(|j| (row.a[j] * u[j]).abs()).sum::<f64>());
        // −2 s_i δ_i a_ij = 2 s_i v_i a_ij for a violated row (δ_i = −v_i).
        let g = std::array::from_fn(|j| {
            let input = 2.0 * inst.weights[j] * (u[j] - inst.u_ref[j]);
            let rows = inst
                .rows
                .iter()
                .zip(&values)
                .filter(|(_, &v)| v < 0.0)
                .map(|(row, &v)| 2.0 * row.weight * v * row.a[j]);
            compensated_sum(std::iter::once(input).chain(rows))
        });
        let g_size = std::array::from_fn(|j| {
            let rows = inst.rows.iter().zip(&values).filter(|(_, &v)| v < 0.0);
            2.0 * inst.weights[j] * (u[j] - inst.u_ref[j]).abs()
                + rows.map(|(row, &v)| 2.0 * row.weight * (v * row.a[j]).abs()).sum::<f64>()
        });
        Self { inst, sizes: sizes.collect(), values, g, g_size }
    }

    /// `R` with `RᵀR = H_FF`, `H = 2 W + 2 Σ_{i: curved(i)} s_i a_i a_iᵀ` on the inputs
    /// `set`: the QR factor of the square root `M` (rows `√(2 w_j) e_j` and `√(2 s_i) a_i`),
    /// which loses only `cond(M) = √cond(H)` digits; `H` itself is never formed.
    fn factor(&self, set: &[usize], curved: &[bool]) -> Factor {
        let (n, inst) = (set.len(), self.inst);
        let rows: Vec<&SoftRow<NU>> = inst.rows.iter().zip(curved).filter(|(_, &c)| c).map(|(row, _)| row).collect();
        let mut m = DMatrix::<f64>::zeros(n + rows.len(), n);
        for (k, &j) in set.iter().enumerate() {
            m[(k, k)] = (2.0 * inst.weights[j]).sqrt();
        }
        for (i, row) in rows.iter().enumerate() {
            let c = (2.0 * row.weight).sqrt();
            for (k, &j) in set.iter().enumerate() {
                m[(n + i, k)] = c * row.a[j];
            }
        }
        Factor { r: if n == 0 { DMatrix::zeros(0, 0) } else { m.qr().r() }, set: set.to_vec() }
    }

    /// The Newton step `−H_FF⁻¹ g_F` on `set`, and per entry the part of it that the
    /// rounding of the data alone can account for (see [`kkt`]).
    ///
    /// `H` is the Hessian of the piece the step moves into: the violated rows, and of the
    /// rows on their kink (value zero within rounding) those the step violates (`a·d < 0`),
    /// settled by re-solving until the choice is consistent. At a kink the piece behind is
    /// the wrong model: a row at exactly zero that the step would violate stiffens `F` at
    /// once, and the step without it can overshoot the optimum by orders of magnitude.
    fn step(&self, set: &[usize]) -> Option<(DVector<f64>, DVector<f64>)> {
        let gamma = row_rounding::<NU>();
        let on_kink: Vec<usize> =
            (0..self.values.len()).filter(|&i| self.values[i].abs() <= gamma * self.sizes[i]).collect();
        let mut curved: Vec<bool> = self.values.iter().map(|&v| v < 0.0).collect();
        let g = DVector::from_iterator(set.len(), set.iter().map(|&j| self.g[j]));
        let column = |i: usize| DVector::from_iterator(set.len(), set.iter().map(|&j| self.inst.rows[i].a[j]));
        let mut rounds = 0;
        let (factor, step) = loop {
            let factor = self.factor(set, &curved);
            let step = -factor.solve(&g)?;
            let mut settled = true;
            for &i in &on_kink {
                let rate = column(i).dot(&step);
                let violates = rate < 0.0 || (rate == 0.0 && self.values[i] < 0.0);
                settled &= violates == curved[i];
                curved[i] = violates;
            }
            rounds += 1;
            if settled || rounds > on_kink.len().min(20) {
                break (factor, step);
            }
        };
        let mut floor = DVector::zeros(set.len());
        for i in 0..self.values.len() {
            // Rows in the gradient, and rows on their kink (in or out of it by rounding).
            if self.values[i] < 0.0 || self.values[i] <= gamma * self.sizes[i] {
                floor += factor.solve(&column(i))?.abs() * (2.0 * self.inst.rows[i].weight * gamma * self.sizes[i]);
            }
        }
        // The rounding of the gradient's own terms (a few ulps of each product), which
        // matters only where a row's violation is itself huge.
        for (k, &j) in set.iter().enumerate() {
            let unit = DVector::from_fn(set.len(), |l, _| if l == k { 1.0 } else { 0.0 });
            floor += factor.solve(&unit)?.abs() * (4.0 * f64::EPSILON * self.g_size[j]);
        }
        Some((step, floor))
    }
}

/// The factor of [`Model::factor`].
struct Factor {
    r: DMatrix<f64>,
    set: Vec<usize>,
}

impl Factor {
    /// `H_FF⁻¹ rhs`; `None` if singular or not finite.
    fn solve(&self, rhs: &DVector<f64>) -> Option<DVector<f64>> {
        if self.set.is_empty() {
            return Some(DVector::zeros(0));
        }
        let y = self.r.transpose().solve_lower_triangular(rhs)?;
        let z = self.r.solve_upper_triangular(&y)?;
        z.iter().all(|v| v.is_finite()).then_some(z)
    }
}

/// What [`kkt`] found.
struct Kkt<const NU: usize> {
    /// The worst KKT violation beyond the rounding floor, in units of `1 + |u_j| + |r_j|`.
    measure: f64,
    /// The same without the rounding floor.
    raw: f64,
    /// Per input strictly inside the box, the rounding floor of its step (zero for the
    /// others).
    floor: [f64; NU],
}

/// The KKT conditions at `u`, recomputed from the instance and `u` alone and judged as
/// distances in each input's own units `1 + |u_j| + |r_j|`.
///
/// With `δ_i = max(0, −(a_i·u + b_i))` the gradient of `F` is
/// `g = 2 W (u − r) − 2 Σ_i s_i δ_i a_i`, and KKT asks `g_j = 0` for inputs strictly inside
/// the box, `g_j ≥ 0` at the lower bound and `g_j ≤ 0` at the upper. Raw gradient units
/// cannot be judged by one tolerance: input weights span 1e6 and a stiff row (`s |a|²` up
/// to ~1e11 here) carries a gradient of `s |a| ε |b|` from rounding alone, which moves `u`
/// by only `ε |b| / |a|`. So each residual becomes the distance `u` would still move, with
/// the Hessian `H = 2 W + 2 Σ s_i a_i a_iᵀ` of the piece the step moves into (see
/// [`Model::step`]):
/// * inside: the Newton step `d = −H_SS⁻¹ g_S` on the set `S` of inputs strictly inside;
/// * at a bound: the step input `j` would take if released together with `S` (`−H⁻¹ g` on
///   `S ∪ {j}`, its `j` entry: the reduced gradient over the Schur complement); a step
///   inward is a violated sign condition.
///
/// `F` is quadratic on the piece, so the step is the distance to the piece's optimum on
/// that face. Inputs in a box of zero width have no condition.
///
/// **Rounding floor.** No double-precision solver can place `u` closer than the rounding
/// of the data allows, so a step is only counted beyond what rounding alone accounts for
/// (a backward-error allowance: `u` is then the exact optimum of a problem perturbed by
/// that rounding, up to the tolerance):
/// * an error `η_i` in a row value (up to `γ (|b_i| + Σ |a_ij u_j|)`, `γ = (NU + 1) ε`, the
///   bound for a dot product) moves the gradient by `2 s_i η_i a_i`, the step by
///   `|H⁻¹ a_i| 2 s_i η_i`, for rows violated or on their kink within it;
/// * each gradient entry's own terms round by a few ulps, `4 ε g_size_j`, through `|H⁻¹|`
///   (this only matters where a violation is itself huge, as with rows of 1e150).
///
/// Each group prints `raw`, the measure without the floor, beside it, so any case the
/// floor decides is visible; with rows of 1e150 it is what makes the measure usable at all.
fn kkt<const NU: usize>(inst: &Instance<NU>, u: &[f64; NU]) -> Kkt<NU> {
    let fail = Kkt { measure: f64::INFINITY, raw: f64::INFINITY, floor: [0.0; NU] };
    if !inst.in_box(u) {
        return fail;
    }
    let model = Model::at(inst, u);
    let unit = |j: usize| 1.0 + u[j].abs() + inst.u_ref[j].abs();
    let inside: Vec<usize> = (0..NU).filter(|&j| inst.lo[j] < u[j] && u[j] < inst.hi[j]).collect();
    let Some((step, floor)) = model.step(&inside) else { return fail };
    let mut out = Kkt { measure: 0.0, raw: 0.0, floor: [0.0; NU] };
    for (k, &j) in inside.iter().enumerate() {
        out.floor[j] = floor[k];
        out.raw = out.raw.max(step[k].abs() / unit(j));
        out.measure = out.measure.max((step[k].abs() - floor[k]).max(0.0) / unit(j));
    }
    for j in 0..NU {
        if inst.lo[j] == inst.hi[j] || inside.contains(&j) {
            continue;
        }
        let mut set = inside.clone();
        set.push(j);
        let Some((step, floor)) = model.step(&set) else { return fail };
        let (dj, fj) = (step[set.len() - 1], floor[set.len() - 1]);
        let inward = if u[j] <= inst.lo[j] { dj } else { -dj };
        out.raw = out.raw.max(inward.max(0.0) / unit(j));
        out.measure = out.measure.max((inward - fj).max(0.0) / unit(j));
    }
    out
}

/// Clarabel's point crossed over to the exact optimum of the face it lies on.
///
/// An interior-point method stops at a distance from a bound that its gap tolerance
/// allows, not on it (`slack · multiplier ≤ gap`), so an input whose bound has a small
/// multiplier, or whose cost carries a large constant from hopelessly violated rows, can
/// stay 1e-4 inside: Clarabel at 1e-10 agrees with the exact answer only to about that.
/// The crossover starts from Clarabel's face — inputs within 1e-6 of the input scale from
/// a bound whose gradient pushes outward held there — and runs a textbook primal
/// active-set method written here: the Newton step of [`Model::step`] on the free inputs,
/// the exact minimum of `F` along it within the box (bisection on the derivative, which
/// is monotone as `F` is convex), an input that blocks the step held at its bound, and,
/// once the free inputs are optimal, the held input whose release step points inward the
/// most freed. It ends when [`kkt`] accepts the point (`None` if not within 100 rounds).
/// Its start comes from Clarabel, not from the solver under test.
fn crossover<const NU: usize>(inst: &Instance<NU>, x: &[f64; NU]) -> Option<[f64; NU]> {
    let mut u = inst.clip(x);
    let model = Model::at(inst, &u);
    let mut held = [Bound::Free; NU];
    for j in 0..NU {
        let near = 1e-6 * inst.input_scale(j);
        if inst.lo[j] == inst.hi[j] || (u[j] - inst.lo[j] <= near && model.g[j] >= 0.0) {
            (held[j], u[j]) = (Bound::Lower, inst.lo[j]);
        } else if inst.hi[j] - u[j] <= near && model.g[j] <= 0.0 {
            (held[j], u[j]) = (Bound::Upper, inst.hi[j]);
        }
    }
    for _ in 0..100 {
        if kkt(inst, &u).measure <= KKT_TOLERANCE {
            return Some(u);
        }
        let model = Model::at(inst, &u);
        let unit = |j: usize| 1.0 + u[j].abs() + inst.u_ref[j].abs();
        let free: Vec<usize> = (0..NU).filter(|&j| held[j] == Bound::Free).collect();
        let (step, _) = model.step(&free)?;
        if free.iter().zip(step.iter()).all(|(&j, d)| d.abs() <= KKT_TOLERANCE * unit(j)) {
            // Optimal on this face: free the held input that would move inward the most.
            let mut worst = (0.0, None);
            for j in (0..NU).filter(|&j| held[j] != Bound::Free && inst.lo[j] < inst.hi[j]) {
                let mut set = free.clone();
                set.push(j);
                let (step, _) = model.step(&set)?;
                let inward = if held[j] == Bound::Lower { step[free.len()] } else { -step[free.len()] };
                if inward / unit(j) > worst.0 {
                    worst = (inward / unit(j), Some(j));
                }
            }
            held[worst.1?] = Bound::Free;
            continue;
        }
        let mut d = [0.0; NU];
        for (k, &j) in free.iter().enumerate() {
            d[j] = step[k];
        }
        let (mut reach, mut blocking) = (f64::INFINITY, None);
        for &j in &free {
            let room = if d[j] > 0.0 {
                (inst.hi[j] - u[j]) / d[j]
            } else if d[j] < 0.0 {
                (inst.lo[j] - u[j]) / d[j]
            } else {
                continue;
            };
            if room < reach {
                (reach, blocking) = (room.max(0.0), Some(j));
            }
        }
        let t = line_minimum(inst, &u, &d, reach);
        for j in 0..NU {
            u[j] += t * d[j];
        }
        if let (Some(j), true) = (blocking, t >= reach) {
            (u[j], held[j]) = if d[j] > 0.0 { (inst.hi[j], Bound::Upper) } else { (inst.lo[j], Bound::Lower) };
        }
        u = inst.clip(&u);
    }
    None
}

/// The minimiser of `F(u + t d)` over `0 ≤ t ≤ reach`, by bisection on its derivative
/// `φ'(t) = Σ_j 2 w_j (x_j − r_j) d_j + Σ_i 2 s_i min(0, a_i·x + b_i) a_i·d` at
/// `x = u + t d` (non-decreasing: `F` is convex).
fn line_minimum<const NU: usize>(inst: &Instance<NU>, u: &[f64; NU], d: &[f64; NU], reach: f64) -> f64 {
    let rates: Vec<f64> = inst.rows.iter().map(|row| (0..NU).map(|j| row.a[j] * d[j]).sum()).collect();
    let slope = |t: f64| {
        let x: [f64; NU] = std::array::from_fn(|j| u[j] + t * d[j]);
        let inputs = (0..NU).map(|j| 2.0 * inst.weights[j] * (x[j] - inst.u_ref[j]) * d[j]);
        let rows = inst.rows.iter().zip(&rates).map(|(row, e)| 2.0 * row.weight * row_value(row, &x).min(0.0) * e);
        compensated_sum(inputs.chain(rows))
    };
    let mut hi = reach.min(1.0);
    while slope(hi) < 0.0 {
        if hi >= reach {
            return reach;
        }
        hi = (2.0 * hi).min(reach);
    }
    let mut lo = 0.0;
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if slope(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Clarabel on the lifted QP in `(u, δ)` ([`kkt::clarabel_soft_qp`], tolerances 1e-10):
/// whether it reported the problem solved, and its `u` (if finite and in the box).
fn clarabel_reference<const NU: usize>(inst: &Instance<NU>) -> (bool, Option<[f64; NU]>) {
    let rows: Vec<(&[f64], f64, f64)> = inst.rows.iter().map(|row| (&row.a[..], row.b, row.weight)).collect();
    match kkt::clarabel_soft_qp(&inst.weights, &inst.u_ref, &inst.lo, &inst.hi, &rows) {
        Some((u, solved)) => (solved, Some(std::array::from_fn(|j| u[j]))),
        None => (false, None),
    }
}

// ---------------------------------------------------------------------------------------
// Instances
// ---------------------------------------------------------------------------------------

fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

fn log_uniform(rng: &mut ChaCha8Rng, lo_exp: f64, hi_exp: f64) -> f64 {
    10f64.powf(uniform(rng, lo_exp, hi_exp))
}

fn sign(rng: &mut ChaCha8Rng) -> f64 {
    if rng.random_bool(0.5) {
        1.0
    } else {
        -1.0
    }
}

/// A row of mixed-scale coefficients (row scale 1e-3–10, entries down to 1e-2 of it,
/// dense or sparse) whose half-space passes near a point around the box, so that it
/// binds at the nominal input about half the time; slack weight 1e2–1e8.
fn random_row<const NU: usize>(rng: &mut ChaCha8Rng, inst: &Instance<NU>) -> SoftRow<NU> {
    let scale = log_uniform(rng, -3.0, 1.0);
    let density = [1.0, 0.5, 0.2][rng.random_range(0..3)];
    let mut a = [0.0; NU];
    for j in 0..NU {
        if rng.random_bool(density) {
            a[j] = scale * uniform(rng, -1.0, 1.0) * log_uniform(rng, -2.0, 0.0);
        }
    }
    let (mut ax, mut reach) = (0.0, 0.0);
    for j in 0..NU {
        let width = inst.hi[j] - inst.lo[j];
        ax += a[j] * uniform(rng, inst.lo[j] - 0.5 * width, inst.hi[j] + 0.5 * width);
        reach += a[j].abs() * width;
    }
    SoftRow { a, b: -ax + 0.1 * reach * uniform(rng, -1.0, 1.0), weight: log_uniform(rng, 2.0, 8.0) }
}

/// Input weights within one random decade range inside [1e-3, 1e3]; limits 1e-2–300
/// wide, not always around zero; the nominal input inside the box half the time, else
/// below or above it by up to three widths; 0–`max_rows` random rows.
fn random_instance<const NU: usize>(rng: &mut ChaCha8Rng, max_rows: usize) -> Instance<NU> {
    let (e0, e1) = (uniform(rng, -3.0, 3.0), uniform(rng, -3.0, 3.0));
    let weights = std::array::from_fn(|_| log_uniform(rng, e0.min(e1), e0.max(e1)));
    let (mut lo, mut hi, mut u_ref) = ([0.0; NU], [0.0; NU], [0.0; NU]);
    for j in 0..NU {
        let width = log_uniform(rng, -2.0, 2.5);
        let shift = if rng.random_bool(0.2) { uniform(rng, -1.0, 1.0) * width } else { 0.0 };
        lo[j] = shift - width * rng.random::<f64>();
        hi[j] = lo[j] + width;
        u_ref[j] = match rng.random_range(0..4) {
            0 | 1 => uniform(rng, lo[j], hi[j]),
            2 => lo[j] - width * log_uniform(rng, -3.0, 0.5),
            _ => hi[j] + width * log_uniform(rng, -3.0, 0.5),
        };
    }
    let mut inst = Instance { kind: "random", weights, u_ref, lo, hi, rows: Vec::new() };
    let m = rng.random_range(0..=max_rows);
    inst.rows = (0..m).map(|_| random_row(rng, &inst)).collect();
    inst
}

/// The degenerate kinds, each built on a random instance of up to 30 rows.
const DEGENERATE_KINDS: [&str; 9] = [
    "duplicate rows",
    "zero rows",
    "rows against saturated inputs",
    "conflicting rows",
    "tiny rows",
    "zero-width box",
    "u_ref at a bound",
    "rows satisfied at u_ref",
    "all of these",
];

fn degenerate_instance<const NU: usize>(rng: &mut ChaCha8Rng, kind: &'static str) -> Instance<NU> {
    let mut inst = random_instance::<NU>(rng, 30);
    inst.kind = kind;
    let all = kind == "all of these";
    // First the box and the nominal input, which the rows below are placed against.
    if kind == "zero-width box" || all {
        for _ in 0..rng.random_range(1..=NU.div_ceil(3)) {
            let j = rng.random_range(0..NU);
            let v = uniform(rng, inst.lo[j], inst.hi[j]);
            (inst.lo[j], inst.hi[j]) = (v, v);
        }
    }
    if kind == "u_ref at a bound" || all {
        for _ in 0..rng.random_range(1..=NU.div_ceil(2)) {
            let j = rng.random_range(0..NU);
            inst.u_ref[j] = if rng.random_bool(0.5) { inst.lo[j] } else { inst.hi[j] };
        }
    }
    if kind == "duplicate rows" || all {
        if inst.rows.is_empty() {
            let row = random_row(rng, &inst);
            inst.rows.push(row);
        }
        for _ in 0..rng.random_range(1..=5) {
            let mut row = inst.rows[rng.random_range(0..inst.rows.len())];
            if rng.random_bool(0.5) {
                row.weight = log_uniform(rng, 2.0, 8.0);
            }
            let at = rng.random_range(0..=inst.rows.len());
            inst.rows.insert(at, row);
        }
    }
    if kind == "zero rows" || all {
        for _ in 0..rng.random_range(1..=4) {
            let b = match rng.random_range(0..3) {
                0 => -log_uniform(rng, -3.0, 2.0),
                1 => 0.0,
                _ => log_uniform(rng, -3.0, 2.0),
            };
            inst.rows.push(SoftRow { a: [0.0; NU], b, weight: log_uniform(rng, 2.0, 8.0) });
        }
    }
    if kind == "rows against saturated inputs" || all {
        // Single-input rows wanting u_j beyond a limit by 1e-3–1 widths (plus a little).
        for _ in 0..rng.random_range(1..=3) {
            let j = rng.random_range(0..NU);
            let c = sign(rng) * log_uniform(rng, -2.0, 1.0);
            let margin = (inst.hi[j] - inst.lo[j]) * log_uniform(rng, -3.0, 0.0) + 1e-3;
            let target = if c > 0.0 { inst.hi[j] + margin } else { inst.lo[j] - margin };
            let mut a = [0.0; NU];
            a[j] = c;
            inst.rows.push(SoftRow { a, b: -c * target, weight: log_uniform(rng, 2.0, 8.0) });
        }
        // One row over several inputs wanting more than the box's best corner gives.
        let mut a = [0.0; NU];
        let mut best = 0.0;
        for _ in 0..rng.random_range(1..=NU.min(4)) {
            let j = rng.random_range(0..NU);
            a[j] = sign(rng) * log_uniform(rng, -2.0, 1.0);
        }
        for j in 0..NU {
            best += a[j] * if a[j] > 0.0 { inst.hi[j] } else { inst.lo[j] };
        }
        let margin = log_uniform(rng, -3.0, 0.0) * a.iter().map(|v| v.abs()).sum::<f64>();
        inst.rows.push(SoftRow { a, b: -(best + margin), weight: log_uniform(rng, 2.0, 8.0) });
    }
    if kind == "conflicting rows" || all {
        // a·u ≥ a·r + m1 and a·u ≤ a·r − m2: both violated at r, never both satisfied.
        for _ in 0..rng.random_range(1..=3) {
            let mut a = random_row(rng, &inst).a;
            if a.iter().all(|&v| v == 0.0) {
                a[rng.random_range(0..NU)] = 1.0;
            }
            let ar: f64 = (0..NU).map(|j| a[j] * inst.u_ref[j]).sum();
            let size: f64 = a.iter().map(|v| v.abs()).sum();
            let (m1, m2) = (size * log_uniform(rng, -3.0, 1.0), size * log_uniform(rng, -3.0, 1.0));
            let neg = a.map(|v| -v);
            inst.rows.push(SoftRow { a, b: -ar - m1, weight: log_uniform(rng, 2.0, 8.0) });
            inst.rows.push(SoftRow { a: neg, b: ar - m2, weight: log_uniform(rng, 2.0, 8.0) });
        }
    }
    if kind == "tiny rows" || all {
        // Coefficients of 1e-9 (the whole row, or one entry of a normal row).
        for _ in 0..rng.random_range(1..=3) {
            let a = std::array::from_fn(|_| 1e-9 * uniform(rng, -1.0, 1.0));
            let b = match rng.random_range(0..3) {
                0 => -log_uniform(rng, -3.0, 1.0),
                1 => -1e-9 * log_uniform(rng, -1.0, 2.0),
                _ => log_uniform(rng, -3.0, 1.0),
            };
            inst.rows.push(SoftRow { a, b, weight: log_uniform(rng, 2.0, 8.0) });
        }
        let mut row = random_row(rng, &inst);
        row.a[rng.random_range(0..NU)] = sign(rng) * 1e-9;
        inst.rows.push(row);
    }
    if kind == "rows satisfied at u_ref" || all {
        // Dyadic r and a, so that b = −a·r is exact and a·r + b = 0 in any order.
        for j in 0..NU {
            inst.u_ref[j] = (inst.u_ref[j] * 8.0).round() / 8.0;
        }
        for _ in 0..rng.random_range(1..=5) {
            let a: [f64; NU] =
                std::array::from_fn(
                    |_| if rng.random_bool(0.6) { rng.random_range(-20..=20) as f64 / 4.0 } else { 0.0 },
                );
            let b = -(0..NU).map(|j| a[j] * inst.u_ref[j]).sum::<f64>();
            inst.rows.push(SoftRow { a, b, weight: log_uniform(rng, 2.0, 8.0) });
        }
    }
    inst
}

// ---------------------------------------------------------------------------------------
// Checking a group
// ---------------------------------------------------------------------------------------

/// What a group of instances did.
#[derive(Default)]
struct Tally {
    name: String,
    instances: usize,
    /// Instances where Clarabel did not report `Solved` (compared by cost and KKT only), or
    /// stopped more than 1e-9 outside the box (`clarabel_soft_qp` then gives no point:
    /// KKT only).
    unsolved: usize,
    /// Solved by Clarabel, but its point did not cross over to a KKT point (compared by
    /// cost and against Clarabel's raw point only).
    no_crossover: usize,
    steps: Vec<u32>,
    /// Largest distance from Clarabel's crossed-over answer (the asserted comparison).
    worst_du: f64,
    /// Largest distance from Clarabel's own point, and how many are beyond 1e-6.
    worst_du_raw: f64,
    raw_beyond: usize,
    worst_kkt: f64,
    worst_kkt_raw: f64,
    /// Instances whose KKT step exceeds the tolerance before the rounding floor is taken
    /// off (see [`kkt`]).
    needed_floor: usize,
    /// Largest `(F(u) − F(u_clarabel)) / (1 + F(u_clarabel))` (negative: the solver's is
    /// the cheaper point).
    worst_excess: f64,
    failures: Vec<String>,
}

impl Tally {
    fn new(name: impl Into<String>) -> Self {
        Self { name: name.into(), worst_excess: f64::NEG_INFINITY, ..Self::default() }
    }

    fn fail<const NU: usize>(&mut self, inst: &Instance<NU>, what: String) {
        self.failures.push(format!("[{}] {what}\n    {inst:?}", inst.kind));
    }

    fn print(&self) {
        let (median, max) = median_max(&self.steps);
        eprintln!(
            "{:<40} {:>5} inst, steps median {median:>2} max {max:>3} | KKT {:.1e} (raw {:.1e}, {} over without floor) \
             | Clarabel: {} unsolved, du {:.1e} after crossover ({} no crossover), raw du {:.1e} ({} > 1e-6), \
             cost excess {:+.1e} | {} failures",
            self.name,
            self.instances,
            self.worst_kkt,
            self.worst_kkt_raw,
            self.needed_floor,
            self.unsolved,
            self.worst_du,
            self.no_crossover,
            self.worst_du_raw,
            self.raw_beyond,
            self.worst_excess,
            self.failures.len()
        );
    }
}

/// Fails with the first few failures of all `tallies`, each with its instance as Rust data.
fn assert_no_failures<'a>(failures: impl IntoIterator<Item = &'a String>) {
    let failures: Vec<&String> = failures.into_iter().collect();
    assert!(
        failures.is_empty(),
        "{} failures; the first:\n{}",
        failures.len(),
        failures.iter().take(SHOWN_FAILURES).map(|f| f.as_str()).collect::<Vec<_>>().join("\n")
    );
}

fn median_max(steps: &[u32]) -> (u32, u32) {
    let mut s = steps.to_vec();
    s.sort_unstable();
    (s.get(s.len() / 2).copied().unwrap_or(0), s.last().copied().unwrap_or(0))
}

/// Solve `inst` cold and check the answer: verified, in the box, KKT (recomputed), no
/// dearer than Clarabel's point, and equal to Clarabel's answer crossed over to its face.
fn check_against_truths<const NU: usize>(inst: &Instance<NU>, solver: &mut InputSpaceSolver<NU>, tally: &mut Tally) {
    let outcome = solver.solve(&inst.problem(), Start::Cold, MAX_STEPS).expect("valid data");
    let u = *solver.u();
    tally.instances += 1;
    tally.steps.push(solver.steps());
    if outcome != Outcome::Verified {
        tally.fail(inst, format!("outcome {outcome:?} after {} steps", solver.steps()));
    }
    if !inst.in_box(&u) {
        tally.fail(inst, format!("u {u:?} outside the box"));
    }
    let kkt = kkt(inst, &u);
    tally.worst_kkt = tally.worst_kkt.max(kkt.measure);
    tally.worst_kkt_raw = tally.worst_kkt_raw.max(kkt.raw);
    tally.needed_floor += usize::from(kkt.raw > KKT_TOLERANCE);
    if !within(kkt.measure, KKT_TOLERANCE) {
        tally.fail(inst, format!("KKT measure {:.3e} (raw {:.3e}) at u {u:?}", kkt.measure, kkt.raw));
    }
    let (solved, reference) = clarabel_reference(inst);
    tally.unsolved += usize::from(!solved);
    let Some(reference) = reference else { return };
    // Clarabel's point may sit outside the box by up to 1e-9; clipped, it is a feasible
    // point, which the exact optimum cannot cost more than.
    let reference = inst.clip(&reference);
    let (f, f_ref) = (cost(inst, &u), cost(inst, &reference));
    let excess = (f - f_ref) / (1.0 + f_ref);
    tally.worst_excess = tally.worst_excess.max(excess);
    if !within(excess, COST_SLACK) {
        tally.fail(inst, format!("cost {f:.17e} above Clarabel's {f_ref:.17e} (relative {excess:.2e})"));
    }
    if !solved {
        return;
    }
    let du_raw = inst.distance(&u, &reference);
    tally.worst_du_raw = tally.worst_du_raw.max(du_raw);
    tally.raw_beyond += usize::from(du_raw > CLARABEL_AGREEMENT);
    match crossover(inst, &reference) {
        Some(exact) => {
            let du = inst.distance(&u, &exact);
            tally.worst_du = tally.worst_du.max(du);
            if !within(du, CLARABEL_AGREEMENT) {
                tally.fail(inst, format!("u {u:?} is {du:.2e} from Clarabel's crossed over {exact:?}"));
            }
        }
        None => tally.no_crossover += 1,
    }
}

fn run_random<const NU: usize>(seed: u64, count: usize) -> Tally {
    let mut rng = common::rng(seed);
    let mut solver = InputSpaceSolver::<NU>::new(CAPACITY);
    let mut tally = Tally::new(format!("random, NU = {NU}"));
    for _ in 0..count {
        let inst = random_instance::<NU>(&mut rng, 60);
        check_against_truths(&inst, &mut solver, &mut tally);
    }
    tally.print();
    tally
}

fn run_degenerate<const NU: usize>(seed: u64, per_kind: usize) -> Vec<Tally> {
    let mut rng = common::rng(seed);
    let mut solver = InputSpaceSolver::<NU>::new(CAPACITY);
    DEGENERATE_KINDS
        .iter()
        .map(|&kind| {
            let mut tally = Tally::new(format!("{kind}, NU = {NU}"));
            for _ in 0..per_kind {
                let inst = degenerate_instance::<NU>(&mut rng, kind);
                check_against_truths(&inst, &mut solver, &mut tally);
            }
            tally.print();
            tally
        })
        .collect()
}

#[test]
fn random_instances_match_clarabel_nu17() {
    let tally = run_random::<17>(1401, 1200);
    assert_no_failures(&tally.failures);
}

#[test]
fn random_instances_match_clarabel_small_nu() {
    let tallies = [run_random::<1>(1411, 200), run_random::<3>(1413, 300), run_random::<6>(1416, 300)];
    assert_no_failures(tallies.iter().flat_map(|t| &t.failures));
}

#[test]
fn degenerate_instances_match_clarabel_nu17() {
    let tallies = run_degenerate::<17>(1421, 100);
    assert_no_failures(tallies.iter().flat_map(|t| &t.failures));
}

#[test]
fn degenerate_instances_match_clarabel_small_nu() {
    let mut tallies = run_degenerate::<1>(1431, 30);
    tallies.extend(run_degenerate::<3>(1433, 30));
    tallies.extend(run_degenerate::<6>(1436, 30));
    assert_no_failures(tallies.iter().flat_map(|t| &t.failures));
}

// ---------------------------------------------------------------------------------------
// Warm starts
// ---------------------------------------------------------------------------------------

/// Per start kind, the steps taken; failures shared.
#[derive(Default)]
struct WarmTally {
    instances: usize,
    own_sets: Vec<u32>,
    shifted_sets: Vec<u32>,
    point: Vec<u32>,
    worst_du: f64,
    failures: Vec<String>,
}

/// Cold, then from (a) the answer's own sets, (b) the sets of the answer to the same
/// problem with every `b` shifted slightly, (c) a random point in the box: all verified,
/// all the same `u` to 1e-9 of the input scale (plus the rounding floors of the two
/// answers, see [`kkt`]); (a) within its face solve and one refining step.
fn check_warm<const NU: usize>(
    inst: &Instance<NU>,
    rng: &mut ChaCha8Rng,
    solver: &mut InputSpaceSolver<NU>,
    tally: &mut WarmTally,
) {
    let p = inst.problem();
    let fail =
        |tally: &mut WarmTally, what: String| tally.failures.push(format!("[{}] {what}\n    {inst:?}", inst.kind));
    tally.instances += 1;
    let outcome = solver.solve(&p, Start::Cold, MAX_STEPS).expect("valid data");
    if outcome != Outcome::Verified {
        fail(tally, format!("cold: {outcome:?}"));
        return;
    }
    let cold = *solver.u();
    let cold_kkt = kkt(inst, &cold);
    let cold_floor = cold_kkt.floor;
    let (violated, held) = (solver.violated().to_vec(), *solver.held());

    let compare = |tally: &mut WarmTally, start: &str, outcome: Outcome, u: &[f64; NU]| {
        let warm_kkt = kkt(inst, u);
        let floor = warm_kkt.floor;
        let du = (0..NU)
            .map(|j| ((u[j] - cold[j]).abs() - floor[j] - cold_floor[j]).max(0.0) / inst.input_scale(j))
            .fold(0.0, f64::max);
        tally.worst_du = tally.worst_du.max(du);
        if outcome != Outcome::Verified || !within(du, WARM_AGREEMENT) {
            fail(
                tally,
                format!(
                    "{start}: {outcome:?}, u is {du:.2e} from the cold answer (KKT measures {:.1e} warm, {:.1e} cold)\n    \
                     warm {u:?}\n    cold {cold:?}",
                    warm_kkt.measure, cold_kkt.measure
                ),
            );
        }
    };

    // (a) The answer's own face: one face solve, verified at once.
    let outcome = solver.solve(&p, Start::Guess { violated: &violated, held: &held }, MAX_STEPS).expect("valid");
    tally.own_sets.push(solver.steps());
    compare(tally, "own sets", outcome, solver.u());
    // The face solve, and at most one Newton step refining it: a direct solve of a face
    // with stiff rows carries the rounding of its right-hand side (terms `2 s_i b_i a_i`
    // far larger than the answer), which the step, computed from the gradient at the
    // point, removes.
    if solver.steps() > 2 {
        fail(tally, format!("own sets: {} steps, not 1 or 2", solver.steps()));
    }

    // (b) A neighbouring problem's face.
    let mut shifted = inst.clone();
    for row in &mut shifted.rows {
        row.b += (1.0 + row.b.abs()) * log_uniform(rng, -6.0, -2.0) * uniform(rng, -1.0, 1.0);
    }
    solver.solve(&shifted.problem(), Start::Cold, MAX_STEPS).expect("valid data");
    let (violated, held) = (solver.violated().to_vec(), *solver.held());
    let outcome = solver.solve(&p, Start::Guess { violated: &violated, held: &held }, MAX_STEPS).expect("valid");
    tally.shifted_sets.push(solver.steps());
    compare(tally, "shifted problem's sets", outcome, solver.u());

    // (c) A random point in the box.
    let x: [f64; NU] = std::array::from_fn(|j| uniform(rng, inst.lo[j], inst.hi[j]));
    let outcome = solver.solve(&p, Start::Point(&x), MAX_STEPS).expect("valid");
    tally.point.push(solver.steps());
    compare(tally, "random point", outcome, solver.u());
}

fn run_warm<const NU: usize>(seed: u64, random: usize, per_kind: usize) -> WarmTally {
    let mut rng = common::rng(seed);
    let mut solver = InputSpaceSolver::<NU>::new(CAPACITY);
    let mut tally = WarmTally::default();
    let mut instances: Vec<Instance<NU>> = (0..random).map(|_| random_instance(&mut rng, 60)).collect();
    for kind in DEGENERATE_KINDS {
        instances.extend((0..per_kind).map(|_| degenerate_instance(&mut rng, kind)));
    }
    for inst in &instances {
        check_warm(inst, &mut rng, &mut solver, &mut tally);
    }
    let ((a_med, a_max), (b_med, b_max), (c_med, c_max)) =
        (median_max(&tally.own_sets), median_max(&tally.shifted_sets), median_max(&tally.point));
    eprintln!(
        "{:<40} {:>5} inst, steps median/max: own sets {a_med}/{a_max}, shifted problem's sets {b_med}/{b_max}, \
         random point {c_med}/{c_max} | worst du {:.1e} | {} failures",
        format!("warm vs cold, NU = {NU}"),
        tally.instances,
        tally.worst_du,
        tally.failures.len()
    );
    tally
}

#[test]
fn warm_starts_give_the_cold_answer() {
    let tallies = [run_warm::<17>(1441, 400, 20), run_warm::<6>(1446, 200, 10), run_warm::<1>(1447, 100, 5)];
    assert_no_failures(tallies.iter().flat_map(|t| &t.failures));
}

// ---------------------------------------------------------------------------------------
// Robustness
// ---------------------------------------------------------------------------------------

/// Rows too large for double precision, added to random instances.
const HUGE_KINDS: [&str; 6] = [
    "a ~ 1e150",
    "a ~ 1e300",
    "a ~ ±1e300 in one row",
    "b = -1e300",
    "b = +1e300 (satisfied everywhere)",
    "NaN or infinite entries",
];

fn huge_instance<const NU: usize>(rng: &mut ChaCha8Rng, kind: &'static str) -> (Instance<NU>, Instance<NU>) {
    let base = random_instance::<NU>(rng, 20);
    let mut inst = base.clone();
    inst.kind = kind;
    for _ in 0..rng.random_range(1..=3) {
        let mut row = random_row(rng, &inst);
        match kind {
            "a ~ 1e150" | "a ~ 1e300" => {
                let size = if kind == "a ~ 1e150" { 1e150 } else { 1e300 };
                for j in 0..NU {
                    if rng.random_bool(0.5) {
                        row.a[j] = size * uniform(rng, 0.5, 1.0) * sign(rng);
                    }
                }
                row.b = match rng.random_range(0..3) {
                    0 => 0.0,
                    1 => row.b,
                    _ => sign(rng) * size,
                };
            }
            "a ~ ±1e300 in one row" => {
                row.a[0] = 1e300;
                row.a[NU - 1] = -1e300;
            }
            "b = -1e300" => row.b = -1e300,
            "b = +1e300 (satisfied everywhere)" => row.b = 1e300,
            _ => {
                let bad = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY][rng.random_range(0..3)];
                if rng.random_bool(0.5) {
                    row.a[rng.random_range(0..NU)] = bad;
                } else {
                    row.b = bad;
                }
            }
        }
        let at = rng.random_range(0..=inst.rows.len());
        inst.rows.insert(at, row);
    }
    (inst, base)
}

#[test]
fn huge_rows_are_verified_non_finite_or_flagged_never_wrong_or_a_panic() {
    fn run<const NU: usize>(seed: u64, per_kind: usize, failures: &mut Vec<String>) {
        let mut rng = common::rng(seed);
        let mut solver = InputSpaceSolver::<NU>::new(CAPACITY);
        for kind in HUGE_KINDS {
            let mut counts = [0usize; 3]; // Verified, StepLimit, NonFinite
            let (mut worst_kkt, mut worst_base_kkt, mut unmeasured) = (0.0f64, 0.0f64, 0);
            for _ in 0..per_kind {
                let (inst, base) = huge_instance::<NU>(&mut rng, kind);
                let mut fail = |what: String| failures.push(format!("[{kind}] {what}\n    {inst:?}"));
                let before = *solver.u();
                let solved = catch_unwind(AssertUnwindSafe(|| solver.solve(&inst.problem(), Start::Cold, MAX_STEPS)));
                let outcome = match solved {
                    Ok(Ok(outcome)) => outcome,
                    Ok(Err(e)) => {
                        fail(format!("error {e}"));
                        continue;
                    }
                    Err(_) => {
                        fail("panicked".into());
                        solver = InputSpaceSolver::new(CAPACITY);
                        continue;
                    }
                };
                let u = *solver.u();
                counts[match outcome {
                    Outcome::Verified => 0,
                    Outcome::StepLimit => 1,
                    Outcome::NonFinite => 2,
                }] += 1;
                if !u.iter().all(|v| v.is_finite()) {
                    fail(format!("{outcome:?} with u {u:?}"));
                }
                if outcome != Outcome::NonFinite && !inst.in_box(&u) {
                    fail(format!("{outcome:?} with u {u:?} outside the box"));
                }
                match outcome {
                    Outcome::NonFinite if u != before => fail(format!("NonFinite changed u from {before:?} to {u:?}")),
                    Outcome::NonFinite => {}
                    // Rows of 1e150 and more can leave no point whose optimality double
                    // precision can confirm: the flagged fallback (the filter hands the
                    // cycle to OSQP), counted below, never a wrong answer.
                    Outcome::StepLimit if !kind.starts_with("a ~") => {
                        fail(format!("{outcome:?} after {} steps (u {u:?})", solver.steps()))
                    }
                    Outcome::StepLimit => {}
                    Outcome::Verified => {
                        // Verified means optimal; where the recomputed measure is finite
                        // (the huge terms do not overflow in it), it must say so too.
                        let kkt = kkt(&inst, &u).measure;
                        if kkt.is_finite() {
                            worst_kkt = worst_kkt.max(kkt);
                            if !within(kkt, KKT_TOLERANCE) {
                                fail(format!("verified with KKT measure {kkt:.2e} at u {u:?}"));
                            }
                        } else {
                            unmeasured += 1;
                        }
                    }
                }
                if kind == "NaN or infinite entries" && outcome != Outcome::NonFinite {
                    fail(format!("{outcome:?} with a row that is not finite"));
                }
                if kind == "b = +1e300 (satisfied everywhere)" {
                    // These rows never bind in the box: the answer is the answer without them.
                    let kkt = kkt(&base, &u).measure;
                    worst_base_kkt = worst_base_kkt.max(kkt);
                    if outcome != Outcome::Verified || !within(kkt, KKT_TOLERANCE) {
                        fail(format!("{outcome:?}; KKT measure without the huge rows {kkt:.2e}"));
                    }
                }
            }
            if counts[1] > per_kind / 10 {
                failures.push(format!("[{kind}] {} of {per_kind} at the step limit (at most a tenth)", counts[1]));
            }
            eprintln!(
                "{:<40} {:>5} inst: {:>3} verified (worst KKT {worst_kkt:.1e}, {unmeasured} beyond the measure's range), \
                 {} step limit, {:>3} non-finite{}",
                format!("{kind}, NU = {NU}"),
                per_kind,
                counts[0],
                counts[1],
                counts[2],
                if kind.starts_with("b = +") {
                    format!("; KKT without the huge rows {worst_base_kkt:.1e}")
                } else {
                    String::new()
                }
            );
        }
    }
    let mut failures = Vec::new();
    run::<17>(1451, 100, &mut failures);
    run::<3>(1453, 100, &mut failures);
    assert_no_failures(&failures);
}

#[test]
fn invalid_data_is_an_error_and_changes_nothing() {
    const NU: usize = 3;
    let rows = [
        SoftRow { a: [1.0, 0.0, 0.0], b: -2.0, weight: 1e4 },
        SoftRow { a: [0.0, 1.0, 1.0], b: 1.0, weight: 1e3 },
        SoftRow { a: [0.0, -1.0, 0.5], b: -0.5, weight: 1e6 },
    ];
    let valid = Instance::<NU> {
        kind: "valid",
        weights: [1.0, 2.0, 0.5],
        u_ref: [0.2, -0.3, 0.1],
        lo: [-1.0, -1.0, -1.0],
        hi: [1.5, 1.0, 1.0],
        rows: rows.to_vec(),
    };
    let mut solver = InputSpaceSolver::<NU>::new(3);
    assert_eq!(solver.solve(&valid.problem(), Start::Cold, MAX_STEPS).unwrap(), Outcome::Verified);
    assert!(kkt(&valid, solver.u()).measure <= KKT_TOLERANCE);
    let snapshot = |s: &InputSpaceSolver<NU>| {
        (*s.u(), s.violated().to_vec(), s.row_values().to_vec(), *s.held(), s.steps(), s.outcome())
    };
    let before = snapshot(&solver);
    // Row 0 wants u_0 ≥ 2 beyond its limit 1.5: violated at the answer.
    assert!(before.1[0], "the snapshot has a violated row");

    let mut cases: Vec<(&str, Instance<NU>)> = Vec::new();
    let mut with = |what: &'static str, change: &dyn Fn(&mut Instance<NU>)| {
        let mut inst = valid.clone();
        change(&mut inst);
        cases.push((what, inst));
    };
    with("NaN input weight", &|i| i.weights[1] = f64::NAN);
    with("zero input weight", &|i| i.weights[0] = 0.0);
    with("negative input weight", &|i| i.weights[2] = -1.0);
    with("infinite input weight", &|i| i.weights[2] = f64::INFINITY);
    with("lo > hi", &|i| (i.lo[1], i.hi[1]) = (0.5, 0.4));
    with("NaN lower limit", &|i| i.lo[0] = f64::NAN);
    with("infinite upper limit", &|i| i.hi[2] = f64::INFINITY);
    with("NaN nominal input", &|i| i.u_ref[1] = f64::NAN);
    with("NaN slack weight", &|i| i.rows[1].weight = f64::NAN);
    with("zero slack weight", &|i| i.rows[2].weight = 0.0);
    with("too many rows for the capacity", &|i| i.rows.push(i.rows[0]));
    for (what, inst) in &cases {
        let result = solver.solve(&inst.problem(), Start::Cold, MAX_STEPS);
        assert!(result.is_err(), "{what}: {result:?}");
        assert!(snapshot(&solver) == before, "{what} changed the solver's state");
    }
    let held = [Bound::Free; NU];
    for guess in [&[true, false][..], &[true, false, false, true][..], &[][..]] {
        let result = solver.solve(&valid.problem(), Start::Guess { violated: guess, held: &held }, MAX_STEPS);
        assert!(result.is_err(), "guess of {} rows for 3: {result:?}", guess.len());
        assert!(snapshot(&solver) == before, "a guess of the wrong length changed the solver's state");
    }
    // And the same workspace still gives the same answer, bit for bit.
    assert_eq!(solver.solve(&valid.problem(), Start::Cold, MAX_STEPS).unwrap(), Outcome::Verified);
    assert!(snapshot(&solver) == before);
}

// ---------------------------------------------------------------------------------------
// Hand-solved cases
// ---------------------------------------------------------------------------------------

fn solve_cold<const NU: usize>(inst: &Instance<NU>) -> [f64; NU] {
    let mut solver = InputSpaceSolver::<NU>::new(CAPACITY);
    let outcome = solver.solve(&inst.problem(), Start::Cold, MAX_STEPS).expect("valid data");
    assert_eq!(outcome, Outcome::Verified, "{inst:?}");
    *solver.u()
}

fn one_input(weight: f64, u_ref: f64, lo: f64, hi: f64, rows: &[(f64, f64, f64)]) -> Instance<1> {
    Instance {
        kind: "hand",
        weights: [weight],
        u_ref: [u_ref],
        lo: [lo],
        hi: [hi],
        rows: rows.iter().map(|&(a, b, weight)| SoftRow { a: [a], b, weight }).collect(),
    }
}

fn assert_close(got: f64, want: f64, what: &str) {
    assert!((got - want).abs() <= 1e-14 * (1.0 + want.abs()), "{what}: got {got:e}, want {want:e}");
}

#[test]
fn hand_solved_cases() {
    // Conflicting rows u ≥ 1 and u ≤ −1, both violated at the optimum:
    // min w (u − r)² + s1 (1 − u)² + s2 (1 + u)²  ⇒  u = (w r + s1 − s2) / (w + s1 + s2).
    let (w, r, s1, s2) = (1.0, 0.3, 2.0, 3.0);
    let u = solve_cold(&one_input(w, r, -10.0, 10.0, &[(1.0, -1.0, s1), (-1.0, -1.0, s2)]));
    assert_close(u[0], (w * r + s1 - s2) / (w + s1 + s2), "conflicting rows");

    // Duplicate rows u ≥ 1 act as one of twice the weight: u = 2s / (w + 2s).
    let s = 1e6;
    let u = solve_cold(&one_input(1.0, 0.0, -10.0, 10.0, &[(1.0, -1.0, s), (1.0, -1.0, s)]));
    assert_close(u[0], 2.0 * s / (1.0 + 2.0 * s), "duplicate rows");

    // A zero row costs a constant whatever its sign: u = clip(r).
    for b in [-3.0, 0.0, 2.0] {
        let u = solve_cold(&one_input(1.0, 4.0, -1.0, 2.5, &[(0.0, b, 1e8)]));
        assert_eq!(u, [2.5], "zero row with b = {b}");
    }

    // A tiny row 1e-9 u ≥ 1 with s = 1e8: 2u − 2e8·1e-9 (1 − 1e-9 u) = 0 ⇒ u = 0.1 / (1 + 1e-10).
    let u = solve_cold(&one_input(1.0, 0.0, -1e3, 1e3, &[(1e-9, -1.0, 1e8)]));
    assert_close(u[0], 0.1 / (1.0 + 1e-10), "tiny row");

    // A box of zero width holds its input whatever the rows and the nominal input want.
    let u = solve_cold(&one_input(1.0, 5.0, 0.75, 0.75, &[(1.0, -3.0, 1e8), (-1.0, 0.0, 1e2)]));
    assert_eq!(u, [0.75], "zero-width box");

    // u_ref exactly at a bound, a row pulling it outward: it stays at the bound.
    let u = solve_cold(&one_input(1.0, 1.0, -1.0, 1.0, &[(1.0, -2.0, 1e4)]));
    assert_eq!(u, [1.0], "u_ref at the upper bound, pulled outward");

    // A row over two saturated inputs wanting u1 + u2 ≥ 3 in [−1, 1]²: both held at 1
    // (the unconstrained optimum is u1 = u2 = 3s / (1 + 2s) > 1, and the gradient at
    // (1, 1), 2 − 2s, pushes outward).
    let inst = Instance::<2> {
        kind: "hand",
        weights: [1.0, 1.0],
        u_ref: [0.0, 0.0],
        lo: [-1.0, -1.0],
        hi: [1.0, 1.0],
        rows: vec![SoftRow { a: [1.0, 1.0], b: -3.0, weight: 1e4 }],
    };
    assert_eq!(solve_cold(&inst), [1.0, 1.0], "row against saturated inputs");

    // Rows exactly satisfied at u_ref (dyadic data: a·r + b = 0 exactly) and r inside the
    // box: r is optimal, found without a step.
    let inst = Instance::<3> {
        kind: "hand",
        weights: [1e-3, 1.0, 1e3],
        u_ref: [0.125, -2.5, 1.75],
        lo: [-4.0, -4.0, -4.0],
        hi: [4.0, 4.0, 4.0],
        rows: vec![
            SoftRow { a: [1.0, 0.5, -0.25], b: -(0.125 - 1.25 - 0.4375), weight: 1e8 },
            SoftRow { a: [-3.0, 0.0, 2.0], b: -(-0.375 + 3.5), weight: 1e2 },
        ],
    };
    let mut solver = InputSpaceSolver::<3>::new(2);
    assert_eq!(solver.solve(&inst.problem(), Start::Cold, MAX_STEPS).unwrap(), Outcome::Verified);
    assert_eq!(solver.u(), &inst.u_ref);
    assert_eq!(solver.steps(), 0);
    assert!(inst.rows.iter().all(|row| row_value(row, &inst.u_ref) == 0.0));
}

// ---------------------------------------------------------------------------------------
// Reduced failures, against exact optima
// ---------------------------------------------------------------------------------------

/// Solve `inst` cold, then again from the answer's own sets, and compare both with the
/// exact optimum `exact` in the KKT measure's units (`1 + |u*_j| + |r_j|`, tolerance
/// [`KKT_TOLERANCE`]); a description of each miss.
fn misses_of_exact<const NU: usize>(name: &str, inst: &Instance<NU>, exact: [f64; NU]) -> Vec<String> {
    let mut solver = InputSpaceSolver::<NU>::new(CAPACITY);
    let mut misses = Vec::new();
    let mut judge = |start: &str, outcome: Outcome, steps: u32, u: &[f64; NU]| {
        let off =
            (0..NU).map(|j| (u[j] - exact[j]).abs() / (1.0 + exact[j].abs() + inst.u_ref[j].abs())).fold(0.0, f64::max);
        if outcome != Outcome::Verified || !within(off, KKT_TOLERANCE) {
            misses.push(format!("{name}, {start}: {outcome:?} in {steps} steps, u {u:?} is {off:.1e} from {exact:?}"));
        }
    };
    let outcome = solver.solve(&inst.problem(), Start::Cold, MAX_STEPS).expect("valid data");
    judge("cold", outcome, solver.steps(), solver.u());
    let (violated, held) = (solver.violated().to_vec(), *solver.held());
    let outcome = solver.solve(&inst.problem(), Start::Guess { violated: &violated, held: &held }, MAX_STEPS).unwrap();
    judge("from its own sets", outcome, solver.steps(), solver.u());
    misses
}

/// Failures of the random and degenerate groups, reduced by hand-run shrinking (rows
/// dropped, numbers rounded, pinned inputs removed, while the failure stays), each with
/// its exact optimum: found by enumerating every face (each input free, at its lower or
/// its upper bound; each row violated or not), solving each face's linear system in
/// rational arithmetic (Python `fractions`, from the exact binary values below) and
/// keeping the one face whose solution satisfies all KKT conditions exactly. It is unique
/// in each case, as strict convexity says it must be; the optimum is that solution
/// rounded to double.
#[test]
fn reduced_failures_match_exact_optima() {
    let mut misses = Vec::new();
    // One stiff row over two inputs: a loose gradient test accepts the first Newton step
    // (4e-8 from the optimum in u_0).
    let inst = Instance::<2> {
        kind: "u_ref at a bound",
        weights: [16.611464703035825, 1.0],
        u_ref: [1.0, -100.0],
        lo: [0.0, -100.0],
        hi: [1.0, 100.0],
        rows: vec![SoftRow { a: [-0.126, 4.0], b: -235.48555790034328, weight: 32000000.0 }],
    };
    misses.extend(misses_of_exact("two inputs, one stiff row", &inst, [0.6986935151832059, 58.89339801047542]));
    // The face solve of a warm start accepted without a correcting step (1e-7 off).
    let inst = Instance::<3> {
        kind: "rows satisfied at u_ref",
        weights: [0.06, 1.0, 1.0],
        u_ref: [-0.0, -145.125, -0.0],
        lo: [-0.006, -400.0, -0.5],
        hi: [0.0, 0.0, -0.05],
        rows: vec![SoftRow { a: [-5.0, 0.75, 0.5], b: 108.84375, weight: 80300000.0 }],
    };
    misses.extend(misses_of_exact(
        "three inputs, one stiff row",
        &inst,
        [-0.0049932591000656735, -145.1249550606681, -0.05],
    ));
    // One stiff row over six inputs (1e-8 off).
    let inst = Instance::<6> {
        kind: "duplicate rows",
        weights: [1.0, 0.03, 1.0, 0.009, 1.0, 1.0],
        u_ref: [10.345456950913173, 0.0, 0.0, 0.0, 0.0, 0.0],
        lo: [0.0, 0.0, 0.0, 0.0, -8.0, -10.0],
        hi: [20.0, 13.0, 1.0, 1.0, 0.0, 0.0],
        rows: vec![SoftRow { a: [-3.606003328717264, 0.9, 1.0, 1.0, -2.0, -0.6], b: -26.0, weight: 20000000.0 }],
    };
    misses.extend(misses_of_exact(
        "six inputs, one stiff row",
        &inst,
        [0.04333010492121017, 13.0, 1.0, 1.0, -5.713875394372783, -1.7141626183118348],
    ));
    // Two rows, one stiff and on its kink within its terms' rounding: verified 0.64 away
    // from the optimum in u_1, at a higher cost.
    let inst = Instance::<6> {
        kind: "rows satisfied at u_ref",
        weights: [1.0, 0.013, 1.0, 1.0, 0.1, 1.0],
        u_ref: [0.0, -2.0, 2.0, -9.0, -6.0, -80.0],
        lo: [0.0, 0.0, 0.0, -10.0, -6.0, -100.0],
        hi: [190.0, 1.0, 2.0, 0.0, 0.0, 0.0],
        rows: vec![
            SoftRow { a: [0.004, 0.0, 0.0, 0.0, 0.0, 0.0], b: -0.9, weight: 9000000.0 },
            SoftRow { a: [-4.25, 3.0, 3.0, -4.5, 5.0, -0.75], b: 726.0, weight: 80000000.0 },
        ],
    };
    misses.extend(misses_of_exact(
        "six inputs, a stiff row on its kink",
        &inst,
        [190.0, 0.6356643321393671, 2.0, -9.051395454476717, -5.4289393947031375, -80.00856590907945],
    ));
    // Conflicting stiff rows (a and nearly −a): the line search stalls (StepLimit after
    // a few steps, 44 away from the optimum in u_1).
    let inst = Instance::<4> {
        kind: "conflicting rows",
        weights: [1.0, 1.0, 0.2, 1.0],
        u_ref: [0.0, 200.0, -50.0, 0.0],
        lo: [-6.0, 0.0, -50.0, 0.0],
        hi: [0.0, 200.0, 0.0, 1.0],
        rows: vec![
            SoftRow { a: [-0.0001, 0.0, 0.0, 7e-05], b: -0.017, weight: 1.0 },
            SoftRow { a: [0.0, -1.3, -2.103800995722615, -0.332372536486341], b: 200.0, weight: 3000000.0 },
            SoftRow { a: [-0.0, 1.27, 2.103800995722615, 0.332372536486341], b: -200.0, weight: 7000000.0 },
        ],
    };
    misses.extend(misses_of_exact(
        "conflicting stiff rows",
        &inst,
        [-1.6929999830700005e-06, 156.09426472400108, 0.0, 1.0],
    ));
    assert!(misses.is_empty(), "{} misses:\n{}", misses.len(), misses.join("\n"));
}
