//! The Python extension module `cbfgen._native` (feature `python`; build it with maturin,
//! as `scripts/cbf setup` does). The `cbfgen` Python package re-exports everything here;
//! `python/cbfgen/_native.pyi` carries the signatures for IDEs.
//!
//! Conventions at the boundary:
//! * arrays in: anything numpy can turn into float64 (lists, tuples, arrays of any
//!   float or int type), with exactly the documented number of values, in row-major
//!   order (a 3×3 rotation may be given as 9 values or as a 3×3 array);
//! * arrays out: new float64 numpy arrays, never views of Rust memory;
//! * errors: [`crate::CbfError`] becomes `cbfgen.CbfError` (a `ValueError`) with the
//!   Rust message; wrong lengths, unknown names and out-of-range legs are `ValueError`
//!   too. Nothing in this module panics on any input.

mod convert;
mod filter;
mod kernels;
mod sim;

use pyo3::prelude::*;

use crate::catalog::{Family, RELATIVE_DEGREE};
use crate::model;

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
    m.add("DT", crate::sim::DT)?;
    kernels::register(m)?;
    filter::register(m)?;
    sim::register(m)?;
    Ok(())
}
