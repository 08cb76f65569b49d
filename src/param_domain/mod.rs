//! The domains of run-time parameters: what a spec declares a parameter may be (a length
//! `> 0`, a proper rotation, …) and the check every generated parameter struct's
//! `validate()` runs before a kernel reads it.
//!
//! A spec gives each parameter a domain (`symbolic/spec.py`: `Real`, `Positive`,
//! `NonNegative`, `Interval(lo, hi)`, `UnitVector(tol)`, `Rotation(tol)`), or a primitive
//! it is used in gives one (a box's half extents `> 0`). Every domain also asks each entry
//! to be finite with `|entry| ≤` [`PARAM_LIMIT`], which is all [`Domain::Real`] asks. A
//! violation is [`CbfError::ParamOutOfDomain`]: it names the family, the parameter, what
//! the domain asks and what was found, and — filled in by whoever knows them — the member
//! and instance. It holds no heap data, so the check runs on the control path (a barrier
//! set re-validates its parameters every evaluation) without allocating.
//!
//! ```
//! use cbfgen::param_domain::{check, Domain, Found};
//! use cbfgen::CbfError;
//!
//! let reflection = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0]; // column by column
//! let err = check("wall", "rotation", Domain::Rotation { tolerance: 1e-9 }, &[3, 3], &reflection).unwrap_err();
//! assert!(matches!(err, CbfError::ParamOutOfDomain { found: Found::Determinant(d), .. } if d == -1.0));
//! assert_eq!(
//!     err.to_string(),
//!     "wall: parameter rotation is outside its domain (a proper rotation: max |RᵀR − I| ≤ 1e-9, det > 0): \
//!      det rotation = -1"
//! );
//! # Ok::<(), CbfError>(())
//! ```

pub(crate) mod kinds;

pub use kinds::{Domain, Found};

use crate::error::CbfError;
use crate::limits::PARAM_LIMIT;

/// What a fixed instance's parameter holds until it is set (where the spec gives it no
/// default): a NaN with its own payload, so [`check`] refuses it as
/// [`Found::NotSet`] rather than filtering against a zero-size box or a zero limit. Any
/// other NaN is reported as the non-finite value it is.
///
/// ```
/// use cbfgen::param_domain::{check, is_unset, Domain, Found, UNSET};
/// use cbfgen::CbfError;
///
/// assert!(is_unset(UNSET) && !is_unset(f64::NAN));
/// let err = check("speed_limit", "vmax", Domain::Positive, &[], &[UNSET]).unwrap_err();
/// assert!(matches!(err, CbfError::ParamOutOfDomain { found: Found::NotSet, .. }));
/// assert!(err.to_string().starts_with("speed_limit: parameter vmax was never set"));
/// ```
pub const UNSET: f64 = f64::from_bits(0x7ff8_0000_0000_0cbf);

/// Whether `value` is [`UNSET`] (bit for bit: not any NaN).
#[inline]
pub fn is_unset(value: f64) -> bool {
    value.to_bits() == UNSET.to_bits()
}

/// `Ok(())` when parameter `param` of family `family`, of shape `shape` (`[]`, `[n]` or
/// `[rows, cols]`) with `values` in nalgebra's storage order (matrices column by column),
/// lies in `domain`. What every generated `validate()` calls, once per parameter.
///
/// # Errors
/// [`CbfError::ParamOutOfDomain`] for the first violation (non-finite or beyond
/// [`PARAM_LIMIT`] first, reported against [`Domain::Real`]), with `member` and
/// `instance` left `None` for the caller to fill in ([`CbfError::in_instance`],
/// [`CbfError::in_member`]). A [`Domain::Rotation`] on anything but a 2 × 2 or 3 × 3
/// matrix (which the generator refuses) fails as not orthonormal.
#[inline]
pub fn check(
    family: &'static str,
    param: &'static str,
    domain: Domain,
    shape: &[usize],
    values: &[f64],
) -> Result<(), CbfError> {
    // Every evaluation of a barrier set runs this for every parameter: the test alone
    // (inlined, so a constant domain folds away), the message only on failure.
    if in_domain(domain, shape, values) {
        Ok(())
    } else {
        Err(violation(family, param, domain, shape, values))
    }
}

/// Within ±[`PARAM_LIMIT`]; false for NaN and ±∞.
#[inline]
fn within_limit(v: f64) -> bool {
    v.abs() <= PARAM_LIMIT
}

/// What a per-entry domain asks of one (finite, within-limit) entry; true for the others.
#[inline]
fn entry_inside(domain: Domain, v: f64) -> bool {
    match domain {
        Domain::Positive => v > 0.0,
        Domain::NonNegative => v >= 0.0,
        Domain::Interval { lo, hi } => lo <= v && v <= hi,
        Domain::Real | Domain::UnitVector { .. } | Domain::Rotation { .. } => true,
    }
}

/// `| |v| − 1 | ≤ tolerance` on the squared norm (no square root on the hot path).
#[inline]
fn unit_length(squared_norm: f64, tolerance: f64) -> bool {
    let (lo, hi) = (1.0 - tolerance, 1.0 + tolerance);
    lo * lo <= squared_norm && squared_norm <= hi * hi
}

#[inline]
fn squared_norm(values: &[f64]) -> f64 {
    // Entries are within ±PARAM_LIMIT, so the squares cannot overflow.
    values.iter().map(|v| v * v).sum()
}

#[inline]
fn in_domain(domain: Domain, shape: &[usize], values: &[f64]) -> bool {
    values.iter().all(|&v| within_limit(v) && entry_inside(domain, v))
        && match domain {
            Domain::UnitVector { tolerance } => unit_length(squared_norm(values), tolerance),
            Domain::Rotation { tolerance } => {
                let (deviation, det) = orthonormality_and_determinant(shape, values);
                deviation <= tolerance && det > 0.0
            }
            Domain::Real | Domain::Positive | Domain::NonNegative | Domain::Interval { .. } => true,
        }
}

/// The first violation [`in_domain`] found, as the error that reports it.
#[cold]
#[inline(never)]
fn violation(family: &'static str, param: &'static str, domain: Domain, shape: &[usize], values: &[f64]) -> CbfError {
    let error =
        |domain, found| CbfError::ParamOutOfDomain { family, member: None, instance: None, param, domain, found };
    if values.iter().any(|&v| is_unset(v)) {
        return error(domain, Found::NotSet);
    }
    let rows = shape.first().copied().unwrap_or(1).max(1);
    let at = |i: usize, value: f64| match shape.len() {
        0 => Found::Value(value),
        1 => Found::Entry { index: i, value },
        _ => Found::MatrixEntry { row: i % rows, col: i / rows, value },
    };
    for (i, &v) in values.iter().enumerate() {
        if !within_limit(v) {
            return error(Domain::Real, at(i, v));
        }
        if !entry_inside(domain, v) {
            return error(domain, at(i, v));
        }
    }
    match domain {
        Domain::UnitVector { .. } => error(domain, Found::Norm(squared_norm(values).sqrt())),
        Domain::Rotation { tolerance } => match orthonormality_and_determinant(shape, values) {
            (deviation, _) if deviation.is_nan() || deviation > tolerance => {
                error(domain, Found::Orthonormality(deviation))
            }
            (_, det) => error(domain, Found::Determinant(det)),
        },
        // Not reached (every entry passed the test in_domain failed on, and these domains ask
        // nothing more); an error all the same, since this path must not panic.
        Domain::Real | Domain::Positive | Domain::NonNegative | Domain::Interval { .. } => {
            error(domain, Found::Value(f64::NAN))
        }
    }
}

/// Largest entry of `|RᵀR − I|` and `det R` of a 2 × 2 or 3 × 3 matrix stored column by
/// column; `(∞, NaN)` for any other shape.
#[inline]
fn orthonormality_and_determinant(shape: &[usize], m: &[f64]) -> (f64, f64) {
    let n = match *shape {
        [2, 2] if m.len() == 4 => 2,
        [3, 3] if m.len() == 9 => 3,
        _ => return (f64::INFINITY, f64::NAN),
    };
    let column = |j: usize| &m[j * n..(j + 1) * n];
    let mut deviation = 0.0_f64;
    for i in 0..n {
        for j in i..n {
            let dot: f64 = column(i).iter().zip(column(j)).map(|(a, b)| a * b).sum();
            let target = if i == j { 1.0 } else { 0.0 };
            // NaN-propagating max: a NaN entry must not read as orthonormal.
            let d = (dot - target).abs();
            if d.is_nan() || d > deviation {
                deviation = d;
            }
        }
    }
    // The determinant is the same column- or row-major (det Rᵀ = det R).
    let det = if n == 2 {
        m[0] * m[3] - m[1] * m[2]
    } else {
        m[0] * (m[4] * m[8] - m[5] * m[7]) - m[3] * (m[1] * m[8] - m[2] * m[7]) + m[6] * (m[1] * m[5] - m[2] * m[4])
    };
    (deviation, det)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn found(domain: Domain, shape: &[usize], values: &[f64]) -> Option<(Domain, Found)> {
        match check("f", "p", domain, shape, values) {
            Ok(()) => None,
            Err(CbfError::ParamOutOfDomain { domain, found, .. }) => Some((domain, found)),
            Err(e) => panic!("unexpected error {e}"),
        }
    }

    #[test]
    fn determinants_equal_the_cofactor_expansion_written_out() {
        // A 3 × 3 matrix with distinct entries, column by column: [[1, 4, 7], [2, 5, 8], [3, 6, 10]]
        // by rows, det = 1(50 − 48) − 4(20 − 24) + 7(12 − 15) = 2 + 16 − 21 = −3.
        let (_, det) = orthonormality_and_determinant(&[3, 3], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 10.0]);
        assert_eq!(det, -3.0);
        let (_, det) = orthonormality_and_determinant(&[2, 2], &[1.0, 2.0, 3.0, 4.0]); // [[1, 3], [2, 4]]
        assert_eq!(det, -2.0);
    }

    #[test]
    fn entries_are_reported_by_row_and_column() {
        // Column-major [a00, a10, a01, a11]: the −1 sits at row 1, column 0.
        let got = found(Domain::Positive, &[2, 2], &[1.0, -1.0, 1.0, 1.0]);
        assert_eq!(got, Some((Domain::Positive, Found::MatrixEntry { row: 1, col: 0, value: -1.0 })));
        assert_eq!(found(Domain::Positive, &[], &[0.0]), Some((Domain::Positive, Found::Value(0.0))));
        let nan = found(Domain::Positive, &[3], &[1.0, f64::NAN, -1.0]);
        assert!(matches!(nan, Some((Domain::Real, Found::Entry { index: 1, value })) if value.is_nan()));
        assert_eq!(found(Domain::Interval { lo: 1.0, hi: 2.0 }, &[], &[2.0]), None);
    }

    #[test]
    fn unit_vectors_are_measured_by_their_length() {
        let unit = Domain::UnitVector { tolerance: 1e-9 };
        assert_eq!(found(unit, &[2], &[0.6, 0.8]), None);
        assert_eq!(found(unit, &[2], &[1.0 + 0.5e-9, 0.0]), None);
        assert_eq!(found(unit, &[2], &[0.0, 1.0 - 0.5e-9]), None);
        let long = found(unit, &[2], &[1.0 + 2e-9, 0.0]);
        assert!(matches!(long, Some((_, Found::Norm(n))) if (n - (1.0 + 2e-9)).abs() < 1e-15), "{long:?}");
        let short = found(unit, &[2], &[0.0, 1.0 - 2e-9]);
        assert!(matches!(short, Some((_, Found::Norm(n))) if (n - (1.0 - 2e-9)).abs() < 1e-15), "{short:?}");
        assert_eq!(found(unit, &[2], &[0.0, 0.0]), Some((unit, Found::Norm(0.0))));
    }

    #[test]
    fn a_rotation_of_another_shape_is_refused() {
        let got = found(Domain::Rotation { tolerance: 1e-9 }, &[3], &[1.0, 0.0, 0.0]);
        assert_eq!(got, Some((Domain::Rotation { tolerance: 1e-9 }, Found::Orthonormality(f64::INFINITY))));
    }
}
