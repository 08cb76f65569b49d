//! Refusing a parameter outside its domain allocates nothing: the barrier set re-checks
//! every parameter on the control path, so a bad edge cuboid (a reflection, 2 I, a
//! negative half extent, NaN) refused by `update`, by `Catalog::evaluate` and by the
//! run-time door's `set` and `push` must cost no allocation, between updates that solve;
//! so must growing the body rows' edges for a measured roll
//! (`Environment::set_body_clearance`, called every cycle), accepted or refused.
//! Counted for Rust's global allocator and for the C `malloc` family OSQP calls; every
//! refusal is checked to be the domain error, so the path counted is the one taken.
//!
//! The counters are process-wide, so this binary has no test harness (`harness = false`
//! in Cargo.toml); `main` runs the one check on the only thread.

#[path = "../../../testkit/alloc_count.rs"]
mod alloc_count;

use cbfgen::dynamic::CapacityCount;
use cbfgen::nalgebra::{Matrix3, Vector3};
use cbfgen::param_domain::Domain;
use cbfgen::{CbfError, OrientedBox};
use cbfgen_tachyon3::catalog::{self, Capacity, Catalog, EdgeCuboid, Environment, Tachyon3Filter};
use cbfgen_tachyon3::model::{standard_posture, NU};

const ROUNDS: usize = 200;

fn main() {
    refusing_parameters_outside_their_domains_allocates_nothing();
    println!("refusing_parameters_outside_their_domains_allocates_nothing ... ok");
}

fn refusing_parameters_outside_their_domains_allocates_nothing() {
    let capacity = Capacity::edges(2, [0; 6]);
    let nosing = OrientedBox::axis_aligned(Vector3::new(0.62, 0.0, 0.14), Vector3::new(0.025, 1.0, 0.025)).unwrap();
    let mut env = Environment::new(capacity).unwrap();
    env.push_edge(EdgeCuboid::from_box(&nosing)).unwrap();
    let good = env.body_edge.as_slice()[0];
    let bad_edges = [
        EdgeCuboid { rotation: Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0)), ..good },
        EdgeCuboid { rotation: Matrix3::identity() * 2.0, ..good },
        EdgeCuboid { half: Vector3::new(-0.025, 1.0, 0.025), ..good },
        EdgeCuboid { center: Vector3::new(0.62, f64::NAN, 0.14), ..good },
    ];
    // Environments with the bad cuboid written past the door, built before the count.
    let bad_envs: Vec<Environment> = bad_edges
        .iter()
        .map(|&edge| {
            let mut bad = env.clone();
            bad.body_edge.as_mut_slice()[0] = edge;
            bad
        })
        .collect();
    let flat = |e: &EdgeCuboid| -> [f64; 15] {
        let r = e.rotation;
        let mut out = [0.0; 15];
        out[..3].copy_from_slice(e.center.as_slice());
        for i in 0..3 {
            for j in 0..3 {
                out[3 + 3 * i + j] = r[(i, j)];
            }
        }
        out[12..].copy_from_slice(e.half.as_slice());
        out
    };
    let bad_flat: Vec<[f64; 15]> = bad_edges.iter().map(flat).collect();

    let mut filter: Tachyon3Filter =
        Tachyon3Filter::new(Catalog::new(capacity).unwrap(), catalog::default_settings()).unwrap();
    let mut catalog = Catalog::new(capacity).unwrap();
    let sys = cbfgen_tachyon3::generated::SYSTEM;
    let body_edge = sys.family_index("body_edge").unwrap();
    let mut params = sys.params(&[CapacityCount { family: body_edge, member: 0, count: 2 }]).unwrap();
    params.push(body_edge, 0, &flat(&good)).unwrap();
    let mut x = standard_posture();
    x[4] = 0.5;
    let u_ref = [0.0; NU];
    filter.update(&x, &u_ref, &env).unwrap();

    alloc_count::assert_counters_work(|| {
        Tachyon3Filter::new(Catalog::new(capacity).unwrap(), catalog::default_settings()).unwrap()
    });

    let is_domain_error =
        |r: Result<(), CbfError>| matches!(r, Err(CbfError::ParamOutOfDomain { family: "body_edge", .. }));
    let (mut refused, mut solved) = (0usize, 0usize);
    let (mut grown, mut solved_grown, mut refused_clearance) = (0usize, 0usize, 0usize);
    let (_, rust, c) = alloc_count::counting(|| {
        for _ in 0..ROUNDS {
            for (bad, numbers) in bad_envs.iter().zip(&bad_flat) {
                refused += usize::from(is_domain_error(filter.update(&x, &u_ref, bad).map(|_| ())));
                refused += usize::from(is_domain_error(catalog.evaluate(&x, bad)));
                refused += usize::from(is_domain_error(params.set(body_edge, 0, 0, numbers)));
                refused += usize::from(is_domain_error(params.push(body_edge, 0, numbers)));
                solved += usize::from(filter.update(&x, &u_ref, &env).is_ok());
            }
            // A measured roll's clearance, applied every cycle: grown, refused, restored.
            grown += usize::from(env.set_body_clearance(0.03).is_ok());
            solved_grown += usize::from(filter.update(&x, &u_ref, &env).is_ok());
            refused_clearance += usize::from(matches!(env.set_body_clearance(-1.0), Err(CbfError::OutOfRange { .. })));
            refused_clearance +=
                usize::from(matches!(env.set_body_clearance(f64::NAN), Err(CbfError::NonFinite { .. })));
            refused_clearance += usize::from(is_domain_error(env.set_body_clearance(1e9)));
            grown += usize::from(env.set_body_clearance(0.0).is_ok());
        }
    });
    assert_eq!(refused, ROUNDS * bad_envs.len() * 4, "every refusal must be the domain error");
    assert_eq!((grown, solved_grown, refused_clearance), (2 * ROUNDS, ROUNDS, 3 * ROUNDS), "body clearance");
    assert_eq!(env.body_edge.as_slice()[0], good, "clearance 0 restores the true cuboid");
    assert_eq!(solved, ROUNDS * bad_envs.len(), "the good environment must still update");
    assert!(matches!(
        catalog.evaluate(&x, &bad_envs[2]),
        Err(CbfError::ParamOutOfDomain { instance: Some(0), param: "half", domain: Domain::Interval { .. }, .. })
    ));
    assert_eq!((rust, c), (0, 0), "refusing parameters allocated: {rust} Rust, {c} C allocations");
}
