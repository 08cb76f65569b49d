//! The generated modules' layout and checks, against values written out by hand.

use cbfgen::nalgebra::{Matrix3, Vector3};
use cbfgen::system::{BarrierSet, ControlAffine, MAX_INSTANCES};
use cbfgen::CbfError;
use spec_crate::{planar_robot as pr, triple_integrator as ti};

#[test]
fn rows_are_laid_out_from_the_capacity_and_filled_slots_are_active() {
    let capacity = pr::Capacity { wall: 2 };
    let mut barriers = pr::Barriers::new(capacity).unwrap();
    let mut params = pr::Params::new(capacity).unwrap();
    params.speed_limit[0].vmax = 2.0;
    let wall = pr::WallParams {
        center: Vector3::new(2.0, 0.5, 0.0),
        rotation: Matrix3::identity(),
        half_extents: Vector3::new(0.5, 1.0, 1.0),
    };
    params.wall.push(wall).unwrap();
    let x = [0.1, 0.2, 0.7, -0.4];
    barriers.evaluate(0.0, &x, &params).unwrap();
    let active: Vec<bool> = barriers.rows().iter().map(|r| r.active).collect();
    assert_eq!(active, [true, true, false]); // speed limit, wall slot 0 filled, slot 1 empty
    assert_eq!(barriers.rows()[0].lg, [-1.4, 0.8]); // −2 v
    assert_eq!(barriers.families()[pr::family::WALL].relative_degree, 2);
    assert_eq!(barriers.families()[pr::family::SPEED_LIMIT].relative_degree, 1);
    assert_eq!(pr::PlanarRobot::xdot(&x, &[1.0, 2.0]), [0.7, -0.4, 1.0, 2.0]);
    assert_eq!((pr::NX, pr::NU, pr::state::VX, pr::input::AY), (4, 2, 2, 1));

    // Full slots, foreign parameters, bad numbers and absurd capacities are typed errors.
    params.wall.push(wall).unwrap();
    assert!(matches!(params.wall.push(wall), Err(CbfError::CapacityExceeded { .. })));
    let foreign = pr::Params::new(pr::Capacity { wall: 1 }).unwrap();
    assert_eq!(barriers.evaluate(0.0, &x, &foreign), Err(CbfError::CapacityMismatch));
    assert!(barriers.evaluate(0.0, &[f64::NAN, 0.0, 0.0, 0.0], &params).is_err());
    params.speed_limit[0].vmax = 1e300;
    assert!(barriers.evaluate(0.0, &x, &params).is_err());
    assert!(pr::Barriers::new(pr::Capacity { wall: MAX_INSTANCES + 1 }).is_err());
}

#[test]
fn the_kernel_table_calls_the_kernels() {
    let entry = ti::KERNELS.iter().find(|k| k.name == "position_limit").unwrap();
    // x = (p, v, a) = (0.25, 1, 2), p_max = 1: lie = [0.75, −1, −2, 0], lg = [−1].
    let mut out = [0.0; 5];
    (entry.call)(&[0.25, 1.0, 2.0, 1.0], &mut out);
    assert_eq!(out, [0.75, -1.0, -2.0, 0.0, -1.0]);
}
