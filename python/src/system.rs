//! Every built-in system through one set of classes: `System` (names, sizes, dynamics),
//! `Params` (each family's run-time instances), `EcbfFilter` and `FilterOutput`, and
//! `Rows`. Nothing here names a system: all of it goes through [`cbfgen::dynamic`].

use std::collections::HashMap;
use std::sync::{Mutex, MutexGuard};
use std::time::Duration;

use pyo3::prelude::*;

use crate::registry::SYSTEMS;
use crate::{value_error, PyResult};
use pyo3::types::{PyDict, PyList, PyTuple};

use super::convert::{choice, matrix_from_fn, shaped, vector, Array1Out, Array2Out, ArrayIn};
use cbfgen::dynamic::{self, CapacityCount, DynFilter, DynParams, DynRows, DynSystem, FamilyStore};
use cbfgen::error::{within, CbfError};
use cbfgen::filter::{BetweenSamples, Cause, FamilyRelaxation, Limit, Output, SampledData, Solver, SolverSettings};
use cbfgen::param_domain::Domain;
use cbfgen::system::{FamilyInfo, InstanceKind, Poles};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(systems, m)?)?;
    m.add_function(wrap_pyfunction!(load_plugin, m)?)?;
    m.add_class::<PySystem>()?;
    m.add_class::<PyParams>()?;
    m.add_class::<PyRows>()?;
    m.add_class::<PyEcbfFilter>()?;
    m.add_class::<PyFilterOutput>()?;
    Ok(())
}

/// The names of every built-in system, then of every system loaded from a plugin
/// (``cbfgen.load``) whose name no built-in one takes: each name once, as ``System(name)``
/// finds it.
#[pyfunction]
fn systems() -> Vec<&'static str> {
    every_system().iter().map(|s| s.name()).collect()
}

/// The systems loaded from plugins in this process, by library path (a path loads once).
static LOADED: std::sync::Mutex<Vec<(std::path::PathBuf, &'static dyn DynSystem)>> = std::sync::Mutex::new(Vec::new());

/// Every system by the name [`system_named`] finds it: the built-in ones in name order,
/// then the loaded ones whose names nothing shadows (the latest load of a name wins).
pub fn every_system() -> Vec<&'static dyn DynSystem> {
    let loaded = LOADED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let mut systems: Vec<&'static dyn DynSystem> = SYSTEMS.names().filter_map(|name| SYSTEMS.get(name).ok()).collect();
    for (_, s) in loaded.iter().rev() {
        if systems.iter().all(|known| known.name() != s.name()) {
            systems.push(*s);
        }
    }
    systems
}

/// A system by name: a built-in one, else the last one loaded from a plugin with that name.
pub fn system_named(name: &str) -> Result<&'static dyn DynSystem, CbfError> {
    let loaded = LOADED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    match loaded.iter().rev().find(|(_, s)| s.name() == name) {
        Some((_, s)) if SYSTEMS.get(name).is_err() => Ok(*s),
        _ => SYSTEMS.get(name),
    }
}

/// The system of the plugin library at ``path`` (a shared library built by
/// ``cbfgen.load``, or any crate exporting one with ``cbfgen::export_plugin!``): checked
/// for its ABI and core version, then usable wherever a ``System`` is. Loading a path
/// twice returns the same system.
#[pyfunction]
fn load_plugin(path: std::path::PathBuf) -> PyResult<PySystem> {
    let path = path.canonicalize().map_err(|e| value_error(format!("cannot load plugin {}: {e}", path.display())))?;
    let mut loaded = LOADED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some((_, s)) = loaded.iter().find(|(p, _)| *p == path) {
        return Ok(PySystem { inner: *s });
    }
    let system = cbfgen::plugin::load(&path)?;
    loaded.push((path, system));
    Ok(PySystem { inner: system })
}

/// A system given by name or as a `System`.
#[derive(FromPyObject)]
pub enum SystemArg<'py> {
    Name(String),
    System(PyRef<'py, PySystem>),
}

impl SystemArg<'_> {
    fn get(&self) -> Result<&'static dyn DynSystem, CbfError> {
        match self {
            SystemArg::Name(n) => system_named(n),
            SystemArg::System(s) => Ok(s.inner),
        }
    }
}

/// Where a row sits: family, member (of an indexed family), instance, row name.
type RowPlace = (&'static str, Option<&'static str>, usize, &'static str);

/// A member of an indexed family, by index or name.
#[derive(FromPyObject, Clone)]
pub enum MemberArg {
    Index(i64),
    Name(String),
}

/// Members `member` selects of family `f`: one, or (`None`) all of an indexed family's and
/// the only one of another.
fn members(f: &FamilyInfo, member: Option<&MemberArg>, all: bool) -> PyResult<Vec<usize>> {
    let n = f.members.len().max(1);
    match member {
        None if f.members.is_empty() || all => Ok((0..n).collect()),
        None => Err(crate::value_error(format!("family '{}' is indexed over {:?}: pass member=", f.name, f.members))),
        Some(MemberArg::Index(i)) => {
            let i = usize::try_from(*i).ok().filter(|&i| i < n);
            Ok(vec![i.ok_or_else(|| crate::value_error(format!("family '{}' has members 0..{n}", f.name)))?])
        }
        Some(MemberArg::Name(name)) => f.members.iter().position(|m| m.eq_ignore_ascii_case(name)).map_or_else(
            || {
                Err(crate::value_error(format!(
                    "family '{}' has no member '{name}': expected one of {:?}",
                    f.name, f.members
                )))
            },
            |i| Ok(vec![i]),
        ),
    }
}

fn one_member(f: &FamilyInfo, member: Option<&MemberArg>) -> PyResult<usize> {
    Ok(members(f, member, false)?[0])
}

fn family_of(families: &'static [FamilyInfo], name: &str) -> PyResult<(usize, &'static FamilyInfo)> {
    let i = dynamic::family_index(families, name)?;
    Ok((i, &families[i]))
}

/// A filter's capacity argument: `{family: count}`, or a `Params` whose own capacities
/// the filter takes (so that the two agree); `None` when absent.
fn filter_capacity(system: &dyn DynSystem, given: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vec<CapacityCount>>> {
    let Some(given) = given.filter(|g| !g.is_none()) else { return Ok(None) };
    if let Ok(params) = given.cast::<PyParams>() {
        let params = params.borrow();
        if params.inner.system() != system.name() {
            return Err(crate::value_error(format!(
                "parameters of system {} for a filter of system {}",
                params.inner.system(),
                system.name()
            )));
        }
        return Ok(Some(params_capacity(params.inner.as_ref())?));
    }
    let counts = given.cast::<PyDict>().map_err(|_| {
        crate::value_error("capacity: a {family: count} dict, or the Params whose capacities the filter takes")
    })?;
    Ok(Some(capacity(system, Some(counts))?))
}

/// The slots `params` hold for family `family`, one count per member.
fn member_slots(params: &dyn DynParams, family: usize) -> PyResult<Vec<usize>> {
    let members = params.families()[family].members.len().max(1);
    Ok((0..members).map(|m| params.store(family, m).map(|s| s.slots())).collect::<Result<_, _>>()?)
}

/// The capacity counts `params` were built with (its capacity families' slots).
fn params_capacity(params: &dyn DynParams) -> PyResult<Vec<CapacityCount>> {
    let mut out = Vec::new();
    for (family, _) in params.families().iter().enumerate().filter(|(_, f)| f.instances == InstanceKind::Capacity) {
        let slots = member_slots(params, family)?;
        out.extend(slots.into_iter().enumerate().map(|(member, count)| CapacityCount { family, member, count }));
    }
    Ok(out)
}

/// `{family: count}` (an indexed family's count for every member, or a list per member)
/// as capacity counts.
fn capacity(system: &dyn DynSystem, counts: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<CapacityCount>> {
    let mut out = Vec::new();
    for (key, value) in counts.into_iter().flat_map(|d| d.iter()) {
        let name: String = key.extract()?;
        let (family, f) = family_of(system.families(), &name)?;
        // An int is one count (a negative or huge one is Python's OverflowError); anything
        // else must be a list of counts, one per member.
        let per_member: Vec<usize> = if value.is_instance_of::<pyo3::types::PyInt>() {
            vec![value.extract::<usize>()?; f.members.len().max(1)]
        } else {
            value
                .extract()
                .map_err(|_| crate::value_error(format!("capacity of '{name}': a count or one count per member")))?
        };
        if per_member.len() != f.members.len().max(1) {
            return Err(CbfError::LengthMismatch {
                what: "capacity counts (one per member)",
                expected: f.members.len().max(1),
                got: per_member.len(),
            }
            .into());
        }
        // A fixed or optional family's own count (what `Params.capacity` reports) says
        // nothing to choose: accepted and skipped.
        if f.instances != InstanceKind::Capacity && !f.params.is_empty() && per_member.iter().all(|&c| c == f.count) {
            continue;
        }
        out.extend(per_member.into_iter().enumerate().map(|(member, count)| CapacityCount { family, member, count }));
    }
    Ok(out)
}

/// A parameter's domain as Python sees it: `("real",)`, `("positive",)`,
/// `("non_negative",)`, `("interval", lo, hi)`, `("unit_vector", tolerance)` or
/// `("rotation", tolerance)`.
fn domain_tuple<'py>(py: Python<'py>, d: Domain) -> PyResult<Bound<'py, PyTuple>> {
    Ok(match d {
        Domain::Real => ("real",).into_pyobject(py)?,
        Domain::Positive => ("positive",).into_pyobject(py)?,
        Domain::NonNegative => ("non_negative",).into_pyobject(py)?,
        Domain::Interval { lo, hi } => ("interval", lo, hi).into_pyobject(py)?,
        Domain::UnitVector { tolerance } => ("unit_vector", tolerance).into_pyobject(py)?,
        Domain::Rotation { tolerance } => ("rotation", tolerance).into_pyobject(py)?,
    })
}

/// `{parameter: domain}` of one family's instances (empty for a parameter-free family).
fn domains_dict<'py>(py: Python<'py>, store: Option<&dyn FamilyStore>) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for &(name, domain) in store.map_or(&[][..], |s| s.domains()) {
        d.set_item(name, domain_tuple(py, domain)?)?;
    }
    Ok(d)
}

fn family_dict<'py>(py: Python<'py>, f: &FamilyInfo, store: Option<&dyn FamilyStore>) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("name", f.name)?;
    d.set_item("kind", f.kind.name())?;
    d.set_item("relative_degree", f.relative_degree)?;
    d.set_item("row_names", f.row_names.to_vec())?;
    d.set_item("members", f.members.to_vec())?;
    d.set_item("instances", f.instances.name())?;
    d.set_item("count", f.count)?;
    let params = PyList::empty(py);
    for (name, shape) in f.params {
        params.append((*name, shape.to_vec()))?;
    }
    d.set_item("params", params)?;
    d.set_item("domains", domains_dict(py, store)?)?;
    d.set_item("poles", f.defaults.poles.as_slice().to_vec())?;
    d.set_item("priority", f.defaults.priority)?;
    d.set_item("activation", f.defaults.activation)?;
    d.set_item("class_k", f.defaults.class_k.name())?;
    Ok(d)
}

/// `values` as `n` finite-or-not numbers of the system's state or input.
fn exact(what: &str, a: &ArrayIn<'_>, n: usize) -> PyResult<Vec<f64>> {
    shaped(what, a, &[n])
}

/// A generated system, by name (see ``systems()``): its sizes and names, its dynamics,
/// and factories for its parameters, rows and filter.
#[pyclass(name = "System", module = "cbfgen", frozen)]
pub struct PySystem {
    pub inner: &'static dyn DynSystem,
}

#[pymethods]
impl PySystem {
    #[new]
    fn new(name: &str) -> PyResult<Self> {
        Ok(Self { inner: system_named(name)? })
    }

    #[getter]
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    /// The spec's description.
    #[getter]
    fn doc(&self) -> &'static str {
        self.inner.doc()
    }

    /// Number of states.
    #[getter]
    fn nx(&self) -> usize {
        self.inner.nx()
    }

    /// Number of inputs.
    #[getter]
    fn nu(&self) -> usize {
        self.inner.nu()
    }

    #[getter]
    fn state_names(&self) -> Vec<&'static str> {
        self.inner.state_names().to_vec()
    }

    #[getter]
    fn input_names(&self) -> Vec<&'static str> {
        self.inner.input_names().to_vec()
    }

    /// The spec's lower input limits, shape (nu,).
    #[getter]
    fn input_min<'py>(&self, py: Python<'py>) -> Array1Out<'py> {
        vector(py, self.inner.input_min())
    }

    /// The spec's upper input limits, shape (nu,).
    #[getter]
    fn input_max<'py>(&self, py: Python<'py>) -> Array1Out<'py> {
        vector(py, self.inner.input_max())
    }

    /// Every family: a dict of ``name``, ``kind`` ("barrier", or "lyapunov" for a CLF
    /// whose rows are ``h = -V``), ``relative_degree``, ``row_names``,
    /// ``members`` (empty unless indexed), ``instances`` ("fixed", "optional" or
    /// "capacity"), ``count`` (instances per member, or the largest capacity), ``params``
    /// (``(name, shape)`` per parameter), ``domains`` (``{name: domain}``: ``("real",)``,
    /// ``("positive",)``, ``("non_negative",)``, ``("interval", lo, hi)``,
    /// ``("unit_vector", tolerance)`` or ``("rotation", tolerance)``) and the defaults
    /// ``poles``, ``priority``, ``activation``, ``class_k`` (the last term's alpha(s) as
    /// the spec wrote it; "s" for the plain ECBF).
    #[getter]
    fn families<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        // The domains live with the parameter types: read them off empty parameters.
        let params = self.inner.params(&[])?;
        let families = self.inner.families().iter().enumerate();
        families.map(|(i, f)| family_dict(py, f, params.store(i, 0).ok())).collect()
    }

    /// ``f(x)``, shape (nx,).
    fn drift<'py>(&self, py: Python<'py>, x: ArrayIn<'py>) -> PyResult<Array1Out<'py>> {
        let mut f = vec![0.0; self.inner.nx()];
        self.inner.drift(&exact("x", &x, self.inner.nx())?, &mut f)?;
        Ok(vector(py, &f))
    }

    /// ``g(x)``, shape (nx, nu).
    fn input_matrix<'py>(&self, py: Python<'py>, x: ArrayIn<'py>) -> PyResult<Array2Out<'py>> {
        let (nx, nu) = (self.inner.nx(), self.inner.nu());
        let mut g = vec![0.0; nx * nu];
        self.inner.input_matrix(&exact("x", &x, nx)?, &mut g)?;
        Ok(matrix_from_fn(py, nx, nu, |i, j| g[i * nu + j]))
    }

    /// ``x' = f(x) + g(x) u``, shape (nx,). ``u`` must be finite, within ``MAX_INPUT``.
    fn xdot<'py>(&self, py: Python<'py>, x: ArrayIn<'py>, u: ArrayIn<'py>) -> PyResult<Array1Out<'py>> {
        let (nx, nu) = (self.inner.nx(), self.inner.nu());
        let mut dx = vec![0.0; nx];
        self.inner.xdot(&exact("x", &x, nx)?, &exact("u", &u, nu)?, &mut dx)?;
        Ok(vector(py, &dx))
    }

    /// Parameters with room for ``capacity`` (``{family: count}``, or a list with a count
    /// per member of an indexed family); fixed instances start at zero, optional ones
    /// absent, capacity lists empty.
    #[pyo3(signature = (capacity=None))]
    fn params(&self, capacity: Option<&Bound<'_, PyDict>>) -> PyResult<PyParams> {
        Ok(PyParams { inner: self.inner.params(&self::capacity(self.inner, capacity)?)? })
    }

    /// Every row at time ``t``, state ``x`` and ``params`` (laid out for their capacity).
    /// Raises ``CbfError`` where a row that applies is not finite.
    #[pyo3(signature = (x, params, t=0.0))]
    fn rows(&self, py: Python<'_>, x: ArrayIn<'_>, params: PyRef<'_, PyParams>, t: f64) -> PyResult<PyRows> {
        let x = exact("x", &x, self.inner.nx())?;
        let mut barriers = self.inner.barriers_for(params.inner.as_ref())?;
        barriers.evaluate(t, &x, params.inner.as_ref())?;
        // Values out are finite: a row that applies but is not (a singular state, a
        // degenerate parameter) is an error, as the filter's fallback would report it.
        for (i, place) in barriers.layout().iter().enumerate() {
            let Some(row) = barriers.row(i) else { continue };
            let degree = self.inner.families()[place.family].relative_degree;
            if row.active && !row.lie[..=degree].iter().chain(row.lg).all(|v| v.is_finite()) {
                return Err(CbfError::NonFiniteRow { row: i }.into());
            }
        }
        PyRows::of(py, barriers.as_ref(), self.inner.nu())
    }

    /// An ``EcbfFilter`` for this system (the same as ``EcbfFilter(system, ...)``).
    #[pyo3(signature = (capacity=None, **settings))]
    fn filter(
        slf: PyRef<'_, Self>,
        capacity: Option<&Bound<'_, PyAny>>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<PyEcbfFilter> {
        PyEcbfFilter::build(slf.inner, capacity, settings)
    }

    fn __repr__(&self) -> String {
        format!("System('{}', nx={}, nu={}, families={})", self.inner.name(), self.inner.nx(), self.inner.nu(), {
            let names: Vec<&str> = self.inner.families().iter().map(|f| f.name).collect();
            format!("{names:?}")
        })
    }
}

/// Parameter values: a dict ``{name: value}`` with every parameter of the family, or one
/// flat vector of all of them (in declaration order, matrices row by row).
fn flat_values(f: &FamilyInfo, values: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let Ok(dict) = values.cast::<PyDict>() else {
        let width = f.params.iter().map(|(_, s)| s.iter().product::<usize>()).sum();
        return shaped(f.name, &values.extract::<ArrayIn<'_>>()?, &[width]);
    };
    let mut out = Vec::new();
    for (name, shape) in f.params {
        let value = dict
            .get_item(name)?
            .ok_or_else(|| crate::value_error(format!("family '{}': missing parameter '{name}'", f.name)))?;
        out.extend(shaped(name, &value.extract::<ArrayIn<'_>>()?, shape)?);
    }
    if dict.len() != f.params.len() {
        let known: Vec<&str> = f.params.iter().map(|(n, _)| *n).collect();
        return Err(crate::value_error(format!(
            "family '{}': unknown parameter among {:?}; its parameters are {known:?}",
            f.name,
            dict.keys().to_string()
        )));
    }
    Ok(out)
}

/// Every family's run-time instances for one system and capacity (see
/// ``System.params``). A family is named by string; an indexed family's member by name
/// or index. Values are a dict of the family's parameters or one flat vector.
#[pyclass(name = "Params", module = "cbfgen", subclass)]
pub struct PyParams {
    pub inner: Box<dyn DynParams>,
}

impl PyParams {
    fn family(&self, name: &str) -> PyResult<(usize, &'static FamilyInfo)> {
        family_of(self.inner.families(), name)
    }
}

/// `e` with the family it concerns in front of its message (unless the message names it:
/// a parameter outside its domain names family, member, instance and parameter).
fn in_family(f: &FamilyInfo, e: CbfError) -> crate::Error {
    match e {
        CbfError::ParamOutOfDomain { .. } => e.into(),
        _ => crate::Error::Py(super::CbfError::new_err(format!("family '{}': {e}", f.name))),
    }
}

#[pymethods]
impl PyParams {
    /// The system these parameters belong to.
    #[getter]
    fn system(&self) -> &'static str {
        self.inner.system()
    }

    /// ``{family: slots}`` of every family with parameters: a count, or a list per member
    /// (a fixed or optional family's its count). What ``system.params(capacity=...)``
    /// and ``system.filter(capacity=...)`` take; ``system.filter(params)`` reads it itself.
    #[getter]
    fn capacity<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (i, f) in self.inner.families().iter().enumerate().filter(|(_, f)| !f.params.is_empty()) {
            let slots = member_slots(self.inner.as_ref(), i)?;
            if f.members.is_empty() {
                d.set_item(f.name, slots[0])?;
            } else {
                d.set_item(f.name, slots)?;
            }
        }
        Ok(d)
    }

    /// Set instance ``instance`` of ``family`` (of ``member``): a fixed or optional
    /// instance, or one already pushed. Values outside a parameter's domain (a half extent
    /// <= 0, a matrix that is not a proper rotation, NaN...) raise ``CbfError`` naming
    /// family, member, instance and parameter. Nothing changes on an error.
    #[pyo3(signature = (family, values, *, member=None, instance=0))]
    fn set(
        &mut self,
        family: &str,
        values: &Bound<'_, PyAny>,
        member: Option<MemberArg>,
        instance: usize,
    ) -> PyResult<()> {
        let (i, f) = self.family(family)?;
        let m = one_member(f, member.as_ref())?;
        let values = flat_values(f, values)?;
        self.inner.set(i, m, instance, &values).map_err(|e| in_family(f, e))
    }

    /// Append an instance to a capacity family (of ``member``). Refuses values outside a
    /// parameter's domain as ``set`` does; nothing changes on an error.
    #[pyo3(signature = (family, values, *, member=None))]
    fn push(&mut self, family: &str, values: &Bound<'_, PyAny>, member: Option<MemberArg>) -> PyResult<()> {
        let (i, f) = self.family(family)?;
        let m = one_member(f, member.as_ref())?;
        let values = flat_values(f, values)?;
        self.inner.push(i, m, &values).map_err(|e| in_family(f, e))
    }

    /// Instance ``instance`` as ``{name: value}`` (floats and numpy arrays of the
    /// parameters' shapes), or None when that slot is empty.
    #[pyo3(signature = (family, *, member=None, instance=0))]
    fn get<'py>(
        &self,
        py: Python<'py>,
        family: &str,
        member: Option<MemberArg>,
        instance: usize,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        let (i, f) = self.family(family)?;
        let store = self.inner.store(i, one_member(f, member.as_ref())?).map_err(|e| in_family(f, e))?;
        let mut flat = vec![0.0; store.width()];
        if !store.get(instance, &mut flat).map_err(|e| in_family(f, e))? {
            return Ok(None);
        }
        let d = PyDict::new(py);
        let mut at = 0;
        for (name, shape) in f.params {
            let n: usize = shape.iter().product();
            let v = &flat[at..at + n];
            match **shape {
                [] => d.set_item(name, v[0])?,
                [_] => d.set_item(name, vector(py, v))?,
                [r, c] => d.set_item(name, matrix_from_fn(py, r, c, |a, b| v[a * c + b]))?,
                _ => unreachable!("parameters are scalars, vectors or matrices"),
            }
            at += n;
        }
        Ok(Some(d))
    }

    /// Empty optional slot ``instance`` of ``family`` (of ``member``).
    #[pyo3(signature = (family, *, member=None, instance=0))]
    fn remove(&mut self, family: &str, member: Option<MemberArg>, instance: usize) -> PyResult<()> {
        let (i, f) = self.family(family)?;
        let m = one_member(f, member.as_ref())?;
        self.inner.store_mut(i, m).and_then(|s| s.remove(instance)).map_err(|e| in_family(f, e))
    }

    /// Remove every instance of a capacity or optional family (of ``member``; of every
    /// member when None).
    #[pyo3(signature = (family, *, member=None))]
    fn clear(&mut self, family: &str, member: Option<MemberArg>) -> PyResult<()> {
        let (i, f) = self.family(family)?;
        for m in members(f, member.as_ref(), true)? {
            self.inner.store_mut(i, m).and_then(|s| s.clear()).map_err(|e| in_family(f, e))?;
        }
        Ok(())
    }

    /// Switch a capacity family's rows on or off, keeping its instances (of ``member``;
    /// of every member when None).
    #[pyo3(signature = (family, enabled, *, member=None))]
    fn set_enabled(&mut self, family: &str, enabled: bool, member: Option<MemberArg>) -> PyResult<()> {
        let (i, f) = self.family(family)?;
        for m in members(f, member.as_ref(), true)? {
            self.inner.store_mut(i, m).and_then(|s| s.set_enabled(enabled)).map_err(|e| in_family(f, e))?;
        }
        Ok(())
    }

    /// Whether ``family``'s rows (of ``member``) take part.
    #[pyo3(signature = (family, *, member=None))]
    fn is_enabled(&self, family: &str, member: Option<MemberArg>) -> PyResult<bool> {
        let (i, f) = self.family(family)?;
        let m = one_member(f, member.as_ref())?;
        Ok(self.inner.store(i, m).map_err(|e| in_family(f, e))?.is_enabled())
    }

    /// Instances present in ``family`` (of ``member``).
    #[pyo3(signature = (family, *, member=None))]
    fn count(&self, family: &str, member: Option<MemberArg>) -> PyResult<usize> {
        let (i, f) = self.family(family)?;
        let m = one_member(f, member.as_ref())?;
        Ok(self.inner.store(i, m).map_err(|e| in_family(f, e))?.len())
    }

    /// An independent copy.
    fn copy(&self) -> Self {
        Self { inner: self.inner.clone_box() }
    }

    fn __repr__(&self) -> String {
        format!("Params(system='{}')", self.inner.system())
    }
}

/// Rows as evaluated: where each sits and its values.
#[pyclass(name = "Rows", module = "cbfgen", frozen)]
pub struct PyRows {
    layout: Vec<RowPlace>,
    lie: Option<Py<numpy::PyArray2<f64>>>,
    lg: Option<Py<numpy::PyArray2<f64>>>,
    applicable: Vec<bool>,
}

/// Per row ``(family, member or None, instance, row name)``.
fn layout(rows: &dyn DynRows) -> Vec<RowPlace> {
    (0..rows.layout().len()).map(|i| place(rows, i)).collect()
}

/// Where row `i` comes from, by name.
fn place(rows: &dyn DynRows, i: usize) -> RowPlace {
    let r = &rows.layout()[i];
    let f = &rows.families()[r.family];
    (f.name, f.members.get(r.member).copied(), r.instance, f.row_names[r.row])
}

/// ``[h, L_f h, …]`` up to the highest relative degree of any family, per row; `None`
/// when any value is not finite (a degenerate state): arrays out are finite or absent.
fn lie<'py>(py: Python<'py>, rows: &dyn DynRows) -> Option<Array2Out<'py>> {
    let width = rows.families().iter().map(|f| f.relative_degree).max().unwrap_or(0) + 1;
    let n = rows.layout().len();
    let finite = (0..n).all(|i| rows.row(i).is_some_and(|r| r.lie[..width].iter().all(|v| v.is_finite())));
    finite.then(|| matrix_from_fn(py, n, width, |i, j| rows.row(i).map_or(0.0, |r| r.lie[j])))
}

/// ``L_g L_f^{r-1} h`` per row; `None` when any value is not finite.
fn lg<'py>(py: Python<'py>, rows: &dyn DynRows, nu: usize) -> Option<Array2Out<'py>> {
    let n = rows.layout().len();
    let finite = (0..n).all(|i| rows.row(i).is_some_and(|r| r.lg[..nu].iter().all(|v| v.is_finite())));
    finite.then(|| matrix_from_fn(py, n, nu, |i, j| rows.row(i).map_or(0.0, |r| r.lg[j])))
}

/// One flag per row, read off each row's view (false for a row that is not there).
fn row_flags(rows: &dyn DynRows, flag: impl Fn(&dynamic::RowView<'_>) -> bool) -> Vec<bool> {
    (0..rows.layout().len()).map(|i| rows.row(i).is_some_and(|r| flag(&r))).collect()
}

fn applicable(rows: &dyn DynRows) -> Vec<bool> {
    row_flags(rows, |r| r.active)
}

impl PyRows {
    fn of(py: Python<'_>, rows: &dyn DynRows, nu: usize) -> PyResult<Self> {
        Ok(Self {
            layout: layout(rows),
            lie: lie(py, rows).map(Bound::unbind),
            lg: lg(py, rows, nu).map(Bound::unbind),
            applicable: applicable(rows),
        })
    }
}

#[pymethods]
impl PyRows {
    /// Per row ``(family, member or None, instance, row name)``.
    #[getter]
    fn layout(&self) -> Vec<RowPlace> {
        self.layout.clone()
    }

    /// ``[h, L_f h, …, L_f^r h]`` per row (zeros past a row's own degree; rows that did
    /// not apply keep zeros), shape (rows, highest degree + 1); None when a value is not
    /// finite (a degenerate state, such as a toe at its hip).
    #[getter]
    fn lie<'py>(&self, py: Python<'py>) -> Option<Bound<'py, numpy::PyArray2<f64>>> {
        self.lie.as_ref().map(|a| a.bind(py).clone())
    }

    /// ``L_g L_f^{r-1} h`` per row, shape (rows, nu); None when a value is not finite.
    #[getter]
    fn lg_lf<'py>(&self, py: Python<'py>) -> Option<Bound<'py, numpy::PyArray2<f64>>> {
        self.lg.as_ref().map(|a| a.bind(py).clone())
    }

    /// Whether each row applied (its instance was present and switched on).
    #[getter]
    fn applicable(&self) -> Vec<bool> {
        self.applicable.clone()
    }

    fn __len__(&self) -> usize {
        self.layout.len()
    }
}

/// One relaxed row, as Python sees it.
#[derive(Debug, Clone)]
struct RelaxedInfo {
    row: usize,
    place: RowPlace,
    slack: f64,
    relative: f64,
    cause: Cause,
    /// The input named by an `InputLimit`, or the row named by a priority conflict.
    input: Option<&'static str>,
    other: Option<(usize, RowPlace)>,
}

/// One update's result.
#[pyclass(name = "FilterOutput", module = "cbfgen", frozen)]
pub struct PyFilterOutput {
    out: Output<Vec<f64>>,
    relaxed: Vec<RelaxedInfo>,
    families: Vec<(&'static str, FamilyRelaxation)>,
}

impl PyFilterOutput {
    /// The filter's last output with its safety report: every relaxed row placed and its
    /// cause spelled out, and every family's relaxations.
    fn of(filter: &dyn DynFilter, input_names: &'static [&'static str]) -> Self {
        // Only the relaxed rows are named: naming every row each update cost more than
        // the filter itself on small systems.
        let delta = filter.delta();
        let relative = filter.relative_slack();
        let relaxed = filter
            .relaxed()
            .iter()
            .enumerate()
            .filter_map(|(row, cause)| {
                let cause = (*cause)?;
                let (input, other) = match cause {
                    Cause::InputLimit { input, .. } => (input_names.get(input).copied(), None),
                    Cause::HigherPriority { row } | Cause::SamePriority { row } => {
                        (None, Some((row, place(filter, row))))
                    }
                    Cause::NoAuthority | Cause::Unsolved => (None, None),
                };
                Some(RelaxedInfo {
                    row,
                    place: place(filter, row),
                    slack: delta[row],
                    relative: relative[row],
                    cause,
                    input,
                    other,
                })
            })
            .collect();
        let families = filter.families().iter().map(|f| f.name).zip(filter.relaxation().iter().copied()).collect();
        Self { out: filter.output().map_input(|u| u.to_vec()), relaxed, families }
    }
}

fn relaxed_dict<'py>(py: Python<'py>, r: &RelaxedInfo) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("row", r.row)?;
    d.set_item("place", r.place)?;
    d.set_item("slack", r.slack)?;
    d.set_item("relative", r.relative)?;
    d.set_item("cause", r.cause.name())?;
    d.set_item("input", r.input)?;
    d.set_item(
        "limit",
        match r.cause {
            Cause::InputLimit { limit: Limit::Min, .. } => Some("min"),
            Cause::InputLimit { limit: Limit::Max, .. } => Some("max"),
            _ => None,
        },
    )?;
    d.set_item("other_row", r.other.map(|(row, _)| row))?;
    d.set_item("other_place", r.other.map(|(_, place)| place))?;
    Ok(d)
}

#[pymethods]
impl PyFilterOutput {
    /// The input to apply, shape (nu,).
    #[getter]
    fn u<'py>(&self, py: Python<'py>) -> Array1Out<'py> {
        vector(py, &self.out.u)
    }

    /// Where ``u`` came from: "qp", "unconverged", "last_safe" or "nominal_clipped".
    #[getter]
    fn source(&self) -> &'static str {
        self.out.source.name()
    }

    /// How the solve ended ("solved", "max_iterations", ...): the dense solve's report, or
    /// OSQP's when OSQP answered; None when no solve ran.
    #[getter]
    fn status(&self) -> Option<&'static str> {
        self.out.status.map(|s| s.name())
    }

    /// The first active row that was not finite, if any.
    #[getter]
    fn nonfinite_row(&self) -> Option<usize> {
        self.out.nonfinite_row
    }

    #[getter]
    fn iterations(&self) -> u32 {
        self.out.iterations
    }

    /// Which solver answered: "dense" or "osqp"; None when no solve ran.
    #[getter]
    fn backend(&self) -> Option<&'static str> {
        self.out.backend.map(|b| b.name())
    }

    /// Newton steps of the dense solve (0 when it did not run).
    #[getter]
    fn dense_steps(&self) -> u32 {
        self.out.dense_steps
    }

    /// Whether the dense solve ran and did not verify within its budget (OSQP then
    /// answered under the default backend).
    #[getter]
    fn dense_fallback(&self) -> bool {
        self.out.dense_fallback
    }

    /// Whether ``u`` is OSQP's iterate polished to the verified optimum by the dense solve.
    #[getter]
    fn polished(&self) -> bool {
        self.out.polished
    }

    #[getter]
    fn active_rows(&self) -> usize {
        self.out.active_rows
    }

    /// Fallback cycles in a row, this one included (0 when ``source`` is "qp").
    #[getter]
    fn consecutive_fallbacks(&self) -> u32 {
        self.out.consecutive_fallbacks
    }

    /// The work this update did, counted as it ran: a dict of ``qp_solves``,
    /// ``dense_trips`` (the dense solver's inner-loop trips) and ``osqp_iterations``.
    #[getter]
    fn work<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let w = self.out.work;
        let d = PyDict::new(py);
        d.set_item("qp_solves", w.qp_solves)?;
        d.set_item("dense_trips", w.dense_trips)?;
        d.set_item("osqp_iterations", w.osqp_iterations)?;
        Ok(d)
    }

    /// The safety verdict, measured at ``u`` whatever its source: "met" (every active
    /// barrier row holds), "relaxed" (see ``relaxed``) or "unassessed" (an active row was
    /// not finite). Lyapunov rows never count here: see ``convergence``.
    #[getter]
    fn verdict(&self) -> &'static str {
        self.out.safety.verdict.name()
    }

    /// Active barrier rows relaxed beyond the tolerance.
    #[getter]
    fn relaxed_rows(&self) -> usize {
        self.out.safety.relaxed_rows
    }

    /// Between the samples (with ``sample_period`` set): "certified" (every active row met
    /// at ``u`` keeps its ECBF condition over the whole period the input is held), "uncertified"
    /// (see ``uncertified_why``) or "off".
    #[getter]
    fn between_samples(&self) -> &'static str {
        self.out.between_samples.name()
    }

    /// Why the update is not certified between the samples: "deficit" (margins fell short),
    /// "no_interval_form", "flow" (the reachable states could not be enclosed) or
    /// "not_solved" (the input is not the QP's answer); None when certified or off.
    #[getter]
    fn uncertified_why(&self) -> Option<&'static str> {
        match self.out.between_samples {
            BetweenSamples::Uncertified { why, .. } => Some(why.name()),
            _ => None,
        }
    }

    /// The Lyapunov families' verdict, as ``verdict`` is the barriers': "met" (every
    /// decrease ``V' + rate V <= 0`` holds at ``u``, or there is none), "relaxed"
    /// (convergence gave way to safety or to the input limits; the rows are in
    /// ``relaxed``) or "unassessed".
    #[getter]
    fn convergence(&self) -> &'static str {
        self.out.convergence.verdict.name()
    }

    /// Every relaxed row: ``row`` (its index), ``place`` (family, member, instance, row
    /// name), ``slack`` (by how much it is missed, in the row's units), ``relative`` (the
    /// slack over the row's terms), ``cause`` ("input_limit", "higher_priority",
    /// "same_priority", "no_authority" or "unsolved"), and for an input limit the
    /// ``input`` and its ``limit`` ("min"/"max"), for a priority conflict the
    /// ``other_row`` and its ``other_place``.
    #[getter]
    fn relaxed<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.relaxed.iter().map(|r| relaxed_dict(py, r)).collect()
    }

    /// The relaxed barrier row with the largest relative slack (as in ``relaxed``), or None.
    #[getter]
    fn worst<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let worst = self.out.safety.worst.and_then(|w| self.relaxed.iter().find(|r| r.row == w.row));
        worst.map(|r| relaxed_dict(py, r)).transpose()
    }

    /// Per family name: ``relaxed_rows``, ``max_slack`` and ``max_relative`` this update.
    #[getter]
    fn relaxation<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, f) in &self.families {
            let e = PyDict::new(py);
            e.set_item("relaxed_rows", f.relaxed_rows)?;
            e.set_item("max_slack", f.max_slack)?;
            e.set_item("max_relative", f.max_relative)?;
            d.set_item(*name, e)?;
        }
        Ok(d)
    }

    /// Row evaluation time \[µs\].
    #[getter]
    fn eval_time_us(&self) -> f64 {
        self.out.eval_time.as_secs_f64() * 1e6
    }

    /// QP update and solve time \[µs\].
    #[getter]
    fn solve_time_us(&self) -> f64 {
        self.out.solve_time.as_secs_f64() * 1e6
    }

    /// The thread's CPU time over the whole update (evaluation and solve) \[µs\], beside
    /// its wall time ``eval_time_us + solve_time_us``: far less CPU than wall time means
    /// the thread waited (a VM stall, preemption) rather than worked. None unless the
    /// filter was built with ``measure_cpu_time=True`` (one clock reading costs a system
    /// call), or where the platform has no per-thread clock.
    #[getter]
    fn cpu_time_us(&self) -> Option<f64> {
        self.out.cpu_time.map(|t| t.as_secs_f64() * 1e6)
    }

    fn __repr__(&self) -> String {
        let status = self.status().map_or_else(|| "None".to_string(), |s| format!("'{s}'"));
        format!(
            "FilterOutput(source='{}', verdict='{}', relaxed_rows={}, status={status}, backend={}, dense_steps={}, iterations={}, polished={}, active_rows={})",
            self.source(),
            self.verdict(),
            self.relaxed_rows(),
            self.out.backend.map_or("None".to_string(), |b| format!("'{}'", b.name())),
            self.out.dense_steps,
            self.out.iterations,
            if self.out.polished { "True" } else { "False" },
            self.out.active_rows
        )
    }
}

/// OSQP's time limit from microseconds, in `(0, SolverSettings::MAX_TIME_LIMIT]`, checked
/// in the unit the caller gave (where `Duration::from_secs_f64` would panic on 1e26 µs).
fn time_limit(us: f64) -> Result<Duration, CbfError> {
    let max_us = SolverSettings::MAX_TIME_LIMIT.as_secs_f64() * 1e6;
    if within("time_limit_us", us, 0.0, max_us, "(0, 1e6]")? == 0.0 {
        return Err(CbfError::NotPositive { what: "time_limit_us", value: us });
    }
    SolverSettings::time_limit_from_secs(us * 1e-6)
}

/// Settings keywords over the system's defaults.
fn settings(system: &dyn DynSystem, kw: Option<&Bound<'_, PyDict>>) -> PyResult<dynamic::DynSettings> {
    let mut s = system.default_settings();
    let nu = system.nu();
    // The certificate first, so that its other keywords may come in any order.
    if let Some(period) = kw.map(|d| d.get_item("sample_period")).transpose()?.flatten().filter(|v| !v.is_none()) {
        s.sampled_data = Some(SampledData::every_family(period.extract()?));
    }
    for (key, value) in kw.into_iter().flat_map(|d| d.iter()) {
        let key: String = key.extract()?;
        if value.is_none() {
            continue; // None leaves the default, as an omitted keyword does
        }
        match key.as_str() {
            "activation" | "priority" | "poles" => {
                for (name, v) in value.extract::<HashMap<String, Bound<'_, PyAny>>>()? {
                    let (i, _) = family_of(system.families(), &name)?;
                    let p = &mut s.families[i];
                    match key.as_str() {
                        "activation" => p.activation = v.extract()?,
                        "priority" => p.priority = v.extract()?,
                        _ => p.poles = Poles::new(&v.extract::<Vec<f64>>()?)?,
                    }
                }
            }
            "input_weights" => s.input_weights = exact("input_weights", &value.extract()?, nu)?,
            "input_min" => s.input_min = exact("input_min", &value.extract()?, nu)?,
            "input_max" => s.input_max = exact("input_max", &value.extract()?, nu)?,
            "backend" => {
                let names = Solver::ALL.map(Solver::name);
                s.solver.backend = Solver::ALL[choice("backend", &value.extract::<String>()?, &names)?];
            }
            "dense_max_steps" => s.solver.dense_max_steps = value.extract()?,
            "dense_max_work" => s.solver.dense_max_work = value.extract()?,
            "eps_abs" => s.solver.eps_abs = value.extract()?,
            "eps_rel" => s.solver.eps_rel = value.extract()?,
            "max_iter" => s.solver.max_iter = value.extract()?,
            "polish" => s.solver.polish = value.extract()?,
            "time_limit_us" => s.solver.time_limit = Some(time_limit(value.extract()?)?),
            "measure_cpu_time" => s.measure_cpu_time = value.extract()?,
            "cull_far_rows" => s.cull_far_rows = value.extract()?,
            "sample_period" => {} // read first, below the defaults
            "input_delay" | "certify_rounds" | "certify_exempt" => {
                let Some(sampled) = &mut s.sampled_data else {
                    return Err(value_error(format!("{key} needs sample_period (the certificate between samples)")));
                };
                match key.as_str() {
                    "input_delay" => sampled.input_delay = value.extract()?,
                    "certify_rounds" => sampled.max_rounds = value.extract()?,
                    _ => {
                        sampled.exempt = value
                            .extract::<Vec<String>>()?
                            .iter()
                            .map(|name| family_of(system.families(), name).map(|(i, _)| i))
                            .collect::<PyResult<_>>()?
                    }
                }
            }
            other => {
                return Err(crate::value_error(format!(
                    "unknown setting '{other}': expected activation, priority, poles, input_weights, \
                     input_min, input_max, backend, dense_max_steps, dense_max_work, eps_abs, eps_rel, max_iter, polish, \
                     time_limit_us, measure_cpu_time, cull_far_rows, sample_period, input_delay, \
                     certify_rounds or certify_exempt"
                )))
            }
        }
    }
    Ok(s)
}

/// The ECBF-QP safety filter of any system. Build once; each ``update`` evaluates every
/// row at the state and returns the input closest to the nominal one that keeps every
/// active row's ECBF condition (with penalised slack). Keyword settings override the
/// spec's defaults: ``activation``, ``priority`` and ``poles`` map family names to
/// values; ``input_weights``, ``input_min``, ``input_max`` have nu values; ``backend``
/// picks the solver (one of ``SOLVERS``: "dense", "osqp", "dense_then_osqp"), and
/// ``dense_max_steps`` bounds the dense solve's steps (1 ..= ``MAX_ITERATIONS``) and
/// ``dense_max_work`` its work in inner-loop trips (1 ..= 10¹⁰; 2·10⁶ by default);
/// ``eps_abs``, ``eps_rel``, ``max_iter``, ``polish`` and ``time_limit_us`` tune OSQP;
/// ``measure_cpu_time=True`` reads the thread's CPU clock around each update (off by
/// default: a system call per reading); ``cull_far_rows=False`` evaluates every row every
/// cycle (by default rows whose spec-declared lower bound is above their activation
/// threshold are skipped: the same input, less work). ``sample_period`` (seconds) certifies
/// each answer for the period it is held (``between_samples`` on the output, ``margins``
/// per row), with ``input_delay``, ``certify_rounds`` (solves per update, 1–16) and
/// ``certify_exempt`` (family names). See the Rust docs of ``cbfgen::filter`` for the
/// failure policy and ``cbfgen::filter::between_samples`` for the certificate.
#[pyclass(name = "EcbfFilter", module = "cbfgen")]
pub struct PyEcbfFilter {
    system: &'static dyn DynSystem,
    // OSQP's workspace may move between threads but not be shared; the lock makes the
    // filter usable from any Python thread.
    inner: Mutex<Box<dyn DynFilter>>,
    /// Built without a capacity and not updated yet: the first update's parameters give
    /// it theirs.
    capacity_from_params: std::sync::atomic::AtomicBool,
}

impl PyEcbfFilter {
    fn build(
        system: &'static dyn DynSystem,
        capacity: Option<&Bound<'_, PyAny>>,
        kw: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let counts = filter_capacity(system, capacity)?;
        let filter = system.filter(counts.as_deref().unwrap_or_default(), &settings(system, kw)?)?;
        Ok(Self {
            system,
            inner: Mutex::new(filter),
            capacity_from_params: std::sync::atomic::AtomicBool::new(counts.is_none()),
        })
    }

    fn lock(&self) -> PyResult<MutexGuard<'_, Box<dyn DynFilter>>> {
        self.inner.lock().map_err(|_| crate::runtime_error("the filter was poisoned by an earlier failure"))
    }
}

#[pymethods]
impl PyEcbfFilter {
    #[new]
    #[pyo3(signature = (system, capacity=None, **settings))]
    fn new(
        system: SystemArg<'_>,
        capacity: Option<&Bound<'_, PyAny>>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        Self::build(system.get()?, capacity, settings)
    }

    /// The system's name.
    #[getter]
    fn system(&self) -> &'static str {
        self.system.name()
    }

    /// One control update at state ``x`` (nx,), nominal input ``u_ref`` (nu,), this
    /// cycle's ``params`` and time ``t`` (read by time-varying families only). Raises
    /// ``CbfError`` for NaN/inf input or parameters of another system or capacity (the
    /// filter is then unchanged); solver trouble is reported in the output.
    #[pyo3(signature = (x, u_ref, params, t=0.0))]
    fn update(
        &self,
        py: Python<'_>,
        x: ArrayIn<'_>,
        u_ref: ArrayIn<'_>,
        params: PyRef<'_, PyParams>,
        t: f64,
    ) -> PyResult<PyFilterOutput> {
        let (x, u_ref) = (exact("x", &x, self.system.nx())?, exact("u_ref", &u_ref, self.system.nu())?);
        let params = params.inner.as_ref();
        // Without the GIL: other Python threads run while the QP does (a solve may take
        // up to its iteration or time limit).
        py.detach(|| -> PyResult<PyFilterOutput> {
            let mut f = self.lock()?;
            // A filter built without a capacity takes its first own parameters' (once).
            if params.system() == self.system.name()
                && self.capacity_from_params.swap(false, std::sync::atomic::Ordering::Relaxed)
            {
                let counts = params_capacity(params)?;
                if !counts.is_empty() {
                    *f = self.system.filter(&counts, &f.settings())?;
                }
            }
            f.update(t, &x, &u_ref, params)?;
            Ok(PyFilterOutput::of(f.as_ref(), self.system.input_names()))
        })
    }

    /// What the filter falls back to now for ``u_ref``: the last QP-solved input, else
    /// ``u_ref``, clipped to the input box.
    fn fallback_input<'py>(&self, py: Python<'py>, u_ref: ArrayIn<'py>) -> PyResult<Array1Out<'py>> {
        let u_ref = exact("u_ref", &u_ref, self.system.nu())?;
        let mut out = vec![0.0; u_ref.len()];
        self.lock()?.fallback_input(&u_ref, &mut out)?;
        Ok(vector(py, &out))
    }

    /// The last update's result.
    #[getter]
    fn output(&self) -> PyResult<PyFilterOutput> {
        let f = self.lock()?;
        Ok(PyFilterOutput::of(f.as_ref(), self.system.input_names()))
    }

    /// Number of rows (fixed by the capacity).
    #[getter]
    fn row_count(&self) -> PyResult<usize> {
        Ok(self.lock()?.layout().len())
    }

    /// Per row ``(family, member or None, instance, row name)``.
    #[getter]
    fn layout(&self) -> PyResult<Vec<RowPlace>> {
        Ok(layout(self.lock()?.as_ref()))
    }

    /// Every row's ``[h, L_f h, …, L_f^r h]`` at the last update, shape (rows, highest
    /// degree + 1). Rows that did not apply keep stale values; see ``applicable``. None
    /// when a value is not finite (an update that fell back on a non-finite row).
    #[getter]
    fn lie<'py>(&self, py: Python<'py>) -> PyResult<Option<Array2Out<'py>>> {
        Ok(lie(py, self.lock()?.as_ref()))
    }

    /// Every row's ``L_g L_f^{r-1} h`` over all inputs, shape (rows, nu); None when a
    /// value is not finite.
    #[getter]
    fn lg_lf<'py>(&self, py: Python<'py>) -> PyResult<Option<Array2Out<'py>>> {
        Ok(lg(py, self.lock()?.as_ref(), self.system.nu()))
    }

    /// Whether each row applied at the last update (its instance was present).
    #[getter]
    fn applicable(&self) -> PyResult<Vec<bool>> {
        Ok(applicable(self.lock()?.as_ref()))
    }

    /// Whether each row was culled at the last update: its family's lower bound was above
    /// the activation threshold, so the row was not evaluated (its ``h`` holds that bound)
    /// and could not take part. All False with ``cull_far_rows=False``.
    #[getter]
    fn culled(&self) -> PyResult<Vec<bool>> {
        Ok(row_flags(self.lock()?.as_ref(), |r| r.culled))
    }

    /// Whether each row took part in the last QP (applicable and below its activation).
    #[getter]
    fn active(&self) -> PyResult<Vec<bool>> {
        Ok(self.lock()?.active().to_vec())
    }

    /// Per row, at the last returned input: by how much it is missed, ``max(0, −(a·u +
    /// b))`` in the row's units (0 for inactive rows).
    #[getter]
    fn slack<'py>(&self, py: Python<'py>) -> PyResult<Array1Out<'py>> {
        Ok(vector(py, self.lock()?.delta()))
    }

    /// Per row: the margin the last update asked of it at the sample to certify the period
    /// (``a·u + b >= margin``, in the row's units; all 0 without ``sample_period``).
    #[getter]
    fn margins<'py>(&self, py: Python<'py>) -> PyResult<Array1Out<'py>> {
        Ok(vector(py, self.lock()?.margins()))
    }

    /// Per family name: the ``poles``, ``priority`` and ``activation`` in use.
    #[getter]
    #[allow(clippy::type_complexity)] // Python's view: {family: (poles, priority, activation)}
    fn family_settings(&self) -> PyResult<HashMap<&'static str, (Vec<f64>, u8, f64)>> {
        let s = self.lock()?.settings();
        Ok(self
            .system
            .families()
            .iter()
            .zip(&s.families)
            .map(|(f, p)| (f.name, (p.poles.as_slice().to_vec(), p.priority, p.activation)))
            .collect())
    }

    /// The solver settings in use: ``backend``, ``dense_max_steps``, ``dense_max_work``, ``eps_abs``,
    /// ``eps_rel``, ``max_iter``, ``polish`` and ``time_limit_us`` (None: no limit), as the
    /// keywords of the same names set them.
    #[getter]
    fn solver_settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.lock()?.settings().solver;
        let d = PyDict::new(py);
        d.set_item("backend", s.backend.name())?;
        d.set_item("dense_max_steps", s.dense_max_steps)?;
        d.set_item("dense_max_work", s.dense_max_work)?;
        d.set_item("eps_abs", s.eps_abs)?;
        d.set_item("eps_rel", s.eps_rel)?;
        d.set_item("max_iter", s.max_iter)?;
        d.set_item("polish", s.polish)?;
        d.set_item("time_limit_us", s.time_limit.map(|t| t.as_secs_f64() * 1e6))?;
        Ok(d)
    }

    /// The most one update of this filter can do, from its rows and settings alone (any
    /// state, rows and history): a dict of ``qp_solves``, ``dense_trips`` and
    /// ``osqp_iterations`` (each update's ``output.work`` is within them), ``row_ops`` (one
    /// row evaluation's floating-point operations as the generated kernels state them; None
    /// where they state none), ``enclosures`` (the certificate's; 0 without it) and
    /// ``interval_ops`` (their interval operations; 0 without the certificate, None where
    /// not stated). Given a ``calibration`` (what ``calibrate`` returned), also
    /// ``cpu_time_us``: the bound in CPU time on that machine, None where a count is not
    /// stated.
    #[pyo3(signature = (calibration=None))]
    fn worst_case<'py>(
        &self,
        py: Python<'py>,
        calibration: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let w = self.lock()?.worst_case();
        let d = PyDict::new(py);
        d.set_item("qp_solves", w.qp_solves)?;
        d.set_item("dense_trips", w.dense_trips)?;
        d.set_item("osqp_iterations", w.osqp_iterations)?;
        d.set_item("row_ops", w.row_ops.map(|o| o.total()))?;
        d.set_item("enclosures", w.enclosures)?;
        d.set_item("interval_ops", w.interval_ops.map(|o| o.total()))?;
        if let Some(c) = calibration {
            let rate = |key: &str| -> PyResult<f64> {
                let value: f64 = c
                    .get_item(key)?
                    .ok_or_else(|| {
                        crate::value_error(format!("calibration: no '{key}' (pass what calibrate returned)"))
                    })?
                    .extract()?;
                if value.is_finite() && value >= 0.0 {
                    Ok(value)
                } else {
                    Err(crate::value_error(format!("calibration: '{key}' is {value}, not a finite rate ≥ 0")))
                }
            };
            let c = cbfgen::filter::Calibration {
                ns_per_dense_trip: rate("ns_per_dense_trip")?,
                ns_per_osqp_iteration: rate("ns_per_osqp_iteration")?,
                ns_per_row_op: rate("ns_per_row_op")?,
                ns_per_interval_op: rate("ns_per_interval_op")?,
            };
            d.set_item("cpu_time_us", w.micros(&c))?;
        }
        Ok(d)
    }

    /// This machine's rates for this filter's work: ns per dense-solver trip on random QPs
    /// of its size, per OSQP iteration on its own sparsity, per operation of its own row
    /// evaluation at ``x`` and ``params`` (nothing culled), per interval operation of its
    /// rows enclosed at ``x`` (with ``sample_period``; else 0), each the slowest seen. A dict
    /// of ``ns_per_dense_trip``, ``ns_per_osqp_iteration``, ``ns_per_row_op`` and
    /// ``ns_per_interval_op``, for
    /// ``worst_case(calibration=...)``. Takes a second or so: not for the control loop.
    #[pyo3(signature = (x, params, t=0.0))]
    fn calibrate<'py>(
        &self,
        py: Python<'py>,
        x: ArrayIn<'py>,
        params: PyRef<'py, PyParams>,
        t: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let x = exact("x", &x, self.system.nx())?;
        let params = params.inner.as_ref();
        let c =
            py.detach(|| -> PyResult<cbfgen::filter::Calibration> { Ok(self.lock()?.calibrate(t, &x, params)?) })?;
        let d = PyDict::new(py);
        d.set_item("ns_per_dense_trip", c.ns_per_dense_trip)?;
        d.set_item("ns_per_osqp_iteration", c.ns_per_osqp_iteration)?;
        d.set_item("ns_per_row_op", c.ns_per_row_op)?;
        d.set_item("ns_per_interval_op", c.ns_per_interval_op)?;
        Ok(d)
    }

    fn __repr__(&self) -> PyResult<String> {
        let f = self.lock()?;
        Ok(format!(
            "EcbfFilter('{}', rows={}, last_source='{}')",
            self.system.name(),
            f.layout().len(),
            f.output().source.name()
        ))
    }
}
