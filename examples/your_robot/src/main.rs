//! Drive the unicycle of `spec/your_robot.py` to a goal behind an obstacle, with the
//! generated barriers in cbfgen's ECBF filter between the nominal controller and the robot.
//!
//! `cargo run -p your_robot --release` (needs Python 3 with SymEngine for the build; see
//! the cbfgen README, "Your own robot").

use cbfgen::nalgebra::Vector2;
use cbfgen::system::ControlAffine;
use std::process::ExitCode;

/// The generated module: `NX`, `NU`, `YourRobot`, `Params`, `Barriers`, `Filter`, …
#[allow(dead_code)] // it has more than this program uses
mod your_robot {
    cbfgen::include_system!("your_robot");
}
use your_robot as robot;

const DT: f64 = 1e-3; // one control cycle [s]
const GOAL: [f64; 2] = [6.0, 0.0];

/// The nominal controller: head for the goal at a cruise speed, blind to every obstacle.
fn nominal(x: &[f64; robot::NX]) -> [f64; robot::NU] {
    let (dx, dy) = (GOAL[0] - x[robot::state::PX], GOAL[1] - x[robot::state::PY]);
    let bearing = dy.atan2(dx) - x[robot::state::HEADING];
    let turn = bearing.sin().atan2(bearing.cos()); // wrapped to (−π, π]
    let cruise = (0.5 * dx.hypot(dy)).min(1.5);
    [2.0 * (cruise - x[robot::state::SPEED]), 3.0 * turn]
}

fn main() -> Result<ExitCode, cbfgen::CbfError> {
    let capacity = robot::Capacity { obstacle: 4 };
    let mut params = robot::Params::new(capacity)?;
    params.speed_limit[0].max_speed = 1.2;
    params.obstacle.push(robot::ObstacleParams { center: Vector2::new(3.0, 0.15), radius: 0.8 })?;
    // A corridor 3 m wide: y ≥ −1.5 and y ≤ 1.5.
    params.corridor[0] = robot::CorridorParams { normal: Vector2::new(0.0, 1.0), offset: 1.5 };
    params.corridor[1] = robot::CorridorParams { normal: Vector2::new(0.0, -1.0), offset: 1.5 };

    // Turning is cheap, braking dear: around the obstacle rather than stopping before it.
    let mut settings = robot::default_settings();
    settings.input_weights = [10.0, 0.1];
    let mut filter = robot::Filter::new(robot::Barriers::new(capacity)?, settings)?;
    let mut x = [0.0; robot::NX];
    let (mut min_clearance, mut fallbacks) = (f64::INFINITY, 0);
    for _ in 0..(20.0 / DT) as usize {
        let out = filter.update(&x, &nominal(&x), &params)?;
        fallbacks += usize::from(out.source != cbfgen::filter::InputSource::Qp);
        let dx = robot::YourRobot::xdot(&x, &out.u);
        for (s, d) in x.iter_mut().zip(dx) {
            *s += DT * d;
        }
        let centre = Vector2::new(3.0, 0.15);
        min_clearance = min_clearance.min((Vector2::new(x[0], x[1]) - centre).norm() - 0.8);
    }
    let to_goal = (GOAL[0] - x[0]).hypot(GOAL[1] - x[1]);
    println!("closest approach to the obstacle: {min_clearance:.3} m (inflated radius 0.8 m)");
    println!("distance to the goal after 20 s: {to_goal:.3} m; cycles not solved by the QP: {fallbacks}");
    Ok(if min_clearance >= 0.0 { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}
