//! The arm run's CSV and figures: exact separation of the checked pairs over time, joint
//! angles against their limits, and the rows in the QP.

use std::fmt::Write as _;
use std::io;
use std::path::{Path, PathBuf};

use super::scenario::{Run, Sample, FAMILY_NAMES, JOINTS};
use crate::generated as gen;
use cbfgen_chart::{Chart, Series};

const COLORS: [&str; 10] =
    ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];

/// One row per `every`-th cycle: time, q, q̇, the PD's and the applied input, the
/// smallest `h` and the active rows of each family, and every checked pair's exact SAT
/// separation \[m\].
pub fn csv(run: &Run, every: usize) -> String {
    let mut out = String::from("t");
    for prefix in ["q", "qd", "u_ref", "u"] {
        for j in 1..=JOINTS {
            let _ = write!(out, ",{prefix}{j}");
        }
    }
    for f in FAMILY_NAMES {
        let _ = write!(out, ",min_h_{f}");
    }
    for f in FAMILY_NAMES {
        let _ = write!(out, ",active_{f}");
    }
    for p in run.scenario.pair_names() {
        let _ = write!(out, ",sep_{}", p.replace('/', "_"));
    }
    out.push_str(",source,cpu_us\n");
    for s in run.samples.iter().step_by(every.max(1)) {
        let _ = write!(out, "{:.3}", s.t);
        for v in s.x.iter().chain(&s.u_ref).chain(&s.u).chain(&s.min_h) {
            let _ = write!(out, ",{v:.6}");
        }
        for a in s.active {
            let _ = write!(out, ",{a}");
        }
        for d in &s.separation {
            let _ = write!(out, ",{d:.6}");
        }
        let source = s.source.map_or("none", |src| src.name());
        let _ = writeln!(out, ",{source},{:.1}", s.cpu_time.as_secs_f64() * 1e6);
    }
    out
}

fn series(samples: &[Sample], f: impl Fn(&Sample) -> f64) -> Vec<(f64, f64)> {
    samples.iter().step_by(10).map(|s| (s.t, f(s))).collect()
}

fn min_over(s: &Sample, range: std::ops::Range<usize>) -> f64 {
    s.separation[range].iter().copied().fold(f64::INFINITY, f64::min)
}

/// Each obstacle's smallest separation over the link boxes, and the smallest over the
/// self-collision pairs: with the filter solid, without dashed.
pub fn clearance_chart(with: &Run, without: Option<&Run>) -> Chart {
    let links = gen::OBSTACLE_LINKS.len();
    let mut chart = Chart::new(
        "Arm: exact SAT separation of the checked box pairs (dashed: without the filter)",
        "t [s]",
        "smallest separation [m] (< 0: overlap)",
    );
    let obstacles = with.scenario.obstacles.len();
    let mut groups: Vec<(String, std::ops::Range<usize>)> =
        with.scenario.obstacles.iter().enumerate().map(|(k, o)| (o.name.clone(), k * links..(k + 1) * links)).collect();
    groups.push(("self-collision".into(), obstacles * links..obstacles * links + gen::SELF_PAIRS.len()));
    for (k, (name, range)) in groups.iter().enumerate() {
        let color = COLORS[k % COLORS.len()];
        chart = chart.with(Series::new(
            &format!("links vs {name}"),
            color,
            series(&with.samples, |s| min_over(s, range.clone())),
        ));
        if let Some(run) = without {
            chart = chart.with(
                Series::new(&format!("{name}, no filter"), color, series(&run.samples, |s| min_over(s, range.clone())))
                    .dashed(),
            );
        }
    }
    let end = with.samples.last().map_or(0.0, |s| s.t);
    chart.with(Series::new("overlap", "black", vec![(0.0, 0.0), (end, 0.0)]).dashed())
}

/// Every self-collision pair's separation with the filter.
pub fn self_pairs_chart(run: &Run) -> Chart {
    let first = run.scenario.obstacles.len() * gen::OBSTACLE_LINKS.len();
    let names = run.scenario.pair_names();
    let mut chart = Chart::new("Arm: self-collision pairs, exact SAT separation", "t [s]", "separation [m]");
    for (k, name) in names[first..].iter().enumerate() {
        chart =
            chart.with(Series::new(name, COLORS[k % COLORS.len()], series(&run.samples, |s| s.separation[first + k])));
    }
    chart
}

/// Joint angles as a fraction of their range: 0 and 1 are the limits (dashed: without
/// the filter).
pub fn joints_chart(with: &Run, without: Option<&Run>) -> Chart {
    let mut chart = Chart::new(
        "Arm: joint angles within their limits (dashed: without the filter)",
        "t [s]",
        "(q - q_min) / (q_max - q_min)",
    );
    let frac = |s: &Sample, j: usize| (s.x[j] - gen::Q_MIN[j]) / (gen::Q_MAX[j] - gen::Q_MIN[j]);
    for (j, &color) in COLORS.iter().enumerate().take(JOINTS) {
        chart = chart.with(Series::new(&format!("q{}", j + 1), color, series(&with.samples, |s| frac(s, j))));
        if let Some(run) = without {
            chart = chart.with(
                Series::new(&format!("q{}, no filter", j + 1), color, series(&run.samples, |s| frac(s, j))).dashed(),
            );
        }
    }
    let end = with.samples.last().map_or(0.0, |s| s.t);
    chart
        .with(Series::new("limits", "black", vec![(0.0, 0.0), (end, 0.0)]).dashed())
        .with(Series::new("", "black", vec![(0.0, 1.0), (end, 1.0)]).dashed())
}

/// Rows of each family in the QP.
pub fn active_rows_chart(run: &Run) -> Chart {
    let mut chart = Chart::new("Arm: rows in the QP per family", "t [s]", "active rows");
    for (k, name) in FAMILY_NAMES.iter().enumerate() {
        chart = chart.with(Series::new(name, COLORS[k], series(&run.samples, |s| s.active[k] as f64)));
    }
    chart
}

/// Write `arm.csv` (and `arm_no_filter.csv`) and the four figures into `dir`.
///
/// # Errors
/// The directory or a file cannot be written.
pub fn write_all(dir: &Path, with: &Run, without: Option<&Run>, every: usize) -> io::Result<Vec<PathBuf>> {
    let mut files = vec![("arm.csv".to_string(), csv(with, every))];
    if let Some(run) = without {
        files.push(("arm_no_filter.csv".into(), csv(run, every)));
    }
    let charts = [
        ("arm_clearance", clearance_chart(with, without)),
        ("arm_self_pairs", self_pairs_chart(with)),
        ("arm_joints", joints_chart(with, without)),
        ("arm_active_rows", active_rows_chart(with)),
    ]
    .map(|(name, chart)| (name.to_string(), chart));
    let mut written = cbfgen_chart::write_files(dir, files)?;
    written.extend(cbfgen_chart::write_charts(dir, &charts)?);
    Ok(written)
}
