//! The generated kernels: SSAT variants, every constraint family's rows, the dynamics
//! and the world kinematics. Inputs are validated (finite, proper rotations, positive
//! sizes) before any kernel runs; the kernels themselves are the generated ones.

use nalgebra::{Matrix3, Rotation3, Vector3};
use pyo3::prelude::*;

use super::convert::{choice, fixed, matrix, matrix_from_fn, vector, Array1Out, Array2Out, ArrayIn, LegArg};
use crate::error::{finite, CbfError};
use crate::generated::tachyon3 as gen;
use crate::ssat::{SmoothAbs, SmoothMax, SmoothParams};
use crate::systems::tachyon3::catalog::{EdgeCuboid, HalfPlane, RELATIVE_DEGREE};
use crate::systems::tachyon3::model::{self, State, NU, NX};
use crate::OrientedBox;

/// The SSAT variants by name (Table I of the paper: smooth max × smooth |.|).
const SSAT_VARIANTS: [(&str, SmoothMax, SmoothAbs); 4] = [
    ("lse_xtanh", SmoothMax::Lse, SmoothAbs::XTanh),
    ("lse_sqrt", SmoothMax::Lse, SmoothAbs::Sqrt),
    ("boltzmann_xtanh", SmoothMax::Boltzmann, SmoothAbs::XTanh),
    ("boltzmann_sqrt", SmoothMax::Boltzmann, SmoothAbs::Sqrt),
];

type Rows<'py> = (Array2Out<'py>, Array2Out<'py>);

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SSAT_VARIANTS", SSAT_VARIANTS.map(|v| v.0).to_vec())?;
    m.add("JOINT_LIMIT_ROWS", gen::JOINT_LIMITS_LF_ROW_NAMES.to_vec())?;
    m.add_function(wrap_pyfunction!(ssat, m)?)?;
    m.add_function(wrap_pyfunction!(ssat_derivatives, m)?)?;
    m.add_function(wrap_pyfunction!(ssat_margin, m)?)?;
    m.add_function(wrap_pyfunction!(joint_limits, m)?)?;
    m.add_function(wrap_pyfunction!(foot_height, m)?)?;
    m.add_function(wrap_pyfunction!(stability, m)?)?;
    m.add_function(wrap_pyfunction!(body_edge, m)?)?;
    m.add_function(wrap_pyfunction!(toe_edge, m)?)?;
    m.add_function(wrap_pyfunction!(foothold, m)?)?;
    m.add_function(wrap_pyfunction!(sine_barrier, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics_f, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics_g, m)?)?;
    m.add_function(wrap_pyfunction!(xdot, m)?)?;
    m.add_function(wrap_pyfunction!(world_kinematics, m)?)?;
    m.add_function(wrap_pyfunction!(standard_posture, m)?)?;
    Ok(())
}

// ------------------------------------------------------------------ conversion
/// A state in the kernels' domain: finite, every |entry| ≤ `model::STATE_LIMIT`.
pub fn state(x: &ArrayIn<'_>) -> PyResult<State> {
    let x = fixed::<NX>("x", x)?;
    model::validate_state(&x)?;
    Ok(x)
}

pub fn input(what: &str, u: &ArrayIn<'_>) -> PyResult<model::Input> {
    let u = fixed::<NU>(what, u)?;
    for &v in &u {
        finite("input entry", v)?;
    }
    Ok(u)
}

/// A validated box from centre, rotation (9 values, row-major) and half extents.
pub fn oriented_box(center: &ArrayIn<'_>, rotation: &ArrayIn<'_>, half: &ArrayIn<'_>) -> PyResult<OrientedBox> {
    let c = fixed::<3>("centre", center)?;
    let r = super::convert::rotation("rotation", rotation)?;
    let h = fixed::<3>("half extents", half)?;
    Ok(OrientedBox::new(
        Vector3::from(c),
        Rotation3::from_matrix_unchecked(Matrix3::from_row_slice(&r)),
        Vector3::from(h),
    )?)
}

/// Kernel rows as numpy: `lie` (rows × 3: h, L_f h, L_f² h) and `lg_lf` scattered onto
/// all NU input columns. A row with a NaN or infinite entry (degenerate geometry such as
/// a toe exactly at its hip, or a state far outside the model's range) raises
/// [`CbfError::NonFiniteRow`] instead of reaching Python.
fn rows_out<'py, const R: usize, const C: usize>(
    py: Python<'py>,
    (lie, lg): ([[f64; RELATIVE_DEGREE + 1]; R], [[f64; C]; R]),
    columns: &[usize],
) -> PyResult<Rows<'py>> {
    for (row, (l, g)) in lie.iter().zip(&lg).enumerate() {
        if !l.iter().chain(g).all(|v| v.is_finite()) {
            return Err(CbfError::NonFiniteRow { row }.into());
        }
    }
    let dense = matrix_from_fn(py, R, NU, |i, j| columns.iter().position(|&c| c == j).map_or(0.0, |k| lg[i][k]));
    Ok((matrix(py, &lie), dense))
}

/// `values`, or [`CbfError::NonFinite`] naming `what` if any of them is NaN or infinite:
/// no kernel output reaches Python unless it is finite.
fn all_finite<'a>(what: &'static str, values: impl IntoIterator<Item = &'a f64>) -> Result<(), CbfError> {
    values.into_iter().try_for_each(|&v| finite(what, v).map(drop))
}

fn ssat_params(variant: &str, alpha: f64, alpha_rot: f64) -> PyResult<SmoothParams> {
    let names = SSAT_VARIANTS.map(|v| v.0);
    let (_, max, abs) = SSAT_VARIANTS[choice("SSAT variant", variant, &names)?];
    Ok(SmoothParams::new(alpha, alpha_rot)?.with_variant(max, abs))
}

// ------------------------------------------------------------------------ SSAT
/// Smooth SAT value h of boxes A and B (> 0 apart, < 0 overlapping).
///
/// Rotations are 9 values, row-major (columns = the box's axes in the world frame), or
/// a 3×3 array. ``variant`` is one of ``SSAT_VARIANTS``.
#[pyfunction]
#[pyo3(signature = (p_a, r_a, half_a, p_b, r_b, half_b, alpha=200.0, alpha_rot=200.0, variant="lse_xtanh"))]
#[allow(clippy::too_many_arguments)]
fn ssat(
    p_a: ArrayIn<'_>,
    r_a: ArrayIn<'_>,
    half_a: ArrayIn<'_>,
    p_b: ArrayIn<'_>,
    r_b: ArrayIn<'_>,
    half_b: ArrayIn<'_>,
    alpha: f64,
    alpha_rot: f64,
    variant: &str,
) -> PyResult<f64> {
    let (a, b) = (oriented_box(&p_a, &r_a, &half_a)?, oriented_box(&p_b, &r_b, &half_b)?);
    Ok(finite("SSAT value", crate::ssat::ssat(&a, &b, &ssat_params(variant, alpha, alpha_rot)?))?)
}

/// ``(h, gradient, hessian)``: the smooth SAT value with its gradient (3,) and Hessian
/// (3, 3) with respect to box B's centre.
#[pyfunction]
#[pyo3(signature = (p_a, r_a, half_a, p_b, r_b, half_b, alpha=200.0, alpha_rot=200.0, variant="lse_xtanh"))]
#[allow(clippy::too_many_arguments)]
fn ssat_derivatives<'py>(
    py: Python<'py>,
    p_a: ArrayIn<'py>,
    r_a: ArrayIn<'py>,
    half_a: ArrayIn<'py>,
    p_b: ArrayIn<'py>,
    r_b: ArrayIn<'py>,
    half_b: ArrayIn<'py>,
    alpha: f64,
    alpha_rot: f64,
    variant: &str,
) -> PyResult<(f64, Array1Out<'py>, Array2Out<'py>)> {
    let (a, b) = (oriented_box(&p_a, &r_a, &half_a)?, oriented_box(&p_b, &r_b, &half_b)?);
    let d = crate::ssat::ssat_with_derivatives(&a, &b, &ssat_params(variant, alpha, alpha_rot)?);
    finite("SSAT value", d.value)?;
    all_finite("SSAT gradient", d.gradient.iter())?;
    all_finite("SSAT Hessian", d.hessian.iter())?;
    let hessian = matrix_from_fn(py, 3, 3, |i, j| d.hessian[(i, j)]);
    Ok((d.value, vector(py, d.gradient.as_slice()), hessian))
}

/// The certified margin m: ``ssat(...) - m >= 0`` proves the exact boxes do not overlap.
/// It depends on the sizes and the smoothing only.
#[pyfunction]
#[pyo3(signature = (half_a, half_b, alpha=200.0, alpha_rot=200.0, variant="lse_xtanh"))]
fn ssat_margin(half_a: ArrayIn<'_>, half_b: ArrayIn<'_>, alpha: f64, alpha_rot: f64, variant: &str) -> PyResult<f64> {
    let box_of = |half: &ArrayIn<'_>| -> PyResult<OrientedBox> {
        Ok(OrientedBox::axis_aligned(Vector3::zeros(), Vector3::from(fixed::<3>("half extents", half)?))?)
    };
    let (a, b) = (box_of(&half_a)?, box_of(&half_b)?);
    Ok(finite("SSAT margin", crate::ssat::certified_margin(&a, &b, &ssat_params(variant, alpha, alpha_rot)?))?)
}

// -------------------------------------------------------------------- families
/// The four joint-limit rows of ``leg`` (knee_min, knee_max, hip_min, hip_max; see
/// ``JOINT_LIMIT_ROWS``): ``(lie, lg_lf)`` with ``lie[i] = [h, L_f h, L_f² h]`` and
/// ``lg_lf[i]`` = L_g L_f h over all NU inputs.
#[pyfunction]
fn joint_limits<'py>(py: Python<'py>, leg: LegArg, x: ArrayIn<'py>) -> PyResult<Rows<'py>> {
    let leg = leg.index()?;
    rows_out(py, gen::JOINT_LIMITS[leg](&state(&x)?), gen::JOINT_LIMITS_INPUT_COLUMNS[leg])
}

/// Toe ``leg``'s wheel bottom above the floor plane at height ``floor_z``: one row.
#[pyfunction]
fn foot_height<'py>(py: Python<'py>, leg: LegArg, x: ArrayIn<'py>, floor_z: f64) -> PyResult<Rows<'py>> {
    let leg = leg.index()?;
    let floor_z = finite("floor height", floor_z)?;
    rows_out(py, gen::FOOT_HEIGHT[leg](&state(&x)?, floor_z), gen::FOOT_HEIGHT_INPUT_COLUMNS[leg])
}

/// Static stability bound of eq. 13 for toe ``leg``: ``a (x_toe - x_body) + b >= 0``.
#[pyfunction]
fn stability<'py>(py: Python<'py>, leg: LegArg, x: ArrayIn<'py>, a: f64, b: f64) -> PyResult<Rows<'py>> {
    let leg = leg.index()?;
    let (a, b) = (finite("stability slope", a)?, finite("stability offset", b)?);
    rows_out(py, gen::STABILITY[leg](&state(&x)?, a, b), gen::STABILITY_INPUT_COLUMNS[leg])
}

/// The body vs one edge cuboid by the smooth SAT minus its certified margin: one row;
/// ``h >= 0`` proves the body and the cuboid do not overlap.
#[pyfunction]
fn body_edge<'py>(
    py: Python<'py>,
    x: ArrayIn<'py>,
    edge_center: ArrayIn<'py>,
    edge_rotation: ArrayIn<'py>,
    edge_half: ArrayIn<'py>,
) -> PyResult<Rows<'py>> {
    let (c, r, h) = EdgeCuboid::from_box(&oriented_box(&edge_center, &edge_rotation, &edge_half)?).kernel_args();
    rows_out(py, gen::body_edge(&state(&x)?, &c, &r, &h), &gen::BODY_EDGE_INPUT_COLUMNS)
}

/// Toe ``leg``'s sphere vs one edge cuboid by the superellipsoid of eq. 11: one row.
#[pyfunction]
fn toe_edge<'py>(
    py: Python<'py>,
    leg: LegArg,
    x: ArrayIn<'py>,
    edge_center: ArrayIn<'py>,
    edge_rotation: ArrayIn<'py>,
    edge_half: ArrayIn<'py>,
) -> PyResult<Rows<'py>> {
    let leg = leg.index()?;
    let (c, r, h) = EdgeCuboid::from_box(&oriented_box(&edge_center, &edge_rotation, &edge_half)?).kernel_args();
    // One kernel gives every toe's row; `lg` is laid out on the union of their columns.
    let (lie, lg) = gen::toe_edge(&state(&x)?, &c, &r, &h);
    rows_out(py, ([lie[leg]], [lg[leg]]), &gen::TOE_EDGE_INPUT_COLUMNS)
}

/// Toe ``leg`` inside the foothold half-plane ``normal . p_xy + offset >= 0``: one row.
#[pyfunction]
fn foothold<'py>(
    py: Python<'py>,
    leg: LegArg,
    x: ArrayIn<'py>,
    normal: ArrayIn<'py>,
    offset: f64,
) -> PyResult<Rows<'py>> {
    let leg = leg.index()?;
    // The kernel as generated, on the caller's (not normalised) normal: HalfPlane
    // validates it but stores the unit normal, which would rescale h.
    let normal = fixed::<2>("normal", &normal)?;
    HalfPlane::new(normal, offset)?;
    let rows = gen::FOOTHOLD[leg](&state(&x)?, &normal, offset);
    rows_out(py, rows, gen::FOOTHOLD_INPUT_COLUMNS[leg])
}

/// The double integrator's time-varying row ``h = q - A sin(w t) - c`` at state
/// ``x = [q, q']`` and time ``t``: ``(lie, lg_lf)`` with ``lie = [h, L_f h, L_f² h]``
/// (dh/dt terms included) and ``lg_lf = L_g L_f h`` (the one input u).
#[pyfunction]
fn sine_barrier(x: ArrayIn<'_>, t: f64, amplitude: f64, omega: f64, offset: f64) -> PyResult<([f64; 3], f64)> {
    let x = fixed::<2>("x", &x)?;
    for &v in &x {
        finite("state entry", v)?;
    }
    let args = [("time", t), ("amplitude", amplitude), ("omega", omega), ("offset", offset)];
    for (what, v) in args {
        finite(what, v)?;
    }
    let ([lie], [[lg]]) = crate::generated::double_integrator::sine_barrier(&x, t, amplitude, omega, offset);
    if !lie.iter().chain([&lg]).all(|v| v.is_finite()) {
        return Err(CbfError::NonFiniteRow { row: 0 }.into());
    }
    Ok((lie, lg))
}

// -------------------------------------------------------------------- dynamics
/// The drift f(x) of x' = f(x) + g(x) u, shape (NX,).
#[pyfunction]
fn dynamics_f<'py>(py: Python<'py>, x: ArrayIn<'py>) -> PyResult<Array1Out<'py>> {
    let f = gen::drift(&state(&x)?);
    all_finite("drift f(x)", &f)?;
    Ok(vector(py, &f))
}

/// The input matrix g(x), dense, shape (NX, NU).
#[pyfunction]
fn dynamics_g<'py>(py: Python<'py>, x: ArrayIn<'py>) -> PyResult<Array2Out<'py>> {
    let g = gen::input_matrix(&state(&x)?);
    all_finite("input matrix g(x)", g.as_flattened())?;
    Ok(matrix_from_fn(py, NX, NU, |r, c| g[r][c]))
}

/// x' = f(x) + g(x) u, shape (NX,).
#[pyfunction]
fn xdot<'py>(py: Python<'py>, x: ArrayIn<'py>, u: ArrayIn<'py>) -> PyResult<Array1Out<'py>> {
    let xdot = model::xdot(&state(&x)?, &input("u", &u)?);
    all_finite("xdot", &xdot)?;
    Ok(vector(py, &xdot))
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
    all_finite("world kinematics", center.iter().chain(rotation.as_flattened()).chain(toes.as_flattened()))?;
    Ok((vector(py, &center), matrix(py, &rotation), matrix(py, &toes)))
}

/// The standard low posture at rest at the world origin, shape (NX,).
#[pyfunction]
fn standard_posture(py: Python<'_>) -> Array1Out<'_> {
    vector(py, &model::standard_posture())
}
