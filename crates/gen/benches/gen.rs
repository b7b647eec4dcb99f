//! Generator throughput: parts per second for each kind at 100 mm, against a named
//! baseline in the same run: `baseline/box_mesh`, a plain box through geom's
//! `Mesh::cuboid` (the floor of any part's cost). Each iteration makes 16 parts (indices
//! 0-15 of seed 1), so parts per second is `16 / time`.
//!
//! Run: `cargo bench -p s2g-gen --bench gen`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use s2g_gen::{GenOptions, Kind, generate, shop_parts};
use s2g_geom::{Aabb, Mesh, Point3};

const PARTS: u64 = 16;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("gen");
    g.sample_size(10);
    g.throughput(Throughput::Elements(PARTS));
    g.bench_function("baseline/box_mesh", |b| {
        b.iter(|| {
            for i in 0..PARTS {
                let e = 100.0 + i as f64;
                black_box(Mesh::cuboid(&Aabb::new(Point3::origin(), Point3::new(e, 60.0, 20.0))).unwrap());
            }
        })
    });
    for kind in [Kind::Prismatic, Kind::Turned, Kind::Freeform, Kind::Mix] {
        let options = GenOptions { kind, size: 100.0 };
        g.bench_function(kind.name(), |b| {
            b.iter(|| {
                for i in 0..PARTS {
                    black_box(generate(1, i, &options).unwrap());
                }
            })
        });
    }
    g.throughput(Throughput::Elements(5));
    g.bench_function("shop", |b| b.iter(|| black_box(shop_parts().unwrap())));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
