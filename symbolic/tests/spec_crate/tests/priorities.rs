//! Issue 32's quadrotor: its speed limit acts only through thrust, which pushes one way;
//! tilted and too fast, the speed row asks for less than no thrust while the floor asks
//! for more. With both at priority 0 the filter says so every cycle (the rows it relaxed,
//! why, and the input at its limit) — and the drone is below its floor, reported; with the
//! floor at 0 and the speed limit at 1, the floor holds and the speed limit yields,
//! reported too. Every cycle's verdict is checked against the rows recomputed here by hand.

use cbfgen::filter::{Cause, InputSource, Limit, Verdict};
use cbfgen::system::ControlAffine;
use spec_crate::planar_quadrotor as quad;

const DT: f64 = 1e-3;
const G: f64 = 9.81;
const VMAX: f64 = 2.5;
const Z_FLOOR: f64 = 0.0;

/// A nominal controller that holds a forward tilt with hover thrust: it keeps
/// accelerating along x, past the speed limit.
fn nominal(x: &[f64; quad::NX]) -> [f64; quad::NU] {
    let (theta, omega) = (x[quad::state::THETA], x[quad::state::OMEGA]);
    [G / theta.cos(), -25.0 * (theta + 0.4) - 10.0 * omega]
}

/// `L_f^r h + Σ k L_f^k h + L_g L_f^{r-1} h · u` of both rows by hand, with the spec's
/// poles (speed 5; floor 4, 4): [speed, floor].
fn rows_by_hand(x: &[f64; quad::NX], u: &[f64; quad::NU]) -> [f64; 2] {
    let (z, th, vx, vz) = (x[1], x[2], x[3], x[4]);
    let (ax, az) = (-u[0] * th.sin(), u[0] * th.cos() - G);
    let speed = VMAX * VMAX - vx * vx - vz * vz;
    let speed_rate = -2.0 * (vx * ax + vz * az);
    let floor = z - Z_FLOOR;
    [speed_rate + 5.0 * speed, az + 8.0 * vz + 16.0 * floor]
}

struct Run {
    lowest_floor: f64,
    speed_at_thrust_min: usize,
    floor_relaxed: usize,
    speed_yields_to_floor: usize,
    cycles: usize,
}

fn run(floor_priority: u8, speed_priority: u8) -> Run {
    let mut params = quad::Params::new(quad::Capacity::default()).unwrap();
    params.speed_limit[0].vmax = VMAX;
    params.floor[0].z_floor = Z_FLOOR;
    let mut settings = quad::default_settings();
    settings.families[quad::family::FLOOR].priority = floor_priority;
    settings.families[quad::family::SPEED_LIMIT].priority = speed_priority;
    let mut filter = quad::Filter::new(quad::Barriers::new(quad::Capacity::default()).unwrap(), settings).unwrap();
    // 1.5 m up, tilted forward, already at the speed limit.
    let mut x = [0.0, 1.5, -0.4, VMAX, 0.0, 0.0];
    let mut r = Run { lowest_floor: f64::INFINITY, speed_at_thrust_min: 0, floor_relaxed: 0, speed_yields_to_floor: 0, cycles: 0 };
    for _ in 0..4000 {
        let out = *filter.update(&x, &nominal(&x), &params).unwrap();
        assert_eq!(out.source, InputSource::Qp, "every cycle is solved: {:?}", out.status);
        // The verdict against the rows recomputed here: a row missed beyond rounding is
        // reported relaxed, a row that holds is not.
        let by_hand = rows_by_hand(&x, &out.u);
        for (row, value) in by_hand.iter().enumerate() {
            let reported = filter.relaxed()[row].is_some();
            if *value < -1e-6 {
                assert!(reported, "row {row} missed by {} but reported met", -value);
            } else if *value > 1e-6 {
                assert!(!reported, "row {row} holds ({value}) but is reported relaxed");
            }
        }
        assert_eq!(out.safety.verdict == Verdict::Met, filter.relaxed().iter().all(Option::is_none));
        match filter.relaxed()[0] {
            Some(Cause::InputLimit { input, limit: Limit::Min }) if input == quad::input::THRUST => {
                // The row is missed by no more than with the thrust at that limit (to the
                // solver's rounding, 1e-8 of the row's terms): the limit is what holds it.
                let at_limit = rows_by_hand(&x, &[0.0, out.u[1]])[0];
                let terms = by_hand[0].abs() + at_limit.abs() + 1.0;
                assert!(by_hand[0] >= at_limit - 1e-8 * terms, "{by_hand:?} vs {at_limit} with zero thrust");
                r.speed_at_thrust_min += 1;
            }
            Some(Cause::HigherPriority { row: 1 }) => r.speed_yields_to_floor += 1,
            _ => {}
        }
        r.floor_relaxed += usize::from(filter.relaxed()[1].is_some());
        let dx = quad::PlanarQuadrotor::xdot(&x, &out.u);
        for (s, d) in x.iter_mut().zip(dx) {
            *s += DT * d;
        }
        r.lowest_floor = r.lowest_floor.min(x[quad::state::Z] - Z_FLOOR);
        r.cycles += 1;
    }
    eprintln!(
        "floor priority {floor_priority}, speed {speed_priority}: lowest {:.4} m above the floor; speed row at zero thrust {} cycles, yielding to the floor {}; floor relaxed {}",
        r.lowest_floor, r.speed_at_thrust_min, r.speed_yields_to_floor, r.floor_relaxed
    );
    r
}

#[test]
fn at_one_priority_the_speed_limit_starves_the_floor_and_the_filter_says_so() {
    let r = run(0, 0);
    // The speed row asks for negative thrust: relaxed with the thrust at its minimum.
    assert!(r.speed_at_thrust_min > 100, "speed row at thrust = 0 in {} cycles", r.speed_at_thrust_min);
    // The drone falls through its floor, and the floor row is reported relaxed.
    assert!(r.lowest_floor < -0.01, "the floor held ({}): the test no longer exercises the conflict", r.lowest_floor);
    assert!(r.floor_relaxed > 0);
}

#[test]
fn with_the_floor_first_the_floor_holds_and_the_speed_limit_yields_reported() {
    let r = run(0, 1);
    assert!(r.lowest_floor >= -1e-6, "the floor was crossed by {}", -r.lowest_floor);
    assert_eq!(r.floor_relaxed, 0, "the floor is never relaxed");
    assert!(r.speed_yields_to_floor + r.speed_at_thrust_min > 100, "the speed limit yields, reported");
    assert!(r.speed_yields_to_floor > 0, "and it says to which row");
}
