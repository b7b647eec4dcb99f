//! Marching cubes: topology on every cube configuration and random lattices, accuracy on
//! analytic shapes (also moved and rotated), voxel input, determinism and bad input.

use std::collections::BTreeMap;
use std::f64::consts::PI;

use s2g_geom::{
    Aabb, BoxShape, GridSpec, McOptions, Mesh, Point3, Rotation3, SignedDistance, Sphere, SplitMix64,
    Vector3, VoxelGrid, marching_cubes, marching_cubes_opt, marching_cubes_samples,
    marching_cubes_samples_opt, marching_cubes_voxels, marching_cubes_voxels_opt,
};

/// Checks that `mesh` is a closed, consistently oriented 2-manifold without degenerate
/// triangles or duplicate vertices: every directed edge appears exactly once and its
/// reverse exactly once (so every undirected edge has exactly two triangles), and the
/// triangles around each vertex form a single cycle.
fn check_closed_manifold(mesh: &Mesh, name: &str) {
    let mut directed: BTreeMap<(u32, u32), usize> = BTreeMap::new();
    for (t, &[a, b, c]) in mesh.triangles().iter().enumerate() {
        assert!(a != b && b != c && c != a, "{name}: triangle {t} repeats a vertex");
        assert!(mesh.triangle_cross(t).norm() > 0.0, "{name}: triangle {t} is degenerate");
        for e in [(a, b), (b, c), (c, a)] {
            *directed.entry(e).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(n, 1, "{name}: directed edge {a}->{b} used {n} times (orientation or manifold)");
        assert_eq!(directed.get(&(b, a)), Some(&1), "{name}: edge {a}-{b} has one triangle (hole)");
    }
    // Vertex links: the opposite edges (b, c) of the triangles at a vertex chain into one cycle.
    let mut link: BTreeMap<u32, Vec<(u32, u32)>> = BTreeMap::new();
    for &[a, b, c] in mesh.triangles() {
        link.entry(a).or_default().push((b, c));
        link.entry(b).or_default().push((c, a));
        link.entry(c).or_default().push((a, b));
    }
    for (v, edges) in &link {
        let next: BTreeMap<u32, u32> = edges.iter().copied().collect();
        let mut at = edges[0].0;
        let mut steps = 0;
        loop {
            at = next[&at];
            steps += 1;
            if at == edges[0].0 {
                break;
            }
            assert!(steps <= edges.len(), "{name}: vertex {v} link is not a cycle");
        }
        assert_eq!(steps, edges.len(), "{name}: vertex {v} is non-manifold (link has several cycles)");
    }
    let mut pos: Vec<[u64; 3]> = mesh.vertices().iter().map(|p| [p.x, p.y, p.z].map(f64::to_bits)).collect();
    pos.sort_unstable();
    let n = pos.len();
    pos.dedup();
    assert_eq!(pos.len(), n, "{name}: duplicate vertex positions");
}

fn lattice_mesh(dims: [usize; 3], values: &[f64], iso: f64) -> Mesh {
    marching_cubes_samples(dims, Point3::origin(), Vector3::repeat(1.0), iso, values).unwrap()
}

#[test]
fn all_256_cube_configurations_are_closed_oriented_manifolds() {
    let mut rng = SplitMix64(1);
    for case in 0..256usize {
        // The cube's corners sit at lattice (1..=2)^3 of a 4^3 lattice whose other samples are
        // outside, so the surface of each configuration is closed.
        for variant in 0..3 {
            let mut v = vec![1.0; 64];
            for c in 0..8 {
                let (x, y, z) = (1 + (c & 1), 1 + (c >> 1 & 1), 1 + (c >> 2 & 1));
                let mag = match variant {
                    0 => 1.0,
                    _ => 0.05 + rng.unit(),
                };
                v[x + 4 * (y + 4 * z)] = if case >> c & 1 == 1 { -mag } else { mag };
            }
            let mesh = lattice_mesh([4, 4, 4], &v, 0.0);
            let name = format!("case {case} variant {variant}");
            assert_eq!(mesh.is_empty(), case == 0, "{name}");
            check_closed_manifold(&mesh, &name);
            if case != 0 {
                assert!(mesh.signed_volume() > 0.0, "{name}: volume {} not positive", mesh.signed_volume());
            }
        }
    }
}

#[test]
fn random_lattices_are_closed_oriented_manifolds() {
    let mut rng = SplitMix64(7);
    for trial in 0..1500 {
        // A random 3x3x3 core (so cells meet across every face) inside an outside border.
        let n = 5;
        let with_zeros = trial % 3 == 2;
        let mut v = vec![1.0; n * n * n];
        for z in 1..4 {
            for y in 1..4 {
                for x in 1..4 {
                    let r = rng.unit();
                    v[x + n * (y + n * z)] = if with_zeros {
                        // Samples exactly on the iso level land vertices on lattice points.
                        [-1.0, 0.0, 1.0][(r * 3.0) as usize % 3]
                    } else {
                        2.0 * r - 1.0
                    };
                }
            }
        }
        let mesh = lattice_mesh([n, n, n], &v, 0.0);
        let name = format!("random lattice {trial}");
        check_closed_manifold(&mesh, &name);
        let inside = v.iter().filter(|&&x| x < 0.0).count();
        assert_eq!(mesh.is_empty(), inside == 0, "{name}");
        if inside > 0 {
            assert!(mesh.signed_volume() > 0.0, "{name}: non-positive volume");
        }
    }
}

#[test]
fn random_voxel_grids_are_closed_and_match_the_midpoint_volume() {
    let mut rng = SplitMix64(11);
    for trial in 0..200 {
        let dims = [1 + trial % 5, 1 + (trial / 5) % 4, 1 + trial % 7];
        let spec =
            GridSpec::new(&Aabb::new(Point3::new(-1.0, 2.0, 0.5), Point3::new(1.0, 3.0, 2.0)), dims).unwrap();
        let mut g = VoxelGrid::new(spec);
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    g.set(x, y, z, rng.unit() < 0.5);
                }
            }
        }
        let mesh = marching_cubes_voxels(&g).unwrap();
        let name = format!("voxel grid {trial} {dims:?}");
        check_closed_manifold(&mesh, &name);
        assert_eq!(mesh.is_empty(), g.count() == 0, "{name}");
        // Every vertex is the midpoint of two voxel centres: on a half-voxel lattice.
        for p in mesh.vertices() {
            for a in 0..3 {
                let c = (p[a] - spec.origin[a]) / spec.voxel[a] * 2.0;
                assert!((c - c.round()).abs() < 1e-9, "{name}: vertex {p} off the half-voxel lattice");
            }
        }
    }
}

#[test]
fn voxel_rows_across_word_boundaries_match_the_samples_path() {
    // Widths around multiples of 64 exercise the bit packing of padded rows; the samples
    // path on an explicit padded 0/1 lattice is the independent reference.
    let mut rng = SplitMix64(5);
    for nx in [1, 7, 8, 55, 56, 57, 61, 62, 63, 64, 65, 70, 126, 127, 128, 130] {
        let dims = [nx, 3, 2];
        let spec =
            GridSpec::new(&Aabb::new(Point3::origin(), Point3::new(nx as f64, 3.0, 2.0)), dims).unwrap();
        let mut g = VoxelGrid::new(spec);
        let (px, py, pz) = (nx + 2, 5, 4);
        let mut lattice = vec![0.0f64; px * py * pz];
        for z in 0..2 {
            for y in 0..3 {
                for x in 0..nx {
                    if rng.unit() < 0.6 {
                        g.set(x, y, z, true);
                        lattice[x + 1 + px * (y + 1 + py * (z + 1))] = -1.0;
                    }
                }
            }
        }
        let m = marching_cubes_voxels(&g).unwrap();
        let origin = spec.origin - 0.5 * spec.voxel;
        let r = marching_cubes_samples([px, py, pz], origin, spec.voxel, -0.5, &lattice).unwrap();
        assert!(m == r, "width {nx}: voxel path differs from the explicit padded lattice");
        check_closed_manifold(&m, &format!("voxel width {nx}"));
    }
}

#[test]
fn a_single_voxel_is_an_octahedron_and_a_full_grid_a_closed_box() {
    let spec = GridSpec::new(&Aabb::new(Point3::origin(), Point3::new(3.0, 3.0, 3.0)), [3, 3, 3]).unwrap();
    let mut g = VoxelGrid::new(spec);
    g.set(1, 1, 1, true);
    let m = marching_cubes_voxels(&g).unwrap();
    // Six vertices half a voxel from the centre, eight faces: volume (4/3) * 0.5^3.
    assert_eq!((m.vertices().len(), m.triangles().len()), (6, 8));
    assert!((m.signed_volume() - 4.0 / 3.0 * 0.125).abs() < 1e-12, "octahedron volume {}", m.signed_volume());

    // A full grid touches the grid boundary; padding still closes it.
    let g = VoxelGrid::full(GridSpec::new(&Aabb::unit_cube(), [20, 12, 9]).unwrap());
    let m = marching_cubes_voxels(&g).unwrap();
    check_closed_manifold(&m, "full 20x12x9 grid");
    let b = m.bbox().unwrap();
    assert!((b.min - Point3::new(-0.5, -0.5, -0.5)).norm() < 1e-12, "bbox {b:?}");
}

fn field_mesh(sdf: &(impl SignedDistance + ?Sized), n: usize) -> Mesh {
    let spec = GridSpec::new(&Aabb::unit_cube(), [n; 3]).unwrap();
    marching_cubes(&spec, 0.0, |p| sdf.distance(p)).unwrap()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Area-weighted centroid of the surface.
fn surface_centroid(m: &Mesh) -> Point3 {
    let mut s = Vector3::zeros();
    let mut w = 0.0;
    for (t, [a, b, c]) in m.triangle_points().enumerate() {
        let area = 0.5 * m.triangle_cross(t).norm();
        s += area * (a.coords + b.coords + c.coords) / 3.0;
        w += area;
    }
    Point3::from(s / w)
}

#[test]
fn sphere_at_256_matches_analytic_area_and_volume_also_off_centre() {
    for (name, centre, r) in [
        ("centred sphere", Point3::origin(), 0.4),
        ("off-centre sphere", Point3::new(0.07, -0.05, 0.031), 0.33),
    ] {
        let m = field_mesh(&Sphere { center: centre, radius: r }, 256);
        check_closed_manifold(&m, name);
        let (area, vol) = (4.0 * PI * r * r, 4.0 / 3.0 * PI * r * r * r);
        assert!(rel(m.area(), area) < 0.005, "{name}: area {} vs {area}", m.area());
        assert!(rel(m.signed_volume(), vol) < 0.005, "{name}: volume {} vs {vol}", m.signed_volume());
        let c = surface_centroid(&m);
        assert!((c - centre).norm() < 1e-3, "{name}: centroid {c} vs {centre}");
        for p in m.vertices() {
            assert!(((p - centre).norm() - r).abs() < 1.0 / 256.0, "{name}: vertex {p} off the sphere");
        }
    }
}

struct Torus {
    centre: Point3,
    rot: Rotation3,
    big: f64,
    small: f64,
}

impl SignedDistance for Torus {
    fn distance(&self, p: &Point3) -> f64 {
        let q = self.rot.inverse() * (p - self.centre);
        let ring = (q.x * q.x + q.y * q.y).sqrt() - self.big;
        (ring * ring + q.z * q.z).sqrt() - self.small
    }
}

#[test]
fn torus_at_256_matches_analytic_area_and_volume_also_rotated() {
    let rot = Rotation3::from_euler_angles(0.3, -0.7, 1.1);
    for (name, t) in [
        ("torus", Torus { centre: Point3::origin(), rot: Rotation3::identity(), big: 0.3, small: 0.1 }),
        (
            "moved rotated torus",
            Torus { centre: Point3::new(0.04, 0.02, -0.05), rot, big: 0.28, small: 0.09 },
        ),
    ] {
        let m = field_mesh(&t, 256);
        check_closed_manifold(&m, name);
        let area = 4.0 * PI * PI * t.big * t.small;
        let vol = 2.0 * PI * PI * t.big * t.small * t.small;
        assert!(rel(m.area(), area) < 0.005, "{name}: area {} vs {area}", m.area());
        assert!(rel(m.signed_volume(), vol) < 0.005, "{name}: volume {} vs {vol}", m.signed_volume());
        // Genus one: V - E + F = 0.
        let (v, f) = (m.vertices().len() as i64, m.triangles().len() as i64);
        assert_eq!(v - 3 * f / 2 + f, 0, "{name}: Euler characteristic");
        let c = surface_centroid(&m);
        assert!((c - t.centre).norm() < 1e-3, "{name}: centroid {c}");
    }
}

struct Moved<S> {
    shape: S,
    rot: Rotation3,
    shift: Vector3,
}

impl<S: SignedDistance> SignedDistance for Moved<S> {
    fn distance(&self, p: &Point3) -> f64 {
        self.shape.distance(&(self.rot.inverse() * (p - self.shift)))
    }
}

#[test]
fn box_sdf_rotated_and_translated_gives_the_transformed_box() {
    let h = Vector3::new(0.25, 0.15, 0.1);
    let shape = BoxShape { min: Point3::from(-h), max: Point3::from(h) };
    let (vol, area) = (8.0 * h.product(), 8.0 * (h.x * h.y + h.y * h.z + h.z * h.x));
    let rot = Rotation3::from_euler_angles(0.4, 0.2, -0.9);
    let shift = Vector3::new(0.05, -0.03, 0.02);
    for (name, rot, shift) in
        [("axis box", Rotation3::identity(), Vector3::zeros()), ("rotated moved box", rot, shift)]
    {
        let sdf = Moved { shape, rot, shift };
        let m = field_mesh(&sdf, 160);
        check_closed_manifold(&m, name);
        // Marching cubes bevels the box's edges by about half a cell: the volume stays within
        // 1 %, and the area loses at most a strip of one cell width along the edge length.
        let (cell, edges) = (1.0 / 160.0, 8.0 * (h.x + h.y + h.z));
        assert!(rel(m.signed_volume(), vol) < 0.01, "{name}: volume {} vs {vol}", m.signed_volume());
        assert!(m.area() < area && area - m.area() < cell * edges, "{name}: area {} vs {area}", m.area());
        let c = surface_centroid(&m);
        assert!((c - Point3::from(shift)).norm() < 1e-3, "{name}: centroid {c} vs {shift}");
        for p in m.vertices() {
            assert!(sdf.distance(p).abs() < 1.0 / 160.0, "{name}: vertex {p} off the box");
        }
        // The box's axes in the mesh: the extent along each rotated axis is the box's.
        for a in 0..3 {
            let axis = rot * Vector3::ith(a, 1.0);
            let (lo, hi) = m.vertices().iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| {
                let d = (p - Point3::from(shift)).dot(&axis);
                (lo.min(d), hi.max(d))
            });
            assert!((hi - lo - 2.0 * h[a]).abs() < 2.0 / 160.0, "{name}: extent {} on axis {a}", hi - lo);
        }
    }
}

#[test]
fn output_does_not_depend_on_slab_size_or_sample_type() {
    let sphere = Sphere { center: Point3::new(0.1, 0.0, -0.05), radius: 0.3 };
    let spec = GridSpec::new(&Aabb::unit_cube(), [70, 50, 61]).unwrap();
    let reference = marching_cubes(&spec, 0.0, |p| sphere.distance(p)).unwrap();
    for slab in [1, 2, 7, 1000] {
        let opts = McOptions { slab_layers: slab, ..McOptions::default() };
        let m = marching_cubes_opt(&spec, 0.0, |p| sphere.distance(p), &opts).unwrap();
        assert!(m == reference, "slab_layers {slab} changes the output");
    }
    // The same lattice through the samples path, f64 and f32.
    let d = spec.dims;
    let mut vals = Vec::with_capacity(spec.len());
    for k in 0..d[2] {
        for j in 0..d[1] {
            for i in 0..d[0] {
                vals.push(sphere.distance(&spec.center(i, j, k)));
            }
        }
    }
    let m = marching_cubes_samples(d, spec.center(0, 0, 0), spec.voxel, 0.0, &vals).unwrap();
    assert!(m == reference, "samples path differs from the field path");
    let v32: Vec<f32> = vals.iter().map(|&v| v as f32).collect();
    let m32 = marching_cubes_samples_opt(
        d,
        spec.center(0, 0, 0),
        spec.voxel,
        0.0,
        &v32,
        &McOptions { slab_layers: 3, ..McOptions::default() },
    )
    .unwrap();
    assert_eq!(m32.triangles(), reference.triangles(), "f32 samples change the topology");
    // Voxel path: slab size does not matter either.
    let mut g = VoxelGrid::new(spec);
    g.set_where(|p| sphere.contains(p));
    let a = marching_cubes_voxels(&g).unwrap();
    let b = marching_cubes_voxels_opt(&g, &McOptions { slab_layers: 5, ..McOptions::default() }).unwrap();
    assert!(a == b, "voxel slab size changes the output");
}

#[test]
fn open_surfaces_at_the_lattice_boundary_and_bad_input() {
    // A half-space: the surface is one open sheet, edges on the boundary have one triangle.
    let spec = GridSpec::new(&Aabb::unit_cube(), [9, 9, 9]).unwrap();
    let m = marching_cubes(&spec, 0.0, |p| p.z - 0.01).unwrap();
    assert!(!m.is_empty());
    for p in m.vertices() {
        assert!((p.z - 0.01).abs() < 1e-12, "plane vertex {p}");
    }
    let n = m.face_normal(0).unwrap();
    assert!(n.z > 0.99, "plane normal {n} must point to +z (outside)");
    // Wrong sample count, non-finite spacing, bad options: errors, no panic.
    assert!(
        marching_cubes_samples([2, 2, 2], Point3::origin(), Vector3::repeat(1.0), 0.0, &[0.0f64; 7]).is_err()
    );
    assert!(
        marching_cubes_samples(
            [2, 2, 2],
            Point3::origin(),
            Vector3::new(f64::NAN, 1.0, 1.0),
            0.0,
            &[0.0f64; 8]
        )
        .is_err()
    );
    let bad = McOptions { min_edge_fraction: 0.0, ..McOptions::default() };
    assert!(marching_cubes_opt(&spec, 0.0, |p| p.z, &bad).is_err());
    // NaN and infinite samples: still a valid, closed mesh (NaN counts as outside).
    let mut v = vec![1.0; 64];
    v[21] = -1.0;
    v[22] = f64::NAN;
    v[25] = f64::NEG_INFINITY;
    v[26] = f64::INFINITY;
    let m = lattice_mesh([4, 4, 4], &v, 0.0);
    check_closed_manifold(&m, "NaN lattice");
    // A mirrored lattice (negative spacing on one axis) still faces outwards.
    for spacing in
        [Vector3::new(-1.0, 1.0, 1.0), Vector3::new(-1.0, -2.0, 1.0), Vector3::new(-1.0, -1.0, -0.5)]
    {
        let m = marching_cubes_samples([4, 4, 4], Point3::origin(), spacing, 0.0, &v).unwrap();
        check_closed_manifold(&m, &format!("mirrored lattice {spacing}"));
        assert!(m.signed_volume() > 0.0, "mirrored lattice {spacing}: volume {}", m.signed_volume());
    }
    assert!(
        marching_cubes_samples([4, 4, 4], Point3::origin(), Vector3::new(1.0, 0.0, 1.0), 0.0, &v).is_err()
    );
    // Lattices too thin to hold a cell give an empty mesh.
    assert!(
        marching_cubes_samples([1, 5, 5], Point3::origin(), Vector3::repeat(1.0), 0.0, &[0.0f64; 25])
            .unwrap()
            .is_empty()
    );
}

/// Mean angle (radians) between the normals of triangles sharing an edge: a roughness measure.
fn roughness(m: &Mesh) -> f64 {
    let mut by_edge: BTreeMap<(u32, u32), Vec<usize>> = BTreeMap::new();
    for (t, &[a, b, c]) in m.triangles().iter().enumerate() {
        for (u, v) in [(a, b), (b, c), (c, a)] {
            by_edge.entry((u.min(v), u.max(v))).or_default().push(t);
        }
    }
    let (mut sum, mut n) = (0.0, 0.0);
    for ts in by_edge.values() {
        if let [s, t] = ts[..] {
            let (a, b) = (m.face_normal(s).unwrap(), m.face_normal(t).unwrap());
            sum += a.dot(&b).clamp(-1.0, 1.0).acos();
            n += 1.0;
        }
    }
    sum / n
}

#[test]
fn taubin_keeps_the_volume_laplacian_shrinks_both_smooth() {
    use s2g_geom::{TAUBIN_LAMBDA, TAUBIN_MU, laplacian_smooth, taubin_smooth};
    for (name, shift) in
        [("voxel sphere", Vector3::zeros()), ("moved voxel sphere", Vector3::new(0.06, -0.04, 0.03))]
    {
        let spec = GridSpec::new(&Aabb::unit_cube().inflated(0.1), [72; 3]).unwrap();
        let sphere = Sphere { center: Point3::from(shift), radius: 0.4 };
        let mut g = VoxelGrid::new(spec);
        g.set_where(|p| sphere.contains(p));
        let m0 = marching_cubes_voxels(&g).unwrap();
        let v0 = m0.signed_volume();
        let analytic = 4.0 / 3.0 * PI * 0.4f64.powi(3);
        assert!(rel(v0, analytic) < 0.03, "{name}: voxel MC volume {v0} vs {analytic}");
        let lap = laplacian_smooth(&m0, 20, 0.5).unwrap();
        let tau = taubin_smooth(&m0, 20, TAUBIN_LAMBDA, TAUBIN_MU).unwrap();
        check_closed_manifold(&lap, name);
        check_closed_manifold(&tau, name);
        let (vl, vt) = (lap.signed_volume(), tau.signed_volume());
        assert!(vl < v0 * 0.99, "{name}: Laplacian volume {vl} should shrink from {v0}");
        assert!(rel(vt, v0) < 0.01, "{name}: Taubin volume {vt} vs {v0}");
        let (r0, rl, rt) = (roughness(&m0), roughness(&lap), roughness(&tau));
        assert!(rl < 0.7 * r0 && rt < 0.7 * r0, "{name}: roughness {r0} -> Laplacian {rl}, Taubin {rt}");
        // Taubin also brings the vertices closer to the true sphere on average.
        let err = |m: &Mesh| {
            m.vertices().iter().map(|p| sphere.distance(p).abs()).sum::<f64>() / m.vertices().len() as f64
        };
        assert!(err(&tau) < err(&m0), "{name}: Taubin error {} vs {}", err(&tau), err(&m0));
        // Smoothing moves the surface with the sphere: centroids follow the shift.
        let c = surface_centroid(&tau);
        assert!((c - sphere.center).norm() < 1e-3, "{name}: centroid {c}");
    }
}

#[test]
fn smoothing_rejects_bad_factors_and_keeps_isolated_vertices() {
    use s2g_geom::{laplacian_smooth, taubin_smooth};
    let mut v = vec![Point3::origin(), Point3::new(1.0, 0.0, 0.0), Point3::new(0.0, 1.0, 0.0)];
    v.push(Point3::new(5.0, 5.0, 5.0));
    let m = Mesh::new(v, vec![[0, 1, 2]]).unwrap();
    assert!(taubin_smooth(&m, 3, 0.5, -0.4).is_err(), "mu must be below -lambda");
    assert!(taubin_smooth(&m, 3, -0.5, -0.6).is_err(), "lambda must be positive");
    assert!(laplacian_smooth(&m, 3, f64::NAN).is_err());
    // Diverging factors give an error rather than non-finite coordinates.
    assert!(laplacian_smooth(&m, 2000, -1e6).is_err());
    let s = laplacian_smooth(&m, 4, 0.5).unwrap();
    assert_eq!(s.vertices()[3], Point3::new(5.0, 5.0, 5.0), "isolated vertex moved");
    // With lambda = 1 the umbrella step moves each corner to the mean of the other two.
    let once = laplacian_smooth(&m, 1, 1.0).unwrap();
    let p = m.vertices();
    for (i, q) in once.vertices()[..3].iter().enumerate() {
        let expect = nalgebra::center(&p[(i + 1) % 3], &p[(i + 2) % 3]);
        assert!((q - expect).norm() < 1e-15, "umbrella step of corner {i}: {q} vs {expect}");
    }
    assert_eq!(laplacian_smooth(&m, 0, 0.5).unwrap(), m, "zero iterations change nothing");
}
