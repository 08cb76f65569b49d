//! What one filter update of ANYmal C costs: the standing robot under a swinging nominal,
//! every foot on a square foothold above the ground (20 foothold rows), its joint limits (48
//! rows) and 30 self-collision pairs (culled beyond 0.2 m, and all evaluated), and what the
//! generated foot kinematics costs alone.

use cbfgen::filter::EcbfFilter;
use cbfgen_anymal::generated::{self as gen, Barriers, NU, NX};
use cbfgen_anymal::{square_footholds, swinging_nominal};
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

fn standing() -> [f64; NX] {
    let mut x = [0.0; NX];
    x[..NU].copy_from_slice(&gen::STANDING);
    x
}

fn update(c: &mut Criterion) {
    let x = standing();
    let params = square_footholds(&x, 0.05, 0.0).expect("footholds");
    let mut group = c.benchmark_group("anymal");
    for (name, activation) in [("update_culled", None), ("update_all_rows", Some(f64::INFINITY))] {
        let mut settings = gen::default_settings();
        if let Some(a) = activation {
            for family in settings.families.iter_mut() {
                family.activation = a;
            }
        }
        let mut filter =
            EcbfFilter::new(Barriers::new(params.capacity()).expect("capacity"), settings).expect("filter");
        // A state mid-swing, where rows are active.
        let mut moving = x;
        moving[NU + 7] = 1.5;
        moving[NU + 10] = -1.5;
        let u_ref = swinging_nominal(0.1, &moving, 0.6, 1.0);
        group.bench_function(name, |b| {
            b.iter(|| *filter.update(black_box(&moving), black_box(&u_ref), &params).unwrap())
        });
    }
    group.bench_function("feet", |b| b.iter(|| gen::feet(black_box(&x))));
    group.finish();
}

criterion_group!(benches, update);
criterion_main!(benches);
