//! The high-rate ID-CBF-QP: track the MPC's acceleration, keep the ECBF condition.
//!
//! ```text
//! minimise   (u − a_des)² + w_δ δ²
//! subject to L_g L_f h · u + δ ≥ −(L_f² h + k1 L_f h + k0 h)      (ECBF, ∂h/∂t terms included)
//!            −u_max ≤ u ≤ u_max
//! ```
//!
//! This is the generic [`EcbfFilter`](cbfgen::filter::EcbfFilter) on the double-integrator
//! spec (`systems/double_integrator/spec/double_integrator.py`, generated into
//! [`generated::double_integrator`](cbfgen_double_integrator)), with the
//! stiffest slack the filter accepts, so the row is met wherever the input bound allows.
//! With unit mass the inverse-dynamics equality `M q̈ = u` makes the acceleration and the
//! input the same variable. Where the bound cannot meet the row (a boundary that
//! accelerates away faster than `u_max`), the filter applies the best input within the
//! bound and reports the violation as [`CbfQpOutput::slack`]; it does not fail.

use super::barrier::{BarrierRow, SineBarrier, State};
use cbfgen::error::CbfError;
use cbfgen::filter::{domain, InputSource};
use cbfgen::qp::{QpStatus, SolverSettings};
use cbfgen::system::{ClassK, FamilyParams, Poles};
use cbfgen_double_integrator as spec;

/// Gains, input bound and solver settings of the CBF-QP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CbfQpSettings {
    /// Real poles `p1, p2 > 0` \[1/s\]: `k0 = p1 p2`, `k1 = p1 + p2`.
    pub poles: [f64; 2],
    /// `|u| ≤ u_max` \[m/s²\]; `f64::INFINITY` for none (the filter's box is then
    /// [`domain::MAX_INPUT`]).
    pub u_max: f64,
    /// OSQP settings of this layer.
    pub solver: SolverSettings,
}

impl Default for CbfQpSettings {
    /// Poles at 10/s (k0 = 100, k1 = 20: h settles in a few tenths of a second, well
    /// inside one MPC period of 50 ms × 30), no input bound (the paper's example has
    /// none), tolerances tight enough that the ECBF row holds to 1e-6 m/s².
    fn default() -> Self {
        Self {
            poles: [10.0, 10.0],
            u_max: f64::INFINITY,
            solver: SolverSettings { eps_abs: 1e-8, eps_rel: 1e-8, max_iter: 4000, ..SolverSettings::default() },
        }
    }
}

/// One CBF-QP solution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CbfQpOutput {
    /// The input `u` \[m/s²\]: finite and within `±u_max`, always.
    pub u: f64,
    /// Where `u` came from (the QP's optimum, an unconverged iterate, or a fallback).
    pub source: InputSource,
    /// OSQP's report; `None` when no solve was attempted.
    pub status: Option<QpStatus>,
    /// OSQP's ADMM iterations in this solve.
    pub iterations: u32,
    /// The ECBF row's slack `δ` \[m/s²\]: 0 when the row holds, positive by how much the
    /// input bound made it slip.
    pub slack: f64,
    /// The barrier row at this cycle's state and time.
    pub row: BarrierRow,
}

/// The ID-CBF-QP: the generic ECBF filter on the double-integrator spec.
#[derive(Debug)]
pub struct IdCbfQp {
    settings: CbfQpSettings,
    filter: spec::Filter,
    params: spec::Params,
}

impl IdCbfQp {
    /// The QP for `barrier`.
    ///
    /// # Errors
    /// Poles, bound, solver settings or barrier parameters outside their domains, or OSQP
    /// refusing the set-up.
    pub fn new(settings: CbfQpSettings, barrier: SineBarrier) -> Result<Self, CbfError> {
        if settings.u_max.is_nan() || settings.u_max <= 0.0 {
            return Err(CbfError::NotPositive { what: "input bound", value: settings.u_max });
        }
        let [amplitude, omega, offset] = barrier.parameters();
        let mut params = spec::Params::new(spec::Capacity::default())?;
        params.sine_barrier[0] = spec::SineBarrierParams { amplitude, omega, offset };
        params.sine_barrier[0].validate()?;
        let u_max = settings.u_max.min(domain::MAX_INPUT);
        let mut filter_settings = spec::default_settings();
        filter_settings.families[spec::family::SINE_BARRIER] = FamilyParams {
            poles: Poles::from(settings.poles),
            priority: 0,
            activation: f64::INFINITY,
            class_k: ClassK::LINEAR,
        };
        filter_settings.input_min = [-u_max];
        filter_settings.input_max = [u_max];
        filter_settings.solver = settings.solver;
        let filter = spec::Filter::new(spec::Barriers::new(spec::Capacity::default())?, filter_settings)?;
        Ok(Self { settings, filter, params })
    }

    /// The settings it was built with.
    pub fn settings(&self) -> &CbfQpSettings {
        &self.settings
    }

    /// The input closest to `desired_accel` that keeps the ECBF row at time `t` and state
    /// `x`. Allocation-free.
    ///
    /// # Errors
    /// `t`, `x` or `desired_accel` outside their domains (NaN/inf, `|t| > 10⁹` s, a state
    /// entry beyond 10⁵, an acceleration beyond [`domain::MAX_INPUT`]); nothing changes then.
    pub fn solve(&mut self, t: f64, x: &State, desired_accel: f64) -> Result<CbfQpOutput, CbfError> {
        let out = *self.filter.update_at(t, x, &[desired_accel], &self.params)?;
        let row = &self.filter.rows()[0];
        Ok(CbfQpOutput {
            u: out.u[0],
            source: out.source,
            status: out.status,
            iterations: out.iterations,
            slack: self.filter.delta()[0].max(0.0),
            row: BarrierRow { lie: [row.lie[0], row.lie[1], row.lie[2]], lg_lf: row.lg[0] },
        })
    }
}
