//! ANYmal C's whole-body controller from Python (`cbfgen.anymal`): the controller, its
//! trot-in-place reference and the standing state, for a plant Python drives (MuJoCo).

use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::PyResult;

use super::convert::{fixed, matrix, matrix_from_fn, rows, shaped, values, vector, Array1Out, Array2Out, ArrayIn};
use cbfgen::nalgebra::Matrix3;
use cbfgen::qp::hierarchy::LevelStatus;
use cbfgen_anymal::gait::{standing_on_the_ground, Trot};
use cbfgen_anymal::stones::{SteppingStones, StoneField, StoneLayout};
use cbfgen_anymal::walk::{Controller, FootholdBarrier, LayeredController, WalkMeter, WalkSettings, WholeBodyBarrier};
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
    m.add_class::<PySteppingStones>()?;
    m.add_class::<PyStoneWalk>()?;
    m.add("ANYMAL_CONTROLLERS", Controller::ALL.map(Controller::name).to_vec())?;
    m.add("ANYMAL_FOOTHOLD_BARRIERS", FootholdBarrier::ALL.map(FootholdBarrier::name).to_vec())?;
    m.add("ANYMAL_WHOLE_BODY_BARRIERS", WholeBodyBarrier::ALL.map(WholeBodyBarrier::name).to_vec())?;
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
    let gait = Trot { velocity, ..Trot::in_place(swing, lift, reach, home, fixed::<3>("trunk", &trunk)?) };
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
    /// ``growth = (m, m', m'')`` at time ``at`` [s] loosens each to ``n · c ≤ d + m(t)``
    /// (seed 004's eq. 24 set, shrinking onto the region as a swing ends; set it each
    /// cycle, with ``at`` the cycle's ``t``); ``None``: the region itself.
    #[pyo3(signature = (foot, normals, offsets, growth = None, at = 0.0))]
    fn set_footholds(
        &mut self,
        foot: usize,
        normals: ArrayIn<'_>,
        offsets: ArrayIn<'_>,
        growth: Option<(f64, f64, f64)>,
        at: f64,
    ) -> PyResult<()> {
        if foot >= FEET {
            return Err(crate::value_error(format!("no foot {foot}: feet are 0..4, {:?}", gen::LEGS)));
        }
        let member = &mut self.footholds.foot_region[foot];
        let normals = rows::<3>("normals", &normals, member.capacity())?;
        let offsets = values("offsets", &offsets, member.capacity())?;
        if normals.len() != offsets.len() {
            return Err(crate::value_error(format!("{} normals but {} offsets", normals.len(), offsets.len())));
        }
        let growth = growth.map_or([0.0; 3], |(m, rate, curvature)| [m, rate, curvature]);
        let mut fresh = member.clone();
        fresh.clear();
        for (normal, offset) in normals.into_iter().zip(offsets) {
            fresh.push(FootRegionParams { normal: normal.into(), offset, growth: growth.into(), at })?;
        }
        *member = fresh;
        Ok(())
    }

    /// One cycle at state ``x`` (shape (42,), the ``anymal_wbc`` layout) towards the
    /// reference: ``stance`` (4 bools), the trunk's pose and world twist, each swing foot's
    /// position, velocity and acceleration (shape (4, 3) each, world), and ``forces``
    /// (4, 3) for the stance feet (``None``: the weight shared). ``dt`` [s] since the last
    /// cycle, ``t`` [s] the time (for grown footholds). Returns a dict: ``torques`` (12,),
    /// ``wbc_torques``, ``accelerations`` (18,),
    /// ``forces`` (4, 3), ``relaxed`` (4,) (each foot's largest CBF slack), ``solved``,
    /// ``residuals`` (3,) and ``status`` (3,) per priority.
    #[pyo3(signature = (x, stance, trunk_position, trunk_rotation, trunk_velocity, trunk_angular_velocity,
                        foot_positions, foot_velocities, foot_accelerations, forces = None, dt = 2.5e-3, t = 0.0))]
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
        t: f64,
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
        let out = self.inner.update(t, &x, &reference, &self.footholds, dt)?;
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

/// Seed 004's stepping stones (``cbfgen_anymal::stones``): square stones along a forward
/// trot, displaced at random from a seeded stream, the trunk stopping on the last ones.
/// ``layout="gait"`` lays one under each foothold the trot asks for (displacements
/// ±10/15/20 mm by default); ``"rows"`` lays each side's row ``pitch`` apart, away from
/// the trot's footholds (±30/20/20 mm by default). ``stones`` is shape (n, 4): each top's
/// centre x, y, z and half side [m], the four the robot starts on first.
#[pyclass(name = "SteppingStones", module = "cbfgen.anymal", frozen)]
struct PySteppingStones {
    inner: SteppingStones,
}

#[pymethods]
impl PySteppingStones {
    #[new]
    #[pyo3(signature = (strides = 8, seed = 0, swing = 0.3, lift = 0.1, size = 0.14,
                        displacement = None, swings_between = 7, layout = "gait", pitch = 0.24))]
    #[allow(clippy::too_many_arguments)] // Python keywords, each with its default
    fn new(
        strides: usize,
        seed: u64,
        swing: f64,
        lift: f64,
        size: f64,
        displacement: Option<(f64, f64, f64)>,
        swings_between: usize,
        layout: &str,
        pitch: f64,
    ) -> PyResult<Self> {
        let base = match super::convert::choice("stone layout", layout, &["gait", "rows"])? {
            0 => StoneField::default(),
            _ => StoneField { layout: StoneLayout::Rows { pitch }, ..StoneField::rows() },
        };
        let field = StoneField {
            strides,
            swing,
            lift,
            swings_between,
            size,
            displacement: displacement.map_or(base.displacement, |d| [d.0, d.1, d.2]),
            seed,
            ..base
        };
        Ok(Self { inner: SteppingStones::new(&field)? })
    }

    #[getter]
    fn stones<'py>(&self, py: Python<'py>) -> Array2Out<'py> {
        let stones = self.inner.stones();
        matrix_from_fn(py, stones.len(), 4, |i, j| if j < 3 { stones[i].top[j] } else { stones[i].half })
    }

    /// When the walk is over [s].
    #[getter]
    fn end(&self) -> f64 {
        self.inner.end()
    }

    /// The trot's forward speed [m/s].
    #[getter]
    fn speed(&self) -> f64 {
        self.inner.trot().velocity[0]
    }

    /// The trot's swing time [s].
    #[getter]
    fn swing(&self) -> f64 {
        self.inner.trot().swing
    }

    /// How far the trunk walks before it stops [m].
    #[getter]
    fn distance(&self) -> f64 {
        self.inner.trot().velocity[0] * self.inner.trot().duration
    }

    /// The horizontal distance from ``(x, y)`` to the nearest stone top (0 on one) [m].
    fn misstep(&self, x: f64, y: f64) -> f64 {
        self.inner.misstep(x, y)
    }

    /// The top height of the stone nearest ``(x, y)`` horizontally [m].
    fn nearest_top(&self, x: f64, y: f64) -> f64 {
        self.inner.nearest_top(x, y)
    }
}

/// Seed 004's two layers walking a :class:`SteppingStones` field on a plant Python drives
/// (MuJoCo): the kino-dynamic MPC every 16th cycle, the whole-body controller every cycle
/// (2.5 ms), the foothold constraints where ``controller`` (one of ``ANYMAL_CONTROLLERS``,
/// Table II's names) puts them, and Table II's measurements of the feet the plant reports.
#[pyclass(name = "StoneWalk", module = "cbfgen.anymal")]
struct PyStoneWalk {
    layers: LayeredController,
    meter: WalkMeter,
}

#[pymethods]
impl PyStoneWalk {
    /// ``margin``: how far inside a stone's edge its region ends [m]; ``gamma``: eq. 25's
    /// rate [1/s] (``None``: 30); ``threaded``: the MPC in its own thread, posted every
    /// cycle (the caller then runs in real time), rather than inline every 16th cycle
    /// (deterministic); ``barrier``: the set eq. 25's CBF (the MPC's) keeps a swing foot
    /// in, and on which its violation is measured: ``"shrinking"`` (eq. 24's set, shrinking
    /// onto its landing region at touchdown; the default) or ``"region"`` (the landing
    /// region itself); ``whole_body_barrier``: the
    /// set of eq. 26's CBF in the whole-body QP, ``"extent"`` (the shrinking set as it
    /// stands each cycle; the default), ``"region"`` or ``"shrinking"``; ``mpc_stage``:
    /// the MPC's stage length [s] (``None``: 0.04), its horizon kept at 1 s.
    #[new]
    #[pyo3(signature = (stones, controller = "CBF in QP & MPC", margin = 0.02, gamma = None, threaded = false,
                        barrier = None, mpc_stage = None, whole_body_barrier = None))]
    #[allow(clippy::too_many_arguments)] // Python keywords, each with its default
    fn new(
        stones: &PySteppingStones,
        controller: &str,
        margin: f64,
        gamma: Option<f64>,
        threaded: bool,
        barrier: Option<&str>,
        mpc_stage: Option<f64>,
        whole_body_barrier: Option<&str>,
    ) -> PyResult<Self> {
        let names = Controller::ALL.map(Controller::name);
        let controller = Controller::ALL[super::convert::choice("controller", controller, &names)?];
        let defaults = WalkSettings::default();
        let barrier = super::convert::named(
            "foothold barrier",
            barrier,
            FootholdBarrier::ALL,
            FootholdBarrier::name,
            defaults.barrier,
        )?;
        let whole_body_barrier = super::convert::named(
            "whole-body barrier",
            whole_body_barrier,
            WholeBodyBarrier::ALL,
            WholeBodyBarrier::name,
            defaults.whole_body_barrier,
        )?;
        let mpc = match mpc_stage {
            Some(stage) => defaults.mpc.with_stage(stage)?,
            None => defaults.mpc,
        };
        let settings = WalkSettings {
            margin,
            gamma: gamma.unwrap_or(defaults.gamma),
            threaded,
            barrier,
            whole_body_barrier,
            mpc,
            ..defaults
        };
        let stones = &stones.inner;
        Ok(Self {
            layers: LayeredController::new(*stones.trot(), stones.terrain().clone(), controller, &settings)?,
            meter: WalkMeter::new(stones, &settings),
        })
    }

    /// One cycle at ``t`` [s] on the measured state ``x`` (shape (42,), the ``anymal_wbc``
    /// layout), with the plant's foot centres and their velocities (world, shape (4, 3)
    /// each) for the measurements. Returns a dict: ``torques`` (12,), ``stance`` (4
    /// bools), ``solved`` (every priority), ``relaxed`` (4,), ``planned`` (a plan exists),
    /// ``mpc`` (``None``, or the iteration's ``(updated, solver iterations)``: Newton steps, or
    /// ADMM iterations under OSQP).
    fn update<'py>(
        &mut self,
        py: Python<'py>,
        t: f64,
        x: ArrayIn<'py>,
        feet: ArrayIn<'py>,
        velocities: ArrayIn<'py>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let x = fixed::<NX>("x", &x)?;
        let (feet, velocities) = (feet_array("feet", &feet)?, feet_array("velocities", &velocities)?);
        let cycle = self.layers.update(t, &x)?;
        self.meter.observe(t, &cycle, &feet, &velocities);
        let dict = PyDict::new(py);
        dict.set_item("torques", vector(py, &cycle.out.torques))?;
        dict.set_item("stance", cycle.reference.stance.to_vec())?;
        dict.set_item("solved", cycle.out.solved)?;
        dict.set_item("relaxed", vector(py, &cycle.out.relaxed))?;
        dict.set_item("planned", cycle.planned)?;
        dict.set_item("mpc", cycle.mpc.map(|r| (r.updated, r.iterations)))?;
        Ok(dict)
    }

    /// Mark a fall at ``t`` [s] (the plant decides what a fall is).
    fn fell(&mut self, t: f64) {
        self.meter.fell(t);
    }

    /// Table II's measurements so far, a dict: ``steps``, ``missteps``,
    /// ``mean_misstep_m``, ``landings`` (k, 11: time, foot, centre x y z, misstep,
    /// height above the stone, the planned touchdown x y z and its misstep [m]),
    /// ``swing_time_s``, ``violated_24_s``,
    /// ``violated_25_s``, ``barriers`` (cycles, 5: time, each foot's smallest h [m]),
    /// ``barriers_24`` (cycles, 4: the same on eq. 24's shrinking set),
    /// ``mpc_failures``, ``mpc_iterations`` (threaded: of the plans that arrived),
    /// ``mpc_thread_solves`` (threaded: the thread's solves and those without a plan),
    /// ``wbc_unsolved``, ``fell`` (time or ``None``).
    fn record<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let r = self.meter.record();
        let dict = PyDict::new(py);
        dict.set_item("steps", r.landings.len())?;
        dict.set_item("missteps", r.missteps().count())?;
        dict.set_item("mean_misstep_m", r.mean_misstep())?;
        let l = &r.landings;
        dict.set_item(
            "landings",
            matrix_from_fn(py, l.len(), 11, |i, j| match j {
                0 => l[i].time,
                1 => l[i].foot as f64,
                2..=4 => l[i].position[j - 2],
                5 => l[i].misstep,
                6 => l[i].height,
                7..=9 => l[i].planned[j - 7],
                _ => l[i].planned_misstep,
            }),
        )?;
        dict.set_item("swing_time_s", r.swing_time)?;
        dict.set_item("violated_24_s", r.violated_24)?;
        dict.set_item("violated_25_s", r.violated_25)?;
        let b = &r.barriers;
        dict.set_item("barriers", matrix_from_fn(py, b.len(), 5, |i, j| if j == 0 { b[i].0 } else { b[i].1[j - 1] }))?;
        let s = &r.shrinking_barriers;
        dict.set_item("barriers_24", matrix_from_fn(py, s.len(), 4, |i, j| s[i][j]))?;
        dict.set_item("mpc_failures", r.mpc_failures)?;
        dict.set_item("mpc_thread_solves", self.layers.thread_solves())?;
        dict.set_item("mpc_iterations", r.mpc_solver_iterations)?;
        dict.set_item("wbc_unsolved", r.wbc_unsolved)?;
        dict.set_item("fell", r.fell)?;
        Ok(dict)
    }
}
