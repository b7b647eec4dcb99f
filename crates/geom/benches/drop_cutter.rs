//! Drop-cutter on the bundled bunny scaled to 100 mm, one thread, a 60 x 60 raster at
//! 1.7 mm: the BVH search with pruning and each triangle's contact terms stored once per
//! index (`bvh_pruned`) against two named baselines in the same run, the same search
//! computing those terms on every call (`bvh_pruned_per_call`,
//! [`DropCutter::height_per_call`], the routine before `perf9`; bit for bit the same
//! heights, asserted before timing) and every triangle tested
//! (`all_triangles`, [`DropCutter::height_all_triangles`]), for a ball and a bull nose;
//! and the waterline at mid height.
//!
//! Run: `cargo bench -p s2g-geom --bench drop_cutter`.

use criterion::{Criterion, criterion_group, criterion_main};
use s2g_geom::{Cutter, DropCutter, MeshIndex, Similarity3, Vector3, WaterlineOptions, load_mesh};

fn bunny_100mm() -> MeshIndex {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/stanford_bunny.stl");
    let mesh = load_mesh(path).expect("the bundled bunny loads");
    let b = mesh.bbox().expect("a non-empty mesh");
    let s = 100.0 / b.extent().max();
    let mesh = mesh.transformed(&Similarity3::new(-b.min.coords * s, Vector3::zeros(), s));
    MeshIndex::new(&mesh).expect("a non-empty mesh")
}

fn bench(c: &mut Criterion) {
    let index = bunny_100mm();
    let grid: Vec<[f64; 2]> =
        (0..60).flat_map(|j| (0..60).map(move |i| [i as f64 * 1.7, j as f64 * 1.7])).collect();
    for (name, cutter) in [("ball_r2", Cutter::ball(2.0, 20.0)), ("bull_r3_c1", Cutter::bull(3.0, 1.0, 20.0))]
    {
        let dc = DropCutter::new(&index, &cutter).expect("a valid cutter");
        assert!(
            grid.iter().all(|p| dc.height(p[0], p[1]).map(f64::to_bits)
                == dc.height_per_call(p[0], p[1]).map(f64::to_bits)),
            "stored terms must give the per-call heights bit for bit"
        );
        let mut g = c.benchmark_group(format!("drop_cutter_bunny_{name}"));
        g.sample_size(10);
        g.bench_function("bvh_pruned", |b| {
            b.iter(|| grid.iter().filter_map(|p| dc.height(p[0], p[1])).sum::<f64>())
        });
        g.bench_function("bvh_pruned_per_call", |b| {
            b.iter(|| grid.iter().filter_map(|p| dc.height_per_call(p[0], p[1])).sum::<f64>())
        });
        g.bench_function("all_triangles", |b| {
            b.iter(|| grid.iter().filter_map(|p| dc.height_all_triangles(p[0], p[1])).sum::<f64>())
        });
        g.finish();
    }
    let dc = DropCutter::new(&index, &Cutter::ball(2.0, 20.0)).expect("a valid cutter");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    let mut g = c.benchmark_group("waterline_bunny_ball_r2");
    g.sample_size(10);
    let options = WaterlineOptions { step: 0.5, ..WaterlineOptions::default() };
    g.bench_function("z40_step0.5_one_thread", |b| {
        b.iter(|| pool.install(|| dc.waterline_opt(40.0, &options).map(|l| l.len()).unwrap_or(0)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
