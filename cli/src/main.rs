//! `cbfgen` command line.

use cbfgen::filter::{FilterSettings, Solver, SolverSettings};
use cbfgen::ssat::{self, SmoothParams};
use cbfgen::{sat, OrientedBox};
use cbfgen_tachyon3::catalog::{Capacity, Catalog, Environment, Family};
use cbfgen_tachyon3::latency;
use cbfgen_tachyon3::model::{self, NU};
use cbfgen_tachyon3::sim::campaign::{self, CampaignSettings, CourseRanges, Episode};
use cbfgen_tachyon3::sim::perceived::PerceptionSettings;
use cbfgen_tachyon3::sim::{self, output, Plant, Scenario, SimConfig, SimResult};
use clap::{Parser, Subcommand};
use nalgebra::{Rotation3, Vector3};
use std::io::Write;
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "cbfgen", version, about = "Code-generated ECBF safety filters (Tachyon 3 style)")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Smooth SAT between a robot body and a stair-edge cuboid below it: value,
    /// certified margin, exact SAT and gradient, for a body height you choose.
    Ssat(SsatArgs),
    /// Evaluate the Tachyon 3 joint-limit rows (h, L_f h, L_f^2 h) at the standard
    /// posture: edit systems/tachyon3/spec/tachyon3.toml, rebuild, and watch them change.
    Rows,
    /// Time the ECBF filter: consecutive 269-row updates at 1 kHz while the robot rolls
    /// into a staircase; prints median, p99 and max per update, in wall time and in the
    /// thread's CPU time (a VM stall adds wall time only), and the cycles over 1 ms of each.
    Latency(LatencyArgs),
    /// Closed-loop simulation at 1 kHz: the robot walks over a step or climbs five stairs
    /// with the ECBF filter correcting a naive gait. Writes a CSV, a page that plays the
    /// runs back (<scenario>_animation.html) and the paper's Figs. 7-10 (SVG and PNG) to
    /// --out and prints a summary. Unless --no-body-cbf is given, the
    /// same course is also run without the body SSAT CBF for Fig. 7's comparison; unless
    /// --no-osqp-reference is given, also with the OSQP backend for Fig. 10's.
    Simulate(SimulateArgs),
    /// Monte Carlo safety campaign: climb many randomised staircases (rise, run, steps,
    /// start gap and gait speed drawn per episode from --seed and the episode id) in
    /// parallel. Prints a table (outcomes, penetrations, joint-limit violations, worst
    /// episodes, CPU and wall time per update) and writes episodes.csv, report.txt and
    /// figures to --out. Rerun one episode with `cbfgen simulate --episode ID --seed S`.
    Campaign(CampaignArgs),
    /// Merge campaign shards (`campaign --shard I/N` runs, each its episodes.csv) into the
    /// one campaign's episodes.csv, report.txt and figures, as `campaign` without --shard
    /// writes them.
    Merge(MergeArgs),
    /// Bipedal navigation: a 3D-LIP MPC with linear discrete CBFs walks from the origin
    /// to a goal past three rectangles. Prints a summary and writes the path figure
    /// (lip_navigation.svg/.png) and the barrier figure (lip_min_h.svg/.png) to --out.
    Lip(LipArgs),
    /// Multi-layer safety on a double integrator kept above a moving sinusoid: a kinematic
    /// MPC at 20 Hz (with a discrete-time CBF, a state constraint, or nothing) feeding an
    /// ID-CBF-QP at 1 kHz. Prints peak |u| and min h per variant and writes
    /// multilayer_positions and multilayer_inputs, SVG and PNG (the paper's Fig. 3), to
    /// --out.
    Multilayer(MultilayerArgs),
    /// A Franka-Panda-like 7-DoF arm (systems/panda/spec/panda.py) at 1 kHz: a joint-space
    /// PD sweeps the forearm through a box on a table, folds the hand onto the shoulder and
    /// pushes the elbow past its limit; run with the ECBF filter and without. Prints each
    /// run's exact SAT separations and joint margins; writes CSVs and four figures (SVG and PNG).
    Arm(ArmArgs),
    /// Perception on the hardware stairs (5 × 16.5 × 35 cm): four simulated LiDAR scans on
    /// the approach, accumulated; planes and edge cuboids extracted from the points alone.
    /// Prints each true nosing beside the cuboid found for it and writes side and top
    /// views (SVG and PNG).
    Perceive(PerceiveArgs),
    /// Regenerate every generated file (generated/, systems/*/generated/) from symbolic/ and the specs (runs `python -m symbolic.generate`).
    Generate,
}

/// `cbfgen ssat`.
#[derive(clap::Args)]
struct SsatArgs {
    /// Height of the body's underside above the step's top face \[m\], in [-1, 1].
    #[arg(long, default_value_t = 0.075, allow_hyphen_values = true, value_parser = number(-1.0, 1.0, Closed))]
    clearance: f64,
    /// Body pitch \[rad\], in [-3.15, 3.15].
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = number(-3.15, 3.15, Closed))]
    pitch: f64,
    /// Smooth-max / smooth-|x| sharpness α [1/m] (α_rot uses the same value), in [1e-6, 1e9].
    #[arg(long, default_value_t = 200.0, allow_hyphen_values = true,
          value_parser = number(ssat::ALPHA_MIN, ssat::ALPHA_MAX, Closed))]
    alpha: f64,
}

/// `cbfgen latency`.
#[derive(clap::Args)]
struct LatencyArgs {
    /// Number of consecutive updates, 1 to 1000000 (each keeps its timings).
    #[arg(long, default_value_t = 10_000, allow_hyphen_values = true, value_parser = count(1, latency::MAX_CYCLES))]
    cycles: usize,
    /// Commanded forward speed [m/s], in [0, 2].
    #[arg(long, default_value_t = 0.3, allow_hyphen_values = true, value_parser = number(0.0, 2.0, Closed))]
    speed: f64,
    /// Start with the robot's front (body or toe) this far from the first riser \[m\], in [0, 10].
    #[arg(long, default_value_t = 0.6, allow_hyphen_values = true, value_parser = number(0.0, 10.0, Closed))]
    gap: f64,
    #[command(flatten)]
    solver: SolverArgs,
}

/// `cbfgen simulate`.
#[derive(clap::Args)]
struct SimulateArgs {
    /// Course: one 16.5 cm step, five steps of 16.5 x 35 cm, four steps of unequal
    /// rise, steps with a landing, a 12 cm box to cross, a 20 cm platform to climb
    /// onto and roll off, three steps with a 90° left turn on a landing and three more.
    #[arg(long, value_enum, default_value_t = ScenarioArg::Stairs)]
    scenario: ScenarioArg,
    /// Run only without the body SSAT CBF (the body hits the edge).
    #[arg(long)]
    no_body_cbf: bool,
    /// Directory for the CSV files and figures.
    #[arg(long, default_value = "out")]
    out: std::path::PathBuf,
    /// Write every N-th cycle to the CSV (1 = every millisecond), 1 to 1000000.
    #[arg(long, default_value_t = 10, allow_hyphen_values = true, value_parser = count(1, MAX_CSV_EVERY))]
    csv_every: usize,
    /// Skip the reference run with the OSQP backend (the paper's solver), whose QP time
    /// Fig. 10 shows beside the default backend's.
    #[arg(long)]
    no_osqp_reference: bool,
    /// Run episode ID of a campaign instead of --scenario (with the campaign's --seed
    /// and ranges): the course a `cbfgen campaign` line names. Any id from 0 to 2^64 - 1.
    #[arg(long, value_name = "ID", allow_hyphen_values = true, value_parser = count(0, u64::MAX))]
    episode: Option<u64>,
    /// The campaign seed of --episode, from 0 to 2^64 - 1.
    #[arg(long, default_value_t = 0, requires = "episode", allow_hyphen_values = true,
          value_parser = count(0, u64::MAX))]
    seed: u64,
    #[command(flatten)]
    ranges: RangeArgs,
    /// The gait and filter see only what a LiDAR on the body perceives (planes and
    /// edge cuboids at 1 Hz on a worker thread), never the true terrain; writes the
    /// map, what was extracted and side and top views too.
    #[arg(long)]
    perception: bool,
    #[command(flatten)]
    between: BetweenArgs,
}

/// `cbfgen campaign`.
#[derive(clap::Args)]
struct CampaignArgs {
    /// Number of episodes, 1 to 1000000.
    #[arg(long, default_value_t = 200, allow_hyphen_values = true, value_parser = count(1, campaign::MAX_EPISODES))]
    episodes: usize,
    /// Seed of the courses, from 0 to 2^64 - 1.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true, value_parser = count(0, u64::MAX))]
    seed: u64,
    /// Id of the first episode, from 0 to 2^64 - 1 - 1000000 (so that every id fits).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true,
          value_parser = count(0, u64::MAX - campaign::MAX_EPISODES as u64))]
    first_id: u64,
    /// Run without the body SSAT CBF (the comparison).
    #[arg(long)]
    no_body_cbf: bool,
    /// Worker threads, 1 to 1024 (default: one per core).
    #[arg(long, allow_hyphen_values = true, value_parser = count(1, campaign::MAX_THREADS))]
    threads: Option<usize>,
    /// Directory for the CSV, the report and the figures (default: out/campaign, or
    /// out/campaign/shard-I-of-N for --shard I/N).
    #[arg(long)]
    out: Option<std::path::PathBuf>,
    #[command(flatten)]
    ranges: RangeArgs,
    /// Every episode on perceived terrain (see `simulate --perception`); rerun one
    /// with `cbfgen simulate --episode ID --seed S --perception`.
    #[arg(long)]
    perception: bool,
    /// Run only shard I of N (0 <= I < N <= episodes): a contiguous block of the
    /// campaign's ids, as an array job of a batch scheduler would (`--shard
    /// $SLURM_ARRAY_TASK_ID/N` with `--array=0-(N-1)`). `cbfgen merge` joins the shards'
    /// episodes.csv into the campaign's files.
    #[arg(long, value_name = "I/N", value_parser = shard)]
    shard: Option<(usize, usize)>,
    #[command(flatten)]
    between: BetweenArgs,
}

/// How the plant moves between the samples, and whether the filter certifies them
/// (`campaign` and `simulate`).
#[derive(clap::Args)]
struct BetweenArgs {
    /// Hold each input over its 1 ms period on the continuous model, RK4 at 1 ms / N
    /// (N from 1 to 1000), and measure every clearance and h at each fine step, between
    /// the samples too (default: one Euler step per period, measured at the samples).
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = count(1, sim::MAX_FINE_STEPS))]
    fine: Option<usize>,
    /// The filter certifies each input between the samples (sampled-data margins,
    /// every family, the 1 ms period); the report counts the updates certified.
    #[arg(long)]
    certify: bool,
}

impl BetweenArgs {
    fn plant(&self) -> Plant {
        Plant::from_fine_steps(self.fine)
    }
}

/// `--shard I/N`.
fn shard(text: &str) -> Result<(usize, usize), String> {
    let message = || format!("`{text}` is not I/N with 0 <= I < N");
    let (i, n) = text.split_once('/').ok_or_else(message)?;
    let (i, n): (usize, usize) = (i.parse().map_err(|_| message())?, n.parse().map_err(|_| message())?);
    if i >= n {
        return Err(message());
    }
    Ok((i, n))
}

/// `cbfgen merge`.
#[derive(clap::Args)]
struct MergeArgs {
    /// The shards' episodes.csv files (or the directories holding them).
    #[arg(required = true)]
    shards: Vec<std::path::PathBuf>,
    /// Directory for the merged CSV, report and figures.
    #[arg(long, default_value = "out/campaign")]
    out: std::path::PathBuf,
}

/// `cbfgen lip`.
#[derive(clap::Args)]
struct LipArgs {
    /// Directory for the figures.
    #[arg(long, default_value = "out")]
    out: std::path::PathBuf,
    /// Step budget, 1 to 10000.
    #[arg(long, default_value_t = 150, allow_hyphen_values = true, value_parser = count(1usize, 10_000))]
    steps: usize,
    /// Course: `standard` (three blocks, to (6, 2) m) or `corner` (one block to walk
    /// round, to (4, 3) m).
    #[arg(long, value_enum, default_value_t = LipCourse::Standard)]
    course: LipCourse,
    /// CBF margin δ, 0 to 2 (m, or m² with `--barrier report`). Unless it is 0 the same
    /// course is also walked with δ = 0, Peng et al.'s LDCBF, for the report's comparison.
    #[arg(long, default_value_t = 0.3, allow_hyphen_values = true, value_parser = number(0.0, 2.0, Closed))]
    delta: f64,
    /// The half-planes' normal: `unit` (h in m) or `report` (η = x − c, h in m²).
    #[arg(long, value_enum, default_value_t = LipBarrier::Unit)]
    barrier: LipBarrier,
    /// Heading preprocessing: `per-step` rates toward the bearing, or the report's one
    /// clipped angle error for the whole horizon.
    #[arg(long, value_enum, default_value_t = LipHeading::PerStep)]
    heading: LipHeading,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum LipCourse {
    Standard,
    Corner,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum LipBarrier {
    Unit,
    Report,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum LipHeading {
    PerStep,
    Report,
}

/// `cbfgen multilayer`.
#[derive(clap::Args)]
struct MultilayerArgs {
    /// Directory for the figures.
    #[arg(long, default_value = "out")]
    out: std::path::PathBuf,
}

/// `cbfgen arm`.
#[derive(clap::Args)]
struct ArmArgs {
    /// Directory for the CSVs and figures.
    #[arg(long, default_value = "out")]
    out: std::path::PathBuf,
    /// Write every n-th cycle to the CSVs, 1 to 1000000.
    #[arg(long, default_value_t = 10, allow_hyphen_values = true, value_parser = count(1, MAX_CSV_EVERY))]
    csv_every: usize,
}

/// `cbfgen perceive`.
#[derive(clap::Args)]
struct PerceiveArgs {
    /// Directory for the figures.
    #[arg(long, default_value = "out")]
    out: std::path::PathBuf,
    /// Seed of the scans' noise and dropouts, from 0 to 2^64 - 1.
    #[arg(long, default_value_t = 1, allow_hyphen_values = true, value_parser = count(0, u64::MAX))]
    seed: u64,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum ScenarioArg {
    Step,
    Stairs,
    #[value(name = "unequal_rises")]
    UnequalRises,
    Landing,
    Box,
    Platform,
    Turn,
}

impl ScenarioArg {
    fn scenario(self) -> Scenario {
        match self {
            ScenarioArg::Step => Scenario::Step,
            ScenarioArg::Stairs => Scenario::Stairs,
            ScenarioArg::UnequalRises => Scenario::UnequalRises,
            ScenarioArg::Landing => Scenario::Landing,
            ScenarioArg::Box => Scenario::Box,
            ScenarioArg::Platform => Scenario::Platform,
            ScenarioArg::Turn => Scenario::Turn,
        }
    }
}

/// The ranges campaign courses are drawn from (defaults: [`CourseRanges::default`]); a
/// campaign episode reruns only with the same ranges. Each is `LO,HI`, checked against
/// [`CourseRanges::validate`]'s domain.
#[derive(clap::Args)]
struct RangeArgs {
    /// Step rise range \[m\], `LO,HI` with 0 < LO <= HI <= 0.3.
    #[arg(long, value_name = "LO,HI", allow_hyphen_values = true, default_value_t = Span(CourseRanges::default().rise),
          value_parser = span(Interval::new(0.0, CourseRanges::MAX_RISE, Open)))]
    rise: Span<f64>,
    /// Tread run range \[m\], `LO,HI` with 0.15 < LO <= HI <= 10.
    #[arg(long, value_name = "LO,HI", allow_hyphen_values = true, default_value_t = Span(CourseRanges::default().run),
          value_parser = span(Interval::new(0.15, 10.0, Open)))]
    run: Span<f64>,
    /// Number of steps, `LO,HI` with 1 <= LO <= HI <= 20.
    #[arg(long, value_name = "LO,HI", allow_hyphen_values = true, default_value_t = Span(CourseRanges::default().steps),
          value_parser = count_span(1, CourseRanges::MAX_STEPS))]
    steps: Span<usize>,
    /// Start gap range \[m\], `LO,HI` with 0 <= LO <= HI <= 10.
    #[arg(long, value_name = "LO,HI", allow_hyphen_values = true,
          default_value_t = Span(CourseRanges::default().start_gap), value_parser = span(Interval::new(0.0, 10.0, Closed)))]
    start_gap: Span<f64>,
    /// Gait speed range \[m/s\], `LO,HI` with 0 < LO <= HI <= 1.
    #[arg(long, value_name = "LO,HI", allow_hyphen_values = true, default_value_t = Span(CourseRanges::default().speed),
          value_parser = span(Interval::new(0.0, 1.0, Open)))]
    speed: Span<f64>,
}

impl RangeArgs {
    fn ranges(&self) -> CourseRanges {
        CourseRanges {
            rise: self.rise.0,
            run: self.run.0,
            steps: self.steps.0,
            start_gap: self.start_gap.0,
            speed: self.speed.0,
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum BackendArg {
    Dense,
    Osqp,
    // Spelled as Solver::name (and Python) spell it.
    #[value(name = "dense_then_osqp")]
    DenseThenOsqp,
}

/// Solver overrides for tuning runs; defaults are [`cbfgen::qp::SolverSettings::default`],
/// ranges [`SolverSettings::validate`]'s.
#[derive(clap::Args)]
struct SolverArgs {
    /// Which solver answers: the dense solve only, OSQP only, or the dense solve with OSQP
    /// when it does not verify in time.
    #[arg(long, value_enum)]
    backend: Option<BackendArg>,
    /// Most steps of the dense solve, 1 to 10000.
    #[arg(long, allow_hyphen_values = true, value_parser = count(1, SolverSettings::MAX_ITERATIONS))]
    dense_max_steps: Option<u32>,
    /// Most work of one dense solve, in inner-loop trips, 1 to 1e10 (default 1e7): what
    /// bounds an update's worst case (printed by `latency`).
    #[arg(long, allow_hyphen_values = true, value_parser = count(1, SolverSettings::MAX_WORK))]
    dense_max_work: Option<u64>,
    /// Absolute tolerance, in [1e-12, 1e3].
    #[arg(long, allow_hyphen_values = true,
          value_parser = number(SolverSettings::MIN_TOLERANCE, SolverSettings::MAX_TOLERANCE, Closed))]
    eps_abs: Option<f64>,
    /// Relative tolerance, in [1e-12, 1e3].
    #[arg(long, allow_hyphen_values = true,
          value_parser = number(SolverSettings::MIN_TOLERANCE, SolverSettings::MAX_TOLERANCE, Closed))]
    eps_rel: Option<f64>,
    /// Initial ADMM step ρ, in [1e-6, 1e6].
    #[arg(long, allow_hyphen_values = true,
          value_parser = number(SolverSettings::RHO_RANGE[0], SolverSettings::RHO_RANGE[1], Closed))]
    rho: Option<f64>,
    /// Over-relaxation α, in [0.01, 1.99].
    #[arg(long, allow_hyphen_values = true,
          value_parser = number(SolverSettings::ALPHA_RANGE[0], SolverSettings::ALPHA_RANGE[1], Closed))]
    alpha: Option<f64>,
    /// Iterations between convergence checks, 1 to 10000.
    #[arg(long, allow_hyphen_values = true, value_parser = count(1, SolverSettings::MAX_ITERATIONS))]
    check_termination: Option<u32>,
    /// Iterations between ρ adaptations, 0 to 10000 (0 turns adaptation off).
    #[arg(long, allow_hyphen_values = true, value_parser = count(0, SolverSettings::MAX_ITERATIONS))]
    adaptive_rho_interval: Option<u32>,
}

impl SolverArgs {
    fn apply(&self, s: &mut FilterSettings<NU>) {
        let o = &mut s.solver;
        if let Some(b) = self.backend {
            o.backend = match b {
                BackendArg::Dense => Solver::Dense,
                BackendArg::Osqp => Solver::Osqp,
                BackendArg::DenseThenOsqp => Solver::DenseThenOsqp,
            };
        }
        o.dense_max_steps = self.dense_max_steps.unwrap_or(o.dense_max_steps);
        o.dense_max_work = self.dense_max_work.unwrap_or(o.dense_max_work);
        o.eps_abs = self.eps_abs.unwrap_or(o.eps_abs);
        o.eps_rel = self.eps_rel.unwrap_or(o.eps_rel);
        o.rho = self.rho.unwrap_or(o.rho);
        o.alpha = self.alpha.unwrap_or(o.alpha);
        o.check_termination = self.check_termination.unwrap_or(o.check_termination);
        match self.adaptive_rho_interval {
            Some(0) => o.adaptive_rho = false,
            Some(n) => o.adaptive_rho_interval = n,
            None => {}
        }
    }
}

/// Most cycles between two CSV lines.
const MAX_CSV_EVERY: usize = 1_000_000;

/// Whether a range of numbers holds its lower end.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Lower {
    Closed,
    Open,
}
use Lower::{Closed, Open};

/// The documented range of a number on the command line: `[lo, hi]` or `(lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Interval {
    lo: f64,
    hi: f64,
    lower: Lower,
}

impl Interval {
    const fn new(lo: f64, hi: f64, lower: Lower) -> Self {
        Self { lo, hi, lower }
    }

    fn contains(&self, v: f64) -> bool {
        let above = match self.lower {
            Closed => v >= self.lo,
            Open => v > self.lo,
        };
        above && v <= self.hi
    }

    /// `text` as a number in the interval, or a message that names the interval.
    fn parse(&self, text: &str) -> Result<f64, String> {
        match text.trim().parse::<f64>() {
            Ok(v) if self.contains(v) => Ok(v),
            _ => Err(format!("`{text}` is not a number in {self}")),
        }
    }
}

impl std::fmt::Display for Interval {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // 1e-12 rather than 0.000000000001.
        let short =
            |v: f64| if v != 0.0 && !(1e-3..1e5).contains(&v.abs()) { format!("{v:e}") } else { format!("{v}") };
        let open = if self.lower == Closed { '[' } else { '(' };
        write!(f, "{open}{}, {}]", short(self.lo), short(self.hi))
    }
}

/// A value parser for a number in `[lo, hi]` (`lower == Open`: `(lo, hi]`); NaN and
/// infinities are outside every interval.
fn number(lo: f64, hi: f64, lower: Lower) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    let interval = Interval::new(lo, hi, lower);
    move |text| interval.parse(text)
}

/// `text` as a whole number in `lo..=hi`, or a message that names the range.
fn whole<T: std::str::FromStr + PartialOrd + std::fmt::Display>(text: &str, lo: &T, hi: &T) -> Result<T, String> {
    match text.trim().parse::<T>() {
        Ok(v) if (lo..=hi).contains(&&v) => Ok(v),
        _ => Err(format!("`{text}` is not a whole number in {lo}..={hi}")),
    }
}

/// A value parser for a whole number in `lo..=hi`.
fn count<T>(lo: T, hi: T) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: std::str::FromStr + PartialOrd + std::fmt::Display + Copy + Send + Sync + 'static,
{
    move |text| whole(text, &lo, &hi)
}

/// A range given on the command line as `LO,HI`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Span<T>([T; 2]);

impl<T: std::fmt::Display> std::fmt::Display for Span<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{},{}", self.0[0], self.0[1])
    }
}

/// `text` split as `LO,HI`, each end parsed by `end`, `LO <= HI`; messages name `range`.
fn split_span<T: PartialOrd>(
    text: &str,
    range: &dyn std::fmt::Display,
    end: impl Fn(&str) -> Result<T, String>,
) -> Result<Span<T>, String> {
    let message = || format!("`{text}` is not LO,HI with LO <= HI, both in {range}");
    let (lo, hi) = text.split_once(',').ok_or_else(message)?;
    let (lo, hi) = (end(lo).map_err(|_| message())?, end(hi).map_err(|_| message())?);
    if lo > hi {
        return Err(message());
    }
    Ok(Span([lo, hi]))
}

/// A value parser for `LO,HI`, both ends in `interval`.
fn span(interval: Interval) -> impl Fn(&str) -> Result<Span<f64>, String> + Clone + Send + Sync + 'static {
    move |text| split_span(text, &interval, |end| interval.parse(end))
}

/// A value parser for `LO,HI`, both ends whole numbers in `lo..=hi`.
fn count_span(lo: usize, hi: usize) -> impl Fn(&str) -> Result<Span<usize>, String> + Clone + Send + Sync + 'static {
    move |text| split_span(text, &format!("{lo}..={hi}"), |end| whole(end, &lo, &hi))
}

/// Create `dir` before any work, so that a run that cannot write its results stops at
/// once, with the path named.
fn output_dir(dir: &std::path::Path) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create the output directory {}: {e}", dir.display()))
}

/// One simulation run with a progress bar on stderr.
fn simulate(config: &SimConfig) -> Result<SimResult, cbfgen::CbfError> {
    let bar = indicatif::ProgressBar::new((config.max_time * 10.0).round() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg:32} [{bar:40}] {pos}/{len} (0.1 s of simulated time)")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar.set_message(format!(
        "{} {} body SSAT CBF",
        config.scenario.name(),
        if config.body_cbf { "with" } else { "without" }
    ));
    let result = sim::run(config, |t| bar.set_position((t * 10.0) as u64));
    bar.finish_and_clear();
    result
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        // A closed pipe (`cbfgen … | head`) is the reader's choice, not an error.
        Err(e) if e.downcast_ref::<std::io::Error>().is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe) => {
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<(), Box<dyn std::error::Error>> {
    let mut stdout = std::io::stdout().lock();
    match cli.command {
        Command::Ssat(args) => args.run(&mut stdout),
        Command::Rows => rows_command(&mut stdout),
        Command::Latency(args) => args.run(&mut stdout),
        Command::Simulate(args) => args.run(&mut stdout),
        Command::Lip(args) => args.run(&mut stdout),
        Command::Multilayer(args) => args.run(&mut stdout),
        Command::Arm(args) => args.run(&mut stdout),
        Command::Perceive(args) => args.run(&mut stdout),
        Command::Campaign(args) => args.run(&mut stdout),
        Command::Merge(args) => args.run(&mut stdout),
        Command::Generate => generate_command(),
    }
}

impl SsatArgs {
    fn run(self, stdout: &mut impl Write) -> Result<(), Box<dyn std::error::Error>> {
        let Self { clearance, pitch, alpha } = self;
        let params = SmoothParams::new(alpha, alpha)?;
        // A 0.9 x 0.5 x 0.2 m body over a 4 cm edge cuboid running along y at x = 0.
        let half_body = Vector3::new(0.45, 0.25, 0.10);
        let edge = OrientedBox::axis_aligned(Vector3::new(0.0, 0.0, -0.02), Vector3::new(0.02, 1.0, 0.02))?;
        let body = OrientedBox::new(
            Vector3::new(0.0, 0.0, clearance + half_body.z),
            Rotation3::from_euler_angles(0.0, pitch, 0.0),
            half_body,
        )?;
        let d = ssat::ssat_with_derivatives(&edge, &body, &params);
        let margin = ssat::certified_margin(&edge, &body, &params);
        writeln!(stdout, "body over stair edge, clearance {clearance:.4} m, pitch {pitch:.3} rad, alpha {alpha}")?;
        writeln!(stdout, "  smooth SAT h          {:+.6} m", d.value)?;
        writeln!(stdout, "  certified margin m    {:.6} m", margin)?;
        // The certificate is h − m beyond a rounding guard (ssat::certified_clearance).
        let certified = ssat::certified_separated(&edge, &body, &params);
        writeln!(
            stdout,
            "  h - m                 {:+.6} m  ({})",
            d.value - margin,
            if certified { "certified apart" } else { "not certified" }
        )?;
        writeln!(stdout, "  exact SAT separation  {:+.6} m", sat::separation(&edge, &body))?;
        writeln!(stdout, "  dh/dp_body            [{:+.4}, {:+.4}, {:+.4}]", d.gradient.x, d.gradient.y, d.gradient.z)?;
        Ok(())
    }
}

fn rows_command(stdout: &mut impl Write) -> Result<(), Box<dyn std::error::Error>> {
    let env = Environment::new(Capacity::PAPER_WORST_CASE)?;
    let mut catalog = Catalog::new(Capacity::PAPER_WORST_CASE)?;
    catalog.evaluate(&model::standard_posture(), &env)?;
    writeln!(stdout, "joint-limit rows at the standard posture (body underside {} m up)", model::NOMINAL_CLEARANCE)?;
    writeln!(stdout, "{:<4} {:<9} {:>12} {:>12} {:>12}", "leg", "row", "h", "L_f h", "L_f^2 h")?;
    let names = cbfgen_tachyon3::generated::JOINT_LIMITS_LF_ROW_NAMES;
    for (slot, row) in catalog.slots().zip(catalog.rows()) {
        if let (Family::JointLimits, Some(leg)) = (slot.family, slot.leg) {
            writeln!(
                stdout,
                "{:<4} {:<9} {:>12.6} {:>12.6} {:>12.6}",
                model::LEG_NAMES[leg],
                names[slot.instance],
                row.lie[0],
                row.lie[1],
                row.lie[2]
            )?;
        }
    }
    Ok(())
}

impl LatencyArgs {
    fn run(self, stdout: &mut impl Write) -> Result<(), Box<dyn std::error::Error>> {
        let Self { cycles, speed, gap, solver } = self;
        let mut settings = cbfgen_tachyon3::catalog::default_settings();
        solver.apply(&mut settings);
        writeln!(stdout, "{}", latency::run(cycles, speed, gap, settings)?)?;
        Ok(())
    }
}

impl SimulateArgs {
    fn run(self, stdout: &mut impl Write) -> Result<(), Box<dyn std::error::Error>> {
        let Self {
            scenario,
            no_body_cbf,
            out,
            csv_every,
            no_osqp_reference,
            episode,
            seed,
            ranges,
            perception,
            between,
        } = self;
        output_dir(&out)?;
        let config = |body_cbf: bool| -> Result<SimConfig, cbfgen::CbfError> {
            let config = match episode {
                Some(id) => Episode::draw(seed, id, &ranges.ranges())?.config_with(body_cbf, perception),
                None => SimConfig {
                    perception: perception.then(PerceptionSettings::default),
                    ..SimConfig::new(scenario.scenario(), body_cbf)
                },
            };
            Ok(config.between_samples(between.plant(), between.certify))
        };
        if let Some(id) = episode {
            let e = Episode::draw(seed, id, &ranges.ranges())?;
            writeln!(
                stdout,
                "episode {id} of seed {seed}: {} steps of {:.4} x {:.4} m, start gap {:.4} m, gait speed {:.4} m/s",
                e.stairs.count, e.stairs.rise, e.stairs.run, e.start_gap, e.speed
            )?;
        }
        let main = simulate(&config(!no_body_cbf)?)?;
        let comparison = if no_body_cbf { None } else { Some(simulate(&config(false)?)?) };
        let osqp_reference = if no_osqp_reference || main.summary.backend == Solver::Osqp {
            None
        } else {
            let mut config = config(!no_body_cbf)?;
            config.filter.solver.backend = Solver::Osqp;
            Some(simulate(&config)?)
        };
        for run in std::iter::once(&main).chain(comparison.as_ref()).chain(osqp_reference.as_ref()) {
            writeln!(stdout, "{}", run.summary)?;
        }
        let written = output::write_all(&out, &main, comparison.as_ref(), osqp_reference.as_ref(), csv_every)?;
        print_written(stdout, &written)?;
        Ok(())
    }
}

impl LipArgs {
    fn run(self, stdout: &mut impl Write) -> Result<(), Box<dyn std::error::Error>> {
        use cbfgen_lip::scenario::{run, Scenario};
        use cbfgen_lip::{BarrierForm, HeadingRule, LipParams};
        let Self { out, steps, course, delta, barrier, heading } = self;
        output_dir(&out)?;
        let course = match course {
            LipCourse::Standard => Scenario::standard(),
            LipCourse::Corner => Scenario::corner(),
        };
        let barrier = match barrier {
            LipBarrier::Unit => BarrierForm::UnitNormal,
            LipBarrier::Report => BarrierForm::ReportNormal,
        };
        let heading = match heading {
            LipHeading::PerStep => HeadingRule::PerStepRate,
            LipHeading::Report => HeadingRule::Report,
        };
        let params = LipParams { delta, barrier, heading, ..course.params };
        let scenario = Scenario { max_steps: steps, params, ..course };
        let result = run(&scenario)?;
        writeln!(stdout, "{}", result.summary())?;
        let baseline = if delta > 0.0 { Some(run(&scenario.with_delta(0.0))?) } else { None };
        if let Some(b) = &baseline {
            writeln!(stdout, "\nThe same course with δ = 0 (Peng et al.'s LDCBF):\n{}", b.summary())?;
        }
        let written = cbfgen_lip::figure::write_all(&out, &result, baseline.as_ref())?;
        print_written(stdout, &written)?;
        Ok(())
    }
}

impl MultilayerArgs {
    fn run(self, stdout: &mut impl Write) -> Result<(), Box<dyn std::error::Error>> {
        let Self { out } = self;
        output_dir(&out)?;
        let config = cbfgen_multilayer::ScenarioConfig::default();
        let results = cbfgen_multilayer::scenario::run_all(&config)?;
        let [a, omega, c] = config.barrier.parameters();
        writeln!(
            stdout,
            "double integrator above {a} sin({omega} t) + ({c}) m, from q = {} m at rest, {} s",
            config.x0[0], config.duration
        )?;
        write!(stdout, "{}", cbfgen_multilayer::scenario::table(&results))?;
        let written = cbfgen_multilayer::scenario::write_figures(&out, &config, &results)?;
        print_written(stdout, &written)?;
        Ok(())
    }
}

impl ArmArgs {
    fn run(self, stdout: &mut impl Write) -> Result<(), Box<dyn std::error::Error>> {
        let Self { out, csv_every } = self;
        output_dir(&out)?;
        let scenario = cbfgen_panda::Scenario::standard();
        let with = cbfgen_panda::run(&scenario)?;
        let without = cbfgen_panda::run(&scenario.clone().without_filter())?;
        write!(stdout, "{with}{without}")?;
        let written = cbfgen_panda::output::write_all(&out, &with, Some(&without), csv_every)?;
        print_written(stdout, &written)?;
        Ok(())
    }
}

impl PerceiveArgs {
    fn run(self, stdout: &mut impl Write) -> Result<(), Box<dyn std::error::Error>> {
        let Self { out, seed } = self;
        output_dir(&out)?;
        perceive(stdout, &out, seed)
    }
}

impl CampaignArgs {
    fn run(self, stdout: &mut impl Write) -> Result<(), Box<dyn std::error::Error>> {
        let Self { episodes, seed, first_id, no_body_cbf, threads, out, ranges, perception, shard, between } = self;
        let out = out.unwrap_or_else(|| match shard {
            Some((index, count)) => format!("out/campaign/shard-{index}-of-{count}").into(),
            None => "out/campaign".into(),
        });
        output_dir(&out)?;
        let mut settings = CampaignSettings {
            seed,
            episodes,
            first_id,
            ranges: ranges.ranges(),
            body_cbf: !no_body_cbf,
            threads,
            perception,
            plant: between.plant(),
            certify: between.certify,
            time_bound_us: None,
        };
        if let Some((index, count)) = shard {
            settings = settings.shard(index, count)?;
            let last = settings.first_id + settings.episodes as u64 - 1;
            writeln!(stdout, "shard {index}/{count}: episodes {} to {last}", settings.first_id)?;
        }
        // Measured before the episodes start, on a quiet machine.
        settings = settings.with_time_bound()?;
        match settings.time_bound_us {
            Some(us) => writeln!(stdout, "worst case per update on this machine: {us:.1} µs of CPU time")?,
            None => writeln!(stdout, "worst case per update: not stated in time (a part states no count)")?,
        }
        let episodes = settings.episodes;
        let bar = indicatif::ProgressBar::new(episodes as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template("campaign {bar:40} {pos}/{len} episodes, {elapsed} (eta {eta})")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        let started = std::time::Instant::now();
        let result = campaign::run(&settings, |_| bar.inc(1))?;
        bar.finish_and_clear();
        writeln!(
            stdout,
            "campaign: {episodes} episodes of seed {seed} {} body SSAT CBF, {:.0} s",
            if no_body_cbf { "without" } else { "with" },
            started.elapsed().as_secs_f64()
        )?;
        let report = result.report();
        writeln!(stdout, "{report}")?;
        let written = campaign::output::write_all(&out, &result)?;
        print_written(stdout, &written)?;
        if !report.errors.is_empty() {
            return Err(format!("{} episodes ended with an error", report.errors.len()).into());
        }
        Ok(())
    }
}

impl MergeArgs {
    fn run(self, stdout: &mut impl Write) -> Result<(), Box<dyn std::error::Error>> {
        let Self { shards, out } = self;
        let mut texts = Vec::with_capacity(shards.len());
        for path in &shards {
            let file = if path.is_dir() { path.join("episodes.csv") } else { path.clone() };
            texts.push(std::fs::read_to_string(&file).map_err(|e| format!("cannot read {}: {e}", file.display()))?);
        }
        let rows = campaign::table::merge(&texts)?;
        let (first, last) = (rows[0].id, rows[rows.len() - 1].id);
        writeln!(
            stdout,
            "merged {} shards: {} episodes of seed {}, ids {first} to {last}",
            shards.len(),
            rows.len(),
            rows[0].seed
        )?;
        for (a, b) in campaign::table::gaps(&rows) {
            writeln!(stdout, "missing: episodes {a} to {b} (a shard that did not run?)")?;
        }
        let report = campaign::Report::of(&rows);
        writeln!(stdout, "{report}")?;
        output_dir(&out)?;
        let written = campaign::output::write_rows(&out, &rows)?;
        print_written(stdout, &written)?;
        Ok(())
    }
}

fn generate_command() -> Result<(), Box<dyn std::error::Error>> {
    // The repository this binary was built from (the CLI crate sits one folder below it).
    let root = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    let python = cbfgen_build::python_interpreter(&[root]);
    let status = std::process::Command::new(&python).args(["-m", "symbolic.generate"]).current_dir(root).status()?;
    if !status.success() {
        return Err(format!("`{} -m symbolic.generate` failed; run `scripts/cbf setup` first", python.display()).into());
    }
    Ok(())
}

/// The "wrote a, b, c" line every command that writes files ends with.
fn print_written(out: &mut impl Write, written: &[std::path::PathBuf]) -> std::io::Result<()> {
    writeln!(out, "wrote {}", written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "))
}

/// `cbfgen perceive`: scan the hardware stairs, extract planes and cuboids, compare them
/// with the true nosings and draw both views.
fn perceive(out: &mut impl Write, dir: &std::path::Path, seed: u64) -> Result<(), Box<dyn std::error::Error>> {
    use cbfgen_perception::{edges, figure, planes, scanner::Lidar};
    use cbfgen_tachyon3::terrain::edge_match;
    use rand::SeedableRng;

    let terrain = cbfgen_tachyon3::terrain::Stairs::HARDWARE.terrain()?;
    let world = terrain.solid_boxes()?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut map = Vec::new();
    for x in [0.0, 0.25, 0.5, 0.75] {
        map.extend(Lidar::default().scan(&Vector3::new(x, 0.0, 0.6), 0.0, &world, &[], &mut rng)?);
    }
    let settings = planes::SegmentSettings { viewpoint: Vector3::new(0.0, 0.0, 0.6), ..Default::default() };
    let found = planes::segment(&map, &settings)?;
    let cuboids = edges::edge_cuboids(&found, &map, &edges::EdgeSettings::default())?;
    writeln!(out, "{} points from 4 scans; {} planes, {} edge cuboids", map.len(), found.len(), cuboids.len())?;
    for (k, p) in found.iter().enumerate() {
        writeln!(
            out,
            "  plane {k}: normal ({:+.3}, {:+.3}, {:+.3}), offset {:+.4} m, {} points",
            p.normal.x, p.normal.y, p.normal.z, p.offset, p.inliers
        )?;
    }
    let truth = terrain.edge_boxes()?;
    for (k, (b, matched)) in truth.iter().zip(edge_match::match_nosings(&truth, &cuboids)).enumerate() {
        let (x, z) = (b.center().x, b.center().z);
        match matched {
            Some(m) => writeln!(
                out,
                "  nosing {k} (x {x:.3}, z {z:.3}): found {:.1} mm off, {:.2} deg, {:.2} m long",
                m.offset * 1e3,
                m.skew_deg,
                m.length
            )?,
            None => writeln!(out, "  nosing {k} (x {x:.3}, z {z:.3}): not found")?,
        }
    }
    let charts: Vec<(String, cbfgen_chart::Chart)> = figure::side_and_top(&map, &found, &cuboids, &truth)
        .into_iter()
        .map(|(name, chart)| (format!("perception_{name}"), chart))
        .collect();
    let written = cbfgen_chart::write_charts(dir, &charts)?;
    print_written(out, &written)?;
    Ok(())
}
