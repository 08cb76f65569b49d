//! One scenario's world and nominal controller, stepped by whoever owns the control loop:
//! [`super::run`] in Rust, or a Python loop through the bindings.
//!
//! Each cycle, [`Course::plan`] reads the state, updates the filter's [`Environment`]
//! (floor under each toe, which legs swing, the swing legs' foothold strips) and returns
//! the gait's nominal input. The caller filters that input and integrates.

use super::gait::{Gait, GaitParams, OriginRule, Plan, STANCE_AXLE};
use super::Scenario;
use crate::catalog::{Capacity, EdgeCuboid, Environment, HalfPlane, StabilityBound};
use crate::generated as gen;
use crate::model::{self, State};
use crate::terrain::route::Route;
use crate::terrain::solid::TerrainClearance;
use crate::terrain::{Profile, SolidTerrain, Terrain};
use cbfgen::error::CbfError;

/// Each toe within this distance (x) of its hip, relative to the body: the stability
/// bounds of eq. 13 \[m\].
const STABILITY_REACH: f64 = 0.45;
/// A standing wheel's centre stays this far past the start of the level it stands on,
/// over its tread \[m\].
const STANCE_INSET: f64 = 0.02;
/// A swing toe outside its foothold strip is pulled to this far inside it \[m\].
const FOOTHOLD_PULL_MARGIN: f64 = 0.01;
/// A level with no start (the first) bounds a standing wheel this far back \[m\].
const STANCE_REACH: f64 = 100.0;

/// The terrain, the edge cuboids the filter avoids, and the gait.
///
/// By default the filter and the gait see the true terrain. A perception loop replaces
/// what they see with [`Course::set_perceived`]; the exact clearances and the finish are
/// always judged against the true terrain.
///
/// A course with turns ([`Route`]) is planned one flight at a time: the gait reads the
/// state in the current flight's frame, and at the flight's turn point it turns on the
/// spot to face the next one ([`Gait::turn_by`]: turning swings on three legs about a
/// drive axle), whose frame it then plans in.
#[derive(Debug, Clone)]
pub struct Course {
    route: Route,
    /// The flight the gait plans on.
    flight: usize,
    /// While turning: the flight it turns to.
    turning_to: Option<usize>,
    /// Whether the loop calls [`Course::exchange_origin`] (a turn needs it).
    origin_exchanged: bool,
    env: Environment,
    /// How far the body rows keep the model's body from every edge
    /// ([`Course::set_body_roll`]) \[m\].
    body_clearance: f64,
    /// The true terrain's solids, for the exact clearance checks.
    solids: SolidTerrain,
    gait: Gait,
}

impl Course {
    /// The scenario's terrain, with every edge pushed into an environment of the paper's
    /// worst-case [`Capacity`].
    ///
    /// # Errors
    /// Stair dimensions that fail [`Stairs::validate`](crate::terrain::Stairs::validate),
    /// or more changes of height than [`Course::CAPACITY`] has edge slots.
    pub fn new(scenario: Scenario, gait: GaitParams) -> Result<Self, CbfError> {
        Self::from_route(scenario.route()?, gait)
    }

    /// A course on a route of your own ([`Route::new`]): flights placed in the plane,
    /// turning between them. The robot starts on the first flight's path (its x axis)
    /// as on any course ([`Course::initial_state`]), facing along it.
    ///
    /// # Errors
    /// More changes of height than [`Course::CAPACITY`] has edge slots.
    pub fn from_route(route: Route, gait: GaitParams) -> Result<Self, CbfError> {
        let mut env = Environment::new(Self::CAPACITY)?;
        for riser in route.riser_cuboids()? {
            env.push_edge(riser)?;
        }
        for (leg, hip) in model::HIP_POSITIONS.iter().enumerate() {
            env.stability[leg] = [
                Some(StabilityBound { a: 1.0, b: STABILITY_REACH - hip[0] }),
                Some(StabilityBound { a: -1.0, b: STABILITY_REACH + hip[0] }),
            ];
        }
        let gait = Gait::new(gait, route.flights()[0].profile()?);
        let solids = SolidTerrain::from_boxes(route.solid_boxes()?);
        Ok(Self { route, flight: 0, turning_to: None, origin_exchanged: false, env, body_clearance: 0.0, solids, gait })
    }

    /// The capacity every course's environment is laid out for; build the filter with it.
    pub const CAPACITY: Capacity = Capacity::PAPER_WORST_CASE;

    /// The standard posture, placed so that the robot's foremost point is `start_gap`
    /// metres before the first riser, on the first flight's path and facing along it.
    pub fn initial_state(&self, start_gap: f64) -> State {
        let mut x = model::standard_posture();
        x[0] = self.terrain().first_change() - start_gap - model::front_reach(&x);
        // The origin stands on the first flight's floor.
        let placement = self.route.flights()[0].placement;
        x[gen::state::PZ] = placement.lift;
        placement.world_state(&x)
    }

    /// Update the environment for state `x` at time `t` and return the gait's plan.
    ///
    /// # Errors
    /// A non-finite state, or ground without room for a foothold.
    pub fn plan(&mut self, t: f64, x: &State) -> Result<Plan, CbfError> {
        for &v in x {
            cbfgen::error::finite("state entry", v)?;
        }
        // The gait plans in the current flight's frame. At the flight's turn point it turns
        // on the spot to face the next flight, in whose frame it plans once turned.
        if self.gait.turning_swing().is_some() && !self.origin_exchanged {
            return Err(CbfError::Malformed {
                what: "control loop",
                why: "a turning swing turns about a drive axle, onto which Course::exchange_origin moves the \
                      origin: call it before Course::plan each cycle"
                    .into(),
            });
        }
        let flights = self.route.flights();
        if let Some(next) = self.turning_to {
            if self.gait.turned() {
                self.gait.turn_frame(flights[next].placement.heading - flights[self.flight].placement.heading);
                self.gait.set_ground(flights[next].profile()?);
                self.flight = next;
                self.turning_to = None;
            }
        } else if self.gait.swinging().is_none() {
            if let (Some(turn_at), Some(next)) = (flights[self.flight].turn_at, flights.get(self.flight + 1)) {
                let here = flights[self.flight].placement;
                if here.local_state(x)[0] >= turn_at {
                    self.gait.turn_by(next.placement.heading - here.heading)?;
                    self.turning_to = Some(self.flight + 1);
                }
            }
        }
        let placement = self.route.flights()[self.flight].placement;
        let world = |planes: &[HalfPlane; 4]| -> Result<[HalfPlane; 4], CbfError> {
            let mut out = *planes;
            for (o, p) in out.iter_mut().zip(planes) {
                *o = placement.world_half_plane(p)?;
            }
            Ok(out)
        };
        let (_, _, world_toes) = gen::world_kinematics(x);
        let x = &placement.local_state(x);
        let (_, _, toes) = gen::world_kinematics(x);
        self.env.set_floors(self.gait.ground().floors_under(&toes));
        let plan = self.gait.plan(t, x)?;
        // Every leg's foothold rows apply: a swinging toe keeps to its strip, and a
        // standing one keeps its centre STANCE_INSET past the start of the level it
        // stands on. A wheel left on a nosing's corner with its centre before the riser
        // (the middle rear one, dragged back as the body came down with its hip at the
        // limit) reads clear to the toe rows, but a physical wheel rolls back off the
        // step there (MuJoCo: it dropped 15 cm onto the tread below).
        self.env.set_swing([true; 6]);
        for (leg, strip) in plan.footholds.iter().enumerate() {
            match strip {
                Some(strip) => {
                    // A swing toe outside its strip (the strip was re-planned on new
                    // perception, or a row above the foothold's pushed the toe out) is
                    // pulled in by the foothold CLF instead (section IV-D).
                    self.env.set_foothold(leg, &world(strip)?)?;
                    self.env.guide_toe(leg, [world_toes[leg][0], world_toes[leg][1]], FOOTHOLD_PULL_MARGIN)?;
                }
                None => {
                    let ground = self.gait.ground();
                    let begin = ground.level_at(ground.standing_x(&toes[leg])).begin.max(-STANCE_REACH);
                    let stance = HalfPlane::new([1.0, 0.0], -(begin + STANCE_INSET))?;
                    self.env.set_foothold(leg, &[placement.world_half_plane(&stance)?])?;
                }
            }
        }
        Ok(plan)
    }

    /// Move the origin of `x` where the support puts it ([`model::shift_origin`]) and
    /// return how far it jumped \[m\] along its heading; call it before [`Course::plan`]
    /// each cycle. A turning swing moves it onto the centre of the drive axle left down
    /// ([`STANCE_AXLE`]), which the robot turns about, and back once the swing is over:
    /// under the body with the rolling origin, to the six wheels' centroid with
    /// [`OriginRule::JumpAtExchange`], which also moves it there at every other support
    /// exchange (a swing ending at `t`). Nothing the filter sees changes (every world
    /// pose, and with the yaw rate at zero every world velocity, is kept), so it waits
    /// while the yaw rate is not zero (above 1e-3 rad/s): the turns keep it zero when the
    /// drive wheels lift and land.
    pub fn exchange_origin(&mut self, t: f64, x: &mut State) -> Option<f64> {
        self.origin_exchanged = true;
        if x[gen::state::YAW_RATE].abs() >= 1e-3 {
            return None;
        }
        let toe_x = |x: &State, leg: usize| x[model::TOE_BLOCK + 4 * leg];
        let centroid = |x: &State| (0..6).map(|leg| toe_x(x, leg)).sum::<f64>() / 6.0;
        let jump_at_exchange = self.gait.origin_rule() == OriginRule::JumpAtExchange;
        let d = match (self.gait.turning_swing(), self.gait.origin_on_axle()) {
            (Some(tripod), false) if !self.gait.support_exchange_due(t) => {
                let [a, b] = STANCE_AXLE[tripod];
                self.gait.set_origin_on_axle(true);
                (toe_x(x, a) + toe_x(x, b)) / 2.0
            }
            (Some(_), _) => return None,
            (None, true) => {
                self.gait.set_origin_on_axle(false);
                if jump_at_exchange {
                    centroid(x)
                } else {
                    x[model::BODY_X]
                }
            }
            (None, false) if jump_at_exchange && self.gait.support_exchange_due(t) => centroid(x),
            (None, false) => return None,
        };
        model::shift_origin(x, d);
        Some(d)
    }

    /// The paper's velocity command from now on: roll at `speed` \[m/s\] and turn at
    /// `yaw_rate` \[rad/s\] ([`Gait::command`]: three-leg turning swings whenever the
    /// heading lags the command's). A route's own turns still turn on the spot.
    ///
    /// # Errors
    /// As [`Gait::command`]; nothing changes then.
    pub fn command(&mut self, speed: f64, yaw_rate: f64) -> Result<(), CbfError> {
        self.gait.command(speed, yaw_rate)
    }

    /// The gait (its turn state and limits, such as [`Gait::max_yaw_rate`]).
    pub fn gait(&self) -> &Gait {
        &self.gait
    }

    /// What the filter must respect this cycle (as of the last [`Course::plan`]).
    pub fn environment(&self) -> &Environment {
        &self.env
    }

    /// The true terrain of this course: of its first flight, for a course with turns
    /// ([`Course::route`]).
    pub fn terrain(&self) -> &Terrain {
        &self.route.flights()[0].terrain
    }

    /// The ground the gait plans on and the floors are read from: the true profile, or
    /// the last perceived one.
    pub fn ground(&self) -> &Profile {
        self.gait.ground()
    }

    /// Replace what the gait and the filter see with a perception of the terrain: the
    /// ground along the path and the edge cuboids (the first [`Capacity::edges`] of
    /// `edges`, which the caller orders nearest first).
    ///
    /// # Errors
    /// None in practice: the environment's edge slots are only filled up to capacity.
    pub fn set_perceived(&mut self, ground: Profile, edges: &[EdgeCuboid]) -> Result<(), CbfError> {
        self.gait.set_ground(ground);
        self.env.clear_edges();
        for &edge in edges.iter().take(Self::CAPACITY.body_edge.min(Self::CAPACITY.toe_edge)) {
            self.env.push_edge(edge)?;
        }
        self.env.set_body_clearance(self.body_clearance)
    }

    /// The body's measured roll \[rad\], which the sagittal model does not hold: from now
    /// on the body rows keep the model's body [`model::roll_clearance`] away from every
    /// edge, so the rolled body is clear when they hold (0, the default: the body as the
    /// model has it). A physical robot's loop calls it each cycle with its IMU's roll.
    ///
    /// # Errors
    /// A roll that is not finite; nothing changes then.
    pub fn set_body_roll(&mut self, roll: f64) -> Result<(), CbfError> {
        let clearance = model::roll_clearance(cbfgen::error::finite("body roll", roll)?);
        self.env.set_body_clearance(clearance)?;
        self.body_clearance = clearance;
        Ok(())
    }

    /// Which tripod swings now, if any.
    pub fn swinging(&self) -> Option<usize> {
        self.gait.swinging()
    }

    /// Exact clearances of the body and the wheels at `x` to the true terrain's solids
    /// ([`SolidTerrain::clearance`]).
    ///
    /// # Errors
    /// A state whose body rotation is not a rotation (non-finite entries).
    pub fn clearance(&self, x: &State) -> Result<TerrainClearance, CbfError> {
        self.solids.clearance(x)
    }

    /// The true terrain's solids, floor first.
    pub fn solids(&self) -> &SolidTerrain {
        &self.solids
    }

    /// The terrain perception runs on ([`Perceiver::new`](super::perceived::Perceiver::new)).
    ///
    /// # Errors
    /// A course with turns: perception builds one profile along x, and does not yet map
    /// a route.
    pub fn perceivable(&self) -> Result<&Terrain, CbfError> {
        match self.route.flights() {
            [only] => Ok(&only.terrain),
            flights => Err(CbfError::OutOfRange {
                what: "flights of a course run on perceived terrain",
                value: flights.len() as f64,
                range: "1",
            }),
        }
    }

    /// The whole course: its flights, where they are and where the robot turns.
    pub fn route(&self) -> &Route {
        &self.route
    }

    /// On the last flight, every toe stands on its true last level, the body centre is
    /// past its last change of height and no tripod swings.
    pub fn finished(&self, x: &State) -> bool {
        let Some(last) = self.route.flights().last() else { return false };
        if self.flight + 1 != self.route.flights().len() || self.turning_to.is_some() {
            return false;
        }
        let x = last.placement.local_state(x);
        let ground = last.terrain.profile();
        let (body_center, _, toes) = gen::world_kinematics(&x);
        let lift = last.placement.lift;
        let arrived = ground
            .floors_under(&toes.map(|t| [t[0], t[1], t[2] - lift]))
            .iter()
            .all(|&floor| (floor - ground.final_height()).abs() < 1e-9);
        arrived && body_center[0] > ground.last_change() && self.gait.swinging().is_none()
    }
}
