//! Tachyon 3 over a course with each input held for a whole 1 ms period on the continuous
//! model (RK4 at Δt/FINE), every row that took part at the sample checked at every fine
//! step, with and without the sampled-data certificate (`FilterSettings::sampled_data`):
//! the least `h` between the samples per family, the least exact clearance of the body and
//! the wheels to the solid terrain, how many updates were certified, and the CPU time.
//!
//! ```text
//! cargo run --release -p cbfgen-tachyon3 --example between_samples [step|stairs] [SECONDS] [FINE]
//! ```
//!
//! Defaults: the one-step course, 25 s, 100 fine steps per period.

use cbfgen::cpu_time::median_p99_max;
use cbfgen::filter::{BetweenSamples, EcbfFilter, SampledData};
use cbfgen::system::BarrierSet;
use cbfgen_tachyon3::catalog::{self, Catalog, Family, FAMILY_COUNT};
use cbfgen_tachyon3::model::held_step;
use cbfgen_tachyon3::sim::gait::GaitParams;
use cbfgen_tachyon3::sim::{Course, Scenario, DT};

struct Run {
    /// Per family: the least h, between the samples, of the rows that took part and were met.
    least_h: [f64; FAMILY_COUNT],
    least_body: f64,
    least_wheel: f64,
    cycles: usize,
    certified: usize,
    /// Certified updates by the QP solves they took: 1, 2, 3, 4 or more.
    solves: [usize; 4],
    finished: bool,
    cpu_us: Vec<f64>,
}

fn run(scenario: Scenario, seconds: f64, fine: usize, certify: bool) -> Result<Run, cbfgen::CbfError> {
    let mut course = Course::new(scenario, GaitParams::default())?;
    let capacity = course.environment().capacity();
    let mut settings = catalog::default_settings();
    settings.measure_cpu_time = true;
    settings.sampled_data = certify.then(|| SampledData::every_family(DT));
    let mut filter = EcbfFilter::new(Catalog::new(capacity)?, settings)?;
    // Every row evaluated in full at the fine steps (no culling).
    let mut checker = Catalog::new(capacity)?;
    let family: Vec<usize> = filter.barriers().slots().map(|s| s.family.index()).collect();
    let mut x = course.initial_state(0.3);
    let mut r = Run {
        least_h: [f64::INFINITY; FAMILY_COUNT],
        least_body: f64::INFINITY,
        least_wheel: f64::INFINITY,
        cycles: 0,
        certified: 0,
        solves: [0; 4],
        finished: false,
        cpu_us: Vec::new(),
    };
    let mut watched = vec![false; family.len()];
    while r.cycles as f64 * DT < seconds {
        let t = r.cycles as f64 * DT;
        course.exchange_origin(t, &mut x);
        let plan = course.plan(t, &x)?;
        let out = *filter.update(&x, &plan.u_ref, course.environment())?;
        r.certified += usize::from(matches!(out.between_samples, BetweenSamples::Certified { .. }));
        if let BetweenSamples::Certified { rounds } = out.between_samples {
            r.solves[(rounds as usize).clamp(1, 4) - 1] += 1;
        }
        r.cpu_us.extend(out.cpu_time.map(|d| d.as_secs_f64() * 1e6));
        for ((w, &on), relaxed) in watched.iter_mut().zip(filter.active()).zip(filter.relaxed()) {
            *w = on && relaxed.is_none();
        }
        let h = DT / fine as f64;
        for j in 1..=fine {
            x = held_step(&x, &out.u, h);
            BarrierSet::evaluate(&mut checker, t + j as f64 * h, &x, course.environment())?;
            for ((row, &w), &f) in checker.rows().iter().zip(&watched).zip(&family) {
                if w {
                    r.least_h[f] = r.least_h[f].min(row.h());
                }
            }
            let clearance = course.clearance(&x)?;
            r.least_body = r.least_body.min(clearance.body.distance);
            r.least_wheel = r.least_wheel.min(clearance.wheel.distance);
        }
        r.cycles += 1;
        if course.finished(&x) {
            r.finished = true;
            break;
        }
    }
    Ok(r)
}

fn main() -> Result<(), cbfgen::CbfError> {
    let mut args = std::env::args().skip(1);
    let scenario = match args.next().as_deref() {
        Some("stairs") => Scenario::Stairs,
        _ => Scenario::Step,
    };
    let seconds: f64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(25.0);
    let fine: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(100);
    println!("{} for up to {seconds} s, {fine} fine steps per 1 ms period", scenario.name());
    let [mut off, mut on] = [run(scenario, seconds, fine, false)?, run(scenario, seconds, fine, true)?];
    println!("{:<14} {:>16} {:>16}", "least h", "off", "certified");
    for f in Family::ALL {
        let (a, b) = (off.least_h[f.index()], on.least_h[f.index()]);
        if a.is_finite() || b.is_finite() {
            println!("{:<14} {a:>16.3e} {b:>16.3e}", f.name());
        }
    }
    println!("{:<14} {:>13.3} mm {:>13.3} mm", "body, exact", off.least_body * 1e3, on.least_body * 1e3);
    println!("{:<14} {:>13.3} mm {:>13.3} mm", "wheel, exact", off.least_wheel * 1e3, on.least_wheel * 1e3);
    println!("{:<14} {:>16} {:>16}", "finished", off.finished, on.finished);
    println!("{:<14} {:>16} {:>10}/{}", "certified", "-", on.certified, on.cycles);
    let [one, two, three, more] = on.solves;
    println!("{:<14} {:>16} {one} in 1 solve, {two} in 2, {three} in 3, {more} in 4 or more", "certified", "-");
    let [m0, p0, _] = median_p99_max(&mut off.cpu_us);
    let [m1, p1, _] = median_p99_max(&mut on.cpu_us);
    println!("{:<14} {:>9.1} / {:>4.0} {:>9.1} / {:>4.0}  (CPU µs per update, median / p99)", "update", m0, p0, m1, p1);
    Ok(())
}
