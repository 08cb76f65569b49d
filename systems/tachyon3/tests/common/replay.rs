//! The stairs run's recorded QPs (`systems/tachyon3/tests/data/stairs_qps.bin`, written by
//! `cargo run --release --example record_stairs_qps`) replayed through an `EcbfQp` laid out
//! exactly as the Tachyon 3 filter's (same 269 barrier rows and 6 pull rows, off, same sparsity, warm start from one
//! problem to the next), and through Clarabel. Shared by the solver tests and the benches
//! (benches include this file by path).
#![allow(dead_code)]
// Index loops mirror the formulas (rows × inputs).
#![allow(clippy::needless_range_loop)]

use cbfgen::filter::{EcbfQp, QpStatus, RowSpec, Solver, SolverSettings};
use cbfgen::qp::recorded::{self, RecordedQp};
use cbfgen::system::{BarrierSet, Gains, Poles, Row};
use cbfgen_tachyon3::catalog::{self, Capacity, Catalog};
use cbfgen_tachyon3::model::NU;
use cbfgen_tachyon3::sim::Course;

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
    backend: Solver,
    rows: Vec<Row<NU>>,
    active: Vec<bool>,
    u_ref: [f64; NU],
}

impl Replay {
    pub fn new(backend: Solver, sample: &RecordedQp) -> Self {
        let catalog = Catalog::new(Course::CAPACITY).expect("catalog");
        // The fixture was recorded from this layout before the foothold pull's 6 rows were
        // appended to it; they were off then (the stairs never start a toe outside its
        // strip), so the recorded rows keep their indices.
        let layout = catalog.layout();
        assert!(layout.len() >= sample.layout_rows, "the fixture was recorded from this layout");
        let pull = catalog::Family::FootholdPull.index();
        assert!(layout[sample.layout_rows..].iter().all(|r| r.family == pull), "only the pull's rows were added");
        // The priorities the fixture was recorded with (the spec's may have moved since):
        // per family, as the sample's rows carry them, else the family's default.
        let defaults = catalog::default_settings();
        let mut priority: Vec<u8> = defaults.families.iter().map(|f| f.priority).collect();
        for r in &sample.rows {
            priority[layout[r.index].family] = r.tier;
        }
        let gains = Gains::from_poles(&Poles::from([1e-6]));
        let specs: Vec<RowSpec<'_>> =
            layout.iter().map(|s| RowSpec { columns: s.columns, gains, priority: priority[s.family] }).collect();
        let (weights, _, min, max) = sample.inputs::<NU>().expect("17 inputs");
        let solver = SolverSettings { backend, ..SolverSettings::default() };
        let qp = EcbfQp::new(&specs, &weights, &min, &max, solver).expect("qp");
        let m = specs.len();
        Self { qp, backend, rows: vec![Row::ZERO; m], active: vec![false; m], u_ref: [0.0; NU] }
    }

    /// The backend it solves with.
    pub fn backend(&self) -> Solver {
        self.backend
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

/// `|u − v|` relative to each input's scale `1 + max(|min|, |max|)`, worst entry.
pub fn input_distance(p: &RecordedQp, u: &[f64], v: &[f64]) -> f64 {
    (0..p.nu())
        .map(|j| (u[j] - v[j]).abs() / (1.0 + p.input_min[j].abs().max(p.input_max[j].abs())))
        .fold(0.0, f64::max)
}

/// The capacity the stairs run's filter was built with.
pub const CAPACITY: Capacity = Course::CAPACITY;
