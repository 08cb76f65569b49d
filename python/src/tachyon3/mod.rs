//! Tachyon 3's own Python API, over the generic classes: its constants, its world
//! kinematics and standard posture, `Environment` (the generic `Params` of `tachyon3` with
//! typed helpers for edge cuboids, floors, footholds, swing legs and stability bounds) and
//! the scenarios (`Course`, `simulate`). The filter itself is the generic `EcbfFilter`.

mod sim;

use pyo3::prelude::*;

use crate::PyResult;

use super::convert::{fixed, matrix, matrix_from_fn, rows, values, vector, Array1Out, Array2Out, ArrayIn};
use super::ssat::oriented_box;
use super::system::PyParams;
use cbfgen::error::finite;
use cbfgen_tachyon3::catalog::{Capacity, EdgeCuboid, Environment, HalfPlane, StabilityBound};
use cbfgen_tachyon3::foothold::{polygon_half_planes, ToeGuide};
use cbfgen_tachyon3::generated as gen;
use cbfgen_tachyon3::model::{self, State, NX};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("LEG_NAMES", model::LEG_NAMES.to_vec())?;
    m.add("TOE_RADIUS", model::TOE_RADIUS)?;
    m.add("BODY_HALF_EXTENTS", model::BODY_HALF_EXTENTS.to_vec())?;
    m.add("NOMINAL_CLEARANCE", model::NOMINAL_CLEARANCE)?;
    m.add("KNEE_RANGE", model::KNEE_RANGE.to_vec())?;
    m.add("HIP_POSITIONS", model::HIP_POSITIONS.map(|h| h.to_vec()).to_vec())?;
    m.add("HIP_RANGES", model::HIP_RANGES.map(|r| r.to_vec()).to_vec())?;
    m.add("HIP_OUTWARD", model::HIP_OUTWARD.to_vec())?;
    m.add("TRIPODS", cbfgen_tachyon3::sim::gait::TRIPODS.map(|t| t.to_vec()).to_vec())?;
    m.add("STANCE_AXLE", cbfgen_tachyon3::sim::gait::STANCE_AXLE.map(|a| a.to_vec()).to_vec())?;
    m.add("DT", cbfgen_tachyon3::sim::DT)?;
    m.add("MAX_EDGES", Capacity::MAX_EDGES)?;
    m.add("MAX_FOOTHOLD_EDGES", Capacity::MAX_FOOTHOLD_EDGES)?;
    m.add("MAX_SIM_TIME", cbfgen_tachyon3::sim::MAX_SIM_TIME)?;
    m.add_function(wrap_pyfunction!(world_kinematics, m)?)?;
    m.add_function(wrap_pyfunction!(standard_posture, m)?)?;
    m.add_function(wrap_pyfunction!(leg_joints, m)?)?;
    m.add_function(wrap_pyfunction!(roll_clearance, m)?)?;
    m.add_class::<PyEnvironment>()?;
    sim::register(m)
}

/// A state in the kernels' domain: finite, every |entry| ≤ `STATE_LIMIT`.
pub fn state(x: &ArrayIn<'_>) -> PyResult<State> {
    let x = fixed::<NX>("x", x)?;
    model::validate_state(&x)?;
    Ok(x)
}

/// ``(body_center (3,), body_rotation (3, 3), toes (6, 3))`` in the world frame; toe rows
/// in ``LEG_NAMES`` order.
#[pyfunction]
#[allow(clippy::type_complexity)]
fn world_kinematics<'py>(
    py: Python<'py>,
    x: ArrayIn<'py>,
) -> PyResult<(Array1Out<'py>, Array2Out<'py>, Array2Out<'py>)> {
    let (center, rotation, toes) = gen::world_kinematics(&state(&x)?);
    for &v in center.iter().chain(rotation.as_flattened()).chain(toes.as_flattened()) {
        finite("world kinematics", v)?;
    }
    Ok((vector(py, &center), matrix(py, &rotation), matrix(py, &toes)))
}

/// Each leg's joints at ``x``, shape (6, 4), rows in ``LEG_NAMES`` order: knee length
/// \[m\], hip angle \[rad, positive outward\], knee rate \[m/s\], hip rate \[rad/s\] (the
/// joint-limit kernels' quantities).
#[pyfunction]
fn leg_joints<'py>(py: Python<'py>, x: ArrayIn<'py>) -> PyResult<Array2Out<'py>> {
    let joints = model::leg_joints(&state(&x)?);
    for &v in joints.as_flattened() {
        finite("leg joints", v)?;
    }
    Ok(matrix(py, &joints))
}

/// The farthest any point of the body box moves when it rolls by ``roll`` \[rad\] about
/// its own x axis \[m\]: what :meth:`Course.set_body_roll` keeps the body rows clear by.
#[pyfunction]
fn roll_clearance(roll: f64) -> PyResult<f64> {
    Ok(model::roll_clearance(finite("roll", roll)?))
}

/// The standard low posture at rest at the world origin, shape (NX,).
#[pyfunction]
fn standard_posture(py: Python<'_>) -> Array1Out<'_> {
    vector(py, &model::standard_posture())
}

use model::LEG_NAMES;

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
            crate::value_error(format!("no leg {given}: legs are 0..6 or one of {LEG_NAMES:?}"))
        })
    }
}

fn capacity(edges: usize, foothold_edges: Option<[usize; 6]>) -> Capacity {
    Capacity::edges(edges, foothold_edges.unwrap_or(Capacity::PAPER_WORST_CASE.foothold))
}

/// The generic parameters of a new environment, ready to wrap.
pub fn initializer(env: Environment) -> PyClassInitializer<PyEnvironment> {
    PyClassInitializer::from(PyParams { inner: Box::new(env) }).add_subclass(PyEnvironment)
}

/// What the robot perceives this cycle: edge cuboids, floor heights, foothold polygons,
/// swing legs and stability bounds. It is the generic ``Params`` of ``tachyon3`` (so
/// ``set``/``push``/``get`` by family work too), sized once (``edges`` cuboids,
/// ``foothold_edges`` half-planes per leg); a filter accepts only parameters of its own
/// capacity.
#[pyclass(name = "Environment", module = "cbfgen.tachyon3", extends = PyParams)]
pub struct PyEnvironment;

fn env<'a>(slf: &'a PyRef<'_, PyEnvironment>) -> PyResult<&'a Environment> {
    slf.as_super().inner.downcast_ref().ok_or_else(|| crate::runtime_error("not Tachyon 3 parameters"))
}

fn env_mut<'a>(slf: &'a mut PyRefMut<'_, PyEnvironment>) -> PyResult<&'a mut Environment> {
    slf.as_super().inner.downcast_mut().ok_or_else(|| crate::runtime_error("not Tachyon 3 parameters"))
}

#[pymethods]
impl PyEnvironment {
    #[new]
    #[pyo3(signature = (edges=20, foothold_edges=None))]
    fn new(edges: usize, foothold_edges: Option<[usize; 6]>) -> PyResult<PyClassInitializer<Self>> {
        Ok(initializer(Environment::new(capacity(edges, foothold_edges))?))
    }

    /// ``(edges, foothold_edges)`` this environment was sized for.
    #[getter]
    fn sizes(slf: PyRef<'_, Self>) -> PyResult<(usize, [usize; 6])> {
        let c = env(&slf)?.capacity();
        Ok((c.body_edge, c.foothold))
    }

    /// Add an edge cuboid (centre, rotation as 9 row-major values or 3×3, half extents):
    /// it fills the next body–edge and toe–edge instance.
    fn push_edge(
        mut slf: PyRefMut<'_, Self>,
        center: ArrayIn<'_>,
        rotation: ArrayIn<'_>,
        half_extents: ArrayIn<'_>,
    ) -> PyResult<()> {
        let b = oriented_box(&center, &rotation, &half_extents)?;
        Ok(env_mut(&mut slf)?.push_edge(EdgeCuboid::from_box(&b))?)
    }

    /// Remove every edge cuboid (their rows go inactive).
    fn clear_edges(mut slf: PyRefMut<'_, Self>) -> PyResult<()> {
        env_mut(&mut slf)?.clear_edges();
        Ok(())
    }

    /// Number of edge cuboids pushed.
    #[getter]
    fn edge_count(slf: PyRef<'_, Self>) -> PyResult<usize> {
        Ok(env(&slf)?.edges().len())
    }

    /// Floor height under each toe, world frame \[m\], ``LEG_NAMES`` order.
    #[getter]
    fn get_floor_z<'py>(slf: PyRef<'py, Self>) -> PyResult<Array1Out<'py>> {
        Ok(vector(slf.py(), &env(&slf)?.floors()))
    }

    #[setter]
    fn set_floor_z(mut slf: PyRefMut<'_, Self>, values: ArrayIn<'_>) -> PyResult<()> {
        let z = fixed::<6>("floor_z", &values)?;
        for &v in &z {
            finite("floor height", v)?;
        }
        env_mut(&mut slf)?.set_floors(z);
        Ok(())
    }

    /// Which legs swing (foothold rows apply to swinging legs only).
    #[getter]
    fn get_swing(slf: PyRef<'_, Self>) -> PyResult<[bool; 6]> {
        Ok(env(&slf)?.swing())
    }

    #[setter]
    fn set_swing(mut slf: PyRefMut<'_, Self>, values: [bool; 6]) -> PyResult<()> {
        env_mut(&mut slf)?.set_swing(values);
        Ok(())
    }

    /// Replace ``leg``'s foothold polygon: row k is ``normals[k] . p_xy + offsets[k] >= 0``,
    /// with ``normals`` of shape (k, 2) and ``offsets`` of shape (k,); each half-plane is
    /// stored with a unit normal.
    fn set_foothold(
        mut slf: PyRefMut<'_, Self>,
        leg: LegArg,
        normals: ArrayIn<'_>,
        offsets: ArrayIn<'_>,
    ) -> PyResult<()> {
        let leg = leg.index()?;
        let capacity = env_mut(&mut slf)?.capacity().foothold[leg];
        let (n, b) = (rows::<2>("foothold edges", &normals, capacity)?, values("foothold edges", &offsets, capacity)?);
        if n.len() != b.len() {
            return Err(crate::value_error(format!("foothold: {} normals (k × 2) but {} offsets", n.len(), b.len())));
        }
        let planes = n.into_iter().zip(b).map(|(n, b)| HalfPlane::new(n, b)).collect::<Result<Vec<_>, _>>()?;
        Ok(env_mut(&mut slf)?.set_foothold(leg, &planes)?)
    }

    /// Replace ``leg``'s foothold with the convex polygon ``vertices`` (shape (k, 2), world
    /// xy, either winding), shrunk by ``inset`` metres (the toe radius and a margin, so a
    /// toe centre inside keeps that far from every side). Raises ``ValueError`` for a
    /// polygon that is not convex, has no area or vanishes under the inset.
    #[pyo3(signature = (leg, vertices, inset=0.0))]
    fn set_foothold_polygon(
        mut slf: PyRefMut<'_, Self>,
        leg: LegArg,
        vertices: ArrayIn<'_>,
        inset: f64,
    ) -> PyResult<()> {
        let leg = leg.index()?;
        let capacity = env_mut(&mut slf)?.capacity().foothold[leg];
        let planes = polygon_half_planes(&rows::<2>("foothold polygon vertices", &vertices, capacity)?, inset)?;
        Ok(env_mut(&mut slf)?.set_foothold(leg, &planes)?)
    }

    /// Each cycle, for a swing leg whose toe centre is at world ``toe`` (x, y): inside its
    /// foothold, the foothold rows keep it (returns ``None``); outside, the rows go off
    /// and the foothold pull (a CLF) brings it to the polygon's nearest point ``margin``
    /// metres inside (returns ``(target, outside)``, ``outside`` in metres).
    #[pyo3(signature = (leg, toe, margin=0.01))]
    fn guide_toe(
        mut slf: PyRefMut<'_, Self>,
        leg: LegArg,
        toe: [f64; 2],
        margin: f64,
    ) -> PyResult<Option<([f64; 2], f64)>> {
        let leg = leg.index()?;
        Ok(match env_mut(&mut slf)?.guide_toe(leg, toe, margin)? {
            ToeGuide::Kept => None,
            ToeGuide::Pulled { target, outside } => Some((target, outside)),
        })
    }

    /// ``(target, direction)`` of ``leg``'s foothold pull, or ``None`` while it is off.
    fn foothold_pull(slf: PyRef<'_, Self>, leg: LegArg) -> PyResult<Option<([f64; 2], [f64; 2])>> {
        Ok(env(&slf)?.foothold_pull(leg.index()?).map(|p| (p.target.into(), p.direction.into())))
    }

    /// ``(normals (k, 2), offsets (k,))`` of ``leg``'s foothold polygon.
    fn foothold<'py>(slf: PyRef<'py, Self>, leg: LegArg) -> PyResult<(Array2Out<'py>, Array1Out<'py>)> {
        let planes = env(&slf)?.foothold(leg.index()?);
        let py = slf.py();
        let normals = matrix_from_fn(py, planes.len(), 2, |i, j| planes[i].normal[j]);
        let offsets: Vec<f64> = planes.iter().map(|p| p.offset).collect();
        Ok((normals, vector(py, &offsets)))
    }

    /// Stability bounds of ``leg`` (eq. 13), each ``(a, b)`` for ``a (x_toe - x_body) + b >= 0``
    /// or ``None`` to leave that row out.
    #[pyo3(signature = (leg, lower=None, upper=None))]
    fn set_stability(
        mut slf: PyRefMut<'_, Self>,
        leg: LegArg,
        lower: Option<(f64, f64)>,
        upper: Option<(f64, f64)>,
    ) -> PyResult<()> {
        let bound = |ab: Option<(f64, f64)>| -> PyResult<Option<StabilityBound>> {
            ab.map(|(a, b)| Ok(StabilityBound { a: finite("stability slope", a)?, b: finite("stability offset", b)? }))
                .transpose()
        };
        let bounds = [bound(lower)?, bound(upper)?];
        env_mut(&mut slf)?.stability[leg.index()?] = bounds;
        Ok(())
    }

    fn __repr__(slf: PyRef<'_, Self>) -> PyResult<String> {
        let e = env(&slf)?;
        let swinging: Vec<&str> = (0..6).filter(|&l| e.swing()[l]).map(|l| model::LEG_NAMES[l]).collect();
        Ok(format!(
            "Environment(edges={}/{}, floor_z={:?}, swinging={swinging:?})",
            e.edges().len(),
            e.capacity().body_edge,
            e.floors(),
        ))
    }
}
