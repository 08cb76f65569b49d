//! A scripted drive up to a staircase: the workload of the latency harness, the filter
//! bench and the scenario-derived QP tests.
//!
//! The robot starts in its standard posture on flat ground and rolls forward at a
//! commanded speed. The nominal input is deliberately naive — track the speed, hold the
//! standard posture, nod the body a little so the QP keeps changing — and does not know
//! about the stairs: the filter has to stop the toes and body at the first nosing.
//! Every row of the catalog is evaluated each cycle ([`worst_case_environment`]).

use crate::catalog::{Capacity, Environment};
use crate::model::{self, Input, State, BODY_PITCH, BODY_X, BODY_Z, NU, TOE_BLOCK};
use crate::terrain::{worst_case_environment, Profile, Stairs};
use cbfgen::error::CbfError;

/// State indices of the origin's speed and yaw rate.
const SPEED: usize = 4;
const YAW_RATE: usize = 5;
/// Posture-hold gains: stiffness [1/s²] and damping [1/s].
const KP: f64 = 40.0;
const KD: f64 = 12.0;
/// Speed tracking gain [1/s].
const KV: f64 = 2.0;

/// The closed-loop workload: state, environment and nominal controller.
#[derive(Debug, Clone)]
pub struct Approach {
    /// The robot's current state; [`Approach::advance`] integrates it.
    pub x: State,
    /// What the filter sees: every catalog row filled ([`worst_case_environment`]), with
    /// the floor heights under the toes refreshed on each [`Approach::advance`].
    pub env: Environment,
    ground: Profile,
    posture: State,
    speed: f64,
    t: f64,
}

impl Approach {
    /// Start with the robot's foremost point (body front or a toe) `start_gap` metres
    /// before the first riser, rolling at `speed` [m/s].
    ///
    /// # Errors
    /// Invalid stair dimensions or a non-finite speed or gap.
    pub fn new(capacity: Capacity, stairs: Stairs, start_gap: f64, speed: f64) -> Result<Self, CbfError> {
        cbfgen::error::finite("speed", speed)?;
        cbfgen::error::finite("start gap", start_gap)?;
        let posture = model::standard_posture();
        let mut x = posture;
        x[0] = stairs.start_x - start_gap - model::front_reach(&posture);
        x[SPEED] = speed;
        // Footholds wide enough to contain every toe for the whole drive.
        let env = worst_case_environment(capacity, &stairs, [x[0], 0.0], 4.0)?;
        let ground = stairs.terrain()?.profile().clone();
        let mut approach = Self { x, env, ground, posture, speed, t: 0.0 };
        approach.update_floors();
        Ok(approach)
    }

    /// Seconds since the start.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// The nominal (unsafe) input for the current state.
    pub fn nominal_input(&self) -> Input {
        let x = &self.x;
        let mut u = [0.0; NU];
        u[0] = KV * (self.speed - x[SPEED]);
        u[1] = -KD * x[YAW_RATE];
        let nod = 0.05 * (2.0 * self.t).sin();
        for (k, (pos, target)) in [(BODY_X, 0.0), (BODY_Z, 0.0), (BODY_PITCH, nod)].into_iter().enumerate() {
            u[2 + k] = KP * (self.posture[pos] + target - x[pos]) - KD * x[pos + 3];
        }
        for leg in 0..6 {
            for axis in 0..2 {
                let pos = TOE_BLOCK + 4 * leg + axis;
                u[5 + 2 * leg + axis] = KP * (self.posture[pos] - x[pos]) - KD * x[pos + 2];
            }
        }
        u
    }

    /// Integrate `ẋ = f(x) + g(x) u` over `dt` (explicit Euler; the filter runs at 1 kHz)
    /// and refresh the floor height under each toe.
    pub fn advance(&mut self, u: &Input, dt: f64) {
        let dx = model::xdot(&self.x, u);
        for (x, d) in self.x.iter_mut().zip(dx) {
            *x += d * dt;
        }
        self.t += dt;
        self.update_floors();
    }

    /// Distance from the origin to the robot's foremost point \[m\].
    pub fn front_reach(&self) -> f64 {
        model::front_reach(&self.x)
    }

    fn update_floors(&mut self) {
        let (_, _, toes) = crate::generated::world_kinematics(&self.x);
        self.env.set_floors(self.ground.floors_under(&toes));
    }
}
