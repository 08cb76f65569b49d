//! One scenario's world and nominal controller, stepped by whoever owns the control loop:
//! [`super::run`] in Rust, or a Python loop through the bindings.
//!
//! Each cycle, [`Course::plan`] reads the state, updates the filter's [`Environment`]
//! (floor under each toe, which legs swing, the swing legs' foothold strips) and returns
//! the gait's nominal input. The caller filters that input and integrates.

use super::gait::{Gait, GaitParams, Plan};
use super::Scenario;
use crate::catalog::{Capacity, EdgeCuboid, Environment, HalfPlane, StabilityBound};
use crate::generated as gen;
use crate::model::{self, State};
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
#[derive(Debug, Clone)]
pub struct Course {
    terrain: Terrain,
    env: Environment,
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
        let terrain = scenario.terrain()?;
        let mut env = Environment::new(Self::CAPACITY)?;
        for riser in terrain.riser_cuboids()? {
            env.push_edge(riser)?;
        }
        for (leg, hip) in model::HIP_POSITIONS.iter().enumerate() {
            env.stability[leg] = [
                Some(StabilityBound { a: 1.0, b: STABILITY_REACH - hip[0] }),
                Some(StabilityBound { a: -1.0, b: STABILITY_REACH + hip[0] }),
            ];
        }
        let gait = Gait::new(gait, terrain.profile().clone());
        let solids = SolidTerrain::new(&terrain)?;
        Ok(Self { terrain, env, solids, gait })
    }

    /// The capacity every course's environment is laid out for; build the filter with it.
    pub const CAPACITY: Capacity = Capacity::PAPER_WORST_CASE;

    /// The standard posture, placed so that the robot's foremost point is `start_gap`
    /// metres before the first riser.
    pub fn initial_state(&self, start_gap: f64) -> State {
        let mut x = model::standard_posture();
        x[0] = self.terrain.first_change() - start_gap - model::front_reach(&x);
        x
    }

    /// Update the environment for state `x` at time `t` and return the gait's plan.
    ///
    /// # Errors
    /// A non-finite state, or ground without room for a foothold.
    pub fn plan(&mut self, t: f64, x: &State) -> Result<Plan, CbfError> {
        for &v in x {
            cbfgen::error::finite("state entry", v)?;
        }
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
                    self.env.set_foothold(leg, strip)?;
                    self.env.guide_toe(leg, [toes[leg][0], toes[leg][1]], FOOTHOLD_PULL_MARGIN)?;
                }
                None => {
                    let ground = self.gait.ground();
                    let begin = ground.level_at(ground.standing_x(&toes[leg])).begin.max(-STANCE_REACH);
                    self.env.set_foothold(leg, &[HalfPlane::new([1.0, 0.0], -(begin + STANCE_INSET))?])?;
                }
            }
        }
        Ok(plan)
    }

    /// What the filter must respect this cycle (as of the last [`Course::plan`]).
    pub fn environment(&self) -> &Environment {
        &self.env
    }

    /// The true terrain of this course.
    pub fn terrain(&self) -> &Terrain {
        &self.terrain
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

    /// Every toe stands on the true terrain's last level, the body centre is past its
    /// last change of height and no tripod swings.
    pub fn finished(&self, x: &State) -> bool {
        let ground = self.terrain.profile();
        let (body_center, _, toes) = gen::world_kinematics(x);
        let arrived = ground.floors_under(&toes).iter().all(|&floor| (floor - ground.final_height()).abs() < 1e-9);
        arrived && body_center[0] > ground.last_change() && self.gait.swinging().is_none()
    }
}
