//! The lexicographic (priority-tier) QP's stages written out for Clarabel, an
//! interior-point solver sharing no code with the filter: the hard QP, and the linear
//! program "least largest violation" of one tier. Shared by the solver's and the filter's
//! tests.
// Index loops mirror the formulas (rows × inputs).
#![allow(clippy::needless_range_loop)]

use cbfgen::qp::lexicographic::TieredRow;
use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus};

/// A row `a·u ≥ lower`, or with `elastic = σ > 0`, `a·u + σ t ≥ lower`.
#[derive(Debug, Clone)]
pub struct RefRow {
    pub a: Vec<f64>,
    pub lower: f64,
    pub elastic: f64,
}

fn settings() -> DefaultSettings<f64> {
    DefaultSettings { max_iter: 500, ..crate::clarabel_qp::tight_settings() }
}

/// Clarabel in the form `min ½ zᵀ P z + qᵀ z` s.t. `G z ≤ h` (dense `G`), `P` diagonal:
/// at tolerances of 1e-11, or where those are beyond it (Clarabel reports "almost solved"
/// on some vertices of nearly parallel rows), at its default 1e-8. A point is used only if
/// it meets every row to 1e-9 of the row's terms, the solver's own feasibility: on rows of
/// 1e7 Clarabel's scaled tolerance can leave one missed by a part in 1e5, which would make
/// it a cheaper "reference" than the exact answer. `None` when no solve gives such a point.
fn solve(p_diag: &[f64], q: &[f64], g: &[Vec<f64>], h: &[f64]) -> Option<Vec<f64>> {
    let n = q.len();
    let p = CscMatrix::new(n, n, (0..=n).collect(), (0..n).collect(), p_diag.to_vec());
    let (mut colptr, mut rowval, mut nzval) = (vec![0], vec![], vec![]);
    for c in 0..n {
        for (r, row) in g.iter().enumerate() {
            if row[c] != 0.0 {
                rowval.push(r);
                nzval.push(row[c]);
            }
        }
        colptr.push(rowval.len());
    }
    let a = CscMatrix::new(g.len(), n, colptr, rowval, nzval);
    for settings in [settings(), DefaultSettings { verbose: false, ..DefaultSettings::default() }] {
        let mut solver = DefaultSolver::new(&p, q, &a, h, &[NonnegativeConeT(g.len())], settings).ok()?;
        solver.solve();
        let z = &solver.solution.x;
        let feasible = g.iter().zip(h).all(|(row, &bound)| {
            let (mut value, mut terms) = (0.0, bound.abs());
            for (a, x) in row.iter().zip(z) {
                value += a * x;
                terms += a.abs() * (1.0 + x.abs());
            }
            value - bound <= 1e-9 * terms
        });
        if solver.solution.status == SolverStatus::Solved && feasible {
            return Some(z.clone());
        }
    }
    None
}

/// `min ½ Σ w (u − r)²` s.t. `a·u ≥ lower` for every row and the box; `None` unless
/// Clarabel reports it solved. The point is clipped into the box, which Clarabel meets
/// only to its tolerance (at inputs of 1e6, by 1e-3: enough to buy a row's rounding back).
pub fn hard_qp(weights: &[f64], u_ref: &[f64], lo: &[f64], hi: &[f64], rows: &[RefRow]) -> Option<Vec<f64>> {
    let nu = weights.len();
    let q: Vec<f64> = (0..nu).map(|j| -weights[j] * u_ref[j]).collect();
    let (mut g, mut h) = (Vec::new(), Vec::new());
    for r in rows {
        g.push(r.a.iter().map(|v| -v).collect());
        h.push(-r.lower);
    }
    box_rows(nu, 0, lo, hi, &mut g, &mut h);
    let x = solve(weights, &q, &g, &h)?;
    Some((0..nu).map(|j| x[j].clamp(lo[j], hi[j])).collect())
}

/// The linear program `min t` s.t. every row (elastic ones with `σ t`), `t ≥ 0` and the
/// box: the input of the least largest violation, clipped into the box. `None` unless
/// solved.
pub fn least_largest_violation(lo: &[f64], hi: &[f64], rows: &[RefRow]) -> Option<Vec<f64>> {
    let nu = lo.len();
    let n = nu + 1;
    let mut q = vec![0.0; n];
    q[nu] = 1.0;
    let (mut g, mut h) = (Vec::new(), Vec::new());
    for r in rows {
        let mut row: Vec<f64> = r.a.iter().map(|v| -v).collect();
        row.push(-r.elastic);
        g.push(row);
        h.push(-r.lower);
    }
    box_rows(nu, 1, lo, hi, &mut g, &mut h);
    let mut t_row = vec![0.0; n];
    t_row[nu] = -1.0;
    g.push(t_row);
    h.push(0.0);
    let z = solve(&vec![0.0; n], &q, &g, &h)?;
    Some((0..nu).map(|j| z[j].clamp(lo[j], hi[j])).collect())
}

fn box_rows(nu: usize, extra: usize, lo: &[f64], hi: &[f64], g: &mut Vec<Vec<f64>>, h: &mut Vec<f64>) {
    for j in 0..nu {
        let mut up = vec![0.0; nu + extra];
        up[j] = 1.0;
        g.push(up);
        h.push(hi[j]);
        let mut down = vec![0.0; nu + extra];
        down[j] = -1.0;
        g.push(down);
        h.push(-lo[j]);
    }
}

/// `max(0, −(a·u + b))`.
pub fn violation<const NU: usize>(r: &TieredRow<NU>, u: &[f64; NU]) -> f64 {
    (-(0..NU).map(|j| r.a[j] * u[j]).sum::<f64>() - r.b).max(0.0)
}

/// The size of a row's terms at `u`, `|b| + Σ_j |a_j| (1 + |u_j|)`: what its rounding is
/// relative to.
pub fn terms<const NU: usize>(r: &TieredRow<NU>, u: &[f64; NU]) -> f64 {
    r.b.abs() + (0..NU).map(|j| r.a[j].abs() * (1.0 + u[j].abs())).sum::<f64>()
}

/// Row `r` is at least as well met at `x` as at `u`, to 1e-12 of its terms.
fn no_worse<const NU: usize>(r: &TieredRow<NU>, x: &[f64; NU], u: &[f64; NU]) -> bool {
    violation(r, x) <= violation(r, u) + 1e-12 * terms(r, u)
}

pub fn sigma<const NU: usize>(r: &TieredRow<NU>, w: &[f64; NU]) -> f64 {
    (0..NU).map(|j| r.a[j] * r.a[j] / w[j]).sum::<f64>().sqrt()
}

/// Checks one verified answer `u` against Clarabel's stages: inside the box; tier by
/// tier, its largest violation (in input units, `σ = ‖a‖_{W⁻¹}`) the least possible given
/// the violations the higher tiers have at `u` (to 1e-6 of it and 1e-7 of the inputs'
/// scale); and no input achieving those violations
/// closer to `u_ref`. `Ok(true)` when some row is relaxed at `u`.
pub fn check_answer<const NU: usize>(
    weights: &[f64; NU],
    lo: &[f64; NU],
    hi: &[f64; NU],
    u_ref: &[f64; NU],
    rows: &[TieredRow<NU>],
    active: &[bool],
    u: &[f64; NU],
) -> Result<bool, String> {
    struct View<'a, const NU: usize> {
        weights: &'a [f64; NU],
        lo: &'a [f64; NU],
        hi: &'a [f64; NU],
        u_ref: &'a [f64; NU],
        rows: &'a [TieredRow<NU>],
        active: &'a [bool],
    }
    let inst = View { weights, lo, hi, u_ref, rows, active };
    const TOL: f64 = 1e-6;
    for j in 0..NU {
        if !(inst.lo[j]..=inst.hi[j]).contains(&u[j]) {
            return Err(format!("u[{j}] = {} outside the box", u[j]));
        }
    }
    let live: Vec<usize> = (0..inst.rows.len())
        .filter(|&i| {
            let r = &inst.rows[i];
            let reach: f64 = (0..NU).map(|j| r.a[j].abs() * (inst.hi[j] - inst.lo[j])).sum();
            inst.active[i] && reach > 1e-12 * r.b.abs()
        })
        .collect();
    let mut tiers: Vec<u8> = live.iter().map(|&i| inst.rows[i].tier).collect();
    tiers.sort_unstable();
    tiers.dedup();
    let mut relaxed = false;
    // Tier by tier: the largest violation in input units is the least possible given the
    // violations the higher tiers have at u.
    for &k in &tiers {
        let mut refs = Vec::new();
        let mut ours: f64 = 0.0;
        for &i in &live {
            let r = &inst.rows[i];
            let v = violation(r, u);
            if r.tier < k {
                // Tightened by what Clarabel may leave a row off by (see `solve`), so that
                // its point meets the bounds u met.
                refs.push(RefRow { a: r.a.to_vec(), lower: -r.b - v + 1e-9 * terms(r, u), elastic: 0.0 });
            } else if r.tier == k {
                let s = sigma(r, inst.weights);
                ours = ours.max(v / s);
                refs.push(RefRow { a: r.a.to_vec(), lower: -r.b, elastic: s });
            }
        }
        relaxed |= ours > TOL;
        // Clarabel's point is a competitor only if it meets the higher tiers at least as
        // well as u does (see the cost check below); its own largest violation is then
        // measured at it, exactly as ours.
        let Some(x) = least_largest_violation(inst.lo, inst.hi, &refs) else { continue };
        let x: [f64; NU] = std::array::from_fn(|j| x[j]);
        if !live.iter().filter(|&&i| inst.rows[i].tier < k).all(|&i| no_worse(&inst.rows[i], &x, u)) {
            continue;
        }
        let best = live
            .iter()
            .filter(|&&i| inst.rows[i].tier == k)
            .map(|&i| violation(&inst.rows[i], &x) / sigma(&inst.rows[i], inst.weights))
            .fold(0.0, f64::max);
        // In input units, relative to the violation and to the inputs' own scale: a row
        // fixed at its least violation is exact only to its rounding, and that rounding
        // can pin an input through a coefficient far below the row's size. Seen: a row of
        // terms 1e4 with a coefficient of 2e-11 on an input of 5e4 that a second row of
        // the tier needed; its few ulps held the second row 0.08 above the least, 5e-8 of
        // the inputs' scale of 1.6e6.
        let scale = (0..NU).map(|j| inst.weights[j].sqrt() * (u[j].abs() + inst.u_ref[j].abs())).fold(0.0, f64::max);
        if ours > best + TOL * (1.0 + best) + 1e-7 * scale {
            return Err(format!("tier {k}: largest violation {ours:.9e} input units, Clarabel's least {best:.9e}"));
        }
    }
    // Then the closest input achieving those violations: no point in the box with every
    // row at least as well met as at u costs less than u. Clarabel is asked for rows
    // tightened by what it may leave a row off by (see `solve`); its point, clipped into
    // the box, is a competitor only if it then meets every row at least as well as u does
    // (to 1e-12 of the row's terms): one that misses a row by more may have bought its
    // lower cost with that rounding (a part in 1e10 of a row of 1e5, traded against an
    // input of 1e6, is a part in 1e5 of the cost), and nothing is concluded from it.
    let refs: Vec<RefRow> = live
        .iter()
        .map(|&i| {
            let r = &inst.rows[i];
            RefRow { a: r.a.to_vec(), lower: -r.b - violation(r, u) + 1e-9 * terms(r, u), elastic: 0.0 }
        })
        .collect();
    let competitor = hard_qp(inst.weights, inst.u_ref, inst.lo, inst.hi, &refs).filter(|x| {
        let x: [f64; NU] = std::array::from_fn(|j| x[j]);
        live.iter().all(|&i| no_worse(&inst.rows[i], &x, u))
    });
    if let Some(x) = competitor {
        let cost = |v: &[f64]| (0..NU).map(|j| 0.5 * inst.weights[j] * (v[j] - inst.u_ref[j]).powi(2)).sum::<f64>();
        let (ours, theirs) = (cost(u), cost(&x));
        if ours > theirs + TOL * (1.0 + theirs) {
            return Err(format!("u costs {ours:.9e}, Clarabel's closest input with the same violations {theirs:.9e}"));
        }
    }
    Ok(relaxed)
}

/// How far `other` is from `reference`, in units of the inputs' scale
/// `1 + max_j |reference_j|`: the largest difference of one input.
pub fn gap_in_scale<const NU: usize>(reference: &[f64; NU], other: &[f64; NU]) -> f64 {
    let scale = 1.0 + reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    (0..NU).map(|j| (reference[j] - other[j]).abs()).fold(0.0, f64::max) / scale
}
