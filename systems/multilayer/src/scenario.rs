//! The example run: the double integrator starts above the moving boundary and is
//! driven to the origin, which the boundary's crests rise above. The three variants
//! differ only in what the MPC knows of the barrier ([`MpcMode`]).

use std::path::{Path, PathBuf};

use super::barrier::{SineBarrier, State};
use super::cbf_qp::CbfQpSettings;
use super::controller::MultiLayerController;
use super::mpc::{MpcMode, MpcSettings};
use cbfgen::error::CbfError;
use cbfgen_chart::{Chart, Series};

/// Everything a run is made of. The paper gives no numbers for its toy example, so
/// every value here is assumed; the shape (start above the boundary, drive to a
/// reference its crests violate) is the paper's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScenarioConfig {
    /// The moving lower bound `s(t) = A sin(ω t) + c`.
    pub barrier: SineBarrier,
    /// Initial state `[q, q̇]` \[m, m/s\].
    pub x0: State,
    /// Simulated time \[s\].
    pub duration: f64,
    /// High-rate period \[s\] (1 kHz).
    pub cycle_dt: f64,
    /// The low-rate MPC's settings; its `dt` must be a whole number of `cycle_dt`.
    pub mpc: MpcSettings,
    /// The high-rate CBF-QP's settings.
    pub qp: CbfQpSettings,
    /// γ of the discrete-time CBF in [`MpcMode::DiscreteCbf`].
    pub gamma: f64,
}

impl Default for ScenarioConfig {
    /// The boundary sin(2t) − 0.5 m crests at 0.5 m, above the MPC's reference q = 0, every
    /// π s; it rises at up to 2 m/s. The system starts at rest 1 m up and runs 10 s
    /// (three crests), the CBF-QP at 1 kHz and the MPC at 20 Hz.
    fn default() -> Self {
        Self {
            barrier: SineBarrier::new(1.0, 2.0, -0.5).expect("finite constants"),
            x0: [1.0, 0.0],
            duration: 10.0,
            cycle_dt: 1e-3,
            mpc: MpcSettings::default(),
            qp: CbfQpSettings::default(),
            gamma: 0.2,
        }
    }
}

impl ScenarioConfig {
    /// The three variants, in the paper's order.
    pub fn modes(&self) -> [MpcMode; 3] {
        [MpcMode::DiscreteCbf { gamma: self.gamma }, MpcMode::StateConstraint, MpcMode::Unconstrained]
    }
}

/// Time series of one run, one entry per control cycle.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trace {
    /// Time at the start of each cycle \[s\].
    pub t: Vec<f64>,
    /// Position `q` at the start of each cycle \[m\].
    pub q: Vec<f64>,
    /// Velocity `q̇` at the start of each cycle \[m/s\].
    pub v: Vec<f64>,
    /// The input applied, an acceleration \[m/s²\].
    pub u: Vec<f64>,
    /// The MPC's acceleration held in each cycle \[m/s²\].
    pub desired_accel: Vec<f64>,
    /// The barrier `h = q − s(t)` at the start of each cycle \[m\].
    pub h: Vec<f64>,
}

/// One variant's run and its figures of merit.
#[derive(Debug, Clone, PartialEq)]
pub struct VariantResult {
    /// What the MPC knew of the barrier in this run.
    pub mode: MpcMode,
    /// The run's time series.
    pub trace: Trace,
    /// max |u| [m/s²] and when.
    pub peak_u: f64,
    /// When `peak_u` first occurred \[s\].
    pub peak_u_time: f64,
    /// min h over the run \[m\], and when.
    pub min_h: f64,
    /// When `min_h` first occurred \[s\].
    pub min_h_time: f64,
}

/// Simulate one variant: the controller at `cycle_dt`, the double integrator integrated
/// exactly for a held input (`q += v dt + u dt²/2`, `v += u dt`).
///
/// # Errors
/// Invalid configuration, or a layer failing (see [`MultiLayerController::control`]).
pub fn run(config: &ScenarioConfig, mode: MpcMode) -> Result<VariantResult, CbfError> {
    let mut controller = MultiLayerController::new(config.barrier, mode, config.mpc, config.qp, config.cycle_dt)?;
    let cycles = (config.duration / config.cycle_dt).round() as usize;
    let mut trace = Trace::default();
    for series in [&mut trace.t, &mut trace.q, &mut trace.v, &mut trace.u, &mut trace.desired_accel, &mut trace.h] {
        series.reserve(cycles);
    }
    let mut x = config.x0;
    for k in 0..cycles {
        let t = k as f64 * config.cycle_dt;
        let out = controller.control(t, &x)?;
        trace.t.push(t);
        trace.q.push(x[0]);
        trace.v.push(x[1]);
        trace.u.push(out.u);
        trace.desired_accel.push(out.desired_accel);
        trace.h.push(out.qp.row.lie[0]);
        let dt = config.cycle_dt;
        x = [x[0] + x[1] * dt + 0.5 * out.u * dt * dt, x[1] + out.u * dt];
    }
    let at = |values: &[f64], better: fn(f64, f64) -> bool| {
        let mut best = 0;
        for (i, &v) in values.iter().enumerate() {
            if better(v, values[best]) {
                best = i;
            }
        }
        (values.get(best).copied().unwrap_or(f64::NAN), trace.t.get(best).copied().unwrap_or(f64::NAN))
    };
    let abs_u: Vec<f64> = trace.u.iter().map(|u| u.abs()).collect();
    let (peak_u, peak_u_time) = at(&abs_u, |a, b| a > b);
    let (min_h, min_h_time) = at(&trace.h, |a, b| a < b);
    Ok(VariantResult { mode, trace, peak_u, peak_u_time, min_h, min_h_time })
}

/// All three variants, in [`ScenarioConfig::modes`] order.
///
/// # Errors
/// As [`run`].
pub fn run_all(config: &ScenarioConfig) -> Result<Vec<VariantResult>, CbfError> {
    config.modes().into_iter().map(|mode| run(config, mode)).collect()
}

/// The comparison table (plain text, one row per variant).
pub fn table(results: &[VariantResult]) -> String {
    let mut s =
        format!("{:<34} {:>10} {:>12} {:>12} {:>12}\n", "variant", "peak |u|", "at t [s]", "min h [m]", "at t [s]");
    for r in results {
        s += &format!(
            "{:<34} {:>10.3} {:>12.3} {:>12.5} {:>12.3}\n",
            r.mode.name(),
            r.peak_u,
            r.peak_u_time,
            r.min_h,
            r.min_h_time
        );
    }
    s
}

const COLORS: [&str; 3] = ["#1f77b4", "#d62728", "#2ca02c"];

/// The paper's Fig. 3 as two SVGs in `dir`: positions against the boundary, and inputs.
///
/// # Errors
/// The directory or a file cannot be written.
pub fn write_figures(dir: &Path, config: &ScenarioConfig, results: &[VariantResult]) -> std::io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(cbfgen_chart::at(dir))?;
    let series = |r: &VariantResult, i: usize, values: &[f64]| {
        Series::new(
            r.mode.name(),
            COLORS[i % COLORS.len()],
            r.trace.t.iter().copied().zip(values.iter().copied()).collect(),
        )
    };
    let mut positions = Chart::new("Position and the moving boundary", "t [s]", "q [m]");
    let mut inputs = Chart::new("Input", "t [s]", "u [m/s²]");
    for (i, r) in results.iter().enumerate() {
        positions = positions.with(series(r, i, &r.trace.q));
        inputs = inputs.with(series(r, i, &r.trace.u));
    }
    let t = results.first().map(|r| r.trace.t.clone()).unwrap_or_default();
    let boundary = t.iter().map(|&t| (t, config.barrier.boundary(t))).collect();
    positions = positions.with(Series::new("boundary A sin(ωt) + c", "black", boundary).dashed());
    cbfgen_chart::write_charts(
        dir,
        &[("multilayer_positions".to_string(), positions), ("multilayer_inputs".to_string(), inputs)],
    )
}
