//! The machining environment and the learned policy (seed 000 §3.4-3.5): rewards that
//! agree with the pipeline's, reproducible episodes, training, and policy files.

use shape2gcode::geom::load_mesh;
use shape2gcode::rl::{DqnConfig, Environment};
use shape2gcode::voxsim::RewardWeights;
use shape2gcode::{
    LearnedPolicy, MachiningEnv, MillOptions, Policy, Preset, SetupCount, TrainOptions, mill, policy_by_name,
    train_policy,
};

use super::common::data;

/// A cheap environment: the 10 mm FDM cube in the shop preset (the shipped library's flat
/// end mills of 1, 2, 3, 6 and 12 mm, layers of 0.25-2 mm) in a 16 mm block, two setups,
/// zigzag only (20 actions), a 24³ grid.
fn cheap() -> (Vec<(String, shape2gcode::geom::Mesh)>, MillOptions) {
    let cube = load_mesh(data("fdm/models/cube10.stl")).expect("cube10");
    let mut tools = shape2gcode::default_tool_library().clone();
    tools.tools.retain(|t| [1.0, 2.0, 3.0, 6.0, 12.0].contains(&t.cutter.diameter()));
    let opts = MillOptions {
        tools: Some(tools),
        preset: Preset::Shop,
        resolution: 24,
        orient_points: 512,
        orient_candidates: 32,
        setups: SetupCount::Exactly(2),
        strategies: vec![shape2gcode::StrategyKind::ZIGZAG],
        metric_samples: 500,
        // 3 mm of stock around the part: material for the tools to remove.
        stock_margin: 0.3,
        // An episode is the setups the policy chooses for; the rest roughing `mill` adds
        // after them is no step of it, so the pipeline is compared without it.
        rest_roughing: 0,
        ..MillOptions::default()
    };
    (vec![("cube10".into(), cube)], opts)
}

#[test]
fn episode_returns_are_eq13_of_the_pipeline_and_reproducible() {
    let (parts, opts) = cheap();
    let w = RewardWeights::default();
    let mut env = MachiningEnv::new(parts.clone(), opts.clone(), w).unwrap();
    assert_eq!(env.num_actions(), 5 * 4, "5 radii x 4 layer heights x zigzag");
    for actions in [[0usize, 19], [19, 0], [19, 5], [7, 7]] {
        let s0 = env.reset(0).unwrap();
        assert_eq!(s0.len(), env.state_dim());
        assert!(s0.iter().all(|v| v.is_finite()));
        let mut total = 0.0f64;
        let mut steps = Vec::new();
        for (i, &a) in actions.iter().enumerate() {
            let step = env.step(a).unwrap();
            assert_eq!(step.done, i == 1, "two setups, two steps");
            assert_eq!(step.state.len(), env.state_dim());
            total += f64::from(step.reward);
            steps.push(step);
        }
        // The same actions again (from the cache) and a fresh environment agree.
        let mut fresh = MachiningEnv::new(parts.clone(), opts.clone(), w).unwrap();
        for env in [&mut env, &mut fresh] {
            env.reset(0).unwrap();
            for (&a, step) in actions.iter().zip(&steps) {
                assert_eq!(&env.step(a).unwrap(), step, "actions {actions:?}");
            }
        }
        // The pipeline mills the same setups with the same actions: Eq. 13 from its
        // per-setup preservation, final IoU and removal rate is the episode's return.
        let space = env.space().clone();
        let mut policy =
            Replay { actions: actions.iter().map(|&a| space.action(a).unwrap()).collect(), k: 0 };
        let milled = mill(&parts[0].1, &mut policy, &opts, &mut |_| {}).unwrap();
        let expected = milled.total_reward(&w);
        assert!(
            (total - expected).abs() <= 1e-5 * expected.abs().max(1.0),
            "actions {actions:?}: environment return {total} vs pipeline {expected}"
        );
        assert!(total > 2.0, "two setups of R_s near 1 plus R_f: {total}");
    }
    // Coarse and fine differ: the removal rate term sees the machining time.
    let ret = |a: usize, env: &mut MachiningEnv| {
        env.reset(0).unwrap();
        env.step(a).unwrap().reward + env.step(a).unwrap().reward
    };
    assert_ne!(ret(0, &mut env), ret(19, &mut env));
    // An action outside the space is an error, not a panic.
    env.reset(0).unwrap();
    assert!(env.step(20).is_err());
}

#[test]
fn telescoped_rewards_charge_a_slow_tool_to_its_step_and_sum_to_eq13() {
    use shape2gcode::RewardShaping;
    let (parts, opts) = cheap();
    let w = RewardWeights::default();
    let mut terminal = MachiningEnv::new(parts.clone(), opts.clone(), w).unwrap();
    let mut telescoped = MachiningEnv::new(parts, opts, w).unwrap();
    telescoped.set_shaping(RewardShaping::Telescoped);
    let rewards = |env: &mut MachiningEnv, actions: [usize; 2]| -> Vec<f64> {
        env.reset(0).unwrap();
        actions.iter().map(|&a| f64::from(env.step(a).unwrap().reward)).collect()
    };
    // The first step's removal rate: what telescoping adds to that step, over lambda_MRR.
    let mut first_rate = Vec::new();
    for actions in [[0usize, 19], [19, 0], [19, 19], [0, 0]] {
        let (a, b) = (rewards(&mut terminal, actions), rewards(&mut telescoped, actions));
        let (sa, sb): (f64, f64) = (a.iter().sum(), b.iter().sum());
        assert!((sa - sb).abs() <= 1e-5 * sa.abs(), "{actions:?}: returns {sa} and {sb} differ");
        let rate = (b[0] - a[0]) / w.lambda_mrr;
        assert!(rate > 0.0, "{actions:?}: the first setup removed material at {rate} cm3/min");
        // The last step is paid the change of the rate, not the rate.
        assert!((b[1] - a[1] + w.lambda_mrr * rate).abs() <= 1e-5, "{actions:?}: {a:?} {b:?}");
        first_rate.push(rate);
    }
    // The same first action, the same first reward whatever follows (the cache's path and
    // the simulated one agree).
    assert!((first_rate[0] - first_rate[3]).abs() <= 1e-6 && (first_rate[1] - first_rate[2]).abs() <= 1e-6);
    // The finest tool on the thinnest layers removes far more slowly than the coarsest: its
    // step, not only the last, is paid less for it.
    assert!(first_rate[0] < 0.75 * first_rate[1], "fine {} vs coarse {}", first_rate[0], first_rate[1]);
}

/// A step that once ran out of memory in training (seed 2's 86th episode): a generated
/// turned part whose third setup stands 0.3 degrees off its axis, so that the needle-thin
/// projections of its wall facets made the keep-outs' running union grow by a slab's
/// vertices per level (200,000 vertices, then offsets that took 24 GB). With the union's
/// vertices bounded it mills as any other part.
#[test]
fn a_turned_part_on_a_slightly_tilted_setup_mills_in_bounded_memory() {
    use s2g_gen::{GenOptions, Kind, generate};
    let part = generate(37, 167, &GenOptions { kind: Kind::Mix, size: 100.0 }).unwrap();
    assert_eq!(part.name, "turned_00167");
    let opts = MillOptions {
        resolution: 64,
        paper_space_scale: shape2gcode::ActionSpace::paper_space_scale(64),
        orient_points: 2048,
        orient_candidates: 128,
        setups: SetupCount::Exactly(3),
        flank_walls: false,
        seed: 2,
        metric_samples: 2000,
        layout: shape2gcode::ProgramLayout::PerSetup,
        ..MillOptions::default()
    };
    let space = opts.action_space();
    let actions = [22, 25, 43].map(|a| space.action(a).unwrap());
    // The third: the coarsest tool's periphery clearing.
    assert_eq!(actions[2].tool_radius, *space.radii.last().unwrap());
    let mut policy = Replay { actions: actions.to_vec(), k: 0 };
    let milled = mill(&part.mesh, &mut policy, &opts, &mut |_| {}).unwrap();
    let axis = milled.setups[2].setup.tool_axis();
    let off = axis.z.abs().acos().to_degrees();
    assert!(off > 0.05 && off < 1.0, "the third setup stands {off} degrees off the part's axis");
    assert!(milled.metrics.iou > 0.9, "IoU {}", milled.metrics.iou);
    assert_eq!(milled.simulation.gouge_voxels, 0);
}

/// Plays back a list of actions.
struct Replay {
    actions: Vec<shape2gcode::Action>,
    k: usize,
}

impl Policy for Replay {
    fn choose(&mut self, _: &shape2gcode::SetupContext<'_>) -> shape2gcode::Action {
        let a = self.actions[self.k];
        self.k += 1;
        a
    }
    fn name(&self) -> String {
        "replay".into()
    }
}

/// Saves `policy` as `file` in `dir`, loads it back, and mills the first part with both:
/// the file holds the policy (the same description, the same programs). Returns the file's
/// path and the saved policy's run.
fn assert_saved_policy_mills_alike(
    policy: &mut LearnedPolicy,
    parts: &[(String, shape2gcode::geom::Mesh)],
    opts: &MillOptions,
    dir: &std::path::Path,
    file: &str,
) -> (std::path::PathBuf, shape2gcode::Milled) {
    let path = dir.join(file);
    policy.save(&path).unwrap();
    let mut loaded = LearnedPolicy::load(&path).unwrap();
    assert_eq!(loaded.info(), policy.info());
    let a = mill(&parts[0].1, policy, opts, &mut |_| {}).unwrap();
    let b = mill(&parts[0].1, &mut loaded, opts, &mut |_| {}).unwrap();
    assert_eq!(a.programs, b.programs, "the loaded policy chooses what the saved one did");
    (path, a)
}

#[test]
fn a_trained_policy_saves_loads_and_mills_like_itself() {
    let (parts, opts) = cheap();
    let train = TrainOptions {
        episodes: 6,
        seed: 3,
        mill: opts.clone(),
        dqn: DqnConfig { hidden: vec![16], learning_starts: 4, batch_size: 4, ..TrainOptions::default().dqn },
        ..TrainOptions::default()
    };
    let mut returns = Vec::new();
    let mut policy = train_policy(&parts, &train, &mut |e| returns.push(e.total_reward)).unwrap();
    assert_eq!(returns.len(), 6);
    assert!(returns.iter().all(|r| r.is_finite() && *r > 0.0), "{returns:?}");
    assert_eq!(policy.info().trained_on, vec!["cube10".to_string()]);

    let dir = tempfile::tempdir().unwrap();
    let (path, a) = assert_saved_policy_mills_alike(&mut policy, &parts, &opts, dir.path(), "p.s2gp");
    assert_eq!(a.policy, "learned");
    // By path through the policy names, too.
    let space = opts.action_space();
    let mut by_name = policy_by_name(path.to_str().unwrap(), &space, 0).expect("a policy file by path");
    let c = mill(&parts[0].1, by_name.as_mut(), &opts, &mut |_| {}).unwrap();
    assert_eq!(c.programs, a.programs);

    // Fine-tuning runs its episodes on the one part and keeps the policy usable.
    let r = policy.finetune(&parts[0].1, "cube10", 2, &train, &mut |_| {}).unwrap();
    assert_eq!(r.len(), 2);
    assert_eq!(policy.info().episodes, 8);

    // Not a policy: a typed error each.
    let junk = dir.path().join("junk.s2gp");
    std::fs::write(&junk, b"S2GPOLICY\n{\"encoder\": 3}\n").unwrap();
    assert!(LearnedPolicy::load(&junk).is_err());
    std::fs::write(&junk, b"hello").unwrap();
    assert!(LearnedPolicy::load(&junk).is_err());
    let mut truncated = std::fs::read(&path).unwrap();
    truncated.truncate(truncated.len() - 10);
    std::fs::write(&junk, &truncated).unwrap();
    assert!(LearnedPolicy::load(&junk).is_err());
    assert!(LearnedPolicy::load(&dir.path().join("missing")).is_err());
    assert!(policy_by_name("no-such-policy", &space, 0).is_none());
}

/// The DGCNN encoder plugs into the same environment and policy files: its states are the
/// DGCNN's features of the setup's surface points (plus the progress), a policy trained on
/// them saves its encoder's shape, and the loaded policy mills as the saved one did.
#[test]
fn a_dgcnn_policy_trains_saves_and_loads() {
    use shape2gcode::rl::DgcnnConfig;
    use shape2gcode::{EncoderKind, MachiningEnv};
    let (parts, opts) = cheap();
    let config =
        DgcnnConfig { k: 8, edge_widths: vec![16, 16], embedding: 32, seed: 5, ..DgcnnConfig::default() };
    let encoder = EncoderKind::Dgcnn(config);
    let mut env =
        MachiningEnv::with_encoder(parts.clone(), opts.clone(), RewardWeights::default(), &encoder).unwrap();
    assert_eq!(env.state_dim(), 2 * 32 + 2, "max and mean pooling of 32, then the progress");
    let s = env.reset(0).unwrap();
    assert!(s.iter().all(|v| v.is_finite()) && s[..64].iter().any(|&v| v != 0.0), "{s:?}");

    let train = TrainOptions {
        episodes: 3,
        seed: 1,
        mill: opts.clone(),
        dqn: DqnConfig { hidden: vec![8], learning_starts: 2, batch_size: 2, ..TrainOptions::default().dqn },
        encoder,
        ..TrainOptions::default()
    };
    let mut policy = train_policy(&parts, &train, &mut |_| {}).unwrap();
    assert_eq!(policy.info().encoder, "dgcnn");
    assert_eq!(policy.info().dgcnn.as_ref().map(|d| d.embedding), Some(32));
    let dir = tempfile::tempdir().unwrap();
    assert_saved_policy_mills_alike(&mut policy, &parts, &opts, dir.path(), "dgcnn.s2gp");
}

/// The geometric encoder with the reach at the grid's resolution: twice the reach
/// features (exact, then at the grid's resolution, each relative to the smallest tool), a
/// policy file that names it (and its double-DQN training), and a loaded policy that mills
/// as the saved one did.
#[test]
fn a_policy_on_the_reach_at_resolution_saves_and_loads() {
    use shape2gcode::rl::Encoder;
    use shape2gcode::{EncoderKind, MachiningEnv, SetupEncoder, SetupFeatures};
    let (parts, opts) = cheap();
    let radii = opts.action_space().radii.len();
    let (plain, res) = (
        SetupEncoder::new(&EncoderKind::Geometric, radii).unwrap(),
        SetupEncoder::new(&EncoderKind::GeometricAtResolution, radii).unwrap(),
    );
    assert_eq!(res.dim(), plain.dim() + radii);
    let f = SetupFeatures {
        reach_by_radius: (0..radii).map(|i| 0.8 - 0.1 * i as f64).collect(),
        reach_at_resolution: (0..radii).map(|i| 0.5 / (1 + i) as f64).collect(),
        visible_fraction: 0.7,
        ..SetupFeatures::default()
    };
    let (a, b) = (plain.encode(&f), res.encode(&f));
    assert_eq!(a[..radii], b[..radii], "the exact reach comes first in both");
    let relative: Vec<f32> = (0..radii).map(|i| (1.0 / (1 + i) as f64) as f32).collect();
    assert_eq!(b[radii..2 * radii], relative[..], "then the reach at the resolution, relative to the first");
    assert_eq!(a[radii..], b[2 * radii..], "then the same visible fraction and depth histogram");

    let encoder = EncoderKind::GeometricAtResolution;
    let env =
        MachiningEnv::with_encoder(parts.clone(), opts.clone(), RewardWeights::default(), &encoder).unwrap();
    assert_eq!(env.state_dim(), res.dim() + 2);
    let train = TrainOptions {
        episodes: 2,
        seed: 2,
        mill: opts.clone(),
        dqn: DqnConfig {
            hidden: vec![8],
            learning_starts: 2,
            batch_size: 2,
            double: true,
            ..TrainOptions::default().dqn
        },
        encoder,
        ..TrainOptions::default()
    };
    let mut policy = train_policy(&parts, &train, &mut |_| {}).unwrap();
    assert_eq!(policy.info().encoder, "geometric-res");
    assert!(policy.info().double, "the file says its targets were double-DQN ones");
    let dir = tempfile::tempdir().unwrap();
    assert_saved_policy_mills_alike(&mut policy, &parts, &opts, dir.path(), "res.s2gp");
}

/// The policy shipped in the crate loads, speaks the paper's action space, and was trained
/// only on the training split, never on a part of the evaluation split
/// (`assets/policy/README.md`).
#[test]
fn the_bundled_policy_is_trained_on_the_training_split_only() {
    let policy = LearnedPolicy::bundled().expect("assets/policy/learned.s2gp");
    let info = policy.info();
    let space = shape2gcode::ActionSpace::paper();
    assert_eq!(info.radii, space.radii);
    assert_eq!(info.layer_heights, space.layer_heights);
    assert_eq!(info.strategies, ["zigzag", "periphery", "spiral"]);
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/policy/README.md")).unwrap();
    let listed = |heading: &str| -> Vec<String> {
        let section = readme.split(heading).nth(1).unwrap_or_else(|| panic!("README lacks {heading:?}"));
        section
            .lines()
            .skip(1)
            .take_while(|l| !l.starts_with('#'))
            .filter_map(|l| l.strip_prefix("- `").and_then(|l| l.split('`').next()))
            .map(str::to_owned)
            .collect()
    };
    let (train, eval) = (listed("## Training split"), listed("## Evaluation split"));
    assert!(!train.is_empty() && !eval.is_empty(), "{train:?} / {eval:?}");
    assert_eq!(info.trained_on, train, "the policy names the training split's parts");
    for part in &info.trained_on {
        assert!(!eval.contains(part), "{part} is in both splits");
    }
    assert!(info.episodes > 0);
}

/// Outside the action space it was trained on (the shop preset's tools), the bundled
/// policy lets the heuristic choose, choosing what the heuristic does, and its report says
/// so; in the paper's space it chooses itself.
#[test]
fn the_bundled_policy_names_the_heuristic_when_it_chooses_for_it() {
    let (parts, opts) = cheap();
    let mut learned = LearnedPolicy::bundled().unwrap();
    let mut heuristic = policy_by_name("heuristic", &opts.action_space(), 0).unwrap();
    let a = mill(&parts[0].1, &mut learned, &opts, &mut |_| {}).unwrap();
    let b = mill(&parts[0].1, &mut *heuristic, &opts, &mut |_| {}).unwrap();
    assert_eq!(a.policy, "learned (heuristic)");
    assert_eq!(b.policy, "heuristic");
    let actions = |m: &shape2gcode::Milled| m.setups.iter().map(|p| p.action).collect::<Vec<_>>();
    assert_eq!(actions(&a), actions(&b));
    let paper = MillOptions {
        preset: Preset::Paper,
        strategies: shape2gcode::StrategyKind::all(),
        tools: None,
        ..opts
    };
    let mut learned = LearnedPolicy::bundled().unwrap();
    let c = mill(&parts[0].1, &mut learned, &paper, &mut |_| {}).unwrap();
    assert_eq!(c.policy, "learned");
}

/// Table 4 ablates the learned policy: with a clearing strategy left out the bundled
/// policy still chooses itself (the best of the actions left, not the heuristic), never
/// the strategy left out, and where it never chose that strategy it chooses exactly as with
/// all of them.
#[test]
fn the_bundled_policy_chooses_among_the_strategies_left() {
    use shape2gcode::StrategyKind;
    let (parts, opts) = cheap();
    let paper = MillOptions { preset: Preset::Paper, strategies: StrategyKind::all(), tools: None, ..opts };
    let actions = |m: &shape2gcode::Milled| m.setups.iter().map(|p| p.action).collect::<Vec<_>>();
    let full = mill(&parts[0].1, &mut LearnedPolicy::bundled().unwrap(), &paper, &mut |_| {}).unwrap();
    assert_eq!(full.policy, "learned");
    let used: Vec<StrategyKind> = full.setups.iter().map(|p| p.action.strategy).collect();
    let (mut kept, mut changed) = (0, 0);
    for removed in StrategyKind::all() {
        let left = MillOptions {
            strategies: StrategyKind::all().into_iter().filter(|&s| s != removed).collect(),
            ..paper.clone()
        };
        let m = mill(&parts[0].1, &mut LearnedPolicy::bundled().unwrap(), &left, &mut |_| {}).unwrap();
        assert_eq!(m.policy, "learned", "without {}", removed.name());
        assert!(m.setups.iter().all(|p| p.action.strategy != removed), "without {}", removed.name());
        if used.contains(&removed) {
            changed += 1;
        } else {
            assert_eq!(actions(&m), actions(&full), "without {}, which it never chose", removed.name());
            kept += 1;
        }
    }
    // Both cases happen: two setups choose at most two of the three strategies.
    assert!(kept > 0 && changed > 0, "{used:?}");
}

/// Outcome files: what one environment simulated, another with the same parts and options
/// reads back and steps through identically, under other reward weights too (the file
/// keeps the reward terms, not their sum); other options take none of it; junk is a typed
/// error naming the line.
#[test]
fn outcome_files_replay_what_was_simulated() {
    use shape2gcode::MachiningEnv;
    let (parts, opts) = cheap();
    let w = RewardWeights::default();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("outcomes.jsonl");
    let mut env = MachiningEnv::new(parts.clone(), opts.clone(), w).unwrap();
    assert_eq!(env.load_outcomes(&path).unwrap(), 0, "a missing file is no outcome");
    let sequences = [[0usize, 19], [19, 3], [19, 0]];
    let mut steps = Vec::new();
    for actions in sequences {
        let s0 = env.reset(0).unwrap();
        steps.push((s0, actions.map(|a| env.step(a).unwrap())));
    }
    env.save_outcomes(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    env.save_outcomes(&path).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), bytes, "written in a fixed order");

    let mut again = MachiningEnv::new(parts.clone(), opts.clone(), w).unwrap();
    assert_eq!(again.load_outcomes(&path).unwrap(), 1 + 5, "one first view, five distinct steps");
    // Autosave writes after every AUTOSAVE_EVERY new steps, without a final save.
    let auto = dir.path().join("auto.jsonl");
    let mut saving = MachiningEnv::new(parts.clone(), opts.clone(), w).unwrap();
    saving.autosave(&auto);
    assert_eq!(MachiningEnv::AUTOSAVE_EVERY, 4);
    for actions in &sequences[..2] {
        saving.reset(0).unwrap();
        actions.iter().for_each(|&a| drop(saving.step(a).unwrap()));
    }
    let mut reread = MachiningEnv::new(parts.clone(), opts.clone(), w).unwrap();
    assert_eq!(reread.load_outcomes(&auto).unwrap(), 1 + 4, "written at the fourth new step");
    for (actions, (s0, expected)) in sequences.iter().zip(&steps) {
        assert_eq!(&again.reset(0).unwrap(), s0);
        for (&a, step) in actions.iter().zip(expected) {
            assert_eq!(&again.step(a).unwrap(), step, "{actions:?}");
        }
    }
    // Without R_MRR the last step's reward drops by exactly 0.1 R_MRR, the rest is equal.
    let no_mrr = RewardWeights { lambda_mrr: 0.0, ..w };
    let mut ablated = MachiningEnv::new(parts.clone(), opts.clone(), no_mrr).unwrap();
    ablated.load_outcomes(&path).unwrap();
    ablated.reset(0).unwrap();
    let first = ablated.step(0).unwrap();
    assert_eq!(first, steps[0].1[0], "R_MRR only enters the last step");
    let last = ablated.step(19).unwrap();
    assert!(last.reward < steps[0].1[1].reward && last.done, "{last:?} vs {:?}", steps[0].1[1]);

    let other = MillOptions { resolution: 20, ..opts };
    let mut fresh = MachiningEnv::new(parts, other, w).unwrap();
    assert_eq!(fresh.load_outcomes(&path).unwrap(), 0, "outcomes of other options are not reused");
    let magic = String::from_utf8(bytes).unwrap().lines().next().unwrap().to_owned();
    std::fs::write(&path, format!("{magic}\n{{\"part\": 3}}\n")).unwrap();
    let err = fresh.load_outcomes(&path).unwrap_err().to_string();
    assert!(err.contains("outcomes.jsonl:2"), "{err}");
    std::fs::write(&path, "hello\n").unwrap();
    assert!(fresh.load_outcomes(&path).is_err());
}

/// Training in the grid space (`--space grid`) is a pure function of its seed: two
/// trainings of a generated part at 24³ write the same policy file byte for byte, the file
/// states the scaled space in normalised units, and another seed trains another network.
#[test]
fn training_in_the_grid_space_is_reproducible() {
    use s2g_gen::{GenOptions, Kind, generate};
    let part = generate(37, 1, &GenOptions { kind: Kind::Prismatic, size: 100.0 }).unwrap();
    let parts = vec![(part.name, part.mesh)];
    let scale = shape2gcode::ActionSpace::paper_space_scale(24);
    let train = |seed: u64| {
        let opts = TrainOptions {
            episodes: 4,
            seed,
            mill: MillOptions {
                resolution: 24,
                paper_space_scale: scale,
                orient_points: 512,
                orient_candidates: 32,
                metric_samples: 500,
                setups: SetupCount::Exactly(2),
                ..TrainOptions::default().mill
            },
            dqn: DqnConfig {
                hidden: vec![16],
                learning_starts: 2,
                batch_size: 2,
                ..TrainOptions::default().dqn
            },
            ..TrainOptions::default()
        };
        let policy = train_policy(&parts, &opts, &mut |_| {}).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.s2gp");
        policy.save(&path).unwrap();
        (policy.info().clone(), std::fs::read(&path).unwrap())
    };
    let (info, a) = train(5);
    let (_, b) = train(5);
    assert!(a == b, "the same seed wrote another policy file");
    let (_, c) = train(6);
    assert!(a != c, "another seed trained the same network");
    let space = shape2gcode::ActionSpace::paper_at_resolution(24);
    for (got, want) in
        info.radii.iter().zip(&space.radii).chain(info.layer_heights.iter().zip(&space.layer_heights))
    {
        assert!((got - want).abs() < 1e-12, "{:?} against {space:?}", info);
    }
    assert_eq!(info.resolution, 24);
}
