//! Closed-loop simulation of the Tachyon 3 kinematic model at 1 kHz (paper section V-B):
//! the nominal gait of [`gait`] → [`EcbfFilter`] → the plant `ẋ = f(x) + g(x) u`, by
//! default one explicit Euler step per period (the paper's simulation); with
//! [`Plant::Held`], the input held over the period on the continuous model and every
//! clearance and `h` measured at each fine step between the samples.
//!
//! Two scenarios: `step` (one 16.5 cm step, the robot starting in its low standard
//! posture) and `stairs` (five steps, 16.5 cm high and 35 cm deep, as in the hardware
//! experiment). Every cycle records the state, each family's minimum `h`, the active
//! rows, the time spent (wall and thread CPU time) and the exact clearance of the body
//! and the wheels to the true terrain's solids, the floor and every step as a block
//! (exact SAT for the body, exact sphere–box distance for the wheels; see
//! [`terrain::solid`](crate::terrain::solid)).

pub mod animation;
pub mod campaign;
mod course;
pub mod foothold_swing;
pub mod gait;
pub mod output;
pub mod perceived;

pub use course::Course;

use std::time::Instant;

use crate::catalog::{self, Catalog, Family, FAMILY_COUNT};
use crate::generated as gen;
use crate::model::{self, State, NU};
use crate::sim::perceived::{Perceiver, PerceptionSettings, PerceptionUpdate};
use crate::terrain::route::Route;
use crate::terrain::solid::{Contact, TerrainClearance, PENETRATION_TOLERANCE};
use crate::terrain::{Stairs, Terrain};
use cbfgen::error::CbfError;
use cbfgen::filter::{BetweenSamples, EcbfFilter, FilterSettings, InputSource, Work, WorstCase};
use cbfgen::system::BarrierSet;
use cbfgen_perception::worker::Perceived;
use gait::GaitParams;

/// Control period \[s\].
pub const DT: f64 = 1e-3;

/// Most fine steps per period [`Plant::Held`] accepts (RK4 at `DT / 1000` = 1 µs).
pub const MAX_FINE_STEPS: usize = 1000;

/// How the plant moves over each control period.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Plant {
    /// One explicit Euler step of `DT` per period, the paper's simulation: clearances and
    /// `h` are measured at the samples only.
    #[default]
    Euler,
    /// The input held for the whole period (zero-order hold) on the continuous model,
    /// integrated by RK4 at `DT / fine`; each sample's clearances and `h` are the least
    /// over its sample and the `fine` states after it, so a run's minima hold at every
    /// fine step, between the samples too. 1 to [`MAX_FINE_STEPS`].
    Held {
        /// RK4 steps per period.
        fine: usize,
    },
}

impl Plant {
    /// `Held { fine }` for `Some(fine)`, [`Plant::Euler`] for `None` (how the command line
    /// and Python give it).
    pub fn from_fine_steps(fine: Option<usize>) -> Self {
        fine.map_or(Plant::Euler, |fine| Plant::Held { fine })
    }

    /// Fine steps per period: 0 for [`Plant::Euler`] (measured at the samples only).
    pub fn fine_steps(self) -> usize {
        match self {
            Plant::Euler => 0,
            Plant::Held { fine } => fine,
        }
    }

    /// # Errors
    /// [`Plant::Held`] with `fine` outside `1..=`[`MAX_FINE_STEPS`].
    pub fn validate(self) -> Result<(), CbfError> {
        match self {
            Plant::Held { fine } if !(1..=MAX_FINE_STEPS).contains(&fine) => {
                Err(CbfError::OutOfRange { what: "fine steps per period", value: fine as f64, range: "1..=1000" })
            }
            _ => Ok(()),
        }
    }
}

/// Longest simulated time \[s\] a run accepts: 6·10⁵ cycles, about 250 MB of samples.
/// The courses finish in under a minute; the limit only stops a typo from asking for
/// terabytes.
pub const MAX_SIM_TIME: f64 = 600.0;

/// Time a run on `terrain` gets to finish \[s\]: 20 s to reach the first change and
/// settle at the end, and 10 s per change of height (the slowest gait climbs a step in
/// about 6 s), at most [`MAX_SIM_TIME`].
pub fn time_allowed(terrain: &Terrain) -> f64 {
    (20.0 + 10.0 * terrain.changes().len() as f64).min(MAX_SIM_TIME)
}

/// Time a run on `route` gets to finish \[s\]: each flight's [`time_allowed`] and, for
/// each turn between flights, twice the time its turning swings take
/// ([`gait::turn_time`]), at most [`MAX_SIM_TIME`]. On one flight, its terrain's
/// [`time_allowed`].
pub fn route_time_allowed(route: &Route) -> f64 {
    let flights = route.flights();
    let climbing = flights.iter().map(|f| time_allowed(&f.terrain)).sum::<f64>();
    let stance = gait::GaitParams::default().stance_time;
    let turning = flights
        .windows(2)
        .map(|pair| 2.0 * gait::turn_time(pair[1].placement.heading - pair[0].placement.heading, stance))
        .sum::<f64>();
    (climbing + turning).min(MAX_SIM_TIME)
}

/// Which course the robot runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scenario {
    /// One step of the hardware stairs' size.
    Step,
    /// Five steps, 16.5 cm × 35 cm.
    Stairs,
    /// A staircase of any dimensions (the Monte Carlo campaign's courses, see
    /// `campaign`).
    Custom(Stairs),
    /// Four steps of unequal rise and run ([`Terrain::unequal_rises`]).
    UnequalRises,
    /// Three steps, a landing, two steps ([`Terrain::landing`]).
    Landing,
    /// A single 12 cm box to cross, up and down ([`Terrain::single_box`]).
    Box,
    /// A 20 cm platform to climb onto and roll off ([`Terrain::platform`]).
    Platform,
    /// Three steps, a 90° left turn on a landing, three steps
    /// ([`Route::turn_on_landing`]).
    Turn,
}

impl Scenario {
    /// The named scenarios, in the order the CLI and Python list them.
    pub const NAMED: [Scenario; 7] = [
        Scenario::Step,
        Scenario::Stairs,
        Scenario::UnequalRises,
        Scenario::Landing,
        Scenario::Box,
        Scenario::Platform,
        Scenario::Turn,
    ];

    /// The time a run of this course gets to finish \[s\]: 25 s (step), 60 s (stairs) or
    /// [`route_time_allowed`] (the others).
    pub fn time_allowed(self) -> f64 {
        match self {
            Scenario::Step => 25.0,
            Scenario::Stairs => 60.0,
            // A terrain that fails to build fails the run instead, with its error.
            other => other.route().map_or(MAX_SIM_TIME, |route| route_time_allowed(&route)),
        }
    }

    /// The whole course: one flight along x, or flights joined by turns.
    ///
    /// # Errors
    /// Custom stairs that fail [`Stairs::validate`].
    pub fn route(self) -> Result<Route, CbfError> {
        match self {
            Scenario::Turn => Ok(Route::turn_on_landing()),
            _ => self.terrain().map(Route::straight),
        }
    }

    /// The terrain of this course: its first flight's, for a course with turns
    /// ([`Scenario::route`]).
    ///
    /// # Errors
    /// Custom stairs that fail [`Stairs::validate`].
    pub fn terrain(self) -> Result<Terrain, CbfError> {
        match self {
            Scenario::Turn => Ok(Route::turn_on_landing().flights()[0].terrain.clone()),
            Scenario::Step => Stairs::SINGLE_STEP.terrain(),
            Scenario::Stairs => Stairs::HARDWARE.terrain(),
            Scenario::Custom(stairs) => stairs.terrain(),
            Scenario::UnequalRises => Ok(Terrain::unequal_rises()),
            Scenario::Landing => Ok(Terrain::landing()),
            Scenario::Box => Ok(Terrain::single_box()),
            Scenario::Platform => Ok(Terrain::platform()),
        }
    }

    /// Short name, as used in file names and printouts: `step`, `stairs`, `custom`,
    /// `unequal_rises`, `landing`, `box`, `platform` or `turn`.
    pub fn name(self) -> &'static str {
        match self {
            Scenario::Step => "step",
            Scenario::Stairs => "stairs",
            Scenario::Custom(_) => "custom",
            Scenario::UnequalRises => "unequal_rises",
            Scenario::Landing => "landing",
            Scenario::Box => "box",
            Scenario::Platform => "platform",
            Scenario::Turn => "turn",
        }
    }
}

/// One simulation run's set-up.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// The course to run.
    pub scenario: Scenario,
    /// With `false`, the body–edge SSAT rows never take part (the paper's comparison).
    pub body_cbf: bool,
    /// Give up after this long \[s\], at most [`MAX_SIM_TIME`].
    pub max_time: f64,
    /// Start with the robot's foremost point this far from the first riser \[m\].
    pub start_gap: f64,
    /// The nominal gait's speeds, timings and step geometry.
    pub gait: GaitParams,
    /// The ECBF-QP filter's settings (gains, weights, activation thresholds, OSQP).
    pub filter: FilterSettings<NU>,
    /// With `Some`, the gait and the filter see only what a LiDAR on the body perceives
    /// of the terrain ([`perceived`]); with `None`
    /// (the default), the true terrain.
    pub perception: Option<PerceptionSettings>,
    /// How the plant moves between the samples, and where safety is measured.
    pub plant: Plant,
    /// The filter's worst case per update in CPU time on this machine \[µs\]
    /// ([`time_bound_us`]), against which each update is counted
    /// ([`Summary::over_time_bound`]); `None`: not counted.
    pub time_bound_us: Option<f64>,
}

impl SimConfig {
    /// The standard run of `scenario`: default gait and filter settings, 0.3 m start gap, and
    /// [`Scenario::time_allowed`] to finish. With `body_cbf == false` the body–edge family's
    /// activation threshold is set to −∞, so its rows never take part.
    pub fn new(scenario: Scenario, body_cbf: bool) -> Self {
        let mut filter = catalog::default_settings();
        filter.measure_cpu_time = true;
        if !body_cbf {
            filter.family_mut(Family::BodyEdge.index()).activation = f64::NEG_INFINITY;
        }
        let max_time = scenario.time_allowed();
        Self {
            scenario,
            body_cbf,
            max_time,
            start_gap: 0.3,
            gait: GaitParams::default(),
            filter,
            perception: None,
            plant: Plant::Euler,
            time_bound_us: None,
        }
    }

    /// The same run on `plant`, with the filter certifying each input between the
    /// samples when `certify` is set
    /// ([`SampledData::every_family`](cbfgen::filter::SampledData::every_family) at the
    /// period [`DT`]).
    pub fn between_samples(mut self, plant: Plant, certify: bool) -> Self {
        self.plant = plant;
        if certify {
            self.filter.sampled_data = Some(cbfgen::filter::SampledData::every_family(DT));
        }
        self
    }
}

/// One control cycle's record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time at the start of the cycle \[s\].
    pub t: f64,
    /// State at the start of the cycle, before this cycle's input is applied.
    pub x: State,
    /// Minimum `h` over each family's applicable rows, [`Family::index`] order
    /// (`f64::INFINITY` where none applies). A culled row counts with its lower bound,
    /// which is above the family's activation threshold
    /// ([`Row::culled`](cbfgen::system::Row::culled)). With [`Plant::Held`], the least
    /// over the sample and every fine step of the period after it.
    pub min_h: [f64; FAMILY_COUNT],
    /// Rows that took part in the QP (applicable and below their family's activation
    /// threshold): the rows applied, Fig. 9's count.
    pub active_rows: usize,
    /// Rows computed this cycle: those whose instance is filled and whose condition holds
    /// ([`Row::active`](cbfgen::system::Row::active)), evaluated in full or culled by their
    /// lower bound. Empty slots of the catalog's [`Capacity`](crate::catalog::Capacity)
    /// (edge slots beyond the course's edges, foothold slots beyond a leg's half-planes)
    /// are not computed and do not count.
    pub computed_rows: usize,
    /// Of the computed rows, those culled: their lower bound on `h` was above the
    /// activation threshold, so only the bound was computed and they could not be applied
    /// ([`Row::culled`](cbfgen::system::Row::culled)).
    pub culled_rows: usize,
    /// Rows each family had relaxed at the applied input (the filter's verdict,
    /// [`Family::index`] order): 0 everywhere when every active row was met.
    pub relaxed_rows: [usize; FAMILY_COUNT],
    /// How far the ground-moving origin jumped at the start of this cycle \[m\], with
    /// [`OriginRule::JumpAtExchange`](gait::OriginRule::JumpAtExchange) at a support exchange.
    pub origin_jump: Option<f64>,
    /// OSQP's ADMM iterations in this cycle's solve.
    pub iterations: u32,
    /// Where the applied input came from: the QP's optimum or one of the fallbacks.
    pub source: InputSource,
    /// Time in row evaluation and activation \[µs\].
    pub eval_us: f64,
    /// Time in the QP update and solve \[µs\].
    pub solve_us: f64,
    /// The whole filter update, timed around the call \[µs\].
    pub update_us: f64,
    /// The thread's CPU time over the whole filter update
    /// ([`FilterOutput::cpu_time`](cbfgen::filter::FilterOutput::cpu_time), on in the
    /// standard configuration) \[µs\]; 0 where it is off or the platform has no thread clock. Well below `update_us` means the thread waited
    /// (a VM stall, preemption) rather than worked.
    pub cpu_us: f64,
    /// The filter update's work, counted as it ran
    /// ([`FilterOutput::work`](cbfgen::filter::FilterOutput::work)).
    pub work: Work,
    /// Exact clearances of the body and the wheels to the true terrain's solids, with
    /// where each is nearest: at the sample, or with [`Plant::Held`] the least over the
    /// sample and every fine step of the period after it.
    pub clearance: TerrainClearance,
    /// Whether the filter certified this cycle's input between the samples
    /// ([`FilterSettings::sampled_data`]; [`BetweenSamples::Off`] without it).
    pub between_samples: BetweenSamples,
    /// Body centre height above the gait's nominal \[m\].
    pub body_raise: f64,
    /// Which tripod swings (-1: none).
    pub swinging: i8,
}

/// What a run established.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// The course that was run.
    pub scenario: Scenario,
    /// Whether the body–edge SSAT rows could take part (see [`SimConfig::body_cbf`]).
    pub body_cbf: bool,
    /// The filter's QP backend in this run.
    pub backend: cbfgen::qp::Solver,
    /// Every toe stands on the top level, and the body centre is past the last riser.
    pub completed: bool,
    /// Time of the last recorded cycle \[s\] (a completed run goes on 1 s past completion).
    pub duration: f64,
    /// How the plant moved: with [`Plant::Held`] every clearance and `h` below is the
    /// least over every fine step, between the samples too.
    pub plant: Plant,
    /// Cycles whose input the filter certified between the samples; `None` when the
    /// filter's certificate was off ([`FilterSettings::sampled_data`]).
    pub certified_cycles: Option<usize>,
    /// Control cycles run (filter updates).
    pub cycles: usize,
    /// The body's closest approach to the solid terrain over the run (its deepest
    /// overlap with a solid, if it went in); `None` for a run of no cycle.
    pub body_nearest: Option<Approach>,
    /// The closest approach of any wheel to the solid terrain (about 0: a wheel on its
    /// tread touches it; negative = depth into a solid).
    pub toe_nearest: Option<Approach>,
    /// The closest approach of any wheel to a riser (a contact normal more than 30° from
    /// vertical, [`Face::Riser`](crate::terrain::solid::Face::Riser)).
    pub toe_riser_nearest: Option<Approach>,
    /// Cycles in which a wheel touched or entered a riser (riser clearance ≤ 0).
    pub riser_contact_cycles: usize,
    /// Minimum `h` of each family over the run, [`Family::index`] order, in each family's own
    /// units (`f64::INFINITY` where no row ever applied).
    pub min_h: [f64; FAMILY_COUNT],
    /// Largest excess of the body centre height over the gait's nominal \[m\].
    pub max_body_raise: f64,
    /// Slowest filter update \[µs\].
    pub max_update_us: f64,
    /// 99th-percentile filter update time (nearest rank) \[µs\].
    pub p99_update_us: f64,
    /// Median filter update time (nearest rank) \[µs\].
    pub median_update_us: f64,
    /// Largest thread CPU time of a filter update ([`Sample::cpu_us`]) \[µs\].
    pub max_cpu_us: f64,
    /// 99th-percentile thread CPU time of a filter update (nearest rank) \[µs\].
    pub p99_cpu_us: f64,
    /// Median thread CPU time of a filter update (nearest rank) \[µs\].
    pub median_cpu_us: f64,
    /// Cycles whose filter update took longer than the 1 ms control period of wall time
    /// ([`Sample::update_us`] above 1000).
    pub over_period_wall: usize,
    /// Cycles whose filter update took longer than the 1 ms control period of CPU time
    /// ([`Sample::cpu_us`] above 1000).
    pub over_period_cpu: usize,
    /// Cycles whose input was not a QP optimum ([`InputSource::Qp`]): unconverged iterates and
    /// fallbacks.
    pub fallback_cycles: usize,
    /// The most one update of this run's filter can do, stated from its size and settings
    /// ([`EcbfFilter::worst_case`]).
    pub worst_case: WorstCase,
    /// The most each count of [`Sample::work`] reached over the run (each its own maximum).
    pub max_work: Work,
    /// Updates whose counted work went beyond [`Summary::worst_case`]: 0, or the bound is
    /// wrong.
    pub over_worst_case: usize,
    /// Updates whose CPU time went beyond [`SimConfig::time_bound_us`] (0 without one):
    /// on a quiet machine, none.
    pub over_time_bound: usize,
    /// Per family ([`Family::index`] order): cycles in which the filter reported rows of it
    /// relaxed (missed at the applied input, beyond the solver's rounding).
    pub relaxed_cycles: [usize; FAMILY_COUNT],
    /// Perception's figures, for a run on perceived terrain.
    pub perception: Option<PerceptionSummary>,
}

/// What perception did in a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerceptionSummary {
    /// Updates applied (the one before the start included).
    pub updates: usize,
    /// Median wall time of an update on the worker thread \[ms\].
    pub median_ms: f64,
    /// Slowest update on the worker thread \[ms\].
    pub max_ms: f64,
    /// Map points (voxel centroids) the last update segmented.
    pub last_map_points: usize,
    /// Edge cuboids the last update found.
    pub last_cuboids: usize,
}

/// Where and when a part of the robot came closest to (or went deepest into) the solid
/// terrain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Approach {
    /// Time \[s\].
    pub t: f64,
    /// Which part, which solid, which face, how far.
    pub contact: Contact,
}

impl Summary {
    /// Smallest exact clearance of the body to the solid terrain over the run \[m\];
    /// negative = depth into a solid; `+∞` for a run of no cycle.
    pub fn min_body_clearance(&self) -> f64 {
        self.body_nearest.map_or(f64::INFINITY, |a| a.contact.distance)
    }

    /// Smallest exact clearance of any wheel to the solid terrain over the run \[m\]:
    /// about 0 (a wheel on its tread); negative = depth into a solid.
    pub fn min_toe_clearance(&self) -> f64 {
        self.toe_nearest.map_or(f64::INFINITY, |a| a.contact.distance)
    }

    /// Smallest exact clearance of any wheel to a riser over the run \[m\].
    pub fn min_toe_riser_clearance(&self) -> f64 {
        self.toe_riser_nearest.map_or(f64::INFINITY, |a| a.contact.distance)
    }

    /// The body or a wheel went more than `tolerance` \[m\] into a solid of the terrain.
    pub fn collided(&self, tolerance: f64) -> bool {
        self.min_body_clearance() < -tolerance || self.min_toe_clearance() < -tolerance
    }

    /// [`Summary::collided`] beyond the documented [`PENETRATION_TOLERANCE`] (1 mm).
    pub fn penetrated(&self) -> bool {
        self.collided(PENETRATION_TOLERANCE)
    }
}

/// A finished run.
#[derive(Debug, Clone)]
pub struct SimResult {
    /// One record per control cycle, in time order.
    pub samples: Vec<Sample>,
    /// What the run established.
    pub summary: Summary,
    /// For a run on perceived terrain: every update, and the last one's map, planes and
    /// cuboids.
    pub perception: Option<PerceptionRun>,
}

/// Perception's record of a run.
#[derive(Debug, Clone)]
pub struct PerceptionRun {
    /// Every update applied, in order.
    pub updates: Vec<PerceptionUpdate>,
    /// The last update's output.
    pub last: Option<Perceived>,
}

/// Run `config` to completion or `max_time`, calling `progress(t)` every 100 cycles. With
/// [`SimConfig::perception`], a perception worker thread runs beside the loop.
///
/// # Errors
/// `max_time` outside `(0, MAX_SIM_TIME]`, filter construction, or a state that left
/// the model's domain.
pub fn run(config: &SimConfig, progress: impl FnMut(f64)) -> Result<SimResult, CbfError> {
    run_observed(config, progress, |_, _| {})
}

/// [`run`], calling `observe(t, filter)` after every filter update: to look at (or
/// record, with [`EcbfFilter::recorded_qp`]) what the filter saw and solved each cycle.
///
/// # Errors
/// As [`run`].
pub fn run_observed(
    config: &SimConfig,
    mut progress: impl FnMut(f64),
    mut observe: impl FnMut(f64, &EcbfFilter<Catalog, NU>),
) -> Result<SimResult, CbfError> {
    cbfgen::error::within("max_time [s]", config.max_time, DT, MAX_SIM_TIME, "[0.001, 600]")?;
    config.plant.validate()?;
    let mut course = Course::new(config.scenario, config.gait)?;
    let mut filter = EcbfFilter::new(Catalog::new(Course::CAPACITY)?, config.filter.clone())?;
    // The rows at the fine steps, computed as the filter computes them (culled by the
    // same thresholds), so a fine step's `h` means what a sample's does.
    let mut between = match config.plant {
        Plant::Euler => None,
        Plant::Held { .. } => {
            let mut rows = Catalog::new(Course::CAPACITY)?;
            let thresholds: Vec<f64> = config
                .filter
                .families
                .iter()
                .map(|p| if config.filter.cull_far_rows { p.activation } else { f64::INFINITY })
                .collect();
            rows.cull_above(&thresholds);
            Some(rows)
        }
    };
    let mut x = course.initial_state(config.start_gap);
    let mut perceiver = config.perception.map(|p| Perceiver::new(p, course.perceivable()?)).transpose()?;
    if let Some(perceiver) = &mut perceiver {
        perceiver.start(&x, &mut course)?;
    }

    let steps = (config.max_time / DT).ceil() as usize;
    // Grown as the run goes: a run that finishes early never holds max_time's worth.
    let mut samples = Vec::new();
    let mut completed_at = None;
    for k in 0..steps {
        let t = k as f64 * DT;
        if let Some(perceiver) = &mut perceiver {
            perceiver.step(t, &x, &mut course)?;
        }
        let origin_jump = course.exchange_origin(t, &mut x);
        let plan = course.plan(t, &x)?;
        let start = Instant::now();
        let out = *filter.update(&x, &plan.u_ref, course.environment())?;
        let update_us = start.elapsed().as_secs_f64() * 1e6;

        observe(t, &filter);
        let clearance = course.clearance(&x)?;
        let mut min_h = [f64::INFINITY; FAMILY_COUNT];
        let (computed_rows, culled_rows) = least_h(filter.barriers(), &mut min_h);
        let (body_center, _, _) = gen::world_kinematics(&x);
        let mut sample = Sample {
            t,
            x,
            min_h,
            active_rows: out.active_rows,
            computed_rows,
            culled_rows,
            // The filter's families are the spec's, which `Family` follows.
            relaxed_rows: std::array::from_fn(|f| filter.relaxation()[f].relaxed_rows),
            origin_jump,
            iterations: out.iterations,
            source: out.source,
            eval_us: out.eval_time.as_secs_f64() * 1e6,
            solve_us: out.solve_time.as_secs_f64() * 1e6,
            update_us,
            cpu_us: out.cpu_time.unwrap_or_default().as_secs_f64() * 1e6,
            work: out.work,
            clearance,
            between_samples: out.between_samples,
            body_raise: body_center[2] - plan.body_height,
            swinging: course.swinging().map_or(-1, |s| s as i8),
        };
        let finished = course.finished(&x);

        match &mut between {
            // Set up exactly when the plant is held (above).
            Some(rows) => {
                let fine = config.plant.fine_steps();
                let h = DT / fine as f64;
                for j in 1..=fine {
                    x = model::held_step(&x, &out.u, h);
                    BarrierSet::evaluate(rows, t + j as f64 * h, &x, course.environment())?;
                    least_h(rows, &mut sample.min_h);
                    sample.clearance = sample.clearance.nearer(course.clearance(&x)?);
                }
            }
            None => {
                let dx = model::xdot(&x, &out.u);
                for (v, d) in x.iter_mut().zip(dx) {
                    *v += d * DT;
                }
            }
        }
        samples.push(sample);
        if k % 100 == 0 {
            progress(t);
        }
        match completed_at {
            None if finished => completed_at = Some(t),
            Some(done) if t - done > 1.0 => break,
            _ => {}
        }
    }
    let perception = perceiver.map(|p| {
        let (updates, last) = p.finish();
        PerceptionRun { updates, last }
    });
    let worst_case = filter.worst_case();
    let summary = summarize(config, &samples, completed_at.is_some(), perception.as_ref(), worst_case);
    Ok(SimResult { samples, summary, perception })
}

/// The worst case of one update of `config`'s filter in CPU time on this machine \[µs\]:
/// its stated counts ([`EcbfFilter::worst_case`]) at the rates
/// [`EcbfFilter::calibrate`] measures now, on the filter a run of `config` builds, with
/// its rows at the latency harness's start (the robot before the hardware stairs).
/// `None` where the worst case states no time. Takes about a tenth of a second (more with
/// the certificate, whose enclosures are timed too).
///
/// # Errors
/// The filter's or the course's construction.
pub fn time_bound_us(config: &SimConfig) -> Result<Option<f64>, CbfError> {
    let mut filter = EcbfFilter::new(Catalog::new(Course::CAPACITY)?, config.filter.clone())?;
    let drive = crate::approach::Approach::new(Course::CAPACITY, Stairs::HARDWARE, 0.6, 0.3)?;
    let calibration = filter.calibrate(0.0, &drive.x, &drive.env)?;
    Ok(filter.worst_case().micros(&calibration))
}

/// Fold the applicable rows of `rows` into each family's least `h`; returns how many
/// rows were computed and how many of those culled (by their lower bound).
fn least_h(rows: &Catalog, min_h: &mut [f64; FAMILY_COUNT]) -> (usize, usize) {
    let (mut computed, mut culled) = (0, 0);
    for (row, slot) in rows.rows().iter().zip(rows.slots()) {
        if row.active {
            computed += 1;
            culled += usize::from(row.culled);
            let m = &mut min_h[slot.family.index()];
            *m = m.min(row.h());
        }
    }
    (computed, culled)
}

/// `[median, p99, max]` (nearest rank) of one timing of the samples \[µs\], zeros when there
/// are none.
fn percentiles(samples: &[Sample], f: fn(&Sample) -> f64) -> [f64; 3] {
    cbfgen::cpu_time::median_p99_max(&mut samples.iter().map(f).collect::<Vec<_>>())
}

/// The sample at which `contact` of its clearance is nearest, as an [`Approach`].
fn nearest(samples: &[Sample], contact: fn(&TerrainClearance) -> Option<Contact>) -> Option<Approach> {
    samples
        .iter()
        .filter_map(|s| contact(&s.clearance).map(|contact| Approach { t: s.t, contact }))
        .min_by(|a, b| a.contact.distance.total_cmp(&b.contact.distance))
}

fn summarize(
    config: &SimConfig,
    samples: &[Sample],
    completed: bool,
    perception: Option<&PerceptionRun>,
    worst_case: WorstCase,
) -> Summary {
    let [median_update_us, p99_update_us, max_update_us] = percentiles(samples, |s| s.update_us);
    let [median_cpu_us, p99_cpu_us, max_cpu_us] = percentiles(samples, |s| s.cpu_us);
    let period_us = crate::latency::PERIOD.as_micros() as f64;
    let over = |f: fn(&Sample) -> f64| samples.iter().filter(|&s| f(s) > period_us).count();
    let mut min_h = [f64::INFINITY; FAMILY_COUNT];
    for s in samples {
        for (m, h) in min_h.iter_mut().zip(s.min_h) {
            *m = m.min(h);
        }
    }
    Summary {
        scenario: config.scenario,
        body_cbf: config.body_cbf,
        backend: config.filter.solver.backend,
        completed,
        duration: samples.last().map_or(0.0, |s| s.t),
        plant: config.plant,
        certified_cycles: config
            .filter
            .sampled_data
            .is_some()
            .then(|| samples.iter().filter(|s| matches!(s.between_samples, BetweenSamples::Certified { .. })).count()),
        cycles: samples.len(),
        body_nearest: nearest(samples, |c| Some(c.body)),
        toe_nearest: nearest(samples, |c| Some(c.wheel)),
        toe_riser_nearest: nearest(samples, |c| c.wheel_riser),
        riser_contact_cycles: samples
            .iter()
            .filter(|s| s.clearance.wheel_riser.is_some_and(|c| c.distance <= 0.0))
            .count(),
        min_h,
        max_body_raise: samples.iter().map(|s| s.body_raise).fold(f64::NEG_INFINITY, f64::max),
        max_update_us,
        p99_update_us,
        median_update_us,
        max_cpu_us,
        p99_cpu_us,
        median_cpu_us,
        over_period_wall: over(|s| s.update_us),
        over_period_cpu: over(|s| s.cpu_us),
        fallback_cycles: samples.iter().filter(|s| s.source != InputSource::Qp).count(),
        worst_case,
        max_work: samples.iter().fold(Work::default(), |m, s| m.most(s.work)),
        over_worst_case: samples.iter().filter(|s| !worst_case.covers(&s.work)).count(),
        over_time_bound: config.time_bound_us.map_or(0, |bound| samples.iter().filter(|s| s.cpu_us > bound).count()),
        relaxed_cycles: std::array::from_fn(|f| samples.iter().filter(|s| s.relaxed_rows[f] > 0).count()),
        perception: perception.map(|p| {
            let [median_ms, _, max_ms] = cbfgen::cpu_time::median_p99_max(
                &mut p.updates.iter().map(|u| u.elapsed.as_secs_f64() * 1e3).collect::<Vec<_>>(),
            );
            PerceptionSummary {
                updates: p.updates.len(),
                median_ms,
                max_ms,
                last_map_points: p.updates.last().map_or(0, |u| u.map_points),
                last_cuboids: p.updates.last().map_or(0, |u| u.edges.len()),
            }
        }),
    }
}
