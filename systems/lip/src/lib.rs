//! Bipedal navigation with a 3D-LIP MPC and linear discrete control barrier functions.
//!
//! Each walking step the robot plans its next `N` footsteps (a QP solved exactly by the
//! dense dual active-set method, OSQP as the fallback) and takes the first:
//!
//! ```text
//! min_{f_0..f_{N−1}}  Σ_{k=1..N} (p_x,k − g_x)² + (p_y,k − g_y)²
//! s.t.  x_{k+1} = A_L x_k + B_L u_k                                  (3D-LIP, [`model`])
//!       v_min ≤ [R(θ_k)ᵀ v_{k+1}] ∘ [1, s_v,k] ≤ v_max                 walking velocity
//!       −l_max ≤ R(θ_k)ᵀ (p_{k+1} − p_k) ≤ l_max                       leg reachability
//!       [R(θ_k)ᵀ v_{k+1}]_x ≤ v_x,max − (α/π) |ω_k|                    maneuverability
//!       h_j(p_{k+1}) ≥ (1 − γ) h_j(p_k)  for every obstacle j          discrete CBF
//! ```
//!
//! Headings `θ_k` and turning rates `ω_k` are fixed before the solve ([`mpc`], heading
//! preprocessing) and each obstacle's half-plane `h_j` is frozen at the step's start
//! ([`obstacles`]), so every row is linear in the feet and states.
//!
//! * [`model`] — `A_L`, `B_L` and the global ↔ local frames.
//! * [`obstacles`] — rectangles and the half-plane barrier of each.
//! * [`mpc`] — the MPC: fixed sparsity, values updated each step, no allocation.
//! * [`scenario`] — a closed loop around rectangles to a goal, and its record.
//! * [`figure`] — the map and barrier figures of a run.

#![warn(missing_docs)]

pub mod figure;
pub mod model;
pub mod mpc;
pub mod obstacles;
pub mod scenario;

pub use model::{Frame, Lip, LipInput, LipState};
pub use mpc::{HeadingRule, LipMpc, Plan};
pub use obstacles::{BarrierForm, HalfPlane, Rectangle};

use cbfgen::error::{finite, positive, CbfError};

/// Everything the MPC is built with. The report gives no numbers, so each default below
/// is **assumed**: sized for a human-scale biped (Digit-like CoM height, 0.4 s steps).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LipParams {
    /// Pendulum: CoM height `H` = 1.0 m (assumed), step time `T` = 0.4 s (assumed).
    pub lip: Lip,
    /// Prediction horizon `N` in steps (6: 2.4 s of walking).
    pub horizon: usize,
    /// Forward velocity bounds at step ends, heading frame [m/s]: [−0.1, 0.6] (assumed).
    pub vx_bounds: [f64; 2],
    /// Bounds on `s_v · lateral velocity` at step ends [m/s]: [0.05, 0.4] (assumed). A
    /// positive lower bound makes the lateral velocity change sign every step, as the CoM
    /// sways over each new stance foot.
    pub vy_bounds: [f64; 2],
    /// Leg reachability `l_max`: the CoM's largest move per step along and across the
    /// heading \[m\]: 0.5 (assumed).
    pub leg_reach: f64,
    /// Turning-rate bounds `[ω_min, ω_max]` [rad/s]: ±π/4 (assumed; ≤ 18° per step).
    pub omega_bounds: [f64; 2],
    /// Maneuverability `α`: forward speed given up per unit `|ω|/π` [m/s per rad/s · π]:
    /// 1.2 (assumed; halves the top speed at the fastest turn).
    pub alpha: f64,
    /// CBF decay `γ` in (0, 1]: 0.3 (assumed).
    pub gamma: f64,
    /// CBF margin `δ`: the least CoM distance to any obstacle \[m\]: 0.3 (assumed; room for
    /// a foot beside the CoM). In m² under [`BarrierForm::ReportNormal`]. `δ = 0` is the
    /// original LDCBF of Peng et al.; `δ > 0` is the report's variation (its section 5.3.3).
    pub delta: f64,
    /// Which normal the half-planes use: unit (default) or the report's `x − c`.
    pub barrier: BarrierForm,
    /// How the turning rates are fixed before each solve: per step toward the bearing
    /// (default) or the report's one clipped rate for the whole horizon.
    pub heading: HeadingRule,
}

impl Default for LipParams {
    fn default() -> Self {
        Self {
            lip: Lip::from_checked(1.0, 0.4),
            horizon: 6,
            vx_bounds: [-0.1, 0.6],
            vy_bounds: [0.05, 0.4],
            leg_reach: 0.5,
            omega_bounds: [-std::f64::consts::FRAC_PI_4, std::f64::consts::FRAC_PI_4],
            alpha: 1.2,
            gamma: 0.3,
            delta: 0.3,
            barrier: BarrierForm::UnitNormal,
            heading: HeadingRule::PerStepRate,
        }
    }
}

impl LipParams {
    /// Check every value.
    ///
    /// # Errors
    /// A non-finite value, an empty bound interval, `N = 0`, `γ ∉ (0, 1]` or negative `δ`.
    pub fn validate(&self) -> Result<(), CbfError> {
        let fresh = Lip::new(self.lip.height, self.lip.step_time)?;
        if fresh != self.lip {
            return Err(CbfError::OutOfRange { what: "LIP matrices", value: self.lip.beta, range: "Lip::new(H, T)" });
        }
        if self.horizon == 0 {
            return Err(CbfError::NotPositive { what: "horizon", value: 0.0 });
        }
        for (what, [lo, hi]) in
            [("vx bounds", self.vx_bounds), ("vy bounds", self.vy_bounds), ("omega bounds", self.omega_bounds)]
        {
            finite(what, lo)?;
            if finite(what, hi)? < lo {
                return Err(CbfError::OutOfRange { what, value: hi, range: "upper bound ≥ lower bound" });
            }
        }
        positive("leg reach", self.leg_reach)?;
        if finite("alpha", self.alpha)? < 0.0 {
            return Err(CbfError::OutOfRange { what: "alpha", value: self.alpha, range: "≥ 0" });
        }
        if !(finite("gamma", self.gamma)? > 0.0 && self.gamma <= 1.0) {
            return Err(CbfError::OutOfRange { what: "gamma", value: self.gamma, range: "(0, 1]" });
        }
        if finite("delta", self.delta)? < 0.0 {
            return Err(CbfError::OutOfRange { what: "delta", value: self.delta, range: "≥ 0" });
        }
        Ok(())
    }

    /// `v_x,max − (α/π)|ω|`: the forward-speed cap while turning at `ω`.
    pub fn maneuver_limit(&self, omega: f64) -> f64 {
        self.vx_bounds[1] - self.alpha / std::f64::consts::PI * omega.abs()
    }
}
