//! Action selection (seed 000 Table A1: 0.03 ms per decision), on the state of the bundled
//! bunny's first setup:
//!
//! - `policy/learned_greedy`: the shipped policy's decision as `s2g mill` makes it
//!   ([`LearnedPolicy::bundled`]): the geometric state of the setup, then a greedy
//!   Q-network forward pass (the paper's network, two hidden layers of 128, on the Burn
//!   Flex backend).
//! - `policy/dgcnn_greedy`: the same decision with the DGCNN encoder's state (the default
//!   DGCNN, k = 20, EdgeConv 64-64-128-256, 1024 features, on the setup's 1,024 surface
//!   points) and a Q-network of the same shape on it (seeded initial weights: a trained one
//!   costs the same).
//! - `policy/heuristic` (baseline): the geometric heuristic's decision on the same setup.
//!
//! Run: `cargo bench --bench policy`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use shape2gcode::geom::load_mesh;
use shape2gcode::rl::{DgcnnConfig, Dqn, DqnConfig, Encoder};
use shape2gcode::{
    EncoderKind, HeuristicPolicy, LearnedPolicy, MillOptions, MillRun, Policy, SetupCount, SetupEncoder,
    observation,
};

const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/stanford_bunny.stl");

fn bench(c: &mut Criterion) {
    let mesh = load_mesh(BUNNY).expect("bundled bunny");
    let opts = MillOptions {
        resolution: 48,
        orient_points: 2048,
        orient_candidates: 128,
        setups: SetupCount::Exactly(3),
        ..MillOptions::default()
    };
    let run = MillRun::new(&mesh, &opts, &mut |_| {}).expect("mill run");
    let features = run.features();
    let ctx = run.context(&features);
    let mut g = c.benchmark_group("policy");
    let mut learned = LearnedPolicy::bundled().expect("the shipped policy");
    g.bench_function("learned_greedy", |b| b.iter(|| black_box(learned.choose(black_box(&ctx)))));
    let mut heuristic = HeuristicPolicy::default();
    g.bench_function("heuristic", |b| b.iter(|| black_box(heuristic.choose(black_box(&ctx)))));
    let dgcnn = SetupEncoder::new(&EncoderKind::Dgcnn(DgcnnConfig::default()), run.space().radii.len())
        .expect("DGCNN");
    let agent = Dqn::new(DqnConfig::default(), dgcnn.dim() + 2, run.space().len()).expect("agent");
    g.sample_size(10);
    g.bench_function("dgcnn_greedy", |b| {
        b.iter(|| {
            let s = observation(&dgcnn, black_box(&ctx));
            black_box(agent.act(&s, false).expect("act"))
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
