//! Conversions at the Python boundary: array-likes in, numpy arrays out.

use numpy::ndarray::Array2;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn,
    PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::PyResult;
use pyo3::sync::PyOnceLock;
use pyo3::{intern, Borrowed};

use cbfgen::error::CbfError;

/// A real-valued array from anything numpy reads as booleans, integers or floats (lists,
/// tuples, arrays of any such dtype), as float64.
///
/// numpy's own cast to float64 would also take complex values (dropping the imaginary
/// part), strings ("1.5") and arbitrary objects; those are refused with a `ValueError`
/// instead, by letting numpy infer the dtype first and checking its kind before the cast.
pub struct ArrayIn<'py>(PyReadonlyArrayDyn<'py, f64>);

impl<'a, 'py> FromPyObject<'a, 'py> for ArrayIn<'py> {
    type Error = PyErr;

    fn extract(ob: Borrowed<'a, 'py, PyAny>) -> pyo3::PyResult<Self> {
        if let Ok(array) = ob.cast::<PyArrayDyn<f64>>() {
            return Ok(Self(array.try_readonly()?));
        }
        let py = ob.py();
        let inferred = match ob.cast::<PyUntypedArray>() {
            Ok(array) => array.to_owned(),
            Err(_) => {
                static ASARRAY: PyOnceLock<Py<PyAny>> = PyOnceLock::new();
                ASARRAY.import(py, "numpy", "asarray")?.call1((ob,))?.cast_into::<PyUntypedArray>()?
            }
        };
        let dtype = inferred.dtype();
        // numpy's kinds: b bool, i signed, u unsigned, f float; c complex, O object,
        // U/S strings, M/m dates and times, V void are not real numbers.
        if !matches!(dtype.kind(), b'b' | b'i' | b'u' | b'f') {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "expected real numbers (bool, int or float), got dtype {dtype}"
            )));
        }
        let converted = inferred.call_method1(intern!(py, "astype"), (numpy::dtype::<f64>(py),))?;
        Ok(Self(converted.cast_into::<PyArrayDyn<f64>>()?.try_readonly()?))
    }
}

/// A new float64 numpy vector / matrix.
pub type Array1Out<'py> = Bound<'py, PyArray1<f64>>;
pub type Array2Out<'py> = Bound<'py, PyArray2<f64>>;

fn shape_error(what: &str, expected: &str, shape: &[usize]) -> crate::Error {
    crate::value_error(format!("{what}: expected {expected}, got shape {}", shape_text(shape)))
}

/// A shape as numpy prints it: (3,), (2, 3), ().
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!("({})", shape.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")),
    }
}

/// Exactly `N` values as a vector of shape (N,). Other shapes are refused even with N
/// values, so that a (2, 3) array is never silently read as 6 values in some order.
pub fn fixed<const N: usize>(what: &str, a: &ArrayIn<'_>) -> PyResult<[f64; N]> {
    let view = a.0.as_array();
    if view.shape() != [N] {
        return Err(shape_error(what, &format!("{N} values in shape ({N},)"), view.shape()));
    }
    let mut out = [0.0; N];
    for (o, v) in out.iter_mut().zip(view.iter()) {
        *o = *v;
    }
    Ok(out)
}

/// Values of exactly `shape` (`[]` a scalar, `[n]` a vector, `[r, c]` a matrix read row
/// by row), flattened. A matrix may also come flat, as its `r·c` row-major values; any
/// other shape is refused, so that a (2, 3) array is never read as a 6-vector.
pub fn shaped(what: &str, a: &ArrayIn<'_>, shape: &[usize]) -> PyResult<Vec<f64>> {
    let view = a.0.as_array();
    let flat_matrix = shape.len() == 2 && view.shape() == [shape[0] * shape[1]];
    if view.shape() != shape && !flat_matrix {
        let expected = match shape {
            [] => "a number".to_string(),
            [r, c] => format!("shape ({r}, {c}) or its {} values row by row, shape ({},)", r * c, r * c),
            _ => format!("shape {}", shape_text(shape)),
        };
        return Err(shape_error(what, &expected, view.shape()));
    }
    // `iter` walks in logical row-major order whatever the memory layout.
    Ok(view.iter().copied().collect())
}

/// At most `max` rows of `C` values: shape (k, C), or (0,) for none (what `[]` becomes).
/// The count is checked before anything is copied.
pub fn rows<const C: usize>(what: &'static str, a: &ArrayIn<'_>, max: usize) -> PyResult<Vec<[f64; C]>> {
    let view = a.0.as_array();
    let k = match *view.shape() {
        [0] => 0,
        [k, c] if c == C => k,
        _ => return Err(shape_error(what, &format!("shape (k, {C})"), view.shape())),
    };
    if k > max {
        return Err(CbfError::CapacityExceeded { what, capacity: max }.into());
    }
    let flat: Vec<f64> = view.iter().copied().collect();
    Ok(flat
        .chunks_exact(C)
        .map(|row| {
            let mut out = [0.0; C];
            out.copy_from_slice(row);
            out
        })
        .collect())
}

/// At most `max` values as a vector of shape (k,); the count is checked before anything
/// is copied.
pub fn values(what: &'static str, a: &ArrayIn<'_>, max: usize) -> PyResult<Vec<f64>> {
    let view = a.0.as_array();
    if view.ndim() != 1 {
        return Err(shape_error(what, "a vector, shape (k,)", view.shape()));
    }
    if view.len() > max {
        return Err(CbfError::CapacityExceeded { what, capacity: max }.into());
    }
    Ok(view.iter().copied().collect())
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

/// The index of `name` in `names`, or a `ValueError` listing the choices.
pub fn choice(what: &str, name: &str, names: &[&str]) -> PyResult<usize> {
    names
        .iter()
        .position(|n| *n == name)
        .ok_or_else(|| crate::value_error(format!("unknown {what} '{name}': expected one of {names:?}")))
}

/// The one of `all` named `name` (by `name_of`), or `default` for `None`; an unknown name is
/// a `ValueError` listing the names.
pub fn named<T: Copy, const N: usize>(
    what: &str,
    name: Option<&str>,
    all: [T; N],
    name_of: fn(T) -> &'static str,
    default: T,
) -> PyResult<T> {
    match name {
        Some(name) => Ok(all[choice(what, name, &all.map(name_of))?]),
        None => Ok(default),
    }
}
