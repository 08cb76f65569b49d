//! OSCBF's torque-controlled Panda between the samples: the plant integrated in 100 RK4
//! steps over each 1 ms period under the held torque, each step's exact sphere clearances
//! measured (the generated forward kinematics, checked against Pinocchio elsewhere), with
//! the sampled-data certificate on and off; and the certificate's enclosure of every
//! torque row against the row's own values along such trajectories.
//!
//! `cargo run --release -p cbfgen-panda-spheres --example between_samples` prints the
//! same sweeps with their cost.

use cbfgen::dual::Dual;
use cbfgen::filter::between_samples::{RowEnclosure, Window};
use cbfgen::filter::BoundCheck;
use cbfgen::interval::Interval;
use cbfgen::system::{BarrierSet, Gains};
use cbfgen_panda_spheres::generated::{self as gen, Barriers, NU, NX};
use cbfgen_panda_spheres::{step_plant, Scenario, Simulation, TorqueRows, DT, START};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Duration;

/// RK4 steps per period: Δt / 100.
const FINE: usize = 100;

/// One 10 s sweep at `n` obstacles.
struct Sweep {
    /// The least exact clearance over every fine step.
    least: f64,
    /// Updates certified.
    certified: usize,
    /// Certified updates that started inside every active row's ECBF safe set.
    certified_from_safe: usize,
    /// The least clearance over the periods of those updates.
    least_certified_from_safe: f64,
    /// The filter's stated worst case beside what its updates did.
    bound: BoundCheck,
}

/// Whether every active row of the filter's last evaluation is in its ECBF safe set:
/// `h ≥ 0` and `ḣ + p h ≥ 0` (poles (10, 10)), to the rows' own rounding.
fn in_safe_set(sim: &Simulation) -> bool {
    sim.filter().rows().iter().filter(|r| r.active && !r.culled).all(|r| {
        let (h, dh) = (r.lie[0], r.lie[1]);
        h >= 0.0 && dh + 10.0 * h >= -1e-12 * (1.0 + dh.abs())
    })
}

fn sweep(n: usize, certified: bool) -> Sweep {
    let mut scenario = Scenario::with_obstacles(n, 1).fine(FINE);
    if certified {
        scenario = scenario.certified();
    }
    let mut sim = Simulation::new(&scenario).unwrap();
    let bound = BoundCheck::new(sim.filter().worst_case(), sim.calibrate().unwrap());
    let mut out = Sweep {
        least: f64::INFINITY,
        certified: 0,
        certified_from_safe: 0,
        least_certified_from_safe: f64::INFINITY,
        bound,
    };
    while sim.time() < scenario.duration - 0.5 * DT {
        let sample = sim.step().unwrap();
        out.bound.record_work(sample.work.unwrap_or_default(), Duration::ZERO);
        let least = sample.obstacle_clearance.min(sample.table_clearance);
        out.least = out.least.min(least);
        if sample.between_samples.is_some_and(|b| b.is_certified()) {
            out.certified += 1;
            // The rows the update saw are the sample's (the filter's last evaluation).
            if in_safe_set(&sim) {
                out.certified_from_safe += 1;
                out.least_certified_from_safe = out.least_certified_from_safe.min(least);
            }
        }
    }
    out
}

/// Without the certificate the sweep dips into an obstacle or the table (by
/// micrometres); with it, every period the filter certified from inside the safe set
/// keeps every sphere out at every fine step. With `whole_sweep`, no sphere enters
/// anything at all (the updates left uncertified did not dip either).
fn safe_between_the_samples_where_certified(n: usize, whole_sweep: bool) {
    let off = sweep(n, false);
    let on = sweep(n, true);
    eprintln!(
        "N = {n}: least clearance off {:.2} µm, on {:.2} µm; {} of 10 000 updates certified ({} from the safe set, \
         least clearance over them {:.2} µm); worst case stated {:.0} µs",
        off.least * 1e6,
        on.least * 1e6,
        on.certified,
        on.certified_from_safe,
        on.least_certified_from_safe * 1e6,
        on.bound.micros().unwrap_or(f64::NAN)
    );
    assert!(off.least < 0.0, "N = {n}: the uncertified sweep was expected to dip between the samples: {}", off.least);
    assert!(
        on.least_certified_from_safe >= 0.0,
        "N = {n}: a period certified from the safe set let a sphere in by {} µm",
        -on.least_certified_from_safe * 1e6
    );
    assert!(
        on.certified_from_safe > 1000,
        "N = {n}: only {} certified periods from the safe set",
        on.certified_from_safe
    );
    // The certified update states its worst case, in time too (its enclosures counted:
    // the interval dynamics, their dual form and the interval solves), and no update
    // passed it in counts.
    let worst = on.bound.worst_case;
    assert!(worst.enclosures > 0 && worst.interval_ops.is_some_and(|o| o.total() > 0), "N = {n}: {worst:?}");
    assert!(on.bound.micros().is_some_and(f64::is_finite), "N = {n}: no time stated\n{}", on.bound);
    assert_eq!(on.bound.beyond_counts, 0, "N = {n}: an update beyond its stated worst case\n{}", on.bound);
    if whole_sweep {
        assert!(on.least >= 0.0, "N = {n}: a sphere entered an obstacle or the table by {} µm", -on.least * 1e6);
    }
}

#[test]
fn no_obstacle_only_the_table() {
    safe_between_the_samples_where_certified(0, true);
}

#[test]
fn ten_obstacles() {
    safe_between_the_samples_where_certified(10, true);
}

#[test]
fn twenty_five_obstacles() {
    safe_between_the_samples_where_certified(25, true);
}

#[test]
fn fifty_obstacles() {
    safe_between_the_samples_where_certified(50, true);
}

#[test]
fn every_torque_row_stays_inside_its_enclosure_along_the_held_torque() {
    // Random states about the sweep's (angles ±0.5 rad about the start, rates up to
    // 1.5 rad/s) and torques about gravity's (±30 % of the limits): every row's
    // ψ = a·τ + b, evaluated on f64 at each of 100 RK4 steps of the period, lies in the
    // enclosure the certificate computed before the period started.
    let scenario = Scenario::with_obstacles(25, 7);
    let params = Simulation::new(&scenario).unwrap().params().clone();
    let mut rows = TorqueRows::new(Barriers::new(params.capacity()).unwrap(), gen::dynamics)
        .with_interval_dynamics(gen::dynamics::<Interval>, gen::dynamics::<Dual<Interval>>);
    let gains: Vec<Gains> =
        scenario.settings.families.iter().map(|f| Gains::with_class_k(&f.poles, f.class_k)).collect();
    let layout = rows.layout().to_vec();
    let mut rng = ChaCha8Rng::seed_from_u64(62);
    let (mut checked, mut enclosed, mut widest) = (0usize, 0usize, 0.0f64);
    for case in 0..100 {
        let mut x = [0.0; NX];
        for j in 0..NU {
            x[j] = START[j] + rng.random_range(-0.5..0.5);
            x[NU + j] = rng.random_range(-1.5..1.5);
        }
        let gravity = gen::dynamics(&[&x[..NU], &[0.0; NU][..]].concat().try_into().unwrap()).1;
        let tau: [f64; NU] = std::array::from_fn(|j| gravity[j] + 0.3 * gen::TAU_MAX[j] * rng.random_range(-1.0..1.0));
        rows.evaluate(0.0, &x, &params).unwrap();
        let wanted: Vec<bool> = rows.rows().iter().map(|r| r.active).collect();
        let mut out = vec![RowEnclosure::ZERO; wanted.len()];
        let window = Window { t: 0.0, period: DT, before: None, u: tau };
        if rows.enclose(&window, &x, &params, &wanted, &mut out).is_err() {
            continue; // not certified, and said so: nothing claimed to check
        }
        enclosed += 1;
        let psi: Vec<Interval> =
            out.iter().zip(&layout).map(|(e, l)| gains[l.family].condition_enclosure(e, &tau)).collect();
        let mut y = x;
        for step in 0..=FINE {
            if step > 0 {
                y = step_plant(&y, &tau, DT / FINE as f64).unwrap();
            }
            rows.evaluate(0.0, &y, &params).unwrap();
            for (i, (row, l)) in rows.rows().iter().zip(&layout).enumerate() {
                if !wanted[i] {
                    continue;
                }
                let value = gains[l.family].condition(row, &tau);
                // The f64 row's own rounding, beside the exact value the enclosure holds.
                let slack = 1e-9 * (1.0 + value.abs());
                assert!(
                    psi[i].lo - slack <= value && value <= psi[i].hi + slack,
                    "case {case}, row {i}, step {step}: ψ = {value} outside {}",
                    psi[i]
                );
                checked += 1;
                widest = widest.max(psi[i].width());
            }
        }
    }
    eprintln!("{enclosed}/100 periods enclosed, {checked} row values inside; widest enclosure {widest:.3}");
    assert!(enclosed >= 75, "only {enclosed} of 100 periods could be enclosed");
}
