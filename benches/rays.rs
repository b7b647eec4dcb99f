//! Orientation-style ray queries on a 69,632-triangle mesh (a bumpy torus, deterministic):
//! 2,048 area-weighted surface samples nudged off along their normal, each cast toward the
//! 64 Fibonacci directions on its outer side (`n . v > 0`, as the orient crate does), an
//! unbounded segment. Throughput counts rays; every group runs on ONE thread (rays/s per
//! core) except `par_any_hit`, which uses all rayon threads.
//!
//! - `ours/any_hit`: `MeshIndex::ray_hits_any` (our flat BVH, early exit, no normal).
//! - `ours/first_hit`: `MeshIndex::cast_ray` (nearest hit with point and normal).
//! - `parry/first_hit` (baseline): parry3d-f64 0.31 `TriMesh::cast_local_ray` (distance only;
//!   parry's own `intersects_local_ray` is this call).
//! - `parry/first_hit_normal` (baseline): `TriMesh::cast_local_ray_and_get_normal`.
//! - `brute_force/moller_trumbore` (baseline): every triangle tested, on the first 64 rays.
//! - `winding/ours_fast` vs `winding/exact_sum` (baseline, 16 points): inside tests.
//! - `voxelize/bunny_256/ours_*`: solid voxelisation of the bundled bunny at 256^3 (voxels/s)
//!   vs `voxelize/bunny_64/winding_per_voxel` (baseline: every centre's winding number).
//!
//! Run: `cargo bench --bench rays`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use parry3d_f64::math::Vector as PVec;
use parry3d_f64::query::{Ray, RayCast};
use parry3d_f64::shape::TriMesh;
use rayon::prelude::*;
use shape2gcode::geom::{
    GridSpec, Mesh, MeshIndex, Point3, Vector3, VoxelGrid, VoxelizeOptions, load_mesh, sample_surface,
    voxelize, voxelize_opt,
};

const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/stanford_bunny.stl");

/// A torus with bumps: `nu x nv` quads, two triangles each (256 x 136 x 2 = 69,632).
fn bumpy_torus(nu: usize, nv: usize) -> Mesh {
    let (big, small) = (0.32, 0.12);
    let tau = std::f64::consts::TAU;
    let mut v = Vec::with_capacity(nu * nv);
    for i in 0..nu {
        for j in 0..nv {
            let (u, w) = (tau * i as f64 / nu as f64, tau * j as f64 / nv as f64);
            let r =
                small * (1.0 + 0.18 * (7.0 * u).sin() * (5.0 * w).cos() + 0.06 * (23.0 * u + 11.0 * w).sin());
            let c = big + r * w.cos();
            v.push(Point3::new(c * u.cos(), c * u.sin(), r * w.sin()));
        }
    }
    let id = |i: usize, j: usize| ((i % nu) * nv + (j % nv)) as u32;
    let mut t = Vec::with_capacity(2 * nu * nv);
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            t.push([a, b, c]);
            t.push([a, c, d]);
        }
    }
    Mesh::new(v, t).expect("torus mesh")
}

/// `n` near-uniform directions on the sphere (Fibonacci lattice).
fn fibonacci(n: usize) -> Vec<Vector3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            Vector3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

fn moller_trumbore(mesh: &Mesh, o: &Point3, d: &Vector3) -> bool {
    mesh.triangle_points().any(|[a, b, c]| {
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(&e2);
        let det = e1.dot(&p);
        if det == 0.0 {
            return false;
        }
        let s = o - a;
        let u = s.dot(&p) / det;
        let q = s.cross(&e1);
        let v = d.dot(&q) / det;
        u >= 0.0 && v >= 0.0 && u + v <= 1.0 && e2.dot(&q) / det >= 0.0
    })
}

fn bench(c: &mut Criterion) {
    let mesh = bumpy_torus(256, 136);
    assert_eq!(mesh.triangles().len(), 69_632);
    let scale = mesh.bbox().expect("torus bbox").extent().max();
    let samples = sample_surface(&mesh, 2048, 1).expect("samples");
    let dirs = fibonacci(64);
    let mut rays: Vec<(Point3, Vector3)> = Vec::new();
    for (p, n) in samples.points.iter().zip(&samples.normals) {
        let o = p + n * (1e-6 * scale);
        rays.extend(dirs.iter().filter(|v| n.dot(v) > 0.0).map(|v| (o, *v)));
    }
    let index = MeshIndex::new(&mesh).expect("index");
    let parry = TriMesh::new(
        mesh.vertices().iter().map(|p| PVec::new(p.x, p.y, p.z)).collect(),
        mesh.triangles().to_vec(),
    )
    .expect("parry trimesh");
    let parry_rays: Vec<Ray> =
        rays.iter().map(|(o, d)| Ray::new(PVec::new(o.x, o.y, o.z), PVec::new(d.x, d.y, d.z))).collect();
    let blocked = rays.iter().filter(|(o, d)| index.ray_hits_any(o, d, f64::INFINITY)).count();
    eprintln!(
        "rays: {} from {} samples, {:.1} % blocked, 69,632 triangles",
        rays.len(),
        samples.len(),
        100.0 * blocked as f64 / rays.len() as f64
    );
    // Sanity: ours and parry agree on which rays are blocked.
    let parry_blocked =
        parry_rays.iter().filter(|r| parry.cast_local_ray(r, f64::MAX, false).is_some()).count();
    assert!(
        blocked.abs_diff(parry_blocked) <= rays.len() / 10_000,
        "ours {blocked} vs parry {parry_blocked}"
    );

    let n = rays.len() as u64;
    let mut g = c.benchmark_group("rays");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n));
    g.bench_function("ours/any_hit", |b| {
        b.iter(|| rays.iter().filter(|(o, d)| index.ray_hits_any(o, d, f64::INFINITY)).count())
    });
    g.bench_function("ours/first_hit", |b| {
        b.iter(|| rays.iter().filter(|(o, d)| index.cast_ray(o, d, f64::INFINITY).is_some()).count())
    });
    g.bench_function("parry/first_hit", |b| {
        b.iter(|| parry_rays.iter().filter(|r| parry.cast_local_ray(r, f64::MAX, false).is_some()).count())
    });
    g.bench_function("parry/first_hit_normal", |b| {
        b.iter(|| {
            parry_rays
                .iter()
                .filter(|r| parry.cast_local_ray_and_get_normal(r, f64::MAX, false).is_some())
                .count()
        })
    });
    g.bench_function("ours/par_any_hit_all_threads", |b| {
        b.iter(|| {
            rays.par_iter()
                .with_min_len(1024)
                .filter(|(o, d)| index.ray_hits_any(o, d, f64::INFINITY))
                .count()
        })
    });
    let few = &rays[..64];
    g.throughput(Throughput::Elements(few.len() as u64));
    g.bench_function("brute_force/moller_trumbore", |b| {
        b.iter(|| few.iter().filter(|(o, d)| moller_trumbore(&mesh, o, d)).count())
    });
    g.finish();

    let mut g = c.benchmark_group("winding");
    g.sample_size(10);
    let bb = mesh.bbox().expect("bbox");
    let pts: Vec<Point3> = (0..4096)
        .map(|i| {
            let f = |k: u32| ((i as u64 * 2654435761 + k as u64 * 40503) % 10007) as f64 / 10007.0;
            Point3::from(bb.min.coords + bb.extent().component_mul(&Vector3::new(f(1), f(2), f(3))))
        })
        .collect();
    g.throughput(Throughput::Elements(pts.len() as u64));
    g.bench_function("ours_fast", |b| b.iter(|| pts.iter().filter(|p| index.contains(black_box(p))).count()));
    g.bench_function("ours_signed_distance", |b| {
        b.iter(|| pts.iter().map(|p| index.signed_distance(black_box(p))).sum::<f64>())
    });
    let few = &pts[..16];
    g.throughput(Throughput::Elements(few.len() as u64));
    g.bench_function("exact_sum", |b| {
        b.iter(|| few.iter().filter(|p| index.winding_number_exact(black_box(p)) >= 0.5).count())
    });
    g.finish();

    // Solid voxelisation of the bundled bunny at 256^3 (voxels/s), against the direct
    // method (every voxel centre classified by the fast winding number) at 64^3.
    let bunny = load_mesh(BUNNY).expect("bundled bunny");
    let mut g = c.benchmark_group("voxelize");
    g.sample_size(10);
    let spec = GridSpec::cubic(&bunny.bbox().expect("bbox").inflated(1e-3), 256).expect("spec");
    g.throughput(Throughput::Elements(spec.len() as u64));
    g.bench_function("bunny_256/ours_robust", |b| {
        b.iter(|| voxelize(&bunny, &spec).expect("voxelize").count())
    });
    let z_only = VoxelizeOptions { robust: false, ..Default::default() };
    g.bench_function("bunny_256/ours_z_only", |b| {
        b.iter(|| voxelize_opt(&bunny, &spec, &z_only).expect("voxelize").count())
    });
    let small = GridSpec::cubic(&bunny.bbox().expect("bbox").inflated(1e-3), 64).expect("spec");
    let bunny_index = MeshIndex::new(&bunny).expect("index");
    g.throughput(Throughput::Elements(small.len() as u64));
    g.bench_function("bunny_64/winding_per_voxel", |b| {
        b.iter(|| {
            let mut grid = VoxelGrid::new(small);
            grid.set_where(|p| bunny_index.contains(p));
            grid.count()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
