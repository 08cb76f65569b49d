//! The arm's closed loop at 1 kHz: a joint-space PD through timed waypoints →
//! [`EcbfFilter`] on the generated `panda` barriers → exact integration of `q̈ = u`.
//!
//! The standard scenario ([`Scenario::standard`]) asks for three things a safety filter
//! must refuse: a 1.4 rad sweep of the base joint that drives the forearm, wrist and hand
//! through a 50 cm box standing on a table; after a return to a ready pose, a fold that
//! brings the hand and wrist onto the shoulder column and the upper arm, with the elbow
//! target 0.23 rad past its limit; then a turn of the hand 0.3 rad past the last joint's
//! limit. Without the filter ([`Scenario::without_filter`]) the forearm enters the box by
//! 11 cm, the wrist the shoulder by 14 cm, and joints pass their limits by 0.3 rad. The PD
//! cruises at 0.8 rad/s: the soft SSAT the arm uses (see the spec) keeps every ECBF
//! condition within the joints' acceleration limits at that speed, not at twice it.
//!
//! Every cycle measures each checked box pair (every link box against every obstacle, and
//! the spec's self-collision pairs) with the exact SAT ([`cbfgen::sat::separation`]),
//! computed from the generated forward kinematics, never from the barrier values.

use std::time::Duration;

use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::generated::{self as gen, Barriers, Capacity, ObstacleParams, Params, NU, NX};
use cbfgen::error::{finite, positive, within, CbfError};
use cbfgen::filter::{BoundCheck, EcbfFilter, FilterSettings, InputSource};
use cbfgen::geometry::OrientedBox;
use cbfgen::sat;
use cbfgen::system::BarrierSet;

/// Control period \[s\].
pub const DT: f64 = 1e-3;
/// Joints of the arm.
pub const JOINTS: usize = 7;
/// Longest run accepted \[s\]: 10⁶ cycles, a few hundred MB of samples.
pub const MAX_DURATION: f64 = 1000.0;
/// Largest PD gain accepted (stiffness \[1/s²\] or damping \[1/s\]).
pub const MAX_GAIN: f64 = 1e4;
/// Largest |waypoint angle| accepted \[rad\]: targets may lie past the limits (the filter
/// holds the joint), but not by several turns.
pub const MAX_TARGET: f64 = 10.0;
/// Link boxes of the arm (every link with collision geometry in its URDF).
pub const LINKS: usize = gen::LINK_NAMES.len();
/// The families, in the spec's (and the rows') order.
pub const FAMILY_NAMES: [&str; 4] = ["joint_limits", "velocity_limits", "obstacle", "self_collision"];

/// The state `[q, q̇]`.
pub type State = [f64; NX];
/// Joint angles (or rates, or accelerations), joints 1–7.
pub type Joints = [f64; JOINTS];

/// A joint-space target, tracked from time `from` \[s\] until the next waypoint's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Waypoint {
    /// When the PD switches to this target \[s\].
    pub from: f64,
    /// Target joint angles \[rad\].
    pub q: Joints,
}

/// A named obstacle box, fixed in the base frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Obstacle {
    /// Its name in the CSV and the figures.
    pub name: String,
    /// The box.
    pub shape: OrientedBox,
}

/// One closed-loop run's set-up.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Joint angles at t = 0, at rest; inside the joint limits \[rad\].
    pub start: Joints,
    /// Targets in time order; the first applies from t = 0 whatever its `from`.
    pub waypoints: Vec<Waypoint>,
    /// Obstacle boxes (at most [`gen::OBSTACLE_MAX_CAPACITY`]).
    pub obstacles: Vec<Obstacle>,
    /// Simulated time \[s\].
    pub duration: f64,
    /// PD stiffness \[1/s²\]: `q̈_ref = kp (q_target − q) − kd q̇`.
    pub kp: f64,
    /// PD damping \[1/s\].
    pub kd: f64,
    /// The PD's position error is clipped to `cruise_speed · kd / kp`, so it approaches a
    /// far target at this joint speed \[rad/s\] instead of at whatever its gains give.
    pub cruise_speed: f64,
    /// Whether the ECBF filter corrects the PD (else its input is only clipped to the
    /// acceleration limits).
    pub filter: bool,
    /// The filter's settings (default: the spec's, [`gen::default_settings`]).
    pub settings: FilterSettings<NU>,
}

impl Scenario {
    /// The standard scenario (see the [module docs](self)): a 1.4 × 1.6 m table top at
    /// z = 0 and a 16 × 16 × 50 cm box on it 0.5 m in front of the base, 24 s, joints
    /// cruising at 0.8 rad/s.
    pub fn standard() -> Self {
        let obstacle = |name: &str, center: [f64; 3], half: [f64; 3]| Obstacle {
            name: name.to_string(),
            shape: OrientedBox::axis_aligned(Vector3::from(center), Vector3::from(half))
                .expect("the standard obstacles are valid boxes"),
        };
        Self {
            start: [0.7, 0.5, 0.0, -1.6, 0.0, 2.1, 0.785],
            waypoints: vec![
                // Sweep the base joint across the box.
                Waypoint { from: 0.0, q: [-0.7, 0.5, 0.0, -1.6, 0.0, 2.1, 0.785] },
                // Back to a ready pose, clear of the box.
                Waypoint { from: 6.0, q: [-0.7, 0.0, 0.0, -1.6, 0.0, 1.6, 0.785] },
                // Fold the hand onto the shoulder, the elbow target past its limit.
                Waypoint { from: 9.0, q: [-0.7, 0.64, -0.74, -3.3, 0.49, 1.12, 1.55] },
                // Turn the hand past the wrist's limit.
                Waypoint { from: 17.0, q: [-0.7, 0.64, -0.74, -3.3, 0.49, 1.12, 3.2] },
            ],
            obstacles: vec![
                obstacle("table", [0.3, 0.0, -0.05], [0.7, 0.8, 0.05]),
                obstacle("box", [0.5, 0.0, 0.25], [0.08, 0.08, 0.25]),
            ],
            duration: 24.0,
            kp: 16.0,
            kd: 8.0,
            cruise_speed: 0.8,
            filter: true,
            // The samples report the update's CPU time beside its wall time.
            settings: FilterSettings { measure_cpu_time: true, ..gen::default_settings() },
        }
    }

    /// The same scenario with the PD's input only clipped to the acceleration limits.
    pub fn without_filter(mut self) -> Self {
        self.filter = false;
        self
    }

    /// `Ok` when every number is usable.
    ///
    /// # Errors
    /// A non-finite or out-of-range start, target, time or gain, a start outside the
    /// joint limits, waypoints out of time order or none, more obstacles than
    /// [`gen::OBSTACLE_MAX_CAPACITY`]. Filter settings are checked by the filter.
    pub fn validate(&self) -> Result<(), CbfError> {
        for (i, &q) in self.start.iter().enumerate() {
            within("start joint angle", q, gen::Q_MIN[i], gen::Q_MAX[i], "the joint's limits (panda::Q_MIN..Q_MAX)")?;
        }
        if self.waypoints.is_empty() {
            return Err(CbfError::NotPositive { what: "waypoint count", value: 0.0 });
        }
        let mut last = f64::NEG_INFINITY;
        for w in &self.waypoints {
            finite("waypoint time", w.from)?;
            if w.from < last {
                return Err(CbfError::OutOfRange {
                    what: "waypoint time",
                    value: w.from,
                    range: "not before the previous waypoint's",
                });
            }
            last = w.from;
            for &q in &w.q {
                within("waypoint joint angle", q, -MAX_TARGET, MAX_TARGET, "[-10, 10] rad")?;
            }
        }
        within("duration", positive("duration", self.duration)?, 0.0, MAX_DURATION, "(0, 1000] s")?;
        within("kp", positive("kp", self.kp)?, 0.0, MAX_GAIN, "(0, 1e4]")?;
        within("kd", positive("kd", self.kd)?, 0.0, MAX_GAIN, "(0, 1e4]")?;
        within("cruise speed", positive("cruise speed", self.cruise_speed)?, 0.0, 100.0, "(0, 100] rad/s")?;
        if self.obstacles.len() > gen::OBSTACLE_MAX_CAPACITY {
            return Err(CbfError::TooLarge {
                what: "obstacle count",
                value: self.obstacles.len(),
                max: gen::OBSTACLE_MAX_CAPACITY,
            });
        }
        Ok(())
    }

    /// Names of the checked box pairs, in [`Sample::separation`] order: every obstacle
    /// against every moving link's box (`"box/link5"`), then the self-collision pairs
    /// (`"link1/hand"`).
    pub fn pair_names(&self) -> Vec<String> {
        let mut names = Vec::new();
        for o in &self.obstacles {
            names.extend(gen::OBSTACLE_LINKS.iter().map(|&l| format!("{}/{}", o.name, gen::LINK_NAMES[l])));
        }
        names.extend(gen::SELF_PAIRS.iter().map(|&[a, b]| self_pair_name(a, b)));
        names
    }

    /// The PD's acceleration at time `t` and state `x` (not clipped).
    pub fn nominal(&self, t: f64, x: &State) -> Joints {
        let target = self.waypoints.iter().rev().find(|w| w.from <= t).unwrap_or(&self.waypoints[0]);
        let reach = self.cruise_speed * self.kd / self.kp;
        std::array::from_fn(|i| self.kp * (target.q[i] - x[i]).clamp(-reach, reach) - self.kd * x[JOINTS + i])
    }
}

fn self_pair_name(a: usize, b: usize) -> String {
    format!("{}/{}", gen::LINK_NAMES[a], gen::LINK_NAMES[b])
}

/// The world boxes of the links at state `x` (generated forward kinematics), in
/// [`gen::LINK_NAMES`] order.
///
/// # Errors
/// A state whose kinematics are not finite.
pub fn link_boxes(x: &State) -> Result<[OrientedBox; LINKS], CbfError> {
    let (centers, rotations) = gen::link_boxes(x);
    let boxes = (0..LINKS)
        .map(|k| {
            let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_row_slice(&rotations[k]));
            OrientedBox::new(Vector3::from(centers[k]), rotation, Vector3::from(gen::LINK_HALF_EXTENTS[k]))
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(boxes.try_into().expect("one box per row of the generated output"))
}

/// One control cycle.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// Time at the start of the cycle \[s\].
    pub t: f64,
    /// The state the input was computed for.
    pub x: State,
    /// The PD's input \[rad/s²\].
    pub u_ref: Joints,
    /// The applied input \[rad/s²\] (filtered, or the PD's clipped to the limits).
    pub u: Joints,
    /// Where the input came from (`None` without the filter).
    pub source: Option<InputSource>,
    /// Smallest `h` of each family over its rows, [`FAMILY_NAMES`] order.
    pub min_h: [f64; 4],
    /// Rows of each family in the QP this cycle.
    pub active: [usize; 4],
    /// Exact SAT separation of each checked pair \[m\] (< 0: overlap), in
    /// [`Scenario::pair_names`] order.
    pub separation: Vec<f64>,
    /// The filter update's thread CPU time (zero without the filter, or when its settings do
    /// not measure it).
    pub cpu_time: Duration,
    /// The filter update's wall time, evaluation and solve (zero without the filter).
    pub wall_time: Duration,
}

/// A closed loop in progress: one [`Simulation::step`] per control cycle.
#[derive(Debug)]
pub struct Simulation {
    scenario: Scenario,
    filter: EcbfFilter<Barriers, NU>,
    /// The rows evaluated for measurement when the filter is off.
    unfiltered: Barriers,
    params: Params,
    x: State,
    cycle: usize,
    /// The filter's stated worst case per update beside what its updates did.
    bound: BoundCheck,
}

impl Simulation {
    /// Build the filter and the obstacles; the arm at rest at `scenario.start`.
    ///
    /// # Errors
    /// An invalid scenario ([`Scenario::validate`]) or filter settings.
    pub fn new(scenario: &Scenario) -> Result<Self, CbfError> {
        scenario.validate()?;
        // Every moving link is checked against every obstacle.
        let capacity = Capacity { obstacle: [scenario.obstacles.len(); gen::OBSTACLE_LINKS.len()] };
        let mut params = Params::new(capacity)?;
        for o in &scenario.obstacles {
            let b = &o.shape;
            let obstacle =
                ObstacleParams { center: *b.center(), rotation: *b.rotation().matrix(), half: *b.half_extents() };
            for link in &mut params.obstacle {
                link.push(obstacle)?;
            }
        }
        let mut filter = EcbfFilter::new(Barriers::new(capacity)?, scenario.settings.clone())?;
        let mut x = [0.0; NX];
        x[..JOINTS].copy_from_slice(&scenario.start);
        let unfiltered = Barriers::new(capacity)?;
        let bound = BoundCheck::new(filter.worst_case(), filter.calibrate(0.0, &x, &params)?);
        Ok(Self { scenario: scenario.clone(), filter, unfiltered, params, x, cycle: 0, bound })
    }

    /// The current state `[q, q̇]`.
    pub fn state(&self) -> &State {
        &self.x
    }

    /// The current time \[s\].
    pub fn time(&self) -> f64 {
        self.cycle as f64 * DT
    }

    /// The filter (its rows, active set and slacks are those of the last step).
    pub fn filter(&self) -> &EcbfFilter<Barriers, NU> {
        &self.filter
    }

    /// The filter's stated worst case per update (calibrated on this machine when the
    /// simulation was built) beside the most its updates so far took.
    pub fn bound(&self) -> &BoundCheck {
        &self.bound
    }

    /// The obstacle parameters the filter sees.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// One cycle: the PD's input, filtered (or clipped), applied for [`DT`] exactly
    /// (`q̈ = u` is integrated in closed form).
    ///
    /// # Errors
    /// A state the filter rejects (beyond its domain) or non-finite kinematics.
    pub fn step(&mut self) -> Result<Sample, CbfError> {
        let t = self.time();
        let x = self.x;
        let u_ref = self.scenario.nominal(t, &x);
        let (u, source, cpu_time, wall_time) = if self.scenario.filter {
            let out = self.filter.update(&x, &u_ref, &self.params)?;
            self.bound.record(out);
            (out.u, Some(out.source), out.cpu_time.unwrap_or_default(), out.eval_time + out.solve_time)
        } else {
            // The rows are still evaluated, for the figures' h.
            self.unfiltered.evaluate(0.0, &x, &self.params)?;
            let s = &self.scenario.settings;
            (
                std::array::from_fn(|j| u_ref[j].clamp(s.input_min[j], s.input_max[j])),
                None,
                Duration::ZERO,
                Duration::ZERO,
            )
        };
        let mut min_h = [f64::INFINITY; 4];
        let mut active = [0; 4];
        let barriers = if self.scenario.filter { self.filter.barriers() } else { &self.unfiltered };
        for (k, (layout, row)) in barriers.layout().iter().zip(barriers.rows()).enumerate() {
            if row.active {
                min_h[layout.family] = min_h[layout.family].min(row.h());
            }
            active[layout.family] += usize::from(self.scenario.filter && self.filter.active()[k]);
        }
        let separation = self.separations(&x)?;
        for j in 0..JOINTS {
            self.x[j] += x[JOINTS + j] * DT + 0.5 * u[j] * DT * DT;
            self.x[JOINTS + j] += u[j] * DT;
        }
        self.cycle += 1;
        Ok(Sample { t, x, u_ref, u, source, min_h, active, separation, cpu_time, wall_time })
    }

    fn separations(&self, x: &State) -> Result<Vec<f64>, CbfError> {
        let links = link_boxes(x)?;
        let mut out =
            Vec::with_capacity(self.scenario.obstacles.len() * gen::OBSTACLE_LINKS.len() + gen::SELF_PAIRS.len());
        for o in &self.scenario.obstacles {
            out.extend(gen::OBSTACLE_LINKS.iter().map(|&l| sat::separation(&o.shape, &links[l])));
        }
        out.extend(gen::SELF_PAIRS.iter().map(|&[a, b]| sat::separation(&links[a], &links[b])));
        Ok(out)
    }
}

/// What a run showed.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Whether the filter ran.
    pub filter: bool,
    /// Control cycles run.
    pub cycles: usize,
    /// Smallest exact separation of each checked pair over the run \[m\], with its time,
    /// [`Scenario::pair_names`] order.
    pub min_separation: Vec<(f64, f64)>,
    /// Smallest distance of any joint inside its limits over the run \[rad\] (< 0: past).
    pub min_joint_margin: f64,
    /// Largest |q̇_i| / q̇_max,i over the run.
    pub max_speed_ratio: f64,
    /// Smallest `h` of each family over the run, [`FAMILY_NAMES`] order.
    pub min_h: [f64; 4],
    /// Median, p99 and max thread CPU time of an update \[µs\].
    pub cpu_us: [f64; 3],
    /// Median, p99 and max wall time of an update \[µs\].
    pub wall_us: [f64; 3],
    /// Updates over 1 ms of CPU time.
    pub over_1ms_cpu: usize,
    /// Cycles whose input was not the QP's optimum.
    pub not_qp: usize,
    /// The filter's stated worst case per update beside the most an update took; `None`
    /// without the filter.
    pub bound: Option<BoundCheck>,
}

impl Summary {
    /// The smallest separation over every checked pair \[m\] (and the pair's index).
    pub fn worst_pair(&self) -> Option<(usize, f64)> {
        self.min_separation.iter().map(|p| p.0).enumerate().min_by(|a, b| a.1.total_cmp(&b.1))
    }
}

/// A finished run: every cycle and the summary.
#[derive(Debug, Clone)]
pub struct Run {
    /// The scenario that was run.
    pub scenario: Scenario,
    /// One sample per cycle.
    pub samples: Vec<Sample>,
    /// What the run showed.
    pub summary: Summary,
}

/// Run `scenario` to its end.
///
/// # Errors
/// As [`Simulation::new`] and [`Simulation::step`].
pub fn run(scenario: &Scenario) -> Result<Run, CbfError> {
    let mut sim = Simulation::new(scenario)?;
    let cycles = (scenario.duration / DT).round() as usize;
    let mut samples = Vec::with_capacity(cycles);
    for _ in 0..cycles {
        samples.push(sim.step()?);
    }
    let mut summary = summarize(scenario, &samples);
    summary.bound = scenario.filter.then(|| *sim.bound());
    Ok(Run { scenario: scenario.clone(), samples, summary })
}

fn summarize(scenario: &Scenario, samples: &[Sample]) -> Summary {
    let pairs = samples.first().map_or(0, |s| s.separation.len());
    let mut min_separation = vec![(f64::INFINITY, 0.0); pairs];
    let mut min_joint_margin = f64::INFINITY;
    let mut max_speed_ratio: f64 = 0.0;
    let mut min_h = [f64::INFINITY; 4];
    for s in samples {
        for (m, &d) in min_separation.iter_mut().zip(&s.separation) {
            if d < m.0 {
                *m = (d, s.t);
            }
        }
        for j in 0..JOINTS {
            min_joint_margin = min_joint_margin.min((s.x[j] - gen::Q_MIN[j]).min(gen::Q_MAX[j] - s.x[j]));
            max_speed_ratio = max_speed_ratio.max(s.x[JOINTS + j].abs() / gen::QD_MAX[j]);
        }
        for (m, h) in min_h.iter_mut().zip(s.min_h) {
            *m = m.min(h);
        }
    }
    let micros = |f: fn(&Sample) -> Duration| {
        cbfgen::cpu_time::median_p99_max(&mut samples.iter().map(|s| f(s).as_secs_f64() * 1e6).collect::<Vec<_>>())
    };
    Summary {
        filter: scenario.filter,
        cycles: samples.len(),
        min_separation,
        min_joint_margin,
        max_speed_ratio,
        min_h,
        cpu_us: micros(|s| s.cpu_time),
        wall_us: micros(|s| s.wall_time),
        over_1ms_cpu: samples.iter().filter(|s| s.cpu_time > Duration::from_millis(1)).count(),
        not_qp: samples.iter().filter(|s| s.source.is_some_and(|src| src != InputSource::Qp)).count(),
        bound: None,
    }
}

impl std::fmt::Display for Run {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = &self.summary;
        let names = self.scenario.pair_names();
        writeln!(f, "arm, {} the ECBF filter, {} cycles:", if s.filter { "with" } else { "without" }, s.cycles)?;
        if let Some((k, d)) = s.worst_pair() {
            let overlaps = s.min_separation.iter().filter(|p| p.0 < -1e-3).count();
            writeln!(
                f,
                "  exact SAT separation, smallest: {:.1} mm ({} at {:.2} s); pairs overlapping > 1 mm: {overlaps} of {}",
                d * 1e3,
                names[k],
                s.min_separation[k].1,
                names.len()
            )?;
        }
        writeln!(
            f,
            "  joint limits: closest {:+.4} rad; largest speed {:.2} x the limit",
            s.min_joint_margin, s.max_speed_ratio
        )?;
        write!(f, "  minimum h:")?;
        for (name, h) in FAMILY_NAMES.iter().zip(s.min_h) {
            write!(f, " {name} {h:.4}")?;
        }
        writeln!(f)?;
        if s.filter {
            writeln!(
                f,
                "  filter update, thread CPU: median {:.1} µs, p99 {:.1} µs, max {:.1} µs; over 1 ms: {}",
                s.cpu_us[0], s.cpu_us[1], s.cpu_us[2], s.over_1ms_cpu
            )?;
            writeln!(
                f,
                "  filter update, wall: median {:.1} µs, p99 {:.1} µs, max {:.1} µs; inputs not from the QP: {}",
                s.wall_us[0], s.wall_us[1], s.wall_us[2], s.not_qp
            )?;
        }
        if let Some(bound) = &s.bound {
            for line in bound.to_string().lines() {
                writeln!(f, "  {line}")?;
            }
        }
        Ok(())
    }
}
