//! Franka's Panda as OSCBF models it, torque-controlled: 21 spheres on its links (20 that
//! a joint moves) kept off N random sphere obstacles and above a table, every row of
//! relative degree 2 through `M(q)⁻¹` — the setting of OSCBF (operational-space CBFs,
//! IROS 2025), built on cbfgen for a side-by-side measurement (docs/arm.md).
//!
//! Everything robot-specific is in the spec, `spec/panda_spheres.py` (kinematics and
//! dynamics from example-robot-data's URDF, OSCBF's spheres). The rows are generated in
//! joint accelerations and mapped to torques by [`cbfgen::torque::JointTorque`] with the
//! generated `dynamics`. The rest of this crate is the closed loop:
//!
//! * [`Scenario`] — N obstacles drawn as OSCBF draws them (centres uniform in
//!   x ∈ \[0.2, 0.8\], y ∈ \[−0.4, 0.4\], z ∈ \[0.1, 0.3\] m, radii in \[0.01, 0.1\] m,
//!   seeded; a draw that touches the arm's start pose is drawn again), a table at
//!   z = 0.1 m, and a computed-torque PD sweeping the hand low across them;
//! * [`Simulation`] — the filter on torques at 1 kHz, the plant integrating
//!   `M(q) q̈ + b(q, q̇) = τ` under each held torque (RK4, [`Scenario::fine_steps`] steps a
//!   period), and each cycle's least exact clearances over those steps.
//!
//! With [`Scenario::certified`] the filter certifies every answer between the samples
//! ([`cbfgen::filter::between_samples`]): the rows are enclosed over every state the arm
//! can reach while the torque is held, through the generated `dynamics` on intervals.
//!
//! ```
//! use cbfgen_panda_spheres::{Scenario, Simulation};
//!
//! let mut sim = Simulation::new(&Scenario::with_obstacles(25, 1))?;
//! assert_eq!(sim.filter().rows().len(), 20 * 25 + 18); // OSCBF counts 21 · 25 + 21 = 546
//! for _ in 0..100 {
//!     let sample = sim.step()?;
//!     assert!(sample.tau.iter().all(|t| t.is_finite()));
//! }
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

#![warn(missing_docs)]

/// The module generated from `spec/panda_spheres.py` (by `cbfgen-build` in `build.rs`,
/// checked in under `generated/`). Never edited by hand: change the spec and rebuild.
#[allow(missing_docs)]
pub mod generated {
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/generated/panda_spheres.rs"));
}

use cbfgen::dual::Dual;
use cbfgen::error::{within, CbfError};
use cbfgen::filter::between_samples::{BetweenSamples, SampledData};
use cbfgen::filter::{Calibration, EcbfFilter, FilterSettings, InputSource, Work};
use cbfgen::interval::Interval;
use cbfgen::torque::JointTorque;
use generated::{self as gen, Barriers, Capacity, Params, SphereObstacleParams, TableParams, NU, NX};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Control period \[s\].
pub const DT: f64 = 1e-3;
/// Arm spheres checked against obstacles.
pub const SPHERES: usize = gen::SPHERE_NAMES.len();
/// The table's height, OSCBF's \[m\].
pub const TABLE_HEIGHT: f64 = 0.1;
/// The arm at rest at t = 0: above the obstacles' box \[rad\].
pub const START: [f64; NU] = [-0.8, 0.2, 0.0, -2.0, 0.0, 2.2, 0.785];
/// Most obstacles a scenario takes.
pub const MAX_OBSTACLES: usize = gen::SPHERE_OBSTACLE_MAX_CAPACITY;

/// The filter on torques: the acceleration rows mapped through the URDF's dynamics.
pub type TorqueRows = JointTorque<Barriers, NX, NU>;

/// A sphere obstacle, fixed in the base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Obstacle {
    /// Centre \[m\].
    pub center: [f64; 3],
    /// Radius \[m\].
    pub radius: f64,
}

/// A joint-space target, tracked from time `from` \[s\].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Waypoint {
    /// When the PD switches to this target \[s\].
    pub from: f64,
    /// Target joint angles \[rad\].
    pub q: [f64; NU],
}

/// One run's set-up.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// The obstacles (at most [`MAX_OBSTACLES`]).
    pub obstacles: Vec<Obstacle>,
    /// The table's height \[m\], or `None` for no table.
    pub table: Option<f64>,
    /// Targets in time order.
    pub waypoints: Vec<Waypoint>,
    /// Simulated time \[s\].
    pub duration: f64,
    /// PD stiffness \[1/s²\] and damping \[1/s\] of the computed-torque nominal.
    pub gains: (f64, f64),
    /// The PD's position error is clipped so far targets are approached at this speed \[rad/s\].
    pub cruise_speed: f64,
    /// Whether the filter corrects the nominal torque (else it is only clipped).
    pub filter: bool,
    /// The filter's settings: the spec's, with torque limits as the input box.
    pub settings: FilterSettings<NU>,
    /// RK4 steps the plant takes over each period (1 to [`MAX_FINE_STEPS`]), each one's
    /// clearances measured: 100 finds what happens between the samples.
    pub fine_steps: usize,
}

/// The most RK4 steps per period [`Scenario::fine_steps`] takes.
pub const MAX_FINE_STEPS: usize = 10_000;

/// `n` obstacles drawn as OSCBF draws them, from `seed`; a draw that touches the arm at
/// [`START`] (or comes within 2 cm of it) is drawn again.
pub fn random_obstacles(n: usize, seed: u64) -> Vec<Obstacle> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut start = [0.0; NX];
    start[..NU].copy_from_slice(&START);
    let centers = gen::sphere_centers(&start);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let o = Obstacle {
            center: [rng.random_range(0.2..0.8), rng.random_range(-0.4..0.4), rng.random_range(0.1..0.3)],
            radius: rng.random_range(0.01..0.1),
        };
        let clear = centers.iter().zip(gen::SPHERE_RADII).all(|(c, r)| distance(c, &o.center) - r - o.radius > 0.02);
        if clear {
            out.push(o);
        }
    }
    out
}

fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

impl Scenario {
    /// `n` random obstacles from `seed`, the table, and the hand swept low across them:
    /// from [`START`] down towards the table at one side, across to the other, and back up
    /// (10 s, joints cruising at 0.8 rad/s).
    pub fn with_obstacles(n: usize, seed: u64) -> Self {
        let low = |q1: f64| [q1, 0.6, 0.0, -1.9, 0.0, 2.5, 0.785];
        let mut settings = gen::default_settings();
        settings.input_min = gen::TAU_MAX.map(|t| -t);
        settings.input_max = gen::TAU_MAX;
        Self {
            obstacles: random_obstacles(n, seed),
            table: Some(TABLE_HEIGHT),
            waypoints: vec![
                Waypoint { from: 0.0, q: low(-0.8) },
                Waypoint { from: 2.0, q: low(0.8) },
                Waypoint { from: 7.0, q: [0.0, 0.2, 0.0, -2.0, 0.0, 2.2, 0.785] },
            ],
            duration: 10.0,
            gains: (16.0, 8.0),
            cruise_speed: 0.8,
            filter: true,
            settings,
            fine_steps: 1,
        }
    }

    /// The same with every answer certified between the samples for the 1 ms period
    /// ([`FilterSettings::sampled_data`]).
    pub fn certified(mut self) -> Self {
        self.settings.sampled_data = Some(SampledData::every_family(DT));
        self
    }

    /// The same with the plant integrated in `steps` RK4 steps a period, and the
    /// clearances measured at each.
    pub fn fine(mut self, steps: usize) -> Self {
        self.fine_steps = steps;
        self
    }

    /// The same with the nominal torque only clipped to the limits.
    pub fn without_filter(mut self) -> Self {
        self.filter = false;
        self
    }

    /// Every row evaluated and in the QP each cycle (activation `+∞`, nothing culled), as
    /// OSCBF solves its QP.
    pub fn all_rows(mut self) -> Self {
        for f in &mut self.settings.families {
            f.activation = f64::INFINITY;
        }
        self
    }

    /// The computed-torque PD at `t`, `x`: `τ = M q̈_ref + b`, `q̈_ref = kp e − kd q̇` with
    /// the error clipped to approach far targets at the cruise speed.
    pub fn nominal(&self, t: f64, x: &[f64; NX]) -> [f64; NU] {
        let target = self.waypoints.iter().rev().find(|w| w.from <= t).unwrap_or(&self.waypoints[0]);
        let (kp, kd) = self.gains;
        let reach = self.cruise_speed * kd / kp;
        let qdd: [f64; NU] = std::array::from_fn(|i| kp * (target.q[i] - x[i]).clamp(-reach, reach) - kd * x[NU + i]);
        let (m, b) = gen::dynamics(x);
        std::array::from_fn(|i| (0..NU).map(|j| m[i][j] * qdd[j]).sum::<f64>() + b[i])
    }

    /// `Ok` when the scenario can run.
    ///
    /// # Errors
    /// More than [`MAX_OBSTACLES`] obstacles, a non-finite or non-positive radius or
    /// duration, no waypoints, a gain outside (0, 10⁴], or fine steps outside
    /// `1..=`[`MAX_FINE_STEPS`].
    pub fn validate(&self) -> Result<(), CbfError> {
        if self.obstacles.len() > MAX_OBSTACLES {
            return Err(CbfError::TooLarge { what: "obstacle count", value: self.obstacles.len(), max: MAX_OBSTACLES });
        }
        if self.waypoints.is_empty() {
            return Err(CbfError::NotPositive { what: "waypoint count", value: 0.0 });
        }
        within("duration", self.duration, 0.0, 1000.0, "(0, 1000] s")?;
        within("kp", self.gains.0, 1e-9, 1e4, "(0, 1e4]")?;
        within("kd", self.gains.1, 1e-9, 1e4, "(0, 1e4]")?;
        within("cruise speed", self.cruise_speed, 1e-9, 100.0, "(0, 100] rad/s")?;
        if !(1..=MAX_FINE_STEPS).contains(&self.fine_steps) {
            return Err(CbfError::TooLarge {
                what: "fine steps per period",
                value: self.fine_steps,
                max: MAX_FINE_STEPS,
            });
        }
        Ok(())
    }
}

/// The plant over `dt` under a held torque ([`cbfgen::torque::step_rigid_body`] with this
/// system's dynamics: one RK4 step).
///
/// # Errors
/// A singular mass matrix.
pub fn step_plant(x: &[f64; NX], tau: &[f64; NU], dt: f64) -> Result<[f64; NX], CbfError> {
    cbfgen::torque::step_rigid_body(gen::dynamics, x, tau, dt)
}

/// The least exact clearances at `x`: (arm sphere to obstacle, arm sphere above the
/// table) \[m\], `+∞` where there is nothing.
pub fn clearances(x: &[f64; NX], obstacles: &[Obstacle], table: Option<f64>) -> (f64, f64) {
    let centers = gen::sphere_centers(x);
    let mut obstacle = f64::INFINITY;
    for o in obstacles {
        for (c, r) in centers.iter().zip(gen::SPHERE_RADII) {
            obstacle = obstacle.min(distance(c, &o.center) - r - o.radius);
        }
    }
    let table = match table {
        Some(height) => {
            centers.iter().zip(gen::SPHERE_RADII).map(|(c, r)| c[2] - r - height).fold(f64::INFINITY, f64::min)
        }
        None => f64::INFINITY,
    };
    (obstacle, table)
}

/// One control cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time at the start of the cycle \[s\].
    pub t: f64,
    /// The applied torque \[N m\].
    pub tau: [f64; NU],
    /// Where it came from (`None` without the filter).
    pub source: Option<InputSource>,
    /// Smallest exact clearance between an arm sphere and an obstacle over the cycle's
    /// fine steps \[m\].
    pub obstacle_clearance: f64,
    /// Smallest exact clearance of an arm sphere above the table over the cycle's fine
    /// steps \[m\].
    pub table_clearance: f64,
    /// What the update certified between the samples (`None` without the filter).
    pub between_samples: Option<BetweenSamples>,
    /// The filter update's CPU time \[µs\], where the settings ask for it
    /// ([`FilterSettings::measure_cpu_time`]) and the platform has a thread clock.
    pub cpu_us: Option<f64>,
    /// The filter update's work, counted as it ran (`None` without the filter).
    pub work: Option<Work>,
}

/// A closed loop in progress.
pub struct Simulation {
    scenario: Scenario,
    filter: EcbfFilter<TorqueRows, NU>,
    params: Params,
    x: [f64; NX],
    cycle: usize,
}

impl Simulation {
    /// The filter, the obstacles and the table; the arm at rest at [`START`].
    ///
    /// # Errors
    /// An invalid scenario or filter settings, or an obstacle or table outside its domain
    /// (a radius ≤ 0, a non-finite centre), naming the obstacle.
    pub fn new(scenario: &Scenario) -> Result<Self, CbfError> {
        scenario.validate()?;
        let n = scenario.obstacles.len();
        let tables = usize::from(scenario.table.is_some());
        let capacity = Capacity { sphere_obstacle: [n; SPHERES], table: [tables; gen::TABLE_SPHERES.len()] };
        let mut params = Params::new(capacity)?;
        for (k, o) in scenario.obstacles.iter().enumerate() {
            let obstacle = SphereObstacleParams { center: o.center.into(), radius: o.radius };
            obstacle.validate().map_err(|e| e.in_instance(k))?;
            for member in &mut params.sphere_obstacle {
                member.push(obstacle)?;
            }
        }
        if let Some(height) = scenario.table {
            TableParams { height }.validate()?;
            for member in &mut params.table {
                member.push(TableParams { height })?;
            }
        }
        let rows = TorqueRows::new(Barriers::new(capacity)?, gen::dynamics)
            .with_interval_dynamics(gen::dynamics::<Interval>, gen::dynamics::<Dual<Interval>>)
            .with_dynamics_ops(gen::dynamics_ops());
        let filter = EcbfFilter::new(rows, scenario.settings.clone())?;
        let mut x = [0.0; NX];
        x[..NU].copy_from_slice(&START);
        Ok(Self { scenario: scenario.clone(), filter, params, x, cycle: 0 })
    }

    /// The filter (its rows, in torques, are the last step's).
    pub fn filter(&self) -> &EcbfFilter<TorqueRows, NU> {
        &self.filter
    }

    /// This machine's rates for the filter's work, measured now at the current state
    /// ([`EcbfFilter::calibrate`]).
    ///
    /// # Errors
    /// As [`EcbfFilter::calibrate`].
    pub fn calibrate(&mut self) -> Result<Calibration, CbfError> {
        self.filter.calibrate(self.time(), &self.x, &self.params)
    }

    /// The obstacle and table parameters the filter sees.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// The current state `[q, q̇]`.
    pub fn state(&self) -> &[f64; NX] {
        &self.x
    }

    /// The current time \[s\].
    pub fn time(&self) -> f64 {
        self.cycle as f64 * DT
    }

    /// One cycle: the nominal torque, filtered (or clipped), applied for [`DT`].
    ///
    /// # Errors
    /// A state the filter rejects, or a singular mass matrix.
    pub fn step(&mut self) -> Result<Sample, CbfError> {
        let t = self.time();
        let tau_ref = self.scenario.nominal(t, &self.x);
        let (tau, source, cpu_us, between_samples, work) = if self.scenario.filter {
            let out = self.filter.update(&self.x, &tau_ref, &self.params)?;
            let cpu_us = out.cpu_time.map(|d| d.as_secs_f64() * 1e6);
            (out.u, Some(out.source), cpu_us, Some(out.between_samples), Some(out.work))
        } else {
            let s = &self.scenario.settings;
            (std::array::from_fn(|j| tau_ref[j].clamp(s.input_min[j], s.input_max[j])), None, None, None, None)
        };
        let (mut obstacle_clearance, mut table_clearance) = (f64::INFINITY, f64::INFINITY);
        let fine = self.scenario.fine_steps;
        for _ in 0..fine {
            self.x = step_plant(&self.x, &tau, DT / fine as f64)?;
            let (obstacle, table) = clearances(&self.x, &self.scenario.obstacles, self.scenario.table);
            obstacle_clearance = obstacle_clearance.min(obstacle);
            table_clearance = table_clearance.min(table);
        }
        self.cycle += 1;
        Ok(Sample { t, tau, source, obstacle_clearance, table_clearance, cpu_us, between_samples, work })
    }
}

/// Run `scenario` to its end.
///
/// # Errors
/// As [`Simulation::new`] and [`Simulation::step`].
pub fn run(scenario: &Scenario) -> Result<Vec<Sample>, CbfError> {
    let mut sim = Simulation::new(scenario)?;
    let cycles = (scenario.duration / DT).round() as usize;
    (0..cycles).map(|_| sim.step()).collect()
}
