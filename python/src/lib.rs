//! The Python extension module `cbfgen._native` (the `cbfgen-python` crate; build it with maturin,
//! as `scripts/cbf setup` does). The `cbfgen` Python package re-exports the generic part
//! (`System`, `Params`, `EcbfFilter`, `Rows`, the SSAT and the kernel table) and
//! `cbfgen.tachyon3` the robot's own (`Environment`, `Course`, `simulate`, kinematics);
//! `python/cbfgen/_native.pyi` carries the signatures for IDEs.
//!
//! Every built-in system is reached through the same classes ([`cbfgen::dynamic`]): a new
//! spec needs no binding code here.
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
//! * errors: [`cbfgen::CbfError`] becomes `cbfgen.CbfError` (a `ValueError`) with the
//!   Rust message; wrong shapes, unknown names and out-of-range legs are `ValueError`
//!   too; integers outside their Rust type (negative counts, > 2⁶⁴) are `OverflowError`.
//!   Nothing in this module panics on any input: counts are checked before anything is
//!   sized by them, and conversions that could panic (`Duration::from_secs_f64`) are
//!   the checked ones.
//! * `EcbfFilter.update` and `simulate` release the GIL while Rust works.

#![warn(missing_docs)]

mod anymal;
mod arm;
mod convert;
mod embedded {
    include!(concat!(env!("OUT_DIR"), "/core_sources.rs"));
}
mod kernel_table;
mod registry;
mod ssat;
mod system;
mod tachyon3;

use pyo3::prelude::*;

pyo3::create_exception!(
    cbfgen,
    CbfError,
    pyo3::exceptions::PyValueError,
    "An error reported by cbfgen's Rust core (bad value, capacity, solver set-up...)."
);

/// An error on its way to Python: the core's (raised as `cbfgen.CbfError`, a `ValueError`,
/// with the Rust message) or pyo3's own. Both convert with `?`, which a plain `PyErr`
/// cannot offer here: `CbfError` and `PyErr` are both foreign to this crate.
#[derive(Debug)]
pub enum Error {
    /// An error of the core or a system crate.
    Cbf(cbfgen::CbfError),
    /// An error pyo3 raised (a wrong type, a shape).
    Py(PyErr),
}

impl From<cbfgen::CbfError> for Error {
    fn from(e: cbfgen::CbfError) -> Self {
        Error::Cbf(e)
    }
}

impl From<PyErr> for Error {
    fn from(e: PyErr) -> Self {
        Error::Py(e)
    }
}

impl From<Error> for PyErr {
    fn from(e: Error) -> Self {
        match e {
            // The one mismatch Python can always avoid: say how.
            Error::Cbf(e @ cbfgen::CbfError::CapacityMismatch) => CbfError::new_err(format!(
                "{e}: build the filter from the parameters, system.filter(params) (or with no capacity: it takes \
                 the first parameters' own)"
            )),
            Error::Cbf(e) => CbfError::new_err(e.to_string()),
            Error::Py(e) => e,
        }
    }
}

/// A Python `ValueError` with `message`.
pub fn value_error(message: impl Into<String>) -> Error {
    Error::Py(pyo3::exceptions::PyValueError::new_err(message.into()))
}

/// A Python `KeyError` with `message`.
pub fn key_error(message: impl Into<String>) -> Error {
    Error::Py(pyo3::exceptions::PyKeyError::new_err(message.into()))
}

/// A Python `RuntimeError` with `message`.
pub fn runtime_error(message: impl Into<String>) -> Error {
    Error::Py(pyo3::exceptions::PyRuntimeError::new_err(message.into()))
}

/// What every binding returns.
pub type PyResult<T> = Result<T, Error>;

/// The core's sources this module was built from, ``[(path, bytes)]`` with paths relative
/// to the repository: what cbfgen.load builds a spec against when no clone is at hand.
#[pyfunction]
fn core_sources(py: Python<'_>) -> Vec<(&'static str, Bound<'_, pyo3::types::PyBytes>)> {
    embedded::CORE_SOURCES.iter().map(|(path, bytes)| (*path, pyo3::types::PyBytes::new(py, bytes))).collect()
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> pyo3::PyResult<()> {
    let py = m.py();
    m.add("CbfError", py.get_type::<CbfError>())?;
    m.add("MAX_ITERATIONS", cbfgen::qp::SolverSettings::MAX_ITERATIONS)?;
    m.add("MAX_TIME_LIMIT_US", cbfgen::qp::SolverSettings::MAX_TIME_LIMIT.as_secs_f64() * 1e6)?;
    m.add("MAX_INPUT", cbfgen::filter::domain::MAX_INPUT)?;
    m.add("STATE_LIMIT", cbfgen::system::STATE_LIMIT)?;
    m.add("PARAM_LIMIT", cbfgen::system::PARAM_LIMIT)?;
    m.add("MAX_INSTANCES", cbfgen::system::MAX_INSTANCES)?;
    m.add("POLE_RANGE", (cbfgen::filter::domain::POLE_RANGE[0], cbfgen::filter::domain::POLE_RANGE[1]))?;
    m.add("MAX_PRIORITY", cbfgen::filter::domain::MAX_PRIORITY)?;
    m.add("SOLVERS", cbfgen::qp::Solver::ALL.map(cbfgen::qp::Solver::name).to_vec())?;
    m.add("INPUT_SOURCES", cbfgen::filter::InputSource::ALL.map(cbfgen::filter::InputSource::name).to_vec())?;
    m.add("SSAT_ALPHA_RANGE", (cbfgen::ssat::ALPHA_MIN, cbfgen::ssat::ALPHA_MAX))?;
    m.add("MAX_COORDINATE", cbfgen::geometry::MAX_COORDINATE)?;
    m.add("HALF_EXTENT_RANGE", (cbfgen::geometry::MIN_HALF_EXTENT, cbfgen::geometry::MAX_HALF_EXTENT))?;
    m.add_function(wrap_pyfunction!(core_sources, m)?)?;
    m.add("PLUGIN_ABI_VERSION", cbfgen::plugin::ABI_VERSION)?;
    system::register(m)?;
    ssat::register(m)?;
    kernel_table::register(m)?;
    tachyon3::register(m)?;
    anymal::register(m)?;
    arm::register(m)?;
    Ok(())
}
