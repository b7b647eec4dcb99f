//! Surface sampling and unit-cube normalisation.

use std::path::Path;

use s2g_geom::{
    Aabb, GeomError, Mesh, Point3, Real, Rotation3, Similarity3, Vector3, load_mesh, normalize_unit_cube,
    sample_surface,
};

/// The closed, outward box `[min, max]`.
fn box_mesh(min: Point3, max: Point3) -> Mesh {
    Mesh::cuboid(&Aabb::new(min, max)).unwrap()
}

/// A latitude/longitude sphere, outward wound.
fn uv_sphere(center: Point3, r: Real, n_lat: u32, n_lon: u32) -> Mesh {
    use std::f64::consts::PI;
    let mut v = vec![center + Vector3::new(0.0, 0.0, r)];
    for i in 1..n_lat {
        let th = PI * i as Real / n_lat as Real;
        for j in 0..n_lon {
            let ph = 2.0 * PI * j as Real / n_lon as Real;
            v.push(center + r * Vector3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()));
        }
    }
    v.push(center - Vector3::new(0.0, 0.0, r));
    let south = v.len() as u32 - 1;
    let ring = |i: u32, j: u32| 1 + (i - 1) * n_lon + j % n_lon;
    let mut t = Vec::new();
    for j in 0..n_lon {
        t.push([0, ring(1, j), ring(1, j + 1)]);
        t.push([south, ring(n_lat - 1, j + 1), ring(n_lat - 1, j)]);
    }
    for i in 1..n_lat - 1 {
        for j in 0..n_lon {
            let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1));
            t.push([a, c, d]);
            t.push([a, d, b]);
        }
    }
    Mesh::new(v, t).unwrap()
}

#[test]
fn same_seed_same_samples_other_seed_other_samples() {
    let m = uv_sphere(Point3::origin(), 1.0, 16, 32);
    let a = sample_surface(&m, 1000, 7).unwrap();
    let b = sample_surface(&m, 1000, 7).unwrap();
    assert_eq!(a, b);
    let c = sample_surface(&m, 1000, 8).unwrap();
    assert_ne!(a.points, c.points);
    assert_eq!(a.len(), 1000);
    assert!(sample_surface(&m, 0, 1).unwrap().is_empty());
}

#[test]
fn samples_lie_on_their_triangles_with_unit_normals() {
    let m = uv_sphere(Point3::new(1.0, -2.0, 3.0), 2.0, 12, 24);
    let s = sample_surface(&m, 5000, 3).unwrap();
    for i in 0..s.len() {
        let t = s.triangles[i] as usize;
        let [a, b, c] = m.triangle(t);
        let n = m.face_normal(t).unwrap();
        assert!((s.normals[i] - n).norm() < 1e-12, "sample {i}");
        assert!((s.points[i] - a).dot(&n).abs() < 1e-12, "sample {i} off the plane of triangle {t}");
        // Barycentric coordinates all in [0, 1].
        let (e1, e2, p) = (b - a, c - a, s.points[i] - a);
        let (d11, d12, d22) = (e1.dot(&e1), e1.dot(&e2), e2.dot(&e2));
        let den = d11 * d22 - d12 * d12;
        let v = (d22 * p.dot(&e1) - d12 * p.dot(&e2)) / den;
        let w = (d11 * p.dot(&e2) - d12 * p.dot(&e1)) / den;
        assert!(v >= -1e-9 && w >= -1e-9 && v + w <= 1.0 + 1e-9, "sample {i} outside triangle {t}");
    }
}

#[test]
fn sphere_sample_mean_is_the_centre() {
    let c = Point3::new(3.0, -1.0, 0.5);
    let r = 2.0;
    let m = uv_sphere(c, r, 24, 48);
    let n = 40_000;
    let s = sample_surface(&m, n, 11).unwrap();
    let mean = s.points.iter().fold(Vector3::zeros(), |acc, p| acc + p.coords) / n as Real;
    // Each coordinate has standard deviation r / sqrt(3); the mean's is r / sqrt(3 n) ~ 0.006.
    assert!((mean - c.coords).norm() < 0.03, "mean {mean:?} vs centre {c:?}");
    for p in &s.points {
        let d = (p - c).norm();
        assert!(d <= r + 1e-12 && d > r * 0.99, "sample at distance {d}");
    }
}

#[test]
fn box_faces_get_samples_in_proportion_to_area() {
    let (x, y, z) = (1.0, 2.0, 3.0);
    let m = box_mesh(Point3::origin(), Point3::new(x, y, z));
    let n = 60_000;
    let s = sample_surface(&m, n, 5).unwrap();
    // Faces by outward normal: -z, +z, -y, +y, -x, +x.
    let areas = [x * y, x * y, x * z, x * z, y * z, y * z];
    let total: Real = areas.iter().sum();
    let mut counts = [0usize; 6];
    for nrm in &s.normals {
        let axis = (0..3).max_by(|&a, &b| nrm[a].abs().total_cmp(&nrm[b].abs())).unwrap();
        let face = 2 * (2 - axis) + usize::from(nrm[axis] > 0.0);
        counts[face] += 1;
    }
    let chi2: Real = (0..6)
        .map(|f| {
            let e = n as Real * areas[f] / total;
            (counts[f] as Real - e).powi(2) / e
        })
        .sum();
    // 5 degrees of freedom: P(chi2 > 20.5) = 0.001.
    assert!(chi2 < 20.5, "chi-square {chi2} for counts {counts:?}");
}

#[test]
fn moving_the_mesh_moves_the_samples() {
    let m = load_mesh(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/meshes/classic/gearwheel_40t.bin.stl"),
    )
    .unwrap();
    let t = Similarity3::from_parts(
        Vector3::new(10.0, -4.0, 2.5).into(),
        Rotation3::from_euler_angles(0.3, -1.2, 2.0),
        1.0,
    );
    let moved = m.transformed(&t);
    let a = sample_surface(&m, 3000, 99).unwrap();
    let b = sample_surface(&moved, 3000, 99).unwrap();
    assert_eq!(a.triangles, b.triangles, "the same triangles are chosen");
    for i in 0..a.len() {
        assert!((t * a.points[i] - b.points[i]).norm() < 1e-9, "sample {i}");
        assert!((t.isometry.rotation * a.normals[i] - b.normals[i]).norm() < 1e-9, "normal {i}");
    }
}

#[test]
fn degenerate_meshes_are_typed_errors() {
    assert!(matches!(sample_surface(&Mesh::default(), 10, 0), Err(GeomError::EmptyMesh)));
    let flat = Mesh::new(
        vec![Point3::origin(), Point3::new(1.0, 0.0, 0.0), Point3::new(2.0, 0.0, 0.0)],
        vec![[0, 1, 2], [0, 0, 1]],
    )
    .unwrap();
    assert!(matches!(sample_surface(&flat, 10, 0), Err(GeomError::InvalidArgument(_))));
    let cube = box_mesh(Point3::origin(), Point3::new(1.0, 1.0, 1.0));
    assert!(matches!(sample_surface(&cube, usize::MAX, 0), Err(GeomError::InvalidArgument(_))));
    // A zero-area triangle beside a real one is never sampled.
    let mut mixed = flat.clone();
    mixed.append(&box_mesh(Point3::origin(), Point3::new(1.0, 1.0, 1.0)));
    let s = sample_surface(&mixed, 2000, 1).unwrap();
    assert!(s.triangles.iter().all(|&t| t >= 2));
}

#[test]
fn normalisation_fits_the_unit_cube_and_maps_back() {
    let m = load_mesh(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/stanford_bunny.stl")).unwrap();
    let (u, n) = normalize_unit_cube(&m).unwrap();
    let b = u.bbox().unwrap();
    assert!((b.extent().max() - 1.0).abs() < 1e-12, "max extent {}", b.extent().max());
    assert!(b.center().coords.norm() < 1e-12, "centre {:?}", b.center());
    assert!(b.min.iter().all(|&c| c >= -0.5 - 1e-12) && b.max.iter().all(|&c| c <= 0.5 + 1e-12));
    for (p, q) in m.vertices().iter().zip(u.vertices()) {
        assert!((n.to_unit(p) - q).norm() < 1e-12);
        assert!((n.from_unit(q) - p).norm() < 1e-12);
        assert!((n.inverse_similarity() * q - p).norm() < 1e-12);
    }
    let bbox = m.bbox().unwrap();
    assert!((n.length_from_unit(1.0) - bbox.extent().max()).abs() < 1e-12);
    // Volume scales by scale^3.
    assert!((u.signed_volume() - m.signed_volume() * n.scale.powi(3)).abs() < 1e-12);

    // A moved and scaled copy normalises to the same mesh.
    let t = Similarity3::new(Vector3::new(-40.0, 7.0, 1e3), Vector3::zeros(), 3.5);
    let (u2, n2) = normalize_unit_cube(&m.transformed(&t)).unwrap();
    for (p, q) in u.vertices().iter().zip(u2.vertices()) {
        assert!((p - q).norm() < 1e-9);
    }
    assert!((n2.scale * 3.5 - n.scale).abs() < 1e-12);
}

#[test]
fn normalising_nothing_is_an_error() {
    assert!(matches!(normalize_unit_cube(&Mesh::default()), Err(GeomError::EmptyMesh)));
    let point = Mesh::new(vec![Point3::new(1.0, 1.0, 1.0); 3], vec![[0, 1, 2]]).unwrap();
    assert!(matches!(normalize_unit_cube(&point), Err(GeomError::InvalidArgument(_))));
}
