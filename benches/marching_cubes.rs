//! Marching cubes throughput on precomputed 256^3 fields (sphere, torus): `s2g_geom`'s
//! flying-edges-style marching cubes against the `fast-surface-nets` crate (baseline), on
//! the same `f32` samples in the same run. Throughput counts lattice samples (voxels).
//!
//! Run: `cargo bench --bench marching_cubes` (all threads) and
//! `RAYON_NUM_THREADS=1 cargo bench --bench marching_cubes` (per core; the baseline is
//! single-threaded in both).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fast_surface_nets::ndshape::{ConstShape, ConstShape3u32};
use fast_surface_nets::{SurfaceNetsBuffer, surface_nets};
use shape2gcode::geom::{Point3, Vector3, marching_cubes_samples};

const N: usize = 256;
type Shape = ConstShape3u32<256, 256, 256>;

/// Samples of `f` at the centres of an N^3 grid over the unit cube, x fastest.
fn field(f: impl Fn(f64, f64, f64) -> f64) -> Vec<f32> {
    let h = 1.0 / N as f64;
    let c = |i: usize| -0.5 + (i as f64 + 0.5) * h;
    let mut v = Vec::with_capacity(N * N * N);
    for k in 0..N {
        for j in 0..N {
            for i in 0..N {
                v.push(f(c(i), c(j), c(k)) as f32);
            }
        }
    }
    v
}

fn bench(c: &mut Criterion) {
    let sphere = field(|x, y, z| (x * x + y * y + z * z).sqrt() - 0.4);
    let torus = field(|x, y, z| {
        let ring = (x * x + y * y).sqrt() - 0.3;
        (ring * ring + z * z).sqrt() - 0.1
    });
    let h = 1.0 / N as f64;
    let origin = Point3::new(-0.5 + 0.5 * h, -0.5 + 0.5 * h, -0.5 + 0.5 * h);
    let mut g = c.benchmark_group("marching_cubes_256");
    g.throughput(Throughput::Elements((N * N * N) as u64));
    g.sample_size(20);
    for (name, values) in [("sphere", &sphere), ("torus", &torus)] {
        g.bench_function(format!("{name}/s2g_marching_cubes"), |b| {
            b.iter(|| {
                let m = marching_cubes_samples([N; 3], origin, Vector3::repeat(h), 0.0, black_box(values))
                    .expect("valid lattice");
                black_box(m.triangles().len())
            })
        });
        let mut buffer = SurfaceNetsBuffer::default();
        g.bench_function(format!("{name}/fast_surface_nets_baseline"), |b| {
            b.iter(|| {
                surface_nets(black_box(values), &Shape {}, [0; 3], [N as u32 - 1; 3], &mut buffer);
                black_box(buffer.indices.len())
            })
        });
    }
    g.finish();
    // Keep the shape type's size check honest: the field matches the baseline's shape.
    assert_eq!(Shape::USIZE, sphere.len());
}

criterion_group!(benches, bench);
criterion_main!(benches);
