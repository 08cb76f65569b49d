//! Every generated kernel of every built-in system behind one uniform call: the table
//! [`kernels`] lists each generated module's table, so a new system needs no binding code
//! here to be called (and cross-checked against SymEngine) from Python.

use pyo3::prelude::*;

use crate::PyResult;

use super::convert::{values, vector, Array1Out, ArrayIn};
use crate::registry::kernels;
use cbfgen::error::{finite, CbfError};
use cbfgen::system::KernelEntry;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(kernel_table, m)?)?;
    m.add_function(wrap_pyfunction!(call_kernel, m)?)?;
    Ok(())
}

/// A kernel's argument or result: its name and how many numbers it holds.
type Slot = (&'static str, usize);

/// Every generated kernel: ``(module, name, inputs, outputs)`` with inputs and outputs as
/// ``(name, length)`` in the kernel's order.
#[pyfunction]
fn kernel_table() -> Vec<(&'static str, &'static str, Vec<Slot>, Vec<Slot>)> {
    kernels()
        .flat_map(|(module, kernels)| {
            kernels.iter().map(move |k| (*module, k.name, k.inputs.to_vec(), k.outputs.to_vec()))
        })
        .collect()
}

/// Call kernel ``name`` of ``module`` with every input flattened, in order, into one
/// vector; returns every output flattened likewise (matrices row by row, symmetric ones by
/// their upper triangle). Inputs must be finite, within ``PARAM_LIMIT`` and exactly as many
/// as the kernel takes; an output that is not finite (a singular state) raises ``CbfError``.
#[pyfunction]
fn call_kernel<'py>(py: Python<'py>, module: &str, name: &str, inputs: ArrayIn<'py>) -> PyResult<Array1Out<'py>> {
    let entry = find(module, name)?;
    let expected: usize = entry.inputs.iter().map(|(_, n)| n).sum();
    let inputs = values("kernel inputs", &inputs, expected)?;
    if inputs.len() != expected {
        return Err(CbfError::LengthMismatch { what: "kernel inputs", expected, got: inputs.len() }.into());
    }
    // One domain for every kernel input (states, times and parameters alike): the widest,
    // the parameters'. Outputs reach Python only when finite.
    cbfgen::system::validate_params("kernel input", &inputs)?;
    let mut outputs = vec![0.0; entry.outputs.iter().map(|(_, n)| n).sum()];
    (entry.call)(&inputs, &mut outputs);
    for &v in &outputs {
        finite("kernel output", v)?;
    }
    Ok(vector(py, &outputs))
}

fn find(module: &str, name: &str) -> PyResult<&'static KernelEntry> {
    kernels()
        .filter(|(m, _)| *m == module)
        .flat_map(|(_, kernels)| kernels.iter())
        .find(|k| k.name == name)
        .ok_or_else(|| crate::key_error(format!("no generated kernel {module}::{name}")))
}
