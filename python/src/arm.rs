//! The arm among random sphere obstacles (`cbfgen_panda_spheres`, docs/arm.md) as one
//! campaign episode: what `cbfgen.campaign.ArmObstacles` runs.

use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::PyResult;
use cbfgen::filter::InputSource;
use cbfgen_panda_spheres::{Scenario, Simulation, MAX_OBSTACLES};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ARM_MAX_OBSTACLES", MAX_OBSTACLES)?;
    m.add_function(wrap_pyfunction!(arm_episode, m)?)?;
    Ok(())
}

/// One run of Franka's Panda under its torque filter among ``obstacles`` random spheres
/// drawn from ``seed`` (as OSCBF draws them) above a table, the hand swept low across them
/// at ``cruise_speed`` [rad/s] for ``duration`` [s] (the documented run: 10 s at 0.8).
/// Returns a dict: ``min_obstacle_clearance`` and ``min_table_clearance`` (exact sphere
/// distances over the run [m], negative in contact), ``cycles``, ``fallback_cycles``
/// (inputs that were not a verified QP optimum), ``median_cpu_us`` and ``max_cpu_us`` (the
/// filter update's thread CPU time, nearest rank; 0 without the filter).
/// With ``filter=False`` the nominal torque is only clipped to the limits. Raises
/// ``CbfError`` for more than ``ARM_MAX_OBSTACLES`` obstacles or settings out of range.
/// Releases the GIL while it runs.
#[pyfunction]
#[pyo3(signature = (obstacles=25, seed=0, duration=10.0, cruise_speed=0.8, filter=true))]
fn arm_episode(
    py: Python<'_>,
    obstacles: usize,
    seed: u64,
    duration: f64,
    cruise_speed: f64,
    filter: bool,
) -> PyResult<Bound<'_, PyDict>> {
    if obstacles > MAX_OBSTACLES {
        return Err(cbfgen::CbfError::TooLarge { what: "obstacle count", value: obstacles, max: MAX_OBSTACLES }.into());
    }
    let mut scenario = Scenario::with_obstacles(obstacles, seed);
    (scenario.duration, scenario.cruise_speed, scenario.filter) = (duration, cruise_speed, filter);
    // The update's CPU time is read only when asked for (it costs two clock reads).
    scenario.settings.measure_cpu_time = true;
    let (mut obstacle, mut table, mut cycles, mut fallback) = (f64::INFINITY, f64::INFINITY, 0usize, 0usize);
    let mut cpu = Vec::new();
    py.detach(|| -> Result<(), cbfgen::CbfError> {
        let mut sim = Simulation::new(&scenario)?;
        // As cbfgen_panda_spheres::run steps it, without keeping the samples.
        let steps = (duration / cbfgen_panda_spheres::DT).round() as usize;
        cpu.reserve(steps);
        for _ in 0..steps {
            let s = sim.step()?;
            obstacle = obstacle.min(s.obstacle_clearance);
            table = table.min(s.table_clearance);
            cycles += 1;
            fallback += usize::from(filter && s.source != Some(InputSource::Qp));
            cpu.extend(s.cpu_us);
        }
        Ok(())
    })?;
    let [median_cpu, _, max_cpu] = cbfgen::cpu_time::median_p99_max(&mut cpu);
    let out = PyDict::new(py);
    out.set_item("min_obstacle_clearance", obstacle)?;
    out.set_item("min_table_clearance", table)?;
    out.set_item("cycles", cycles)?;
    out.set_item("fallback_cycles", fallback)?;
    out.set_item("median_cpu_us", median_cpu)?;
    out.set_item("max_cpu_us", max_cpu)?;
    Ok(out)
}
