//! The control path allocates nothing: thousands of filter updates along the drive into
//! the stairs, counted two ways — Rust's global allocator, and the C `malloc` family
//! that OSQP (compiled C, linked into this binary) would call.
//!
//! The counters are process-wide, so this binary has no test harness (`harness = false`
//! in Cargo.toml): libtest's own thread allocates while a test runs, and once made this
//! count flaky under load. `main` runs the one check on the only thread.

#[path = "common/alloc_count.rs"]
mod alloc_count;

use cbfgen::approach::Approach;
use cbfgen::catalog::Capacity;
use cbfgen::filter::{EcbfFilter, FilterSettings, InputSource};
use cbfgen::terrain::Stairs;

fn main() {
    thousands_of_filter_updates_allocate_nothing();
    println!("thousands_of_filter_updates_allocate_nothing ... ok");
}

fn thousands_of_filter_updates_allocate_nothing() {
    let capacity = Capacity::PAPER_WORST_CASE;
    let mut filter = EcbfFilter::new(capacity, FilterSettings::default()).expect("filter");
    let mut drive = Approach::new(capacity, Stairs::HARDWARE, 0.3, 0.4).expect("drive");
    let mut broken = drive.x;
    broken[7] = f64::NAN;

    alloc_count::assert_counters_work(|| {
        EcbfFilter::new(Capacity { edges: 1, foothold_edges: [1; 6] }, FilterSettings::default())
    });

    let (mut sources, mut solved) = ([0usize; 4], 0);
    let ((), rust, c) = alloc_count::counting(|| {
        for cycle in 0..3000 {
            let u_ref = drive.nominal_input();
            // Every 500th cycle a bad state: the error path must not allocate either.
            if cycle % 500 == 250 {
                let _ = filter.update(&broken, &u_ref, &drive.env);
            }
            let out = match filter.update(&drive.x, &u_ref, &drive.env) {
                Ok(out) => *out,
                Err(_) => break,
            };
            sources[out.source as usize] += 1;
            solved += usize::from(out.polished);
            drive.advance(&out.u, 1e-3);
        }
    });
    assert_eq!((rust, c), (0, 0), "allocations during 3000 updates: Rust {rust}, C {c}");
    assert_eq!(sources.iter().sum::<usize>(), 3000, "an update failed");
    assert!(sources[InputSource::Qp as usize] > 2900 && solved > 2900, "the loop must really solve: {sources:?}");
    assert!(drive.x[0] > 0.1, "the robot must have moved");
}
