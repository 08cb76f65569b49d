//! What a parameter's domain is and what was found outside it: plain data with its
//! messages, below the error type that carries them (so it imports nothing of it).

use std::fmt;

use crate::limits::PARAM_LIMIT;

/// The set of values a run-time parameter may take (`symbolic/spec.py` declares it per
/// parameter). Every domain lies within [`Domain::Real`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Domain {
    /// Every entry finite with `|entry| ≤` [`PARAM_LIMIT`] (the default).
    Real,
    /// Every entry `> 0`: a length, a radius, a half extent.
    Positive,
    /// Every entry `≥ 0`: an inflation, a margin.
    NonNegative,
    /// Every entry in `[lo, hi]`.
    Interval {
        /// The least value accepted.
        lo: f64,
        /// The largest value accepted.
        hi: f64,
    },
    /// A vector of length 1 within `tolerance`: `| |v| − 1 | ≤ tolerance`.
    UnitVector {
        /// How far from 1 the length may be.
        tolerance: f64,
    },
    /// A proper rotation matrix (2 × 2 or 3 × 3): every entry of `RᵀR − I` within
    /// `tolerance`, and `det R > 0` (no reflection).
    Rotation {
        /// How far from orthonormal (largest entry of `|RᵀR − I|`) the matrix may be.
        tolerance: f64,
    },
}

/// A number in a message: plain where that is short, in exponent form where it is not
/// (`1e-9`, not `0.000000001`).
struct Number(f64);

impl fmt::Display for Number {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v != 0.0 && v.is_finite() && !(1e-3..1e6).contains(&v.abs()) {
            write!(f, "{v:e}")
        } else {
            write!(f, "{v}")
        }
    }
}

impl fmt::Display for Domain {
    /// What the domain asks, as a message states it (`"> 0"`, `"in [1e-6, 10000]"`).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Domain::Real => write!(f, "finite, within ±{}", Number(PARAM_LIMIT)),
            Domain::Positive => write!(f, "> 0"),
            Domain::NonNegative => write!(f, "≥ 0"),
            Domain::Interval { lo, hi } => write!(f, "in [{}, {}]", Number(lo), Number(hi)),
            Domain::UnitVector { tolerance } => write!(f, "a unit vector: | |v| − 1 | ≤ {}", Number(tolerance)),
            Domain::Rotation { tolerance } => {
                write!(f, "a proper rotation: max |RᵀR − I| ≤ {}, det > 0", Number(tolerance))
            }
        }
    }
}

/// What was found outside a domain, for [`CbfError::ParamOutOfDomain`](crate::CbfError::ParamOutOfDomain).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Found {
    /// A scalar parameter's value.
    Value(f64),
    /// Entry `index` of a vector parameter.
    Entry {
        /// Its position in the vector.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// Entry (`row`, `col`) of a matrix parameter.
    MatrixEntry {
        /// Its row.
        row: usize,
        /// Its column.
        col: usize,
        /// Its value.
        value: f64,
    },
    /// The length of a vector that should have unit length.
    Norm(f64),
    /// The largest entry of `|RᵀR − I|` of a matrix that should be a rotation.
    Orthonormality(f64),
    /// The determinant of an orthonormal matrix that should be a rotation (≤ 0: a
    /// reflection).
    Determinant(f64),
    /// The parameter was never set: it still holds [`UNSET`](super::UNSET), as a fixed
    /// instance's parameters do until they are set where the spec gives no default.
    NotSet,
}

/// `found` as a message states it, of parameter `param`.
pub(crate) struct FoundIn<'a>(pub &'a Found, pub &'a str);

impl fmt::Display for FoundIn<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = self.1;
        match *self.0 {
            Found::Value(v) => write!(f, "{p} = {}", Number(v)),
            Found::Entry { index, value } => write!(f, "{p}[{index}] = {}", Number(value)),
            Found::MatrixEntry { row, col, value } => write!(f, "{p}[{row}, {col}] = {}", Number(value)),
            Found::Norm(v) => write!(f, "|{p}| = {}", Number(v)),
            Found::Orthonormality(v) => write!(f, "max |RᵀR − I| of {p} = {}", Number(v)),
            Found::Determinant(v) => write!(f, "det {p} = {}", Number(v)),
            Found::NotSet => write!(f, "{p} was never set"),
        }
    }
}

/// Where a parameter sits, as a message states it: `"obstacle member link3 instance 2"`.
pub(crate) struct Site<'a>(pub &'a str, pub &'a Option<&'static str>, pub &'a Option<usize>);

impl fmt::Display for Site<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)?;
        if let Some(member) = self.1 {
            write!(f, " member {member}")?;
        }
        if let Some(instance) = self.2 {
            write!(f, " instance {instance}")?;
        }
        Ok(())
    }
}
