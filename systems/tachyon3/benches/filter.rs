//! The ECBF filter's cost, with each backend measured in the same run:
//!
//! * `filter/update_269_rows_at_stair_edge/{dense_then_osqp,osqp}` — one full update (269
//!   rows evaluated, the QP solved) on the robot pressed against a stair nosing (toe and
//!   body rows binding), warm-started from the previous cycle as in the control loop;
//! * `filter/solve_dense` and `filter/solve_osqp` — the QP alone, on the 500 committed
//!   QPs of the stairs run (`systems/tachyon3/tests/data/stairs_qps.bin`, every cycle of the window
//!   t = 25.10–25.30 s included), replayed in time order through a QP laid out as the
//!   filter's; one iteration solves the next problem. `solve_osqp` is this crate's OSQP
//!   path (`Solver::Osqp`: ADMM, then the dense solve from its face), `solve_dense` the
//!   lexicographic dense solve (`Solver::Dense`).
//!
//! For percentiles over a moving trajectory run `cbfgen latency`, or
//! `cargo run --release -p cbfgen-tachyon3 --example replay_stairs_qps` on the fixture.
#[path = "../tests/common/replay.rs"]
mod replay;

use cbfgen::filter::{Backend, EcbfFilter, Solver};
use cbfgen_tachyon3::approach::Approach;
use cbfgen_tachyon3::catalog::Tachyon3FilterExt;
use cbfgen_tachyon3::catalog::{self, Capacity};
use cbfgen_tachyon3::terrain::Stairs;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

fn update(c: &mut Criterion) {
    let capacity = Capacity::PAPER_WORST_CASE;
    let mut g = c.benchmark_group("filter");
    let runs =
        [(Solver::DenseThenOsqp, true, ""), (Solver::DenseThenOsqp, false, "/no_culling"), (Solver::Osqp, true, "")];
    for (backend, cull_far_rows, suffix) in runs {
        let mut settings = catalog::default_settings();
        settings.solver.backend = backend;
        settings.cull_far_rows = cull_far_rows;
        let mut filter = EcbfFilter::with_capacity(capacity, settings).expect("filter");
        let mut drive = Approach::new(capacity, Stairs::HARDWARE, 0.1, 0.3).expect("drive");
        // 1.5 s of closed loop: the front toes reach the first nosing and the filter holds them.
        for _ in 0..1500 {
            let u = filter.update(&drive.x, &drive.nominal_input(), &drive.env).expect("finite").u;
            drive.advance(&u, 1e-3);
        }
        let (x, u_ref) = (drive.x, drive.nominal_input());
        let out = *filter.update(&x, &u_ref, &drive.env).expect("finite");
        let exact = out.backend == Some(Backend::Dense) || out.polished;
        assert!(out.active_rows > 100 && exact, "a binding instance: {out:?}");
        g.bench_function(format!("update_269_rows_at_stair_edge/{}{suffix}", backend.name()), |b| {
            b.iter(|| filter.update(black_box(&x), black_box(&u_ref), &drive.env).map(|o| o.u))
        });
    }
    g.finish();
}

fn solve(c: &mut Criterion) {
    let problems = replay::stairs_qps();
    let mut g = c.benchmark_group("filter");
    for (name, backend) in [("solve_dense", Solver::Dense), ("solve_osqp", Solver::Osqp)] {
        let mut replay = replay::Replay::new(backend, &problems[0]);
        let mut next = 0;
        g.bench_function(name, |b| {
            b.iter(|| {
                replay.load(&problems[next]);
                next = (next + 1) % problems.len();
                black_box(replay.solve())
            })
        });
    }
    g.finish();
}

criterion_group!(benches, update, solve);
criterion_main!(benches);
