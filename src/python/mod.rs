//! The Python extension module `cbfgen._native` (feature `python`; build it with maturin,
//! as `scripts/cbf setup` does). The `cbfgen` Python package re-exports everything here;
//! `python/cbfgen/_native.pyi` carries the signatures for IDEs.
//!
//! Conventions at the boundary:
//! * arrays in: anything numpy reads as booleans, integers or floats (lists, tuples,
//!   arrays of those dtypes), converted to float64; complex, string and object arrays
//!   are a `ValueError` (numpy's cast would drop the imaginary part or parse text);
//! * shapes are exact: a vector of N values has shape (N,); a 3×3 rotation is 9
//!   row-major values (9,) or a 3×3 array; a foothold polygon's normals are (k, 2) and
//!   its offsets (k,). A (2, 3) array is never read as 6 values in some order;
//! * arrays out: new float64 numpy arrays, never views of Rust memory; every kernel
//!   output is finite (a NaN or infinite value raises `CbfError` instead);
//! * errors: [`crate::CbfError`] becomes `cbfgen.CbfError` (a `ValueError`) with the
//!   Rust message; wrong shapes, unknown names and out-of-range legs are `ValueError`
//!   too; integers outside their Rust type (negative counts, > 2⁶⁴) are `OverflowError`.
//!   Nothing in this module panics on any input: counts are checked before anything is
//!   sized by them, and conversions that could panic (`Duration::from_secs_f64`) are
//!   the checked ones.
//! * `EcbfFilter.update` and `simulate` release the GIL while Rust works.

mod convert;
mod filter;
mod kernel_table;
mod kernels;
mod sim;

use pyo3::prelude::*;

use crate::systems::tachyon3::catalog::{Family, RELATIVE_DEGREE};
use crate::systems::tachyon3::model;

pyo3::create_exception!(
    cbfgen,
    CbfError,
    pyo3::exceptions::PyValueError,
    "An error reported by cbfgen's Rust core (bad value, capacity, solver set-up...)."
);

impl From<crate::CbfError> for PyErr {
    fn from(e: crate::CbfError) -> Self {
        CbfError::new_err(e.to_string())
    }
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("CbfError", py.get_type::<CbfError>())?;
    m.add("NX", model::NX)?;
    m.add("NU", model::NU)?;
    m.add("STATE_NAMES", model::STATE_NAMES.to_vec())?;
    m.add("INPUT_NAMES", model::INPUT_NAMES.to_vec())?;
    m.add("LEG_NAMES", model::LEG_NAMES.to_vec())?;
    m.add("INPUT_LIMITS", model::INPUT_LIMITS.to_vec())?;
    m.add("TOE_RADIUS", model::TOE_RADIUS)?;
    m.add("BODY_HALF_EXTENTS", model::BODY_HALF_EXTENTS.to_vec())?;
    m.add("RELATIVE_DEGREE", RELATIVE_DEGREE)?;
    m.add("FAMILIES", Family::ALL.map(Family::name).to_vec())?;
    m.add("DT", crate::systems::tachyon3::sim::DT)?;
    m.add("MAX_EDGES", crate::systems::tachyon3::catalog::Capacity::MAX_EDGES)?;
    m.add("MAX_FOOTHOLD_EDGES", crate::systems::tachyon3::catalog::Capacity::MAX_FOOTHOLD_EDGES)?;
    m.add("MAX_ITERATIONS", crate::filter::SolverSettings::MAX_ITERATIONS)?;
    m.add("MAX_TIME_LIMIT_US", crate::filter::SolverSettings::MAX_TIME_LIMIT.as_secs_f64() * 1e6)?;
    m.add("MAX_INPUT", crate::filter::domain::MAX_INPUT)?;
    m.add("STATE_LIMIT", model::STATE_LIMIT)?;
    m.add("MAX_SIM_TIME", crate::systems::tachyon3::sim::MAX_SIM_TIME)?;
    m.add("SSAT_ALPHA_RANGE", (crate::ssat::ALPHA_MIN, crate::ssat::ALPHA_MAX))?;
    m.add("MAX_COORDINATE", crate::geometry::MAX_COORDINATE)?;
    m.add("HALF_EXTENT_RANGE", (crate::geometry::MIN_HALF_EXTENT, crate::geometry::MAX_HALF_EXTENT))?;
    kernels::register(m)?;
    kernel_table::register(m)?;
    filter::register(m)?;
    sim::register(m)?;
    Ok(())
}
