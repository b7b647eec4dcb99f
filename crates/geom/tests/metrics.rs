//! Shape metrics: identity, a shifted box against independent computations (exact voxel
//! counting, brute-force nearest neighbours), rigid-motion invariance and bad input.

use s2g_geom::{
    Aabb, GeomError, GridSpec, Mesh, MetricOptions, Point3, Rotation3, Similarity3, SurfaceSamples, Vector3,
    VoxelGrid, chamfer_and_normals, compare, occupancy_iou, sample_surface,
};

/// The closed, outward box `[min, max]`.
fn box_mesh(min: Point3, max: Point3) -> Mesh {
    Mesh::cuboid(&Aabb::new(min, max)).unwrap()
}

fn cube(half: f64, shift_x: f64) -> Mesh {
    box_mesh(Point3::new(-half + shift_x, -half, -half), Point3::new(half + shift_x, half, half))
}

/// Number of voxel centres `-0.5 + (i + 0.5) / n` strictly inside `(lo, hi)`.
fn centres_in(lo: f64, hi: f64, n: usize) -> u64 {
    (0..n)
        .filter(|&i| {
            let c = -0.5 + (i as f64 + 0.5) / n as f64;
            lo < c && c < hi
        })
        .count() as u64
}

/// Brute-force O(n^2) Chamfer ×1000 and normal consistency, written independently.
fn brute_force(a: &SurfaceSamples, b: &SurfaceSamples) -> (f64, f64) {
    let one_way = |from: &SurfaceSamples, to: &SurfaceSamples| {
        let mut d_sum = 0.0;
        let mut n_sum = 0.0;
        for (p, n) in from.points.iter().zip(&from.normals) {
            let (mut best, mut best_j) = (f64::INFINITY, 0);
            for (j, q) in to.points.iter().enumerate() {
                let d = (p - q).norm_squared();
                if d < best {
                    best = d;
                    best_j = j;
                }
            }
            d_sum += best;
            n_sum += n.dot(&to.normals[best_j]).abs();
        }
        (d_sum / from.points.len() as f64, n_sum / from.points.len() as f64)
    };
    let (d1, n1) = one_way(a, b);
    let (d2, n2) = one_way(b, a);
    (1000.0 * (d1 + d2), 0.5 * (n1 + n2))
}

#[test]
fn a_mesh_against_itself_is_perfect() {
    let a = cube(0.3, 0.0);
    let m = compare(&a, &a, &MetricOptions::default()).unwrap();
    assert_eq!((m.iou, m.f1), (1.0, 1.0), "self IoU/F1: {m:?}");
    assert_eq!(m.chamfer_x1000, 0.0, "same seed, same samples: {m:?}");
    assert!((m.normal_consistency - 1.0).abs() < 1e-12, "self NC: {m:?}");
    // Different seeds: small but non-zero Chamfer, normals still agree (flat faces).
    let s1 = sample_surface(&a, 2000, 1).unwrap();
    let s2 = sample_surface(&a, 2000, 2).unwrap();
    let (cd, nc) = chamfer_and_normals(&s1, &s2).unwrap();
    // Independent: for uniform random points of density rho on a surface, the mean squared
    // distance to the nearest one is 1 / (pi rho); two directions, times 1000.
    let rho = 2000.0 / a.area();
    let expect = 2.0 * 1000.0 / (std::f64::consts::PI * rho);
    assert!((cd - expect).abs() < 0.2 * expect, "self Chamfer with different seeds: {cd} vs {expect}");
    // Only samples near the box's edges can find a neighbour on the adjacent face (cos 0).
    assert!(nc > 0.9 && nc < 1.0, "self NC with different seeds: {nc}");
}

#[test]
fn shifted_box_iou_f1_match_exact_voxel_counting() {
    let res = 256;
    let opts = MetricOptions { resolution: res, samples: 2000, seed: 5, ..MetricOptions::default() };
    let a = cube(0.3, 0.0);
    for d in [0.02, 0.05, 0.13] {
        let b = cube(0.3, d);
        let m = compare(&a, &b, &opts).unwrap();
        // Independent: count voxel centres per axis (the boxes are products of intervals).
        let yz = centres_in(-0.3, 0.3, res).pow(2);
        let na = centres_in(-0.3, 0.3, res) * yz;
        let nb = centres_in(-0.3 + d, 0.3 + d, res) * yz;
        let ni = centres_in(-0.3 + d, 0.3, res) * yz;
        let iou = ni as f64 / (na + nb - ni) as f64;
        let f1 = 2.0 * ni as f64 / (na + nb) as f64;
        assert!((m.iou - iou).abs() < 1e-12, "d = {d}: IoU {} vs exact count {iou}", m.iou);
        assert!((m.f1 - f1).abs() < 1e-12, "d = {d}: F1 {} vs exact count {f1}", m.f1);
        // And the continuous overlap, within the voxelisation error (one voxel per face).
        let (w, h) = (0.6, 1.0 / res as f64);
        let iou_c = (w - d) / (w + d);
        let f1_c = (w - d) / w;
        assert!((m.iou - iou_c).abs() < 2.0 * h / w, "d = {d}: IoU {} vs analytic {iou_c}", m.iou);
        assert!((m.f1 - f1_c).abs() < 2.0 * h / w, "d = {d}: F1 {} vs analytic {f1_c}", m.f1);
    }
}

#[test]
fn shifted_box_chamfer_and_normals_match_brute_force() {
    let opts = MetricOptions { resolution: 64, samples: 2000, seed: 9, ..MetricOptions::default() };
    let a = cube(0.3, 0.0);
    let mut last = 0.0;
    for d in [0.0, 0.02, 0.05] {
        let b = cube(0.3, d);
        let m = compare(&a, &b, &opts).unwrap();
        let sa = sample_surface(&a, opts.samples, opts.seed).unwrap();
        let sb = sample_surface(&b, opts.samples, opts.seed).unwrap();
        let (cd, nc) = brute_force(&sa, &sb);
        assert!(
            (m.chamfer_x1000 - cd).abs() <= 1e-9 * cd.max(1.0),
            "d = {d}: {} vs brute {cd}",
            m.chamfer_x1000
        );
        assert!(
            (m.normal_consistency - nc).abs() < 1e-9,
            "d = {d}: NC {} vs brute {nc}",
            m.normal_consistency
        );
        assert!(m.chamfer_x1000 >= last, "d = {d}: Chamfer must grow with the shift");
        last = m.chamfer_x1000;
        // Roughly two faces' worth of area move by d: about (2/6) d^2 per direction.
        if d > 0.0 {
            let expect = 1000.0 * 2.0 * d * d / 3.0;
            assert!(m.chamfer_x1000 > 0.5 * expect && m.chamfer_x1000 < 1.5 * expect + 0.2, "d = {d}: {m:?}");
        }
    }
}

#[test]
fn metrics_are_invariant_under_rigid_motion_of_both_meshes() {
    let a = cube(0.25, 0.0);
    let b = cube(0.25, 0.04);
    let sa = sample_surface(&a, 1500, 3).unwrap();
    let sb = sample_surface(&b, 1500, 3).unwrap();
    let (cd, nc) = chamfer_and_normals(&sa, &sb).unwrap();
    let t = Similarity3::from_parts(
        Vector3::new(0.05, -0.02, 0.03).into(),
        Rotation3::from_euler_angles(0.3, 0.9, -0.4),
        1.0,
    );
    let (ta, tb) = (a.transformed(&t), b.transformed(&t));
    let (sta, stb) = (sample_surface(&ta, 1500, 3).unwrap(), sample_surface(&tb, 1500, 3).unwrap());
    let (cd2, nc2) = chamfer_and_normals(&sta, &stb).unwrap();
    assert!((cd - cd2).abs() < 1e-6 * cd, "rigid motion changes Chamfer: {cd} vs {cd2}");
    assert!((nc - nc2).abs() < 1e-9, "rigid motion changes NC: {nc} vs {nc2}");
    // A quarter turn about z maps the voxel-centre lattice onto itself: IoU and F1 unchanged.
    let q = Similarity3::from_parts(
        Vector3::zeros().into(),
        Rotation3::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2),
        1.0,
    );
    let opts = MetricOptions { resolution: 128, samples: 500, ..MetricOptions::default() };
    let m1 = compare(&a, &b, &opts).unwrap();
    let m2 = compare(&a.transformed(&q), &b.transformed(&q), &opts).unwrap();
    assert!((m1.iou - m2.iou).abs() < 1e-9 && (m1.f1 - m2.f1).abs() < 1e-9, "{m1:?} vs {m2:?}");
}

#[test]
fn bad_input_gives_errors() {
    let a = cube(0.3, 0.0);
    let opts = MetricOptions::default();
    assert!(matches!(compare(&a, &Mesh::default(), &opts), Err(GeomError::EmptyMesh)));
    assert!(compare(&a, &a, &MetricOptions { resolution: 0, ..opts }).is_err());
    assert!(compare(&a, &a, &MetricOptions { samples: 0, ..opts }).is_err());
    let g1 = VoxelGrid::new(GridSpec::new(&Aabb::unit_cube(), [8; 3]).unwrap());
    let g2 = VoxelGrid::new(GridSpec::new(&Aabb::unit_cube(), [9; 3]).unwrap());
    assert!(matches!(occupancy_iou(&g1, &g2), Err(GeomError::GridMismatch)));
    assert_eq!(occupancy_iou(&g1, &g1).unwrap(), (1.0, 1.0), "two empty grids agree");
    assert!(chamfer_and_normals(&SurfaceSamples::default(), &sample_surface(&a, 10, 0).unwrap()).is_err());
}
