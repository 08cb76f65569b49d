//! What the ECBF filter can be tuned with: poles, priority and activation per family,
//! input weights and limits, and the OSQP settings. Defaults come from the system's spec.

use super::between_samples::SampledData;
use crate::error::CbfError;
use crate::qp::SolverSettings;
use crate::system::{FamilyInfo, FamilyKind, FamilyParams};

/// Everything the [`EcbfFilter`](super::EcbfFilter) is built with.
///
/// The filter meets every row exactly when the input box allows it; where it does not,
/// each family's priority decides who yields ([`FamilyParams::priority`]: tier 0 first, a
/// lexicographic order, not a trade-off), and among the inputs that meet the rows as well
/// as possible it picks the one closest to the nominal input in `Σ_j w_j (u_j −
/// u_ref,j)²`.
///
/// Start from a system's defaults ([`FilterSettings::defaults`], which generated code
/// wraps as `default_settings()`) and tune from there.
#[derive(Debug, Clone, PartialEq)]
pub struct FilterSettings<const NU: usize> {
    /// Per family, indexed like the barrier set's
    /// [`families`](crate::system::BarrierSet::families).
    pub families: Vec<FamilyParams>,
    /// `w_j` per input, within `[1e-3, 1e3]`.
    pub input_weights: [f64; NU],
    /// Lower box limits `input_min ≤ u`, in each input's units.
    pub input_min: [f64; NU],
    /// Upper box limits `u ≤ input_max`, in each input's units.
    pub input_max: [f64; NU],
    /// OSQP's settings for the QP.
    pub solver: SolverSettings,
    /// Read the thread's CPU clock around each update ([`Output::cpu_time`]). Off by
    /// default: on Linux one reading is a system call (0.2–0.5 µs, two per update), more
    /// than a small system's whole update; simulations and latency harnesses turn it on.
    ///
    /// [`Output::cpu_time`]: super::Output::cpu_time
    pub measure_cpu_time: bool,
    /// Skip evaluating the rows whose family's lower bound on `h` already puts them above
    /// the activation threshold ([`BarrierSet::cull_above`]): on by default. The input is
    /// the same bit for bit either way; off, every row is evaluated every cycle (to read
    /// every far row's exact `h`).
    ///
    /// [`BarrierSet::cull_above`]: crate::system::BarrierSet::cull_above
    pub cull_far_rows: bool,
    /// Certify each answer between the samples ([`SampledData`]): rows enclosed over the
    /// period the input is held, and margins raised where the enclosure reaches below 0.
    /// `None` (the default): the rows are met at the samples only
    /// ([`crate::filter::between_samples`]).
    pub sampled_data: Option<SampledData>,
}

impl<const NU: usize> FilterSettings<NU> {
    /// The families' own defaults (from their spec), unit input weights, these input
    /// limits, [`SolverSettings::default`], no CPU clock, far rows culled.
    pub fn defaults(families: &[FamilyInfo], input_min: [f64; NU], input_max: [f64; NU]) -> Self {
        Self {
            families: families.iter().map(|f| f.defaults).collect(),
            input_weights: [1.0; NU],
            input_min,
            input_max,
            solver: SolverSettings::default(),
            measure_cpu_time: false,
            cull_far_rows: true,
            sampled_data: None,
        }
    }

    /// The parameters of family `index`.
    ///
    /// # Panics
    /// `index` beyond the families (a programming error: indices come from a row layout).
    pub fn family(&self, index: usize) -> &FamilyParams {
        &self.families[index]
    }

    /// The parameters of family `index`, to tune one family in place.
    ///
    /// # Panics
    /// `index` beyond the families.
    pub fn family_mut(&mut self, index: usize) -> &mut FamilyParams {
        &mut self.families[index]
    }

    /// Check the settings against `families` (the barrier set they are for).
    ///
    /// # Errors
    /// Another number of families than `families`, a family with another number of
    /// poles than its relative degree, a pole, weight, input limit or solver setting
    /// outside its documented range ([`domain`], [`SolverSettings::validate`]), a NaN
    /// activation, `input_min > input_max`, or sampled-data settings outside their
    /// domain ([`SampledData::validate`]).
    pub fn validate(&self, families: &[FamilyInfo]) -> Result<(), CbfError> {
        if self.families.len() != families.len() {
            return Err(CbfError::LengthMismatch {
                what: "family settings",
                expected: families.len(),
                got: self.families.len(),
            });
        }
        for (p, info) in self.families.iter().zip(families) {
            if p.poles.len() != info.relative_degree {
                return Err(CbfError::LengthMismatch {
                    what: "ECBF poles (one per relative degree)",
                    expected: info.relative_degree,
                    got: p.poles.len(),
                });
            }
            for &pole in p.poles.as_slice() {
                domain::pole(pole)?;
            }
            domain::priority(p.priority)?;
            if info.kind == FamilyKind::Lyapunov && p.priority == 0 {
                // Convergence never shares the tier that must hold.
                return Err(CbfError::OutOfRange {
                    what: "priority of a Lyapunov family (below the safety rows)",
                    value: 0.0,
                    range: "[1, 15]",
                });
            }
            if p.activation.is_nan() {
                return Err(CbfError::NonFinite { what: "activation threshold", value: p.activation });
            }
        }
        validate_inputs(&self.input_weights, &self.input_min, &self.input_max)?;
        if let Some(sampled) = &self.sampled_data {
            sampled.validate(families.len())?;
        }
        self.solver.validate()
    }
}

/// The documented domain of the filter's numbers. Inside it every product the QP forms
/// stays far from overflow (input and weight bounds multiply to ≤ 1e15, pole products to
/// ≤ 1e8), so a finite problem gives a finite answer; outside it, settings and inputs are
/// typed errors rather than NaN.
pub mod domain {
    /// Largest |input limit| and the largest |nominal input| accepted, in the input's
    /// units (m/s², rad/s²): 10⁶ is far past any actuator, and keeps `w·u²` finite.
    pub const MAX_INPUT: f64 = 1e6;
    /// Input weights `w_j` lie in `[1/W, W]` with `W` = this. The weights' spread is the
    /// QP's condition number (with the slack weights'), and every digit of it is a digit
    /// the exact solve and its KKT check lose: at most 10⁶ between inputs.
    pub const MAX_WEIGHT_RATIO: f64 = 1e3;
    /// Priority tiers run from 0 (met first) to this.
    pub const MAX_PRIORITY: u8 = (crate::qp::lexicographic::TIERS - 1) as u8;
    /// ECBF poles lie in `[1e-6, 1e4]` 1/s; faster than 10 kHz is meaningless for a 1 kHz
    /// loop, and the gains `p1 p2` stay ≤ 1e8.
    pub const POLE_RANGE: [f64; 2] = [1e-6, 1e4];
    /// Largest ECBF gain accepted by [`EcbfQp::new`](crate::filter::EcbfQp::new): the
    /// coefficients of `∏ (s + p_i)` (for two poles `k0 = p1 p2`, `k1 = p1 + p2`). Fast poles
    /// on a high relative degree reach it first (four poles of 100/s give `k0 = 10⁸`).
    pub const MAX_GAIN: f64 = 1e8;

    use crate::error::{within, CbfError};

    // One check per kind of number, so each range and its message live in one place.

    /// An input value (limit, nominal input, commanded acceleration) within ±[`MAX_INPUT`].
    pub(crate) fn input(what: &'static str, value: f64) -> Result<f64, CbfError> {
        within(what, value, -MAX_INPUT, MAX_INPUT, "[-1e6, 1e6]")
    }

    /// An ECBF pole within [`POLE_RANGE`].
    pub(crate) fn pole(value: f64) -> Result<f64, CbfError> {
        within("ECBF pole", value, POLE_RANGE[0], POLE_RANGE[1], "[1e-6, 1e4]")
    }

    /// A priority tier within `0..=`[`MAX_PRIORITY`].
    pub(crate) fn priority(value: u8) -> Result<u8, CbfError> {
        if value > MAX_PRIORITY {
            return Err(CbfError::TooLarge {
                what: "priority tier",
                value: usize::from(value),
                max: usize::from(MAX_PRIORITY),
            });
        }
        Ok(value)
    }

    /// An input weight within `[1/MAX_WEIGHT_RATIO, MAX_WEIGHT_RATIO]`.
    pub(crate) fn input_weight(value: f64) -> Result<f64, CbfError> {
        within("input weight", value, 1.0 / MAX_WEIGHT_RATIO, MAX_WEIGHT_RATIO, "[1e-3, 1e3]")
    }

    /// An ECBF gain within `[0, MAX_GAIN]`.
    pub(crate) fn gain(value: f64) -> Result<f64, CbfError> {
        within("ECBF gain", value, 0.0, MAX_GAIN, "[0, 1e8]")
    }
}

/// `Ok(u)` when every entry is finite with `|u_j| ≤` [`domain::MAX_INPUT`]: the nominal
/// input's domain, shared by the filter and [`EcbfQp::solve`](crate::filter::EcbfQp::solve).
pub(crate) fn validate_nominal<const NU: usize>(u_ref: &[f64; NU]) -> Result<(), CbfError> {
    for &v in u_ref {
        domain::input("nominal input", v)?;
    }
    Ok(())
}

/// Input weights in `[1e-3, 1e3]` ([`domain::MAX_WEIGHT_RATIO`]), box limits finite with
/// `|limit| ≤` [`domain::MAX_INPUT`] and `min ≤ max`: shared by
/// [`FilterSettings::validate`] and [`EcbfQp::new`](super::EcbfQp::new).
pub(crate) fn validate_inputs<const NU: usize>(
    weights: &[f64; NU],
    min: &[f64; NU],
    max: &[f64; NU],
) -> Result<(), CbfError> {
    for j in 0..NU {
        domain::input_weight(weights[j])?;
        domain::input("input limit", min[j])?;
        domain::input("input limit", max[j])?;
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
