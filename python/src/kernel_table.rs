//! Every generated kernel behind one uniform call: the core's primitives (SSAT,
//! sphere–box) and the kernels of every system, built in or loaded with `cbfgen.load`
//! (through [`DynSystem::kernels`](cbfgen::dynamic::DynSystem::kernels)), so a new system
//! needs no binding code here to be called (and cross-checked against SymEngine) from
//! Python.

use pyo3::prelude::*;

use crate::PyResult;

use super::convert::{values, vector, Array1Out, ArrayIn};
use crate::system::{every_system, system_named};
use cbfgen::dynamic::DynSystem;
use cbfgen::error::finite;
use cbfgen::system::KernelSignature;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(kernel_table, m)?)?;
    m.add_function(wrap_pyfunction!(call_kernel, m)?)?;
    Ok(())
}

/// A kernel's argument or result: its name and how many numbers it holds.
type Slot = (&'static str, usize);

/// Every generated kernel: ``(module, name, inputs, outputs)`` with inputs and outputs as
/// ``(name, length)`` in the kernel's order. Modules are the core's primitives
/// (``ssat``, ``sphere_box``), then each system by name, loaded ones included.
#[pyfunction]
fn kernel_table() -> Vec<(&'static str, &'static str, Vec<Slot>, Vec<Slot>)> {
    let primitives = cbfgen::generated::KERNELS
        .iter()
        .flat_map(|(module, kernels)| kernels.iter().map(move |k| (*module, k.signature())));
    let systems = every_system().into_iter().flat_map(|s| s.kernels().into_iter().map(move |k| (s.name(), k)));
    primitives.chain(systems).map(|(module, k)| (module, k.name, k.inputs.to_vec(), k.outputs.to_vec())).collect()
}

/// Call kernel ``name`` of ``module`` with every input flattened, in order, into one
/// vector; returns every output flattened likewise (matrices row by row, symmetric ones by
/// their upper triangle). Inputs must be finite, within ``PARAM_LIMIT`` and exactly as many
/// as the kernel takes; an output that is not finite (a singular state) raises ``CbfError``.
#[pyfunction]
fn call_kernel<'py>(py: Python<'py>, module: &str, name: &str, inputs: ArrayIn<'py>) -> PyResult<Array1Out<'py>> {
    let (signature, owner) = find(module, name)?;
    let inputs = values("kernel inputs", &inputs, signature.input_len())?;
    let mut outputs = vec![0.0; signature.output_len()];
    signature.check_lengths(&inputs, &outputs)?;
    // One domain for every kernel input (states, times and parameters alike): the widest,
    // the parameters'. Outputs reach Python only when finite.
    cbfgen::system::validate_params("kernel input", &inputs)?;
    match owner {
        Owner::Core(call) => call(&inputs, &mut outputs),
        Owner::System(system) => system.call_kernel(name, &inputs, &mut outputs)?,
    }
    for &v in &outputs {
        finite("kernel output", v)?;
    }
    Ok(vector(py, &outputs))
}

/// Who runs a kernel: the core's generated primitives directly, a system through its
/// `DynSystem` (linked or loaded alike).
enum Owner {
    Core(fn(&[f64], &mut [f64])),
    System(&'static dyn DynSystem),
}

/// Kernel `name` of `module`: a core primitive's, else a system's.
fn find(module: &str, name: &str) -> PyResult<(KernelSignature, Owner)> {
    let missing = || crate::key_error(format!("no generated kernel {module}::{name}"));
    if let Some((_, kernels)) = cbfgen::generated::KERNELS.iter().find(|(m, _)| *m == module) {
        let entry = kernels.iter().find(|k| k.name == name).ok_or_else(missing)?;
        return Ok((entry.signature(), Owner::Core(entry.call)));
    }
    let system = system_named(module).map_err(|_| missing())?;
    let signature = system.kernels().into_iter().find(|k| k.name == name).ok_or_else(missing)?;
    Ok((signature, Owner::System(system)))
}
