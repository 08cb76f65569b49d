//! One full ECBF filter update — 269 rows evaluated, QP updated and solved by OSQP,
//! polished — on the robot pressed against a stair nosing (toe and body rows binding),
//! warm-started from the previous cycle as in the control loop. For percentiles over a
//! moving trajectory run `cbfgen latency`.
use cbfgen::filter::EcbfFilter;
use cbfgen::systems::tachyon3::approach::Approach;
use cbfgen::systems::tachyon3::catalog::{self, Capacity};
use cbfgen::systems::tachyon3::terrain::Stairs;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

fn update(c: &mut Criterion) {
    let capacity = Capacity::PAPER_WORST_CASE;
    let mut filter = EcbfFilter::with_capacity(capacity, catalog::default_settings()).expect("filter");
    let mut drive = Approach::new(capacity, Stairs::HARDWARE, 0.1, 0.3).expect("drive");
    // 1.5 s of closed loop: the front toes reach the first nosing and the filter holds them.
    for _ in 0..1500 {
        let u = filter.update(&drive.x, &drive.nominal_input(), &drive.env).expect("finite").u;
        drive.advance(&u, 1e-3);
    }
    let (x, u_ref) = (drive.x, drive.nominal_input());
    let out = *filter.update(&x, &u_ref, &drive.env).expect("finite");
    assert!(out.active_rows > 100 && out.polished, "a binding instance: {out:?}");
    let mut g = c.benchmark_group("filter");
    g.bench_function("update_269_rows_at_stair_edge", |b| {
        b.iter(|| filter.update(black_box(&x), black_box(&u_ref), &drive.env).map(|o| o.u))
    });
    g.finish();
}

criterion_group!(benches, update);
criterion_main!(benches);
