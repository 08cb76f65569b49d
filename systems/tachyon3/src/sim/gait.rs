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
/// The drive axle that stays down while each tripod swings, in `LEG_NAMES` indices:
/// LF and RF while tripod 0 (LR, RR, MF) is lifted, LR and RR while tripod 1 is. With
/// the middle omnidirectional wheel of the same tripod they carry a turn (the paper's
/// section II-B): the robot turns about that axle's centre.
pub const STANCE_AXLE: [[usize; 2]; 2] = [[0, 2], [3, 5]];
/// How long a turning swing takes \[s\].
pub const TURN_SWING_TIME: f64 = 2.5;
/// Fractions of a turning swing between which the yaw spline runs: the lifted wheels are
/// then at least half their lift above the floor, and both ends have zero yaw rate, so
/// the drive wheels land (and lift) with the robot not turning.
pub const TURN_WINDOW: [f64; 2] = [0.2, 0.8];
/// Most a turning swing turns \[rad\] (30°): the cubic spline over the window then asks
/// for at most 6 · (π/6) / 1.5² = 1.4 rad/s² of the model's 3, and 0.52 rad/s.
pub const MAX_SWING_TURN: f64 = std::f64::consts::FRAC_PI_6;
/// Below this forward speed \[m/s\] a turn on the spot may lift a tripod.
const STOPPED_SPEED: f64 = 0.01;
/// A heading this close to the goal \[rad\] needs no turning swing.
const HEADING_TOLERANCE: f64 = 1e-3;
/// Fractions of a swing spent lifting, carrying forward, lowering.
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
    /// A turning swing's yaw spline: the robot turns on the other tripod about its
    /// [`STANCE_AXLE`], and the lifted toes land under their hips (body-relative x in
    /// `from` and `land_x`) rather than at world points ahead.
    turn: Option<YawSpline>,
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
    /// The heading the robot is to face, in the frame the gait plans in \[rad\]: set by
    /// a turn ([`Gait::turn_by`]) or run on by a yaw-rate command ([`Gait::command`]).
    heading_goal: f64,
    /// The heading held on six wheels: where the last turning swing ended \[rad\].
    yaw_hold: f64,
    /// The commanded yaw rate \[rad/s\] that runs `heading_goal` on.
    yaw_rate_command: f64,
    /// Whether the turn under way is on the spot (a route's turn): the robot stops to
    /// turn rather than rolling on through it.
    on_the_spot: bool,
    /// Whether the origin stands on a drive axle (moved there for a turning swing by
    /// [`Course::exchange_origin`](super::Course::exchange_origin)): the body holds its
    /// place relative to it instead of being brought over it.
    origin_on_axle: bool,
}

/// The paper's yaw reference through a turning swing: a cubic from `from` to `from + by`
/// over the swing's [`TURN_WINDOW`], with zero yaw rate at both ends, so the rate is zero
/// whenever the drive wheels land.
#[derive(Debug, Clone, Copy, PartialEq)]
struct YawSpline {
    start: f64,
    from: f64,
    by: f64,
}

impl YawSpline {
    /// Yaw, yaw rate and yaw acceleration at time `t` (the swing started at `start`).
    fn at(&self, t: f64) -> [f64; 3] {
        let span = (TURN_WINDOW[1] - TURN_WINDOW[0]) * TURN_SWING_TIME;
        let tau = ((t - self.start) / TURN_SWING_TIME - TURN_WINDOW[0]) * TURN_SWING_TIME / span;
        let (sigma, rate) = smoothstep(tau);
        let accel = if (0.0..1.0).contains(&tau) { 6.0 - 12.0 * tau } else { 0.0 };
        [self.from + self.by * sigma, self.by * rate / span, self.by * accel / (span * span)]
    }
}

/// How long turning by `angle` \[rad\] takes on the spot with `stance_time` \[s\] on six
/// wheels between turning swings: one swing per [`MAX_SWING_TURN`].
pub fn turn_time(angle: f64, stance_time: f64) -> f64 {
    let swings = (angle.abs() / MAX_SWING_TURN - 1e-9).ceil().max(0.0);
    swings * (TURN_SWING_TIME + stance_time)
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
            heading_goal: 0.0,
            yaw_hold: 0.0,
            yaw_rate_command: 0.0,
            on_the_spot: false,
            origin_on_axle: false,
        }
    }

    /// Turn on the spot by `by` radians (positive: left) from the heading held now: the
    /// robot stops rolling and turns in turning swings of at most [`MAX_SWING_TURN`]
    /// each, the tripods taking turns to lift (the paper's three-leg turn, see
    /// [`STANCE_AXLE`]), until it faces the new heading ([`Gait::turned`]).
    ///
    /// # Errors
    /// A non-finite or out-of-range angle (at most a half turn); nothing changes then.
    pub fn turn_by(&mut self, by: f64) -> Result<(), CbfError> {
        cbfgen::error::within("turn angle [rad]", by, -std::f64::consts::PI, std::f64::consts::PI, "[-pi, pi]")?;
        self.heading_goal = self.yaw_hold + by;
        self.on_the_spot = true;
        Ok(())
    }

    /// The fastest yaw rate a command may ask for \[rad/s\]: one [`MAX_SWING_TURN`] per
    /// turning swing and stance.
    pub fn max_yaw_rate(&self) -> f64 {
        MAX_SWING_TURN / (TURN_SWING_TIME + self.params.stance_time)
    }

    /// The paper's velocity command: roll at `speed` \[m/s\] and turn at `yaw_rate`
    /// \[rad/s\] (positive: left). The heading goal runs on at `yaw_rate`; whenever the
    /// held heading lags it, a tripod lifts and the robot turns on the other three legs
    /// about their drive axle, still rolling (at `step_speed`), and the lifted
    /// toes land under their hips: the 2-D footsteps of the commanded motion.
    ///
    /// # Errors
    /// A speed outside \[0, 1\] m/s or a yaw rate beyond [`Gait::max_yaw_rate`] (or
    /// either not finite); nothing changes then.
    pub fn command(&mut self, speed: f64, yaw_rate: f64) -> Result<(), CbfError> {
        cbfgen::error::within("commanded speed [m/s]", speed, 0.0, 1.0, "[0, 1]")?;
        let max = self.max_yaw_rate();
        cbfgen::error::within("commanded yaw rate [rad/s]", yaw_rate, -max, max, "|rate| <= max_yaw_rate")?;
        self.params.speed = speed;
        self.yaw_rate_command = yaw_rate;
        self.on_the_spot = false;
        Ok(())
    }

    /// Whether the robot faces its heading goal, on six wheels, with the origin off the
    /// axle: a turn is over.
    pub fn turned(&self) -> bool {
        self.swing.is_none() && !self.origin_on_axle && (self.heading_goal - self.yaw_hold).abs() < HEADING_TOLERANCE
    }

    /// Plan from now on in a frame turned by `by` \[rad\] from the present one (the next
    /// flight's, after a turn): the held heading and the goal are re-expressed in it.
    pub fn turn_frame(&mut self, by: f64) {
        self.heading_goal -= by;
        self.yaw_hold -= by;
        self.on_the_spot = false;
    }

    /// The turning swing under way, if any: the tripod lifted.
    pub fn turning_swing(&self) -> Option<usize> {
        self.swing.filter(|s| s.turn.is_some()).map(|s| s.tripod)
    }

    /// Whether the origin stands on a drive axle (see [`Gait::turning_swing`]).
    pub fn origin_on_axle(&self) -> bool {
        self.origin_on_axle
    }

    /// Record that the origin was moved onto the turning swing's drive axle (`true`) or
    /// back off it (`false`) ([`Course::exchange_origin`](super::Course::exchange_origin)).
    pub fn set_origin_on_axle(&mut self, on: bool) {
        self.origin_on_axle = on;
    }

    /// Whether the swing under way ends at `t`: the support legs change then.
    pub fn support_exchange_due(&self, t: f64) -> bool {
        self.swing.is_some_and(|s| t - s.start >= s.duration(&self.params))
    }

    /// How the origin moves.
    pub fn origin_rule(&self) -> OriginRule {
        self.params.origin
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

        let dt = (t - self.last_t).clamp(0.0, 1.0);
        self.last_t = t;
        self.heading_goal += self.yaw_rate_command * dt;
        if let Some(s) = self.swing {
            if t - s.start >= s.duration(&p) {
                self.swing = None;
                self.last_tripod = s.tripod;
                self.stance_since = t;
                if let Some(turn) = s.turn {
                    self.yaw_hold = turn.from + turn.by;
                }
            }
        }
        let turn_due = (self.heading_goal - self.yaw_hold).abs() >= HEADING_TOLERANCE;
        let stopped_to_turn = self.on_the_spot && (turn_due || self.swing.is_some_and(|s| s.turn.is_some()));
        if stopped_to_turn {
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
        let rolling = t - self.stopped_at >= p.stall_time;
        let rate = if stalled {
            p.stall_raise_rate
        } else if rolling {
            -STALL_LOWER_RATE
        } else {
            0.0
        };
        self.stall_raise = (self.stall_raise + rate * dt).clamp(0.0, p.stall_raise_max);
        // A turn lifts the tripods in turn, whatever lies ahead; the origin must be off
        // the last turning swing's axle first (the course moves it once the yaw rate
        // has settled), and a turn on the spot waits for the robot to stop rolling.
        let stance_done = self.swing.is_none() && t - self.stance_since >= p.stance_time;
        let stopped = !self.on_the_spot || x[4].abs() < STOPPED_SPEED;
        if stance_done && turn_due && !self.origin_on_axle && stopped {
            let by = (self.heading_goal - self.yaw_hold).clamp(-MAX_SWING_TURN, MAX_SWING_TURN);
            self.swing = Some(self.lift_to_turn(1 - self.last_tripod, t, x, &toes, by)?);
        } else if stance_done && !turn_due {
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
        let turn = self.swing.and_then(|s| s.turn);
        let speed = if stopped_to_turn {
            0.0
        } else if self.swing.is_some() {
            p.step_speed
        } else {
            p.speed
        };
        u[0] = KV * (speed - x[4]);
        // Heading: the one held on six wheels (the drive wheels cannot steer), or the
        // turning swing's spline.
        let [yaw, yaw_rate, yaw_accel] = turn.map_or([self.yaw_hold, 0.0, 0.0], |turn| turn.at(t));
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
        // Along the heading: a turn faces the robot across the frame's x.
        let (sin_yaw, cos_yaw) = x[3].sin_cos();
        let along = |l: usize| toes[l][0] * cos_yaw + toes[l][1] * sin_yaw;
        let run = mean(front, &along) - mean(rear, &along);
        let pitch = -rise.atan2(run);
        // Body targets are origin-relative; the origin stays at its initial height.
        let body_z = body_height - x[2];
        for (k, (pos, target)) in [(BODY_X, 0.0), (BODY_Z, body_z), (BODY_PITCH, pitch)].into_iter().enumerate() {
            u[2 + k] = KP * (target - x[pos]) - KD * x[pos + 3];
        }
        // With the origin on a drive axle the body holds its place over the support.
        let pivoting = self.origin_on_axle || turn.is_some();
        if pivoting {
            u[2] = -KD * x[BODY_X + 3];
        }

        let mut swing = [false; 6];
        let mut footholds = [None; 6];
        for leg in 0..6 {
            let (ix, iz) = (TOE_BLOCK + 4 * leg, TOE_BLOCK + 4 * leg + 1);
            let (ax, az) = (5 + 2 * leg, 6 + 2 * leg);
            match self.swing.filter(|s| TRIPODS[s.tripod].contains(&leg)) {
                Some(s) => {
                    // A turning swing's toes are placed relative to the body, which
                    // the origin moves under (its carry is body-relative), and the
                    // others at world points along the path.
                    let bases = if s.turn.is_some() { [x[BODY_X]; 2] } else { [0.0, -x[0]] };
                    let ([rx, vx], [rz, vz]) = swing_reference(&s, leg, t, bases, &p);
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
                        + if p.origin == OriginRule::JumpAtExchange || pivoting { x[BODY_X] } else { 0.0 };
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
        let mut s = Swing::lifting(tripod, t, None);
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

    /// Plan a turning swing of `tripod` by `by` \[rad\] from the held heading: each
    /// lifted toe rises by the swing clearance over the level it stands on and lands on
    /// that level under its hip, its foothold the whole flat region it stands in. The
    /// robot turns about the other tripod's [`STANCE_AXLE`] meanwhile.
    fn lift_to_turn(&self, tripod: usize, t: f64, x: &State, toes: &[[f64; 3]; 6], by: f64) -> Result<Swing, CbfError> {
        let mut s = Swing::lifting(tripod, t, Some(YawSpline { start: t, from: self.yaw_hold, by }));
        for &leg in &TRIPODS[tripod] {
            let toe_x = self.ground.standing_x(&toes[leg]);
            let here = self.ground.height_at(toe_x);
            // Body-relative: the origin moves onto the drive axle under the swing.
            s.from[leg] = [x[TOE_BLOCK + 4 * leg] - x[BODY_X], x[TOE_BLOCK + 4 * leg + 1]];
            s.land_x[leg] = model::HIP_POSITIONS[leg][0];
            s.apex[leg] = here + TOE_RADIUS + self.params.clearance - x[2];
            s.land[leg] = here + TOE_RADIUS - x[2];
            let (begin, end) = self.ground.flat_region(toe_x);
            s.strip[leg] = foothold_strip(self.ground.level_at(toe_x).half_width, begin, end, FOOTHOLD_INSET)?;
        }
        Ok(s)
    }
}

impl Swing {
    /// A swing of `tripod` lifting off at `t`, turning by `turn` if given, with every
    /// leg's plan still to fill in.
    fn lifting(tripod: usize, t: f64, turn: Option<YawSpline>) -> Self {
        let unused = HalfPlane { normal: nalgebra::Vector2::new(1.0, 0.0), offset: 0.0 };
        Self {
            tripod,
            start: t,
            turn,
            from: [[0.0; 2]; 6],
            land_x: [0.0; 6],
            apex: [0.0; 6],
            land: [0.0; 6],
            strip: [[unused; 4]; 6],
        }
    }

    /// How long this swing lasts \[s\].
    fn duration(&self, p: &GaitParams) -> f64 {
        if self.turn.is_some() {
            TURN_SWING_TIME
        } else {
            p.swing_time
        }
    }
}

/// Smoothstep from 0 to 1 over `tau` in [0, 1], and its derivative in `tau`.
fn smoothstep(tau: f64) -> (f64, f64) {
    let tau = tau.clamp(0.0, 1.0);
    (tau * tau * (3.0 - 2.0 * tau), 6.0 * tau * (1.0 - tau))
}

/// Origin-relative ([x, ẋ], [z, ż]) of a swinging toe: lift, carry to the landing point,
/// lower. `bases` are what `from` and `land_x` are measured from, origin-relative: for
/// a swing along the path, the origin at lift-off and minus the origin's x now (the
/// landing is a world point); for a turning swing's, the body's x (both body-relative).
fn swing_reference(s: &Swing, leg: usize, t: f64, bases: [f64; 2], p: &GaitParams) -> ([f64; 2], [f64; 2]) {
    let phase = ((t - s.start) / s.duration(p)).clamp(0.0, 1.0);
    let [x0, z0] = s.from[leg];
    let x0 = bases[0] + x0;
    let segment = |a: f64, b: f64| {
        let (sigma, rate) = smoothstep((phase - a) / (b - a));
        (sigma, rate / ((b - a) * s.duration(p)))
    };
    let (lift, lift_rate) = segment(0.0, LIFT_END);
    let (carry, carry_rate) = segment(LIFT_END, CARRY_END);
    let (lower, lower_rate) = segment(CARRY_END, 1.0);
    let z = z0 + (s.apex[leg] - z0) * lift + (s.land[leg] - s.apex[leg]) * lower;
    let vz = (s.apex[leg] - z0) * lift_rate + (s.land[leg] - s.apex[leg]) * lower_rate;
    let reach = bases[1] + s.land_x[leg] - x0;
    ([x0 + reach * carry, reach * carry_rate], [z, vz])
}
