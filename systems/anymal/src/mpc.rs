//! Seed 004's kino-dynamic MPC (section IV-A, B, eqs. 18–25) on the generated model
//! [`mpc_generated`](crate::mpc_generated): the robot as one rigid body with its legs'
//! joints as integrators; inputs are the four feet's contact forces (trunk frame) and the
//! 12 joint velocities.
//!
//! Each [`KinodynamicMpc::solve`] is one real-time iteration: the last plan, shifted to
//! the current time, is the point the dynamics and constraints are linearised at (the
//! generated Jacobians), and one QP over the horizon ([`cbfgen::qp::ocp`] on a sparsity
//! laid out once, by default its Riccati interior-point method) gives the new plan. Per stage `k` at time `t + k dt`, for each
//! foot, by the gait's mode (seed 004, IV-B):
//!
//! | mode | rows |
//! |---|---|
//! | stance | the foot's world velocity is zero (3); the force inside the friction pyramid, normal force ≥ 0 (5) |
//! | swing | no force (3); the foot's velocity along the surface normal follows the gait's lift curve, with feedback on its height ([`LIFT_GAIN`]) (1) |
//! | both | the foothold rows of [`FootholdConstraint`], on the foot's region (up to [`MAX_SIDES`] half-spaces) |
//!
//! and every joint inside its limits. The friction cone `‖f_t‖ ≤ μ f_n` is the inscribed
//! pyramid `|f_t1|, |f_t2| ≤ μ f_n / √2` on the region's normal: conservative by at most
//! 29 % of the tangential force (the OCP's solvers take no cones).
//!
//! The cost is quadratic around a reference from the gait ([`Trot`]): the trunk level at
//! the commanded velocity and height, the joints at the standing state, the weight shared
//! equally by the stance feet, joint velocities zero.
//!
//! Units inside the QP: forces in [`FORCE_UNIT`] newtons, so that every variable is of
//! order one (both solvers' tolerances are absolute, and OSQP runs unscaled on data that
//! changes every iteration).

// Index loops mirror the formulas (rows × stage variables).
#![allow(clippy::needless_range_loop)]

use cbfgen::error::{within, CbfError};
use cbfgen::qp::ocp::{Ocp, OcpMethod, OcpShape};
use cbfgen::qp::{QpStatus, SolverSettings, INFINITY};

use cbfgen::nalgebra::{Matrix3, Vector3};

use crate::gait::Trot;
use crate::mpc_generated::{self as gen, NU, NX};
use crate::vec3::{cross, dot};
use crate::wbc::{FootReference, WbcReference};
use crate::wbc_generated as wbc_gen;

/// Feet.
pub const FEET: usize = 4;
/// Joints.
pub const JOINTS: usize = 12;
/// Most half-spaces a foothold region has.
pub const MAX_SIDES: usize = 6;
/// Newtons per unit of a force inside the QP.
pub const FORCE_UNIT: f64 = 100.0;
/// The swing height's feedback gain \[1/s\]: a swing foot's normal velocity is the lift
/// curve's plus this times its height error.
pub const LIFT_GAIN: f64 = 20.0;
/// Each foot's rows in a stage: motion (3: stance velocity, or the swing's lift row),
/// force (5: the pyramid, or a swing foot's zero force), then its foothold sides
/// ([`MAX_SIDES`], none with [`FootholdConstraint::Off`]).
const MOTION_ROWS: usize = 3;
const FORCE_ROWS: usize = 5;

/// Rows per foot and stage under `footholds`.
fn foot_rows(footholds: FootholdConstraint) -> usize {
    MOTION_ROWS + FORCE_ROWS + if footholds == FootholdConstraint::Off { 0 } else { MAX_SIDES }
}

/// A convex foothold region: half-spaces `n · c ≤ d` on a foot sphere's centre (world),
/// and the surface's plane `normal · p = surface` (the friction pyramid is built on its
/// normal, and a swing lands on it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// The half-spaces `(n, d)`; the first `count` are used (all of them if `count` is
    /// larger).
    pub sides: [([f64; 3], f64); MAX_SIDES],
    /// How many of `sides` are used.
    pub count: usize,
    /// The surface's unit normal (world).
    pub normal: [f64; 3],
    /// The surface's offset along `normal` \[m\]: its points `p` have `normal · p = surface`.
    pub surface: f64,
    /// A point of the surface deep inside the sides, where the MPC aims a foot that lands
    /// here (a terrain patch's centroid; for [`Region::flat`] the centre of the largest
    /// circle the sides hold; see [`MpcWeights::swing_joints`]); `None` without one (no
    /// sides, or too few to bound the region): a foot is not aimed.
    pub centre: Option<[f64; 3]>,
}

impl Region {
    /// The whole flat ground: no sides, normal `+z`.
    pub const GROUND: Self =
        Self { sides: [([0.0; 3], 0.0); MAX_SIDES], count: 0, normal: [0.0, 0.0, 1.0], surface: 0.0, centre: None };

    /// Region from half-spaces on the flat ground `z = 0`.
    ///
    /// # Errors
    /// More than [`MAX_SIDES`] sides, or a non-finite one.
    pub fn flat(sides: &[([f64; 3], f64)]) -> Result<Self, CbfError> {
        if sides.len() > MAX_SIDES {
            return Err(CbfError::TooLarge { what: "foothold region sides", value: sides.len(), max: MAX_SIDES });
        }
        let mut region = Self::GROUND;
        for (slot, &(n, d)) in region.sides.iter_mut().zip(sides) {
            for v in n.iter().chain([&d]) {
                cbfgen::error::finite("foothold side", *v)?;
            }
            *slot = (n, d);
        }
        region.count = sides.len();
        region.centre = deepest_point(sides).map(|(x, y)| [x, y, 0.0]);
        Ok(region)
    }

    /// How far a foot the gait stands at `nominal` (a foot sphere's centre over `z = 0`)
    /// is moved to stand on this region: to above its [`centre`](Self::centre), or without
    /// one only onto its surface (a swing's start on open ground), at the same height.
    fn shift(&self, nominal: [f64; 3]) -> [f64; 3] {
        let on_surface = match self.centre {
            Some(c) => c,
            None => {
                let off = self.surface - dot(&self.normal, &nominal);
                std::array::from_fn(|i| nominal[i] + off * self.normal[i])
            }
        };
        std::array::from_fn(|i| on_surface[i] + nominal[2] * self.normal[i] - nominal[i])
    }

    /// `min_j (d_j − n_j · c)`: how far inside its region a foot centre `c` is (negative
    /// outside; `+∞` with no sides).
    pub fn margin(&self, c: [f64; 3]) -> f64 {
        self.sides.iter().take(self.count).map(|(n, d)| d - dot(n, &c)).fold(f64::INFINITY, f64::min)
    }
}

/// The centre of the largest circle inside the horizontal half-planes `n · (x, y) ≤ d`, or
/// `None` if no three sides bound one. Each such circle touches three sides, so every point
/// equally far from three sides is tried (at most `C(6, 3) = 20`); where the largest is not
/// unique (a rectangle's slides along its length), the middle of the points it can take.
fn deepest_point(sides: &[([f64; 3], f64)]) -> Option<(f64, f64)> {
    const TIE: f64 = 1e-9;
    let mut candidates = [(0.0, 0.0, f64::NEG_INFINITY); 20];
    let mut found = 0;
    for i in 0..sides.len() {
        for j in i + 1..sides.len() {
            for k in j + 1..sides.len() {
                // n_a · c + r |n_a| = d_a for a in {i, j, k}: three equations in (x, y, r).
                let row = |a: usize| {
                    let (n, d) = sides[a];
                    [n[0], n[1], n[0].hypot(n[1]), d]
                };
                let m = Matrix3::from_fn(|r, c| row([i, j, k][r])[c]);
                let rhs = Vector3::new(row(i)[3], row(j)[3], row(k)[3]);
                let Some(solution) = m.lu().solve(&rhs) else { continue };
                let (x, y, r) = (solution[0], solution[1], solution[2]);
                let inside = sides.iter().all(|(n, d)| n[0] * x + n[1] * y + r * n[0].hypot(n[1]) <= d + TIE);
                if r.is_finite() && r > 0.0 && inside && found < candidates.len() {
                    candidates[found] = (x, y, r);
                    found += 1;
                }
            }
        }
    }
    let best = candidates[..found].iter().map(|c| c.2).fold(f64::NEG_INFINITY, f64::max);
    let optimal = || candidates[..found].iter().filter(move |c| c.2 >= best - TIE);
    // The two optimal points furthest apart; their middle.
    let (a, b) = optimal()
        .flat_map(|a| optimal().map(move |b| (a, b)))
        .max_by(|p, q| distance(p.0, p.1).total_cmp(&distance(q.0, q.1)))?;
    Some((0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1)))
}

/// The horizontal distance between two candidates of [`deepest_point`].
fn distance(a: &(f64, f64, f64), b: &(f64, f64, f64)) -> f64 {
    (a.0 - b.0).hypot(a.1 - b.1)
}

/// How the MPC keeps feet in their foothold regions (seed 004, IV-B3 and IV-B4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FootholdConstraint {
    /// Not at all (the whole-body controller's CBF alone: Table II's "CBF-QP").
    Off,
    /// Eq. 23: stance feet inside their region (state-only): Table II's "MPC baseline".
    StanceOnly,
    /// Eq. 24: swing feet inside their next region grown by
    /// [`Trot::shrinking_growth`](crate::gait::Trot::shrinking_growth) (`margin` at
    /// lift-off), shrinking to it at touchdown; stance feet inside theirs.
    Shrinking {
        /// The growth at lift-off \[m\].
        margin: f64,
    },
    /// Eq. 25: `h' + γ h ≥ 0` for `h = d − n · c` of each side, swing feet on their next
    /// region and stance feet on theirs: a swing foot outside is drawn in at rate γ, one
    /// inside stays.
    Barrier {
        /// γ \[1/s\].
        gamma: f64,
    },
    /// Eq. 25 on eq. 24's shrinking set: `h' + γ h ≥ 0` for `h = d − n · c + m(t)` of each
    /// side, where a swing foot's region is grown by `m`
    /// ([`Trot::shrinking_growth`](crate::gait::Trot::shrinking_growth), `margin` at
    /// lift-off), shrinking onto the region at touchdown, and a stance foot's is not grown
    /// (`m = 0`). A foot lifting off outside its next region starts inside the grown one,
    /// and is drawn in as the set shrinks.
    ShrinkingBarrier {
        /// γ \[1/s\].
        gamma: f64,
        /// The growth at lift-off \[m\].
        margin: f64,
    },
}

impl FootholdConstraint {
    /// Whether the rows lead a swing foot to its region (eqs. 24 and 25), so that the
    /// cost aims it at the region's [`centre`](Region::centre)
    /// ([`MpcWeights::swing_joints`]): without them (eq. 23, or none) the plan learns of a
    /// region only at touchdown, and aims at nothing.
    pub fn guides_swings(self) -> bool {
        matches!(self, Self::Shrinking { .. } | Self::Barrier { .. } | Self::ShrinkingBarrier { .. })
    }

    /// Eq. 25's rate γ and its set's growth at lift-off, for the two CBF forms: the fixed
    /// region is the shrinking set with no growth.
    fn barrier(self) -> Option<(f64, f64)> {
        match self {
            Self::Barrier { gamma } => Some((gamma, 0.0)),
            Self::ShrinkingBarrier { gamma, margin } => Some((gamma, margin)),
            Self::Off | Self::StanceOnly | Self::Shrinking { .. } => None,
        }
    }
}

/// The MPC's weights (the QP's diagonal `Q`, `R`), in SI units (forces per newton).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MpcWeights {
    /// Roll, pitch, yaw.
    pub orientation: [f64; 3],
    /// Centre of mass x, y, z.
    pub position: [f64; 3],
    /// Angular velocity (trunk frame).
    pub angular_velocity: [f64; 3],
    /// Linear velocity (trunk frame).
    pub velocity: [f64; 3],
    /// Each joint angle's deviation from standing, or, for a leg whose foot is aimed, from
    /// the joints that put it there (see [`swing_joints`](Self::swing_joints)).
    pub joints: f64,
    /// Each swing leg's joint angle's deviation from the joints that put its foot where it
    /// is aimed, where the rows lead swing feet to their regions
    /// ([`FootholdConstraint::guides_swings`]) and the landing region has a
    /// [`centre`](Region::centre): along the gait's swing curve, moved from the last
    /// foothold's aim to the next's (a region's centre, the foot's radius above it).
    /// Other swing legs are free (drawn to standing by `joints`): on open ground a swing
    /// foot's placement is the MPC's to choose for balance.
    pub swing_joints: f64,
    /// Each force component's deviation from the shared weight, per N².
    pub force: f64,
    /// Each joint velocity.
    pub joint_velocity: f64,
}

impl Default for MpcWeights {
    fn default() -> Self {
        Self {
            // The centre of mass's x, y at 300 rather than 100: the whole-body loop
            // (tests/mpc_wbc.rs) drifted 8.3 cm sideways at 100, 4.9 cm at 300; 1000
            // doubled the iteration's time for 4.6 cm.
            orientation: [200.0, 200.0, 100.0],
            position: [300.0, 300.0, 300.0],
            angular_velocity: [2.0, 2.0, 2.0],
            velocity: [10.0, 10.0, 10.0],
            joints: 2.0,
            // At the joints' 2 a plan lands its feet on the region's edge nearest the hip
            // (the foothold rows hold them, nothing draws them in), where any tracking
            // error breaks eq. 25. The proposed controller on MuJoCo's five fields in
            // rows broke it for 6.6 % of swing time at 2, 2.6 % at 200, 2.0 % at 500,
            // 1.7 % at 2000 and 2.1 % at 5000 (docs/anymal.md).
            swing_joints: 2000.0,
            force: 1e-4,
            joint_velocity: 0.05,
        }
    }
}

/// The MPC's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MpcSettings {
    /// Stages in the horizon.
    pub horizon: usize,
    /// Time per stage \[s\].
    pub dt: f64,
    /// Friction coefficient μ.
    pub friction: f64,
    /// How footholds enter.
    pub footholds: FootholdConstraint,
    /// The cost's weights.
    pub weights: MpcWeights,
    /// Which method solves each iteration's QP.
    pub method: OcpMethod,
    /// The solver's settings: every OSQP field under [`OcpMethod::Admm`] (its scaling
    /// stays off: see [`cbfgen::qp::ocp`]); `eps_abs` and `max_iter` (Newton steps) under
    /// [`OcpMethod::InteriorPoint`].
    pub solver: SolverSettings,
}

impl Default for MpcSettings {
    /// A 1 s horizon of 25 stages; μ = 0.7; footholds as CBFs (γ = 20 /s); the
    /// interior-point method to 1e-6 in at most 50 Newton steps (`examples/mpc_latency.rs`
    /// on the stepping stones: 9 steps at the median against 7 at 1e-4, and a seventh of
    /// OSQP's time; `docs/anymal.md`).
    fn default() -> Self {
        Self {
            horizon: 25,
            dt: 0.04,
            friction: 0.7,
            footholds: FootholdConstraint::Barrier { gamma: 20.0 },
            weights: MpcWeights::default(),
            method: OcpMethod::InteriorPoint,
            solver: SolverSettings { eps_abs: 1e-6, max_iter: 50, ..Self::ADMM },
        }
    }
}

impl MpcSettings {
    /// OSQP's settings for this QP: to 1e-4 with ρ = 0.01 (ρ = 0.1 took twice the
    /// iterations at p99). Looser tolerances are faster but their plans, the next
    /// iteration's linearisation point, let the closed loop drift: at 3e-4 the trot of
    /// `tests/mpc.rs` swayed 9 cm within 6 s, at 1e-4 it stays within 2 cm.
    pub const ADMM: SolverSettings = SolverSettings {
        eps_abs: 1e-4,
        eps_rel: 1e-4,
        rho: 0.01,
        max_iter: 4000,
        check_termination: 10,
        ..SolverSettings::DEFAULT
    };

    /// These settings solved by OSQP ([`OcpMethod::Admm`] with [`Self::ADMM`]).
    pub fn with_admm(self) -> Self {
        Self { method: OcpMethod::Admm, solver: Self::ADMM, ..self }
    }

    /// These settings with stages `stage` seconds long and as many as keep the horizon's
    /// span (rounded to whole stages, at least one).
    ///
    /// # Errors
    /// A stage outside `[0.005, 0.5]` s.
    pub fn with_stage(self, stage: f64) -> Result<Self, CbfError> {
        within("MPC stage [s]", stage, 0.005, 0.5, "[0.005, 0.5]")?;
        let span = self.dt * self.horizon as f64;
        Ok(Self { horizon: (span / stage).round().max(1.0) as usize, dt: stage, ..self })
    }
}

/// What one iteration did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MpcReport {
    /// How the QP ended.
    pub status: QpStatus,
    /// The solver's iterations (Newton steps, or OSQP's ADMM iterations).
    pub iterations: u32,
    /// Whether the plan was replaced: only by a solved QP. Otherwise the last plan stays
    /// (it is what the next iteration linearises at, shifted).
    pub updated: bool,
}

/// A plan of the MPC: states at `start + k dt` (`N + 1`) and inputs (`N`, forces in
/// newtons, trunk frame), or none yet.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    start: f64,
    dt: f64,
    states: Vec<[f64; NX]>,
    inputs: Vec<[f64; NU]>,
    valid: bool,
}

impl Plan {
    /// No plan yet, for a horizon of `horizon` stages of `dt` seconds.
    pub fn new(horizon: usize, dt: f64) -> Self {
        Self { start: 0.0, dt, states: vec![[0.0; NX]; horizon + 1], inputs: vec![[0.0; NU]; horizon], valid: false }
    }

    /// Whether there is a plan.
    pub fn is_valid(&self) -> bool {
        self.valid
    }

    /// When it starts \[s\].
    pub fn start(&self) -> f64 {
        self.start
    }

    /// Become a copy of `other`, a plan of the same horizon, without allocating.
    ///
    /// # Panics
    /// A plan of another horizon (a caller's mix-up of two MPCs).
    pub fn copy_from(&mut self, other: &Plan) {
        self.states.copy_from_slice(&other.states);
        self.inputs.copy_from_slice(&other.inputs);
        (self.start, self.dt, self.valid) = (other.start, other.dt, other.valid);
    }

    /// The plan: its start time, states (`N + 1`, one per stage) and inputs (`N`, forces
    /// in newtons, trunk frame). Empty before the first solve that left an iterate.
    pub fn parts(&self) -> (f64, &[[f64; NX]], &[[f64; NU]]) {
        if self.valid {
            (self.start, &self.states, &self.inputs)
        } else {
            (self.start, &[], &[])
        }
    }

    /// The planned state and input at time `t`: linear between stages, held outside.
    pub fn at(&self, t: f64) -> Option<([f64; NX], [f64; NU])> {
        if !self.valid {
            return None;
        }
        let n = self.inputs.len();
        let s = ((t - self.start) / self.dt).clamp(0.0, n as f64);
        let k = (s.floor() as usize).min(n - 1);
        let f = s - k as f64;
        let x = std::array::from_fn(|i| self.states[k][i] + f * (self.states[k + 1][i] - self.states[k][i]));
        let next = (k + 1).min(n - 1);
        let u = std::array::from_fn(|i| self.inputs[k][i] + f * (self.inputs[next][i] - self.inputs[k][i]));
        Some((x, u))
    }

    /// What the whole-body controller tracks at time `t`: the gait's modes; the planned
    /// trunk pose, twist and acceleration (world); each swing foot's planned position, velocity and
    /// acceleration (a difference of the planned velocities over 1 ms); each stance foot's
    /// planned force, in the world. `None` before the first plan.
    pub fn whole_body_reference(&self, t: f64, trot: &Trot) -> Option<WbcReference> {
        const DIFFERENCE: f64 = 1e-3;
        let (x, u) = self.at(t)?;
        let (x_next, u_next) = self.at(t + DIFFERENCE)?;
        let mut reference = trot.reference(t);
        let (rotation, _) = gen::orientation(&x);
        let r = Matrix3::from_fn(|i, j| rotation[i][j]);
        let c = Vector3::from(gen::COM_OFFSET);
        let (w, v) = (Vector3::new(x[6], x[7], x[8]), Vector3::new(x[9], x[10], x[11]));
        let origin = Vector3::new(x[3], x[4], x[5]) - r * c;
        reference.trunk_position = origin.into();
        reference.trunk_rotation = r;
        reference.trunk_velocity = (r * (v - w.cross(&c))).into();
        reference.trunk_angular_velocity = (r * w).into();
        // The plan's accelerations: d(R v)/dt = R (v' + w × v) at the centre of mass, less
        // d²(R c)/dt² = R (w' × c + w × (w × c)) for the trunk's origin; R w' angular.
        let xdot = gen::flow(&x, &u).0;
        let (w_dot, v_dot) = (Vector3::new(xdot[6], xdot[7], xdot[8]), Vector3::new(xdot[9], xdot[10], xdot[11]));
        reference.trunk_acceleration = (r * (v_dot + w.cross(&v) - w_dot.cross(&c) - w.cross(&w.cross(&c)))).into();
        reference.trunk_angular_acceleration = (r * w_dot).into();
        let (positions, _, velocities, _, _) = gen::feet(&x, &u);
        let next = gen::feet(&x_next, &u_next).2;
        for foot in 0..FEET {
            let f = r * Vector3::new(u[3 * foot], u[3 * foot + 1], u[3 * foot + 2]);
            reference.forces[foot] = if reference.stance[foot] { f.into() } else { [0.0; 3] };
            reference.feet[foot] = FootReference {
                position: positions[foot],
                velocity: velocities[foot],
                acceleration: std::array::from_fn(|i| (next[foot][i] - velocities[foot][i]) / DIFFERENCE),
            };
        }
        Some(reference)
    }
}

/// The MPC (module docs). Holds the last plan.
#[derive(Debug)]
pub struct KinodynamicMpc {
    settings: MpcSettings,
    ocp: Ocp,
    plan: Plan,
    /// Shifted guess (scratch).
    guess_x: Vec<[f64; NX]>,
    guess_u: Vec<[f64; NU]>,
    warm: Vec<f64>,
}

/// State columns: roll, pitch, yaw; centre of mass; angular velocity; velocity.
const ORIENTATION: std::ops::Range<usize> = 0..3;
const POSITION: std::ops::Range<usize> = 3..6;
const TWIST: std::ops::Range<usize> = 6..12;

/// The sparsity, each row kind on only what it depends on: a foot's motion rows on the
/// trunk's pose and twist and its leg's joints and joint velocities; its force rows on the
/// orientation and its force; its foothold rows on the pose and its leg's joints (and,
/// as CBFs, the twist and joint velocities); a joint-limit row on its joint.
fn shape(horizon: usize, footholds: FootholdConstraint) -> OcpShape {
    let rows = foot_rows(footholds);
    let mut s = OcpShape::dense(horizon, NX, NU, FEET * rows + JOINTS);
    // The discrete A = I + dt ∂f/∂x and B = dt ∂f/∂u: the identity and the Jacobians'
    // structural non-zeros, as the spec found them.
    for i in 0..NX {
        for j in 0..NX {
            s.a[i * NX + j] = i == j || gen::FLOW_A_PATTERN[i][j] != 0;
        }
        for j in 0..NU {
            s.b[i * NU + j] = gen::FLOW_B_PATTERN[i][j] != 0;
        }
    }
    s.c.fill(false);
    s.d.fill(false);
    let moving = footholds.barrier().is_some();
    for foot in 0..FEET {
        let (joints, force, rates) =
            (12 + 3 * foot..15 + 3 * foot, 3 * foot..3 * foot + 3, 12 + 3 * foot..15 + 3 * foot);
        for r in 0..rows {
            let row = foot * rows + r;
            let (states, inputs): (Vec<usize>, Vec<usize>) = if r < MOTION_ROWS {
                (ORIENTATION.chain(POSITION).chain(TWIST).chain(joints.clone()).collect(), rates.clone().collect())
            } else if r < MOTION_ROWS + FORCE_ROWS {
                (ORIENTATION.collect(), force.clone().collect())
            } else if moving {
                (ORIENTATION.chain(POSITION).chain(TWIST).chain(joints.clone()).collect(), rates.clone().collect())
            } else {
                (ORIENTATION.chain(POSITION).chain(joints.clone()).collect(), Vec::new())
            };
            for j in states {
                s.c[row * NX + j] = true;
            }
            for j in inputs {
                s.d[row * NU + j] = true;
            }
        }
    }
    for j in 0..JOINTS {
        s.c[(FEET * rows + j) * NX + 12 + j] = true;
    }
    s
}

impl KinodynamicMpc {
    /// Lay the QP out.
    ///
    /// # Errors
    /// A horizon outside `[2, 200]`, a stage time outside `[1e-3, 0.5]` s, μ outside
    /// `(0, 2]`, a negative or non-finite weight, a foothold parameter out of range, or
    /// OSQP refusing the set-up.
    pub fn new(settings: MpcSettings) -> Result<Self, CbfError> {
        within("MPC horizon", settings.horizon as f64, 2.0, 200.0, "[2, 200]")?;
        within("MPC stage time [s]", settings.dt, 1e-3, 0.5, "[1e-3, 0.5]")?;
        within("friction coefficient", settings.friction, 1e-3, 2.0, "(0, 2]")?;
        let w = settings.weights;
        for v in w.orientation.iter().chain(&w.position).chain(&w.angular_velocity).chain(&w.velocity) {
            within("MPC weight", *v, 0.0, 1e8, "[0, 1e8]")?;
        }
        for v in [w.joints, w.force, w.joint_velocity] {
            within("MPC weight", v, 1e-12, 1e8, "(0, 1e8]")?;
        }
        match settings.footholds {
            FootholdConstraint::Shrinking { margin } => {
                within("shrinking foothold margin [m]", margin, 0.0, 10.0, "[0, 10]")?;
            }
            FootholdConstraint::Barrier { .. } | FootholdConstraint::ShrinkingBarrier { .. } => {
                let (gamma, margin) = settings.footholds.barrier().unwrap_or_default();
                within("foothold CBF rate [1/s]", gamma, 1e-3, 1e3, "[1e-3, 1e3]")?;
                within("shrinking foothold margin [m]", margin, 0.0, 10.0, "[0, 10]")?;
            }
            FootholdConstraint::Off | FootholdConstraint::StanceOnly => {}
        }
        let n = settings.horizon;
        let ocp = Ocp::with_method(shape(n, settings.footholds), settings.solver, settings.method)?;
        Ok(Self {
            settings,
            ocp,
            plan: Plan::new(n, settings.dt),
            guess_x: vec![[0.0; NX]; n + 1],
            guess_u: vec![[0.0; NU]; n],
            warm: vec![0.0; n * (NX + NU) + NX],
        })
    }

    /// The settings it was built with.
    pub fn settings(&self) -> &MpcSettings {
        &self.settings
    }

    /// The plan: its start time, states (`N + 1`, one per stage) and inputs (`N`, forces
    /// in newtons, trunk frame). Empty before the first solve that left an iterate.
    pub fn plan(&self) -> (f64, &[[f64; NX]], &[[f64; NU]]) {
        self.plan.parts()
    }

    /// The last plan, whole (to copy to another thread: [`Plan::copy_from`]).
    pub fn latest(&self) -> &Plan {
        &self.plan
    }

    /// The planned state and input at time `t` ([`Plan::at`]).
    pub fn plan_at(&self, t: f64) -> Option<([f64; NX], [f64; NU])> {
        self.plan.at(t)
    }

    /// What the whole-body controller tracks at time `t` ([`Plan::whole_body_reference`]).
    pub fn whole_body_reference(&self, t: f64, trot: &Trot) -> Option<WbcReference> {
        self.plan.whole_body_reference(t, trot)
    }

    /// One real-time iteration from the measured state `x` at time `t`, on the gait
    /// `trot`, with each foot's region for the stance that contains a time given by
    /// `region(foot, time)` (the stance it is in, or for a swing foot the one it lands
    /// in). Allocation-free.
    ///
    /// # Errors
    /// A non-finite `x` or `t`.
    pub fn solve(
        &mut self,
        t: f64,
        x: &[f64; NX],
        trot: &Trot,
        region: &dyn Fn(usize, f64) -> Region,
    ) -> Result<MpcReport, CbfError> {
        cbfgen::error::finite("MPC time", t)?;
        for v in x {
            cbfgen::error::finite("MPC state", *v)?;
        }
        self.shift_guess(t, x, trot);
        let s = self.settings;
        let (n, dt) = (s.horizon, s.dt);
        let rows = foot_rows(s.footholds);
        self.ocp.initial_state_mut().copy_from_slice(x);
        // A foot in the stance it stands in at `t` cannot move before it lifts off, so a
        // foothold row on it is a constant of the measured state: satisfied, or a QP with
        // no solution. Those rows are left out.
        let mut first_stance: [bool; FEET] = trot.reference(t).stance;
        let aiming = s.footholds.guides_swings();
        for k in 0..=n {
            let time = t + k as f64 * dt;
            let xk = self.guess_x[k];
            let reference = trot.reference(time);
            for (first, stance) in first_stance.iter_mut().zip(reference.stance) {
                *first &= stance;
            }
            let regions: [Region; FEET] = std::array::from_fn(|foot| region(foot, time));
            let mut stage = self.ocp.stage_mut(k);
            // Cost: around the gait's trunk (the centre of mass at the commanded height
            // above the feet's surfaces: the gait's is above z = 0), level, at the
            // commanded velocity; the joints standing or aimed (below); the weight shared.
            let w = s.weights;
            let ground = regions.iter().map(|r| r.surface).sum::<f64>() / FEET as f64;
            let com = [
                reference.trunk_position[0] + gen::COM_OFFSET[0],
                reference.trunk_position[1] + gen::COM_OFFSET[1],
                reference.trunk_position[2] + gen::COM_OFFSET[2] + ground,
            ];
            let yaw = 0.0;
            let (c, sn) = (f64::cos(xk[2]), f64::sin(xk[2]));
            let v_world = reference.trunk_velocity;
            let v_trunk = [c * v_world[0] + sn * v_world[1], -sn * v_world[0] + c * v_world[1], v_world[2]];
            let target: [f64; NX] = std::array::from_fn(|i| match i {
                2 => yaw,
                3..=5 => com[i - 3],
                9..=11 => v_trunk[i - 9],
                // The joints' target is set below, aimed or standing.
                _ => 0.0,
            });
            let weights: [f64; NX] = std::array::from_fn(|i| match i {
                0..=2 => w.orientation[i],
                3..=5 => w.position[i - 3],
                6..=8 => w.angular_velocity[i - 6],
                9..=11 => w.velocity[i - 9],
                _ => w.joints,
            });
            stage.x_ref.copy_from_slice(&target);
            // Where the rows lead a foot to a region with a centre, its leg is drawn to
            // the joints that put it there under the reference trunk (a swing foot along
            // the gait's curve, moved from the last foothold's aim to the next's); other
            // legs to standing.
            let aims: [Option<[f64; 3]>; FEET] = std::array::from_fn(|foot| {
                if !aiming || regions[foot].centre.is_none() {
                    return None;
                }
                let nominal = trot.foothold_for(foot, time);
                let to = regions[foot].shift(nominal);
                let Some(swing) = trot.swing_at(foot, time) else {
                    return Some(std::array::from_fn(|i| nominal[i] + to[i]));
                };
                let before = swing.lift_off - 0.5 * trot.swing;
                let from = region(foot, before).shift(trot.foothold_for(foot, before));
                let (g, curve) = (swing.travel[0], reference.feet[foot].position);
                Some(std::array::from_fn(|i| curve[i] + (1.0 - g) * from[i] + g * to[i]))
            });
            stage.x_ref[12..].copy_from_slice(&aimed_joints(&target, &aims));
            stage.q.copy_from_slice(&weights);
            for foot in (0..FEET).filter(|&foot| !reference.stance[foot] && aims[foot].is_some()) {
                stage.q[12 + 3 * foot..15 + 3 * foot].fill(w.swing_joints);
            }
            stage.free_rows();
            // Joint limits.
            for j in 0..JOINTS {
                let r = FEET * rows + j;
                stage.c[r * NX + 12 + j] = 1.0;
                stage.lower[r] = gen::Q_MIN[j];
                stage.upper[r] = gen::Q_MAX[j];
            }
            let uk = if k < n { self.guess_u[k] } else { self.guess_u[n - 1] };
            let (positions, jp, velocities, jvx, jvu) = gen::feet(&xk, &uk);
            let (rotation, derivatives) = gen::orientation(&xk);
            if k < n {
                let (xdot, a, b) = gen::flow(&xk, &uk);
                // x_{k+1} ≈ x̄ + dt f + (I + dt A)(x − x̄) + dt B (u − ū), u in QP units.
                for i in 0..NX {
                    let mut offset = xk[i] + dt * xdot[i];
                    for j in 0..NX {
                        let aij = f64::from(u8::from(i == j)) + dt * a[i][j];
                        stage.a[i * NX + j] = aij;
                        offset -= aij * xk[j];
                    }
                    for j in 0..NU {
                        let unit = if j < 12 { FORCE_UNIT } else { 1.0 };
                        let bij = dt * b[i][j] * unit;
                        stage.b[i * NU + j] = bij;
                        offset -= bij * uk[j] / unit;
                    }
                    stage.offset[i] = offset;
                }
                let stance_count = reference.stance.iter().filter(|s| **s).count();
                for j in 0..NU {
                    let (weight, target) = if j < 12 {
                        let foot = j / 3;
                        // The shared weight, in the trunk frame (vertical in the world).
                        let share = if reference.stance[foot] && stance_count > 0 {
                            gen::MASS * gen::GRAVITY / stance_count as f64
                        } else {
                            0.0
                        };
                        (w.force * FORCE_UNIT * FORCE_UNIT, share * rotation[2][j % 3] / FORCE_UNIT)
                    } else {
                        (w.joint_velocity, 0.0)
                    };
                    stage.r[j] = weight;
                    stage.u_ref[j] = target;
                }
            }
            for foot in 0..FEET {
                let top = foot * rows;
                let stance = reference.stance[foot];
                let normal = regions[foot].normal;
                // A row r(x, u) ≈ r̄ + C (x − x̄) + D (u − ū) in [lo, hi]: write C, D and
                // shift the bounds by C x̄ + D ū − r̄.
                let mut linear_row = |row: usize, value: f64, cx: &[f64], du: &[f64], lo: f64, hi: f64| {
                    let mut shift = -value;
                    for j in 0..NX {
                        stage.c[row * NX + j] = cx[j];
                        shift += cx[j] * xk[j];
                    }
                    if k < n {
                        for j in 0..NU {
                            let unit = if j < 12 { FORCE_UNIT } else { 1.0 };
                            stage.d[row * NU + j] = du[j] * unit;
                            shift += du[j] * uk[j];
                        }
                    }
                    stage.lower[row] = if lo <= -INFINITY { -INFINITY } else { lo + shift };
                    stage.upper[row] = if hi >= INFINITY { INFINITY } else { hi + shift };
                };
                let none = [0.0; NU];
                if k < n && stance {
                    for axis in 0..3 {
                        let r = 3 * foot + axis;
                        linear_row(top + axis, velocities[foot][axis], &jvx[r], &jvu[r], 0.0, 0.0);
                    }
                    // The pyramid on F = R f (world): rows a · F with a over the normal's
                    // tangents, linearised in roll, pitch, yaw and f.
                    let f = [uk[3 * foot], uk[3 * foot + 1], uk[3 * foot + 2]];
                    let (t1, t2) = tangents(normal);
                    let mu = s.friction / std::f64::consts::SQRT_2;
                    let rows: [[f64; 3]; 5] = std::array::from_fn(|r| {
                        let (tangent, sign) = match r {
                            0 => (t1, 1.0),
                            1 => (t1, -1.0),
                            2 => (t2, 1.0),
                            3 => (t2, -1.0),
                            _ => ([0.0; 3], 0.0),
                        };
                        if r == 4 {
                            normal
                        } else {
                            std::array::from_fn(|i| sign * tangent[i] - mu * normal[i])
                        }
                    });
                    for (r, a) in rows.iter().enumerate() {
                        let world = |m: &[[f64; 3]; 3]| -> f64 {
                            (0..3).map(|i| a[i] * (0..3).map(|j| m[i][j] * f[j]).sum::<f64>()).sum()
                        };
                        let value = world(&rotation);
                        let mut cx = [0.0; NX];
                        for (e, d) in derivatives.iter().enumerate() {
                            let m: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| d[3 * i + j]));
                            cx[e] = world(&m);
                        }
                        let mut du = none;
                        for j in 0..3 {
                            du[3 * foot + j] = (0..3).map(|i| a[i] * rotation[i][j]).sum();
                        }
                        let (lo, hi) = if r == 4 { (0.0, INFINITY) } else { (-INFINITY, 0.0) };
                        linear_row(top + MOTION_ROWS + r, value, &cx, &du, lo, hi);
                    }
                } else if k < n {
                    for axis in 0..3 {
                        let mut du = none;
                        du[3 * foot + axis] = 1.0;
                        linear_row(top + MOTION_ROWS + axis, uk[3 * foot + axis], &[0.0; NX], &du, 0.0, 0.0);
                    }
                    // The lift curve along the normal, with feedback on its height so that
                    // the feet land on the surface, not where the linearisation's errors
                    // would take them: n·v + K n·p = n·v_ref + K n·p_ref. The gait draws
                    // the curve over z = 0; it is raised from the surface the foot left
                    // to the one it lands on as the foot travels.
                    let curve = &reference.feet[foot];
                    let (left, travel) = match trot.swing_at(foot, time) {
                        Some(swing) => (region(foot, swing.lift_off - 0.5 * trot.swing).surface, swing.travel),
                        None => (regions[foot].surface, [1.0, 0.0, 0.0]),
                    };
                    let rise = regions[foot].surface - left;
                    let target = dot(&normal, &curve.velocity)
                        + rise * travel[1]
                        + LIFT_GAIN * (dot(&normal, &curve.position) + left + rise * travel[0]);
                    let value = dot(&normal, &velocities[foot]) + LIFT_GAIN * dot(&normal, &positions[foot]);
                    let cx: [f64; NX] = std::array::from_fn(|j| {
                        (0..3).map(|i| normal[i] * (jvx[3 * foot + i][j] + LIFT_GAIN * jp[3 * foot + i][j])).sum()
                    });
                    let du: [f64; NU] = std::array::from_fn(|j| (0..3).map(|i| normal[i] * jvu[3 * foot + i][j]).sum());
                    linear_row(top, value, &cx, &du, target, target);
                }
                // Footholds.
                if s.footholds == FootholdConstraint::Off || first_stance[foot] {
                    continue;
                }
                let r = &regions[foot];
                for (side, (n_side, d)) in r.sides.iter().take(r.count).enumerate() {
                    let row = top + MOTION_ROWS + FORCE_ROWS + side;
                    let h = d - dot(n_side, &positions[foot]);
                    let dh_dx: [f64; NX] =
                        std::array::from_fn(|j| -(0..3).map(|i| n_side[i] * jp[3 * foot + i][j]).sum::<f64>());
                    match s.footholds {
                        FootholdConstraint::Off => {}
                        FootholdConstraint::StanceOnly if stance => {
                            linear_row(row, h, &dh_dx, &none, 0.0, INFINITY);
                        }
                        FootholdConstraint::StanceOnly => {}
                        FootholdConstraint::Shrinking { margin } => {
                            let grow = if stance { 0.0 } else { trot.shrinking_growth(margin, time)[0] };
                            linear_row(row, h, &dh_dx, &none, -grow, INFINITY);
                        }
                        FootholdConstraint::Barrier { .. } | FootholdConstraint::ShrinkingBarrier { .. } if k < n => {
                            // h_s' + γ h_s = −n · v + m' + γ (h + m) ≥ 0 on a swing foot's set
                            // grown by m (none on the region itself, nor for a stance foot):
                            // the growth and its rate are constants of the stage, in the bound.
                            let (gamma, margin) = s.footholds.barrier().unwrap_or_default();
                            let [grow, rate, _] = if stance { [0.0; 3] } else { trot.shrinking_growth(margin, time) };
                            let hdot = -dot(n_side, &velocities[foot]);
                            let cx: [f64; NX] = std::array::from_fn(|j| {
                                -(0..3).map(|i| n_side[i] * jvx[3 * foot + i][j]).sum::<f64>() + gamma * dh_dx[j]
                            });
                            let du: [f64; NU] =
                                std::array::from_fn(|j| -(0..3).map(|i| n_side[i] * jvu[3 * foot + i][j]).sum::<f64>());
                            linear_row(row, hdot + gamma * h, &cx, &du, -(rate + gamma * grow), INFINITY);
                        }
                        FootholdConstraint::Barrier { .. } | FootholdConstraint::ShrinkingBarrier { .. } => {
                            if stance {
                                linear_row(row, h, &dh_dx, &none, 0.0, INFINITY);
                            }
                        }
                    }
                }
            }
        }
        // Warm start from the guess, in QP units.
        for k in 0..=n {
            let at = k * (NX + NU);
            self.warm[at..at + NX].copy_from_slice(&self.guess_x[k]);
            if k < n {
                for j in 0..NU {
                    self.warm[at + NX + j] = self.guess_u[k][j] / if j < 12 { FORCE_UNIT } else { 1.0 };
                }
            }
        }
        self.ocp.warm_start(&self.warm)?;
        let status = self.ocp.solve();
        let updated = status.is_solved() && self.ocp.has_solution();
        if updated {
            for k in 0..=n {
                self.plan.states[k].copy_from_slice(self.ocp.state(k));
                if k < n {
                    for (j, v) in self.ocp.input(k).iter().enumerate() {
                        self.plan.inputs[k][j] = v * if j < 12 { FORCE_UNIT } else { 1.0 };
                    }
                }
            }
            self.plan.start = t;
            self.plan.valid = true;
        }
        Ok(MpcReport { status, iterations: self.ocp.iterations(), updated })
    }

    /// The point this iteration linearises at: the last plan shifted to `t` (with the
    /// measured state first), or, with no plan yet, the measured state held and the weight
    /// shared by the stance feet.
    fn shift_guess(&mut self, t: f64, x: &[f64; NX], trot: &Trot) {
        let n = self.settings.horizon;
        for k in 0..=n {
            let time = t + k as f64 * self.settings.dt;
            let planned = self.plan.at(time);
            let (xs, us) = planned.unwrap_or_else(|| {
                let reference = trot.reference(time);
                let count = reference.stance.iter().filter(|s| **s).count().max(1) as f64;
                let mut u = [0.0; NU];
                for foot in 0..FEET {
                    if reference.stance[foot] {
                        u[3 * foot + 2] = gen::MASS * gen::GRAVITY / count;
                    }
                }
                (*x, u)
            });
            self.guess_x[k] = if k == 0 { *x } else { xs };
            if k < n {
                self.guess_u[k] = us;
            }
        }
    }
}

/// The MPC's state of the whole-body model's state `x` ([`wbc_generated`](crate::wbc_generated)'s
/// layout): roll, pitch, yaw of its rotation (yaw in (−π, π]), the centre of mass at
/// [`gen::COM_OFFSET`] in the trunk frame, the trunk's angular velocity, the centre of
/// mass's velocity `v + w × c` (both trunk frame), and the joints.
pub fn state_from_whole_body(x: &[f64; wbc_gen::NX]) -> [f64; NX] {
    let r = |i: usize, j: usize| x[3 + 3 * i + j];
    let c = gen::COM_OFFSET;
    let (v, w) = ([x[24], x[25], x[26]], [x[27], x[28], x[29]]);
    let mut m = [0.0; NX];
    m[0] = r(2, 1).atan2(r(2, 2));
    m[1] = (-r(2, 0)).atan2(r(2, 1).hypot(r(2, 2)));
    m[2] = r(1, 0).atan2(r(0, 0));
    for i in 0..3 {
        m[3 + i] = x[i] + (0..3).map(|k| r(i, k) * c[k]).sum::<f64>();
        m[6 + i] = w[i];
    }
    let w_cross_c = cross(&w, &c);
    for i in 0..3 {
        m[9 + i] = v[i] + w_cross_c[i];
    }
    m[12..].copy_from_slice(&x[12..24]);
    m
}

/// The MPC's state for [`standing_on_the_ground`](crate::gait::standing_on_the_ground):
/// level, at rest, the centre of mass above the trunk origin by [`gen::COM_OFFSET`].
pub fn standing() -> [f64; NX] {
    let trunk = crate::gait::standing_on_the_ground();
    let mut x = [0.0; NX];
    for i in 0..3 {
        x[3 + i] = trunk[i] + gen::COM_OFFSET[i];
    }
    x[12..].copy_from_slice(&gen::STANDING_JOINTS);
    x
}

/// One RK4 step of `h` seconds of the MPC's own model under input `u` (forces in newtons,
/// trunk frame): the plant its plans are exact for.
pub fn integrate(x: &[f64; NX], u: &[f64; NU], h: f64) -> [f64; NX] {
    let f = |x: &[f64; NX]| Ok::<_, std::convert::Infallible>(gen::flow(x, u).0);
    let Ok(next) = cbfgen::system::rk4_step(f, x, h);
    next
}

/// The joints that put the feet's centres at `aims` (world) with the trunk at `x`'s pose:
/// Newton steps on each leg's three joints from standing (a foot moves with its own leg
/// only), to 10 µm. A leg with no aim, or whose aim is not reached within 1 cm (out of
/// reach within its joint limits, or too far for four steps of at most 0.3 rad), keeps
/// standing.
pub fn aimed_joints(x: &[f64; NX], aims: &[Option<[f64; 3]>; FEET]) -> [f64; JOINTS] {
    const STEPS: usize = 4;
    const REACHED: f64 = 0.01;
    let mut state = *x;
    state[12..].copy_from_slice(&gen::STANDING_JOINTS);
    let still = [0.0; NU];
    let mut error = [f64::INFINITY; FEET];
    for step in 0..=STEPS {
        let (positions, jp, ..) = gen::feet(&state, &still);
        for (foot, aim) in aims.iter().enumerate() {
            let Some(aim) = aim else { continue };
            let e = Vector3::from_fn(|i, _| aim[i] - positions[foot][i]);
            error[foot] = e.norm();
            if step == STEPS || error[foot] < 1e-5 {
                continue;
            }
            let jacobian = Matrix3::from_fn(|i, c| jp[3 * foot + i][12 + 3 * foot + c]);
            let Some(dq) = jacobian.lu().solve(&e) else { continue };
            // At most 0.3 rad a step: far aims are approached, not jumped at.
            let scale = (0.3 / dq.amax()).min(1.0);
            for c in 0..3 {
                let j = 3 * foot + c;
                state[12 + j] = (state[12 + j] + scale * dq[c]).clamp(gen::Q_MIN[j], gen::Q_MAX[j]);
            }
        }
    }
    std::array::from_fn(|j| if error[j / 3] < REACHED { state[12 + j] } else { gen::STANDING_JOINTS[j] })
}

/// Two unit tangents completing `normal` to a right-handed frame.
fn tangents(normal: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let helper = if normal[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let along = dot(&helper, &normal);
    let mut t1 = [helper[0] - along * normal[0], helper[1] - along * normal[1], helper[2] - along * normal[2]];
    let length = dot(&t1, &t1).sqrt();
    t1.iter_mut().for_each(|v| *v /= length);
    (t1, cross(&normal, &t1))
}
