//! Cost of the Tachyon 3 ECBF rows: one row of each family (h, L_f h, L_f² h, L_g L_f h)
//! and the whole catalog at the paper's worst case (269 rows), on the standard posture
//! in front of a staircase of 20 edge cuboids.

use cbfgen::system::BarrierSet;
use cbfgen::OrientedBox;
use cbfgen_tachyon3::catalog::{self, Capacity, Catalog, EdgeCuboid, Environment, HalfPlane, StabilityBound};
use cbfgen_tachyon3::generated as gen;
use cbfgen_tachyon3::model::{self, State};
use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Rotation3, Vector2, Vector3};
use std::hint::black_box;

/// 20 stair-edge cuboids (5 cm square, 2 m long, along y) every 35 cm ahead, rising 16.5 cm.
fn staircase() -> Vec<EdgeCuboid> {
    (0..20)
        .map(|i| {
            let c = Vector3::new(0.8 + 0.35 * i as f64, 0.0, 0.165 * (i + 1) as f64 - 0.025);
            let b = OrientedBox::new(
                c,
                Rotation3::from_euler_angles(0.0, 0.0, 0.02 * i as f64),
                Vector3::new(0.025, 1.0, 0.025),
            );
            EdgeCuboid::from_box(&b.expect("valid edge"))
        })
        .collect()
}

fn moving_posture() -> State {
    let mut x = model::standard_posture();
    x[4] = 0.3; // rolling forward
    x[9] = 0.05;
    x[8] = 0.05;
    x
}

fn per_row(c: &mut Criterion) {
    let x = moving_posture();
    let edge = staircase()[0];
    let (ec, er, eh) = edge.kernel_args();
    let (ec, er, eh) = (&ec, &er, &eh);
    let mut g = c.benchmark_group("constraint_row");
    g.bench_function("body_edge_ssat", |b| b.iter(|| gen::body_edge(black_box(&x), ec, er, eh)));
    g.bench_function("body_edge_lower_bound", |b| b.iter(|| gen::body_edge_lower_bound(black_box(&x), ec, er, eh)));
    g.bench_function("toe_edge_lower_bound", |b| b.iter(|| gen::toe_edge_lower_bound(black_box(&x), ec, er, eh)));
    g.bench_function("toe_edge (6 rows, one per toe)", |b| b.iter(|| gen::toe_edge(black_box(&x), ec, er, eh)));
    g.bench_function("joint_limits (4 rows)", |b| b.iter(|| gen::JOINT_LIMITS[0](black_box(&x))));
    g.bench_function("foothold", |b| b.iter(|| gen::FOOTHOLD[0](black_box(&x), &Vector2::new(0.6, 0.8), 0.4)));
    g.bench_function("foot_height", |b| b.iter(|| gen::FOOT_HEIGHT[0](black_box(&x), 0.0)));
    g.bench_function("stability", |b| b.iter(|| gen::STABILITY[0](black_box(&x), 1.0, 0.3)));
    g.finish();
}

fn whole_catalog(c: &mut Criterion) {
    let cap = Capacity::PAPER_WORST_CASE;
    let mut env = Environment::new(cap).unwrap();
    for e in staircase() {
        env.push_edge(e).expect("capacity");
    }
    for leg in 0..6 {
        let planes: Vec<_> = (0..cap.foothold[leg])
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / cap.foothold[leg] as f64;
                HalfPlane::new([a.cos(), a.sin()], 2.0).expect("valid")
            })
            .collect();
        env.set_foothold(leg, &planes).expect("capacity");
        env.stability[leg] = [Some(StabilityBound { a: 1.0, b: 0.3 }), Some(StabilityBound { a: -1.0, b: 0.3 })];
    }
    env.set_swing([true; 6]);
    let mut catalog = Catalog::new(cap).unwrap();
    let x = moving_posture();
    catalog.evaluate(&x, &env).expect("finite");
    assert_eq!(catalog.rows().iter().filter(|r| r.active).count(), 269);
    c.bench_function("catalog/269_rows", |b| b.iter(|| catalog.evaluate(black_box(&x), &env)));
    // As the filter evaluates them: instances whose lower bound is above their family's
    // activation threshold are culled, the rest evaluated in full.
    let thresholds: Vec<f64> = catalog::default_settings().families.iter().map(|f| f.activation).collect();
    catalog.cull_above(&thresholds);
    catalog.evaluate(&x, &env).expect("finite");
    let culled = catalog.rows().iter().filter(|r| r.culled).count();
    println!("catalog/269_rows_culled: {culled} of 269 rows culled at this posture");
    c.bench_function("catalog/269_rows_culled", |b| b.iter(|| catalog.evaluate(black_box(&x), &env)));
}

criterion_group!(benches, per_row, whole_catalog);
criterion_main!(benches);
