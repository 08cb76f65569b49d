//! One perception update on an accumulated map of about 10⁵ points (a floor and three
//! steps scanned from six poses on the way up, 1 cm range noise, 5 % dropouts), and its
//! stages:
//!
//! * `perception/scan` — one 32 × 720-ray scan against four boxes;
//! * `perception/segment` — normals, region growing, RANSAC refits and hulls
//!   (`planes::segment`), its neighbourhoods on every core, and `…_1_thread` on one;
//! * `perception/edges` — edge cuboids from the planes (`edges::edge_cuboids`);
//! * `perception/update` — segment and edges together, what a 1 Hz update costs;
//! * `perception/update_voxel_map` — the same on the 2 cm voxel map the closed loop's
//!   worker segments (`perception::map::VoxelMap` of the same scans), and
//!   `perception/map_insert` — adding one scan to that map, where it has been before.
//!
//! Criterion reports time per iteration; points per second is the map size over that
//! (throughput is set to the map's points).

use cbfgen_perception::edges::{self, EdgeSettings};
use cbfgen_perception::map::VoxelMap;
use cbfgen_perception::planes::{self, SegmentSettings};
use cbfgen_perception::scanner::Lidar;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

#[path = "../tests/step_terrain.rs"]
mod step_terrain;
use step_terrain::{terrain, SCAN_POSES};

fn perception(c: &mut Criterion) {
    let (lidar, world) = (Lidar::default(), terrain());
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let map: Vec<Vector3<f64>> = SCAN_POSES
        .iter()
        .flat_map(|&(x, z)| lidar.scan(&Vector3::new(x, 0.0, z), 0.0, &world, &[], &mut rng).unwrap())
        .collect();
    let segment = SegmentSettings { viewpoint: Vector3::new(0.0, 0.0, 0.6), ..Default::default() };
    let found = planes::segment(&map, &segment).unwrap();
    assert!(found.len() >= 7, "the map's planes: {}", found.len());
    let mut g = c.benchmark_group("perception");
    g.sample_size(10);
    g.bench_function("scan", |b| {
        b.iter(|| lidar.scan(black_box(&Vector3::new(0.0, 0.0, 0.6)), 0.0, &world, &[], &mut rng))
    });
    g.throughput(Throughput::Elements(map.len() as u64));
    g.bench_function(format!("segment_{}_points", map.len()), |b| {
        b.iter(|| planes::segment(black_box(&map), &segment))
    });
    let one_thread = SegmentSettings { threads: 1, ..segment };
    g.bench_function(format!("segment_{}_points_1_thread", map.len()), |b| {
        b.iter(|| planes::segment(black_box(&map), &one_thread))
    });
    g.bench_function("edges", |b| b.iter(|| edges::edge_cuboids(black_box(&found), &map, &EdgeSettings::default())));
    g.bench_function(format!("update_{}_points", map.len()), |b| {
        b.iter(|| {
            let found = planes::segment(black_box(&map), &segment)?;
            edges::edge_cuboids(&found, &map, &EdgeSettings::default())
        })
    });
    let mut voxels = VoxelMap::new(0.02).unwrap();
    voxels.insert(&map).unwrap();
    let (centroids, counts) = voxels.points_near(&Vector3::new(1.0, 0.0, 0.0), 3.5);
    g.throughput(Throughput::Elements(centroids.len() as u64));
    g.bench_function(format!("update_voxel_map_{}_points", centroids.len()), |b| {
        b.iter(|| {
            let found = planes::segment_weighted(black_box(&centroids), &counts, &segment)?;
            edges::edge_cuboids(&found, &centroids, &EdgeSettings { min_support: 40.0, ..EdgeSettings::default() })
        })
    });
    let one_scan = lidar.scan(&Vector3::new(0.0, 0.0, 0.6), 0.0, &world, &[], &mut rng).unwrap();
    g.throughput(Throughput::Elements(one_scan.len() as u64));
    // Into a map that has seen the place before: the steady state of a robot scanning as
    // it goes.
    g.bench_function("map_insert", |b| b.iter(|| voxels.insert(black_box(&one_scan))));
    g.finish();
}

criterion_group!(benches, perception);
criterion_main!(benches);
