//! What one filter update of ANYmal C costs: the standing robot under a swinging nominal,
//! every foot on a square foothold above the ground (20 foothold rows), its joint limits (48
//! rows) and 30 self-collision pairs (culled beyond 0.2 m, and all evaluated), and what the
//! generated foot kinematics costs alone; the whole-body controller's kernels (free-flyer
//! mass matrix and bias, the four contact points with Jacobians and J' v).

use cbfgen::filter::EcbfFilter;
use cbfgen_anymal::gait::{footholds_around, standing_on_the_ground, Trot};
use cbfgen_anymal::generated::{self as gen, Barriers, NU, NX};
use cbfgen_anymal::wbc::{WbcSettings, WholeBodyController};
use cbfgen_anymal::wbc_generated as wbc;
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

/// A trotting-like state in free-flyer coordinates: the standing joints, the trunk tilted
/// and moving, every rate non-zero (no term of the kernels drops out).
fn wbc_state() -> [f64; wbc::NX] {
    let (roll, pitch, yaw) = (0.05_f64, -0.08_f64, 0.3_f64);
    let (cr, sr, cp, sp, cy, sy) = (roll.cos(), roll.sin(), pitch.cos(), pitch.sin(), yaw.cos(), yaw.sin());
    let rotation = [
        cy * cp,
        cy * sp * sr - sy * cr,
        cy * sp * cr + sy * sr,
        sy * cp,
        sy * sp * sr + cy * cr,
        sy * sp * cr - cy * sr,
        -sp,
        cp * sr,
        cp * cr,
    ];
    let mut x = [0.0; wbc::NX];
    x[2] = wbc::STANDING_HEIGHT;
    x[3..12].copy_from_slice(&rotation);
    x[12..24].copy_from_slice(&wbc::STANDING_JOINTS);
    for (i, v) in x[24..].iter_mut().enumerate() {
        *v = 0.3 * ((i as f64) * 0.7).sin();
    }
    x
}

fn whole_body_kernels(c: &mut Criterion) {
    let x = wbc_state();
    let mut group = c.benchmark_group("anymal_wbc");
    group.bench_function("dynamics", |b| b.iter(|| wbc::dynamics(black_box(&x))));
    group.bench_function("contacts", |b| b.iter(|| wbc::contacts(black_box(&x))));
    // One controller cycle mid-trot: two feet swinging (LF asked 10 cm past its 3 cm
    // square, so its CBF rows bind), two in stance, all three levels.
    let standing = standing_on_the_ground();
    let home = wbc::contacts(&standing).0;
    let params = footholds_around(&home, 0.03).expect("footholds");
    let gait = Trot::in_place(0.3, 0.08, 0.1, home, [standing[0], standing[1], standing[2]]);
    let mut controller = WholeBodyController::new(params.capacity(), WbcSettings::default()).expect("controller");
    let t = 0.3 + 0.4 * 0.3; // 40 % into LF and RH's swing
    let reference = gait.reference(t);
    let mut state = standing;
    state[24..].copy_from_slice(&x[24..]); // moving
    group.bench_function("update_trot", |b| {
        b.iter(|| controller.update(t, black_box(&state), black_box(&reference), &params, 2.5e-3).unwrap())
    });
    group.finish();
}

criterion_group!(benches, update, whole_body_kernels);
criterion_main!(benches);
