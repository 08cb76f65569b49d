//! `Environment`, `EcbfFilter` and `FilterOutput` for Python.

use std::collections::HashMap;
use std::sync::{Mutex, MutexGuard};
use std::time::Duration;

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

use super::convert::{choice, fixed, matrix_from_fn, rows, values, vector, Array1Out, Array2Out, ArrayIn, LegArg};
use super::kernels::{input, oriented_box, state};
use crate::error::{finite, within, CbfError};
use crate::filter::{EcbfFilter, FilterOutput, SolverSettings};
use crate::system::Poles;
use crate::systems::tachyon3::catalog::{
    self, Capacity, EdgeCuboid, Environment, Family, HalfPlane, StabilityBound, Tachyon3Filter,
};
use crate::systems::tachyon3::model::NU;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyEnvironment>()?;
    m.add_class::<PyEcbfFilter>()?;
    m.add_class::<PyFilterOutput>()?;
    Ok(())
}

fn capacity(edges: usize, foothold_edges: Option<[usize; 6]>) -> Capacity {
    Capacity::edges(edges, foothold_edges.unwrap_or(Capacity::PAPER_WORST_CASE.foothold))
}

/// OSQP's time limit from microseconds, in `(0, SolverSettings::MAX_TIME_LIMIT]`, checked
/// here in the unit the caller gave (where `Duration::from_secs_f64` would panic on
/// 1e26 µs).
fn time_limit(us: f64) -> Result<Duration, CbfError> {
    let max_us = SolverSettings::MAX_TIME_LIMIT.as_secs_f64() * 1e6;
    if within("time_limit_us", us, 0.0, max_us, "(0, 1e6]")? == 0.0 {
        return Err(CbfError::NotPositive { what: "time_limit_us", value: us });
    }
    SolverSettings::time_limit_from_secs(us * 1e-6)
}

fn family(name: &str) -> PyResult<Family> {
    Ok(Family::ALL[choice("family", name, &Family::ALL.map(Family::name))?])
}

/// What the robot perceives this cycle: edge cuboids, floor heights, foothold polygons,
/// swing legs and stability bounds. Sized once (``edges`` cuboids, ``foothold_edges``
/// half-planes per leg); a filter only accepts an environment of its own capacity.
#[pyclass(name = "Environment", module = "cbfgen")]
#[derive(Clone)]
pub struct PyEnvironment {
    pub inner: Environment,
}

#[pymethods]
impl PyEnvironment {
    #[new]
    #[pyo3(signature = (edges=20, foothold_edges=None))]
    fn new(edges: usize, foothold_edges: Option<[usize; 6]>) -> PyResult<Self> {
        Ok(Self { inner: Environment::new(capacity(edges, foothold_edges))? })
    }

    /// ``(edges, foothold_edges)`` this environment was sized for.
    #[getter]
    fn capacity(&self) -> (usize, [usize; 6]) {
        let c = self.inner.capacity();
        (c.body_edge, c.foothold)
    }

    /// Add an edge cuboid (centre, 9-value row-major rotation, half extents).
    fn push_edge(&mut self, center: ArrayIn<'_>, rotation: ArrayIn<'_>, half_extents: ArrayIn<'_>) -> PyResult<()> {
        let b = oriented_box(&center, &rotation, &half_extents)?;
        Ok(self.inner.push_edge(EdgeCuboid::from_box(&b))?)
    }

    fn clear_edges(&mut self) {
        self.inner.clear_edges();
    }

    /// Number of edge cuboids pushed.
    #[getter]
    fn edge_count(&self) -> usize {
        self.inner.edges().len()
    }

    /// Floor height under each toe, world frame \[m\], ``LEG_NAMES`` order.
    #[getter]
    fn get_floor_z<'py>(&self, py: Python<'py>) -> Array1Out<'py> {
        vector(py, &self.inner.floors())
    }

    #[setter]
    fn set_floor_z(&mut self, values: ArrayIn<'_>) -> PyResult<()> {
        let z = fixed::<6>("floor_z", &values)?;
        for &v in &z {
            finite("floor height", v)?;
        }
        self.inner.set_floors(z);
        Ok(())
    }

    /// Which legs swing (foothold rows apply to swinging legs only).
    #[getter]
    fn get_swing(&self) -> [bool; 6] {
        self.inner.swing()
    }

    #[setter]
    fn set_swing(&mut self, values: [bool; 6]) {
        self.inner.set_swing(values);
    }

    /// Replace ``leg``'s foothold polygon: row k is ``normals[k] . p_xy + offsets[k] >= 0``,
    /// with ``normals`` of shape (k, 2) and ``offsets`` of shape (k,).
    fn set_foothold(&mut self, leg: LegArg, normals: ArrayIn<'_>, offsets: ArrayIn<'_>) -> PyResult<()> {
        let leg = leg.index()?;
        let capacity = self.inner.capacity().foothold[leg];
        let (n, b) = (rows::<2>("foothold edges", &normals, capacity)?, values("foothold edges", &offsets, capacity)?);
        if n.len() != b.len() {
            return Err(PyValueError::new_err(format!(
                "foothold: {} normals (k × 2) but {} offsets",
                n.len(),
                b.len()
            )));
        }
        let planes = n.into_iter().zip(b).map(|(n, b)| HalfPlane::new(n, b)).collect::<Result<Vec<_>, _>>()?;
        Ok(self.inner.set_foothold(leg, &planes)?)
    }

    /// ``(normals (k, 2), offsets (k,))`` of ``leg``'s foothold polygon.
    fn foothold<'py>(&self, py: Python<'py>, leg: LegArg) -> PyResult<(Array2Out<'py>, Array1Out<'py>)> {
        let planes = self.inner.foothold(leg.index()?);
        let normals = matrix_from_fn(py, planes.len(), 2, |i, j| planes[i].normal[j]);
        let offsets: Vec<f64> = planes.iter().map(|p| p.offset).collect();
        Ok((normals, vector(py, &offsets)))
    }

    /// Stability bounds of ``leg`` (eq. 13), each ``(a, b)`` for ``a (x_toe - x_body) + b >= 0``
    /// or ``None`` to leave that row out.
    #[pyo3(signature = (leg, lower=None, upper=None))]
    fn set_stability(&mut self, leg: LegArg, lower: Option<(f64, f64)>, upper: Option<(f64, f64)>) -> PyResult<()> {
        let bound = |ab: Option<(f64, f64)>| -> PyResult<Option<StabilityBound>> {
            ab.map(|(a, b)| Ok(StabilityBound { a: finite("stability slope", a)?, b: finite("stability offset", b)? }))
                .transpose()
        };
        self.inner.stability[leg.index()?] = [bound(lower)?, bound(upper)?];
        Ok(())
    }

    fn __repr__(&self) -> String {
        let swinging: Vec<&str> =
            (0..6).filter(|&l| self.inner.swing()[l]).map(|l| crate::systems::tachyon3::model::LEG_NAMES[l]).collect();
        format!(
            "Environment(edges={}/{}, floor_z={:?}, swinging={swinging:?})",
            self.inner.edges().len(),
            self.inner.capacity().body_edge,
            self.inner.floors(),
        )
    }
}

/// One update's result.
#[pyclass(name = "FilterOutput", module = "cbfgen", frozen)]
pub struct PyFilterOutput {
    out: FilterOutput<NU>,
}

#[pymethods]
impl PyFilterOutput {
    /// The input to apply, shape (NU,).
    #[getter]
    fn u<'py>(&self, py: Python<'py>) -> Array1Out<'py> {
        vector(py, &self.out.u)
    }

    /// Where ``u`` came from: "qp", "unconverged", "last_safe" or "nominal_clipped".
    #[getter]
    fn source(&self) -> &'static str {
        self.out.source.name()
    }

    /// OSQP's report ("solved", "max_iterations", ...), or None when no solve ran.
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

    /// Whether ``u`` is the exact, KKT-verified optimum of the active set ADMM found.
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

    fn __repr__(&self) -> String {
        let status = self.status().map_or_else(|| "None".to_string(), |s| format!("'{s}'"));
        format!(
            "FilterOutput(source='{}', status={status}, iterations={}, polished={}, active_rows={})",
            self.source(),
            self.out.iterations,
            if self.out.polished { "True" } else { "False" },
            self.out.active_rows
        )
    }
}

/// The ECBF-QP safety filter (OSQP). Build once; each ``update`` evaluates every row at
/// the state and returns the input closest to the nominal one that keeps every active
/// row's ECBF condition (with penalised slack). See the Rust docs of
/// ``cbfgen::filter`` for the failure policy.
#[pyclass(name = "EcbfFilter", module = "cbfgen")]
pub struct PyEcbfFilter {
    // OSQP's workspace may move between threads but not be shared; the lock makes the
    // filter usable from any Python thread.
    inner: Mutex<Tachyon3Filter>,
}

impl PyEcbfFilter {
    fn lock(&self) -> PyResult<MutexGuard<'_, Tachyon3Filter>> {
        self.inner.lock().map_err(|_| PyRuntimeError::new_err("the filter was poisoned by an earlier failure"))
    }
}

#[pymethods]
impl PyEcbfFilter {
    /// Keyword arguments override ``catalog::default_settings()``:
    /// ``activation``, ``slack_weight`` and ``poles`` map family names (``FAMILIES``) to
    /// values; ``input_weights``, ``input_min``, ``input_max`` have NU values;
    /// ``eps_abs``, ``eps_rel``, ``max_iter``, ``polish`` and ``time_limit_us`` tune OSQP.
    #[new]
    #[pyo3(signature = (edges=20, foothold_edges=None, *, activation=None, slack_weight=None, poles=None,
                        input_weights=None, input_min=None, input_max=None, eps_abs=None, eps_rel=None,
                        max_iter=None, polish=None, time_limit_us=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        edges: usize,
        foothold_edges: Option<[usize; 6]>,
        activation: Option<HashMap<String, f64>>,
        slack_weight: Option<HashMap<String, f64>>,
        poles: Option<HashMap<String, [f64; 2]>>,
        input_weights: Option<ArrayIn<'_>>,
        input_min: Option<ArrayIn<'_>>,
        input_max: Option<ArrayIn<'_>>,
        eps_abs: Option<f64>,
        eps_rel: Option<f64>,
        max_iter: Option<u32>,
        polish: Option<bool>,
        time_limit_us: Option<f64>,
    ) -> PyResult<Self> {
        let mut s = catalog::default_settings();
        for (name, v) in activation.unwrap_or_default() {
            s.family_mut(family(&name)?.index()).activation = v;
        }
        for (name, v) in slack_weight.unwrap_or_default() {
            s.family_mut(family(&name)?.index()).slack_weight = v;
        }
        for (name, v) in poles.unwrap_or_default() {
            s.family_mut(family(&name)?.index()).poles = Poles::from(v);
        }
        if let Some(w) = input_weights {
            s.input_weights = fixed::<NU>("input_weights", &w)?;
        }
        if let Some(v) = input_min {
            s.input_min = fixed::<NU>("input_min", &v)?;
        }
        if let Some(v) = input_max {
            s.input_max = fixed::<NU>("input_max", &v)?;
        }
        let solver = &mut s.solver;
        solver.eps_abs = eps_abs.unwrap_or(solver.eps_abs);
        solver.eps_rel = eps_rel.unwrap_or(solver.eps_rel);
        solver.max_iter = max_iter.unwrap_or(solver.max_iter);
        solver.polish = polish.unwrap_or(solver.polish);
        if let Some(us) = time_limit_us {
            solver.time_limit = Some(time_limit(us)?);
        }
        let filter = EcbfFilter::with_capacity(capacity(edges, foothold_edges), s)?;
        Ok(Self { inner: Mutex::new(filter) })
    }

    /// One control update for state ``x`` (NX,), nominal input ``u_ref`` (NU,) and this
    /// cycle's ``env``. Raises ``CbfError`` for NaN/inf input or an environment of another
    /// capacity (the filter is then unchanged); solver trouble is reported in the output.
    fn update(
        &self,
        py: Python<'_>,
        x: ArrayIn<'_>,
        u_ref: ArrayIn<'_>,
        env: PyRef<'_, PyEnvironment>,
    ) -> PyResult<PyFilterOutput> {
        let (x, u_ref) = (state(&x)?, input("u_ref", &u_ref)?);
        let env = &env.inner;
        // Without the GIL: other Python threads run while the QP does (a solve may take
        // up to its iteration or time limit).
        let out = py.detach(|| -> PyResult<FilterOutput<NU>> { Ok(*self.lock()?.update(&x, &u_ref, env)?) })?;
        Ok(PyFilterOutput { out })
    }

    /// What the filter falls back to now for ``u_ref``: the last QP-solved input, else
    /// ``u_ref``, clipped to the input box.
    fn fallback_input<'py>(&self, py: Python<'py>, u_ref: ArrayIn<'py>) -> PyResult<Array1Out<'py>> {
        Ok(vector(py, &self.lock()?.fallback_input(&input("u_ref", &u_ref)?)))
    }

    /// The last update's result.
    #[getter]
    fn output(&self) -> PyResult<PyFilterOutput> {
        Ok(PyFilterOutput { out: *self.lock()?.output() })
    }

    /// Number of rows (fixed by the capacity).
    #[getter]
    fn row_count(&self) -> PyResult<usize> {
        Ok(self.lock()?.slots().len())
    }

    /// Per row: ``(family, leg index or None, instance)``.
    #[getter]
    fn slots(&self) -> PyResult<Vec<(&'static str, Option<usize>, usize)>> {
        Ok(self.lock()?.slots().map(|s| (s.family.name(), s.leg, s.instance)).collect())
    }

    /// Every row's ``[h, L_f h, L_f² h]`` at the last update, shape (rows, 3). Rows that
    /// did not apply keep stale values; see ``applicable``.
    #[getter]
    fn lie<'py>(&self, py: Python<'py>) -> PyResult<Array2Out<'py>> {
        let f = self.lock()?;
        let rows = f.rows();
        Ok(matrix_from_fn(py, rows.len(), 3, |i, j| rows[i].lie[j]))
    }

    /// Every row's L_g L_f h over all inputs, shape (rows, NU).
    #[getter]
    fn lg_lf<'py>(&self, py: Python<'py>) -> PyResult<Array2Out<'py>> {
        let f = self.lock()?;
        let rows = f.rows();
        Ok(matrix_from_fn(py, rows.len(), NU, |i, j| rows[i].lg[j]))
    }

    /// Whether each row applied at the last update (its obstacle, foothold edge or bound
    /// was present).
    #[getter]
    fn applicable(&self) -> PyResult<Vec<bool>> {
        Ok(self.lock()?.rows().iter().map(|r| r.active).collect())
    }

    /// Whether each row took part in the last QP (applicable and below its activation).
    #[getter]
    fn active(&self) -> PyResult<Vec<bool>> {
        Ok(self.lock()?.active().to_vec())
    }

    /// The last QP's slack per row.
    #[getter]
    fn slack<'py>(&self, py: Python<'py>) -> PyResult<Array1Out<'py>> {
        Ok(vector(py, self.lock()?.delta()))
    }

    fn __repr__(&self) -> PyResult<String> {
        let f = self.lock()?;
        Ok(format!("EcbfFilter(rows={}, last_source='{}')", f.slots().len(), f.output().source.name()))
    }
}
