//! The simulation scenarios for Python: `Course`, for a control loop written in Python,
//! and `simulate`, the whole Rust closed loop returning its time series as numpy arrays.

use std::sync::Mutex;

use pyo3::prelude::*;

use crate::PyResult;
use pyo3::types::PyDict;

use super::{initializer, state, PyEnvironment};
use crate::convert::{choice, matrix, matrix_from_fn, vector, Array1Out, Array2Out, ArrayIn};
use cbfgen::error::finite;
use cbfgen::error::CbfError;
use cbfgen::filter::InputSource;
use cbfgen_tachyon3::catalog::Family;
use cbfgen_tachyon3::model::NX;
use cbfgen_tachyon3::sim::campaign::{self as monte_carlo, CampaignSettings, CourseRanges, Episode};
use cbfgen_tachyon3::sim::gait::{GaitParams, OriginRule};
use cbfgen_tachyon3::sim::perceived::{Perceiver, PerceptionSettings};
use cbfgen_tachyon3::sim::{self, Course, Scenario, SimConfig};

const SCENARIOS: [Scenario; Scenario::NAMED.len()] = Scenario::NAMED;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SCENARIOS", SCENARIOS.map(Scenario::name).to_vec())?;
    let r = CourseRanges::default();
    let ranges = PyDict::new(m.py());
    for (key, range) in [("rise", r.rise), ("run", r.run), ("start_gap", r.start_gap), ("speed", r.speed)] {
        ranges.set_item(key, range.to_vec())?;
    }
    ranges.set_item("steps", r.steps.to_vec())?;
    m.add("COURSE_RANGES", ranges)?;
    m.add("CAMPAIGN_TIMING_COLUMNS", monte_carlo::table::TIMING_COLUMNS.to_vec())?;
    m.add_class::<PyCourse>()?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(campaign, m)?)?;
    m.add_function(wrap_pyfunction!(merge_campaign, m)?)?;
    Ok(())
}

/// ``Course(origin=...)``'s names, in `OriginRule`'s order.
const ORIGIN_RULES: [&str; 2] = ["rolling", "jump_at_exchange"];

fn scenario(name: &str) -> PyResult<Scenario> {
    Ok(SCENARIOS[choice("scenario", name, &SCENARIOS.map(Scenario::name))?])
}

/// A scenario's stairs and nominal gait, stepped by your own loop:
///
/// ```python
/// course = Course("step")
/// filt = ecbf_filter()
/// x = course.initial_state()
/// for k in range(n):
///     u_ref = course.plan(k * DT, x)          # also updates course.environment
///     out = filt.update(x, u_ref, course.environment)
///     x = x + DT * xdot(x, out.u)
/// ```
///
/// With ``perception=True`` the gait and the environment see only what a LiDAR on the
/// body perceives (the settings of ``simulate(perception=True)``, noise from
/// ``perception_seed``, perceived levels raised by ``floor_lift`` \[m\] when given, from
/// −0.05 to 0.5, default 0.004): call :meth:`perceive` before :meth:`plan` every cycle.
///
/// ``origin`` is how the ground-moving origin moves: ``"rolling"`` (the default, every
/// documented run) or ``"jump_at_exchange"``, the paper's, where it also jumps to the
/// wheels' centroid at each support exchange. Call :meth:`exchange_origin` before
/// :meth:`plan` every cycle then, and on a course that turns (``"turn"``, or after
/// :meth:`command` with a yaw rate): the robot turns on three legs about a drive axle,
/// onto which it moves the origin.
#[pyclass(name = "Course", module = "cbfgen.tachyon3")]
pub struct PyCourse {
    inner: Course,
    scenario: Scenario,
    env: Py<PyEnvironment>,
    nominal_body_height: Option<f64>,
    /// In a mutex only because a Python class must be `Sync` and the worker's channel is
    /// not; `&mut self` methods take it uncontended.
    perceiver: Option<Mutex<Perceiver>>,
    perception_started: bool,
}

#[pymethods]
impl PyCourse {
    #[new]
    #[pyo3(signature = (scenario="step", perception=false, perception_seed=1, floor_lift=None, origin="rolling"))]
    fn new(
        py: Python<'_>,
        scenario: &str,
        perception: bool,
        perception_seed: u64,
        floor_lift: Option<f64>,
        origin: &str,
    ) -> PyResult<Self> {
        let origin = [OriginRule::Rolling, OriginRule::JumpAtExchange][choice("origin", origin, &ORIGIN_RULES)?];
        let scenario = self::scenario(scenario)?;
        let inner = Course::new(scenario, GaitParams { origin, ..GaitParams::default() })?;
        let env = Py::new(py, initializer(inner.environment().clone()))?;
        let defaults = PerceptionSettings::default();
        let settings = PerceptionSettings {
            seed: perception_seed,
            floor_lift: floor_lift.unwrap_or(defaults.floor_lift),
            ..defaults
        };
        let perceiver = perception.then(|| Perceiver::new(settings, inner.perceivable()?)).transpose()?.map(Mutex::new);
        Ok(Self { inner, scenario, env, nominal_body_height: None, perceiver, perception_started: false })
    }

    /// Perception before the control cycle at time ``t`` \[s\], for a robot that believes
    /// it is at ``x`` (its state estimate, what the gait and filter are given) and is at
    /// ``truth`` (the physical state; ``x`` when None). The LiDAR's rays leave from the
    /// true pose; its returns are mapped from the believed one. Scans at 10 Hz, requests
    /// an update at 1 Hz and applies it 0.5 s later; the first call scans and applies at
    /// once. Updates ``environment``. An error on a course built without perception.
    #[pyo3(signature = (t, x, truth=None))]
    fn perceive(&mut self, py: Python<'_>, t: f64, x: ArrayIn<'_>, truth: Option<ArrayIn<'_>>) -> PyResult<()> {
        let t = finite("time", t)?;
        let estimate = state(&x)?;
        let truth = truth.map(|x| state(&x)).transpose()?.unwrap_or(estimate);
        let Some(perceiver) = self.perceiver.as_mut() else {
            return Err(crate::value_error("perceive needs a Course(perception=True)"));
        };
        let perceiver = perceiver
            .get_mut()
            .map_err(|_| CbfError::Thread { what: "perception", reason: "it panicked in an earlier call".into() })?;
        if self.perception_started {
            perceiver.step_estimated(t, &truth, &estimate, &mut self.inner)?;
        } else {
            perceiver.start_estimated(&truth, &estimate, &mut self.inner)?;
            self.perception_started = true;
        }
        self.sync_environment(py);
        Ok(())
    }

    /// The body's measured roll \[rad\] (an IMU's), which the sagittal model does not
    /// hold: the body rows then keep the model's body ``roll_clearance(roll)`` from every
    /// edge, so that the rolled body is clear when they hold. Applies to the environment
    /// at once and to every later perception update; 0 (the default) is the model's body.
    fn set_body_roll(&mut self, py: Python<'_>, roll: f64) -> PyResult<()> {
        self.inner.set_body_roll(roll)?;
        self.sync_environment(py);
        Ok(())
    }

    /// The paper's velocity command from now on: roll at ``speed`` \[m/s\] (0 to 1) and
    /// turn at ``yaw_rate`` \[rad/s\] (positive left, at most :attr:`max_yaw_rate`).
    /// Whenever the heading lags the command's, a tripod lifts and the robot turns on the
    /// other three legs about their drive axle (:data:`STANCE_AXLE`), the lifted toes
    /// landing under their hips. A ``ValueError`` for a speed or rate out of range.
    fn command(&mut self, speed: f64, yaw_rate: f64) -> PyResult<()> {
        Ok(self.inner.command(speed, yaw_rate)?)
    }

    /// The time a run on this course gets to finish \[s\] (``simulate``'s limit): each
    /// flight's climb and each turn's.
    #[getter]
    fn time_allowed(&self) -> f64 {
        self.scenario.time_allowed()
    }

    /// The fastest yaw rate :meth:`command` accepts \[rad/s\]: one 30° turning swing per
    /// turning swing and stance.
    #[getter]
    fn max_yaw_rate(&self) -> f64 {
        self.inner.gait().max_yaw_rate()
    }

    /// ``x`` with its origin moved where the support puts it, and how far it jumped \[m\]
    /// (otherwise ``x`` unchanged and None): onto the drive axle a turning swing turns
    /// about, and back off it after; with ``origin="jump_at_exchange"`` also to the six
    /// wheels' centroid at each support exchange. Every world pose is kept, so nothing
    /// the filter sees changes. Call it before :meth:`plan` each cycle, and go on from
    /// the state it returns: a course that turns refuses to plan a turning swing's
    /// cycles otherwise.
    fn exchange_origin<'py>(
        &mut self,
        py: Python<'py>,
        t: f64,
        x: ArrayIn<'py>,
    ) -> PyResult<(Array1Out<'py>, Option<f64>)> {
        let mut x = state(&x)?;
        let jump = self.inner.exchange_origin(finite("time", t)?, &mut x);
        Ok((vector(py, &x), jump))
    }

    /// Perception updates applied so far (0 without perception).
    #[getter]
    fn perception_updates(&self) -> usize {
        self.perceiver.as_ref().and_then(|p| p.lock().ok()).map_or(0, |p| p.updates())
    }

    /// The edge boxes the filter was last given, as :meth:`terrain_boxes` gives boxes (the
    /// true edges' riser boxes without perception), as its body rows see them: grown by
    /// ``roll_clearance`` of the roll given to :meth:`set_body_roll`.
    fn environment_edges<'py>(&self, py: Python<'py>) -> Vec<BoxOut<'py>> {
        let edge = |e: &cbfgen_tachyon3::catalog::EdgeCuboid| -> BoxOut<'py> {
            let rows: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| e.rotation[(i, j)]));
            (vector(py, &<[f64; 3]>::from(e.center)), matrix(py, &rows), vector(py, &<[f64; 3]>::from(e.half)))
        };
        self.inner.environment().edges().iter().map(edge).collect()
    }

    /// The standard posture with the robot's foremost point ``start_gap`` metres before
    /// the first riser, shape (NX,).
    #[pyo3(signature = (start_gap=0.3))]
    fn initial_state<'py>(&self, py: Python<'py>, start_gap: f64) -> PyResult<Array1Out<'py>> {
        Ok(vector(py, &self.inner.initial_state(finite("start gap", start_gap)?)))
    }

    /// The gait's nominal input at time ``t`` \[s\] for state ``x``, shape (NU,). Updates
    /// ``environment`` (floors under the toes, swing legs, their foothold strips).
    fn plan<'py>(&mut self, py: Python<'py>, t: f64, x: ArrayIn<'py>) -> PyResult<Array1Out<'py>> {
        let plan = self.inner.plan(finite("time", t)?, &state(&x)?)?;
        for &v in &plan.u_ref {
            finite("nominal input", v)?;
        }
        finite("nominal body height", plan.body_height)?;
        self.nominal_body_height = Some(plan.body_height);
        self.sync_environment(py);
        Ok(vector(py, &plan.u_ref))
    }

    /// The environment the filter must respect, as of the last ``plan``.
    #[getter]
    fn environment(&self, py: Python<'_>) -> Py<PyEnvironment> {
        self.env.clone_ref(py)
    }

    /// The gait's nominal body-centre height at the last ``plan`` \[m\]; None before the
    /// first (not NaN: no output of the module is NaN).
    #[getter]
    fn nominal_body_height(&self) -> Option<f64> {
        self.nominal_body_height
    }

    /// Which tripod swings (0: LR RR MF, 1: MR LF RF), or None.
    #[getter]
    fn swinging(&self) -> Option<usize> {
        self.inner.swinging()
    }

    /// Exact ``(body, wheel, wheel_riser)`` clearance at ``x`` to the true terrain's solids
    /// (:meth:`terrain_boxes`: the floor and every step as a block) \[m\]; negative = depth
    /// into a solid. ``body`` by the exact SAT; ``wheel``, the nearest wheel by the exact
    /// sphere–box distance (about 0 for a wheel on a tread); ``wheel_riser``, the nearest
    /// wheel to a riser (contact normal more than 30° from vertical; inf if none).
    fn clearance(&self, x: ArrayIn<'_>) -> PyResult<(f64, f64, f64)> {
        let c = self.inner.clearance(&state(&x)?)?;
        Ok((
            finite("body clearance", c.body.distance)?,
            finite("wheel clearance", c.wheel.distance)?,
            c.wheel_riser.map_or(f64::INFINITY, |r| r.distance),
        ))
    }

    /// Every toe on the top level, the body past the last riser, no tripod swinging.
    fn finished(&self, x: ArrayIn<'_>) -> PyResult<bool> {
        Ok(self.inner.finished(&state(&x)?))
    }

    /// The true terrain as solid boxes, ``[(center (3,), rotation (3, 3), half_extents
    /// (3,))]``: a floor with its top at z = 0 and one box per raised level (what a
    /// physics engine or a scanner is given), every flight's on a course that turns.
    fn terrain_boxes<'py>(&self, py: Python<'py>) -> PyResult<Vec<BoxOut<'py>>> {
        Ok(self.inner.solids().solids().iter().map(|b| box_out(py, b)).collect())
    }

    /// The true edge cuboids (the nosings), one along each change of height, in order, as
    /// :meth:`terrain_boxes` gives boxes (every flight's, in the world).
    fn edge_boxes<'py>(&self, py: Python<'py>) -> PyResult<Vec<BoxOut<'py>>> {
        Ok(self.inner.route().edge_boxes()?.iter().map(|b| box_out(py, b)).collect())
    }

    /// Ground height at ``x`` \[m\] along the path the gait is planning on (the current
    /// flight's, in its own frame, on a course that turns).
    fn floor_height(&self, x: f64) -> PyResult<f64> {
        Ok(self.inner.ground().height_at(finite("x", x)?))
    }
}

impl PyCourse {
    /// Copy the course's environment into the one Python holds.
    fn sync_environment(&self, py: Python<'_>) {
        let mut env = self.env.borrow_mut(py);
        let params = &mut env.as_super().inner;
        match params.downcast_mut::<cbfgen_tachyon3::catalog::Environment>() {
            Some(e) => e.clone_from(self.inner.environment()),
            // Only reachable if the wrapped parameters were replaced: restore them.
            None => *params = Box::new(self.inner.environment().clone()),
        }
    }
}

type BoxOut<'py> = (Array1Out<'py>, Array2Out<'py>, Array1Out<'py>);

fn box_out<'py>(py: Python<'py>, b: &cbfgen::geometry::OrientedBox) -> BoxOut<'py> {
    let r = b.rotation().matrix();
    let rows: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| r[(i, j)]));
    (vector(py, &<[f64; 3]>::from(*b.center())), matrix(py, &rows), vector(py, &<[f64; 3]>::from(*b.half_extents())))
}

/// Run a scenario's closed loop in Rust (gait → filter → Euler at 1 kHz) and return its
/// time series as a dict of numpy arrays, one entry per cycle:
///
/// ``t`` (n,), ``x`` (n, NX), ``body_z_world`` and ``body_raise`` (n,), ``min_h`` (n, 6) in
/// ``FAMILIES`` order (inf where no row applied), ``active_rows``, ``iterations``,
/// ``source`` (index into ``INPUT_SOURCES``), ``eval_us``, ``solve_us``, ``update_us`` (wall
/// time), ``cpu_us`` (the thread's CPU time over the update), ``body_clearance``,
/// ``toe_clearance``, ``toe_riser_clearance`` (as :meth:`Course.clearance`: to the solid
/// terrain, inf where no wheel faces a riser), ``swinging`` (-1: none); and ``summary``, a
/// dict (``min_body_clearance``, ``min_toe_clearance``, ``min_toe_riser_clearance`` with
/// where each was, as ``"RR step 2 riser"``, in ``body_nearest``, ``toe_nearest``,
/// ``toe_riser_nearest``; ``riser_contact_cycles``; …).
/// With ``episode`` (and ``seed``, ``ranges`` as given to :func:`campaign`), the course is
/// that campaign episode's instead of ``scenario``. With ``perception=True`` the gait and
/// filter see only what a LiDAR on the body perceives (``summary["perception_updates"]``
/// counts the 1 Hz updates). With ``fine=N`` each input is held over its period on the
/// continuous model (RK4 at 1 ms / N) and every clearance and ``min_h`` is the least over
/// the cycle's fine steps; ``certify=True`` has the filter certify each input between the
/// samples (``summary["certified_cycles"]``). The GIL is released while it runs.
#[pyfunction]
#[pyo3(signature = (scenario="stairs", body_cbf=true, max_time=None, episode=None, seed=0, ranges=None, perception=false, fine=None, certify=false))]
#[allow(clippy::too_many_arguments)] // one per keyword argument of the Python function
fn simulate<'py>(
    py: Python<'py>,
    scenario: &str,
    body_cbf: bool,
    max_time: Option<f64>,
    episode: Option<u64>,
    seed: u64,
    ranges: Option<&Bound<'py, PyDict>>,
    perception: bool,
    fine: Option<usize>,
    certify: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let plant = sim::Plant::from_fine_steps(fine);
    let mut config = match episode {
        Some(id) => Episode::draw(seed, id, &course_ranges(ranges)?)?.config_with(body_cbf, perception),
        None => SimConfig {
            perception: perception.then(PerceptionSettings::default),
            ..SimConfig::new(self::scenario(scenario)?, body_cbf)
        },
    }
    .between_samples(plant, certify);
    if let Some(t) = max_time {
        config.max_time = cbfgen::error::positive("max_time", t)?;
    }
    let run = py.detach(|| sim::run(&config, |_| {}))?;
    let s = &run.samples;
    let column = |f: &dyn Fn(&sim::Sample) -> f64| -> Vec<f64> { s.iter().map(f).collect() };
    let out = PyDict::new(py);
    out.set_item("t", vector(py, &column(&|s| s.t)))?;
    out.set_item("x", matrix_from_fn(py, s.len(), NX, |i, j| s[i].x[j]))?;
    out.set_item("body_z_world", vector(py, &column(&|s| s.x[2] + s.x[cbfgen_tachyon3::model::BODY_Z])))?;
    out.set_item("body_raise", vector(py, &column(&|s| s.body_raise)))?;
    out.set_item("min_h", matrix_from_fn(py, s.len(), Family::ALL.len(), |i, j| s[i].min_h[j]))?;
    out.set_item("active_rows", vector(py, &column(&|s| s.active_rows as f64)))?;
    out.set_item("iterations", vector(py, &column(&|s| f64::from(s.iterations))))?;
    let source_index = |s: &sim::Sample| InputSource::ALL.iter().position(|&k| k == s.source).unwrap_or(0) as f64;
    out.set_item("source", vector(py, &column(&source_index)))?;
    out.set_item("eval_us", vector(py, &column(&|s| s.eval_us)))?;
    out.set_item("solve_us", vector(py, &column(&|s| s.solve_us)))?;
    out.set_item("update_us", vector(py, &column(&|s| s.update_us)))?;
    out.set_item("cpu_us", vector(py, &column(&|s| s.cpu_us)))?;
    out.set_item("body_clearance", vector(py, &column(&|s| s.clearance.body.distance)))?;
    out.set_item("toe_clearance", vector(py, &column(&|s| s.clearance.wheel.distance)))?;
    let riser = |s: &sim::Sample| s.clearance.wheel_riser.map_or(f64::INFINITY, |r| r.distance);
    out.set_item("toe_riser_clearance", vector(py, &column(&riser)))?;
    out.set_item("swinging", vector(py, &column(&|s| f64::from(s.swinging))))?;

    let m = &run.summary;
    let summary = PyDict::new(py);
    summary.set_item("scenario", m.scenario.name())?;
    summary.set_item("body_cbf", m.body_cbf)?;
    summary.set_item("completed", m.completed)?;
    summary.set_item("duration", m.duration)?;
    summary.set_item("certified_cycles", m.certified_cycles)?;
    summary.set_item("min_body_clearance", m.min_body_clearance())?;
    summary.set_item("min_toe_clearance", m.min_toe_clearance())?;
    summary.set_item("min_toe_riser_clearance", m.min_toe_riser_clearance())?;
    for (key, approach) in
        [("body_nearest", m.body_nearest), ("toe_nearest", m.toe_nearest), ("toe_riser_nearest", m.toe_riser_nearest)]
    {
        summary.set_item(key, approach.map(|a| a.contact.place()))?;
    }
    summary.set_item("riser_contact_cycles", m.riser_contact_cycles)?;
    let min_h = PyDict::new(py);
    for f in Family::ALL {
        min_h.set_item(f.name(), m.min_h[f.index()])?;
    }
    summary.set_item("min_h", min_h)?;
    summary.set_item("max_body_raise", m.max_body_raise)?;
    summary.set_item("median_update_us", m.median_update_us)?;
    summary.set_item("p99_update_us", m.p99_update_us)?;
    summary.set_item("max_update_us", m.max_update_us)?;
    summary.set_item("median_cpu_us", m.median_cpu_us)?;
    summary.set_item("p99_cpu_us", m.p99_cpu_us)?;
    summary.set_item("max_cpu_us", m.max_cpu_us)?;
    summary.set_item("over_period_wall", m.over_period_wall)?;
    summary.set_item("over_period_cpu", m.over_period_cpu)?;
    summary.set_item("fallback_cycles", m.fallback_cycles)?;
    let relaxed = PyDict::new(py);
    for f in Family::ALL {
        relaxed.set_item(f.name(), m.relaxed_cycles[f.index()])?;
    }
    summary.set_item("relaxed_cycles", relaxed)?;
    summary.set_item("perception_updates", m.perception.map_or(0, |p| p.updates))?;
    out.set_item("summary", summary)?;
    Ok(out)
}

/// Course ranges from a dict of ``[lo, hi]`` pairs (keys ``rise``, ``run``, ``steps``,
/// ``start_gap``, ``speed``); missing keys keep their defaults, unknown keys are errors.
fn course_ranges(ranges: Option<&Bound<'_, PyDict>>) -> PyResult<CourseRanges> {
    let mut out = CourseRanges::default();
    let Some(ranges) = ranges else { return Ok(out) };
    for (key, value) in ranges.iter() {
        let key: String = key.extract()?;
        match key.as_str() {
            "rise" => out.rise = value.extract()?,
            "run" => out.run = value.extract()?,
            "steps" => out.steps = value.extract()?,
            "start_gap" => out.start_gap = value.extract()?,
            "speed" => out.speed = value.extract()?,
            _ => {
                return Err(cbfgen::error::CbfError::UnknownName {
                    what: "course range",
                    name: key,
                    known: "rise, run, steps, start_gap, speed".into(),
                }
                .into())
            }
        }
    }
    out.validate()?;
    Ok(out)
}

/// Run a Monte Carlo campaign in Rust (rayon threads, the GIL released): ``episodes``
/// random staircases drawn from ``seed`` and ``ranges`` (a dict of ``[lo, hi]`` pairs:
/// ``rise``, ``run``, ``steps``, ``start_gap``, ``speed``; defaults as ``cbfgen campaign``),
/// episode ids from ``first_id``. Returns a dict of numpy arrays, one entry per episode in id
/// order: ``id``, ``rise``, ``run``, ``steps``, ``start_gap``, ``speed``, ``outcome`` (a list
/// of ``"finished"``, ``"not_finished"``, ``"error"``), ``duration``, ``min_body_clearance``, ``min_toe_clearance``,
/// ``min_toe_riser_clearance`` (to the solid terrain, as :func:`simulate`'s summary),
/// ``riser_contact_cycles``, ``min_h`` (n, 6),
/// ``median_cpu_us``, ``p99_cpu_us``, ``max_cpu_us``, ``median_wall_us``, ``p99_wall_us``,
/// ``max_wall_us``, ``over_1ms_cpu``, ``over_1ms_wall``, ``cycles`` (all 0 for an episode
/// whose outcome is ``"error"``: no output of the module is NaN); ``errors``, a list of ``(id, message)``; and ``report``, the
/// printed table as text; and ``csv``, the text of ``episodes.csv`` at full precision
/// (what :func:`merge_campaign` joins). Rerun one episode with ``simulate(episode=id,
/// seed=seed)``. With ``perception=True`` every episode runs on perceived terrain. With
/// ``fine=N`` each input is held over its 1 ms period on the continuous model (RK4 at
/// 1 ms / N, N from 1 to 1000) and every clearance and ``min_h`` is the least over each
/// fine step, between the samples too; ``certify=True`` has the filter certify each
/// input between the samples, and ``certified_cycles`` counts the updates it certified.
#[pyfunction]
#[pyo3(signature = (episodes=200, seed=0, first_id=0, body_cbf=true, threads=None, ranges=None, perception=false, fine=None, certify=false))]
#[allow(clippy::too_many_arguments)] // one per keyword argument of the Python function
fn campaign<'py>(
    py: Python<'py>,
    episodes: usize,
    seed: u64,
    first_id: u64,
    body_cbf: bool,
    threads: Option<usize>,
    ranges: Option<&Bound<'py, PyDict>>,
    perception: bool,
    fine: Option<usize>,
    certify: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let plant = sim::Plant::from_fine_steps(fine);
    let settings = CampaignSettings {
        seed,
        episodes,
        first_id,
        ranges: course_ranges(ranges)?,
        body_cbf,
        threads,
        perception,
        plant,
        certify,
        time_bound_us: None,
    };
    let result = py.detach(|| monte_carlo::run(&settings, |_| {}))?;
    let r = &result.records;
    let episode = |f: &dyn Fn(&Episode) -> f64| -> Vec<f64> { r.iter().map(|x| f(&x.episode)).collect() };
    let summary =
        |f: &dyn Fn(&sim::Summary) -> f64| -> Vec<f64> { r.iter().map(|x| x.result.as_ref().map_or(0.0, f)).collect() };
    let out = PyDict::new(py);
    out.set_item("id", vector(py, &episode(&|e| e.id as f64)))?;
    out.set_item("rise", vector(py, &episode(&|e| e.stairs.rise)))?;
    out.set_item("run", vector(py, &episode(&|e| e.stairs.run)))?;
    out.set_item("steps", vector(py, &episode(&|e| e.stairs.count as f64)))?;
    out.set_item("start_gap", vector(py, &episode(&|e| e.start_gap)))?;
    out.set_item("speed", vector(py, &episode(&|e| e.speed)))?;
    out.set_item("outcome", r.iter().map(|x| x.outcome().name()).collect::<Vec<_>>())?;
    out.set_item("duration", vector(py, &summary(&|s| s.duration)))?;
    out.set_item("certified_cycles", vector(py, &summary(&|s| s.certified_cycles.unwrap_or(0) as f64)))?;
    out.set_item("min_body_clearance", vector(py, &summary(&|s| s.min_body_clearance())))?;
    out.set_item("min_toe_clearance", vector(py, &summary(&|s| s.min_toe_clearance())))?;
    out.set_item("min_toe_riser_clearance", vector(py, &summary(&|s| s.min_toe_riser_clearance())))?;
    out.set_item("riser_contact_cycles", vector(py, &summary(&|s| s.riser_contact_cycles as f64)))?;
    let min_h = |i: usize, j: usize| r[i].result.as_ref().map_or(0.0, |s| s.min_h[j]);
    out.set_item("min_h", matrix_from_fn(py, r.len(), Family::ALL.len(), min_h))?;
    out.set_item("median_cpu_us", vector(py, &summary(&|s| s.median_cpu_us)))?;
    out.set_item("p99_cpu_us", vector(py, &summary(&|s| s.p99_cpu_us)))?;
    out.set_item("max_cpu_us", vector(py, &summary(&|s| s.max_cpu_us)))?;
    out.set_item("median_wall_us", vector(py, &summary(&|s| s.median_update_us)))?;
    out.set_item("p99_wall_us", vector(py, &summary(&|s| s.p99_update_us)))?;
    out.set_item("max_wall_us", vector(py, &summary(&|s| s.max_update_us)))?;
    out.set_item("over_1ms_cpu", vector(py, &summary(&|s| s.over_period_cpu as f64)))?;
    out.set_item("over_1ms_wall", vector(py, &summary(&|s| s.over_period_wall as f64)))?;
    out.set_item("cycles", vector(py, &summary(&|s| s.cycles as f64)))?;
    let errors: Vec<(u64, String)> =
        r.iter().filter_map(|x| x.result.as_ref().err().map(|e| (x.episode.id, e.clone()))).collect();
    out.set_item("errors", errors)?;
    out.set_item("report", result.report().to_string())?;
    out.set_item("csv", monte_carlo::output::csv(&result))?;
    Ok(out)
}

/// Join campaign shards (each the ``csv`` of a :func:`campaign` call, or an
/// ``episodes.csv`` a ``cbfgen campaign --shard`` wrote) into one campaign: returns a dict
/// with ``csv`` (the merged ``episodes.csv`` text, in id order), ``report`` (the printed
/// table), ``missing`` (``(first, last)`` id spans no shard held) and ``written`` (the
/// paths, when ``out`` names a directory to write ``episodes.csv``, ``report.txt`` and the
/// figures into, as the command line does). Raises ``CbfError`` for a text that is not a
/// campaign CSV of this version, shards of different seeds, or an episode in two shards.
#[pyfunction]
#[pyo3(signature = (shards, out=None))]
fn merge_campaign<'py>(
    py: Python<'py>,
    shards: Vec<String>,
    out: Option<std::path::PathBuf>,
) -> PyResult<Bound<'py, PyDict>> {
    use monte_carlo::table;
    let rows = table::merge(&shards)?;
    let result = PyDict::new(py);
    result.set_item("csv", table::csv(&rows))?;
    result.set_item("report", monte_carlo::Report::of(&rows).to_string())?;
    result.set_item("missing", table::gaps(&rows))?;
    let written = match out {
        Some(dir) => monte_carlo::output::write_rows(&dir, &rows)
            .map_err(|e| pyo3::exceptions::PyOSError::new_err(format!("{}: {e}", dir.display())))?,
        None => Vec::new(),
    };
    result.set_item("written", written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>())?;
    Ok(result)
}
