//! Neural SDF fitting on an analytic sphere, determinism and save/load.

use s2g_field::{NeuralSdf, SdfOptions, SirenConfig, fit_sdf_samples, sdf_error, validation_points};
use s2g_geom::{Aabb, Point3, SignedDistance, Sphere, SurfaceSamples, Vector3};

/// A sphere in "millimetres", off the origin, so the normalisation is exercised.
fn sphere() -> Sphere {
    Sphere { center: Point3::new(10.0, -20.0, 5.0), radius: 30.0 }
}

/// The sphere's bounding box grown by a third of the radius on every side, so the sphere
/// fills about 3/4 of the unit cube like a typical part.
fn sphere_box(s: &Sphere) -> Aabb {
    let r = Vector3::repeat(s.radius * 4.0 / 3.0);
    Aabb::new(s.center - r, s.center + r)
}

/// Surface samples with exact normals, from a Fibonacci lattice (deterministic, even).
fn sphere_samples(s: &Sphere, n: usize) -> SurfaceSamples {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut out = SurfaceSamples::default();
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let t = golden * i as f64;
        let d = Vector3::new(r * t.cos(), r * t.sin(), z);
        out.points.push(s.center + d * s.radius);
        out.normals.push(d);
    }
    out
}

fn small_options(epochs: usize) -> SdfOptions {
    SdfOptions {
        network: SirenConfig {
            sine_layers: 2,
            width: 32,
            first_omega: 10.0,
            seed: 1,
            ..SirenConfig::default()
        },
        epochs,
        surface_samples: 2048,
        general_samples: 2048,
        batch_size: 512,
        seed: 3,
        ..SdfOptions::default()
    }
}

#[test]
fn sphere_sdf_is_accurate_and_its_gradient_is_the_normal() {
    let s = sphere();
    let bbox = sphere_box(&s);
    let diag = (bbox.max - bbox.min).norm();
    let options = small_options(100);
    let (sdf, report) = fit_sdf_samples(&sphere_samples(&s, 2048), &s, &bbox, &options).unwrap();
    assert_eq!(report.steps, options.steps());
    assert!(report.final_loss.is_finite());

    // Held-out points: a different lattice, near and uniform.
    let points = validation_points(&sphere_samples(&s, 777), 2000, 0.01 * s.radius, &bbox, 2000, 42).unwrap();
    let err = sdf_error(&sdf, &s, &points).unwrap();
    // An untrained network of the same shape, for scale: what a broken fit would leave.
    let (untrained, _) = fit_sdf_samples(
        &sphere_samples(&s, 2048),
        &s,
        &bbox,
        &SdfOptions { learning_rate: 1e-12, ..small_options(1) },
    )
    .unwrap();
    let base = sdf_error(&untrained, &s, &points).unwrap();
    assert!(
        err.mean_abs < 0.005 * diag && err.mean_abs < 0.1 * base.mean_abs,
        "sphere MAE {} (diag {diag}), untrained {}",
        err.mean_abs,
        base.mean_abs
    );

    // The exact gradient is the sphere's normal near the surface.
    let near = &points[..2000];
    let mean_cos = near.iter().map(|p| sdf.gradient(p).normalize().dot(&s.gradient(p))).sum::<f64>() / 2000.0;
    assert!(mean_cos > 0.99, "mean cos(grad, normal) near the surface = {mean_cos}");
    // And it is the derivative of the distance (central differences, in millimetres).
    for p in &near[..50] {
        let (d, g) = sdf.distance_gradient(p);
        assert_eq!(d, sdf.distance(p));
        let h = 1e-4;
        for a in 0..3 {
            let (mut p1, mut p2) = (*p, *p);
            p1[a] += h;
            p2[a] -= h;
            let fd = (sdf.distance(&p1) - sdf.distance(&p2)) / (2.0 * h);
            assert!((fd - g[a]).abs() < 1e-5, "d/dx{a} at {p:?}: {fd} vs {}", g[a]);
        }
    }
    // Far outside the training box the distance keeps growing like the true one.
    let far = s.center + Vector3::new(500.0, 0.0, 0.0);
    let d = sdf.distance(&far);
    assert!((d - s.distance(&far)).abs() < 0.05 * s.radius + 0.01 * 500.0, "far distance {d}");
}

#[test]
fn training_is_deterministic_and_saves_bit_identically() {
    let s = sphere();
    let bbox = sphere_box(&s);
    let samples = sphere_samples(&s, 512);
    let options =
        SdfOptions { surface_samples: 512, general_samples: 512, batch_size: 256, ..small_options(2) };
    let (a, _) = fit_sdf_samples(&samples, &s, &bbox, &options).unwrap();
    let (b, _) = fit_sdf_samples(&samples, &s, &bbox, &options).unwrap();
    assert_eq!(a, b, "same options, same field");
    // Burn's random parameter ids stay out of the bytes.
    assert_eq!(a.to_bytes().unwrap(), b.to_bytes().unwrap(), "same field, same bytes");
    let (c, _) = fit_sdf_samples(&samples, &s, &bbox, &SdfOptions { seed: 4, ..options.clone() }).unwrap();
    assert_ne!(a, c, "another sampling seed, another field");

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sphere.sdf");
    a.save(&path).unwrap();
    let back = NeuralSdf::load(&path).unwrap();
    assert_eq!(back, a);
    let p = Point3::new(12.0, -3.0, 7.5);
    assert_eq!(back.distance(&p).to_bits(), a.distance(&p).to_bits());
    // Only the final file is left behind (the write is atomic).
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}
