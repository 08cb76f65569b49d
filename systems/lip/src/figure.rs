//! Figures of a navigation run: the map (CoM path, footsteps, obstacles, start and goal)
//! and the smallest barrier value per step.

use std::io;
use std::path::{Path, PathBuf};

use super::scenario::RunResult;
use cbfgen_chart::{Area, Chart, Series};

/// The map, to scale: obstacles, the band `δ` around them, CoM path and footsteps.
pub fn navigation_chart(run: &RunResult) -> Chart {
    let delta = run.scenario.params.delta;
    let mut chart = Chart::new(
        &format!(
            "3D-LIP MPC with discrete CBFs: {} steps, goal {}",
            run.steps.len(),
            if run.reached_goal { "reached" } else { "not reached" }
        ),
        "x [m]",
        "y [m]",
    )
    .equal_axes();
    for r in &run.scenario.obstacles {
        // The δ band first, so the obstacle is drawn over it.
        let band = Area {
            min: (r.min[0] - delta, r.min[1] - delta),
            max: (r.max[0] + delta, r.max[1] + delta),
            fill: "#f3d9d9",
        };
        chart = chart.with_area(band);
    }
    for r in &run.scenario.obstacles {
        chart = chart.with_area(Area { min: (r.min[0], r.min[1]), max: (r.max[0], r.max[1]), fill: "#b04040" });
    }
    let path = run.com_path.iter().map(|p| (p[0], p[1])).collect();
    let feet = run.footsteps().map(|f| (f[0], f[1])).collect();
    let start = run.com_path.first().map(|p| vec![(p[0], p[1])]).unwrap_or_default();
    let goal = vec![(run.scenario.goal[0], run.scenario.goal[1])];
    chart
        .with(Series::new("CoM path", "#1f4e9c", path))
        .with(Series::new("footsteps", "#2a8a2a", feet).markers())
        .with(Series::new("start", "black", start).markers())
        .with(Series::new("goal", "#d08000", goal).markers())
}

/// `min_j h_j` after each step, against zero.
pub fn min_h_chart(run: &RunResult) -> Chart {
    let min_h = run
        .steps
        .iter()
        .enumerate()
        .map(|(k, s)| ((k + 1) as f64, s.h.iter().copied().fold(f64::INFINITY, f64::min)))
        .collect();
    let zero = vec![(0.0, 0.0), (run.steps.len().max(1) as f64, 0.0)];
    Chart::new("Smallest barrier value per step", "step", "min_j h_j = ηᵀ(p − c) − δ [m]")
        .with(Series::new("min h", "#1f4e9c", min_h))
        .with(Series::new("h = 0 (CoM at distance δ)", "gray", zero).dashed())
}

/// Write `lip_navigation` and `lip_min_h`, and with a baseline `lip_delta_comparison`,
/// as SVG and PNG, into `dir` (created if missing).
///
/// # Errors
/// The directory or a file cannot be written.
pub fn write_all(dir: &Path, run: &RunResult, baseline: Option<&RunResult>) -> io::Result<Vec<PathBuf>> {
    let mut charts =
        vec![("lip_navigation".to_string(), navigation_chart(run)), ("lip_min_h".to_string(), min_h_chart(run))];
    if let Some(b) = baseline {
        charts.push(("lip_delta_comparison".to_string(), comparison_chart(run, b)));
    }
    cbfgen_chart::write_charts(dir, &charts)
}

/// Two runs of one course on one map, after the report's Figs. 2 and 3: `run` (its `δ`
/// band drawn) and `baseline` (usually `δ = 0`), with every footstep that lands on an
/// obstacle ringed.
pub fn comparison_chart(run: &RunResult, baseline: &RunResult) -> Chart {
    let label = |r: &RunResult| format!("δ = {}", r.scenario.params.delta);
    let mut chart = navigation_chart(run);
    chart.title = format!(
        "Same course, {} vs {}: {} vs {} footsteps on an obstacle",
        label(run),
        label(baseline),
        run.footsteps_on_obstacles().count(),
        baseline.footsteps_on_obstacles().count()
    );
    let path = baseline.com_path.iter().map(|p| (p[0], p[1])).collect();
    let feet = baseline.footsteps().map(|f| (f[0], f[1])).collect();
    let ringed: Vec<_> =
        run.footsteps_on_obstacles().chain(baseline.footsteps_on_obstacles()).map(|f| (f[0], f[1])).collect();
    chart = chart
        .with(Series::new(&format!("CoM path, {}", label(baseline)), "#7a7a7a", path).dashed())
        .with(Series::new(&format!("footsteps, {}", label(baseline)), "#e07020", feet).markers());
    if !ringed.is_empty() {
        chart = chart.with(Series::new("footstep on an obstacle", "#00b0c0", ringed).markers());
    }
    chart
}
