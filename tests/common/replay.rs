//! The stairs run's recorded QPs (`tests/data/stairs_qps.bin`, written by
//! `cargo run --release --example record_stairs_qps`) replayed through an `EcbfQp` laid out
//! exactly as the Tachyon 3 filter's (same 269 rows, same sparsity, warm start from one
//! problem to the next), and through Clarabel. Shared by the solver tests and the benches
//! (benches include this file by path).
#![allow(dead_code)]
// Index loops mirror the formulas (rows × inputs).
#![allow(clippy::needless_range_loop)]

use cbfgen::filter::{EcbfQp, QpStatus, RowSpec, Solver, SolverSettings};
use cbfgen::qp::recorded::{self, RecordedQp};
use cbfgen::system::{BarrierSet, Gains, Poles, Row};
use cbfgen::systems::tachyon3::catalog::{self, Capacity, Catalog};
use cbfgen::systems::tachyon3::model::NU;
use cbfgen::systems::tachyon3::sim::Course;

#[path = "kkt.rs"]
mod kkt;

/// The committed fixture: 500 problems of the stairs run, every cycle of t = 25.10–25.30 s
/// included.
pub fn stairs_qps() -> Vec<RecordedQp> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/stairs_qps.bin");
    let mut file = std::io::BufReader::new(std::fs::File::open(path).expect("fixture"));
    recorded::read(&mut file).expect("a recorded-QP file")
}

/// An `EcbfQp` over the filter's row layout, whose rows carry a recorded problem's
/// `a` and `b` (a degree-1 row with `h = 0` and `L_f h = b` has ECBF bound `b`).
pub struct Replay {
    pub qp: EcbfQp<NU>,
    rows: Vec<Row<NU>>,
    active: Vec<bool>,
    u_ref: [f64; NU],
}

impl Replay {
    pub fn new(backend: Solver, sample: &RecordedQp) -> Self {
        let catalog = Catalog::new(Course::CAPACITY).expect("catalog");
        assert_eq!(catalog.layout().len(), sample.layout_rows, "the fixture was recorded from this layout");
        // The slack weights the fixture was recorded with (the spec's tiers may have moved
        // since): per family, as the sample's rows carry them; a family without a row in
        // the sample takes the sample's first row's (every family had one weight then).
        let layout = catalog.layout();
        let mut recorded = vec![None; catalog::default_settings().families.len()];
        for r in &sample.rows {
            recorded[layout[r.index].family].get_or_insert(r.weight);
        }
        let fallback = sample.rows.first().map_or(catalog::default_settings().families[0].slack_weight, |r| r.weight);
        let gains = Gains::from_poles(&Poles::from([1e-6]));
        let specs: Vec<RowSpec<'_>> = layout
            .iter()
            .map(|s| RowSpec { columns: s.columns, gains, slack_weight: recorded[s.family].unwrap_or(fallback) })
            .collect();
        let (weights, _, min, max) = sample.inputs::<NU>().expect("17 inputs");
        let solver = SolverSettings { backend, ..SolverSettings::default() };
        let qp = EcbfQp::new(&specs, &weights, &min, &max, solver).expect("qp");
        let m = specs.len();
        Self { qp, rows: vec![Row::ZERO; m], active: vec![false; m], u_ref: [0.0; NU] }
    }

    /// Write `p` into the rows (no allocation).
    pub fn load(&mut self, p: &RecordedQp) {
        self.active.fill(false);
        for r in &p.rows {
            let row = &mut self.rows[r.index];
            row.lie = [0.0, r.b, 0.0, 0.0, 0.0];
            row.lg.copy_from_slice(&r.a);
            self.active[r.index] = true;
        }
        self.u_ref.copy_from_slice(&p.u_ref);
    }

    /// Solve the loaded problem.
    pub fn solve(&mut self) -> QpStatus {
        self.qp.solve(&self.u_ref, &self.rows, &self.active).expect("a finite recorded problem")
    }
}

/// Slack weights must match the layout's: the recording and the replay agree on them.
pub fn assert_weights_match(replay_weights: impl Fn(usize) -> f64, p: &RecordedQp) {
    for r in &p.rows {
        assert_eq!(replay_weights(r.index), r.weight, "row {}", r.index);
    }
}

/// Clarabel on the recorded problem ([`kkt::clarabel_soft_qp`]).
pub fn clarabel(p: &RecordedQp) -> Option<(Vec<f64>, bool)> {
    let rows: Vec<(&[f64], f64, f64)> = p.rows.iter().map(|r| (&r.a[..], r.b, r.weight)).collect();
    kkt::clarabel_soft_qp(&p.weights, &p.u_ref, &p.input_min, &p.input_max, &rows)
}

/// `|u − v|` relative to each input's scale `1 + max(|min|, |max|)`, worst entry.
pub fn input_distance(p: &RecordedQp, u: &[f64], v: &[f64]) -> f64 {
    (0..p.nu())
        .map(|j| (u[j] - v[j]).abs() / (1.0 + p.input_min[j].abs().max(p.input_max[j].abs())))
        .fold(0.0, f64::max)
}

/// Whether `exact` (claimed optimal) agrees with Clarabel's `reference`: within 1e-6 of
/// the input scale, or else provably closer to the optimum than Clarabel. An interior-point
/// answer stops short of the boundary: at its 1e-10 tolerances Clarabel sits up to a few
/// 1e-6 from the optimum on stiff rows. Since `F ≥ F(u*) + w_min |u − u*|²` (the cost is
/// `2 w_min`-strongly convex), a reference whose cost exceeds the exact answer's by `ΔF`
/// lies within `√(ΔF / w_min)` of it; a distance within that bound is Clarabel's shortfall,
/// not a disagreement. Returns the distance (relative to the input scale) and whether it
/// was explained that way.
pub fn agrees_with_clarabel(p: &RecordedQp, exact: &[f64], reference: &[f64]) -> Result<(f64, bool), String> {
    let d = input_distance(p, exact, reference);
    let (mine, theirs) = (p.cost(exact), p.cost(reference));
    if mine > theirs + 1e-12 * (1.0 + theirs) {
        return Err(format!("cost {mine:e} above Clarabel's {theirs:e}"));
    }
    if d <= 1e-6 {
        return Ok((d, false));
    }
    let w_min = p.weights.iter().copied().fold(f64::INFINITY, f64::min);
    // ΔF is a difference of two costs each rounded to ~1e-16 of its size; along a
    // direction where the cost is exactly quadratic the bound is met with equality.
    let gap = (theirs - mine).max(0.0) + 1e-14 * (1.0 + theirs);
    let bound = (gap / w_min).sqrt();
    let absolute = (0..p.nu()).map(|j| (exact[j] - reference[j]).powi(2)).sum::<f64>().sqrt();
    if absolute <= bound * 1.01 {
        Ok((d, true))
    } else {
        Err(format!("|u - u_clarabel| = {d:.2e} of the input scale, beyond Clarabel's shortfall bound {bound:.2e}"))
    }
}

/// An optimality certificate of `u` computed from the problem alone: the KKT conditions
/// of `F(u) = Σ w (u − r)² + Σ s max(0, −(a·u + b))²` over the box, judged in input
/// units. Inputs within 1e-12 of a bound whose gradient pushes outward are held; on the
/// others the Newton step `H⁻¹ ∇F` (with `H = 2W + 2 Σ_{violated} s a aᵀ`) must be below
/// `tolerance · (1 + |u_j| + |r_j|)`, and no held input may be pulled inward by more than
/// rounding. Returns the worst ratio to the tolerance's scale (≤ tolerance passes).
pub fn kkt_step_residual(p: &RecordedQp, u: &[f64]) -> f64 {
    use nalgebra::{DMatrix, DVector};
    let nu = p.nu();
    let mut g: Vec<f64> = (0..nu).map(|j| 2.0 * p.weights[j] * (u[j] - p.u_ref[j])).collect();
    let mut size: Vec<f64> = (0..nu).map(|j| 2.0 * p.weights[j] * (u[j].abs() + p.u_ref[j].abs())).collect();
    let mut h = DMatrix::<f64>::from_diagonal(&DVector::from_iterator(nu, p.weights.iter().map(|w| 2.0 * w)));
    for r in &p.rows {
        let value = r.a.iter().zip(u).map(|(a, x)| a * x).sum::<f64>() + r.b;
        let magnitude = r.b.abs() + r.a.iter().zip(u).map(|(a, x)| (a * x).abs()).sum::<f64>();
        if value < 0.0 {
            for j in 0..nu {
                g[j] += 2.0 * r.weight * value * r.a[j];
                size[j] += 2.0 * r.weight * magnitude * r.a[j].abs();
                for k in 0..nu {
                    h[(j, k)] += 2.0 * r.weight * r.a[j] * r.a[k];
                }
            }
        }
    }
    let mut worst: f64 = 0.0;
    let free: Vec<usize> = (0..nu)
        .filter(|&j| {
            let at_lower = u[j] <= p.input_min[j] + 1e-12 * (1.0 + p.input_min[j].abs());
            let at_upper = u[j] >= p.input_max[j] - 1e-12 * (1.0 + p.input_max[j].abs());
            let rounding = 1e-12 * size[j];
            if (at_lower && g[j] >= -rounding) || (at_upper && g[j] <= rounding) {
                return false; // held, and the bound is the right side
            }
            if at_lower || at_upper {
                // Held in the wrong direction: pulled inward by more than rounding.
                worst = worst.max(g[j].abs() / size[j].max(f64::MIN_POSITIVE));
            }
            true
        })
        .collect();
    if free.is_empty() {
        return worst;
    }
    let hf = DMatrix::from_fn(free.len(), free.len(), |a, b| h[(free[a], free[b])]);
    let gf = DVector::from_iterator(free.len(), free.iter().map(|&j| g[j]));
    let step = hf.cholesky().expect("H is positive definite").solve(&gf);
    for (k, &j) in free.iter().enumerate() {
        worst = worst.max(step[k].abs() / (1.0 + u[j].abs() + p.u_ref[j].abs()));
    }
    worst
}

/// The capacity the stairs run's filter was built with.
pub const CAPACITY: Capacity = Course::CAPACITY;
