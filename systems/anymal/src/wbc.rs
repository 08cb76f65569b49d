//! ANYmal's hierarchical whole-body controller (seed 004, section IV-C and Table I): joint
//! torques from a trunk motion, swing-foot motions and contact forces, with the foothold
//! CBF among the highest-priority constraints.
//!
//! The decision variables are `z = (ν̇, τ, f)`: the 18 generalized accelerations of the
//! free-flyer model ([`wbc_generated`](crate::wbc_generated)), the 12 joint torques and a
//! world-frame force at each foot (12). Each cycle builds three levels for the core's
//! [`Hierarchy`] (each solved in the null space of the tasks above):
//!
//! | priority | tasks (least squares) | rows |
//! |---|---|---|
//! | 0 | equations of motion `M ν̇ + b = Sᵀτ + Σ Jᵢᵀfᵢ`; stance feet still, `Jᵢν̇ = −J̇ᵢν`; swing feet carry no force | hard: torque limits, friction pyramid; soft: the foothold CBF rows of swing feet |
//! | 1 | trunk acceleration (a PD on the reference pose and twist); swing-foot acceleration (a PD on its reference) | |
//! | 2 | contact forces `fᵢ = fᵢ,ref` | |
//!
//! The foothold rows are the generated `foot_region` family's ([`crate::wbc_generated`]),
//! `a · ν̇ ≥ −(L_f²h + k₁ L_f h + k₀ h)`, with `ν̇` tied to torques and forces by the
//! equations of motion at the same priority: the CBF is affine in the torques (eq. 26).
//! A row that had to give way (its slack beyond [`SLACK_TOLERANCE`]) is reported in
//! [`WbcOutput::relaxed`], never hidden.
//!
//! The friction cone `‖f_t‖ ≤ μ f_n` (world z the normal: flat ground) is the inscribed
//! pyramid `|f_x|, |f_y| ≤ μ f_n / √2`: conservative by at most 29 % of the tangential force.
//!
//! The torque applied adds eq. 27's integral term on swing legs: `τ = τ_wbc + K_I e` with
//! `e = ∫ (q̈_wbc − q̈) dt` over the current swing, where `∫ q̈ dt` is the measured rate's
//! change (no differentiation of measured rates), reset when a leg lifts off.
//!
//! A cycle does not allocate.
//!
//! Standing on the ground: the feet carry the robot's weight.
//!
//! ```
//! use cbfgen::nalgebra::Matrix3;
//! use cbfgen_anymal::gait::standing_on_the_ground;
//! use cbfgen_anymal::wbc::{WbcReference, WbcSettings, WholeBodyController};
//! use cbfgen_anymal::wbc_generated::{self as gen, Capacity, Params};
//!
//! let x = standing_on_the_ground();
//! let footholds = Params::new(Capacity { foot_region: [0; 4] })?; // no foothold rows
//! let mut controller = WholeBodyController::new(footholds.capacity(), WbcSettings::default())?;
//! let reference = WbcReference::standing([x[0], x[1], x[2]], Matrix3::identity());
//! let out = controller.update(0.0, &x, &reference, &footholds, 2.5e-3)?;
//! assert!(out.solved);
//! let carried: f64 = out.forces.iter().map(|f| f[2]).sum();
//! assert!((carried - gen::TOTAL_MASS * 9.81).abs() < 1e-3);
//! # Ok::<(), cbfgen::CbfError>(())
//! ```

use cbfgen::error::{finite, CbfError};
use cbfgen::nalgebra::{Matrix3, Vector3};
use cbfgen::qp::hierarchy::{Hierarchy, LevelReport, LevelShape, LevelStatus};
use cbfgen::system::{BarrierSet, Gains};

use crate::mpc::Region;
use crate::wbc_generated::{self as gen, Barriers, Capacity, FootRegionParams, Params, NU, NX};

/// How far a foot's set is grown beyond its region at one time (seed 004's eq. 24): each
/// half-space `n · c ≤ d` is loosened to `n · c ≤ d + m(t)`, given by `m` and its first two
/// time derivatives at `at` (all a cycle's rows at `at` need: the shape of the shrink is
/// the caller's, [`Trot::shrinking_growth`](crate::gait::Trot::shrinking_growth) for a
/// trot's swing). [`Growth::NONE`] is the region itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Growth {
    /// `m`, `m'`, `m''` at `at` \[m, m/s, m/s²\].
    pub derivatives: [f64; 3],
    /// When \[s\]: the cycle's time.
    pub at: f64,
}

impl Growth {
    /// The region itself: no growth.
    pub const NONE: Self = Self { derivatives: [0.0; 3], at: 0.0 };
}

/// Put `region`'s half-spaces into foot `foot`'s slot of `params` (the generated
/// `foot_region` family's), grown by `growth`, replacing what was there.
/// Allocation-free.
///
/// # Errors
/// No foot `foot`, more sides than the slot's capacity, or a non-finite growth (the slot
/// is then unchanged).
pub fn set_foothold(params: &mut Params, foot: usize, region: &Region, growth: Growth) -> Result<(), CbfError> {
    let member = params.foot_region.get_mut(foot).ok_or(CbfError::OutOfRange {
        what: "foot",
        value: foot as f64,
        range: "[0, 4)",
    })?;
    let count = region.count.min(region.sides.len());
    if count > member.capacity() {
        return Err(CbfError::TooLarge { what: "foothold region sides", value: count, max: member.capacity() });
    }
    for v in growth.derivatives {
        finite("foothold growth", v)?;
    }
    finite("foothold growth time [s]", growth.at)?;
    member.clear();
    for &(normal, offset) in &region.sides[..count] {
        member.push(FootRegionParams {
            normal: normal.into(),
            offset,
            growth: growth.derivatives.into(),
            at: growth.at,
        })?;
    }
    Ok(())
}

/// Decision variables: accelerations, torques, forces.
pub const VARS: usize = NU + JOINTS + 3 * FEET;
/// Joints (torques).
pub const JOINTS: usize = 12;
/// Feet.
pub const FEET: usize = 4;
const TORQUE: usize = NU;
const FORCE: usize = NU + JOINTS;
/// Friction pyramid rows per foot: `f_n ≥ f_min`, `±f_x ≤ μ' f_n`, `±f_y ≤ μ' f_n`.
const PYRAMID: usize = 5;
/// A soft row whose slack is beyond this counts as relaxed (in the row's units, m/s²); below
/// it the slack is the regularisation's rounding (measured up to 1.5e-6 in MuJoCo).
pub const SLACK_TOLERANCE: f64 = 1e-5;
/// The QP's units for torques \[N m\] and forces \[N\]: every variable is then of order
/// one, so the hierarchy's regularisation (relative to each level's largest term) moves
/// the equations of motion by parts in 10¹⁰ of the weight, not parts in 10⁵.
const TORQUE_UNIT: f64 = 100.0;
const FORCE_UNIT: f64 = 100.0;

/// The controller's gains and physical constants. Defaults: see each field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WbcSettings {
    /// Friction coefficient μ of the feet on the ground (default 0.7).
    pub friction: f64,
    /// Least normal force of a stance foot \[N\] (default 5: it stays in contact).
    pub min_normal_force: f64,
    /// Trunk position stiffness and damping \[1/s², 1/s\] (default 400, 40).
    pub trunk_position_gains: (f64, f64),
    /// Trunk orientation stiffness and damping (default 400, 40).
    pub trunk_orientation_gains: (f64, f64),
    /// Swing-foot stiffness and damping (default 900, 60).
    pub swing_gains: (f64, f64),
    /// Eq. 27's integral gain `K_I` on swing joints \[N m s/rad\] (default 0: off).
    pub integral_gain: f64,
    /// The foothold rows' gains `k₀, k₁` (default: the spec's poles).
    pub foothold_gains: Gains,
    /// Joint torque limits \[N m\] (default: the URDF's).
    pub torque_limits: [f64; JOINTS],
}

impl Default for WbcSettings {
    fn default() -> Self {
        let poles = gen::default_settings().families[gen::family::FOOT_REGION].poles;
        Self {
            friction: 0.7,
            min_normal_force: 5.0,
            trunk_position_gains: (400.0, 40.0),
            trunk_orientation_gains: (400.0, 40.0),
            swing_gains: (900.0, 60.0),
            integral_gain: 0.0,
            foothold_gains: Gains::from_poles(&poles),
            torque_limits: gen::TAU_MAX,
        }
    }
}

/// Where one swing foot should be (world): position, velocity, acceleration.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FootReference {
    /// Position \[m\].
    pub position: [f64; 3],
    /// Velocity \[m/s\].
    pub velocity: [f64; 3],
    /// Acceleration \[m/s²\] (feed-forward).
    pub acceleration: [f64; 3],
}

/// What the controller tracks this cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WbcReference {
    /// Which feet are on the ground, in [`gen::LEGS`] order.
    pub stance: [bool; FEET],
    /// The trunk's position \[m\] and rotation (world from trunk).
    pub trunk_position: [f64; 3],
    /// The trunk's reference rotation.
    pub trunk_rotation: Matrix3<f64>,
    /// The trunk's velocity \[m/s\] and angular velocity \[rad/s\], world frame.
    pub trunk_velocity: [f64; 3],
    /// See `trunk_velocity`.
    pub trunk_angular_velocity: [f64; 3],
    /// The trunk's planned acceleration \[m/s²\] and angular acceleration \[rad/s²\],
    /// world frame: fed forward beside the PD on pose and twist (zero for a fixed
    /// reference; a plan's own, from the MPC).
    pub trunk_acceleration: [f64; 3],
    /// See `trunk_acceleration`.
    pub trunk_angular_acceleration: [f64; 3],
    /// Each swing foot's reference (stance feet's are not read).
    pub feet: [FootReference; FEET],
    /// Each stance foot's reference force, world \[N\] (swing feet's are not read).
    pub forces: [[f64; 3]; FEET],
}

impl WbcReference {
    /// Standing still at `position` with rotation `rotation`, every foot on the ground and
    /// the weight shared equally (the seed's reference forces).
    pub fn standing(position: [f64; 3], rotation: Matrix3<f64>) -> Self {
        let share = gen::TOTAL_MASS * GRAVITY / FEET as f64;
        Self {
            stance: [true; FEET],
            trunk_position: position,
            trunk_rotation: rotation,
            trunk_velocity: [0.0; 3],
            trunk_angular_velocity: [0.0; 3],
            trunk_acceleration: [0.0; 3],
            trunk_angular_acceleration: [0.0; 3],
            feet: [FootReference::default(); FEET],
            forces: [[0.0, 0.0, share]; FEET],
        }
    }

    /// Share the weight equally over the stance feet (vertical forces).
    pub fn share_weight(&mut self) {
        let count = self.stance.iter().filter(|s| **s).count().max(1) as f64;
        for (force, stance) in self.forces.iter_mut().zip(self.stance) {
            *force = if stance { [0.0, 0.0, gen::TOTAL_MASS * GRAVITY / count] } else { [0.0; 3] };
        }
    }
}

/// Gravity's magnitude \[m/s²\], as the spec's dynamics.
pub const GRAVITY: f64 = 9.81;

/// One cycle's answer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WbcOutput {
    /// The torques to apply \[N m\], eq. 27's integral term included.
    pub torques: [f64; JOINTS],
    /// The torques the hierarchy chose (without the integral term).
    pub wbc_torques: [f64; JOINTS],
    /// The generalized accelerations it expects.
    pub accelerations: [f64; NU],
    /// The foot forces it expects, world \[N\].
    pub forces: [[f64; 3]; FEET],
    /// Each priority's outcome.
    pub levels: [LevelReport; 3],
    /// Per foot, the largest slack its foothold rows needed \[m/s²\]: 0 when every one
    /// held to [`SLACK_TOLERANCE`].
    pub relaxed: [f64; FEET],
    /// Every level solved (else the torques are the last solved level's, or zero).
    pub solved: bool,
}

/// The controller: sizes fixed at construction, no allocation per cycle.
#[derive(Debug, Clone)]
pub struct WholeBodyController {
    settings: WbcSettings,
    qp: Hierarchy,
    barriers: Barriers,
    capacity: Capacity,
    /// Eq. 27: per joint, ∫ q̈_wbc dt and the rate at lift-off.
    commanded_rate_change: [f64; JOINTS],
    rate_at_liftoff: [f64; JOINTS],
    last_acceleration: [f64; JOINTS],
    last_stance: [bool; FEET],
}

impl WholeBodyController {
    /// A controller for foothold parameters of `capacity` (half-spaces per foot).
    ///
    /// # Errors
    /// A capacity above the spec's maximum; non-finite or non-positive settings.
    pub fn new(capacity: Capacity, settings: WbcSettings) -> Result<Self, CbfError> {
        for (what, v) in [
            ("friction", settings.friction),
            ("trunk position stiffness", settings.trunk_position_gains.0),
            ("trunk orientation stiffness", settings.trunk_orientation_gains.0),
            ("swing stiffness", settings.swing_gains.0),
        ] {
            cbfgen::error::positive(what, v)?;
        }
        for (what, v) in [
            ("min normal force", settings.min_normal_force),
            ("trunk position damping", settings.trunk_position_gains.1),
            ("trunk orientation damping", settings.trunk_orientation_gains.1),
            ("swing damping", settings.swing_gains.1),
            ("integral gain", settings.integral_gain),
        ] {
            finite(what, v)?;
        }
        for &limit in &settings.torque_limits {
            cbfgen::error::positive("torque limit", limit)?;
        }
        let soft: usize = capacity.foot_region.iter().sum();
        let shapes = [
            LevelShape { tasks: NU + 3 * FEET, hard: JOINTS + PYRAMID * FEET, soft },
            LevelShape { tasks: 6 + 3 * FEET, hard: 0, soft: 0 },
            LevelShape { tasks: 3 * FEET, hard: 0, soft: 0 },
        ];
        let qp = Hierarchy::new(VARS, &shapes)?;
        Ok(Self {
            settings,
            qp,
            barriers: Barriers::new(capacity)?,
            capacity,
            commanded_rate_change: [0.0; JOINTS],
            rate_at_liftoff: [0.0; JOINTS],
            last_acceleration: [0.0; JOINTS],
            last_stance: [true; FEET],
        })
    }

    /// The settings in use.
    pub fn settings(&self) -> &WbcSettings {
        &self.settings
    }

    /// One cycle at time `t` \[s\] and state `x` (the
    /// [`wbc_generated`](crate::wbc_generated) layout) towards `reference`, swing feet kept
    /// in the sets of `footholds` (grown ones at `t`, [`Growth`]); `dt` \[s\] is the
    /// time since the last cycle (for eq. 27's integral).
    ///
    /// # Errors
    /// A non-finite time, state, reference or `dt`; foothold parameters of another capacity
    /// or outside their domains. The controller's state is then unchanged.
    pub fn update(
        &mut self,
        t: f64,
        x: &[f64; NX],
        reference: &WbcReference,
        footholds: &Params,
        dt: f64,
    ) -> Result<WbcOutput, CbfError> {
        for &v in x {
            finite("state", v)?;
        }
        finite("time", t)?;
        finite("time step", dt)?;
        check_reference(reference)?;
        if footholds.capacity() != self.capacity {
            return Err(CbfError::CapacityMismatch);
        }
        self.barriers.evaluate(t, x, footholds)?;
        let (mass, bias) = gen::dynamics(x);
        let (positions, jacobians, drifts) = gen::contacts(x);
        let nu = &x[24..42];
        self.write_level_0(&mass, &bias, &jacobians, &drifts, reference);
        self.write_level_1(x, &positions, &jacobians, &drifts, nu, reference);
        self.write_level_2(reference);
        self.scale_to_qp_units();
        self.qp.solve();
        let reports = self.qp.reports();
        let levels = [reports[0], reports[1], reports[2]];
        let solved = levels.iter().all(|r| r.status == LevelStatus::Solved);
        let z = self.qp.solution();
        let mut out = WbcOutput {
            torques: [0.0; JOINTS],
            wbc_torques: [0.0; JOINTS],
            accelerations: [0.0; NU],
            forces: [[0.0; 3]; FEET],
            levels,
            relaxed: [0.0; FEET],
            solved,
        };
        if levels[0].status == LevelStatus::Solved {
            out.accelerations.copy_from_slice(&z[..NU]);
            for (t, v) in out.wbc_torques.iter_mut().zip(&z[TORQUE..TORQUE + JOINTS]) {
                *t = TORQUE_UNIT * v;
            }
            for (i, f) in out.forces.iter_mut().enumerate() {
                *f = std::array::from_fn(|a| FORCE_UNIT * z[FORCE + 3 * i + a]);
            }
            let slacks = self.qp.slacks(0);
            let mut row = 0;
            for (foot, relaxed) in out.relaxed.iter_mut().enumerate() {
                for _ in 0..self.capacity.foot_region[foot] {
                    if slacks[row].abs() > SLACK_TOLERANCE {
                        *relaxed = relaxed.max(slacks[row].abs());
                    }
                    row += 1;
                }
            }
        }
        out.torques = out.wbc_torques;
        self.integral_term(x, reference, dt, &mut out);
        Ok(out)
    }

    fn write_level_0(
        &mut self,
        mass: &[[f64; NU]; NU],
        bias: &[f64; NU],
        jacobians: &[[f64; NU]; 3 * FEET],
        drifts: &[[f64; 3]; FEET],
        reference: &WbcReference,
    ) {
        let settings = self.settings;
        let level = self.qp.level_mut(0);
        level.task.fill(0.0);
        // Equations of motion: M ν̇ − Sᵀτ − Σ Jᵢᵀ fᵢ = −b, divided by the robot's mass so
        // that they weigh as the contact rows (both in m/s²) in the least squares.
        let per_kg = 1.0 / gen::TOTAL_MASS;
        for r in 0..NU {
            let row = &mut level.task[r * VARS..(r + 1) * VARS];
            for (out, m) in row[..NU].iter_mut().zip(&mass[r]) {
                *out = per_kg * m;
            }
            if r >= 6 {
                row[TORQUE + r - 6] = -per_kg;
            }
            for (foot, _) in reference.stance.iter().enumerate().filter(|(_, s)| **s) {
                for axis in 0..3 {
                    row[FORCE + 3 * foot + axis] = -per_kg * jacobians[3 * foot + axis][r];
                }
            }
            level.target[r] = -per_kg * bias[r];
        }
        // Stance feet still (J ν̇ = −J̇ν); swing feet carry no force.
        for foot in 0..FEET {
            for axis in 0..3 {
                let r = NU + 3 * foot + axis;
                let row = &mut level.task[r * VARS..(r + 1) * VARS];
                if reference.stance[foot] {
                    row[..NU].copy_from_slice(&jacobians[3 * foot + axis]);
                    level.target[r] = -drifts[foot][axis];
                } else {
                    // f = 0, of order one in the QP's units as the other rows.
                    row[FORCE + 3 * foot + axis] = 1.0 / FORCE_UNIT;
                    level.target[r] = 0.0;
                }
            }
        }
        // Torque limits.
        for j in 0..JOINTS {
            let row = &mut level.rows[j * VARS..(j + 1) * VARS];
            row.fill(0.0);
            row[TORQUE + j] = 1.0;
            level.lower[j] = -settings.torque_limits[j];
            level.upper[j] = settings.torque_limits[j];
        }
        // Friction pyramid of stance feet.
        let mu = settings.friction / std::f64::consts::SQRT_2;
        for foot in 0..FEET {
            for k in 0..PYRAMID {
                let r = JOINTS + PYRAMID * foot + k;
                let row = &mut level.rows[r * VARS..(r + 1) * VARS];
                row.fill(0.0);
                level.lower[r] = f64::NEG_INFINITY;
                level.upper[r] = f64::INFINITY;
                if !reference.stance[foot] {
                    continue;
                }
                let (x, y, z) = (FORCE + 3 * foot, FORCE + 3 * foot + 1, FORCE + 3 * foot + 2);
                match k {
                    0 => {
                        row[z] = 1.0;
                        level.lower[r] = settings.min_normal_force;
                    }
                    1 | 2 => {
                        row[x] = if k == 1 { 1.0 } else { -1.0 };
                        row[z] = -mu;
                        level.upper[r] = 0.0;
                    }
                    _ => {
                        row[y] = if k == 3 { 1.0 } else { -1.0 };
                        row[z] = -mu;
                        level.upper[r] = 0.0;
                    }
                }
            }
        }
        // Foothold CBF rows of swing feet: a · ν̇ ≥ −(L_f²h + k₁ L_f h + k₀ h).
        let first = JOINTS + PYRAMID * FEET;
        let rows = self.barriers.rows();
        for (i, (row, layout)) in rows.iter().zip(self.barriers.layout()).enumerate() {
            let r = first + i;
            let out = &mut level.rows[r * VARS..(r + 1) * VARS];
            out.fill(0.0);
            level.lower[r] = f64::NEG_INFINITY;
            level.upper[r] = f64::INFINITY;
            if row.active && !row.culled && !reference.stance[layout.member] {
                out[..NU].copy_from_slice(&row.lg);
                level.lower[r] = -settings.foothold_gains.bound(&row.lie);
            }
        }
    }

    fn write_level_1(
        &mut self,
        x: &[f64; NX],
        positions: &[[f64; 3]; FEET],
        jacobians: &[[f64; NU]; 3 * FEET],
        drifts: &[[f64; 3]; FEET],
        nu: &[f64],
        reference: &WbcReference,
    ) {
        let s = self.settings;
        let rotation = Matrix3::from_row_slice(&x[3..12]);
        let v_body = Vector3::new(nu[0], nu[1], nu[2]);
        let w_body = Vector3::new(nu[3], nu[4], nu[5]);
        let velocity = rotation * v_body;
        let omega = rotation * w_body;
        let position = Vector3::new(x[0], x[1], x[2]);
        let (kp, kd) = s.trunk_position_gains;
        let linear = Vector3::from(reference.trunk_acceleration)
            + kp * (Vector3::from(reference.trunk_position) - position)
            + kd * (Vector3::from(reference.trunk_velocity) - velocity);
        let (kr, kw) = s.trunk_orientation_gains;
        let error = rotation_vector(&(reference.trunk_rotation * rotation.transpose()));
        let angular = Vector3::from(reference.trunk_angular_acceleration)
            + kr * error
            + kw * (Vector3::from(reference.trunk_angular_velocity) - omega);
        // In the twist's own terms: v̇_b = Rᵀ p̈ − ω_b × v_b, ω̇_b = Rᵀ α.
        let v_dot = rotation.transpose() * linear - w_body.cross(&v_body);
        let w_dot = rotation.transpose() * angular;
        let level = self.qp.level_mut(1);
        level.task.fill(0.0);
        for k in 0..6 {
            level.task[k * VARS + k] = 1.0;
            level.target[k] = if k < 3 { v_dot[k] } else { w_dot[k - 3] };
        }
        let (ks, ds) = s.swing_gains;
        for foot in 0..FEET {
            for axis in 0..3 {
                let r = 6 + 3 * foot + axis;
                level.target[r] = 0.0;
                if reference.stance[foot] {
                    continue;
                }
                let j = &jacobians[3 * foot + axis];
                let velocity: f64 = j.iter().zip(nu).map(|(a, b)| a * b).sum();
                let want = &reference.feet[foot];
                let accel = want.acceleration[axis]
                    + ks * (want.position[axis] - positions[foot][axis])
                    + ds * (want.velocity[axis] - velocity);
                level.task[r * VARS..r * VARS + NU].copy_from_slice(j);
                level.target[r] = accel - drifts[foot][axis];
            }
        }
    }

    fn write_level_2(&mut self, reference: &WbcReference) {
        let level = self.qp.level_mut(2);
        level.task.fill(0.0);
        for foot in 0..FEET {
            for axis in 0..3 {
                let r = 3 * foot + axis;
                level.target[r] = 0.0;
                if reference.stance[foot] {
                    level.task[r * VARS + FORCE + r] = 1.0;
                    level.target[r] = reference.forces[foot][axis];
                }
            }
        }
    }

    /// Every row written in physical units, with the torque and force columns taken to
    /// the QP's ([`TORQUE_UNIT`], [`FORCE_UNIT`]): `a τ = (a · unit) τ'`.
    fn scale_to_qp_units(&mut self) {
        for k in 0..self.qp.levels() {
            let level = self.qp.level_mut(k);
            for row in level.task.chunks_exact_mut(VARS).chain(level.rows.chunks_exact_mut(VARS)) {
                row[TORQUE..FORCE].iter_mut().for_each(|v| *v *= TORQUE_UNIT);
                row[FORCE..].iter_mut().for_each(|v| *v *= FORCE_UNIT);
            }
        }
    }

    /// Eq. 27 on swing legs; resets a leg's integral when it lifts off.
    fn integral_term(&mut self, x: &[f64; NX], reference: &WbcReference, dt: f64, out: &mut WbcOutput) {
        let rates = &x[30..42];
        for foot in 0..FEET {
            let joints = 3 * foot..3 * foot + 3;
            if reference.stance[foot] {
                self.commanded_rate_change[joints.clone()].fill(0.0);
            } else {
                if self.last_stance[foot] {
                    self.commanded_rate_change[joints.clone()].fill(0.0);
                    self.rate_at_liftoff[joints.clone()].copy_from_slice(&rates[joints.clone()]);
                } else {
                    for j in joints.clone() {
                        self.commanded_rate_change[j] += self.last_acceleration[j] * dt;
                    }
                }
                for j in joints {
                    let error = self.commanded_rate_change[j] - (rates[j] - self.rate_at_liftoff[j]);
                    let limit = self.settings.torque_limits[j];
                    out.torques[j] = (out.torques[j] + self.settings.integral_gain * error).clamp(-limit, limit);
                }
            }
            self.last_stance[foot] = reference.stance[foot];
        }
        self.last_acceleration.copy_from_slice(&out.accelerations[6..]);
    }
}

/// The rotation vector (axis times angle) of a rotation matrix `m` (the trunk's orientation
/// error), the angle from `atan2(|s|, (tr m − 1) / 2)` with `s` the axial vector of
/// `(m − mᵀ) / 2`: finite for any finite `m`, where `acos((tr m − 1) / 2)` (nalgebra's
/// `Rotation3::angle`) is NaN once an integrated rotation's rounding puts its trace above 3
/// (it did, in whole-body cycles on the stepping stones).
pub fn rotation_vector(m: &Matrix3<f64>) -> Vector3<f64> {
    let s = 0.5 * Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)]);
    let sine = s.norm();
    let cosine = 0.5 * (m.trace() - 1.0);
    if sine > 1e-9 {
        s * (sine.atan2(cosine) / sine)
    } else if cosine > 0.0 {
        s // a small angle: s is the rotation vector to third order
    } else {
        // A half turn, m = 2 a aᵀ − I: the axis from the largest diagonal entry's column.
        let i = (0..3).fold(0, |b, i| if m[(i, i)] > m[(b, b)] { i } else { b });
        let ai = (0.5 * (m[(i, i)] + 1.0)).max(0.0).sqrt();
        if ai == 0.0 {
            return Vector3::zeros(); // not a rotation: no axis to give
        }
        let axis = Vector3::from_fn(|j, _| if j == i { ai } else { 0.25 * (m[(i, j)] + m[(j, i)]) / ai });
        axis.normalize() * sine.atan2(cosine)
    }
}

fn check_reference(reference: &WbcReference) -> Result<(), CbfError> {
    let values = reference
        .trunk_position
        .iter()
        .chain(reference.trunk_rotation.iter())
        .chain(&reference.trunk_velocity)
        .chain(&reference.trunk_angular_velocity)
        .chain(&reference.trunk_acceleration)
        .chain(&reference.trunk_angular_acceleration)
        .chain(reference.feet.iter().flat_map(|f| f.position.iter().chain(&f.velocity).chain(&f.acceleration)))
        .chain(reference.forces.iter().flatten());
    for &v in values {
        finite("whole-body reference", v)?;
    }
    Ok(())
}
