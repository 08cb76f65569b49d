//! One filter update of the smallest system (2 states, 1 input, 1 row): what an update
//! costs beyond its rows and QP — validation, activation, the verdict — with the thread
//! CPU clock off (the default) and on (two system calls per update on Linux); and the same
//! update through the type-erased layer and through the C ABI's table (what a C or C++
//! program calls every cycle: `filter_update`, which writes the input and returns the
//! verdict), so the cost of each layer is read in one run. `scripts/bench_cpp.py` times the C++ wrapper's update against these.

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
        let (t, x, u_ref) = state();
        let out = filter.update_at(t, &x, &u_ref, &params).expect("finite");
        assert_eq!(out.active_rows, 1);
        g.bench_function(name, |b| {
            b.iter(|| filter.update_at(black_box(t), black_box(&x), black_box(&u_ref), &params).map(|o| o.u))
        });
    }
    erased_and_c(&mut g, state());
    g.finish();
}

/// The benchmark's state: 2 cm above the boundary and falling towards it, so the row is
/// active and binds; `(t, x, u_ref)`.
fn state() -> (f64, [f64; 2], [f64; 1]) {
    (0.3, [0.1f64.mul_add((0.6f64).sin(), -0.03), -0.5], [-3.0])
}

/// The update through `dyn DynFilter`, and through the C ABI (the table `cbfgen::export_c!`
/// exports, called as `cbfgen.h` calls it).
fn erased_and_c(
    g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    state: (f64, [f64; 2], [f64; 1]),
) {
    use cbfgen::plugin::{ErrorC, SettingsC};
    let (t, x, u_ref) = state;
    let system = cbfgen_double_integrator::SYSTEM;
    let mut params = system.params(&[]).expect("params");
    params.set(0, 0, 0, &[0.1, 2.0, -0.05]).expect("amplitude, omega, offset");
    let mut filter = system.filter(&[], &system.default_settings()).expect("filter");
    filter.update(t, &x, &u_ref, params.as_ref()).expect("finite");
    assert_eq!(filter.output().active_rows, 1);
    g.bench_function("update_type_erased", |b| {
        b.iter(|| {
            filter
                .update(black_box(t), black_box(&x), black_box(&u_ref), params.as_ref())
                .map(|()| filter.output().u[0])
        })
    });

    struct DoubleIntegrator;
    impl cbfgen::plugin::Exported for DoubleIntegrator {
        const SYSTEM: &'static dyn cbfgen::dynamic::DynSystem = cbfgen_double_integrator::SYSTEM;
    }
    static TABLE: cbfgen::plugin::PluginV1 = cbfgen::plugin::table::<DoubleIntegrator>();
    let table = &TABLE;
    let mut err = ErrorC::new();
    // SAFETY (every call): the table's own handles, buffers sized from its description.
    let c_params = unsafe { (table.params_new)(std::ptr::null(), 0, &mut err) };
    let mut boundary = [0.1, 2.0, -0.05];
    let set = unsafe {
        (table.store)(c_params, cbfgen::plugin::store_op::SET, 0, 0, 0, boundary.as_mut_ptr(), 3, false, &mut err)
    };
    assert_eq!(set, 0);
    let description = unsafe { &*(table.describe)() };
    let mut families = vec![unsafe { std::mem::zeroed() }; description.n_families];
    let mut inputs = [[0.0; 1]; 3];
    let [weights, min, max] = &mut inputs;
    let mut settings = SettingsC {
        n_families: families.len(),
        n_inputs: 1,
        families: families.as_mut_ptr(),
        input_weights: weights.as_mut_ptr(),
        input_min: min.as_mut_ptr(),
        input_max: max.as_mut_ptr(),
        solver: unsafe { std::mem::zeroed() },
        measure_cpu_time: false,
        cull_far_rows: true,
    };
    assert_eq!(unsafe { (table.default_settings)(&mut settings, &mut err) }, 0);
    let c_filter = unsafe { (table.filter_new)(std::ptr::null(), 0, &settings, &mut err) };
    assert!(!c_filter.is_null());
    let mut u = [0.0];
    g.bench_function("update_through_c_abi", |b| {
        b.iter(|| unsafe {
            let (t, x, u_ref) = (black_box(t), black_box(&x), black_box(&u_ref));
            (table.filter_update)(c_filter, t, x.as_ptr(), 2, u_ref.as_ptr(), 1, c_params, u.as_mut_ptr(), 1, &mut err);
            u[0]
        })
    });
    unsafe {
        (table.filter_free)(c_filter);
        (table.params_free)(c_params);
    }
}

criterion_group!(benches, update);
criterion_main!(benches);
