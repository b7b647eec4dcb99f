//! The drop-cutter with its per-triangle terms stored once per index equals the search
//! that computes them on every call ([`DropCutter::height_per_call`]) bit for bit.

use proptest::prelude::*;
use s2g_geom::{Cutter, DropCutter, Mesh, MeshIndex, Point3, Similarity3, Vector3, load_mesh};

/// A cutter from its kind (0 flat, 1 ball, 2 bull nose), radius and corner fraction.
fn cutter(kind: u8, radius: f64, corner: f64) -> Cutter {
    match kind {
        0 => Cutter::flat(radius, 10.0),
        1 => Cutter::ball(radius, 10.0),
        _ => Cutter::bull(radius, corner * radius, 10.0),
    }
}

/// Both searches at every point, bit for bit.
fn assert_same(dc: &DropCutter<'_>, points: &[[f64; 2]]) -> Result<(), TestCaseError> {
    for p in points {
        let (got, want) = (dc.height(p[0], p[1]), dc.height_per_call(p[0], p[1]));
        prop_assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "at {:?}: {:?} vs {:?}", p, got, want);
    }
    Ok(())
}

proptest! {
    /// Random soups (steep, vertical and sliver triangles among them, vertices snapped to
    /// a coarse lattice so that edges and vertices line up and vertical facets occur), every
    /// end shape, points over and beside them.
    #[test]
    fn stored_terms_equal_per_call(
        tris in prop::collection::vec(prop::array::uniform3((-8i32..8, -8i32..8, -6i32..6)), 1..40),
        kind in 0u8..3,
        radius in 0.3f64..4.0,
        corner in 0.1f64..0.9,
        points in prop::collection::vec((-12.0f64..12.0, -12.0f64..12.0), 1..40),
    ) {
        let soup: Vec<[Point3; 3]> = tris
            .iter()
            .map(|t| t.map(|(x, y, z)| Point3::new(x as f64 * 0.5, y as f64 * 0.5, z as f64 * 0.5)))
            .collect();
        let Ok(mesh) = Mesh::from_soup(&soup) else { return Ok(()) };
        let Ok(index) = MeshIndex::new(&mesh) else { return Ok(()) };
        let c = cutter(kind, radius, corner);
        let dc = DropCutter::new(&index, &c).unwrap();
        let pts: Vec<[f64; 2]> = points.iter().map(|&(x, y)| [x, y]).collect();
        assert_same(&dc, &pts)?;
    }
}

/// On the bundled bunny at 100 mm, a raster at an odd step for the three end shapes.
#[test]
fn stored_terms_equal_per_call_on_the_bunny() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/stanford_bunny.stl");
    let mesh = load_mesh(path).unwrap();
    let b = mesh.bbox().unwrap();
    let s = 100.0 / b.extent().max();
    let mesh = mesh.transformed(&Similarity3::new(-b.min.coords * s, Vector3::zeros(), s));
    let index = MeshIndex::new(&mesh).unwrap();
    let points: Vec<[f64; 2]> =
        (0..40).flat_map(|j| (0..40).map(move |i| [i as f64 * 2.61 - 3.0, j as f64 * 2.57 - 3.0])).collect();
    for c in [cutter(0, 3.0, 0.0), cutter(1, 5.0, 1.0), cutter(2, 3.0, 0.4)] {
        let dc = DropCutter::new(&index, &c).unwrap();
        assert!(points.iter().any(|p| dc.height(p[0], p[1]).is_some()), "the raster must touch the bunny");
        assert_same(&dc, &points).unwrap();
    }
    // The ball's contact normal from the search bounded to a little over its radius is
    // the unbounded search's, at the heights and off them (where the bound misses).
    let dc = DropCutter::new(&index, &cutter(1, 5.0, 1.0)).unwrap();
    let mut checked = 0;
    for p in &points {
        let Some(h) = dc.height(p[0], p[1]) else { continue };
        for z in [h, h + 0.5, h - 0.01, h + 40.0] {
            let (got, want) = (dc.contact_normal(p[0], p[1], z), dc.contact_normal_unbounded(p[0], p[1], z));
            assert_eq!(got.map(|n| n.map(f64::to_bits)), want.map(|n| n.map(f64::to_bits)), "at {p:?}, {z}");
            checked += usize::from(got.is_some());
        }
    }
    assert!(checked > 100, "only {checked} normals");
}
