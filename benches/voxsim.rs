//! Voxel simulator benches (s2g-voxsim), each against a baseline in the same run:
//! - `a1_vs_exact`: the exact carver against the paper's Monte-Carlo Algorithm A1 at the
//!   sampling density where A1 first agrees with the exact residual within 1 % (symmetric
//!   difference / removed voxels). The program is a serpentine facing pass whose ends lie
//!   outside the stock and whose floor lies on voxel faces, so the set A1 samples from is
//!   exactly the flat-end sweep there and the density, not the shape model, decides.
//! - `dexel_vs_exact`: the dexel carver against the exact carver (pocket and finishing).
//! - `throughput_*`: moves/s (Criterion throughput) of the exact and dexel carvers on a
//!   zigzag pocket and a ball-end raster over a bumpy surface, at 256^3 and 1024^3; removed
//!   voxels per second are printed from a timed run. The 1024^3 finishing case is a 4 mm
//!   strip of the raster (0.25 mm stepover), to keep ten samples within minutes.
//!
//! Run: `cargo bench --bench voxsim`.

use std::hint::black_box;
use std::time::Instant;

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use shape2gcode::gcode::{Motion, MotionSink};
use shape2gcode::geom::{Aabb, GridSpec, Point3, VoxelGrid};
use shape2gcode::voxsim::{Carver, Cutter, SimOptions, Simulation, Simulator, ToolTable};

fn p(x: f64, y: f64, z: f64) -> Point3 {
    Point3::new(x, y, z)
}

fn lin(to: Point3) -> Motion<'static> {
    Motion::Linear { to, feed: 1000.0, extrude: None }
}

fn simulate(stock: &VoxelGrid, tool: Cutter, carver: Carver, ms: &[Motion<'_>]) -> Simulation {
    let opts = SimOptions { carver, ..Default::default() };
    let mut s = Simulator::new(stock.clone(), ToolTable::single(tool), opts).expect("valid setup");
    for m in ms {
        s.motion(m).expect("valid motion");
    }
    s.finish().expect("finish");
    s.into_simulation().expect("simulation")
}

/// Symmetric difference of residuals over the exact carver's removed voxels.
fn mismatch(a: &Simulation, exact: &Simulation) -> f64 {
    let mut x = a.residual().clone();
    x.xor(exact.residual()).expect("same grid");
    x.count() as f64 / exact.report().removed_voxels.max(1) as f64
}

/// Stock [0,64]x[0,64]x[0,16] mm at `n` voxels along x.
fn stock(n: usize) -> VoxelGrid {
    VoxelGrid::full(GridSpec::cubic(&Aabb::new(p(0., 0., 0.), p(64., 64., 16.)), n).expect("grid"))
}

/// Serpentine facing: rows 2 R apart, ends outside the stock, tip at z (a voxel face).
fn facing(r: f64, z: f64) -> Vec<Motion<'static>> {
    let mut ms = vec![Motion::Rapid { to: p(-5., r, z) }];
    let mut j = 0;
    loop {
        let y = r + 2.0 * r * j as f64;
        if y + r > 64.0 + 1e-9 {
            break;
        }
        let (a, b) = if j % 2 == 0 { (-5.0, 69.0) } else { (69.0, -5.0) };
        ms.push(lin(p(a, y, z)));
        ms.push(lin(p(b, y, z)));
        j += 1;
    }
    ms
}

/// Zigzag pocket [4,60]^2, two levels, stepover `step`, short moves (1 mm) along the rows.
fn pocket(step: f64) -> Vec<Motion<'static>> {
    let mut ms = vec![Motion::Rapid { to: p(4., 4., 20.) }];
    for z in [13.0, 10.0] {
        ms.push(Motion::Rapid { to: p(4., 4., 20.) });
        ms.push(lin(p(4., 4., z)));
        let mut y = 4.0;
        let mut fwd = true;
        while y <= 60.0 + 1e-9 {
            for i in 1..=56 {
                let x = if fwd { 4.0 + i as f64 } else { 60.0 - i as f64 };
                ms.push(lin(p(x, y, z)));
            }
            y += step;
            if y <= 60.0 + 1e-9 {
                ms.push(lin(p(if fwd { 60.0 } else { 4.0 }, y, z)));
            }
            fwd = !fwd;
        }
    }
    ms
}

/// Ball-end raster over a bumpy surface: 0.1 mm segments, stepover `step`, rows up to `y_max`.
fn finishing(step: f64, y_max: f64) -> Vec<Motion<'static>> {
    let surf =
        |x: f64, y: f64| 10.0 + 2.0 * (0.25 * x).sin() * (0.2 * y).cos() + 0.5 * (0.9 * x + 0.4 * y).sin();
    let mut ms = vec![Motion::Rapid { to: p(2., 2., 20.) }];
    let mut y = 2.0;
    let mut fwd = true;
    while y <= y_max {
        for i in 0..=600 {
            let x = if fwd { 2.0 + 0.1 * i as f64 } else { 62.0 - 0.1 * i as f64 };
            ms.push(lin(p(x, y, surf(x, y))));
        }
        y += step;
        fwd = !fwd;
    }
    ms
}

fn a1_vs_exact(c: &mut Criterion) {
    let n = 256;
    let grid = stock(n);
    let (r, z) = (2.0, 12.0); // z = 48 voxels of 0.25 mm: a voxel face.
    let tool = Cutter::flat(r, 2.0 * r);
    let prog = facing(r, z);
    let exact = simulate(&grid, tool, Carver::Exact, &prog);
    let mut density = 1.0;
    let mut found = None;
    while density <= 1.0e6 {
        let a1 = simulate(&grid, tool, Carver::PaperMonteCarlo { samples_per_unit: density, seed: 1 }, &prog);
        let m = mismatch(&a1, &exact);
        println!("A1 density {density:>9} samples/mm: mismatch {:.4} %", 100.0 * m);
        if m <= 0.01 {
            found = Some(density);
            break;
        }
        density *= 2.0;
    }
    let density = found.expect("A1 reaches 1 % agreement");
    let t0 = Instant::now();
    let _ = simulate(&grid, tool, Carver::Exact, &prog);
    let te = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let _ = simulate(&grid, tool, Carver::PaperMonteCarlo { samples_per_unit: density, seed: 1 }, &prog);
    let ta = t0.elapsed().as_secs_f64();
    println!(
        "A1 first agrees within 1 % at {density} samples/mm; one run: exact {:.4} s, A1 {:.4} s, ratio {:.0}x",
        te,
        ta,
        ta / te
    );
    let mut g = c.benchmark_group("a1_vs_exact_256");
    g.sample_size(10);
    g.bench_function("exact", |b| b.iter(|| black_box(simulate(&grid, tool, Carver::Exact, &prog))));
    g.bench_function(format!("paper_a1_{density}_per_mm"), |b| {
        b.iter(|| {
            black_box(simulate(
                &grid,
                tool,
                Carver::PaperMonteCarlo { samples_per_unit: density, seed: 1 },
                &prog,
            ))
        })
    });
    g.finish();
}

fn throughput(c: &mut Criterion) {
    for n in [256usize, 1024] {
        let grid = stock(n);
        let cases = [
            ("pocket", Cutter::flat(1.5, 10.0), pocket(2.0)),
            // At 1024^3 a 4 mm strip keeps ten samples within minutes.
            (
                "finishing",
                Cutter::ball(1.0, 10.0),
                if n == 256 { finishing(0.5, 62.0) } else { finishing(0.25, 6.0) },
            ),
        ];
        for (name, tool, prog) in cases {
            let mut g = c.benchmark_group(format!("throughput_{name}_{n}"));
            g.sample_size(10);
            g.throughput(Throughput::Elements(prog.len() as u64));
            for (cname, carver) in [("exact", Carver::Exact), ("dexel", Carver::Dexel)] {
                let t0 = Instant::now();
                let s = simulate(&grid, tool, carver, &prog);
                let t = t0.elapsed().as_secs_f64();
                println!(
                    "{name} {n}^3 {cname}: {} moves, {} removed voxels in {:.3} s: {:.3e} voxels/s, {:.3e} moves/s",
                    prog.len(),
                    s.report().removed_voxels,
                    t,
                    s.report().removed_voxels as f64 / t,
                    prog.len() as f64 / t
                );
                g.bench_function(cname, |b| {
                    b.iter_batched(
                        || (),
                        |_| black_box(simulate(&grid, tool, carver, &prog)),
                        BatchSize::PerIteration,
                    )
                });
            }
            g.finish();
        }
    }
}

criterion_group!(benches, a1_vs_exact, throughput);
criterion_main!(benches);
