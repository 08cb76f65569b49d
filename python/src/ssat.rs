//! The smooth SAT for Python: the value, its derivatives and the certified margin of two
//! oriented boxes, for every smoothing variant. Inputs are validated (finite, proper
//! rotations, sizes in range) before anything is computed.

use nalgebra::{Matrix3, Rotation3, Vector3};
use pyo3::prelude::*;

use crate::PyResult;

use super::convert::{choice, fixed, matrix_from_fn, vector, Array1Out, Array2Out, ArrayIn};
use cbfgen::error::{finite, CbfError};
use cbfgen::ssat::{SmoothAbs, SmoothMax, SmoothParams};
use cbfgen::OrientedBox;

/// The SSAT variants by name (Table I of the paper: smooth max × smooth |.|).
const SSAT_VARIANTS: [(&str, SmoothMax, SmoothAbs); 4] = [
    ("lse_xtanh", SmoothMax::Lse, SmoothAbs::XTanh),
    ("lse_sqrt", SmoothMax::Lse, SmoothAbs::Sqrt),
    ("boltzmann_xtanh", SmoothMax::Boltzmann, SmoothAbs::XTanh),
    ("boltzmann_sqrt", SmoothMax::Boltzmann, SmoothAbs::Sqrt),
];

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SSAT_VARIANTS", SSAT_VARIANTS.map(|v| v.0).to_vec())?;
    m.add_function(wrap_pyfunction!(ssat, m)?)?;
    m.add_function(wrap_pyfunction!(ssat_derivatives, m)?)?;
    m.add_function(wrap_pyfunction!(ssat_margin, m)?)?;
    Ok(())
}

/// A validated box from centre, rotation (9 values, row-major) and half extents.
pub fn oriented_box(center: &ArrayIn<'_>, rotation: &ArrayIn<'_>, half: &ArrayIn<'_>) -> PyResult<OrientedBox> {
    let c = fixed::<3>("centre", center)?;
    let r = super::convert::shaped("rotation", rotation, &[3, 3])?; // (3, 3) or 9 row-major values
    let h = fixed::<3>("half extents", half)?;
    Ok(OrientedBox::new(
        Vector3::from(c),
        Rotation3::from_matrix_unchecked(Matrix3::from_row_slice(&r)),
        Vector3::from(h),
    )?)
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
    Ok(finite("SSAT value", cbfgen::ssat::ssat(&a, &b, &ssat_params(variant, alpha, alpha_rot)?))?)
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
    let d = cbfgen::ssat::ssat_with_derivatives(&a, &b, &ssat_params(variant, alpha, alpha_rot)?);
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
    Ok(finite("SSAT margin", cbfgen::ssat::certified_margin(&a, &b, &ssat_params(variant, alpha, alpha_rot)?))?)
}
