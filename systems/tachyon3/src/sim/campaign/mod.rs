//! Monte Carlo safety campaign: many randomised staircases climbed in closed loop, in
//! parallel, each episode reproducible from `(seed, id)` alone.
//!
//! An [`Episode`] draws its course (rise, run, number of steps, start gap) and gait speed
//! from [`CourseRanges`] with a ChaCha8 generator keyed by the campaign seed and the
//! episode id, so episode 1234 of seed 7 is the same course whether it is run among ten
//! thousand others, alone (`cbfgen simulate --episode 1234 --seed 7`) or from Python.
//! [`run`] climbs every episode with [`sim::run`](super::run) on a rayon pool and keeps
//! one [`EpisodeRecord`] each (the run's [`Summary`], not its samples); [`Report`] counts
//! what the campaign established and names the worst episode of each kind.
//!
//! ```no_run
//! use cbfgen_tachyon3::sim::campaign::{self, CampaignSettings};
//!
//! let settings = CampaignSettings { episodes: 20, ..CampaignSettings::default() };
//! let campaign = campaign::run(&settings, |_done| {})?;
//! let report = campaign.report();
//! assert!(report.errors.is_empty());
//! println!("{report}");
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

pub mod output;
pub mod table;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicUsize, Ordering};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::{Plant, Scenario, SimConfig, Summary};
use crate::catalog::{Family, FAMILY_COUNT};
use crate::sim::perceived::PerceptionSettings;
use crate::terrain::Stairs;
use cbfgen::error::CbfError;
use table::{EpisodeRow, Nearest};

/// Penetration counted as a collision \[m\]: the body or a wheel more than 1 mm into a
/// solid of the terrain, by exact geometry.
pub use crate::terrain::solid::PENETRATION_TOLERANCE;
/// A joint-limit row below `−1e-4` (rad or m) counts as a violated joint limit.
pub const JOINT_LIMIT_TOLERANCE: f64 = 1e-4;
/// Most episodes one campaign runs: each keeps its record (under 0.5 KB) until the
/// report, so a campaign's memory stays under 0.5 GB (and 10⁶ episodes are some 75 hours
/// of two cores).
pub const MAX_EPISODES: usize = 1_000_000;
/// Most worker threads a campaign starts (each episode holds its samples, some 100 MB
/// for the longest, while it runs).
pub const MAX_THREADS: usize = 1024;

/// Ranges the courses are drawn from, uniformly; `[lo, hi]` inclusive. The defaults are
/// issue 15's: rise 5–20 cm, run 25–45 cm, 1–6 steps, start gap 10–60 cm, gait speed
/// 0.1–0.4 m/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CourseRanges {
    /// Height of each step \[m\].
    pub rise: [f64; 2],
    /// Depth of each tread \[m\].
    pub run: [f64; 2],
    /// Number of steps.
    pub steps: [usize; 2],
    /// Distance from the robot's foremost point to the first riser at the start \[m\].
    pub start_gap: [f64; 2],
    /// The gait's rolling speed \[m/s\].
    pub speed: [f64; 2],
}

impl Default for CourseRanges {
    fn default() -> Self {
        Self { rise: [0.05, 0.20], run: [0.25, 0.45], steps: [1, 6], start_gap: [0.1, 0.6], speed: [0.1, 0.4] }
    }
}

impl CourseRanges {
    /// Largest rise accepted \[m\]: the knee's 0.5 m stroke cannot climb more.
    pub const MAX_RISE: f64 = 0.3;
    /// Most steps accepted: the filter's environment has this many edge slots.
    pub const MAX_STEPS: usize = 20;

    /// # Errors
    /// A range with `lo > hi`, a bound that is not finite, a rise outside `(0, MAX_RISE]`,
    /// a run at or below 0.15 m or above 10 m, steps outside `1..=MAX_STEPS`, a start gap
    /// outside `[0, 10]` m, a speed outside `(0, 1]` m/s.
    pub fn validate(&self) -> Result<(), CbfError> {
        use cbfgen::error::within;
        let check = |what, [lo, hi]: [f64; 2], min: f64, max: f64, range| -> Result<(), CbfError> {
            within(what, lo, min, max, range)?;
            within(what, hi, min, max, range)?;
            if lo > hi {
                return Err(CbfError::OutOfRange { what, value: lo, range: "at most the range's upper end" });
            }
            Ok(())
        };
        check("rise range [m]", self.rise, 0.0, Self::MAX_RISE, "(0, 0.3]")?;
        cbfgen::error::positive("rise range [m]", self.rise[0])?;
        check("run range [m]", self.run, 0.15, 10.0, "(0.15, 10]")?;
        if self.run[0] <= 0.15 {
            return Err(CbfError::OutOfRange { what: "run range [m]", value: self.run[0], range: "(0.15, 10]" });
        }
        check("start gap range [m]", self.start_gap, 0.0, 10.0, "[0, 10]")?;
        check("speed range [m/s]", self.speed, 0.0, 1.0, "(0, 1]")?;
        cbfgen::error::positive("speed range [m/s]", self.speed[0])?;
        let [lo, hi] = self.steps;
        if lo == 0 || hi > Self::MAX_STEPS || lo > hi {
            return Err(CbfError::OutOfRange { what: "steps range", value: lo as f64, range: "1 <= lo <= hi <= 20" });
        }
        Ok(())
    }
}

/// One randomised course and gait speed, drawn from `(seed, id)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Episode {
    /// The campaign seed it was drawn with.
    pub seed: u64,
    /// Its number within the campaign.
    pub id: u64,
    /// The staircase (first riser at x = 1 m, hardware width and edge cuboid section).
    pub stairs: Stairs,
    /// Distance from the robot's foremost point to the first riser at the start \[m\].
    pub start_gap: f64,
    /// The gait's rolling speed \[m/s\].
    pub speed: f64,
}

impl Episode {
    /// Episode `id` of the campaign seeded `seed`: the same `(seed, id, ranges)` always
    /// gives the same episode, on every platform.
    ///
    /// # Errors
    /// Ranges that fail [`CourseRanges::validate`].
    pub fn draw(seed: u64, id: u64, ranges: &CourseRanges) -> Result<Self, CbfError> {
        ranges.validate()?;
        Ok(Self::draw_valid(seed, id, ranges))
    }

    /// [`Episode::draw`] for ranges already validated.
    fn draw_valid(seed: u64, id: u64, ranges: &CourseRanges) -> Self {
        let mut key = [0u8; 32];
        key[..8].copy_from_slice(&seed.to_le_bytes());
        key[8..16].copy_from_slice(&id.to_le_bytes());
        let mut rng = ChaCha8Rng::from_seed(key);
        let mut uniform = |[lo, hi]: [f64; 2]| lo + (hi - lo) * rng.random::<f64>();
        let rise = uniform(ranges.rise);
        let run = uniform(ranges.run);
        let start_gap = uniform(ranges.start_gap);
        let speed = uniform(ranges.speed);
        let [lo, hi] = ranges.steps;
        let count = rng.random_range(lo..=hi);
        let stairs = Stairs { rise, run, count, ..Stairs::HARDWARE };
        Self { seed, id, stairs, start_gap, speed }
    }

    /// The simulation set-up of this episode: the default gait at the episode's speed, the
    /// default filter, [`time_allowed`](super::time_allowed) to finish.
    pub fn config(&self, body_cbf: bool) -> SimConfig {
        let mut config = SimConfig::new(Scenario::Custom(self.stairs), body_cbf);
        config.start_gap = self.start_gap;
        config.gait.speed = self.speed;
        config
    }

    /// [`Episode::config`], on perceived terrain when `perception` is set: default
    /// perception, the scans' noise seeded from the episode's `(seed, id)`.
    pub fn config_with(&self, body_cbf: bool, perception: bool) -> SimConfig {
        let seed = self.seed.rotate_left(32) ^ self.id;
        let perception = perception.then(|| PerceptionSettings { seed, ..PerceptionSettings::default() });
        SimConfig { perception, ..self.config(body_cbf) }
    }
}

/// How an episode ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Outcome {
    /// Climbed the whole staircase within [`time_allowed`](super::time_allowed).
    Finished,
    /// Still short of the top when the time ran out (a stall).
    NotFinished,
    /// The run stopped with an error (or a panic, which is a bug).
    Error,
}

impl Outcome {
    /// `finished`, `not_finished` or `error`, as in the CSV.
    pub fn name(self) -> &'static str {
        match self {
            Outcome::Finished => "finished",
            Outcome::NotFinished => "not_finished",
            Outcome::Error => "error",
        }
    }
}

/// What one episode established.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeRecord {
    /// The course and speed.
    pub episode: Episode,
    /// The run's summary, or the error (or panic) message that ended it.
    pub result: Result<Summary, String>,
}

impl EpisodeRecord {
    /// How the episode ended.
    pub fn outcome(&self) -> Outcome {
        match &self.result {
            Ok(s) if s.completed => Outcome::Finished,
            Ok(_) => Outcome::NotFinished,
            Err(_) => Outcome::Error,
        }
    }
}

/// A campaign's set-up.
#[derive(Debug, Clone, PartialEq)]
pub struct CampaignSettings {
    /// Seed of every episode's course.
    pub seed: u64,
    /// Episodes `first_id .. first_id + episodes` are run.
    pub episodes: usize,
    /// Id of the first episode (to split a campaign, or to rerun part of one).
    pub first_id: u64,
    /// Where the courses are drawn from.
    pub ranges: CourseRanges,
    /// With `false`, the body–edge SSAT rows never take part (the comparison).
    pub body_cbf: bool,
    /// Worker threads; `None` = one per core.
    pub threads: Option<usize>,
    /// With `true`, every episode runs on perceived terrain ([`Episode::config_with`]).
    pub perception: bool,
    /// How the plant moves between the samples ([`Plant::Held`] measures every clearance
    /// and `h` at each fine step).
    pub plant: Plant,
    /// With `true`, the filter certifies each input between the samples
    /// ([`SampledData::every_family`](cbfgen::filter::SampledData::every_family) at the
    /// 1 ms period).
    pub certify: bool,
    /// The filter's worst case per update in CPU time on this machine \[µs\]
    /// ([`time_bound_us`](crate::sim::time_bound_us), measured once for the campaign):
    /// each episode counts its updates beyond it. `None`: not counted.
    pub time_bound_us: Option<f64>,
}

impl Default for CampaignSettings {
    fn default() -> Self {
        Self {
            seed: 0,
            episodes: 200,
            first_id: 0,
            ranges: CourseRanges::default(),
            body_cbf: true,
            threads: None,
            perception: false,
            plant: Plant::Euler,
            certify: false,
            time_bound_us: None,
        }
    }
}

impl CampaignSettings {
    /// The simulation set-up of `episode` in this campaign.
    pub fn config(&self, episode: &Episode) -> SimConfig {
        let config = episode.config_with(self.body_cbf, self.perception).between_samples(self.plant, self.certify);
        SimConfig { time_bound_us: self.time_bound_us, ..config }
    }

    /// The same campaign counting each update against the filter's worst case in CPU
    /// time, measured now on this machine ([`time_bound_us`](crate::sim::time_bound_us) of
    /// its first episode's filter; every episode's filter has the same rows and settings).
    /// Unchanged where the worst case states no time.
    ///
    /// # Errors
    /// The first episode's course or filter.
    pub fn with_time_bound(self) -> Result<Self, CbfError> {
        let first = Episode::draw(self.seed, self.first_id, &self.ranges)?;
        let time_bound_us = crate::sim::time_bound_us(&self.config(&first))?;
        Ok(Self { time_bound_us, ..self })
    }

    /// Shard `index` of `count` (0-based): the same campaign narrowed to a contiguous block
    /// of its ids, episodes `first_id + ⌊index·episodes/count⌋` up to the next shard's
    /// first. The shards cover every id once, and each episode is drawn from `(seed, id)`
    /// alone, so shards run anywhere (a batch scheduler's array jobs, a Ray cluster) and
    /// [`table::merge`]d are the campaign run in one go.
    ///
    /// # Errors
    /// `count` zero or above the number of episodes, or `index` not below `count`.
    pub fn shard(&self, index: usize, count: usize) -> Result<Self, CbfError> {
        if count == 0 {
            return Err(CbfError::NotPositive { what: "shard count", value: 0.0 });
        }
        if count > self.episodes {
            return Err(CbfError::TooLarge {
                what: "shard count (more shards than episodes)",
                value: count,
                max: self.episodes,
            });
        }
        if index >= count {
            return Err(CbfError::NoSuchIndex { what: "shard", index, len: count });
        }
        // u128: index · episodes cannot overflow.
        let start = |i: usize| (i as u128 * self.episodes as u128 / count as u128) as usize;
        let (begin, end) = (start(index), start(index + 1));
        Ok(Self { first_id: self.first_id + begin as u64, episodes: end - begin, ..self.clone() })
    }
}

/// Every episode's record, in id order.
#[derive(Debug, Clone, PartialEq)]
pub struct Campaign {
    /// The set-up it ran with.
    pub settings: CampaignSettings,
    /// One per episode, in id order.
    pub records: Vec<EpisodeRecord>,
}

/// Run every episode of `settings` in parallel, calling `progress(done)` as episodes end
/// (from worker threads). An episode that fails, or panics, is recorded as
/// [`Outcome::Error`] with its message; the others go on.
///
/// # Errors
/// Invalid ranges or plant, more than [`MAX_EPISODES`] episodes, zero threads or more than
/// [`MAX_THREADS`], or a thread pool that cannot start.
pub fn run(settings: &CampaignSettings, progress: impl Fn(usize) + Sync) -> Result<Campaign, CbfError> {
    settings.ranges.validate()?;
    settings.plant.validate()?;
    if settings.episodes > MAX_EPISODES {
        return Err(CbfError::TooLarge { what: "episodes", value: settings.episodes, max: MAX_EPISODES });
    }
    if settings.first_id.checked_add(settings.episodes as u64).is_none() {
        return Err(CbfError::TooLarge { what: "first episode id", value: usize::MAX, max: MAX_EPISODES });
    }
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(threads) = settings.threads {
        if threads == 0 {
            return Err(CbfError::NotPositive { what: "threads", value: 0.0 });
        }
        if threads > MAX_THREADS {
            return Err(CbfError::TooLarge { what: "threads", value: threads, max: MAX_THREADS });
        }
        pool = pool.num_threads(threads);
    }
    let pool =
        pool.build().map_err(|e| CbfError::Thread { what: "campaign", reason: format!("could not start: {e}") })?;
    let done = AtomicUsize::new(0);
    let ids = settings.first_id..settings.first_id + settings.episodes as u64;
    let records = pool.install(|| {
        ids.into_par_iter()
            .map(|id| {
                let episode = Episode::draw_valid(settings.seed, id, &settings.ranges);
                let record = run_episode(&episode, settings);
                progress(done.fetch_add(1, Ordering::Relaxed) + 1);
                record
            })
            .collect()
    });
    Ok(Campaign { settings: settings.clone(), records })
}

/// Climb `episode` once as `settings` say (with or without the body SSAT CBF, on true or
/// perceived terrain, the plant, the certificate), recording its summary or the error
/// (or panic) that ended it.
pub fn run_episode(episode: &Episode, settings: &CampaignSettings) -> EpisodeRecord {
    let config = settings.config(episode);
    // A panic is a bug, but one episode's must not cost the other ten thousand.
    let result = match catch_unwind(AssertUnwindSafe(|| super::run(&config, |_| {}))) {
        Ok(Ok(r)) => Ok(r.summary),
        Ok(Err(e)) => Err(e.to_string()),
        Err(panic) => Err(format!(
            "panic: {}",
            panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default()
        )),
    };
    EpisodeRecord { episode: *episode, result }
}

/// An episode id and the value it holds the record for.
pub type Worst = Option<(u64, f64)>;

/// An episode id and its closest approach that holds the record (distance, place, time).
pub type WorstApproach = Option<(u64, Nearest)>;

/// What a campaign established: outcomes, safety counts against the documented tolerances,
/// the worst episode of each kind, and the filter's time per update (thread CPU time beside
/// wall time).
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// Episodes run.
    pub episodes: usize,
    /// Episodes that climbed the whole staircase.
    pub finished: usize,
    /// Episodes short of the top when their time ran out; their ids (in order).
    pub not_finished: Vec<u64>,
    /// Episodes that ended with an error, with the message.
    pub errors: Vec<(u64, String)>,
    /// Episodes whose body went more than [`PENETRATION_TOLERANCE`] into a solid of the
    /// terrain (exact SAT against the floor and every step as a block).
    pub body_penetrations: usize,
    /// Episodes with a wheel more than [`PENETRATION_TOLERANCE`] into a solid of the
    /// terrain (exact sphere–box distance), tread or riser.
    pub toe_penetrations: usize,
    /// Episodes with a cycle in which a wheel touched or entered a riser, and those
    /// cycles in all.
    pub riser_contacts: (usize, usize),
    /// Episodes with a joint-limit row below `−`[`JOINT_LIMIT_TOLERANCE`].
    pub joint_limit_violations: usize,
    /// The body's closest approach to (or deepest into) the solid terrain.
    pub worst_body: WorstApproach,
    /// The deepest wheel into the solid terrain (about 0 where wheels only stood on
    /// treads).
    pub worst_toe: WorstApproach,
    /// The closest approach of a wheel to a riser.
    pub worst_toe_riser: WorstApproach,
    /// Smallest joint-limit `h` (rad or m).
    pub worst_joint_limit: Worst,
    /// Smallest foothold `h`: how far a swinging toe left its foothold strip \[m\] when negative.
    pub worst_foothold: Worst,
    /// Filter updates in all episodes.
    pub cycles: usize,
    /// Updates over the 1 ms period in thread CPU time, and the episodes holding any.
    pub over_period_cpu: (usize, usize),
    /// Updates over the 1 ms period in wall time, and the episodes holding any.
    pub over_period_wall: (usize, usize),
    /// Median over episodes of each episode's median update, CPU time \[µs\].
    pub median_cpu_us: f64,
    /// Largest per-episode 99th percentile of the update's CPU time \[µs\].
    pub worst_p99_cpu: Worst,
    /// Slowest update in CPU time \[µs\].
    pub max_cpu: Worst,
    /// Slowest update in wall time \[µs\].
    pub max_wall: Worst,
    /// Updates whose input was not a verified QP optimum (flagged fallbacks).
    pub fallback_cycles: usize,
    /// Per family ([`Family::index`](crate::catalog::Family::index)
    /// order): updates in which the filter reported rows of it relaxed, and the episodes
    /// holding any.
    pub relaxed_cycles: [(usize, usize); FAMILY_COUNT],
    /// Fine steps per period the clearances and `h` above were measured at (0: at the
    /// samples only), the most of any episode.
    pub fine_steps: usize,
    /// Updates certified between the samples, and updates run with the certificate on.
    pub certified_cycles: (usize, usize),
    /// The most dense-solver trips any update took, and its episode.
    pub max_dense_trips: Option<(u64, u64)>,
    /// Updates whose counted work went beyond the filter's stated worst case, and the
    /// episodes holding any: (0, 0), or the bound is wrong.
    pub beyond_worst_case: (usize, usize),
    /// Updates whose CPU time went beyond the worst case in time
    /// ([`CampaignSettings::time_bound_us`]), and the episodes holding any.
    pub beyond_time_bound: (usize, usize),
}

impl Campaign {
    /// Each record as `episodes.csv` holds it.
    pub fn rows(&self) -> Vec<EpisodeRow> {
        self.records.iter().map(EpisodeRow::of).collect()
    }

    /// Count and rank what the episodes established ([`Report::of`] its rows).
    pub fn report(&self) -> Report {
        Report::of(&self.rows())
    }
}

impl Report {
    /// Count and rank what `rows` established: the same report for a campaign just run
    /// and for its shards read back and merged.
    pub fn of(rows: &[EpisodeRow]) -> Self {
        let mut r = Report {
            episodes: rows.len(),
            finished: 0,
            not_finished: Vec::new(),
            errors: Vec::new(),
            body_penetrations: 0,
            toe_penetrations: 0,
            riser_contacts: (0, 0),
            joint_limit_violations: 0,
            worst_body: None,
            worst_toe: None,
            worst_toe_riser: None,
            worst_joint_limit: None,
            worst_foothold: None,
            cycles: 0,
            over_period_cpu: (0, 0),
            over_period_wall: (0, 0),
            median_cpu_us: 0.0,
            worst_p99_cpu: None,
            max_cpu: None,
            max_wall: None,
            fallback_cycles: 0,
            relaxed_cycles: [(0, 0); FAMILY_COUNT],
            fine_steps: 0,
            certified_cycles: (0, 0),
            max_dense_trips: None,
            beyond_worst_case: (0, 0),
            beyond_time_bound: (0, 0),
        };
        let lowest = |worst: &mut Worst, id: u64, v: f64| {
            if v.is_finite() && worst.is_none_or(|(_, w)| v < w) {
                *worst = Some((id, v));
            }
        };
        let nearest = |worst: &mut WorstApproach, id: u64, a: &Option<Nearest>| {
            if let Some(a) = a.as_ref().filter(|a| a.distance.is_finite()) {
                if worst.as_ref().is_none_or(|(_, w)| a.distance < w.distance) {
                    *worst = Some((id, a.clone()));
                }
            }
        };
        let highest = |worst: &mut Worst, id: u64, v: f64| {
            if worst.is_none_or(|(_, w)| v > w) {
                *worst = Some((id, v));
            }
        };
        let mut medians = Vec::with_capacity(rows.len());
        for row in rows {
            let id = row.id;
            let s = match (&row.result, row.outcome) {
                (Err(e), _) => {
                    r.errors.push((id, e.clone()));
                    continue;
                }
                (Ok(s), Outcome::Finished) => {
                    r.finished += 1;
                    s
                }
                (Ok(s), _) => {
                    r.not_finished.push(id);
                    s
                }
            };
            r.body_penetrations += usize::from(s.min_body_clearance() < -PENETRATION_TOLERANCE);
            r.toe_penetrations += usize::from(s.min_toe_clearance() < -PENETRATION_TOLERANCE);
            r.riser_contacts.0 += usize::from(s.riser_contact_cycles > 0);
            r.riser_contacts.1 += s.riser_contact_cycles;
            let joint = s.min_h[Family::JointLimits.index()];
            r.joint_limit_violations += usize::from(joint < -JOINT_LIMIT_TOLERANCE);
            nearest(&mut r.worst_body, id, &s.body_nearest);
            nearest(&mut r.worst_toe, id, &s.toe_nearest);
            nearest(&mut r.worst_toe_riser, id, &s.toe_riser_nearest);
            lowest(&mut r.worst_joint_limit, id, joint);
            lowest(&mut r.worst_foothold, id, s.min_h[Family::Foothold.index()]);
            r.cycles += s.cycles;
            r.over_period_cpu.0 += s.over_1ms_cpu;
            r.over_period_cpu.1 += usize::from(s.over_1ms_cpu > 0);
            r.over_period_wall.0 += s.over_1ms_wall;
            r.over_period_wall.1 += usize::from(s.over_1ms_wall > 0);
            let [median_cpu, p99_cpu, max_cpu] = s.cpu_us;
            medians.push(median_cpu);
            highest(&mut r.worst_p99_cpu, id, p99_cpu);
            highest(&mut r.max_cpu, id, max_cpu);
            highest(&mut r.max_wall, id, s.wall_us[2]);
            r.fallback_cycles += s.fallback_cycles;
            if r.max_dense_trips.is_none_or(|(_, most)| s.max_dense_trips > most) {
                r.max_dense_trips = Some((id, s.max_dense_trips));
            }
            r.beyond_worst_case.0 += s.beyond_worst_case;
            r.beyond_worst_case.1 += usize::from(s.beyond_worst_case > 0);
            r.beyond_time_bound.0 += s.beyond_time_bound;
            r.beyond_time_bound.1 += usize::from(s.beyond_time_bound > 0);
            r.fine_steps = r.fine_steps.max(s.fine_steps);
            if let Some(n) = s.certified_cycles {
                r.certified_cycles = (r.certified_cycles.0 + n, r.certified_cycles.1 + s.cycles);
            }
            for (total, &n) in r.relaxed_cycles.iter_mut().zip(&s.relaxed_cycles) {
                *total = (total.0 + n, total.1 + usize::from(n > 0));
            }
        }
        medians.sort_unstable_by(f64::total_cmp);
        r.median_cpu_us = crate::latency::nearest_rank(&medians, 0.5).unwrap_or(0.0);
        r
    }

    /// No penetration or joint-limit violation beyond the tolerances, no error, and every
    /// episode finished: what the CI campaign requires.
    pub fn all_safe_and_finished(&self) -> bool {
        self.body_penetrations == 0
            && self.toe_penetrations == 0
            && self.joint_limit_violations == 0
            && self.errors.is_empty()
            && self.not_finished.is_empty()
    }
}
