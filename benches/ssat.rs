//! Table I of the Tachyon 3 paper on this machine: cost of one box–box query for the
//! SSAT variants, the exact SAT, parry3d's GJK and the LP (Clarabel, setup included), all
//! on the same 1024 random pairs.
//! Criterion reports the time for all 1024 pairs; divide by 1024 for one query. For the
//! same table with every query interleaved in one run, see `benches/table_one.rs`.

#[path = "common/table_one.rs"]
mod table_one;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};

fn table_one(c: &mut Criterion) {
    let mut group = c.benchmark_group("ssat_table1");
    group.throughput(Throughput::Elements(table_one::PAIRS as u64));
    for (name, _, pass) in table_one::queries() {
        group.bench_function(name, |bench| bench.iter(&pass));
    }
    group.finish();
}

criterion_group!(benches, table_one);
criterion_main!(benches);
