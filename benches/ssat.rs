//! Table I of the Tachyon 3 paper on this machine: cost of one box–box query for the
//! SSAT variants, the exact SAT and parry3d's GJK, all on the same 1024 random pairs.
//! Criterion reports the time for all 1024 pairs; divide by 1024 for one query.

use cbfgen_testkit::boxes as common;

use cbfgen::ssat::{self, SmoothAbs, SmoothMax, SmoothParams};
use cbfgen::{sat, OrientedBox};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use parry3d_f64::math::{Pose, Rot3, Vec3};
use parry3d_f64::query::details::distance_support_map_support_map;
use parry3d_f64::shape::Cuboid;
use std::hint::black_box;

const PAIRS: usize = 1024;

fn parry_pose(b: &OrientedBox) -> Pose {
    let q = nalgebra::UnitQuaternion::from_rotation_matrix(b.rotation());
    let c = b.center();
    Pose::from_parts(Vec3::new(c.x, c.y, c.z), Rot3::from_xyzw(q.i, q.j, q.k, q.w))
}

fn parry_cuboid(b: &OrientedBox) -> Cuboid {
    let h = b.half_extents();
    Cuboid::new(Vec3::new(h.x, h.y, h.z))
}

fn table_one(c: &mut Criterion) {
    let pairs = common::random_pairs(7, PAIRS, 1.0);
    let mut group = c.benchmark_group("ssat_table1");
    group.throughput(Throughput::Elements(PAIRS as u64));
    let variants = [
        ("lse_xtanh", SmoothMax::Lse, SmoothAbs::XTanh),
        ("lse_sqrt", SmoothMax::Lse, SmoothAbs::Sqrt),
        ("boltzmann_xtanh", SmoothMax::Boltzmann, SmoothAbs::XTanh),
    ];
    for (name, max, abs) in variants {
        let p = SmoothParams::default().with_variant(max, abs);
        group.bench_function(BenchmarkId::new("evaluate", name), |bench| {
            bench.iter(|| pairs.iter().map(|(a, b)| ssat::ssat(black_box(a), black_box(b), &p)).sum::<f64>())
        });
        group.bench_function(BenchmarkId::new("evaluate+grad+hess", name), |bench| {
            bench.iter(|| {
                pairs
                    .iter()
                    .map(|(a, b)| ssat::ssat_with_derivatives(black_box(a), black_box(b), &p).hessian[(0, 0)])
                    .sum::<f64>()
            })
        });
    }
    group.bench_function("exact_sat", |bench| {
        bench.iter(|| pairs.iter().map(|(a, b)| sat::separation(black_box(a), black_box(b))).sum::<f64>())
    });
    let parry: Vec<_> =
        pairs.iter().map(|(a, b)| (parry_pose(a).inv_mul(&parry_pose(b)), parry_cuboid(a), parry_cuboid(b))).collect();
    group.bench_function("parry3d_gjk_distance", |bench| {
        bench.iter(|| {
            parry.iter().map(|(pos12, ca, cb)| distance_support_map_support_map(black_box(pos12), ca, cb)).sum::<f64>()
        })
    });
    group.bench_function("parry3d_cuboid_distance", |bench| {
        bench.iter(|| {
            parry
                .iter()
                .map(|(pos12, ca, cb)| parry3d_f64::query::details::distance_cuboid_cuboid(black_box(pos12), ca, cb))
                .sum::<f64>()
        })
    });
    group.finish();
}

criterion_group!(benches, table_one);
criterion_main!(benches);
