//! The whole `shape2gcode::mill` pipeline (orientations, actions, toolpaths, G-code text,
//! re-parse, simulation, scoring) on the bundled sample, at a reduced grid so that one
//! iteration takes seconds.
//!
//! - `mill/exact`: our pipeline with the heuristic policy and the exact swept-volume
//!   carver.
//! - `mill/paper_a1` (baseline): the same pipeline with the paper's Monte-Carlo carver
//!   (Algorithm A1, 4 samples per mm of path: far coarser than the density at which A1
//!   agrees with the exact result, so the baseline is flattered).
//! - `mill/learned_exact`: as `s2g mill` runs it, with the shipped learned policy (its 1 mm
//!   spiral on 1/512 layers), against `mill/exact` as the baseline: what the default
//!   policy's finer program costs.
//!
//! Run: `cargo bench --bench mill`. The per-stage split of a full 256^3 run is in the
//! report of `s2g mill --json`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use shape2gcode::geom::load_mesh;
use shape2gcode::voxsim::Carver;
use shape2gcode::{HeuristicPolicy, LearnedPolicy, MillOptions, SetupCount, mill};

const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/stanford_bunny.stl");

fn bench(c: &mut Criterion) {
    let mesh = load_mesh(BUNNY).expect("bundled bunny");
    let base = MillOptions {
        resolution: 64,
        orient_points: 4096,
        setups: SetupCount::Exactly(3),
        metric_samples: 4000,
        ..MillOptions::default()
    };
    let mut group = c.benchmark_group("mill");
    group.sample_size(10);
    for (name, carver) in
        [("exact", Carver::Exact), ("paper_a1", Carver::PaperMonteCarlo { samples_per_unit: 4.0, seed: 0 })]
    {
        let opts = MillOptions { carver, ..base.clone() };
        group.bench_function(name, |b| {
            b.iter(|| {
                let m = mill(&mesh, &mut HeuristicPolicy::default(), &opts, &mut |_| {}).expect("mill");
                black_box(m.metrics.iou)
            })
        });
    }
    let mut learned = LearnedPolicy::bundled().expect("bundled policy");
    group.bench_function("learned_exact", |b| {
        b.iter(|| {
            let m = mill(&mesh, &mut learned, &base, &mut |_| {}).expect("mill");
            black_box(m.metrics.iou)
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
