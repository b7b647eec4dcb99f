//! Visibility matrix and orientation selection on the Stanford bunny (16,384 samples x
//! 518 candidate directions, seed 000 §3.1). Throughput counts sample-direction pairs.
//!
//! - `matrix/by_directions`: ours (rayon over directions, front-face cull, any-hit ray
//!   that stops at the bounding box).
//! - `matrix/by_points`: the same rule, rayon over blocks of 64 samples.
//! - `matrix/naive_closest_hit` (baseline): the paper's rule cast naively, one closest-hit
//!   ray per pair without the `n . v > 0` cull or the bounding-box limit, on the first
//!   1,024 samples (same throughput unit).
//! - `select/local_search` (ours, end to end: sampling, BVH, matrix, search, refinement,
//!   no random baselines) against `select/plain_greedy` (the paper's greedy, same stages).
//!
//! Run: `cargo bench --bench visibility` (all threads) or with `RAYON_NUM_THREADS=1`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use shape2gcode::geom::{MeshIndex, load_mesh, sample_surface};
use shape2gcode::orient::{
    OrientOptions, Strategy, VisibilityContext, VisibilityOptions, candidate_directions, select_orientations,
};

const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/meshes/classic/stanford_bunny.stl");

fn bench(c: &mut Criterion) {
    let mesh = load_mesh(BUNNY).expect("bundled bunny");
    let bbox = mesh.bbox().expect("bunny has vertices");
    let samples = sample_surface(&mesh, 16384, 0).expect("bunny samples");
    let index = MeshIndex::new(&mesh).expect("bunny BVH");
    let vopts = VisibilityOptions::default();
    let ctx = VisibilityContext::new(&mesh, &index, &samples, &vopts).expect("context");
    let dirs = candidate_directions(512);
    let pairs = (samples.len() * dirs.len()) as u64;

    let mut g = c.benchmark_group("matrix");
    g.sample_size(10);
    g.throughput(Throughput::Elements(pairs));
    g.bench_function("by_directions", |b| b.iter(|| black_box(ctx.matrix(black_box(&dirs)))));
    g.bench_function("by_points", |b| b.iter(|| black_box(ctx.matrix_by_points(black_box(&dirs)))));
    let subset = 1024;
    let eps = vopts.eps * bbox.extent().norm();
    g.throughput(Throughput::Elements((subset * dirs.len()) as u64));
    g.bench_function("naive_closest_hit", |b| {
        b.iter(|| {
            let mut visible = 0usize;
            for v in &dirs {
                for i in 0..subset {
                    let n = samples.normals[i];
                    let o = samples.points[i] + n * eps;
                    let free = index.cast_ray(&o, v, f64::INFINITY).is_none();
                    visible += usize::from(free && n.dot(v) > 0.0);
                }
            }
            black_box(visible)
        })
    });
    g.finish();

    let mut g = c.benchmark_group("select");
    g.sample_size(10);
    let opts = OrientOptions { baseline_trials: 0, ..Default::default() };
    g.bench_function("local_search", |b| {
        b.iter(|| black_box(select_orientations(&mesh, &opts).expect("select")))
    });
    let plain = OrientOptions { strategy: Strategy::PlainGreedy, ..opts };
    g.bench_function("plain_greedy", |b| {
        b.iter(|| black_box(select_orientations(&mesh, &plain).expect("select")))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
