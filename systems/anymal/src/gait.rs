//! A trot: the simple reference the whole-body controller is tried on before a planner
//! drives it (seed 004's MPC, issue 38). After one still swing period the diagonal pairs
//! (RF + LH first, then LF + RH) alternate, each swing as long as a stance. The trunk moves
//! level at `velocity` (world x, y) from then on, and a swing foot goes from where it stood
//! to where it will be under its hip at mid-stance (`home` plus the trunk's travel: a
//! Raibert-style placement), rising `lift` and reaching `reach` further forward (world x)
//! at mid-swing, all on `(1 − cos 2πs)/2` (`s` the swing's phase) so it leaves and lands
//! with zero velocity. The weight is shared by the stance feet. With zero velocity it is a
//! trot in place. With a finite `duration` the trunk stops once it has walked that long
//! and the feet trot in place on the footholds of their stride nearest their hips.

use cbfgen::error::{finite, positive, CbfError};
use cbfgen::nalgebra::Matrix3;

use crate::wbc::{FootReference, WbcReference, FEET};
use crate::wbc_generated::{self as gen, Capacity, FootRegionParams, Params, NX};

/// One swing's timing and profiles, each as value and first two time derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Swing {
    /// When the foot left \[s\].
    pub lift_off: f64,
    /// When it lands \[s\].
    pub touchdown: f64,
    /// The share of the way from the last foothold to the next (0 → 1).
    pub travel: [f64; 3],
    /// The lift's share of its height (0 → 1 → 0).
    pub bump: [f64; 3],
}

/// The trot's shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trot {
    /// Each pair's swing time \[s\] (a stance lasts as long).
    pub swing: f64,
    /// How high a swing foot rises \[m\].
    pub lift: f64,
    /// How far further forward (world x) a swing foot is asked to go at mid-swing \[m\]
    /// (0 for walking; the foothold CBF's demonstration asks for more than its region).
    pub reach: f64,
    /// Where each foot stands at the start (world) \[m\].
    pub home: [[f64; 3]; FEET],
    /// Where the trunk starts (world) \[m\], level.
    pub trunk: [f64; 3],
    /// The trunk's commanded velocity (world x, y) \[m/s\].
    pub velocity: [f64; 2],
    /// How long the trunk walks \[s\] (after the first still swing) before it stops:
    /// `f64::INFINITY` walks on.
    pub duration: f64,
}

impl Trot {
    /// A trot in place: no velocity.
    pub fn in_place(swing: f64, lift: f64, reach: f64, home: [[f64; 3]; FEET], trunk: [f64; 3]) -> Self {
        Self { swing, lift, reach, home, trunk, velocity: [0.0; 2], duration: f64::INFINITY }
    }

    /// A trot from [`standing_on_the_ground`]: each foot's home where it stands there, the
    /// trunk where it is, at `velocity` (world x, y) \[m/s\].
    pub fn from_standing(swing: f64, lift: f64, velocity: [f64; 2]) -> Self {
        let x = standing_on_the_ground();
        let home = gen::contacts(&x).0;
        Self { velocity, ..Self::in_place(swing, lift, 0.0, home, [x[0], x[1], x[2]]) }
    }

    /// Time the trunk has walked at `t` (the first swing period stands still, and it
    /// stops after `duration`).
    fn walked(&self, t: f64) -> f64 {
        (t - self.swing).clamp(0.0, self.duration)
    }

    /// Whether the trunk moves at `t`.
    fn walking(&self, t: f64) -> bool {
        t >= self.swing && t - self.swing < self.duration
    }

    /// Whether foot `foot` (in `LEGS` order: LF RF LH RH) swings at time `t`.
    pub fn swings(&self, t: f64, foot: usize) -> bool {
        if t < self.swing {
            return false;
        }
        let pair = ((t / self.swing).floor() as usize) % 2;
        pair == usize::from(foot == 1 || foot == 2)
    }

    /// Time left \[s\] until the swing under way at `t` lands (the whole swing time at
    /// a lift-off; also for a foot in stance, whose next swing this then is not).
    pub fn time_to_touchdown(&self, t: f64) -> f64 {
        self.swing - (t - (t / self.swing).floor() * self.swing)
    }

    /// Eq. 24's growth of a swing foot's region at `t` and its first two time derivatives,
    /// `[m, m', m'']`, shrinking with the swing's travel: `m = margin · (1 − g(s))` for `s`
    /// the swing's phase and `g` its share of the way ([`Swing::travel`]): `margin` at
    /// lift-off, zero at touchdown, still at both. For the rows and measurements of a swing
    /// foot (a stance foot's region is not grown).
    ///
    /// The MPC aims a swing foot along the gait's curve, which moves by `g`
    /// ([`MpcWeights::swing_joints`](crate::mpc::MpcWeights::swing_joints)), so a foot on
    /// its aim keeps its margin to this set all through the swing. A linear shrink
    /// (`margin · τ / T`) runs ahead of the aim while `g(s) < s`, in the first half: the
    /// rows then fought the aim and the plans rolled the trunk to meet both (on the rigid
    /// plant "CBF in MPC" diverged on both long fields), and at touchdown it asked a foot
    /// at rest to be `margin / (γ T)` inside its region (docs/anymal.md).
    pub fn shrinking_growth(&self, margin: f64, t: f64) -> [f64; 3] {
        let s = 1.0 - self.time_to_touchdown(t) / self.swing;
        let [g, dg, ddg] = travel(s, self.swing);
        [margin * (1.0 - g), -margin * dg, -margin * ddg]
    }

    /// Where the gait puts foot `foot` (`LEGS` order) for the stance it is in at `t`, or,
    /// swinging, for the stance it lands in: under its hip at mid-stance (world).
    pub fn foothold_for(&self, foot: usize, t: f64) -> [f64; 3] {
        let period = self.period(t);
        self.foothold(foot, if self.swings(t, foot) { period + 1 } else { period })
    }

    /// The swing period `t` is in: the `k`-th runs over `[k T, (k + 1) T)`.
    fn period(&self, t: f64) -> i64 {
        (t / self.swing).floor() as i64
    }

    /// Where foot `foot` stands in a stance that begins with period `stance` (it landed
    /// `(stance − 1) T` after the first still swing; at home before): under its hip at
    /// mid-stance. Once the trunk has stopped, at the one of the foot's own footholds (a
    /// stride apart) nearest to under its hip, so that a stopping walk uses no footholds
    /// a walk on would not (the stepping stones'). Periods are counted in integers so
    /// that a stance is never confused with the next at its boundary.
    fn foothold(&self, foot: usize, stance: i64) -> [f64; 3] {
        let stride = 2.0 * self.swing;
        let mut travel = if stance <= 1 { 0.0 } else { (stance - 1) as f64 * self.swing + 0.5 * self.swing };
        if travel > self.duration + 0.5 * stride {
            travel -= stride * ((travel - self.duration + 0.5 * stride) / stride).floor();
        }
        let mut p = self.home[foot];
        p[0] += self.velocity[0] * travel;
        p[1] += self.velocity[1] * travel;
        p
    }

    /// Foot `foot`'s swing under way at `t`, if it swings.
    pub fn swing_at(&self, foot: usize, t: f64) -> Option<Swing> {
        if !self.swings(t, foot) {
            return None;
        }
        // The phase s ∈ [0, 1): out and back on b(s) = (1 − cos 2πs)/2, the move on
        // g(s) (`travel`); both leave and land with zero velocity. Their time derivatives
        // follow from ds/dt = 1/T.
        let period = self.swing;
        let s = t / period - (t / period).floor();
        let angle = std::f64::consts::TAU * s;
        let w = std::f64::consts::TAU / period;
        let lift_off = t - s * period;
        Some(Swing {
            lift_off,
            touchdown: lift_off + period,
            bump: [0.5 * (1.0 - angle.cos()), 0.5 * w * angle.sin(), 0.5 * w * w * angle.cos()],
            travel: travel(s, period),
        })
    }

    /// The reference at time `t` \[s\].
    pub fn reference(&self, t: f64) -> WbcReference {
        let walked = self.walked(t);
        let mut trunk = self.trunk;
        trunk[0] += self.velocity[0] * walked;
        trunk[1] += self.velocity[1] * walked;
        let mut reference = WbcReference::standing(trunk, Matrix3::identity());
        if self.walking(t) {
            reference.trunk_velocity = [self.velocity[0], self.velocity[1], 0.0];
        }
        for foot in 0..FEET {
            let Some(swing) = self.swing_at(foot, t) else { continue };
            reference.stance[foot] = false;
            // From the stance before this swing's period to the one after it.
            let period = self.period(t);
            let (from, to) = (self.foothold(foot, period - 1), self.foothold(foot, period + 1));
            let out_and_back = [self.reach, 0.0, self.lift];
            let mut target = FootReference::default();
            for axis in 0..3 {
                let travel = to[axis] - from[axis];
                target.position[axis] = from[axis] + travel * swing.travel[0] + out_and_back[axis] * swing.bump[0];
                target.velocity[axis] = travel * swing.travel[1] + out_and_back[axis] * swing.bump[1];
                target.acceleration[axis] = travel * swing.travel[2] + out_and_back[axis] * swing.bump[2];
            }
            reference.feet[foot] = target;
        }
        reference.share_weight();
        reference
    }
}

/// A swing's share of its way at phase `s` ∈ [0, 1] of a swing of `period` \[s\], with its
/// first two time derivatives: `g(s) = s − sin(2πs)/2π`, which leaves and lands still.
fn travel(s: f64, period: f64) -> [f64; 3] {
    let angle = std::f64::consts::TAU * s;
    let w = std::f64::consts::TAU / period;
    [s - angle.sin() / std::f64::consts::TAU, (1.0 - angle.cos()) / period, w * angle.sin() / period]
}

/// The SRDF's standing joints with the trunk level at the height where the feet's
/// spheres touch `z = 0`, at rest, in the [`wbc_generated`](crate::wbc_generated) layout.
pub fn standing_on_the_ground() -> [f64; NX] {
    let mut x = [0.0; NX];
    x[2] = gen::STANDING_HEIGHT;
    for k in [3, 7, 11] {
        x[k] = 1.0; // R = I
    }
    x[12..24].copy_from_slice(&gen::STANDING_JOINTS);
    let (feet, _, _) = gen::contacts(&x);
    let lowest = feet.iter().map(|f| f[2]).fold(f64::INFINITY, f64::min);
    x[2] -= lowest - gen::FOOT_RADIUS;
    x
}

/// A square foothold of half-width `half_width` \[m\] around each of `feet` (x, y; world),
/// as four half-spaces per foot.
///
/// # Errors
/// A non-finite or non-positive `half_width`, or a non-finite foot.
pub fn footholds_around(feet: &[[f64; 3]; FEET], half_width: f64) -> Result<Params, CbfError> {
    positive("foothold half_width", half_width)?;
    let mut params = Params::new(Capacity { foot_region: [4; FEET] })?;
    for (member, foot) in params.foot_region.iter_mut().zip(feet) {
        for (normal, offset) in crate::square_sides(*foot, half_width) {
            finite("foot position", offset)?;
            member.push(FootRegionParams { normal: normal.into(), offset, growth: [0.0; 3].into(), at: 0.0 })?;
        }
    }
    Ok(params)
}
