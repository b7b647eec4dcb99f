//! The planner's region algebra on inputs whose boundaries are long and finely divided
//! (issue 32: a flanged bushing with a cross hole never finished at 256^3).
//!
//! - `keepouts/bushing_96/{ours,baseline_with_slivers}`: slicing the bundled stress part
//!   `bushing_96` (a tube with a cross hole on a flange, 96 facets per circle) into 48
//!   levels with a 1 mm end mill: every level's keep-out, the running union of the slabs'
//!   projections. The baseline is the code before the sliver fix (`sliver_width: 0`):
//!   the tube's numerically vertical walls near the cross hole are unioned in as needles
//!   and the keep-out's boundary grows from level to level.
//! - `staircase/N`: the per-layer operations on a staircase region (the cells of an
//!   N x N grid over 100 mm that a 96-facet circle of 40 mm radius covers, as the
//!   remaining-material map gives them): its union from cell rows, its intersection with
//!   a layer's free region (a 96-facet ring of 10-45 mm) and the difference with a
//!   roughing level's (a 96-facet disc of 30 mm), as `Ctx::plan_layer` does. The boundary
//!   has about 4N vertices.
//! - `staircase_offset/N`: the same staircase grown by 1 mm with `grown_safe` (the
//!   planner grows keep-outs made of facets, not staircases: this is the worst case of the
//!   offset engine, whose round joins overlap about r / cell neighbours).
//!
//! Run: `cargo bench --bench region`.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use shape2gcode::geom::{Setup, load_mesh};
use shape2gcode::toolpath::{DEFAULT_ARC_STEP, PlanOptions, Point2, Region2, Tool, slice_setup};

const BUSHING: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/meshes/stress/bushing_96.stl");

/// The cells of an `n` x `n` grid over [-50, 50]^2 whose centres lie in a 96-gon of
/// radius 40, as one rectangle per run of cells in a row.
fn staircase(n: usize) -> Vec<[Point2; 4]> {
    let c = 100.0 / n as f64;
    let r = 40.0 * (std::f64::consts::PI / 96.0).cos();
    let mut rects = Vec::new();
    for j in 0..n {
        let y = -50.0 + (j as f64 + 0.5) * c;
        if y.abs() >= r {
            continue;
        }
        // The 96-gon's half-width at this height, from its inscribed circle (close enough
        // for a staircase).
        let half = (r * r - y * y).sqrt();
        let (i0, i1) = (((50.0 - half) / c).ceil() as usize, ((50.0 + half) / c).floor() as usize);
        if i0 < i1 {
            let (x0, x1, y0) = (-50.0 + i0 as f64 * c, -50.0 + i1 as f64 * c, -50.0 + j as f64 * c);
            rects.push([
                Point2::new(x0, y0),
                Point2::new(x1, y0),
                Point2::new(x1, y0 + c),
                Point2::new(x0, y0 + c),
            ]);
        }
    }
    rects
}

fn bench(c: &mut Criterion) {
    let mesh = load_mesh(BUSHING).expect("bundled stress part");
    let tool = Tool::flat(1.0);
    let opts = PlanOptions { layer_height: 35.0 / 48.0, ..PlanOptions::default() };
    let baseline = PlanOptions { sliver_width: Some(0.0), ..opts.clone() };
    let mut g = c.benchmark_group("keepouts/bushing_96");
    g.sample_size(10);
    for (name, o) in [("ours", &opts), ("baseline_with_slivers", &baseline)] {
        let s = slice_setup::<()>(&mesh, &Setup::top(), &tool, o).expect("slices");
        let most = s.keepouts.iter().map(Region2::vertex_count).max().unwrap_or(0);
        println!("keepouts/bushing_96/{name}: {} levels, largest keep-out {most} vertices", s.levels.len());
        g.bench_function(name, |b| {
            b.iter(|| {
                black_box(slice_setup::<()>(&mesh, &Setup::top(), &tool, o).expect("slices").levels.len())
            })
        });
    }
    g.finish();

    let polygon = |radius: f64| -> Vec<Point2> {
        (0..96)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / 96.0;
                Point2::new(radius * a.cos(), radius * a.sin())
            })
            .collect()
    };
    let disc = |radius: f64| Region2::from_polygons([&polygon(radius)[..]]);
    let free = disc(45.0).difference(&disc(10.0));
    let done = disc(30.0);
    let mut g = c.benchmark_group("staircase");
    g.sample_size(10);
    for n in [128, 256, 512, 1024] {
        let rects = staircase(n);
        let region = Region2::from_polygons(rects.iter().map(|r| &r[..]));
        println!("staircase/{n}: {} boundary vertices", region.vertex_count());
        g.bench_with_input(BenchmarkId::from_parameter(n), &rects, |b, rects| {
            b.iter(|| {
                let reach = Region2::from_polygons(rects.iter().map(|r| &r[..]));
                black_box(free.difference(&done).intersection(&reach).vertex_count())
            })
        });
    }
    g.finish();
    let mut g = c.benchmark_group("staircase_offset");
    g.sample_size(10);
    for n in [128, 256, 512, 1024] {
        let region = Region2::from_polygons(staircase(n).iter().map(|r| &r[..]));
        g.bench_with_input(BenchmarkId::from_parameter(n), &region, |b, region| {
            b.iter(|| black_box(region.grown_safe(1.0, 1e-3, DEFAULT_ARC_STEP).vertex_count()))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
