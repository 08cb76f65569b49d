//! The dense dual active-set solver against independent truths: hand-computed optima,
//! Clarabel (an interior-point solver) on thousands of random strictly convex QPs with
//! equality, duplicate, zero, huge and tiny rows and infeasible row sets, and the KKT
//! conditions recomputed here from the returned point and multipliers alone.

// Index loops mirror the formulas (rows × variables).
#![allow(clippy::needless_range_loop)]

use cbfgen::qp::dual_active_set::{ActiveRow, DenseStatus, DualActiveSet, Side, WarmStart, KKT_TOLERANCE};
use cbfgen_testkit::clarabel_qp::{self, Answer};
use clarabel::solver::DefaultSettings;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One QP: `min ½ zᵀPz + qᵀz s.t. l ≤ Az ≤ u`, dense and row-major.
#[derive(Debug, Clone)]
struct Qp {
    n: usize,
    p: Vec<f64>,
    q: Vec<f64>,
    a: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl Qp {
    fn m(&self) -> usize {
        self.lower.len()
    }

    fn row(&self, i: usize) -> &[f64] {
        &self.a[i * self.n..(i + 1) * self.n]
    }

    fn solver(&self) -> DualActiveSet {
        let mut solver = DualActiveSet::new(&self.p, self.n, self.m()).expect("positive definite");
        self.write(&mut solver);
        solver
    }

    fn write(&self, solver: &mut DualActiveSet) {
        let data = solver.data_mut();
        data.q.copy_from_slice(&self.q);
        data.a.copy_from_slice(&self.a);
        data.lower.copy_from_slice(&self.lower);
        data.upper.copy_from_slice(&self.upper);
    }

    /// `½ zᵀPz + qᵀz`.
    fn objective(&self, z: &[f64]) -> f64 {
        let n = self.n;
        let mut v = 0.0;
        for i in 0..n {
            v += self.q[i] * z[i];
            for j in 0..n {
                v += 0.5 * z[i] * self.p[i * n + j] * z[j];
            }
        }
        v
    }
}

/// What Clarabel made of a QP.
#[derive(Debug)]
enum Reference {
    /// Clarabel's point, and whether it met the tight tolerances (else its defaults).
    Solved(Vec<f64>, bool),
    Infeasible,
    /// No verdict (iteration limit, numerical error, no progress) at either tolerance.
    Other,
}

/// The QP on Clarabel: equality rows in a zero cone, each finite inequality bound one row
/// of `A' z + s = b`, `s ≥ 0`.
fn clarabel(qp: &Qp) -> Reference {
    let n = qp.n;
    let mut equalities: Vec<(Vec<f64>, f64)> = Vec::new();
    let mut inequalities: Vec<(Vec<f64>, f64)> = Vec::new();
    for i in 0..qp.m() {
        // Each row divided by its largest entry: exact, and rows 10^±8 apart in scale are
        // beyond what Clarabel's equilibration takes (it stops or fails on them). A zero
        // row with 0 within its bounds is no row.
        let largest = max_abs(qp.row(i));
        if largest == 0.0 && qp.lower[i] <= 0.0 && qp.upper[i] >= 0.0 {
            continue;
        }
        let f = if largest > 0.0 { 1.0 / largest } else { 1.0 };
        let row: Vec<f64> = qp.row(i).iter().map(|v| v * f).collect();
        let (l, u) = (
            if qp.lower[i] > -1e30 { qp.lower[i] * f } else { -1e30 },
            if qp.upper[i] < 1e30 { qp.upper[i] * f } else { 1e30 },
        );
        if l == u {
            // An exact repeat of an equality row makes Clarabel's equality block rank
            // deficient (it then reports such problems infeasible); it adds nothing, so
            // Clarabel gets each once.
            if !equalities.iter().any(|(r, b)| *r == row && *b == l) {
                equalities.push((row, l));
            }
            continue;
        }
        if u < 1e30 {
            inequalities.push((row.clone(), u));
        }
        if l > -1e30 {
            inequalities.push((row.iter().map(|v| -v).collect(), -l));
        }
    }
    // Tight tolerances first (z is compared to 1e-6); where Clarabel cannot make progress
    // on them (it stops short on a few degenerate draws), its defaults.
    let default = DefaultSettings { verbose: false, ..DefaultSettings::default() };
    for (settings, is_tight) in [(clarabel_qp::tight_settings(), true), (default, false)] {
        match clarabel_qp::solve(n, &qp.p, &qp.q, &equalities, &inequalities, settings) {
            Answer::Solved(x) => return Reference::Solved(x, is_tight),
            Answer::Infeasible => return Reference::Infeasible,
            Answer::Other => {}
        }
    }
    Reference::Other
}

/// The KKT conditions of `z` with OSQP-convention multipliers `y` (`Pz + q + Aᵀy = 0`),
/// recomputed here; returns the worst residual of each kind, each divided by the module's
/// documented scale, so each must be at most [`KKT_TOLERANCE`]:
/// `[primal, complementarity, dual sign, stationarity]`.
fn kkt_residuals(qp: &Qp, z: &[f64], y: &[f64]) -> [f64; 4] {
    let n = qp.n;
    let mut worst = [0.0f64; 4];
    for i in 0..qp.m() {
        let row = qp.row(i);
        let value: f64 = row.iter().zip(z).map(|(a, z)| a * z).sum();
        let size: f64 = row.iter().zip(z).map(|(a, z)| a.abs() * (1.0 + z.abs())).sum();
        let (l, u) = (qp.lower[i], qp.upper[i]);
        let scaled = |gap: f64, bound: f64| {
            let scale = bound.abs() + size;
            if scale > 0.0 {
                gap / scale
            } else if gap > 0.0 {
                f64::INFINITY
            } else {
                0.0
            }
        };
        if l > -1e30 {
            worst[0] = worst[0].max(scaled(l - value, l));
        }
        if u < 1e30 {
            worst[0] = worst[0].max(scaled(value - u, u));
        }
        // A multiplier only on a row at the bound its sign names (either, on an equality).
        if y[i] < 0.0 && l != u {
            worst[1] = worst[1].max(scaled((value - l).abs(), l));
            if l <= -1e30 {
                worst[2] = f64::INFINITY;
            }
        }
        if y[i] > 0.0 && l != u {
            worst[1] = worst[1].max(scaled((value - u).abs(), u));
            if u >= 1e30 {
                worst[2] = f64::INFINITY;
            }
        }
        if !y[i].is_finite() {
            worst[2] = f64::INFINITY;
        }
    }
    for j in 0..n {
        let mut terms = vec![qp.q[j]];
        terms.extend((0..n).map(|k| qp.p[j * n + k] * z[k]));
        terms.extend((0..qp.m()).map(|i| y[i] * qp.a[i * n + j]));
        let sum: f64 = terms.iter().sum();
        let size: f64 = terms.iter().map(|t| t.abs()).sum();
        worst[3] = worst[3].max(if size > 0.0 { sum.abs() / size } else { sum.abs() });
    }
    worst
}

fn assert_kkt(qp: &Qp, solver: &DualActiveSet, what: &str) {
    let r = kkt_residuals(qp, solver.solution(), solver.row_multipliers());
    assert!(r.iter().all(|&v| v <= KKT_TOLERANCE), "{what}: KKT residuals {r:?} (primal, compl., sign, stationarity)");
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

#[test]
fn hand_computed_optima() {
    // min ½ z² − 3z s.t. z ≤ 1: the unconstrained 3 is cut to 1; 1 − 3 + y = 0, y = 2.
    let qp = Qp { n: 1, p: vec![1.0], q: vec![-3.0], a: vec![1.0], lower: vec![f64::NEG_INFINITY], upper: vec![1.0] };
    let mut s = qp.solver();
    assert_eq!(s.solve(WarmStart::Cold, 10), DenseStatus::Solved);
    assert!((s.solution()[0] - 1.0).abs() < 1e-14 && (s.row_multipliers()[0] - 2.0).abs() < 1e-14);
    assert_eq!(s.active_set(), &[ActiveRow { row: 0, side: Side::Upper }]);
    assert_eq!(s.steps(), 1);

    // min ½‖z‖² s.t. z₁ + z₂ = 2: z = (1, 1); 1 + y = 0, y = −1.
    let qp = Qp {
        n: 2,
        p: vec![1.0, 0.0, 0.0, 1.0],
        q: vec![0.0; 2],
        a: vec![1.0, 1.0],
        lower: vec![2.0],
        upper: vec![2.0],
    };
    let mut s = qp.solver();
    assert_eq!(s.solve(WarmStart::Cold, 10), DenseStatus::Solved);
    assert!((s.solution()[0] - 1.0).abs() < 1e-14 && (s.solution()[1] - 1.0).abs() < 1e-14);
    assert!((s.row_multipliers()[0] + 1.0).abs() < 1e-14);

    // A lower bound with coupling in P: min z₁² + z₁z₂ + z₂² − z₂ (P = [2 1; 1 2], q = (0, −1))
    // s.t. z₁ ≥ 1. On z₁ = 1: ∂/∂z₂ = 1 + 2z₂ − 1 = 0, z₂ = 0; ∂/∂z₁ = 2 + 0 = 2 = −y, y = −2.
    let qp = Qp {
        n: 2,
        p: vec![2.0, 1.0, 1.0, 2.0],
        q: vec![0.0, -1.0],
        a: vec![1.0, 0.0],
        lower: vec![1.0],
        upper: vec![f64::INFINITY],
    };
    let mut s = qp.solver();
    assert_eq!(s.solve(WarmStart::Cold, 10), DenseStatus::Solved);
    assert!((s.solution()[0] - 1.0).abs() < 1e-14 && s.solution()[1].abs() < 1e-14, "{:?}", s.solution());
    assert!((s.row_multipliers()[0] + 2.0).abs() < 1e-13);

    // No rows: the unconstrained minimum −P⁻¹q = −[2 1; 1 2]⁻¹ (3, 0) = −(2, −1).
    let qp = Qp { n: 2, p: vec![2.0, 1.0, 1.0, 2.0], q: vec![3.0, 0.0], a: vec![], lower: vec![], upper: vec![] };
    let mut s = qp.solver();
    assert_eq!(s.solve(WarmStart::Cold, 10), DenseStatus::Solved);
    assert!((s.solution()[0] + 2.0).abs() < 1e-14 && (s.solution()[1] - 1.0).abs() < 1e-14);
    assert_eq!(s.steps(), 0);
}

#[test]
fn infeasible_rows_are_reported_and_bad_data_is_a_status_not_a_panic() {
    let base = Qp {
        n: 2,
        p: vec![1.0, 0.0, 0.0, 1.0],
        q: vec![0.0; 2],
        a: vec![1.0, 1.0, 1.0, 1.0],
        lower: vec![1.0, f64::NEG_INFINITY],
        upper: vec![f64::INFINITY, 0.0],
    };
    // z₁ + z₂ ≥ 1 and z₁ + z₂ ≤ 0, as two rows.
    assert_eq!(base.solver().solve(WarmStart::Cold, 10), DenseStatus::Infeasible);
    // l > u on one row; a zero row whose bounds exclude 0; a lower bound at +∞.
    let crossed = Qp { lower: vec![1.0, 0.5], upper: vec![0.0, 1.0], ..base.clone() };
    assert_eq!(crossed.solver().solve(WarmStart::Cold, 10), DenseStatus::Infeasible);
    let zero_row = Qp { a: vec![0.0, 0.0, 1.0, 0.0], lower: vec![0.5, 0.0], upper: vec![1.0, 1.0], ..base.clone() };
    assert_eq!(zero_row.solver().solve(WarmStart::Cold, 10), DenseStatus::Infeasible);
    let zero_ok = Qp { lower: vec![-1.0, 0.5], ..zero_row.clone() };
    let mut s = zero_ok.solver();
    assert_eq!(s.solve(WarmStart::Cold, 10), DenseStatus::Solved, "a zero row with 0 inside its bounds is no row");
    assert!((s.solution()[0] - 0.5).abs() < 1e-14);
    let at_infinity = Qp { lower: vec![f64::INFINITY, 0.0], upper: vec![f64::INFINITY, 1.0], ..base.clone() };
    assert_eq!(at_infinity.solver().solve(WarmStart::Cold, 10), DenseStatus::Infeasible);

    // NaN or ±∞ where a finite value is needed.
    for (what, corrupt) in [
        ("NaN in q", Box::new(|qp: &mut Qp| qp.q[0] = f64::NAN) as Box<dyn Fn(&mut Qp)>),
        ("∞ in A", Box::new(|qp: &mut Qp| qp.a[1] = f64::INFINITY)),
        ("NaN in A", Box::new(|qp: &mut Qp| qp.a[2] = f64::NAN)),
        ("NaN bound", Box::new(|qp: &mut Qp| qp.lower[0] = f64::NAN)),
    ] {
        let mut qp = Qp { upper: vec![f64::INFINITY, 3.0], ..base.clone() };
        let mut s = qp.solver();
        assert_eq!(s.solve(WarmStart::Cold, 10), DenseStatus::Solved);
        corrupt(&mut qp);
        qp.write(&mut s);
        assert_eq!(s.solve(WarmStart::Previous, 10), DenseStatus::NonFiniteData, "{what}");
        assert!(s.solution().iter().all(|v| v.is_finite()), "{what}");
    }
    // The Hessian: not positive definite, not finite, the wrong size; the old one is kept.
    assert!(DualActiveSet::new(&[1.0, 2.0, 2.0, 1.0], 2, 0).is_err(), "indefinite");
    assert!(DualActiveSet::new(&[1.0, 0.0, 0.0, 0.0], 2, 0).is_err(), "singular");
    assert!(DualActiveSet::new(&[1.0, f64::NAN, 0.0, 1.0], 2, 0).is_err(), "NaN");
    assert!(DualActiveSet::new(&[1.0, 0.0, 1.0], 2, 0).is_err(), "length");
    assert!(DualActiveSet::new(&[], 0, 0).is_err(), "no variables");
    let mut s = DualActiveSet::new(&[2.0], 1, 0).expect("pd");
    assert!(s.set_hessian(&[-1.0]).is_err());
    s.data_mut().q[0] = -4.0;
    assert_eq!(s.solve(WarmStart::Cold, 1), DenseStatus::Solved);
    assert!((s.solution()[0] - 2.0).abs() < 1e-15, "−q/P with the P = 2 kept: {:?}", s.solution());
}

#[test]
fn the_step_budget_stops_a_solve_with_a_finite_flagged_iterate() {
    // min ½‖z − (5, 5, 5)‖² s.t. z_i ≤ i: three rows to add, one step each.
    let qp = Qp {
        n: 3,
        p: vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        q: vec![-5.0; 3],
        a: vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        lower: vec![f64::NEG_INFINITY; 3],
        upper: vec![1.0, 2.0, 3.0],
    };
    let mut s = qp.solver();
    for budget in 1..3 {
        assert_eq!(s.solve(WarmStart::Cold, budget), DenseStatus::MaxSteps);
        assert_eq!(s.steps(), budget);
        assert!(s.solution().iter().all(|v| v.is_finite()));
    }
    assert_eq!(s.solve(WarmStart::Cold, 3), DenseStatus::Solved);
    assert_eq!(s.solution(), &[1.0, 2.0, 3.0]);
    assert_eq!(s.steps(), 3);
    // Warm: nothing left to do.
    assert_eq!(s.solve(WarmStart::Previous, 1), DenseStatus::Solved);
    assert_eq!(s.steps(), 0);
}

/// What a random problem was built with, to check every kind really occurred.
#[derive(Debug, Default)]
struct Kinds {
    equality: usize,
    duplicate: usize,
    zero: usize,
    scaled: usize,
    infeasible: usize,
}

/// A random strictly convex QP of 1–20 variables and 0–60 rows, feasible unless
/// `infeasible` (then a contradiction is planted among its rows).
fn random_qp(rng: &mut ChaCha8Rng, infeasible: bool, kinds: &mut Kinds) -> Qp {
    let n = rng.random_range(1..=20);
    let m = rng.random_range(if infeasible { 3 } else { 0 }..=60);
    let scale = 10f64.powf(rng.random_range(-2.0..2.0));
    let mu = 10f64.powf(rng.random_range(-2.0..0.0));
    let root: Vec<f64> = (0..n * n).map(|_| rng.random_range(-1.0..1.0)).collect();
    let mut p = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            let v: f64 = (0..n).map(|k| root[k * n + i] * root[k * n + j]).sum::<f64>() / n as f64;
            p[i * n + j] = scale * (v + if i == j { mu } else { 0.0 });
        }
    }
    // The unconstrained optimum a few units out, so that rows bind.
    let target: Vec<f64> = (0..n).map(|_| rng.random_range(-4.0..4.0)).collect();
    let q: Vec<f64> = (0..n).map(|i| -(0..n).map(|j| p[i * n + j] * target[j]).sum::<f64>()).collect();
    // A point every row holds at (exactly, for equality rows).
    let feasible: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
    let value = |row: &[f64]| row.iter().zip(&feasible).map(|(a, x)| a * x).sum::<f64>();
    let mut a = Vec::with_capacity(m * n);
    let (mut lower, mut upper) = (Vec::with_capacity(m), Vec::with_capacity(m));
    let mut equalities = 0;
    for i in 0..m {
        let kind = rng.random_range(0..100);
        let mut row: Vec<f64> =
            (0..n).map(|_| if rng.random_bool(0.3) { 0.0 } else { rng.random_range(-1.0..1.0) }).collect();
        if row.iter().all(|&v| v == 0.0) {
            row[rng.random_range(0..n)] = 1.0;
        }
        let (l, u);
        if kind < 10 && i > 0 {
            // An exact copy of an earlier row, bounds and all.
            let j = rng.random_range(0..i);
            row = a[j * n..(j + 1) * n].to_vec();
            (l, u) = (lower[j], upper[j]);
            kinds.duplicate += 1;
        } else if kind < 20 && i > 0 {
            // An earlier row times ±10^k, with bounds of its own around the point.
            let j = rng.random_range(0..i);
            let factor = 10f64.powf(rng.random_range(-3.0..3.0)) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            row = a[j * n..(j + 1) * n].iter().map(|v| v * factor).collect();
            let v = value(&row);
            (l, u) = (v - rng.random_range(0.0..1.0) * factor.abs(), v + rng.random_range(0.0..1.0) * factor.abs());
            kinds.duplicate += 1;
        } else if kind < 28 && equalities < n / 2 {
            let v = value(&row);
            (l, u) = (v, v);
            equalities += 1;
            kinds.equality += 1;
        } else if kind < 33 {
            row.fill(0.0);
            (l, u) = (-rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
            kinds.zero += 1;
        } else {
            let v = value(&row);
            let tight = rng.random_bool(0.1);
            let below = if tight { 0.0 } else { rng.random_range(0.0..1.0) };
            let above = rng.random_range(0.0..1.0);
            let lo = if rng.random_bool(0.25) { f64::NEG_INFINITY } else { v - below };
            let hi = if rng.random_bool(0.25) { 1e30 } else { v + above };
            (l, u) = (lo, hi);
            if kind >= 88 {
                // Huge or tiny: the whole row and its bounds times 10^±8.
                let factor = 10f64.powf(rng.random_range(-8.0..8.0));
                row.iter_mut().for_each(|v| *v *= factor);
                let (lf, uf) = (l * factor, u * factor);
                a.extend_from_slice(&row);
                lower.push(if l.is_finite() { lf } else { l });
                upper.push(if u < 1e30 { uf } else { u });
                kinds.scaled += 1;
                continue;
            }
        }
        a.extend_from_slice(&row);
        lower.push(l);
        upper.push(u);
    }
    if infeasible {
        kinds.infeasible += 1;
        // Overwrite the last rows with a contradiction of one of three shapes.
        let r1: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        let r2: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        let gap = 10f64.powf(rng.random_range(-3.0..0.0));
        let (v1, v2) = (value(&r1), value(&r2));
        let inf = f64::INFINITY;
        let planted: Vec<(Vec<f64>, f64, f64)> = match rng.random_range(0..3) {
            // r₁z ≥ v₁ + gap and r₁z ≤ v₁, as separate rows.
            0 => vec![(r1.clone(), v1 + gap, inf), (r2, -inf, v2 + 1.0), (r1, -inf, v1)],
            // r₁z ≥ v₁, r₂z ≥ v₂, (r₁ + r₂)z ≤ v₁ + v₂ − gap.
            1 => {
                let sum: Vec<f64> = r1.iter().zip(&r2).map(|(a, b)| a + b).collect();
                vec![(r1, v1, inf), (r2, v2, inf), (sum, -inf, v1 + v2 - gap)]
            }
            // Two equality rows on the same normal, gap apart.
            _ => vec![(r1.clone(), v1, v1), (r2, v2 - 1.0, v2 + 1.0), (r1, v1 + gap, v1 + gap)],
        };
        for (k, (row, l, u)) in planted.into_iter().enumerate() {
            let i = m - 3 + k;
            a[i * n..(i + 1) * n].copy_from_slice(&row);
            (lower[i], upper[i]) = (l, u);
        }
    }
    Qp { n, p, q, a, lower, upper }
}

/// Each row with probability `share`, at a random side: a warm start that is mostly wrong.
fn random_hint(rng: &mut ChaCha8Rng, rows: usize, share: f64) -> Vec<ActiveRow> {
    let mut hint = Vec::new();
    for row in 0..rows {
        if rng.random_bool(share) {
            hint.push(ActiveRow { row, side: if rng.random_bool(0.5) { Side::Lower } else { Side::Upper } });
        }
    }
    hint
}

#[test]
fn random_qps_agree_with_clarabel_and_pass_an_independent_kkt_check() {
    let mut kinds = Kinds::default();
    let (mut solved, mut infeasible, mut warm_checked, mut total_steps, mut max_steps) = (0, 0, 0, 0u64, 0);
    // A longer campaign: DUAL_ACTIVE_SET_CASES=100000 (and DUAL_ACTIVE_SET_SEED=<n>).
    let env = |name: &str, default: u64| std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default);
    let mut rng = ChaCha8Rng::seed_from_u64(env("DUAL_ACTIVE_SET_SEED", 14));
    let cases = env("DUAL_ACTIVE_SET_CASES", 2400) as usize;
    let (mut worst_gap, mut unreliable_reference, mut compared, mut clarabel_short) = (0.0f64, 0, 0, 0);
    for case in 0..cases {
        let planted = case % 6 == 5;
        let qp = random_qp(&mut rng, planted, &mut kinds);
        let what = format!("case {case} (n {}, m {})", qp.n, qp.m());
        let mut s = qp.solver();
        let status = s.solve(WarmStart::Cold, 1000);
        total_steps += u64::from(s.steps());
        max_steps = max_steps.max(s.steps());
        let reference = clarabel(&qp);
        if planted {
            // Infeasible by construction; Clarabel must not find a point that meets the
            // rows, and says so itself unless it stops without a verdict.
            assert_eq!(status, DenseStatus::Infeasible, "{what}");
            match &reference {
                Reference::Infeasible => {}
                Reference::Solved(z_ref, _) => {
                    let primal = kkt_residuals(&qp, z_ref, &vec![0.0; qp.m()])[0];
                    assert!(primal > 1e-7, "{what}: Clarabel found a feasible point");
                    unreliable_reference += 1;
                }
                Reference::Other => unreliable_reference += 1,
            }
            // A hint of rows does not change the verdict.
            let hint: Vec<ActiveRow> = random_hint(&mut rng, qp.m(), 0.3);
            assert_eq!(s.solve(WarmStart::Given(&hint), 1000), DenseStatus::Infeasible, "{what}, warm");
            infeasible += 1;
            continue;
        }
        assert_eq!(status, DenseStatus::Solved, "{what}");
        assert_kkt(&qp, &s, &what);
        let z = s.solution().to_vec();
        let z_ref = match reference {
            Reference::Solved(z_ref, tight) => Some((z_ref, tight)),
            // The rows hold at a known point; on a draw whose feasible set is a sliver
            // (equality and tight rows through that point) Clarabel can still say this.
            Reference::Infeasible | Reference::Other => None,
        };
        // Clarabel is the reference only where its own point meets the rows to the same
        // tolerance as ours: on a nearly degenerate draw (a sliver of a feasible set,
        // which Clarabel may even call infeasible at tight tolerances) a point 1e-8 outside
        // can be far from the optimum and cheaper than it.
        let reliable = z_ref.filter(|(z_ref, _)| kkt_residuals(&qp, z_ref, &vec![0.0; qp.m()])[0] <= KKT_TOLERANCE);
        if let Some((z_ref, tight)) = reliable {
            // No point costs less than the optimum, but what its violations buy at the
            // optimum's multipliers (convexity: f(z) ≥ f(z*) − Σ |y_i| violation_i(z)).
            let (ours, theirs) = (qp.objective(&z), qp.objective(&z_ref));
            let bought: f64 = (0..qp.m())
                .map(|i| {
                    let v: f64 = qp.row(i).iter().zip(&z_ref).map(|(a, z)| a * z).sum();
                    s.row_multipliers()[i].abs() * (qp.lower[i] - v).max(v - qp.upper[i]).max(0.0)
                })
                .sum();
            let rounding = 1e-9 * (1.0 + theirs.abs());
            assert!(
                ours <= theirs + bought + rounding,
                "{what}: objective {ours} above Clarabel's {theirs} (+{bought:.1e})"
            );
            // At its default tolerances Clarabel's point is only near the optimum (its gap
            // is 1e-8): z is compared where it met the tight ones.
            if tight {
                let scale = 1.0 + max_abs(&z_ref);
                let gap = z.iter().zip(&z_ref).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                if gap <= 1e-6 * scale {
                    worst_gap = worst_gap.max(gap / scale);
                } else {
                    // Then Clarabel stopped short (its gap tolerance allows 1e-5 along a
                    // flat direction of P): from our point its point lies uphill, the
                    // first-order optimality of ours, `∇f(z)ᵀ(z_ref − z) ≥ 0`, up to what
                    // Clarabel's violations buy and rounding.
                    let (mut slope, mut size) = (0.0, 0.0);
                    for i in 0..qp.n {
                        let grad = qp.q[i] + (0..qp.n).map(|j| qp.p[i * qp.n + j] * z[j]).sum::<f64>();
                        slope += grad * (z_ref[i] - z[i]);
                        size += (grad * (z_ref[i] - z[i])).abs();
                    }
                    assert!(
                        slope >= -(bought + 1e-9 * size),
                        "{what}: z differs from Clarabel's by {gap:.2e} (scale {scale:.2e}), and its point is downhill"
                    );
                    assert!(theirs >= ours - rounding, "{what}: Clarabel's point costs less than ours");
                    clarabel_short += 1;
                }
                compared += 1;
            }
        } else {
            unreliable_reference += 1;
        }
        solved += 1;

        // Warm starts: the next problem (q nudged) from this one's active set, and from a
        // random hint, against a cold solve of it.
        let active = s.active_set().to_vec();
        let mut next = qp.clone();
        next.q.iter_mut().for_each(|v| *v += rng.random_range(-0.05..0.05) * (1.0 + v.abs()));
        next.write(&mut s);
        assert_eq!(s.solve(WarmStart::Cold, 1000), DenseStatus::Solved, "{what}, nudged cold");
        let cold = s.solution().to_vec();
        let hint: Vec<ActiveRow> = random_hint(&mut rng, qp.m(), 0.2);
        for (start, name) in [(WarmStart::Given(&active), "previous active set"), (WarmStart::Given(&hint), "hint")] {
            assert_eq!(s.solve(start, 1000), DenseStatus::Solved, "{what}, warm from the {name}");
            assert_kkt(&next, &s, &what);
            let scale = 1.0 + max_abs(&cold);
            let gap = s.solution().iter().zip(&cold).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(gap <= 1e-8 * scale, "{what}: warm from the {name} differs from cold by {gap:.2e}");
        }
        warm_checked += 1;
    }
    println!(
        "{solved} solved, {infeasible} infeasible, {warm_checked} warm-start pairs; steps mean {:.1}, max {max_steps}; \
         z compared with Clarabel on {compared}, largest gap {worst_gap:.1e} of the scale, {clarabel_short} \
         where Clarabel stopped at a costlier point ({unreliable_reference} draws where Clarabel reached no \
         usable verdict or point); {kinds:?}",
        total_steps as f64 / cases as f64
    );
    assert_eq!(solved + infeasible, cases);
    assert!(unreliable_reference * 200 <= cases, "{unreliable_reference} draws without a usable reference");
    assert!(compared * 10 >= solved * 9, "z compared on only {compared} of {solved}");
    assert!(clarabel_short * 200 <= compared, "Clarabel short of the optimum on {clarabel_short} of {compared}");
    assert!(infeasible >= cases / 8 && kinds.equality >= cases && kinds.duplicate >= 2 * cases, "{kinds:?}");
    assert!(kinds.zero >= cases && kinds.scaled >= 2 * cases, "{kinds:?}");
}

#[test]
fn no_solve_works_more_than_its_stated_worst_case() {
    // Random problems (feasible and infeasible, equality, duplicate, zero and badly scaled
    // rows), cold and from random warm starts, with budgets from 1 row to plenty: the work
    // each solve counted as it ran never passes the worst case stated for its size and
    // budget. The largest share of it any solve used is printed: how loose the bound is.
    let mut kinds = Kinds::default();
    let mut rng = ChaCha8Rng::seed_from_u64(62);
    let (mut solves, mut tightest) = (0, 0.0f64);
    for case in 0..1500 {
        let qp = random_qp(&mut rng, case % 5 == 4, &mut kinds);
        let mut s = qp.solver();
        for budget in [1, 2, 5, 1000] {
            for start in 0..3 {
                let hint = random_hint(&mut rng, qp.m(), 0.4);
                let warm = match start {
                    0 => WarmStart::Cold,
                    1 => WarmStart::Previous,
                    _ => WarmStart::Given(&hint),
                };
                s.solve(warm, budget);
                let bound = DualActiveSet::worst_case_work(qp.n, qp.m(), budget);
                assert!(s.work() > 0 && s.work() <= bound, "case {case}, budget {budget}: {} > {bound}", s.work());
                tightest = tightest.max(s.work() as f64 / bound as f64);
                solves += 1;
            }
        }
    }
    assert!(kinds.equality > 0 && kinds.infeasible > 0 && kinds.zero > 0, "{kinds:?}");
    println!("{solves} solves; the most work any took: {:.1} % of its worst case", 100.0 * tightest);
}

#[test]
fn a_work_budget_stops_a_solve_within_its_stated_overshoot_and_a_warm_start_goes_on() {
    // Random problems under random work budgets: a solve stopped for work has reached its
    // budget, no solve passes its budget by more than the stated overshoot, and solving
    // again from where a budgeted solve stopped reaches the unbudgeted solve's answer.
    let mut kinds = Kinds::default();
    let mut rng = ChaCha8Rng::seed_from_u64(63);
    let (mut stopped, mut largest_share) = (0, 0.0f64);
    for case in 0..1500 {
        let qp = random_qp(&mut rng, case % 5 == 4, &mut kinds);
        let mut free = qp.solver();
        let status = free.solve(WarmStart::Cold, 1000);
        let (unbudgeted, full_work) = (free.solution().to_vec(), free.work());
        let overshoot = DualActiveSet::work_overshoot(qp.n, qp.m());
        let mut s = qp.solver();
        let max_work = rng.random_range(1..=full_work.max(1));
        let mut budgeted = s.solve_within(WarmStart::Cold, 1000, max_work);
        assert!(s.work() <= max_work + overshoot, "case {case}: {} > {max_work} + {overshoot}", s.work());
        largest_share = largest_share.max((s.work().saturating_sub(max_work)) as f64 / overshoot as f64);
        if budgeted == DenseStatus::MaxWork {
            stopped += 1;
            assert!(s.work() >= max_work, "case {case}: stopped at {} before its budget {max_work}", s.work());
            assert!(s.solution().iter().all(|v| v.is_finite()));
            // Solved again from where each stopped (a budget below one pass of the set-up
            // and search makes no progress, so a solve that added nothing gets twice the
            // budget), the budgeted solves end where the unbudgeted one did.
            let mut budget = max_work;
            for _ in 0..200 {
                let reached = s.active_set().to_vec();
                budgeted = s.solve_within(WarmStart::Given(&reached), 1000, budget);
                if budgeted != DenseStatus::MaxWork {
                    break;
                }
                if s.rows_added() == 0 {
                    budget *= 2;
                }
            }
        }
        assert_eq!(budgeted, status, "case {case}");
        if status == DenseStatus::Solved {
            for (a, b) in s.solution().iter().zip(&unbudgeted) {
                assert!((a - b).abs() <= 1e-7 * (1.0 + b.abs()), "case {case}: {a} against {b}");
            }
        }
    }
    assert!(stopped > 300 && kinds.infeasible > 0, "{stopped} stopped; {kinds:?}");
    println!(
        "{stopped} solves stopped for work; the most past its budget: {:.1} % of the overshoot",
        100.0 * largest_share
    );
}
