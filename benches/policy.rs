//! Action selection (seed 000 Table A1: 0.03 ms per decision), on the state of the bundled
//! bunny's first setup:
//!
//! - `policy/learned_greedy`: the DQN policy's decision as `s2g mill --policy` makes it:
//!   the geometric state of the setup, then a greedy Q-network forward pass (the paper's
//!   network, two hidden layers of 128, on the Burn Flex backend). The weights are the
//!   seeded initial ones: a trained network of the same shape costs the same.
//! - `policy/heuristic` (baseline): the geometric heuristic's decision on the same setup.
//!
//! Run: `cargo bench --bench policy`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use shape2gcode::geom::load_mesh;
use shape2gcode::rl::{Dqn, DqnConfig};
use shape2gcode::{GeometricEncoder, HeuristicPolicy, MillOptions, MillRun, Policy, SetupCount, observation};

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
    let encoder = GeometricEncoder { radii: run.space().radii.len() };
    let state_dim = observation(&encoder, &ctx).len();
    let agent = Dqn::new(DqnConfig::default(), state_dim, run.space().len()).expect("agent");
    let mut g = c.benchmark_group("policy");
    g.bench_function("learned_greedy", |b| {
        b.iter(|| {
            let s = observation(&encoder, black_box(&ctx));
            black_box(agent.act(&s, false).expect("act"))
        })
    });
    let mut heuristic = HeuristicPolicy::default();
    g.bench_function("heuristic", |b| b.iter(|| black_box(heuristic.choose(black_box(&ctx)))));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
