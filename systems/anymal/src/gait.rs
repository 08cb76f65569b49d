//! A trot in place: the simple reference the whole-body controller is tried on before a
//! planner drives it (seed 004's MPC, issue 38). After one still swing period, the diagonal
//! pairs (LF + RH, then RF + LH) alternate; a swing foot rises `lift` and moves `reach`
//! forward (world x) on `(1 − cos 2πs)/2`, `s` the swing's phase, so it leaves and lands
//! with zero velocity; the trunk holds its pose and the weight is shared by the stance feet.

use cbfgen::error::{finite, positive, CbfError};
use cbfgen::nalgebra::Matrix3;

use crate::wbc::{FootReference, WbcReference, FEET};
use crate::wbc_generated::{self as gen, Capacity, FootRegionParams, Params, NX};

/// The trot's shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrotInPlace {
    /// Each pair's swing time \[s\].
    pub swing: f64,
    /// How high a swing foot rises \[m\].
    pub lift: f64,
    /// How far forward (world x) a swing foot is asked to go at mid-swing \[m\].
    pub reach: f64,
    /// Where each foot stands (world) \[m\].
    pub home: [[f64; 3]; FEET],
    /// Where the trunk stays (world) \[m\], level.
    pub trunk: [f64; 3],
}

impl TrotInPlace {
    /// Whether foot `foot` (in `LEGS` order: LF RF LH RH) swings at time `t`.
    pub fn swings(&self, t: f64, foot: usize) -> bool {
        if t < self.swing {
            return false;
        }
        let pair = ((t / self.swing).floor() as usize) % 2;
        pair == usize::from(foot == 1 || foot == 2)
    }

    /// The reference at time `t` \[s\].
    pub fn reference(&self, t: f64) -> WbcReference {
        let mut reference = WbcReference::standing(self.trunk, Matrix3::identity());
        let s = t / self.swing - (t / self.swing).floor();
        let w = std::f64::consts::TAU / self.swing;
        let (shape, rate, accel) = (
            0.5 * (1.0 - (w * s * self.swing).cos()),
            0.5 * w * (w * s * self.swing).sin(),
            0.5 * w * w * (w * s * self.swing).cos(),
        );
        for foot in 0..FEET {
            reference.stance[foot] = !self.swings(t, foot);
            if reference.stance[foot] {
                continue;
            }
            let mut target = FootReference { position: self.home[foot], ..FootReference::default() };
            for (axis, amplitude) in [(0, self.reach), (2, self.lift)] {
                target.position[axis] += amplitude * shape;
                target.velocity[axis] = amplitude * rate;
                target.acceleration[axis] = amplitude * accel;
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
        for (normal, offset) in [
            ([1.0, 0.0, 0.0], foot[0] + half_width),
            ([-1.0, 0.0, 0.0], half_width - foot[0]),
            ([0.0, 1.0, 0.0], foot[1] + half_width),
            ([0.0, -1.0, 0.0], half_width - foot[1]),
        ] {
            finite("foot position", offset)?;
            member.push(FootRegionParams { normal: normal.into(), offset })?;
        }
    }
    Ok(params)
}
