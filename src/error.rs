//! The crate's error type.

use std::fmt;

use crate::param_domain::kinds::{Domain, Found, FoundIn, Site};

/// Everything that can go wrong in cbfgen's public API.
#[derive(Debug, Clone, PartialEq)]
pub enum CbfError {
    /// A value that must be finite was NaN or infinite.
    NonFinite {
        /// Which value, as named in the message.
        what: &'static str,
        /// The value given (NaN or ±∞).
        value: f64,
    },
    /// A value that must be strictly positive was not.
    NotPositive {
        /// Which value, as named in the message.
        what: &'static str,
        /// The value given (≤ 0; 0 for a count or a zero-length normal).
        value: f64,
    },
    /// More obstacles or foothold edges than the catalog was sized for.
    CapacityExceeded {
        /// What ran out of slots (e.g. `"edge cuboids"`, `"foothold edges"`).
        what: &'static str,
        /// How many slots were reserved for it.
        capacity: usize,
    },
    /// A capacity (or another count) above its documented maximum, e.g.
    /// [`MAX_INSTANCES`](crate::system::MAX_INSTANCES).
    TooLarge {
        /// Which count, as named in the message.
        what: &'static str,
        /// The count given.
        value: usize,
        /// Its documented maximum.
        max: usize,
    },
    /// Threads a system crate runs beside the filter failed: one stopped (it panicked), or
    /// they could not be started. The crate that runs them names them and says why.
    Thread {
        /// Which threads, as their crate names them (e.g. `"perception worker"`).
        what: &'static str,
        /// What happened to them.
        reason: String,
    },
    /// Parameters (an environment) sized for other capacities than the filter's rows.
    CapacityMismatch,
    /// A system loaded from a plugin ([`crate::plugin`]) reported an error (its message,
    /// as the plugin's core wrote it), or the plugin could not be loaded.
    Plugin {
        /// What went wrong.
        message: String,
    },
    /// A setting outside its allowed range.
    OutOfRange {
        /// Which value, as named in the message.
        what: &'static str,
        /// The value given.
        value: f64,
        /// The allowed range, as text for the message (e.g. `"[1e-6, 1e4]"`).
        range: &'static str,
    },
    /// A slice of the wrong length for what it was passed to.
    LengthMismatch {
        /// Which slice, as named in the message.
        what: &'static str,
        /// The length required.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// A constraint row named an input column twice or beyond the input dimension.
    BadRowPattern {
        /// Index of the offending row among the rows given.
        row: usize,
        /// The input column it repeats, or names at or beyond the input dimension.
        column: usize,
    },
    /// An active constraint row evaluated to NaN or infinity (degenerate geometry or state).
    NonFiniteRow {
        /// Index of the first such row in the QP's row order (the catalog's, for the
        /// ECBF filter; 0 for the single-row QPs).
        row: usize,
    },
    /// OSQP refused the problem at set-up.
    SolverSetup {
        /// OSQP's set-up error, as text.
        reason: String,
    },
    /// A QP of the multi-layer controller ended without a usable iterate (infeasible,
    /// non-convex or a solver fault); `status` is [`QpStatus::name`](crate::qp::QpStatus::name).
    QpFailed {
        /// Which QP failed (e.g. `"kinematic MPC"`).
        layer: &'static str,
        /// How it ended: a [`QpStatus::name`](crate::qp::QpStatus::name).
        status: &'static str,
    },
    /// An index beyond what exists (a family, member, instance, leg…).
    NoSuchIndex {
        /// What was indexed (`"family"`, `"member"`, `"instance"`, `"leg"`).
        what: &'static str,
        /// The index given.
        index: usize,
        /// How many there are.
        len: usize,
    },
    /// A name (of a family, member or system) that does not exist.
    UnknownName {
        /// What was looked up.
        what: &'static str,
        /// The name given.
        name: String,
        /// The names that exist, comma-separated.
        known: String,
    },
    /// An operation a family's kind of instances does not have (pushing onto a fixed
    /// family, a capacity for a fixed-count family...).
    Unsupported {
        /// What was asked.
        operation: &'static str,
        /// The family's kind (`"fixed"`, `"optional"`, `"capacity"`, `"parameter-free"`).
        kind: &'static str,
    },
    /// Data that does not read as what it claims to be (a campaign's CSV of another
    /// version, a line cut short), or calls made out of their order, with where and why.
    Malformed {
        /// What was read.
        what: &'static str,
        /// Where it went wrong and why.
        why: String,
    },
    /// Parameters of one system handed to another system's rows or filter.
    SystemMismatch {
        /// The system that was asked.
        expected: &'static str,
        /// The system the parameters belong to.
        got: &'static str,
    },
    /// A rotation matrix was not orthonormal with determinant +1.
    NotARotation {
        /// Largest entry of `|RᵀR − I|`.
        deviation: f64,
        /// `det R` (negative for a reflection).
        determinant: f64,
    },
    /// A cost matrix (a spec's objective `P(x)`) that is not symmetric positive definite
    /// with every Cholesky pivot at least `required` of its largest diagonal entry.
    NotPositiveDefinite {
        /// Which matrix, as named in the message.
        what: &'static str,
        /// The first index where the Cholesky factorisation failed (or the asymmetric
        /// entry's row).
        index: usize,
        /// That pivot relative to the largest diagonal entry (`NaN` for a matrix that is
        /// not finite or not symmetric).
        value: f64,
        /// The least relative pivot the check accepts (the factorisation's own threshold,
        /// carried here so the message states it).
        required: f64,
    },
    /// A run-time parameter outside the domain its spec declares (or a primitive it is used
    /// in requires): a negative half extent, a reflection given as a rotation, a NaN. See
    /// [`param_domain`](crate::param_domain). Holds no heap data, so the control path can
    /// return it without allocating.
    ParamOutOfDomain {
        /// The family, as in the spec.
        family: &'static str,
        /// The member of an indexed family, where known.
        member: Option<&'static str>,
        /// The instance (its slot among the family's instances), where known.
        instance: Option<usize>,
        /// The parameter, as in the spec.
        param: &'static str,
        /// What its domain asks ([`Domain::Real`] for a
        /// value that is not finite or beyond [`PARAM_LIMIT`](crate::system::PARAM_LIMIT)).
        domain: Domain,
        /// What was found.
        found: Found,
    },
}

// The messages, written out rather than derived: the core's dependency list stays at
// nalgebra, libc and osqp (no proc-macro crates for a user's build to compile).
impl fmt::Display for CbfError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CbfError::NonFinite { what, value } => write!(f, "{what} must be finite, got {value}"),
            CbfError::NotPositive { what, value } => write!(f, "{what} must be > 0, got {value}"),
            CbfError::CapacityExceeded { what, capacity } => write!(f, "too many {what}: capacity is {capacity}"),
            CbfError::TooLarge { what, value, max } => write!(f, "{what} = {value} is above the maximum of {max}"),
            CbfError::Thread { what, reason } => write!(f, "{what} threads: {reason}"),
            CbfError::CapacityMismatch => f.write_str("the parameters were built for other capacities than the filter"),
            CbfError::Plugin { message } => f.write_str(message),
            CbfError::OutOfRange { what, value, range } => write!(f, "{what} = {value} is outside {range}"),
            CbfError::LengthMismatch { what, expected, got } => {
                write!(f, "{what}: expected length {expected}, got {got}")
            }
            CbfError::BadRowPattern { row, column } => {
                write!(f, "constraint row {row}: input column {column} is repeated or out of range")
            }
            CbfError::NonFiniteRow { row } => write!(f, "constraint row {row} is not finite"),
            CbfError::SolverSetup { reason } => write!(f, "QP solver set-up failed: {reason}"),
            CbfError::QpFailed { layer, status } => write!(f, "{layer}: QP not solved ({status})"),
            CbfError::NoSuchIndex { what, index, len } => write!(f, "no {what} {index}: there are {len}"),
            CbfError::UnknownName { what, name, known } => write!(f, "no {what} named {name:?}; known: {known}"),
            CbfError::Unsupported { operation, kind } => write!(f, "{operation} is not available for {kind} families"),
            CbfError::Malformed { what, why } => write!(f, "{what}: {why}"),
            CbfError::SystemMismatch { expected, got } => {
                write!(f, "parameters of system {got} given to system {expected}")
            }
            CbfError::NotARotation { deviation, determinant } => {
                write!(f, "rotation is not a proper rotation (|R^T R - I| = {deviation:.3e}, det R = {determinant:.6})")
            }
            CbfError::NotPositiveDefinite { what, index, value, .. } if value.is_nan() => {
                write!(f, "{what} is not a finite symmetric matrix (row {index})")
            }
            CbfError::NotPositiveDefinite { what, index, value, required } => write!(
                f,
                "{what} is not positive definite (Cholesky pivot {index} is {value:.3e} of the largest diagonal entry; at least \
                 {required:e} is required)"
            ),
            CbfError::ParamOutOfDomain { family, member, instance, param, found: Found::NotSet, .. } => write!(
                f,
                "{}: parameter {param} was never set (a fixed instance's parameters are refused until they are \
                 set, unless the spec gives the family defaults=)",
                Site(family, member, instance),
            ),
            CbfError::ParamOutOfDomain { family, member, instance, param, domain, found } => write!(
                f,
                "{}: parameter {param} is outside its domain ({domain}): {}",
                Site(family, member, instance),
                FoundIn(found, param)
            ),
        }
    }
}

impl std::error::Error for CbfError {}

impl CbfError {
    /// For [`CbfError::ParamOutOfDomain`] without an instance, the same error naming
    /// instance `instance`; any other error unchanged.
    #[must_use]
    pub fn in_instance(self, instance: usize) -> Self {
        match self {
            CbfError::ParamOutOfDomain { family, member, instance: None, param, domain, found } => {
                CbfError::ParamOutOfDomain { family, member, instance: Some(instance), param, domain, found }
            }
            other => other,
        }
    }

    /// For [`CbfError::ParamOutOfDomain`] without a member, the same error naming member
    /// `member` (`None`: a family that is not indexed); any other error unchanged.
    #[must_use]
    pub fn in_member(self, member: Option<&'static str>) -> Self {
        match self {
            CbfError::ParamOutOfDomain { family, member: None, instance, param, domain, found } => {
                CbfError::ParamOutOfDomain { family, member, instance, param, domain, found }
            }
            other => other,
        }
    }
}

/// `Ok(value)` if finite, else [`CbfError::NonFinite`].
pub fn finite(what: &'static str, value: f64) -> Result<f64, CbfError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(CbfError::NonFinite { what, value })
    }
}

/// `Ok(value)` if finite and within `[lo, hi]`, else [`CbfError::NonFinite`] or
/// [`CbfError::OutOfRange`] naming `range` (the documented domain, for the message).
pub fn within(what: &'static str, value: f64, lo: f64, hi: f64, range: &'static str) -> Result<f64, CbfError> {
    if (lo..=hi).contains(&finite(what, value)?) {
        Ok(value)
    } else {
        Err(CbfError::OutOfRange { what, value, range })
    }
}

/// `Ok(value)` if finite and > 0.
pub fn positive(what: &'static str, value: f64) -> Result<f64, CbfError> {
    if finite(what, value)? > 0.0 {
        Ok(value)
    } else {
        Err(CbfError::NotPositive { what, value })
    }
}
