//! The nominal (unsafe) motion the filter corrects: roll on the wheels at a commanded
//! speed and, when a toe meets a riser, step by exchanging the two tripods (LR, RR, MF
//! swing, then MR, LF, RF), each footstep projected onto the flat region it lands on.
//!
//! It is naive on purpose, like the paper's: the body is held at its nominal low height
//! above the toes' mean floor, pitched to the line from the rear toes' floor to the front
//! toes' (raised only while a tripod swings, so the lifted legs can reach forward), and
//! nothing here knows about the body's extent or the edges. Keeping the body off the nosings, the toes off the risers and the legs within
//! their limits is the safety filter's job.

use crate::catalog::HalfPlane;
use crate::generated as gen;
use crate::model::{self, Input, State, BODY_PITCH, BODY_X, BODY_Z, NU, TOE_BLOCK, TOE_RADIUS};
use crate::terrain::{foothold_strip, Profile};
use cbfgen::error::CbfError;

/// Legs of the two tripods, in `LEG_NAMES` indices: (LR, RR, MF) and (MR, LF, RF).
pub const TRIPODS: [[usize; 3]; 2] = [[3, 5, 1], [4, 0, 2]];

/// Posture and speed tracking gains: stiffness [1/s²], damping [1/s], speed [1/s].
const KP: f64 = 40.0;
const KD: f64 = 12.0;
const KP_SWING: f64 = 150.0;
const KD_SWING: f64 = 25.0;
const KV: f64 = 2.0;
/// Stance wheels return towards their hips at this rate [1/s], and at most this fraction
/// of the rolling speed.
const RETURN_RATE: f64 = 0.5;
const STANCE_RETURN: f64 = 0.8;
/// Once the robot has rolled again for a whole `stall_time`, a stall raise comes down at this
/// rate \[m/s\].
const STALL_LOWER_RATE: f64 = 0.02;
/// A foothold strip keeps the toe centre this far inside its flat region: the toe radius
/// and 2 cm \[m\].
pub const FOOTHOLD_INSET: f64 = TOE_RADIUS + 0.02;
/// A strip reaching back to a lift-off point outside its region's inset leaves the toe
/// this much room behind it \[m\].
const FOOTHOLD_SLACK: f64 = 0.01;
/// Fractions of a swing spent lifting, carrying forward, lowering.
/// How long a turn on the spot takes \[s\]: the cubic yaw spline of a 90° turn then asks
/// for at most 6 · (π/2) / 4² = 0.59 rad/s² of the model's 3.
pub const TURN_TIME: f64 = 4.0;
const LIFT_END: f64 = 0.4;
const CARRY_END: f64 = 0.7;

/// How the robot walks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaitParams {
    /// Rolling speed [m/s].
    pub speed: f64,
    /// Speed while a tripod swings [m/s].
    pub step_speed: f64,
    /// Duration of one swing \[s\].
    pub swing_time: f64,
    /// Minimum time on all six wheels between swings \[s\].
    pub stance_time: f64,
    /// Height of the swing apex above the higher of the two floors \[m\].
    pub clearance: f64,
    /// A toe steps when a riser is within this distance of its front \[m\].
    pub lookahead: f64,
    /// When the robot has been stalled (forward speed below 2 cm/s) for `stall_time` \[s\], toes
    /// with a riser within `stall_lookahead` \[m\] step too: the filter may be holding the
    /// body back until the rear legs climb.
    pub stall_time: f64,
    /// The step lookahead \[m\] that replaces `lookahead` once the robot has stalled for
    /// `stall_time`.
    pub stall_lookahead: f64,
    /// How far a swing carries the toe forward relative to the body on flat ground \[m\];
    /// over a riser it aims one toe radius past the riser instead.
    pub reach: f64,
    /// While a tripod swings, the body is held at least this far above the swing apex
    /// less the hip height, so the lifted leg keeps room to reach forward \[m\].
    pub leg_room: f64,
    /// While stalled for `stall_time`, the body target rises at this rate \[m/s\] (see
    /// [`Gait::plan`]).
    pub stall_raise_rate: f64,
    /// Highest the stall raise takes the body target above its nominal \[m\].
    pub stall_raise_max: f64,
    /// How the ground-moving origin moves.
    pub origin: OriginRule,
}

/// How the ground-moving origin moves (the paper's section II-B).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OriginRule {
    /// It rolls with its unicycle speed and the body is held over it: the origin is the
    /// body's footprint. The default: every run in the docs uses it.
    #[default]
    Rolling,
    /// As the paper's: it also jumps, at each support exchange (a swing's touchdown), to
    /// the centroid of the six wheels then in contact ([`Course::exchange_origin`](super::Course::exchange_origin)),
    /// and the body is held over it, so over the support.
    JumpAtExchange,
}

impl Default for GaitParams {
    fn default() -> Self {
        Self {
            speed: 0.2,
            step_speed: 0.08,
            swing_time: 1.2,
            stance_time: 0.3,
            clearance: 0.06,
            lookahead: 0.06,
            stall_time: 1.0,
            stall_lookahead: 0.3,
            reach: 0.12,
            leg_room: 0.15,
            stall_raise_rate: 0.05,
            stall_raise_max: 0.2,
            origin: OriginRule::Rolling,
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Swing {
    tripod: usize,
    start: f64,
    /// Per leg (only the tripod's are used): origin-relative x and z at lift-off, the
    /// world x it lands at, apex and touchdown heights, and the foothold strip from
    /// lift-off to landing (fixed for the swing, in the world: the origin moves under it).
    from: [[f64; 2]; 6],
    land_x: [f64; 6],
    apex: [f64; 6],
    land: [f64; 6],
    strip: [[HalfPlane; 4]; 6],
}

/// What the gait asks for this cycle.
#[derive(Debug, Clone, Copy)]
pub struct Plan {
    /// The nominal input, before the safety filter.
    pub u_ref: Input,
    /// Per leg, `LEG_NAMES` order: whether it swings this cycle.
    pub swing: [bool; 6],
    /// For swinging legs: the convex strip from the flat region it lifts off to the one
    /// it lands on.
    pub footholds: [Option<[HalfPlane; 4]>; 6],
    /// The nominal body centre height, world frame \[m\].
    pub body_height: f64,
}

/// The gait's state between cycles.
#[derive(Debug, Clone)]
pub struct Gait {
    params: GaitParams,
    ground: Profile,
    swing: Option<Swing>,
    last_tripod: usize,
    stance_since: f64,
    moving_since: f64,
    /// The last time the robot was not rolling forward \[s\].
    stopped_at: f64,
    /// Time of the last plan \[s\].
    last_t: f64,
    /// How far the body target is raised above the nominal to get out of a stall \[m\].
    stall_raise: f64,
    /// A turn on the spot under way.
    turn: Option<YawSpline>,
}

/// The paper's yaw reference through a turn: a cubic from `from` to `from + by` over
/// [`TURN_TIME`] with zero yaw rate at both ends, so the rate is zero whenever wheels
/// land (no tripod swings during the turn).
#[derive(Debug, Clone, Copy, PartialEq)]
struct YawSpline {
    start: f64,
    from: f64,
    by: f64,
}

impl YawSpline {
    /// Yaw, yaw rate and yaw acceleration at time `t`.
    fn at(&self, t: f64) -> [f64; 3] {
        let tau = ((t - self.start) / TURN_TIME).clamp(0.0, 1.0);
        let (sigma, rate) = smoothstep(tau);
        let accel = if (0.0..1.0).contains(&tau) { 6.0 - 12.0 * tau } else { 0.0 };
        [self.from + self.by * sigma, self.by * rate / TURN_TIME, self.by * accel / (TURN_TIME * TURN_TIME)]
    }
}

impl Gait {
    /// The gait for `params` over the ground `ground`, at t = 0 with all six wheels down;
    /// the first swing starts no earlier than `stance_time`.
    pub fn new(params: GaitParams, ground: Profile) -> Self {
        Self {
            params,
            ground,
            swing: None,
            last_tripod: 1,
            stance_since: 0.0,
            moving_since: 0.0,
            stopped_at: 0.0,
            last_t: 0.0,
            stall_raise: 0.0,
            turn: None,
        }
    }

    /// Turn on the spot by `by` radians (positive: left) from yaw `yaw` (the state's, in
    /// the frame the gait plans in), starting at `t`: the origin stops, no tripod lifts off,
    /// and the yaw follows a cubic spline with zero rate at both ends over [`TURN_TIME`].
    ///
    /// # Errors
    /// A tripod swinging (turn only on all six wheels), or a non-finite or out-of-range
    /// angle (at most a half turn).
    pub fn start_turn(&mut self, t: f64, yaw: f64, by: f64) -> Result<(), CbfError> {
        cbfgen::error::finite("turn start yaw", yaw)?;
        cbfgen::error::within("turn angle [rad]", by, -std::f64::consts::PI, std::f64::consts::PI, "[-pi, pi]")?;
        if self.swing.is_some() {
            return Err(CbfError::OutOfRange { what: "swinging tripods at a turn", value: 1.0, range: "0" });
        }
        self.turn = Some(YawSpline { start: t, from: yaw, by });
        Ok(())
    }

    /// Whether the swing under way ends at `t`: the support legs change then.
    pub fn support_exchange_due(&self, t: f64) -> bool {
        self.swing.is_some_and(|s| t - s.start >= self.params.swing_time)
    }

    /// How the origin moves.
    pub fn origin_rule(&self) -> OriginRule {
        self.params.origin
    }

    /// Whether the turn under way ends at `t`.
    pub fn turn_due_to_end(&self, t: f64) -> bool {
        self.turn.is_some_and(|turn| t - turn.start >= TURN_TIME)
    }

    /// Whether a turn is under way.
    pub fn turning(&self) -> bool {
        self.turn.is_some()
    }

    /// Replace the ground the gait plans on (a new perception of it). A swing under way
    /// keeps the landing and foothold it lifted off with.
    pub fn set_ground(&mut self, ground: Profile) {
        self.ground = ground;
    }

    /// The ground the gait plans on.
    pub fn ground(&self) -> &Profile {
        &self.ground
    }

    /// Which tripod swings now, if any.
    pub fn swinging(&self) -> Option<usize> {
        self.swing.map(|s| s.tripod)
    }

    /// The nominal input at time `t` \[s\] for state `x`.
    ///
    /// # Errors
    /// Only if the ground is degenerate (no room for a foothold).
    pub fn plan(&mut self, t: f64, x: &State) -> Result<Plan, CbfError> {
        let p = self.params;
        let (_, _, toes) = gen::world_kinematics(x);
        let floor = self.ground.floors_under(&toes);

        if let Some(s) = self.swing {
            if t - s.start >= p.swing_time {
                self.swing = None;
                self.last_tripod = s.tripod;
                self.stance_since = t;
            }
        }
        if self.turn_due_to_end(t) {
            self.turn = None;
            self.stance_since = t;
        }
        if self.turn.is_some() {
            // Stopped on purpose: neither a stall nor rolling.
            (self.moving_since, self.stopped_at) = (t, t);
        }
        // Rolling backwards (the filter yielding to the gait's own pull) is no progress.
        if x[4] >= 0.02 {
            self.moving_since = t;
        } else {
            self.stopped_at = t;
        }
        let stalled = t - self.moving_since >= p.stall_time;
        let lookahead = if stalled { p.stall_lookahead } else { p.lookahead };
        // A body held on the boundary of the body–edge CBF by the gait's own pull towards
        // the nominal height balances the forward command exactly (a CBF deadlock): a
        // stalled gait raises its body target until the body clears the nosing and rolls
        // again, then lowers it slowly once rolling has lasted a whole `stall_time` (a
        // brief roll at the first nosing is not yet clear of it: lowering then makes the
        // body oscillate on the nosing).
        let dt = (t - self.last_t).clamp(0.0, 1.0);
        self.last_t = t;
        let rolling = t - self.stopped_at >= p.stall_time;
        let rate = if stalled {
            p.stall_raise_rate
        } else if rolling {
            -STALL_LOWER_RATE
        } else {
            0.0
        };
        self.stall_raise = (self.stall_raise + rate * dt).clamp(0.0, p.stall_raise_max);
        if self.swing.is_none() && self.turn.is_none() && t - self.stance_since >= p.stance_time {
            let needs = TRIPODS
                .map(|legs| legs.iter().any(|&leg| self.riser_ahead(self.ground.standing_x(&toes[leg]), lookahead)));
            let tripod = match needs {
                [true, true] => Some(1 - self.last_tripod),
                [true, false] => Some(0),
                [false, true] => Some(1),
                [false, false] => None,
            };
            if let Some(tripod) = tripod {
                self.swing = Some(self.lift_off(tripod, t, x, &toes)?);
            }
        }

        let mut u = [0.0; NU];
        let speed = match (self.turn, self.swing) {
            (Some(_), _) => 0.0,
            (None, Some(_)) => p.step_speed,
            (None, None) => p.speed,
        };
        u[0] = KV * (speed - x[4]);
        // Heading: along the path (yaw 0 in the gait's frame), or the turn's spline.
        let [yaw, yaw_rate, yaw_accel] = self.turn.map_or([0.0; 3], |turn| turn.at(t));
        u[1] = yaw_accel + KP * (yaw - x[3]) + KD * (yaw_rate - x[5]);
        let low = floor.iter().sum::<f64>() / 6.0 + model::NOMINAL_CLEARANCE + model::BODY_HALF_EXTENTS[2];
        let hip_z = model::HIP_POSITIONS[0][2];
        let room = self.swing.map_or(f64::NEG_INFINITY, |s| {
            TRIPODS[s.tripod]
                .iter()
                .map(|&leg| s.apex[leg] + x[2] - hip_z + p.leg_room)
                .fold(f64::NEG_INFINITY, f64::max)
        });
        let body_height = low.max(room) + self.stall_raise;
        // Nose up along the line from the rear toes' floor to the front toes' (pitch > 0 is
        // nose down).
        let mean = |legs: [usize; 3], f: &dyn Fn(usize) -> f64| legs.iter().map(|&l| f(l)).sum::<f64>() / 3.0;
        let (front, rear) = ([0, 1, 2], [3, 4, 5]);
        let rise = mean(front, &|l| floor[l]) - mean(rear, &|l| floor[l]);
        let run = mean(front, &|l| toes[l][0]) - mean(rear, &|l| toes[l][0]);
        let pitch = -rise.atan2(run);
        // Body targets are origin-relative; the origin stays at its initial height.
        let body_z = body_height - x[2];
        for (k, (pos, target)) in [(BODY_X, 0.0), (BODY_Z, body_z), (BODY_PITCH, pitch)].into_iter().enumerate() {
            u[2 + k] = KP * (target - x[pos]) - KD * x[pos + 3];
        }

        let mut swing = [false; 6];
        let mut footholds = [None; 6];
        for leg in 0..6 {
            let (ix, iz) = (TOE_BLOCK + 4 * leg, TOE_BLOCK + 4 * leg + 1);
            let (ax, az) = (5 + 2 * leg, 6 + 2 * leg);
            match self.swing.filter(|s| TRIPODS[s.tripod].contains(&leg)) {
                Some(s) => {
                    let ([rx, vx], [rz, vz]) = swing_reference(&s, leg, t, x[0], &p);
                    u[ax] = KP_SWING * (rx - x[ix]) + KD_SWING * (vx - x[ix + 2]);
                    u[az] = KP_SWING * (rz - x[iz]) + KD_SWING * (vz - x[iz + 2]);
                    swing[leg] = true;
                    footholds[leg] = Some(s.strip[leg]);
                }
                None => {
                    // A stance wheel drifts back towards its hip only as fast as the robot
                    // rolls forward, so in the world it never rolls backwards off its tread.
                    let limit = STANCE_RETURN * x[4].max(0.0);
                    // Its hip, origin-relative: the body is the origin unless the origin
                    // jumps, when the body lags the support centroid it jumped to.
                    let hip = model::HIP_POSITIONS[leg][0]
                        + if p.origin == OriginRule::JumpAtExchange { x[BODY_X] } else { 0.0 };
                    let drift = (RETURN_RATE * (hip - x[ix])).clamp(-limit, limit);
                    u[ax] = KD * (drift - x[ix + 2]);
                    let stand_z = floor[leg] + TOE_RADIUS - x[2];
                    u[az] = KP * (stand_z - x[iz]) - KD * x[iz + 2];
                }
            }
        }
        Ok(Plan { u_ref: u, swing, footholds, body_height })
    }

    fn riser_ahead(&self, toe_x: f64, lookahead: f64) -> bool {
        let ahead = toe_x + TOE_RADIUS + lookahead;
        self.ground.height_at(ahead) > self.ground.height_at(toe_x) + 1e-3
    }

    /// Plan the swing of `tripod` from the toes' positions now. Each swinging toe's
    /// foothold strip runs from its lift-off point (which may lie on a nosing, a wheel
    /// resting on an edge, outside its region's inset) to the far end of the region it
    /// lands in.
    fn lift_off(&self, tripod: usize, t: f64, x: &State, toes: &[[f64; 3]; 6]) -> Result<Swing, CbfError> {
        let p = self.params;
        let unused = HalfPlane { normal: nalgebra::Vector2::new(1.0, 0.0), offset: 0.0 };
        let mut s = Swing {
            tripod,
            start: t,
            from: [[0.0; 2]; 6],
            land_x: [0.0; 6],
            apex: [0.0; 6],
            land: [0.0; 6],
            strip: [[unused; 4]; 6],
        };
        for &leg in &TRIPODS[tripod] {
            let (ix, iz) = (TOE_BLOCK + 4 * leg, TOE_BLOCK + 4 * leg + 1);
            s.from[leg] = [x[ix], x[iz]];
            let toe_x = self.ground.standing_x(&toes[leg]);
            let (lift_begin, region_end) = self.ground.flat_region(toe_x);
            let lift_x = toes[leg][0];
            let climbs = self.riser_ahead(toe_x, p.stall_lookahead.max(p.lookahead));
            s.land_x[leg] = if climbs { region_end + TOE_RADIUS } else { toe_x + p.reach };
            let here = self.ground.height_at(toe_x);
            let there = self.ground.height_at(s.land_x[leg]);
            s.apex[leg] = here.max(there) + TOE_RADIUS + p.clearance - x[2];
            s.land[leg] = there + TOE_RADIUS - x[2];
            let (_, land_end) = self.ground.flat_region(s.land_x[leg]);
            let begin = lift_begin.min(lift_x - FOOTHOLD_INSET - FOOTHOLD_SLACK);
            let half_width = self.ground.level_at(toe_x).half_width.min(self.ground.level_at(s.land_x[leg]).half_width);
            s.strip[leg] = foothold_strip(half_width, begin, land_end, FOOTHOLD_INSET)?;
        }
        Ok(s)
    }
}

/// Smoothstep from 0 to 1 over `tau` in [0, 1], and its derivative in `tau`.
fn smoothstep(tau: f64) -> (f64, f64) {
    let tau = tau.clamp(0.0, 1.0);
    (tau * tau * (3.0 - 2.0 * tau), 6.0 * tau * (1.0 - tau))
}

/// Origin-relative ([x, ẋ], [z, ż]) of a swinging toe: lift, carry to the landing point
/// (world-fixed, so relative to the origin at `px`), lower.
fn swing_reference(s: &Swing, leg: usize, t: f64, px: f64, p: &GaitParams) -> ([f64; 2], [f64; 2]) {
    let phase = ((t - s.start) / p.swing_time).clamp(0.0, 1.0);
    let [x0, z0] = s.from[leg];
    let segment = |a: f64, b: f64| {
        let (sigma, rate) = smoothstep((phase - a) / (b - a));
        (sigma, rate / ((b - a) * p.swing_time))
    };
    let (lift, lift_rate) = segment(0.0, LIFT_END);
    let (carry, carry_rate) = segment(LIFT_END, CARRY_END);
    let (lower, lower_rate) = segment(CARRY_END, 1.0);
    let z = z0 + (s.apex[leg] - z0) * lift + (s.land[leg] - s.apex[leg]) * lower;
    let vz = (s.apex[leg] - z0) * lift_rate + (s.land[leg] - s.apex[leg]) * lower_rate;
    let reach = s.land_x[leg] - px - x0;
    ([x0 + reach * carry, reach * carry_rate], [z, vz])
}
