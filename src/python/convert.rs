//! Conversions at the Python boundary: array-likes in, numpy arrays out, legs by index
//! or name.

use numpy::ndarray::Array2;
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLikeDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::model::LEG_NAMES;

/// Any array-like numpy accepts as float64.
pub type ArrayIn<'py> = PyArrayLikeDyn<'py, f64, AllowTypeChange>;

/// A new float64 numpy vector / matrix.
pub type Array1Out<'py> = Bound<'py, PyArray1<f64>>;
pub type Array2Out<'py> = Bound<'py, PyArray2<f64>>;

/// Exactly `N` values, in row-major order, whatever the array's shape.
pub fn fixed<const N: usize>(what: &str, a: &ArrayIn<'_>) -> PyResult<[f64; N]> {
    let view = a.as_array();
    if view.len() != N {
        return Err(PyValueError::new_err(format!(
            "{what}: expected {N} values, got {} (shape {:?})",
            view.len(),
            view.shape()
        )));
    }
    let mut out = [0.0; N];
    for (o, v) in out.iter_mut().zip(view.iter()) {
        *o = *v;
    }
    Ok(out)
}

/// Every value, row-major, as a flat vector.
pub fn flat(a: &ArrayIn<'_>) -> Vec<f64> {
    a.as_array().iter().copied().collect()
}

pub fn vector<'py>(py: Python<'py>, v: &[f64]) -> Array1Out<'py> {
    PyArray1::from_slice(py, v)
}

pub fn matrix<'py, const R: usize, const C: usize>(py: Python<'py>, m: &[[f64; C]; R]) -> Array2Out<'py> {
    Array2::from_shape_fn((R, C), |(i, j)| m[i][j]).into_pyarray(py)
}

pub fn matrix_from_fn<'py>(
    py: Python<'py>,
    rows: usize,
    cols: usize,
    f: impl Fn(usize, usize) -> f64,
) -> Array2Out<'py> {
    Array2::from_shape_fn((rows, cols), |(i, j)| f(i, j)).into_pyarray(py)
}

/// A leg, as its index in `LEG_NAMES` order or its name ("LF", "MF", ...).
#[derive(FromPyObject)]
pub enum LegArg {
    Index(i64),
    Name(String),
}

impl LegArg {
    pub fn index(&self) -> PyResult<usize> {
        let found = match self {
            LegArg::Index(i) => usize::try_from(*i).ok().filter(|&i| i < LEG_NAMES.len()),
            LegArg::Name(n) => LEG_NAMES.iter().position(|l| l.eq_ignore_ascii_case(n)),
        };
        found.ok_or_else(|| {
            let given = match self {
                LegArg::Index(i) => i.to_string(),
                LegArg::Name(n) => format!("'{n}'"),
            };
            PyValueError::new_err(format!("no leg {given}: legs are 0..6 or one of {LEG_NAMES:?}"))
        })
    }
}

/// The index of `name` in `names`, or a `ValueError` listing the choices.
pub fn choice(what: &str, name: &str, names: &[&str]) -> PyResult<usize> {
    names
        .iter()
        .position(|n| *n == name)
        .ok_or_else(|| PyValueError::new_err(format!("unknown {what} '{name}': expected one of {names:?}")))
}
