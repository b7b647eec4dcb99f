//! Toolpath planning on the Stanford bunny at the paper's finest setting (part normalised
//! into the unit cube, layer height 1/512, tool radius 0.001; seed 000 Appendix A.1).
//!
//! - `setup/ours_zigzag`: a whole +Z setup (slicing, exact keep-outs, offsets, contour
//!   and zigzag clearing, linking) streamed into a counting sink.
//! - `layer/ours_contour`: one mid-height layer's exact contour (keep-out grown by the
//!   tool radius, boundary loops), from precomputed slices.
//! - `layer/paper_contour` (baseline): the paper's contour for the same layer (Eq. 5-6):
//!   grid points at 1/256 where |SDF - r| < eps, from the mesh's signed distance, sorted by
//!   nearest neighbour.
//!
//! - `undercut_scan/bounded`: the undercut pass's level scan (`undercut::undercut_levels`)
//!   for a 21 mm T-slot cutter over the bunny at 100 mm seen from +Z, with no material
//!   left within the disc's reach (as after the bunny's finishing): every level passed over
//!   on its material bound; `undercut_scan/unbounded` (baseline,
//!   `undercut_levels_unbounded`): every level's free region built and measured. The same
//!   levels (none).
//!
//! Run: `cargo bench --bench toolpath`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use shape2gcode::gcode::{Motion, MotionSink};
use shape2gcode::geom::{
    Aabb, Cutter, MeshIndex, Point3, Setup, Similarity3, Vector3, load_mesh, normalize_unit_cube,
};
use shape2gcode::toolpath::undercut::{
    UndercutOptions, part_columns, undercut_levels, undercut_levels_unbounded,
};
use shape2gcode::toolpath::{PlanOptions, Point2, Tool, baseline, plan_setup, slice_setup};

const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/meshes/classic/stanford_bunny.stl");

/// Counts moves; keeps nothing.
#[derive(Default)]
struct Count(u64);

impl MotionSink for Count {
    type Error = std::convert::Infallible;
    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        self.0 += u64::from(m.end_point().is_some());
        Ok(())
    }
}

fn bench(c: &mut Criterion) {
    let mesh = normalize_unit_cube(&load_mesh(BUNNY).expect("bundled bunny")).expect("normalise").0;
    let tool = Tool::flat(0.001);
    let opts = PlanOptions { layer_height: 1.0 / 512.0, ..Default::default() };
    let setup = Setup::top();

    let slices = slice_setup::<()>(&mesh, &setup, &tool, &opts).expect("slices");
    let mid = slices.levels.len() / 2;
    let z = slices.levels[mid];
    let keep = slices.keepouts[mid].clone();
    let index = MeshIndex::new(&mesh).expect("bunny index");
    let (lo, hi) = (slices.stock.min, slices.stock.max);

    let mut g = c.benchmark_group("layer");
    g.sample_size(10);
    g.bench_function("ours_contour", |b| {
        b.iter(|| {
            let off = keep.grown_safe(tool.radius(), 1e-3 * tool.radius(), opts.arc_step);
            black_box(off.loops().len())
        })
    });
    g.bench_function("paper_contour", |b| {
        b.iter(|| {
            black_box(
                baseline::paper_contour(
                    &index,
                    z,
                    Point2::new(lo.x, lo.y),
                    Point2::new(hi.x, hi.y),
                    1.0 / 256.0,
                    tool.radius(),
                    0.5 / 256.0,
                    Point2::new(lo.x, lo.y),
                )
                .len(),
            )
        })
    });
    g.finish();

    let mut g = c.benchmark_group("setup");
    g.sample_size(10);
    g.bench_function("ours_slicing_only", |b| {
        b.iter(|| black_box(slice_setup::<()>(&mesh, &setup, &tool, &opts).expect("slices").levels.len()))
    });
    // Contour + clearing at the finest setting: one whole setup (layers: slices.levels.len()).
    g.bench_function("ours_zigzag", |b| {
        b.iter(|| {
            let mut sink = Count::default();
            let s = plan_setup(&mesh, &setup, &tool, &opts, &mut sink).expect("plan");
            black_box((s.layers, sink.0))
        })
    });
    g.finish();
}

/// The undercut scan over the bunny at 100 mm from +Z (see the module's documentation).
fn undercut_scan(c: &mut Criterion) {
    let unit = normalize_unit_cube(&load_mesh(BUNNY).expect("bundled bunny")).expect("normalise").0;
    let mesh = unit.transformed(&Similarity3::new(Vector3::zeros(), Vector3::zeros(), 100.0));
    let part = mesh.bbox().expect("a bounded part");
    let margin = Point3::new(5.0, 5.0, 5.0).coords;
    let stock = Aabb::new(part.min - margin, part.max + margin);
    let mut tool = Tool::new(Cutter::t_slot(10.5, 9.0, 5.0, 30.0));
    tool.cutter.stickout = 40.0;
    let opts = UndercutOptions { min_volume: 2000.0, ..UndercutOptions::default() };
    let columns = part_columns(&mesh, &Setup::top(), &stock, &tool, opts.cell);
    // Material only in the stock's lowest 2 mm, out of the disc's reach from the top.
    let floor = stock.min.z + 2.0;
    let rest = move |min: &Point3, _: &Point3| min.z < floor;
    let mut g = c.benchmark_group("undercut_scan");
    g.sample_size(10);
    g.bench_function("bounded", |b| {
        b.iter(|| black_box(undercut_levels(&columns, &tool, &stock, &rest, &opts).0.len()))
    });
    g.bench_function("unbounded", |b| {
        b.iter(|| black_box(undercut_levels_unbounded(&columns, &tool, &stock, &rest, &opts).0.len()))
    });
    g.finish();
}

criterion_group!(benches, bench, undercut_scan);
criterion_main!(benches);
