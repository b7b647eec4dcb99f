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
//! Run: `cargo bench --bench toolpath`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use shape2gcode::gcode::{Motion, MotionSink};
use shape2gcode::geom::{MeshIndex, Setup, load_mesh, normalize_unit_cube};
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

criterion_group!(benches, bench);
criterion_main!(benches);
