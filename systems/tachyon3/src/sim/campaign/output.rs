//! What a campaign leaves behind: a CSV with one line per episode, figures (minimum
//! clearance and minimum joint-limit `h` against rise and speed, and an outcome map), and
//! the printed report.
//!
//! CSV columns:
//!
//! | column | meaning |
//! |---|---|
//! | `id`, `seed` | the episode, reproducible with `cbfgen simulate --episode ID --seed SEED` |
//! | `rise`, `run`, `steps`, `start_gap`, `speed` | the course \[m\] and the gait speed \[m/s\] |
//! | `outcome` | `finished`, `not_finished` or `error` |
//! | `duration` | simulated time \[s\] |
//! | `min_body_clearance`, `body_nearest`, `body_nearest_t` | the body's smallest exact clearance to the solid terrain (floor and steps as blocks) \[m\], negative = depth into a solid; where (`body step 2 riser`) and when \[s\] |
//! | `min_toe_clearance`, `toe_nearest`, `toe_nearest_t` | the same for the wheels: about 0 for wheels that only stood on treads (`RR floor tread`) |
//! | `min_toe_riser_clearance`, `toe_riser_nearest`, `riser_contact_cycles` | the wheels' smallest clearance to a riser (contact normal over 30° from vertical) \[m\], where, and the cycles with a wheel touching or in a riser |
//! | `min_h_<family>` | smallest `h` of that family's active rows over the run (empty if none) |
//! | `median_cpu_us`, `p99_cpu_us`, `max_cpu_us` | filter update, thread CPU time \[µs\] |
//! | `median_wall_us`, `p99_wall_us`, `max_wall_us` | filter update, wall time \[µs\] |
//! | `over_1ms_cpu`, `over_1ms_wall`, `cycles`, `fallback_cycles` | update counts |
//! | `relaxed_<family>` | updates in which the filter reported rows of that family relaxed |
//! | `fine_steps` | 0: clearances and `h` measured at the samples (the Euler plant); N: the input held over each period, RK4 at 1 ms / N, every clearance and `h` the least over every fine step ([`Plant::Held`](crate::sim::Plant::Held)) |
//! | `certified_cycles` | updates the filter certified between the samples (empty: certificate off) |
//! | `max_dense_trips` | the most dense-solver trips an update took ([`Work`](cbfgen::filter::Work)) |
//! | `beyond_worst_case` | updates whose counted work went beyond the filter's stated worst case ([`EcbfFilter::worst_case`](cbfgen::filter::EcbfFilter::worst_case)): 0, or the bound is wrong |
//! | `beyond_time_bound` | updates whose CPU time went beyond the worst case in time on this machine (0 when not measured) |
//! | `error` | the error message, quoted |
//!
//! Numbers are written at full precision (the shortest text that reads back to the same
//! `f64`), so shards read back with [`table::parse`] and merged give the report and file
//! of the campaign run in one go; an empty number is not finite (no such row or contact).

use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

use super::table::{self, EpisodeRow};
use super::{Campaign, Outcome, Report, Worst, WorstApproach, JOINT_LIMIT_TOLERANCE, PENETRATION_TOLERANCE};
use crate::catalog::Family;
use cbfgen_chart::{Chart, Series};

/// The CSV text of the campaign, one line per episode in id order ([`table::csv`] of its
/// rows).
pub fn csv(campaign: &Campaign) -> String {
    table::csv(&campaign.rows())
}

/// Write `episodes.csv`, `report.txt` and the figures (`campaign_*.svg` and `.png`) into
/// `dir`.
/// Returns the paths written.
///
/// # Errors
/// Any I/O error.
pub fn write_all(dir: &Path, campaign: &Campaign) -> io::Result<Vec<PathBuf>> {
    write_rows(dir, &campaign.rows())
}

/// [`write_all`] for rows: a campaign's, or its shards' [`table::merge`]d (the same files
/// for both).
///
/// # Errors
/// Any I/O error.
pub fn write_rows(dir: &Path, rows: &[EpisodeRow]) -> io::Result<Vec<PathBuf>> {
    let files =
        vec![("episodes.csv".into(), table::csv(rows)), ("report.txt".into(), format!("{}\n", Report::of(rows)))];
    let charts: Vec<(String, Chart)> =
        figures(rows).into_iter().map(|(name, chart)| (format!("campaign_{name}"), chart)).collect();
    let mut written = cbfgen_chart::write_files(dir, files)?;
    written.extend(cbfgen_chart::write_charts(dir, &charts)?);
    Ok(written)
}

const OUTCOME_COLORS: [(Outcome, &str); 3] =
    [(Outcome::Finished, "#2ca02c"), (Outcome::NotFinished, "#ff7f0e"), (Outcome::Error, "#d62728")];

/// Scatter of `y` against `x` over the episodes with a summary, one dot set per outcome.
fn scatter(
    rows: &[EpisodeRow],
    title: &str,
    x_label: &str,
    y_label: &str,
    x: fn(&EpisodeRow) -> f64,
    y: &dyn Fn(&EpisodeRow) -> f64,
    limit: Option<f64>,
) -> Chart {
    let mut chart = Chart::new(title, x_label, y_label);
    for (outcome, color) in OUTCOME_COLORS {
        let points: Vec<_> = rows.iter().filter(|r| r.outcome == outcome).map(|r| (x(r), y(r))).collect();
        if !points.is_empty() {
            chart = chart.with(Series::new(outcome.name(), color, points).markers());
        }
    }
    if let Some(limit) = limit {
        let xs = rows.iter().map(x).filter(|v| v.is_finite());
        let (lo, hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
        if lo <= hi {
            chart = chart.with(Series::new("tolerance", "#555", vec![(lo, limit), (hi, limit)]).dashed());
        }
    }
    chart
}

/// The campaign's figures: minimum clearance (body and toes) and minimum joint-limit `h`
/// against rise and gait speed, and the outcome of each episode over rise and speed.
pub fn figures(rows: &[EpisodeRow]) -> Vec<(&'static str, Chart)> {
    let rise = |r: &EpisodeRow| r.rise;
    let speed = |r: &EpisodeRow| r.speed;
    let clearance = |r: &EpisodeRow| {
        r.result.as_ref().map_or(f64::NAN, |s| s.min_body_clearance().min(s.min_toe_clearance()) * 1e3)
    };
    let joint = |r: &EpisodeRow| r.min_joint_limit_h();
    let tol_mm = -PENETRATION_TOLERANCE * 1e3;
    let clearance_label = "min exact clearance to the solid terrain, body or wheel [mm]";
    let joint_label = "min joint-limit h [rad or m]";
    let mut map = Chart::new("Outcome per episode", "rise [m]", "gait speed [m/s]");
    for (outcome, color) in OUTCOME_COLORS {
        let points: Vec<_> = rows.iter().filter(|r| r.outcome == outcome).map(|r| (rise(r), speed(r))).collect();
        if !points.is_empty() {
            map = map.with(Series::new(outcome.name(), color, points).markers());
        }
    }
    vec![
        (
            "clearance_vs_rise",
            scatter(rows, "Minimum clearance", "rise [m]", clearance_label, rise, &clearance, Some(tol_mm)),
        ),
        (
            "clearance_vs_speed",
            scatter(rows, "Minimum clearance", "gait speed [m/s]", clearance_label, speed, &clearance, Some(tol_mm)),
        ),
        (
            "joint_limits_vs_rise",
            scatter(rows, "Minimum joint-limit h", "rise [m]", joint_label, rise, &joint, Some(-JOINT_LIMIT_TOLERANCE)),
        ),
        (
            "joint_limits_vs_speed",
            scatter(
                rows,
                "Minimum joint-limit h",
                "gait speed [m/s]",
                joint_label,
                speed,
                &joint,
                Some(-JOINT_LIMIT_TOLERANCE),
            ),
        ),
        ("outcome_map", map),
    ]
}

fn worst(w: Worst, scale: f64, unit: &str) -> String {
    w.map_or_else(|| "-".into(), |(id, v)| format!("{:.3} {unit} (episode {id})", v * scale))
}

fn worst_approach(w: &WorstApproach) -> String {
    w.as_ref().map_or_else(
        || "-".into(),
        |(id, n)| {
            let when = if n.t.is_finite() { format!(", t {:.2} s", n.t) } else { String::new() };
            format!("{:+.3} mm, {} (episode {id}{when})", n.distance * 1e3, n.place)
        },
    )
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let pct = |n: usize, of: usize| if of == 0 { 0.0 } else { 100.0 * n as f64 / of as f64 };
        let n = self.episodes;
        writeln!(f, "| episodes | {n} |")?;
        writeln!(f, "|---|---|")?;
        match self.fine_steps {
            0 => writeln!(f, "| clearances and h measured | at the samples (Euler plant) |")?,
            fine => {
                writeln!(f, "| clearances and h measured | at every fine step, RK4 at 1 ms / {fine}, input held |")?
            }
        }
        if self.certified_cycles.1 > 0 {
            let (certified, of) = self.certified_cycles;
            writeln!(
                f,
                "| updates certified between the samples | {certified} of {of} ({:.2} %) |",
                pct(certified, of)
            )?;
        }
        writeln!(f, "| finished | {} ({:.2} %) |", self.finished, pct(self.finished, n))?;
        writeln!(f, "| not finished | {} ({:.2} %) |", self.not_finished.len(), pct(self.not_finished.len(), n))?;
        writeln!(f, "| errors | {} |", self.errors.len())?;
        writeln!(f, "| body more than 1 mm into the solid terrain | {} |", self.body_penetrations)?;
        writeln!(f, "| wheel more than 1 mm into the solid terrain | {} |", self.toe_penetrations)?;
        writeln!(
            f,
            "| wheel touching a riser | {} episodes, {} cycles |",
            self.riser_contacts.0, self.riser_contacts.1
        )?;
        writeln!(f, "| joint-limit h < -1e-4 | {} |", self.joint_limit_violations)?;
        writeln!(f, "| worst body clearance | {} |", worst_approach(&self.worst_body))?;
        writeln!(f, "| deepest wheel (0: on a tread) | {} |", worst_approach(&self.worst_toe))?;
        writeln!(f, "| worst wheel clearance to a riser | {} |", worst_approach(&self.worst_toe_riser))?;
        writeln!(f, "| worst joint-limit h | {} |", worst(self.worst_joint_limit, 1.0, "rad or m"))?;
        writeln!(f, "| worst foothold h (toe outside its strip) | {} |", worst(self.worst_foothold, 1e3, "mm"))?;
        writeln!(f, "| filter updates | {} |", self.cycles)?;
        writeln!(f, "| median update, CPU (median of episodes) | {:.1} µs |", self.median_cpu_us)?;
        writeln!(f, "| worst episode p99, CPU | {} |", worst(self.worst_p99_cpu, 1.0, "µs"))?;
        writeln!(f, "| slowest update, CPU | {} |", worst(self.max_cpu, 1.0, "µs"))?;
        writeln!(f, "| slowest update, wall | {} |", worst(self.max_wall, 1.0, "µs"))?;
        writeln!(
            f,
            "| updates over 1 ms, CPU | {} of {} in {} episodes |",
            self.over_period_cpu.0, self.cycles, self.over_period_cpu.1
        )?;
        writeln!(
            f,
            "| updates over 1 ms, wall | {} of {} in {} episodes |",
            self.over_period_wall.0, self.cycles, self.over_period_wall.1
        )?;
        let trips = self.max_dense_trips.map_or_else(|| "-".to_string(), |(id, n)| format!("{n} (episode {id})"));
        writeln!(f, "| most dense-solver trips in an update | {trips} |")?;
        writeln!(
            f,
            "| updates beyond the stated worst case, counts | {} in {} episodes |",
            self.beyond_worst_case.0, self.beyond_worst_case.1
        )?;
        writeln!(
            f,
            "| updates beyond the worst case in CPU time (when measured) | {} in {} episodes |",
            self.beyond_time_bound.0, self.beyond_time_bound.1
        )?;
        writeln!(f, "| updates not solved to tolerance | {} |", self.fallback_cycles)?;
        write!(f, "| updates with rows relaxed (the filter's verdict), per family |")?;
        for family in Family::ALL {
            let (cycles, episodes) = self.relaxed_cycles[family.index()];
            write!(f, " {} {cycles} in {episodes} episodes;", family.name())?;
        }
        write!(f, " |")?;
        if !self.not_finished.is_empty() {
            let ids: Vec<String> = self.not_finished.iter().take(20).map(u64::to_string).collect();
            let more = if self.not_finished.len() > 20 { ", ..." } else { "" };
            write!(f, "\nnot finished: episodes {}{more}", ids.join(", "))?;
        }
        for (id, e) in self.errors.iter().take(20) {
            write!(f, "\nerror in episode {id}: {e}")?;
        }
        Ok(())
    }
}
