//! The crossed finisher fill-checks each direction's gaps only near the points it keeps
//! (`Crossed::narrow_fills`): its passes equal, bit for bit, those of the check over the
//! whole part, on the bundled bunny's scanned relief (whose hollows call for fill passes),
//! at several raster angles and scallop targets; and there are fill passes to find.

use s2g_geom::{Cutter, DropCutter, MeshIndex, Point3, Similarity3, Vector3, load_mesh};
use s2g_toolpath::finish::{Crossed, FinishContext, FinishingStrategy, Parallel};

fn bunny(size: f64) -> MeshIndex {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/stanford_bunny.stl");
    let mesh = load_mesh(path).expect("the bundled bunny loads");
    let b = mesh.bbox().expect("a non-empty mesh");
    let s = size / b.extent().max();
    let mesh = mesh.transformed(&Similarity3::new(-b.min.coords * s, Vector3::zeros(), s));
    MeshIndex::new(&mesh).expect("a non-empty mesh")
}

fn bits(paths: &[Vec<Point3>]) -> Vec<Vec<[u64; 3]>> {
    paths.iter().map(|p| p.iter().map(|q| [q.x.to_bits(), q.y.to_bits(), q.z.to_bits()]).collect()).collect()
}

#[test]
fn narrow_fill_checks_give_the_whole_checks_passes() {
    let index = bunny(40.0);
    let cutter = Cutter::ball(1.0, 20.0);
    let dc = DropCutter::new(&index, &cutter).unwrap();
    for (angle, scallop, min, max) in [
        (0.0, 0.01, [4.0, 4.0], [36.0, 30.0]),
        (0.4, 0.005, [10.0, 0.0], [30.0, 22.0]),
        (1.1, 0.02, [0.0, 8.0], [24.0, 34.0]),
    ] {
        let ctx = FinishContext {
            drop_cutter: &dc,
            cutter: &cutter,
            min,
            max,
            z_range: [2.0, 60.0],
            scallop,
            cancel: None,
        };
        let parallel = Parallel { angle, ..Parallel::default() };
        let narrow = Crossed { parallel, ..Crossed::default() };
        let whole = Crossed { narrow_fills: false, ..narrow };
        let bare = Crossed { parallel: Parallel { fill: 0.0, ..parallel }, ..narrow };
        let (n, w, b) = (narrow.paths(&ctx).unwrap(), whole.paths(&ctx).unwrap(), bare.paths(&ctx).unwrap());
        let points = |p: &[Vec<Point3>]| p.iter().map(Vec::len).sum::<usize>();
        println!("angle {angle}: {} points, {} without fill passes", points(&n), points(&b));
        // The fill passes add points: the check has something to find.
        assert!(points(&w) > points(&b), "angle {angle}: no fill passes");
        assert!(bits(&n) == bits(&w), "angle {angle}: narrow checks changed the passes");
    }
}
