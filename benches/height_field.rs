//! The finishing height field's sweep (s2g-voxsim `HeightField`, issue 36's surface
//! deviation) against its baseline in the same run: `reference` visits every column of
//! each move's box, `tiled` (the default) passes over 8 x 8 blocks of columns that the
//! move cannot lower and decides most columns' mark and floor tests on their squared
//! distance (`ColumnTests`), `tiled_roots` (its baseline) by square roots; `tiled` passes
//! most far blocks over on the gap between the block's box and the path's before their
//! distance, `tiled_distances` (its baseline) computes every block's distance. All leave the same field bit for bit (`crates/voxsim/tests/
//! surface_sweep.rs`). The program is a bunny-like finish: a 10 mm ball end mill on a
//! crossed raster of 0.6 mm stepover over a wavy 24 x 24 mm surface mesh, its tip
//! dropped onto the mesh every 0.2 mm (drop-cutter), columns 0.1 mm apart, passes marked
//! 0.45 mm wide.
//!
//! Group `surface_deviation_closed_part`: the deviation of such a finish from the part
//! (s2g-voxsim `surface_deviation_opt`, a 5 mm ball's reach as in the pipeline) on the
//! bundled bunny at 100 mm, a closed part, against its baseline `reference`
//! (`surface_deviation_reference`: every cut point's closest point and winding number);
//! `closed_part` passes over the winding number of cut points with nothing of the part
//! above them, and their closest point where they do not count. Both give the same
//! deviation (asserted here and in `crates/voxsim/tests/surface.rs`).
//!
//! Group `height_field_beside_simulator`: the pipeline's two sinks of a finishing program,
//! the voxel simulator and the finished surface's height field (columns 0.05 mm apart,
//! passes marked), fed the crossed raster above: `direct`, the baseline, feeds both from
//! one thread, each move of the field over 4096 columns swept on rayon's threads (a hand-off
//! per move); `own_thread` feeds the simulator there and the field on a thread of its own
//! (`s2g_gcode::SinkThread`, batches of 1024 motions), every move swept on that thread
//! (`HeightField::set_parallel_columns`). Both leave the same field bit for bit (asserted
//! here and in `crates/voxsim/tests/surface_sweep.rs`).
//!
//! Run: `cargo bench --bench height_field`.

use criterion::{Criterion, criterion_group, criterion_main};
use shape2gcode::gcode::{Motion, MotionSink, SinkThread};
use shape2gcode::geom::{
    Aabb, DropCutter, GridSpec, Mesh, MeshIndex, Point3, Similarity3, Vector3, VoxelGrid, load_mesh,
};
use shape2gcode::voxsim::{
    Cutter, DeviationOptions, HeightField, HeightFieldOptions, SimOptions, Simulator, ToolTable,
    surface_deviation_opt, surface_deviation_reference,
};

fn surface(x: f64, y: f64) -> f64 {
    3.0 * (x / 6.0).sin() * (y / 8.0).cos() + 0.2 * x
}

/// The wavy surface over `[-6, 30]^2` as a mesh of 0.5 mm squares.
fn mesh() -> Mesh {
    let n = 72;
    let at = |k: usize| -6.0 + k as f64 * 0.5;
    let vs: Vec<Point3> = (0..=n)
        .flat_map(|j| (0..=n).map(move |i| Point3::new(at(i), at(j), surface(at(i), at(j)))))
        .collect();
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let fs = (0..n)
        .flat_map(|j| {
            (0..n).flat_map(move |i| {
                [[id(i, j), id(i + 1, j), id(i + 1, j + 1)], [id(i, j), id(i + 1, j + 1), id(i, j + 1)]]
            })
        })
        .collect();
    Mesh::new(vs, fs).expect("mesh")
}

/// The crossed raster: passes along X, then along Y, 0.6 apart, the ball's tip dropped
/// onto the surface every 0.2.
fn program() -> Vec<Motion<'static>> {
    let index = MeshIndex::new(&mesh()).expect("index");
    let dc = DropCutter::new(&index, &Cutter::ball(5.0, 30.0)).expect("drop cutter");
    let mut ms = Vec::new();
    for along_x in [true, false] {
        for k in 0..=40 {
            let v = k as f64 * 0.6;
            let at = |u: f64| if along_x { (u, v) } else { (v, u) };
            let (x, y) = at(0.0);
            ms.push(Motion::Rapid { to: Point3::new(x, y, 20.0) });
            for s in 0..=120 {
                let (x, y) = at(s as f64 * 0.2);
                let z = dc.height(x, y).expect("over the surface");
                ms.push(Motion::Linear { to: Point3::new(x, y, z), feed: 1000.0, extrude: None });
            }
            let (x, y) = at(24.0);
            ms.push(Motion::Rapid { to: Point3::new(x, y, 20.0) });
        }
    }
    ms
}

/// Which sweep: the reference, the tiled one deciding every column's mark and floor by
/// square roots (its baseline before `ColumnTests`), or the tiled one as it is.
#[derive(Clone, Copy, PartialEq)]
enum Sweep {
    Reference,
    TiledRoots,
    TiledDistances,
    Tiled,
}

fn sweep(ms: &[Motion<'_>], how: Sweep) -> HeightField {
    let o = HeightFieldOptions { spacing: 0.1, pass_width: Some(0.45), ..Default::default() };
    let tools = ToolTable::single(Cutter::ball(5.0, 30.0));
    let mut f = HeightField::new_opt([-6.0, -6.0], [30.0, 30.0], tools, &o).expect("field");
    match how {
        Sweep::Reference => f.use_reference_sweep(),
        Sweep::TiledRoots => f.use_exact_column_tests(),
        Sweep::TiledDistances => f.use_every_block_distance(),
        Sweep::Tiled => {}
    }
    for m in ms {
        f.motion(m).expect("motion");
    }
    f
}

fn bench(c: &mut Criterion) {
    let ms = program();
    let reference = sweep(&ms, Sweep::Reference);
    for how in [Sweep::TiledRoots, Sweep::TiledDistances, Sweep::Tiled] {
        assert_eq!(
            sweep(&ms, how).columns(),
            reference.columns(),
            "the tiled sweep must equal the reference"
        );
    }
    let mut g = c.benchmark_group("height_field_finish");
    g.sample_size(10);
    g.bench_function("reference", |b| b.iter(|| sweep(&ms, Sweep::Reference)));
    g.bench_function("tiled_roots", |b| b.iter(|| sweep(&ms, Sweep::TiledRoots)));
    g.bench_function("tiled_distances", |b| b.iter(|| sweep(&ms, Sweep::TiledDistances)));
    g.bench_function("tiled", |b| b.iter(|| sweep(&ms, Sweep::Tiled)));
    g.finish();
}

/// The bunny at 100 mm, and the field a 5 mm ball's crossed raster (0.5 mm stepover, its
/// tip dropped every 0.2 mm) cuts over the middle 40 x 40 mm of its top, columns 0.1 mm
/// apart.
fn bunny_finish() -> (MeshIndex, HeightField) {
    let mesh = load_mesh(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/stanford_bunny.stl")).expect("bunny");
    let b = mesh.bbox().expect("a non-empty mesh");
    let s = 100.0 / b.extent().max();
    let part = mesh.transformed(&Similarity3::new(-b.min.coords * s, Vector3::zeros(), s));
    let index = MeshIndex::new(&part).expect("index");
    let c = part.bbox().expect("a non-empty mesh").center();
    let ball = Cutter::ball(5.0, 30.0);
    let dc = DropCutter::new(&index, &ball).expect("drop cutter");
    let (lo, n) = ([c.x - 20.0, c.y - 20.0], 80);
    let o = HeightFieldOptions { spacing: 0.1, ..Default::default() };
    let mut f = HeightField::new_opt(
        [lo[0] - 6.0, lo[1] - 6.0],
        [lo[0] + 46.0, lo[1] + 46.0],
        ToolTable::single(ball),
        &o,
    )
    .expect("field");
    for along_x in [true, false] {
        for k in 0..=n {
            let v = k as f64 * 0.5;
            let at = |u: f64| if along_x { (lo[0] + u, lo[1] + v) } else { (lo[0] + v, lo[1] + u) };
            let (x, y) = at(0.0);
            f.motion(&Motion::Rapid { to: Point3::new(x, y, 200.0) }).expect("motion");
            for s in 0..=200 {
                let (x, y) = at(s as f64 * 0.2);
                if let Some(z) = dc.height(x, y) {
                    f.motion(&Motion::Linear { to: Point3::new(x, y, z), feed: 1000.0, extrude: None })
                        .expect("motion");
                }
            }
            let (x, y) = at(40.0);
            f.motion(&Motion::Rapid { to: Point3::new(x, y, 200.0) }).expect("motion");
        }
    }
    (index, f)
}

fn deviation(c: &mut Criterion) {
    let (index, field) = bunny_finish();
    let o = DeviationOptions { ball_radius: Some(5.0), closed_part: true, ..Default::default() };
    let all = |_: &Point3, _: &Vector3| true;
    let want = surface_deviation_reference(&field, &index, &o, &all);
    assert!(want.columns > 10_000, "{want:?}");
    assert_eq!(surface_deviation_opt(&field, &index, &o), want, "the quick test must equal the reference");
    let mut g = c.benchmark_group("surface_deviation_closed_part");
    g.sample_size(10);
    g.bench_function("reference", |b| b.iter(|| surface_deviation_reference(&field, &index, &o, &all)));
    g.bench_function("closed_part", |b| b.iter(|| surface_deviation_opt(&field, &index, &o)));
    g.finish();
}

/// The simulator and the field fed `ms`, the field on its own thread with `own_thread`;
/// the field.
fn beside_simulator(ms: &[Motion<'_>], own_thread: bool) -> HeightField {
    let ball = Cutter::ball(5.0, 30.0);
    let stock = Aabb::new(Point3::new(-6.0, -6.0, -6.0), Point3::new(30.0, 30.0, 12.0));
    let spec = GridSpec::new(&stock, [144, 144, 72]).expect("grid");
    let mut sim = Simulator::new(VoxelGrid::full(spec), ToolTable::single(ball), SimOptions::default())
        .expect("simulator");
    let o = HeightFieldOptions { spacing: 0.05, pass_width: Some(0.45), ..Default::default() };
    let mut f = HeightField::new_opt([-6.0, -6.0], [30.0, 30.0], ToolTable::single(ball), &o).expect("field");
    if own_thread {
        f.set_parallel_columns(usize::MAX);
        let mut fed = SinkThread::spawn(f, 1024, 8);
        for m in ms {
            let Ok(()) = fed.motion(m);
            sim.motion(m).expect("motion");
        }
        sim.finish().expect("simulation");
        return fed.join().expect("field");
    }
    for m in ms {
        f.motion(m).expect("motion");
        sim.motion(m).expect("motion");
    }
    sim.finish().expect("simulation");
    f
}

fn feed(c: &mut Criterion) {
    let ms = program();
    let want = beside_simulator(&ms, false);
    assert_eq!(beside_simulator(&ms, true).columns(), want.columns(), "the fields must be the same");
    let mut g = c.benchmark_group("height_field_beside_simulator");
    g.sample_size(10);
    g.bench_function("direct", |b| b.iter(|| beside_simulator(&ms, false)));
    g.bench_function("own_thread", |b| b.iter(|| beside_simulator(&ms, true)));
    g.finish();
}

criterion_group!(benches, bench, deviation, feed);
criterion_main!(benches);
