//! A trot: the simple reference the whole-body controller is tried on before a planner
//! drives it (seed 004's MPC, issue 38). After one still swing period the diagonal pairs
//! (RF + LH first, then LF + RH) alternate, each swing as long as a stance. The trunk moves
//! level at `velocity` (world x, y) from then on, and a swing foot goes from where it stood
//! to where it will be under its hip at mid-stance (`home` plus the trunk's travel: a
//! Raibert-style placement), rising `lift` and reaching `reach` further forward (world x)
//! at mid-swing, all on `(1 − cos 2πs)/2` (`s` the swing's phase) so it leaves and lands
//! with zero velocity. The weight is shared by the stance feet. With zero velocity it is a
//! trot in place.

use cbfgen::error::{finite, positive, CbfError};
use cbfgen::nalgebra::Matrix3;

use crate::wbc::{FootReference, WbcReference, FEET};
use crate::wbc_generated::{self as gen, Capacity, FootRegionParams, Params, NX};

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
}

impl Trot {
    /// A trot in place: no velocity.
    pub fn in_place(swing: f64, lift: f64, reach: f64, home: [[f64; 3]; FEET], trunk: [f64; 3]) -> Self {
        Self { swing, lift, reach, home, trunk, velocity: [0.0; 2] }
    }

    /// A trot from [`standing_on_the_ground`]: each foot's home where it stands there, the
    /// trunk where it is, at `velocity` (world x, y) \[m/s\].
    pub fn from_standing(swing: f64, lift: f64, velocity: [f64; 2]) -> Self {
        let x = standing_on_the_ground();
        let home = gen::contacts(&x).0;
        Self { velocity, ..Self::in_place(swing, lift, 0.0, home, [x[0], x[1], x[2]]) }
    }

    /// Time walked at `t` (the first swing period stands still).
    fn walked(&self, t: f64) -> f64 {
        (t - self.swing).max(0.0)
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

    /// Where the gait puts foot `foot` (`LEGS` order) for the stance it is in at `t`, or,
    /// swinging, for the stance it lands in: under its hip at mid-stance (world).
    pub fn foothold_for(&self, foot: usize, t: f64) -> [f64; 3] {
        let walked = self.walked(t);
        let phase = t / self.swing - (t / self.swing).floor();
        let start = walked - phase * self.swing;
        self.foothold(foot, if self.swings(t, foot) { start + self.swing } else { start })
    }

    /// Where foot `foot` stands after landing at walked time `landing`: under its hip at
    /// mid-stance.
    fn foothold(&self, foot: usize, landing: f64) -> [f64; 3] {
        let travel = if landing <= 0.0 { 0.0 } else { landing + 0.5 * self.swing };
        let mut p = self.home[foot];
        p[0] += self.velocity[0] * travel;
        p[1] += self.velocity[1] * travel;
        p
    }

    /// The reference at time `t` \[s\].
    pub fn reference(&self, t: f64) -> WbcReference {
        let walked = self.walked(t);
        let mut trunk = self.trunk;
        trunk[0] += self.velocity[0] * walked;
        trunk[1] += self.velocity[1] * walked;
        let mut reference = WbcReference::standing(trunk, Matrix3::identity());
        if t >= self.swing {
            reference.trunk_velocity = [self.velocity[0], self.velocity[1], 0.0];
        }
        // The swing's phase s ∈ [0, 1): out and back (lift, reach) on b(s) = (1 − cos 2πs)/2,
        // the move to the next foothold on g(s) = s − sin(2πs)/2π; both leave and land with
        // zero velocity. Their time derivatives follow from ds/dt = 1/T.
        let period = self.swing;
        let s = t / period - (t / period).floor();
        let angle = std::f64::consts::TAU * s;
        let w = std::f64::consts::TAU / period;
        let bump = [0.5 * (1.0 - angle.cos()), 0.5 * w * angle.sin(), 0.5 * w * w * angle.cos()];
        let go = [s - angle.sin() / std::f64::consts::TAU, (1.0 - angle.cos()) / period, w * angle.sin() / period];
        // This swing's lift-off and touchdown, in walked time.
        let lift_off = walked - s * period;
        let touchdown = lift_off + period;
        for foot in 0..FEET {
            reference.stance[foot] = !self.swings(t, foot);
            if reference.stance[foot] {
                continue;
            }
            // It landed one stance before this lift-off (at the start, in its first swing).
            let from = self.foothold(foot, lift_off - period);
            let to = self.foothold(foot, touchdown);
            let out_and_back = [self.reach, 0.0, self.lift];
            let mut target = FootReference::default();
            for axis in 0..3 {
                let travel = to[axis] - from[axis];
                target.position[axis] = from[axis] + travel * go[0] + out_and_back[axis] * bump[0];
                target.velocity[axis] = travel * go[1] + out_and_back[axis] * bump[1];
                target.acceleration[axis] = travel * go[2] + out_and_back[axis] * bump[2];
            }
            reference.feet[foot] = target;
        }
        reference.share_weight();
        reference
    }
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
            member.push(FootRegionParams { normal: normal.into(), offset })?;
        }
    }
    Ok(params)
}
