//! A closed loop: the robot walks past rectangles to a goal, one MPC step at a time.
//!
//! Each step, in the robot's current frame (origin at the CoM, x-axis along the heading,
//! see [`Frame::following`]): build each obstacle's half-plane from the global CoM and move
//! it, the goal and the state into that frame; solve the MPC; take the first foot and
//! turning rate; advance the state by the LIP model; convert back to global coordinates.
//! [`Walker`] is that loop, allocation-free per step; [`run`] drives it and records.

use std::time::{Duration, Instant};

use super::model::{Frame, LipState};
use super::mpc::LipMpc;
use super::obstacles::{BarrierForm, HalfPlane, Rectangle};
use super::LipParams;
use cbfgen::error::{finite, positive, CbfError};
use cbfgen::qp::{Backend, QpStatus, SolverSettings};

/// Start, goal, obstacles and limits of one navigation run.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Global start state `[p_x, v_x, p_y, v_y, θ]`.
    pub start: LipState,
    /// Global goal \[m\].
    pub goal: [f64; 2],
    /// Reached when the CoM is this close to the goal \[m\].
    pub goal_tolerance: f64,
    /// Obstacles (global, axis-aligned).
    pub obstacles: Vec<Rectangle>,
    /// Stance sign of the first step (+1: right foot).
    pub first_stance: f64,
    /// Steps allowed before giving up.
    pub max_steps: usize,
    /// The MPC's model, horizon, limits and CBF settings.
    pub params: LipParams,
    /// Solver settings of the MPC (which solver, the dense budget, OSQP's settings).
    pub solver: SolverSettings,
}

impl Scenario {
    /// The standard course: from rest at the origin facing +x to (6, 2) m, with three
    /// 0.6 m-deep blocks across the straight line.
    pub fn standard() -> Self {
        let rect = |x0, x1, y0, y1| Rectangle { min: [x0, y0], max: [x1, y1] };
        Self {
            start: [0.0; 5],
            goal: [6.0, 2.0],
            goal_tolerance: 0.2,
            obstacles: vec![rect(1.5, 2.1, 0.1, 1.1), rect(3.2, 3.8, 0.8, 1.6), rect(4.6, 5.2, 1.2, 1.9)],
            first_stance: 1.0,
            max_steps: 150,
            params: LipParams::default(),
            solver: LipMpc::default_solver_settings(),
        }
    }

    /// The comparison course of the report's section 5.3.3: from rest at the origin
    /// facing +x to (4, 3) m, with one block `[1, 3] × [0.3, 2]` m across the straight
    /// line. The robot walks up its left face and round its upper-left corner, so with
    /// `δ = 0` the CoM grazes the block and feet, which sway out from the CoM, land on it.
    pub fn corner() -> Self {
        Self { goal: [4.0, 3.0], obstacles: vec![Rectangle { min: [1.0, 0.3], max: [3.0, 2.0] }], ..Self::standard() }
    }

    /// The same course with another margin `δ` (`0`: Peng et al.'s LDCBF).
    pub fn with_delta(&self, delta: f64) -> Self {
        Self { params: LipParams { delta, ..self.params }, ..self.clone() }
    }
}

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepOutcome {
    /// The status of this step's MPC solve, from the solver that answered.
    pub status: QpStatus,
    /// Which solver answered.
    pub answered_by: Backend,
    /// OSQP's ADMM iterations in that solve (0 when OSQP did not run).
    pub iterations: u32,
    /// The dense solve's active-set changes in that solve (0 when it did not run).
    pub dense_steps: u32,
    /// Preprocessing, value update and solve (the dense one, OSQP, or both).
    pub solve_time: Duration,
    /// Whether the state advanced (only when the QP was solved).
    pub advanced: bool,
    /// The stance foot placed this step, global \[m\] (meaningful when `advanced`).
    pub foot: [f64; 2],
    /// Some obstacle's half-plane was built with the CoM on or inside it.
    pub inside: bool,
}

/// The closed loop's state: the robot, its MPC, and per-step scratch.
#[derive(Debug)]
pub struct Walker {
    scenario: Scenario,
    mpc: LipMpc,
    /// Global state.
    state: LipState,
    stance: f64,
    /// The frame of the last step's solve, and the state and half-planes in it.
    frame: Frame,
    local_start: LipState,
    planes: Vec<HalfPlane>,
    /// `h_j` at the current CoM, per obstacle (global half-planes).
    h: Vec<f64>,
}

impl Walker {
    /// The robot at the scenario's start, with an MPC sized for its obstacles.
    ///
    /// # Errors
    /// A non-finite start or goal, a bad stance sign or tolerance, or the MPC's errors.
    pub fn new(scenario: Scenario) -> Result<Self, CbfError> {
        for &v in scenario.start.iter().chain(&scenario.goal) {
            finite("scenario start/goal", v)?;
        }
        positive("goal tolerance", scenario.goal_tolerance)?;
        let mpc = LipMpc::new(scenario.params, scenario.obstacles.len(), scenario.solver)?;
        let n = scenario.obstacles.len();
        let mut walker = Self {
            stance: scenario.first_stance,
            state: scenario.start,
            frame: Frame::GLOBAL,
            local_start: scenario.start,
            planes: Vec::with_capacity(n),
            h: vec![0.0; n],
            scenario,
            mpc,
        };
        walker.update_h();
        Ok(walker)
    }

    fn update_h(&mut self) {
        let p = self.com();
        for (h, rect) in self.h.iter_mut().zip(&self.scenario.obstacles) {
            *h = rect.half_plane(p, self.scenario.params.delta, self.scenario.params.barrier).h(p);
        }
    }

    /// One MPC step. A solved QP advances the robot by its first input; any other status
    /// leaves the robot where it is (`advanced == false`) for the caller to decide.
    ///
    /// # Errors
    /// The MPC's input errors (a non-finite state, e.g. after [`Walker::set_state`]).
    pub fn step(&mut self) -> Result<StepOutcome, CbfError> {
        let started = Instant::now();
        let p = self.com();
        let (delta, form) = (self.scenario.params.delta, self.scenario.params.barrier);
        self.frame = Frame { origin: p, heading: self.state[4] };
        self.local_start = self.frame.state_to_local(&self.state);
        self.planes.clear();
        let mut inside = false;
        for rect in &self.scenario.obstacles {
            let plane = rect.half_plane(p, delta, form);
            inside |= plane.inside;
            self.planes.push(plane.to_local(&self.frame));
        }
        let goal = self.frame.point_to_local(self.scenario.goal);
        let status = self.mpc.solve(&self.local_start, goal, self.stance, &self.planes)?;
        let solve_time = started.elapsed();
        let mut outcome = StepOutcome {
            status,
            answered_by: self.mpc.answered_by(),
            iterations: self.mpc.iterations(),
            dense_steps: self.mpc.dense_steps(),
            solve_time,
            advanced: false,
            foot: [0.0; 2],
            inside,
        };
        if status.is_solved() {
            let u = self.mpc.plan().inputs()[0];
            let next = self.scenario.params.lip.step(&self.local_start, &u);
            outcome.foot = self.frame.point_to_global([u[0], u[1]]);
            self.state = self.frame.state_to_global(&next);
            self.stance = -self.stance;
            outcome.advanced = true;
            self.update_h();
        }
        Ok(outcome)
    }

    /// Global CoM position.
    pub fn com(&self) -> [f64; 2] {
        [self.state[0], self.state[2]]
    }

    /// Global state.
    pub fn state(&self) -> &LipState {
        &self.state
    }

    /// Replace the global state (tests inject bad ones).
    pub fn set_state(&mut self, state: LipState) {
        self.state = state;
    }

    /// Whether the CoM is within the goal tolerance.
    pub fn at_goal(&self) -> bool {
        let p = self.com();
        (p[0] - self.scenario.goal[0]).hypot(p[1] - self.scenario.goal[1]) <= self.scenario.goal_tolerance
    }

    /// `h_j = ηᵀ(p − c) − δ` at the current CoM, per obstacle.
    pub fn h(&self) -> &[f64] {
        &self.h
    }

    /// The MPC (its last plan is in [`Walker::frame`]).
    pub fn mpc(&self) -> &LipMpc {
        &self.mpc
    }

    /// The frame of the last step's solve.
    pub fn frame(&self) -> Frame {
        self.frame
    }

    /// The state the last step started from, in [`Walker::frame`].
    pub fn local_start(&self) -> &LipState {
        &self.local_start
    }

    /// The half-planes of the last step, in [`Walker::frame`].
    pub fn planes(&self) -> &[HalfPlane] {
        &self.planes
    }

    /// The scenario it walks.
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }
}

/// One recorded step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepRecord {
    /// What the step did.
    pub outcome: StepOutcome,
    /// Global CoM after the step \[m\].
    pub com: [f64; 2],
    /// `h_j` after the step, per obstacle.
    pub h: Vec<f64>,
}

/// A whole run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunResult {
    /// The scenario that was run.
    pub scenario: Scenario,
    /// Global CoM at the start and after every step \[m\].
    pub com_path: Vec<[f64; 2]>,
    /// One record per MPC step taken, the failed one included if the MPC failed.
    pub steps: Vec<StepRecord>,
    /// Whether the CoM ended within `goal_tolerance` of the goal.
    pub reached_goal: bool,
    /// The status that stopped the run, if the MPC failed.
    pub failure: Option<QpStatus>,
}

impl RunResult {
    /// Global footsteps, one per step.
    pub fn footsteps(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        self.steps.iter().filter(|s| s.outcome.advanced).map(|s| s.outcome.foot)
    }

    /// Smallest Euclidean distance from the CoM path to any obstacle \[m\].
    pub fn min_clearance(&self) -> f64 {
        self.com_path
            .iter()
            .flat_map(|p| self.scenario.obstacles.iter().map(move |r| r.distance(*p)))
            .fold(f64::INFINITY, f64::min)
    }

    /// Smallest signed distance from any footstep to any obstacle \[m\] (negative: a foot
    /// inside one; see [`Rectangle::signed_distance`]).
    pub fn min_footstep_clearance(&self) -> f64 {
        self.footsteps()
            .flat_map(|f| self.scenario.obstacles.iter().map(move |r| r.signed_distance(f)))
            .fold(f64::INFINITY, f64::min)
    }

    /// Footsteps on or inside some obstacle.
    pub fn footsteps_on_obstacles(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        self.footsteps().filter(|&f| self.scenario.obstacles.iter().any(|r| r.signed_distance(f) <= 0.0))
    }

    /// Solve times, sorted ascending \[µs\].
    pub fn sorted_solve_micros(&self) -> Vec<f64> {
        let mut t: Vec<f64> = self.steps.iter().map(|s| s.outcome.solve_time.as_secs_f64() * 1e6).collect();
        t.sort_by(f64::total_cmp);
        t
    }

    /// Printable summary: steps, goal, clearance against `δ`, solve times.
    pub fn summary(&self) -> String {
        let t = self.sorted_solve_micros();
        let pick = |q: f64| t.get(((t.len() as f64 - 1.0) * q).round() as usize).copied().unwrap_or(f64::NAN);
        let iterations: Vec<u32> = self.steps.iter().map(|s| s.outcome.iterations).collect();
        let max_iter = iterations.iter().max().copied().unwrap_or(0);
        let inaccurate = self.steps.iter().filter(|s| s.outcome.status == QpStatus::SolvedInaccurate).count();
        let by_osqp = self.steps.iter().filter(|s| s.outcome.answered_by == Backend::Osqp).count();
        let dense_steps = self.steps.iter().map(|s| s.outcome.dense_steps).max().unwrap_or(0);
        let p = &self.scenario.params;
        format!(
            "3D-LIP MPC navigation: N = {}, {} obstacles, T = {} s\n  steps taken          {}\n  goal reached         {}{}\n  \
             min CoM clearance    {:.4} m (δ = {} {}, {} normal, {} headings)\n  \
             min foot clearance   {:.4} m ({} footsteps in an obstacle)\n  MPC solve median     {:.1} µs, p99 {:.1} µs, max {:.1} µs\n  \
             solver               {} (OSQP answered {} of {} solves)\n  dense steps max      {}\n  \
             ADMM iterations max  {} ({} of the solves only to OSQP's 10x looser \"inaccurate\" tolerances)",
            p.horizon,
            self.scenario.obstacles.len(),
            p.lip.step_time,
            self.steps.len(),
            if self.reached_goal { "yes" } else { "no" },
            self.failure.map(|s| format!(" (MPC stopped: {})", s.name())).unwrap_or_default(),
            self.min_clearance(),
            p.delta,
            if p.barrier == BarrierForm::UnitNormal { "m" } else { "m²" },
            p.barrier.name(),
            p.heading.name(),
            self.min_footstep_clearance(),
            self.footsteps_on_obstacles().count(),
            pick(0.5),
            pick(0.99),
            pick(1.0),
            self.scenario.solver.backend.name(),
            by_osqp,
            self.steps.len(),
            dense_steps,
            max_iter,
            inaccurate,
        )
    }
}

/// Walk the scenario until the goal, an MPC failure, or the step budget.
///
/// # Errors
/// The [`Walker`]'s errors.
pub fn run(scenario: &Scenario) -> Result<RunResult, CbfError> {
    let mut walker = Walker::new(scenario.clone())?;
    let mut result = RunResult {
        scenario: scenario.clone(),
        com_path: vec![walker.com()],
        steps: Vec::new(),
        reached_goal: walker.at_goal(),
        failure: None,
    };
    while !result.reached_goal && result.steps.len() < scenario.max_steps {
        let outcome = walker.step()?;
        result.steps.push(StepRecord { outcome, com: walker.com(), h: walker.h().to_vec() });
        if !outcome.advanced {
            result.failure = Some(outcome.status);
            break;
        }
        result.com_path.push(walker.com());
        result.reached_goal = walker.at_goal();
    }
    Ok(result)
}
