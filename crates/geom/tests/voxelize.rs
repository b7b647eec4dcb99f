//! Solid voxelisation against exact volumes, analytic shapes and an independent
//! point-by-point winding-number classification.

use s2g_geom::{
    Aabb, BoxShape, GridSpec, Mesh, MeshIndex, Point3, Rotation3, SignedDistance, Similarity3, Vector3,
    VoxelGrid, VoxelizeOptions, voxelize, voxelize_opt,
};

/// The closed, outward box `[min, max]`.
fn box_mesh(min: Point3, max: Point3) -> Mesh {
    Mesh::cuboid(&Aabb::new(min, max)).unwrap()
}

/// An icosphere: the icosahedron subdivided `levels` times, vertices pushed onto the sphere.
fn icosphere(center: Point3, radius: f64, levels: usize) -> Mesh {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<Vector3> = [
        (-1.0, g, 0.0),
        (1.0, g, 0.0),
        (-1.0, -g, 0.0),
        (1.0, -g, 0.0),
        (0.0, -1.0, g),
        (0.0, 1.0, g),
        (0.0, -1.0, -g),
        (0.0, 1.0, -g),
        (g, 0.0, -1.0),
        (g, 0.0, 1.0),
        (-g, 0.0, -1.0),
        (-g, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vector3::new(x, y, z).normalize())
    .collect();
    let mut t: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::BTreeMap::new();
        let mut next = Vec::with_capacity(t.len() * 4);
        let mut midpoint = |a: u32, b: u32, v: &mut Vec<Vector3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push((v[a as usize] + v[b as usize]).normalize());
                v.len() as u32 - 1
            })
        };
        for &[a, b, c] in &t {
            let ab = midpoint(a, b, &mut v);
            let bc = midpoint(b, c, &mut v);
            let ca = midpoint(c, a, &mut v);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        t = next;
    }
    Mesh::new(v.iter().map(|d| center + d * radius).collect(), t).unwrap()
}

fn bunny() -> Mesh {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/stanford_bunny.stl");
    s2g_geom::load_mesh(path).unwrap_or_else(|e| panic!("loading {path}: {e}"))
}

/// The independent reference: every voxel centre classified by the winding number.
fn reference(mesh: &Mesh, spec: &GridSpec) -> VoxelGrid {
    let index = MeshIndex::new(mesh).unwrap();
    let mut g = VoxelGrid::new(*spec);
    g.set_where(|p| index.contains(p));
    g
}

/// Number of voxels where two grids differ.
fn differ(a: &VoxelGrid, b: &VoxelGrid) -> u64 {
    let mut x = a.clone();
    x.xor(b).unwrap();
    x.count()
}

#[test]
fn bunny_volume_at_256_is_within_one_percent_of_the_exact_volume() {
    let mesh = bunny();
    let exact = mesh.signed_volume();
    let spec = GridSpec::cubic(&mesh.bbox().unwrap().inflated(1e-3), 256).unwrap();
    for robust in [true, false] {
        let opts = VoxelizeOptions { robust, ..Default::default() };
        let g = voxelize_opt(&mesh, &spec, &opts).unwrap();
        let rel = (g.volume() - exact).abs() / exact;
        assert!(rel < 0.01, "bunny at 256^3 (robust {robust}): voxel volume {} vs exact {exact}", g.volume());
    }
}

#[test]
fn bunny_matches_the_winding_number_classification_at_96() {
    let mesh = bunny();
    let spec = GridSpec::cubic(&mesh.bbox().unwrap().inflated(0.05), 96).unwrap();
    let g = voxelize(&mesh, &spec).unwrap();
    let r = reference(&mesh, &spec);
    let d = differ(&g, &r);
    assert!(
        d <= r.count() / 5000,
        "bunny at 96^3: {d} voxels differ from the winding reference of {}",
        r.count()
    );
}

#[test]
fn box_mesh_gives_exactly_the_analytic_voxel_set() {
    let spec = GridSpec::cubic(&Aabb::unit_cube(), 64).unwrap();
    // Bounds off the voxel centres (centres sit at odd multiples of 1/128).
    let shape = BoxShape { min: Point3::new(-0.31, -0.2, -0.45), max: Point3::new(0.27, 0.41, 0.05) };
    let mut want = VoxelGrid::new(spec);
    want.set_where(|p| shape.distance(p) < 0.0);
    for robust in [true, false] {
        let g = voxelize_opt(
            &box_mesh(shape.min, shape.max),
            &spec,
            &VoxelizeOptions { robust, ..Default::default() },
        )
        .unwrap();
        assert_eq!(g.count(), want.count(), "box (robust {robust})");
        assert_eq!(differ(&g, &want), 0, "box (robust {robust})");
    }
}

#[test]
fn box_with_faces_through_voxel_centres_does_not_leak() {
    // Faces and edges exactly on voxel centres exercise the tie-breaking rules: every
    // column must see matched crossings, so the fill equals a half-open count.
    let spec = GridSpec::new(&Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(16.0, 16.0, 16.0)), [16; 3])
        .unwrap();
    let mesh = box_mesh(Point3::new(2.5, 3.5, 4.5), Point3::new(9.5, 11.5, 12.5));
    for robust in [true, false] {
        let opts = VoxelizeOptions { robust, winding_fallback: false, ..Default::default() };
        let g = voxelize_opt(&mesh, &spec, &opts).unwrap();
        // Each axis has either 7 or 8 voxel centres on the closed interval; the half-open
        // rule takes one end, so exactly 7 x 8 x 8 voxels.
        assert_eq!(g.count(), 7 * 8 * 8, "box on voxel centres (robust {robust})");
    }
}

#[test]
fn icosphere_volume_matches_the_mesh_and_the_winding_reference() {
    let mesh = icosphere(Point3::new(0.013, -0.021, 0.007), 0.4, 4);
    let spec = GridSpec::cubic(&Aabb::unit_cube(), 128).unwrap();
    let g = voxelize(&mesh, &spec).unwrap();
    let exact = mesh.signed_volume();
    let rel = (g.volume() - exact).abs() / exact;
    assert!(rel < 0.005, "icosphere at 128^3: {} vs mesh volume {exact}", g.volume());
    let sphere = 4.0 / 3.0 * std::f64::consts::PI * 0.4f64.powi(3);
    assert!((g.volume() - sphere).abs() / sphere < 0.01, "icosphere vs analytic sphere {sphere}");
    assert_eq!(differ(&g, &reference(&mesh, &spec)), 0, "icosphere vs winding reference");
}

#[test]
fn open_cube_is_still_filled() {
    let spec = GridSpec::cubic(&Aabb::unit_cube(), 48).unwrap();
    let shape = BoxShape { min: Point3::new(-0.33, -0.29, -0.31), max: Point3::new(0.3, 0.35, 0.32) };
    let mut want = VoxelGrid::new(spec);
    want.set_where(|p| shape.distance(p) < 0.0);
    let (v, mut t) = box_mesh(shape.min, shape.max).into_parts();
    t.drain(2..4); // drop the +z face
    let open = Mesh::new(v, t).unwrap();
    let g = voxelize(&open, &spec).unwrap();
    let d = differ(&g, &want);
    // Only voxels just under the missing face may differ (winding < 0.5 near the hole).
    assert!(d < want.count() / 50, "open cube: {d} of {} voxels differ", want.count());
    assert!(g.count() <= want.count(), "open cube grew outside the box");
    // Z-only filling gets no consistent column through the hole: the winding fallback decides.
    let z = voxelize_opt(&open, &spec, &VoxelizeOptions { robust: false, ..Default::default() }).unwrap();
    assert!(differ(&z, &want) < want.count() / 50, "open cube, Z only");
}

#[test]
fn duplicated_faces_fill_once_and_opposed_faces_cancel() {
    let spec = GridSpec::cubic(&Aabb::unit_cube(), 40).unwrap();
    let shape = BoxShape { min: Point3::new(-0.21, -0.33, -0.12), max: Point3::new(0.3, 0.19, 0.41) };
    let single = box_mesh(shape.min, shape.max);
    let mut twice = single.clone();
    twice.append(&single);
    let a = voxelize(&single, &spec).unwrap();
    assert_eq!(differ(&voxelize(&twice, &spec).unwrap(), &a), 0, "duplicated faces");
    let mut opposed = single.clone();
    opposed.append(&single.flipped());
    assert_eq!(voxelize(&opposed, &spec).unwrap().count(), 0, "opposed faces");
}

#[test]
fn rotated_and_translated_inputs_give_the_transformed_answer() {
    let mesh = bunny();
    let bb = mesh.bbox().unwrap();
    let spec = GridSpec::cubic(&bb.inflated(0.05), 80).unwrap();
    let base = voxelize(&mesh, &spec).unwrap();
    // Translating mesh and grid together by any amount moves the voxel set with them
    // (up to rounding at voxel centres lying on the surface).
    let shift = Vector3::new(123.456, -78.9, 0.123);
    let moved = mesh.transformed(&Similarity3::from_parts(shift.into(), Rotation3::identity(), 1.0));
    let spec2 = GridSpec { origin: spec.origin + shift, ..spec };
    let g = voxelize(&moved, &spec2).unwrap();
    let mut shifted = VoxelGrid::new(spec2);
    for [i, j, k] in base.iter_set() {
        shifted.set(i, j, k, true);
    }
    assert!(differ(&g, &shifted) <= 2, "translated bunny: {} voxels differ", differ(&g, &shifted));
    // A rotation: compare with the independent classification in the rotated frame, and
    // the volume with the (rotation-invariant) exact volume.
    let rot = Similarity3::from_parts(
        nalgebra::Translation3::new(0.3, -0.2, 0.1),
        Rotation3::from_euler_angles(0.5, -0.9, 2.1),
        1.0,
    );
    let rotated = mesh.transformed(&rot);
    let spec3 = GridSpec::cubic(&rotated.bbox().unwrap().inflated(0.05), 80).unwrap();
    let g = voxelize(&rotated, &spec3).unwrap();
    let r = reference(&rotated, &spec3);
    assert!(differ(&g, &r) <= r.count() / 2000, "rotated bunny vs reference: {}", differ(&g, &r));
    let rel = (g.volume() - mesh.signed_volume()).abs() / mesh.signed_volume();
    assert!(rel < 0.03, "rotated bunny at 80^3: volume off by {rel}");
}

#[test]
fn malformed_specs_are_errors_and_empty_meshes_give_empty_grids() {
    let good = GridSpec::cubic(&Aabb::unit_cube(), 8).unwrap();
    let mesh = box_mesh(Point3::new(-0.2, -0.2, -0.2), Point3::new(0.2, 0.2, 0.2));
    for bad in [
        GridSpec { voxel: Vector3::new(0.0, 0.1, 0.1), ..good },
        GridSpec { voxel: Vector3::new(f64::NAN, 0.1, 0.1), ..good },
        GridSpec { origin: Point3::new(f64::INFINITY, 0.0, 0.0), ..good },
        GridSpec { voxel: Vector3::new(-0.1, 0.1, 0.1), ..good },
    ] {
        assert!(voxelize(&mesh, &bad).is_err(), "{bad:?} should be rejected");
    }
    assert_eq!(voxelize(&Mesh::default(), &good).unwrap().count(), 0);
    // A mesh far outside the grid leaves it empty.
    let far = box_mesh(Point3::new(10.0, 10.0, 10.0), Point3::new(11.0, 11.0, 11.0));
    assert_eq!(voxelize(&far, &good).unwrap().count(), 0);
}
