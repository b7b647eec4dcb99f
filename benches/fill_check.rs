//! The parallel finisher's fill check (`Line::centre_distance`: how far a contact point
//! between two passes lies from the ball centres over a pass), the bunny's hottest routine
//! after the drop-cutter's contacts (9 % of its CPU in `perf record` on `fperf8`), against
//! its baseline in the same run:
//!
//! - `reference`: every segment within two radii along the pass, a square root each (the
//!   routine before `fperf8`);
//! - `outward`: from the segment at the point outwards, each side stopping where the
//!   distance along the pass alone is no nearer than the nearest so far, one square root;
//!   the same distances bit for bit (asserted before timing).
//!
//! Input: the bundled bunny at 100 mm, a 3 mm ball's tip heights from drop-cutter every
//! 1/32 mm along a pass across its middle (X, at Y = 0: the fill checks' fine step for a
//! 0.125 mm sampling step), and 4,096 contact points between it and a neighbour 0.4 mm
//! away, as the fill check asks them (the contact under the ball at a quarter and half the
//! way across).
//!
//! Group `crossed_fill_checks`: the crossed finisher's two directions with fill passes
//! (`Crossed::paths`) over a 40 x 40 mm window of the same bunny (base up, a 10 mm ball,
//! the shop library's 0.01 mm scallop), each direction's gaps fill-checked only near the
//! points it keeps (`narrow`, `fperf12`) against its baseline in the same run, the check
//! over the whole window (`whole`, the routine before; the same passes bit for bit,
//! asserted before timing).
//!
//! Run: `cargo bench --bench fill_check`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use shape2gcode::geom::{Cutter, DropCutter, MeshIndex, load_mesh};
use shape2gcode::toolpath::finish::{Crossed, FinishContext, FinishingStrategy, centre_distances};

const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/stanford_bunny.stl");

fn bench(c: &mut Criterion) {
    let mesh = load_mesh(BUNNY).expect("bundled bunny");
    let b = mesh.bbox().expect("bunny box");
    let k = 100.0 / b.extent().max();
    let mesh = mesh.transformed(&shape2gcode::geom::Similarity3::new(
        -b.center().coords * k,
        shape2gcode::geom::Vector3::zeros(),
        k,
    ));
    let index = MeshIndex::new(&mesh).expect("bunny index");
    let r = 3.0;
    let dc = DropCutter::new(&index, &Cutter::ball(r, 30.0)).expect("drop-cutter");
    let (x0, x1) = (-55.0, 55.0);
    let n = ((x1 - x0) * 32.0) as usize;
    let points: Vec<(f64, Option<f64>)> =
        (0..=n).map(|i| x0 + (x1 - x0) * i as f64 / n as f64).map(|x| (x, dc.height(x, 0.0))).collect();
    let queries: Vec<[f64; 3]> = (0..4096)
        .map(|i| x0 + (x1 - x0) * (i as f64 + 0.5) / 4096.0)
        .flat_map(|x| [0.1, 0.2].map(|y| (x, y)))
        .filter_map(|(x, y)| dc.height(x, y).map(|z| [x, y, z]))
        .collect();
    let (dir, offset) = ([1.0, 0.0], 0.0);
    let want = centre_distances(&points, dir, offset, r, &queries, true);
    let got = centre_distances(&points, dir, offset, r, &queries, false);
    assert!(
        want.iter().zip(&got).all(|(a, b)| a.to_bits() == b.to_bits()),
        "outward must equal the reference bit for bit"
    );
    let mut g = c.benchmark_group("fill_check");
    g.bench_function("reference", |bch| {
        bch.iter(|| black_box(centre_distances(&points, dir, offset, r, &queries, true)))
    });
    g.bench_function("outward", |bch| {
        bch.iter(|| black_box(centre_distances(&points, dir, offset, r, &queries, false)))
    });
    g.finish();
    crossed(c, &index);
}

fn crossed(c: &mut Criterion, index: &MeshIndex) {
    let cutter = Cutter::ball(5.0, 40.0);
    let dc = DropCutter::new(index, &cutter).expect("drop-cutter");
    let ctx = FinishContext {
        drop_cutter: &dc,
        cutter: &cutter,
        min: [-20.0, -20.0],
        max: [20.0, 20.0],
        z_range: [-60.0, 60.0],
        scallop: 0.01,
        cancel: None,
    };
    let narrow = Crossed::default();
    let whole = Crossed { narrow_fills: false, ..narrow };
    let bits = |p: Vec<Vec<shape2gcode::geom::Point3>>| -> Vec<[u64; 3]> {
        p.iter().flatten().map(|q| [q.x.to_bits(), q.y.to_bits(), q.z.to_bits()]).collect()
    };
    assert!(
        bits(narrow.paths(&ctx).expect("narrow")) == bits(whole.paths(&ctx).expect("whole")),
        "narrow checks must give the whole checks' passes bit for bit"
    );
    let mut g = c.benchmark_group("crossed_fill_checks");
    g.sample_size(10);
    g.bench_function("whole", |bch| bch.iter(|| black_box(whole.paths(&ctx).map(|p| p.len()))));
    g.bench_function("narrow", |bch| bch.iter(|| black_box(narrow.paths(&ctx).map(|p| p.len()))));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
