//! ANYmal C's whole-body controller from Python (`cbfgen.anymal`): the controller, its
//! trot-in-place reference and the standing state, for a plant Python drives (MuJoCo).

use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::PyResult;

use super::convert::{fixed, matrix, rows, shaped, values, vector, Array1Out, Array2Out, ArrayIn};
use cbfgen::nalgebra::Matrix3;
use cbfgen::qp::hierarchy::LevelStatus;
use cbfgen_anymal::gait::{standing_on_the_ground, Trot};
use cbfgen_anymal::wbc::{FootReference, WbcReference, WbcSettings, WholeBodyController, FEET};
use cbfgen_anymal::wbc_generated::{self as gen, Capacity, FootRegionParams, Params, NX};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ANYMAL_LEGS", gen::LEGS.to_vec())?;
    m.add("ANYMAL_JOINT_NAMES", gen::JOINT_NAMES.to_vec())?;
    m.add("ANYMAL_TOTAL_MASS", gen::TOTAL_MASS)?;
    m.add("ANYMAL_FOOT_RADIUS", gen::FOOT_RADIUS)?;
    m.add_function(wrap_pyfunction!(anymal_standing, m)?)?;
    m.add_function(wrap_pyfunction!(anymal_trot, m)?)?;
    m.add_class::<PyWholeBodyController>()?;
    Ok(())
}

/// The SRDF's standing joints, the trunk level at the height where the feet touch z = 0,
/// at rest: the ``anymal_wbc`` state, shape (42,).
#[pyfunction]
fn anymal_standing(py: Python<'_>) -> Array1Out<'_> {
    vector(py, &standing_on_the_ground())
}

/// The trot at time ``t`` [s] (cbfgen_anymal::gait::Trot; ``velocity`` (2,) world x, y
/// [m/s], zero for a trot in place): ``(stance (4,) bools, trunk position (3,), trunk
/// velocity (3,), foot positions (4, 3), velocities (4, 3), accelerations (4, 3))``.
#[pyfunction]
#[pyo3(signature = (t, swing, lift, reach, home, trunk, velocity = None))]
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
fn anymal_trot<'py>(
    py: Python<'py>,
    t: f64,
    swing: f64,
    lift: f64,
    reach: f64,
    home: ArrayIn<'py>,
    trunk: ArrayIn<'py>,
    velocity: Option<ArrayIn<'py>>,
) -> PyResult<(Vec<bool>, Array1Out<'py>, Array1Out<'py>, Array2Out<'py>, Array2Out<'py>, Array2Out<'py>)> {
    let velocity = velocity.map(|v| fixed::<2>("velocity", &v)).transpose()?.unwrap_or([0.0; 2]);
    let home = feet_array("home", &home)?;
    let gait = Trot { swing, lift, reach, home, trunk: fixed::<3>("trunk", &trunk)?, velocity };
    let reference = gait.reference(t);
    let [p, v, a] = [0, 1, 2].map(|k| {
        reference.feet.map(|f| match k {
            0 => f.position,
            1 => f.velocity,
            _ => f.acceleration,
        })
    });
    Ok((
        reference.stance.to_vec(),
        vector(py, &reference.trunk_position),
        vector(py, &reference.trunk_velocity),
        matrix(py, &p),
        matrix(py, &v),
        matrix(py, &a),
    ))
}

fn feet_array(what: &'static str, a: &ArrayIn<'_>) -> PyResult<[[f64; 3]; FEET]> {
    let flat = shaped(what, a, &[FEET, 3])?;
    Ok(std::array::from_fn(|f| std::array::from_fn(|k| flat[3 * f + k])))
}

/// Seed 004's hierarchical whole-body controller on ANYmal C (docs/anymal.md): torques
/// from a trunk motion, swing-foot motions and contact forces, the swing feet kept in
/// their foothold half-spaces by the CBF at priority 0.
#[pyclass(name = "WholeBodyController", module = "cbfgen.anymal")]
struct PyWholeBodyController {
    inner: WholeBodyController,
    footholds: Params,
}

#[pymethods]
impl PyWholeBodyController {
    /// ``half_spaces`` per foot at most; the gains as in ``WbcSettings`` (pairs are
    /// stiffness, damping); ``integral_gain`` is eq. 27's ``K_I``.
    #[new]
    #[pyo3(signature = (half_spaces = 4, friction = 0.7, min_normal_force = 5.0, trunk_position_gains = (400.0, 40.0),
                        trunk_orientation_gains = (400.0, 40.0), swing_gains = (900.0, 60.0), integral_gain = 0.0))]
    fn new(
        half_spaces: usize,
        friction: f64,
        min_normal_force: f64,
        trunk_position_gains: (f64, f64),
        trunk_orientation_gains: (f64, f64),
        swing_gains: (f64, f64),
        integral_gain: f64,
    ) -> PyResult<Self> {
        let settings = WbcSettings {
            friction,
            min_normal_force,
            trunk_position_gains,
            trunk_orientation_gains,
            swing_gains,
            integral_gain,
            ..WbcSettings::default()
        };
        let capacity = Capacity { foot_region: [half_spaces; FEET] };
        Ok(Self { inner: WholeBodyController::new(capacity, settings)?, footholds: Params::new(capacity)? })
    }

    /// Replace foot ``foot``'s region (index in ``ANYMAL_LEGS``) by the half-spaces
    /// ``n · c ≤ d``: ``normals`` shape (k, 3), ``offsets`` shape (k,); none clears it.
    fn set_footholds(&mut self, foot: usize, normals: ArrayIn<'_>, offsets: ArrayIn<'_>) -> PyResult<()> {
        if foot >= FEET {
            return Err(crate::value_error(format!("no foot {foot}: feet are 0..4, {:?}", gen::LEGS)));
        }
        let member = &mut self.footholds.foot_region[foot];
        let normals = rows::<3>("normals", &normals, member.capacity())?;
        let offsets = values("offsets", &offsets, member.capacity())?;
        if normals.len() != offsets.len() {
            return Err(crate::value_error(format!("{} normals but {} offsets", normals.len(), offsets.len())));
        }
        let mut fresh = member.clone();
        fresh.clear();
        for (normal, offset) in normals.into_iter().zip(offsets) {
            fresh.push(FootRegionParams { normal: normal.into(), offset })?;
        }
        *member = fresh;
        Ok(())
    }

    /// One cycle at state ``x`` (shape (42,), the ``anymal_wbc`` layout) towards the
    /// reference: ``stance`` (4 bools), the trunk's pose and world twist, each swing foot's
    /// position, velocity and acceleration (shape (4, 3) each, world), and ``forces``
    /// (4, 3) for the stance feet (``None``: the weight shared). ``dt`` [s] since the last
    /// cycle. Returns a dict: ``torques`` (12,), ``wbc_torques``, ``accelerations`` (18,),
    /// ``forces`` (4, 3), ``relaxed`` (4,) (each foot's largest CBF slack), ``solved``,
    /// ``residuals`` (3,) and ``status`` (3,) per priority.
    #[pyo3(signature = (x, stance, trunk_position, trunk_rotation, trunk_velocity, trunk_angular_velocity,
                        foot_positions, foot_velocities, foot_accelerations, forces = None, dt = 2.5e-3))]
    #[allow(clippy::too_many_arguments)]
    fn update<'py>(
        &mut self,
        py: Python<'py>,
        x: ArrayIn<'py>,
        stance: [bool; FEET],
        trunk_position: ArrayIn<'py>,
        trunk_rotation: ArrayIn<'py>,
        trunk_velocity: ArrayIn<'py>,
        trunk_angular_velocity: ArrayIn<'py>,
        foot_positions: ArrayIn<'py>,
        foot_velocities: ArrayIn<'py>,
        foot_accelerations: ArrayIn<'py>,
        forces: Option<ArrayIn<'py>>,
        dt: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let x = fixed::<NX>("x", &x)?;
        let rotation = shaped("trunk_rotation", &trunk_rotation, &[3, 3])?;
        let (p, v, a) = (
            feet_array("foot_positions", &foot_positions)?,
            feet_array("foot_velocities", &foot_velocities)?,
            feet_array("foot_accelerations", &foot_accelerations)?,
        );
        let mut reference = WbcReference {
            stance,
            trunk_position: fixed::<3>("trunk_position", &trunk_position)?,
            trunk_rotation: Matrix3::from_row_slice(&rotation),
            trunk_velocity: fixed::<3>("trunk_velocity", &trunk_velocity)?,
            trunk_angular_velocity: fixed::<3>("trunk_angular_velocity", &trunk_angular_velocity)?,
            trunk_acceleration: [0.0; 3],
            trunk_angular_acceleration: [0.0; 3],
            feet: std::array::from_fn(|f| FootReference { position: p[f], velocity: v[f], acceleration: a[f] }),
            forces: [[0.0; 3]; FEET],
        };
        match forces {
            Some(f) => reference.forces = feet_array("forces", &f)?,
            None => reference.share_weight(),
        }
        let out = self.inner.update(&x, &reference, &self.footholds, dt)?;
        let dict = PyDict::new(py);
        dict.set_item("torques", vector(py, &out.torques))?;
        dict.set_item("wbc_torques", vector(py, &out.wbc_torques))?;
        dict.set_item("accelerations", vector(py, &out.accelerations))?;
        dict.set_item("forces", matrix(py, &out.forces))?;
        dict.set_item("relaxed", vector(py, &out.relaxed))?;
        dict.set_item("solved", out.solved)?;
        dict.set_item("residuals", vector(py, &out.levels.map(|l| l.residual)))?;
        let status = out.levels.map(|l| match l.status {
            LevelStatus::Solved => "solved".to_string(),
            LevelStatus::Skipped => "skipped".to_string(),
            LevelStatus::Failed(s) => format!("failed: {s:?}"),
        });
        dict.set_item("status", status.to_vec())?;
        Ok(dict)
    }
}
