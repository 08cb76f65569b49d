//! The ECBF filter in a control loop of your own: Tachyon 3's gait proposes an input
//! every millisecond, the filter corrects it, and the loop integrates the model, over the
//! single step of the hardware stairs.
//!
//! ```text
//! cargo run --release -p cbfgen-tachyon3 --example filter_in_a_loop
//! ```

use cbfgen::filter::EcbfFilter;
use cbfgen_tachyon3::catalog::{self, Catalog};
use cbfgen_tachyon3::model::xdot;
use cbfgen_tachyon3::sim::gait::GaitParams;
use cbfgen_tachyon3::sim::{Course, Scenario, DT};

fn main() -> Result<(), cbfgen::CbfError> {
    let mut course = Course::new(Scenario::Step, GaitParams::default())?;
    // Sized once, for the course's edges and footholds: nothing is allocated per cycle.
    let mut filter = EcbfFilter::new(Catalog::new(course.environment().capacity())?, catalog::default_settings())?;
    let mut x = course.initial_state(0.3);
    let (mut closest_body, mut closest_riser) = (f64::INFINITY, f64::INFINITY);
    let mut cycles = 0;
    while !course.finished(&x) && cycles < 25_000 {
        let t = cycles as f64 * DT;
        let plan = course.plan(t, &x)?;
        let out = filter.update(&x, &plan.u_ref, course.environment())?;
        let dx = xdot(&x, &out.u);
        for (xi, di) in x.iter_mut().zip(dx) {
            *xi += DT * di;
        }
        // Exact clearances to the solid terrain (the floor and the step as blocks).
        let clearance = course.clearance(&x)?;
        let riser = clearance.wheel_riser.map_or(f64::INFINITY, |c| c.distance);
        (closest_body, closest_riser) = (closest_body.min(clearance.body.distance), closest_riser.min(riser));
        cycles += 1;
    }
    println!(
        "over the step in {:.2} s: body kept {:.1} mm from the step, the wheels {:.1} mm from its riser",
        cycles as f64 * DT,
        closest_body * 1e3,
        closest_riser * 1e3
    );
    assert!(course.finished(&x) && closest_body > 0.0, "the filter got the robot over safely");
    Ok(())
}
