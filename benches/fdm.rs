//! FDM reconstruction benches (seed 004) on the ISO 527-1A dog-bone sliced at 100 % infill
//! (tests/data/fdm/gcode/prusa_dogbone_iso527_1A_infill100.gcode), each against a baseline
//! in the same run:
//! - `fdm_dogbone/tubes` and `fdm_dogbone/solid`: the whole reconstruction from G-code text,
//!   with Criterion throughput in sweeps (spines), so the per-sweep time reads directly
//!   against the paper's FreeCAD figure, 10.6 s per sweep (Table 2: 62,384 s for the 100 %
//!   dog-bone); a timed run prints both.
//! - `fdm_deposit/*`: the solid's deposition at the same grid: the slice raster (default),
//!   voxsim's additive mode, and a naive per-segment baseline (one bead at a time, one
//!   thread, every voxel of the bead's box tested).
//!
//! Run: `cargo bench --bench fdm`.

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use shape2gcode::{
    BeadShape, Deposition, FdmOptions, FdmOutput, deposit_beads, deposit_beads_naive, extract_beads,
    reconstruct,
};

/// The paper's FreeCAD time per sweep (seed 004, Table 2 / Fig. 6), seconds.
const PAPER_S_PER_SWEEP: f64 = 10.6;

fn dogbone() -> String {
    let p =
        concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/fdm/gcode/prusa_dogbone_iso527_1A_infill100.gcode");
    std::fs::read_to_string(p).expect("dog-bone G-code")
}

fn whole(c: &mut Criterion) {
    let text = dogbone();
    let mut g = c.benchmark_group("fdm_dogbone");
    g.sample_size(10);
    for (name, output) in [("tubes", FdmOutput::Tubes), ("solid", FdmOutput::Solid)] {
        let opts = FdmOptions { profile: BeadShape::Slot, output, ..Default::default() };
        let t = Instant::now();
        let r = reconstruct(&text, &opts).expect("dog-bone reconstructs");
        let s = t.elapsed().as_secs_f64();
        let sweeps = r.report.spines;
        eprintln!(
            "fdm_dogbone/{name}: {sweeps} sweeps, {s:.3} s ({:.2e} s per sweep; paper {PAPER_S_PER_SWEEP} s per \
             sweep, {:.0} s for these sweeps: {:.0}x); stages {:?}",
            s / sweeps as f64,
            PAPER_S_PER_SWEEP * sweeps as f64,
            PAPER_S_PER_SWEEP * sweeps as f64 / s,
            r.report.stage_seconds
        );
        g.throughput(Throughput::Elements(sweeps as u64));
        g.bench_function(name, |b| b.iter(|| black_box(reconstruct(black_box(&text), &opts).expect("ok"))));
    }
    g.finish();
}

fn deposit(c: &mut Criterion) {
    let text = dogbone();
    let opts = FdmOptions { profile: BeadShape::Slot, ..Default::default() };
    let ex = extract_beads(&text, &opts).expect("beads");
    let vs = FdmOptions { deposition: Deposition::Voxsim, ..opts.clone() };
    let mut g = c.benchmark_group("fdm_deposit");
    g.sample_size(10);
    g.throughput(Throughput::Elements(ex.beads.len() as u64));
    g.bench_function("raster", |b| b.iter(|| black_box(deposit_beads(&ex, &opts, 1.0).expect("ok"))));
    g.bench_function("voxsim", |b| b.iter(|| black_box(deposit_beads(&ex, &vs, 1.0).expect("ok"))));
    g.bench_function("naive_baseline", |b| {
        b.iter(|| black_box(deposit_beads_naive(&ex, &opts).expect("ok")))
    });
    g.finish();
}

criterion_group!(benches, whole, deposit);
criterion_main!(benches);
