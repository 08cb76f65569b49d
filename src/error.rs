//! The crate's error type.

use thiserror::Error;

/// Everything that can go wrong in cbfgen's public API.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CbfError {
    /// A value that must be finite was NaN or infinite.
    #[error("{what} must be finite, got {value}")]
    NonFinite { what: &'static str, value: f64 },
    /// A value that must be strictly positive was not.
    #[error("{what} must be > 0, got {value}")]
    NotPositive { what: &'static str, value: f64 },
    /// More obstacles or foothold edges than the catalog was sized for.
    #[error("too many {what}: capacity is {capacity}")]
    CapacityExceeded { what: &'static str, capacity: usize },
    /// A capacity (or another count) above its documented maximum, e.g.
    /// [`Capacity::MAX_EDGES`](crate::catalog::Capacity::MAX_EDGES).
    #[error("{what} = {value} is above the maximum of {max}")]
    TooLarge { what: &'static str, value: usize, max: usize },
    /// An environment sized for another catalog capacity.
    #[error("environment and catalog were built for different capacities")]
    CapacityMismatch,
    /// A leg index outside 0..6.
    #[error("no leg {leg}: legs are 0..6 in LEG_NAMES order")]
    NoSuchLeg { leg: usize },
    /// A setting outside its allowed range.
    #[error("{what} = {value} is outside {range}")]
    OutOfRange { what: &'static str, value: f64, range: &'static str },
    /// A slice of the wrong length for what it was passed to.
    #[error("{what}: expected length {expected}, got {got}")]
    LengthMismatch { what: &'static str, expected: usize, got: usize },
    /// A constraint row named an input column twice or beyond the input dimension.
    #[error("constraint row {row}: input column {column} is repeated or out of range")]
    BadRowPattern { row: usize, column: usize },
    /// An active constraint row evaluated to NaN or infinity (degenerate geometry or state).
    #[error("constraint row {row} is not finite")]
    NonFiniteRow { row: usize },
    /// OSQP refused the problem at set-up.
    #[error("QP solver set-up failed: {reason}")]
    SolverSetup { reason: String },
    /// A QP of the multi-layer controller ended without a usable iterate (infeasible,
    /// non-convex or a solver fault); `status` is [`QpStatus::name`](crate::filter::QpStatus::name).
    #[error("{layer}: QP not solved ({status})")]
    QpFailed { layer: &'static str, status: &'static str },
    /// A rotation matrix was not orthonormal with determinant +1.
    #[error("rotation is not a proper rotation (|R^T R - I| = {deviation:.3e}, det R = {determinant:.6})")]
    NotARotation { deviation: f64, determinant: f64 },
}

/// `Ok(value)` if finite, else [`CbfError::NonFinite`].
pub(crate) fn finite(what: &'static str, value: f64) -> Result<f64, CbfError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(CbfError::NonFinite { what, value })
    }
}

/// `Ok(value)` if finite and within `[lo, hi]`, else [`CbfError::NonFinite`] or
/// [`CbfError::OutOfRange`] naming `range` (the documented domain, for the message).
pub(crate) fn within(what: &'static str, value: f64, lo: f64, hi: f64, range: &'static str) -> Result<f64, CbfError> {
    if (lo..=hi).contains(&finite(what, value)?) {
        Ok(value)
    } else {
        Err(CbfError::OutOfRange { what, value, range })
    }
}

/// `Ok(value)` if finite and > 0.
pub(crate) fn positive(what: &'static str, value: f64) -> Result<f64, CbfError> {
    if finite(what, value)? > 0.0 {
        Ok(value)
    } else {
        Err(CbfError::NotPositive { what, value })
    }
}
