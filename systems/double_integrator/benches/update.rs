//! One filter update of the smallest system (2 states, 1 input, 1 row): what an update
//! costs beyond its rows and QP — validation, activation, the verdict — with the thread
//! CPU clock off (the default) and on (two system calls per update on Linux).

use cbfgen_double_integrator::{default_settings, Barriers, Capacity, Filter, Params, SineBarrierParams};
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

fn update(c: &mut Criterion) {
    let mut params = Params::new(Capacity::default()).expect("params");
    params.sine_barrier[0] = SineBarrierParams { amplitude: 0.1, omega: 2.0, offset: -0.05 };
    let mut g = c.benchmark_group("double_integrator");
    for (name, measure_cpu_time) in [("update", false), ("update_with_cpu_clock", true)] {
        let settings = cbfgen::filter::FilterSettings { measure_cpu_time, ..default_settings() };
        let mut filter = Filter::new(Barriers::new(Capacity::default()).expect("rows"), settings).expect("filter");
        // 2 cm above the boundary and falling towards it: the row is active and binds.
        let (t, x, u_ref) = (0.3, [0.1f64.mul_add((0.6f64).sin(), -0.03), -0.5], [-3.0]);
        let out = filter.update_at(t, &x, &u_ref, &params).expect("finite");
        assert_eq!(out.active_rows, 1);
        g.bench_function(name, |b| {
            b.iter(|| filter.update_at(black_box(t), black_box(&x), black_box(&u_ref), &params).map(|o| o.u))
        });
    }
    g.finish();
}

criterion_group!(benches, update);
criterion_main!(benches);
