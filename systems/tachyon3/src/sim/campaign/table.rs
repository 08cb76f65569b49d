//! The campaign as `episodes.csv` holds it: one [`EpisodeRow`] per episode, written at
//! full precision (every number reads back to the same `f64`), so that shards run apart
//! merge into the file and report one run would have written.
//!
//! The report and the figures are computed from rows, both for a campaign just run and
//! for shards read back: one path for both, so a merge cannot drift from a single run.
//!
//! ```
//! use cbfgen_tachyon3::sim::campaign::{self, table, CampaignSettings};
//!
//! let settings = CampaignSettings { episodes: 4, ..CampaignSettings::default() };
//! // Two shards, as two array jobs of a batch scheduler would run them.
//! let mut texts = Vec::new();
//! for shard in 0..2 {
//!     let part = campaign::run(&settings.shard(shard, 2)?, |_| {})?;
//!     texts.push(table::csv(&part.rows()));
//! }
//! let merged = table::merge(&texts)?;
//! assert_eq!(merged.iter().map(|r| r.id).collect::<Vec<_>>(), [0, 1, 2, 3]);
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

use std::fmt::Write as _;

use super::{EpisodeRecord, Outcome};
use crate::catalog::{Family, FAMILY_COUNT};
use crate::sim::Approach;
use cbfgen::error::CbfError;

/// A closest approach as the CSV holds it: signed distance \[m\], where (`RR step 2
/// riser`) and when \[s\].
#[derive(Debug, Clone, PartialEq)]
pub struct Nearest {
    /// Signed distance \[m\]: the gap, or minus the depth.
    pub distance: f64,
    /// Part, solid and face, as [`Contact::place`](crate::terrain::solid::Contact::place).
    pub place: String,
    /// Time \[s\] (NaN where the CSV has none: the riser column keeps no time).
    pub t: f64,
}

impl Nearest {
    fn of(approach: Option<Approach>) -> Option<Self> {
        approach.map(|a| Self { distance: a.contact.distance, place: a.contact.place(), t: a.t })
    }
}

/// What a run that ended without an error established, as the CSV holds it.
#[derive(Debug, Clone, PartialEq)]
pub struct RowSummary {
    /// Simulated time \[s\].
    pub duration: f64,
    /// The body's closest approach to the solid terrain.
    pub body_nearest: Option<Nearest>,
    /// The wheels' closest approach to the solid terrain.
    pub toe_nearest: Option<Nearest>,
    /// The wheels' closest approach to a riser (no time).
    pub toe_riser_nearest: Option<Nearest>,
    /// Cycles with a wheel touching or in a riser.
    pub riser_contact_cycles: usize,
    /// Smallest `h` per family ([`Family::index`] order), `+∞` where no row applied.
    pub min_h: [f64; FAMILY_COUNT],
    /// Filter update, thread CPU time: median, 99th percentile, largest \[µs\].
    pub cpu_us: [f64; 3],
    /// Filter update, wall time: median, 99th percentile, largest \[µs\].
    pub wall_us: [f64; 3],
    /// Updates over the 1 ms period in CPU time.
    pub over_1ms_cpu: usize,
    /// Updates over the 1 ms period in wall time.
    pub over_1ms_wall: usize,
    /// Filter updates.
    pub cycles: usize,
    /// Updates whose input was not a verified QP optimum.
    pub fallback_cycles: usize,
    /// Per family: updates with rows of it relaxed.
    pub relaxed_cycles: [usize; FAMILY_COUNT],
    /// Fine steps per period at which clearances and `h` were measured (0: at the
    /// samples only, the Euler plant; see [`Plant`](crate::sim::Plant)).
    pub fine_steps: usize,
    /// Updates certified between the samples; `None` with the certificate off.
    pub certified_cycles: Option<usize>,
    /// The most dense-solver trips an update took.
    pub max_dense_trips: u64,
    /// Updates whose counted work went beyond the filter's stated worst case.
    pub beyond_worst_case: usize,
    /// Updates whose CPU time went beyond the campaign's time bound (0 without one).
    pub beyond_time_bound: usize,
}

impl RowSummary {
    /// The body's smallest clearance to the solid terrain \[m\] (`+∞` without one).
    pub fn min_body_clearance(&self) -> f64 {
        self.body_nearest.as_ref().map_or(f64::INFINITY, |n| n.distance)
    }

    /// The wheels' smallest clearance to the solid terrain \[m\] (`+∞` without one).
    pub fn min_toe_clearance(&self) -> f64 {
        self.toe_nearest.as_ref().map_or(f64::INFINITY, |n| n.distance)
    }

    /// The wheels' smallest clearance to a riser \[m\] (`+∞` where none faced one).
    pub fn min_toe_riser_clearance(&self) -> f64 {
        self.toe_riser_nearest.as_ref().map_or(f64::INFINITY, |n| n.distance)
    }
}

/// One episode, one line of `episodes.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeRow {
    /// Episode id.
    pub id: u64,
    /// Campaign seed.
    pub seed: u64,
    /// Step rise \[m\].
    pub rise: f64,
    /// Tread run \[m\].
    pub run: f64,
    /// Number of steps.
    pub steps: usize,
    /// Start gap \[m\].
    pub start_gap: f64,
    /// Gait speed \[m/s\].
    pub speed: f64,
    /// How it ended.
    pub outcome: Outcome,
    /// What it established, or the error message that ended it.
    pub result: Result<RowSummary, String>,
}

impl EpisodeRow {
    /// The row of a record just run.
    pub fn of(record: &EpisodeRecord) -> Self {
        let e = &record.episode;
        let result = record.result.as_ref().map_err(Clone::clone).map(|s| RowSummary {
            duration: s.duration,
            body_nearest: Nearest::of(s.body_nearest),
            toe_nearest: Nearest::of(s.toe_nearest),
            // The CSV keeps where a wheel came closest to a riser, not when.
            toe_riser_nearest: Nearest::of(s.toe_riser_nearest).map(|n| Nearest { t: f64::NAN, ..n }),
            riser_contact_cycles: s.riser_contact_cycles,
            min_h: s.min_h,
            cpu_us: [s.median_cpu_us, s.p99_cpu_us, s.max_cpu_us],
            wall_us: [s.median_update_us, s.p99_update_us, s.max_update_us],
            over_1ms_cpu: s.over_period_cpu,
            over_1ms_wall: s.over_period_wall,
            beyond_time_bound: s.over_time_bound,
            max_dense_trips: s.max_work.dense_trips,
            beyond_worst_case: s.over_worst_case,
            cycles: s.cycles,
            fallback_cycles: s.fallback_cycles,
            relaxed_cycles: s.relaxed_cycles,
            fine_steps: s.plant.fine_steps(),
            certified_cycles: s.certified_cycles,
        });
        Self {
            id: e.id,
            seed: e.seed,
            rise: e.stairs.rise,
            run: e.stairs.run,
            steps: e.stairs.count,
            start_gap: e.start_gap,
            speed: e.speed,
            outcome: record.outcome(),
            result,
        }
    }

    /// The smallest joint-limit `h` (rad or m), `+∞` without a summary.
    pub fn min_joint_limit_h(&self) -> f64 {
        self.result.as_ref().map_or(f64::INFINITY, |s| s.min_h[Family::JointLimits.index()])
    }
}

/// Columns of `episodes.csv`, in order (documented in [`super::output`]).
pub fn header() -> Vec<String> {
    let mut columns: Vec<String> = [
        "id",
        "seed",
        "rise",
        "run",
        "steps",
        "start_gap",
        "speed",
        "outcome",
        "duration",
        "min_body_clearance",
        "body_nearest",
        "body_nearest_t",
        "min_toe_clearance",
        "toe_nearest",
        "toe_nearest_t",
        "min_toe_riser_clearance",
        "toe_riser_nearest",
        "riser_contact_cycles",
    ]
    .map(String::from)
    .into();
    columns.extend(Family::ALL.iter().map(|f| format!("min_h_{}", f.name())));
    columns.extend(TIMING_COLUMNS.iter().chain(&["cycles", "fallback_cycles"]).map(|c| c.to_string()));
    columns.extend(Family::ALL.iter().map(|f| format!("relaxed_{}", f.name())));
    columns
        .extend(["fine_steps", "certified_cycles", "max_dense_trips", "beyond_worst_case", "error"].map(String::from));
    columns
}

/// Columns that depend on the machine and the moment (timings), not on the episode:
/// two runs of the same episodes agree on every other column.
pub const TIMING_COLUMNS: [&str; 9] = [
    "median_cpu_us",
    "p99_cpu_us",
    "max_cpu_us",
    "median_wall_us",
    "p99_wall_us",
    "max_wall_us",
    "over_1ms_cpu",
    "over_1ms_wall",
    "beyond_time_bound",
];

/// A number as the CSV writes it: the shortest text that reads back to the same `f64`,
/// empty where it is not finite (`+∞`: no such row or contact; NaN: no time).
fn number(v: f64) -> String {
    if !v.is_finite() {
        String::new()
    } else if v == 0.0 || (1e-4..1e15).contains(&v.abs()) {
        format!("{v}")
    } else {
        // Display writes every digit of 1e-17 out; the exponent form reads back the same.
        format!("{v:e}")
    }
}

/// The CSV text of `rows`: a header and one line per row, in the order given.
pub fn csv(rows: &[EpisodeRow]) -> String {
    let mut out = header().join(",");
    out.push('\n');
    for r in rows {
        let _ = write!(
            out,
            "{},{},{},{},{},{},{},{}",
            r.id,
            r.seed,
            number(r.rise),
            number(r.run),
            r.steps,
            number(r.start_gap),
            number(r.speed),
            r.outcome.name()
        );
        match &r.result {
            Ok(s) => {
                let _ = write!(out, ",{}", number(s.duration));
                for n in [&s.body_nearest, &s.toe_nearest] {
                    let (d, place, t) = n.as_ref().map_or((f64::NAN, "", f64::NAN), |n| (n.distance, &n.place, n.t));
                    let _ = write!(out, ",{},{place},{}", number(d), number(t));
                }
                let riser = s.toe_riser_nearest.as_ref().map_or("", |n| n.place.as_str());
                let _ = write!(out, ",{},{riser},{}", number(s.min_toe_riser_clearance()), s.riser_contact_cycles);
                for h in s.min_h {
                    let _ = write!(out, ",{}", number(h));
                }
                for v in s.cpu_us.iter().chain(&s.wall_us) {
                    let _ = write!(out, ",{}", number(*v));
                }
                let counts = [s.over_1ms_cpu, s.over_1ms_wall, s.beyond_time_bound, s.cycles, s.fallback_cycles];
                for n in counts.iter().chain(&s.relaxed_cycles).chain(&[s.fine_steps]) {
                    let _ = write!(out, ",{n}");
                }
                let certified = s.certified_cycles.map_or(String::new(), |n| n.to_string());
                let _ = writeln!(out, ",{certified},{},{},", s.max_dense_trips, s.beyond_worst_case);
            }
            Err(message) => {
                out.push_str(&",".repeat(header().len() - 9));
                let _ = writeln!(out, ",\"{}\"", message.replace('"', "\"\""));
            }
        }
    }
    out
}

/// A parse error at `line` (1-based, the header is line 1).
fn bad(line: usize, why: String) -> CbfError {
    CbfError::Malformed { what: "campaign CSV", why: format!("line {line}: {why}") }
}

/// `[f(0), f(1), ...]`, or the first error.
fn array<T: Copy + Default, const N: usize>(f: impl Fn(usize) -> Result<T, CbfError>) -> Result<[T; N], CbfError> {
    let mut out = [T::default(); N];
    for (j, slot) in out.iter_mut().enumerate() {
        *slot = f(j)?;
    }
    Ok(out)
}

/// Split one CSV line into fields; only the last (`error`) may be quoted, with `""` for
/// a quote inside.
fn fields(line: &str, columns: usize, at: usize) -> Result<Vec<String>, CbfError> {
    let (plain, quoted) = match line.find('"') {
        Some(q) => {
            let tail = &line[q..];
            if !(tail.len() >= 2 && tail.ends_with('"') && line[..q].ends_with(',')) {
                return Err(bad(at, "only the error column may be quoted".into()));
            }
            (&line[..q - 1], Some(tail[1..tail.len() - 1].replace("\"\"", "\"")))
        }
        None => (line, None),
    };
    let mut out: Vec<String> = plain.split(',').map(String::from).collect();
    if let Some(q) = quoted {
        out.push(q);
    }
    if out.len() != columns {
        return Err(bad(at, format!("{} fields, the header has {columns}", out.len())));
    }
    Ok(out)
}

/// Read `episodes.csv` text back into rows, in the file's order.
///
/// # Errors
/// A header that is not this version's (a CSV of another version of cbfgen, or of
/// another program), or a line that does not parse, with its line number.
pub fn parse(text: &str) -> Result<Vec<EpisodeRow>, CbfError> {
    let mut lines = text.lines();
    let expected = header();
    let found = lines.next().unwrap_or_default();
    if found != expected.join(",") {
        return Err(bad(1, format!("not this version's header (expected `{}`)", expected.join(","))));
    }
    // Every position by its column's name: the header above is the one source of the order.
    let column =
        |name: &str| expected.iter().position(|c| c == name).ok_or_else(|| bad(1, format!("no column `{name}`")));
    let names = |names: &[&str; 4]| array::<usize, 4>(|j| column(names[j]));
    let [id_at, seed_at, rise_at, run_at] = names(&["id", "seed", "rise", "run"])?;
    let [steps_at, gap_at, speed_at, outcome_at] = names(&["steps", "start_gap", "speed", "outcome"])?;
    let [duration_at, riser_cycles_at, cpu_at, wall_at] =
        names(&["duration", "riser_contact_cycles", "median_cpu_us", "median_wall_us"])?;
    let [over_cpu_at, over_wall_at, cycles_at, fallback_at] =
        names(&["over_1ms_cpu", "over_1ms_wall", "cycles", "fallback_cycles"])?;
    let body_at = [column("min_body_clearance")?, column("body_nearest")?, column("body_nearest_t")?];
    let toe_at = [column("min_toe_clearance")?, column("toe_nearest")?, column("toe_nearest_t")?];
    let riser_at = [column("min_toe_riser_clearance")?, column("toe_riser_nearest")?];
    let h_at = column(&format!("min_h_{}", Family::ALL[0].name()))?;
    let relaxed_at = column(&format!("relaxed_{}", Family::ALL[0].name()))?;
    let [fine_at, certified_at, error_at] = [column("fine_steps")?, column("certified_cycles")?, column("error")?];
    let [trips_at, beyond_at, beyond_time_at] =
        [column("max_dense_trips")?, column("beyond_worst_case")?, column("beyond_time_bound")?];
    let mut rows = Vec::new();
    for (k, line) in lines.enumerate().filter(|(_, l)| !l.is_empty()) {
        let at = k + 2;
        let f = fields(line, expected.len(), at)?;
        let real = |i: usize| -> Result<f64, CbfError> {
            f[i].parse::<f64>().map_err(|_| bad(at, format!("`{}` in column {} is not a number", f[i], expected[i])))
        };
        // Empty: not finite (no row or contact: +∞; no time: NaN).
        let maybe = |i: usize, empty: f64| if f[i].is_empty() { Ok(empty) } else { real(i) };
        let whole = |i: usize| -> Result<u64, CbfError> {
            f[i].parse::<u64>().map_err(|_| bad(at, format!("`{}` in column {} is not a count", f[i], expected[i])))
        };
        let count = |i: usize| whole(i).map(|n| n as usize);
        let outcome = match f[outcome_at].as_str() {
            "finished" => Outcome::Finished,
            "not_finished" => Outcome::NotFinished,
            "error" => Outcome::Error,
            other => return Err(bad(at, format!("unknown outcome `{other}`"))),
        };
        // A closest approach from its distance, place and (where kept) time columns.
        let nearest = |distance: usize, place: usize, t: Option<usize>| -> Result<Option<Nearest>, CbfError> {
            if f[place].is_empty() {
                return Ok(None);
            }
            let t = t.map_or(Ok(f64::NAN), |t| maybe(t, f64::NAN))?;
            Ok(Some(Nearest { distance: maybe(distance, f64::INFINITY)?, place: f[place].clone(), t }))
        };
        let result = if outcome == Outcome::Error {
            Err(f[error_at].clone())
        } else {
            Ok(RowSummary {
                duration: maybe(duration_at, f64::NAN)?,
                body_nearest: nearest(body_at[0], body_at[1], Some(body_at[2]))?,
                toe_nearest: nearest(toe_at[0], toe_at[1], Some(toe_at[2]))?,
                toe_riser_nearest: nearest(riser_at[0], riser_at[1], None)?,
                riser_contact_cycles: count(riser_cycles_at)?,
                min_h: array(|j| maybe(h_at + j, f64::INFINITY))?,
                cpu_us: array(|j| real(cpu_at + j))?,
                wall_us: array(|j| real(wall_at + j))?,
                over_1ms_cpu: count(over_cpu_at)?,
                over_1ms_wall: count(over_wall_at)?,
                cycles: count(cycles_at)?,
                fallback_cycles: count(fallback_at)?,
                relaxed_cycles: array(|j| count(relaxed_at + j))?,
                fine_steps: count(fine_at)?,
                certified_cycles: if f[certified_at].is_empty() { None } else { Some(count(certified_at)?) },
                max_dense_trips: whole(trips_at)?,
                beyond_worst_case: count(beyond_at)?,
                beyond_time_bound: count(beyond_time_at)?,
            })
        };
        rows.push(EpisodeRow {
            id: whole(id_at)?,
            seed: whole(seed_at)?,
            rise: real(rise_at)?,
            run: real(run_at)?,
            steps: count(steps_at)?,
            start_gap: real(gap_at)?,
            speed: real(speed_at)?,
            outcome,
            result,
        });
    }
    Ok(rows)
}

/// Shards' CSV texts merged into one campaign's rows, in id order.
///
/// # Errors
/// A text that does not [`parse`], no episode at all, episodes of different seeds, or an
/// id found twice (a shard merged twice, or shards that overlap).
pub fn merge(texts: &[impl AsRef<str>]) -> Result<Vec<EpisodeRow>, CbfError> {
    let mut rows = Vec::new();
    for (k, text) in texts.iter().enumerate() {
        rows.extend(
            parse(text.as_ref())
                .map_err(|e| CbfError::Malformed { what: "campaign shard", why: format!("shard {k}: {e}") })?,
        );
    }
    let Some(first) = rows.first() else {
        return Err(CbfError::Malformed { what: "campaign merge", why: "no episode in any shard".into() });
    };
    if let Some(other) = rows.iter().find(|r| r.seed != first.seed) {
        return Err(CbfError::Malformed {
            what: "campaign merge",
            why: format!("episodes of seeds {} and {} (one campaign per merge)", first.seed, other.seed),
        });
    }
    rows.sort_by_key(|r| r.id);
    if let Some(pair) = rows.windows(2).find(|w| w[0].id == w[1].id) {
        return Err(CbfError::Malformed {
            what: "campaign merge",
            why: format!("episode {} is in two shards", pair[0].id),
        });
    }
    Ok(rows)
}

/// Ids missing between the first and last of `rows` (sorted by id), as `(first, last)`
/// spans: a shard that did not run.
pub fn gaps(rows: &[EpisodeRow]) -> Vec<(u64, u64)> {
    rows.windows(2).filter(|w| w[1].id > w[0].id + 1).map(|w| (w[0].id + 1, w[1].id - 1)).collect()
}
