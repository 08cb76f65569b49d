//! ANYmal C's control path allocates nothing: 5 s of the swinging legs on square
//! footholds (joint limits, velocity limits, 20 foothold rows, 30 self-collision pairs),
//! with a NaN state rejected now and then. Counted for Rust's global allocator and for the
//! C `malloc` family OSQP calls; no test harness (`harness = false`), so `main` runs the
//! one check on the only thread.

#[path = "../../../testkit/alloc_count.rs"]
mod alloc_count;

use cbfgen::filter::{EcbfFilter, InputSource};
use cbfgen_anymal::generated::{self as gen, Barriers, NU, NX};
use cbfgen_anymal::{square_footholds, swinging_nominal};

fn main() {
    let mut x = [0.0; NX];
    x[..NU].copy_from_slice(&gen::STANDING);
    let params = square_footholds(&x, 0.05, 0.0).expect("footholds");
    let new_filter =
        || EcbfFilter::new(Barriers::new(params.capacity()).unwrap(), gen::default_settings()).expect("filter");
    let mut filter = new_filter();
    alloc_count::assert_counters_work(new_filter);
    let dt = 1e-3;
    let (mut solved, mut rejected) = (0usize, 0usize);
    let cycles = 5000;
    let (_, rust, c) = alloc_count::counting(|| {
        for k in 0..cycles {
            let u_ref = swinging_nominal(k as f64 * dt, &x, 0.6, 1.5);
            let out = *filter.update(&x, &u_ref, &params).expect("in the domain");
            solved += usize::from(out.source == InputSource::Qp);
            if k % 100 == 0 {
                let mut nan = x;
                nan[9] = f64::NAN;
                rejected += usize::from(filter.update(&nan, &u_ref, &params).is_err());
            }
            for i in 0..NU {
                x[i] += dt * x[NU + i] + 0.5 * dt * dt * out.u[i];
                x[NU + i] += dt * out.u[i];
            }
        }
    });
    assert_eq!((rust, c), (0, 0), "allocations during {cycles} cycles: Rust {rust}, C {c}");
    assert_eq!(solved, cycles);
    assert_eq!(rejected, cycles / 100);
    println!("the_anymal_filter_allocates_nothing ... ok");
}
