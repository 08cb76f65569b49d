//! The moving lower bound of the example and its generated ECBF row.
//!
//! ```text
//! s(t) = A sin(ω t) + c,      h(x, t) = q − s(t),      x = [q, q̇]
//! L_f h = q̇ − A ω cos(ω t),   L_f² h = A ω² sin(ω t),  L_g L_f h = 1
//! ```
//!
//! The values come from the generated kernel (`systems/double_integrator/generated/double_integrator.rs`), whose
//! Lie derivatives include ∂h/∂t: the boundary's own velocity and acceleration.

use cbfgen::error::{finite, CbfError};
use cbfgen_double_integrator as gen;

/// The double integrator's state `[q, q̇]`.
pub type State = [f64; 2];

/// `h` and its Lie derivatives at one state and time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarrierRow {
    /// `[h, L_f h, L_f² h]`, each including its ∂/∂t terms.
    pub lie: [f64; 3],
    /// `L_g L_f h`: the coefficient of `u` in `ḧ`.
    pub lg_lf: f64,
}

/// The safe set `q ≥ A sin(ω t) + c`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SineBarrier {
    amplitude: f64,
    omega: f64,
    offset: f64,
}

impl SineBarrier {
    /// # Errors
    /// A non-finite parameter.
    pub fn new(amplitude: f64, omega: f64, offset: f64) -> Result<Self, CbfError> {
        Ok(Self {
            amplitude: finite("barrier amplitude", amplitude)?,
            omega: finite("barrier frequency", omega)?,
            offset: finite("barrier offset", offset)?,
        })
    }

    /// `[A, ω, c]`.
    pub fn parameters(&self) -> [f64; 3] {
        [self.amplitude, self.omega, self.offset]
    }

    /// The boundary position `s(t)`.
    pub fn boundary(&self, t: f64) -> f64 {
        self.amplitude * (self.omega * t).sin() + self.offset
    }

    /// The generated row at `x` and `t` (no validation: callers check finiteness).
    pub fn row(&self, x: &State, t: f64) -> BarrierRow {
        let ([lie], [[lg_lf]]) = gen::sine_barrier(x, t, self.amplitude, self.omega, self.offset);
        BarrierRow { lie, lg_lf }
    }
}

/// `Ok` if `t` is within the core's time domain ([`system::TIME_LIMIT`](cbfgen::system::TIME_LIMIT))
/// and both state entries within its state domain
/// ([`STATE_LIMIT`](cbfgen::system::STATE_LIMIT)): no QP sees a number whose square
/// overflows.
pub(crate) fn check_state(x: &State, t: f64) -> Result<(), CbfError> {
    cbfgen::system::validate_time(t)?;
    cbfgen::system::coordinate("position", x[0])?;
    cbfgen::system::coordinate("velocity", x[1])?;
    Ok(())
}
