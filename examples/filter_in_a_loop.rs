//! The ECBF filter in a control loop of your own: Tachyon 3's gait proposes an input
//! every millisecond, the filter corrects it, and the loop integrates the model, over the
//! single step of the hardware stairs.
//!
//! ```text
//! cargo run --release --example filter_in_a_loop
//! ```

use cbfgen::filter::EcbfFilter;
use cbfgen::systems::tachyon3::catalog::{self, Catalog};
use cbfgen::systems::tachyon3::model::xdot;
use cbfgen::systems::tachyon3::sim::gait::GaitParams;
use cbfgen::systems::tachyon3::sim::{Course, Scenario, DT};

fn main() -> Result<(), cbfgen::CbfError> {
    let mut course = Course::new(Scenario::Step, GaitParams::default())?;
    // Sized once, for the course's edges and footholds: nothing is allocated per cycle.
    let mut filter = EcbfFilter::new(Catalog::new(course.environment().capacity())?, catalog::default_settings())?;
    let mut x = course.initial_state(0.3);
    let (mut closest_body, mut closest_toe) = (f64::INFINITY, f64::INFINITY);
    let mut cycles = 0;
    while !course.finished(&x) && cycles < 25_000 {
        let t = cycles as f64 * DT;
        let plan = course.plan(t, &x)?;
        let out = filter.update(&x, &plan.u_ref, course.environment())?;
        let dx = xdot(&x, &out.u);
        for (xi, di) in x.iter_mut().zip(dx) {
            *xi += DT * di;
        }
        let clearance = course.clearance(&x)?;
        (closest_body, closest_toe) = (closest_body.min(clearance.body), closest_toe.min(clearance.toe));
        cycles += 1;
    }
    println!(
        "over the step in {:.2} s: body kept {:.1} mm from the edge, the toes {:.1} mm",
        cycles as f64 * DT,
        closest_body * 1e3,
        closest_toe * 1e3
    );
    assert!(course.finished(&x) && closest_body > 0.0, "the filter got the robot over safely");
    Ok(())
}
