//! What the ECBF filter can be tuned with: gains, weights and activation per family,
//! input limits, and the OSQP settings. Defaults come from the model file.

use std::time::Duration;

use crate::catalog::Family;
use crate::error::{positive, CbfError};
use crate::model::{Input, ECBF_POLES, INPUT_LIMITS, NU};

/// Per-family ECBF parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FamilyParams {
    /// Real poles `p1, p2 > 0` [1/s]: rows enforce `L_f² h + (p1 + p2) L_f h + p1 p2 h ≥ 0`,
    /// so `h` decays no faster than `e^{-p t}` towards the boundary.
    pub poles: [f64; 2],
    /// `w_δ` of this family's slacks, relative to an input weight of 1. Larger is
    /// harder; see [`FilterSettings`] for the trade-off.
    pub slack_weight: f64,
    /// The row takes part only while `h` is below this (in `h`'s own units; `f64::INFINITY`
    /// = always). Rows above it are relaxed through their bounds, not removed.
    pub activation: f64,
}

impl FamilyParams {
    /// `[k0, k1]` of `L_f² h + k1 L_f h + k0 h ≥ 0`.
    pub fn gains(&self) -> [f64; 2] {
        ecbf_gains(self.poles)
    }
}

/// `[k0, k1] = [p1 p2, p1 + p2]`: the ECBF gains that place the closed-loop poles of `h`
/// at `−p1, −p2`. Every ECBF row in the crate takes its gains from here.
pub fn ecbf_gains([p1, p2]: [f64; 2]) -> [f64; 2] {
    [p1 * p2, p1 + p2]
}

/// OSQP settings for this problem class, exposed as they are passed to the solver.
///
/// The defaults are chosen for a 1 ms cycle, warm-started each cycle from the last one:
/// * the QP is handed to OSQP already scaled (variables by `√w`, each row by its norm,
///   every cycle), so OSQP's own Ruiz scaling — computed once at set-up on values that
///   change every cycle — is off;
/// * polishing is off: it allocates and factorises a second system on every solve;
/// * ρ adapts on a fixed iteration interval (not OSQP's default fraction of set-up time),
///   so iteration counts are reproducible across machines and runs;
/// * loose tolerances (`eps_abs` 1e-3, `eps_rel` 1e-4, scaled units: m/s² for inputs of
///   weight 1) because ADMM only has to find the active set: the filter then solves that
///   set exactly and keeps the result only if it passes every KKT condition (the polish
///   step, allocation-free). On the Clarabel cross-check and along the latency drive
///   every cycle polishes; 1e-4 tolerances cost twice the p99 iterations for nothing;
/// * at most 200 iterations (about 1 ms here): a cycle that needs more hands back the
///   iterate, flagged, and the next cycle continues from it;
/// * convergence is checked every 5 iterations: a check costs about one iteration, and
///   checking every iteration costs 40 % more instructions than it saves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverSettings {
    pub eps_abs: f64,
    pub eps_rel: f64,
    pub max_iter: u32,
    /// Initial ADMM step.
    pub rho: f64,
    pub sigma: f64,
    /// Over-relaxation, in (0, 2).
    pub alpha: f64,
    pub adaptive_rho: bool,
    /// Iterations between ρ adaptations (each one refactorises).
    pub adaptive_rho_interval: u32,
    /// Iterations between convergence checks (each costs about one iteration).
    pub check_termination: u32,
    /// Give up (flagged, with a fallback input) after this long; `None` = no limit.
    pub time_limit: Option<Duration>,
    /// Solve ADMM's active set exactly and keep it when it passes the KKT test (this
    /// crate's allocation-free polish; OSQP's own stays off).
    pub polish: bool,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            eps_abs: 1e-3,
            eps_rel: 1e-4,
            max_iter: 200,
            rho: 0.1,
            sigma: 1e-6,
            alpha: 1.6,
            adaptive_rho: true,
            adaptive_rho_interval: 25,
            check_termination: 5,
            time_limit: None,
            polish: true,
        }
    }
}

impl SolverSettings {
    pub(crate) fn validate(&self) -> Result<(), CbfError> {
        positive("eps_abs", self.eps_abs)?;
        positive("eps_rel", self.eps_rel)?;
        positive("rho", self.rho)?;
        positive("sigma", self.sigma)?;
        positive("alpha", self.alpha)?;
        if self.alpha >= 2.0 {
            return Err(CbfError::OutOfRange { what: "alpha", value: self.alpha, range: "(0, 2)" });
        }
        for (what, v) in [
            ("max_iter", self.max_iter),
            ("adaptive_rho_interval", self.adaptive_rho_interval),
            ("check_termination", self.check_termination),
        ] {
            positive(what, f64::from(v))?;
        }
        Ok(())
    }

    pub(crate) fn to_osqp(self) -> osqp::Settings {
        osqp::Settings::default()
            .verbose(false)
            .polish(false)
            .scaling(None)
            .warm_start(true)
            .eps_abs(self.eps_abs)
            .eps_rel(self.eps_rel)
            .max_iter(self.max_iter)
            .rho(self.rho)
            .sigma(self.sigma)
            .alpha(self.alpha)
            .adaptive_rho(self.adaptive_rho)
            .adaptive_rho_interval(Some(self.adaptive_rho_interval))
            .check_termination(Some(self.check_termination))
            .time_limit(self.time_limit)
    }
}

/// Everything the [`EcbfFilter`](super::EcbfFilter) is built with.
///
/// Cost: `Σ_j w_j (u_j − u_ref,j)² + Σ_i w_δ,i δ_i²`. A slack weight of `w_δ` makes one
/// unit of ECBF violation (m/s² of `ḧ`) cost as much as `√w_δ` units of input change:
/// with the default 10⁴ the filter bends the input a hundred times further before it
/// lets a row slip. Much larger weights make the QP stiffer and slower to converge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterSettings {
    /// Indexed by [`Family::index`].
    pub families: [FamilyParams; 6],
    /// `w_j` per input (> 0).
    pub input_weights: [f64; NU],
    /// Box limits `input_min ≤ u ≤ input_max`.
    pub input_min: Input,
    pub input_max: Input,
    pub solver: SolverSettings,
}

impl Default for FilterSettings {
    /// Poles and input limits from the model file; activation 0.5 m for the body–edge SSAT
    /// (its `h` is a lower bound on the distance) and 15 for the toe superellipsoid (toe
    /// within twice the inflated edge half-extent); every other family always applies.
    fn default() -> Self {
        let family = |f: Family| FamilyParams {
            poles: ECBF_POLES,
            slack_weight: 1e4,
            activation: match f {
                Family::BodyEdge => 0.5,
                Family::ToeEdge => 15.0,
                _ => f64::INFINITY,
            },
        };
        Self {
            families: Family::ALL.map(family),
            input_weights: [1.0; NU],
            input_min: INPUT_LIMITS.map(|l| -l),
            input_max: INPUT_LIMITS,
            solver: SolverSettings::default(),
        }
    }
}

impl FilterSettings {
    pub fn family(&self, f: Family) -> &FamilyParams {
        &self.families[f.index()]
    }

    pub fn family_mut(&mut self, f: Family) -> &mut FamilyParams {
        &mut self.families[f.index()]
    }

    /// # Errors
    /// Non-positive poles, weights or tolerances, a NaN activation, or `input_min > input_max`.
    pub fn validate(&self) -> Result<(), CbfError> {
        for p in &self.families {
            positive("ECBF pole", p.poles[0])?;
            positive("ECBF pole", p.poles[1])?;
            positive("slack weight", p.slack_weight)?;
            if p.activation.is_nan() {
                return Err(CbfError::NonFinite { what: "activation threshold", value: p.activation });
            }
        }
        validate_inputs(&self.input_weights, &self.input_min, &self.input_max)?;
        self.solver.validate()
    }
}

/// Input weights positive, box limits finite with `min ≤ max`: shared by
/// [`FilterSettings::validate`] and [`EcbfQp::new`](super::EcbfQp::new).
pub(crate) fn validate_inputs(weights: &[f64; NU], min: &Input, max: &Input) -> Result<(), CbfError> {
    for j in 0..NU {
        positive("input weight", weights[j])?;
        crate::error::finite("input limit", min[j])?;
        crate::error::finite("input limit", max[j])?;
        if min[j] > max[j] {
            return Err(CbfError::OutOfRange {
                what: "input_min (must not exceed input_max)",
                value: min[j],
                range: "[-inf, input_max]",
            });
        }
    }
    Ok(())
}
