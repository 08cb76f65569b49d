//! What each of your constraints costs, and one whole filter update: the pattern for any
//! outside crate (`cargo bench -p your_robot`; in your own crate, `cargo bench`).
//!
//! Each family's generated kernel is a plain function of the state and one instance's
//! parameters (vectors and matrices as the nalgebra types `Params` holds them in), returning
//! the row's Lie derivatives; `black_box` keeps the compiler from computing it once.

use cbfgen::nalgebra::Vector2;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

#[allow(dead_code)] // the bench uses part of it
mod your_robot {
    cbfgen::include_system!("your_robot");
}
use your_robot as robot;

fn constraints(c: &mut Criterion) {
    // A state with every row active: moving at 1 m/s, 1 m from an obstacle.
    let x = [2.0, 0.0, 0.1, 1.0];
    let mut rows = c.benchmark_group("your_robot/row");
    rows.bench_function("speed_limit", |b| b.iter(|| robot::speed_limit(black_box(&x), black_box(1.2))));
    rows.bench_function("obstacle", |b| {
        b.iter(|| robot::obstacle(black_box(&x), &Vector2::new(3.0, 0.15), black_box(0.8)))
    });
    rows.bench_function("corridor", |b| {
        b.iter(|| robot::corridor(black_box(&x), &Vector2::new(0.0, 1.0), black_box(1.5)))
    });
    rows.finish();

    // One whole update: every row evaluated, the QP solved, the verdict measured.
    let capacity = robot::Capacity { obstacle: 1 };
    let mut params = robot::Params::new(capacity).expect("capacity");
    params.speed_limit[0].max_speed = 1.2;
    params.obstacle.push(robot::ObstacleParams { center: Vector2::new(3.0, 0.15), radius: 0.8 }).expect("room");
    params.corridor[0] = robot::CorridorParams { normal: Vector2::new(0.0, 1.0), offset: 1.5 };
    params.corridor[1] = robot::CorridorParams { normal: Vector2::new(0.0, -1.0), offset: 1.5 };
    let mut filter =
        robot::Filter::new(robot::Barriers::new(capacity).expect("rows"), robot::default_settings()).expect("filter");
    let u_ref = [1.0, 0.0];
    c.bench_function("your_robot/update", |b| {
        b.iter(|| filter.update(black_box(&x), black_box(&u_ref), &params).map(|out| out.u))
    });
}

criterion_group!(benches, constraints);
criterion_main!(benches);
