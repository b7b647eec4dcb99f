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

/// A cheap environment: the 10 mm FDM cube in the shop preset (tools of 0.5-6 mm, layers of
/// 0.25-2 mm) in a 16 mm block, two setups, zigzag only (20 actions), a 24³ grid.
fn cheap() -> (Vec<(String, shape2gcode::geom::Mesh)>, MillOptions) {
    let cube = load_mesh(data("fdm/models/cube10.stl")).expect("cube10");
    let opts = MillOptions {
        preset: Preset::Shop,
        resolution: 24,
        orient_points: 512,
        orient_candidates: 32,
        setups: SetupCount::Exactly(2),
        strategies: vec![shape2gcode::StrategyKind::Zigzag],
        metric_samples: 500,
        // 3 mm of stock around the part: material for the tools to remove.
        stock_margin: 0.3,
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
    let path = dir.path().join("p.s2gp");
    policy.save(&path).unwrap();
    let mut loaded = LearnedPolicy::load(&path).unwrap();
    assert_eq!(loaded.info(), policy.info());
    let a = mill(&parts[0].1, &mut policy, &opts, &mut |_| {}).unwrap();
    let b = mill(&parts[0].1, &mut loaded, &opts, &mut |_| {}).unwrap();
    assert_eq!(a.programs, b.programs, "the loaded policy chooses what the saved one did");
    assert_eq!(a.policy, "learned");
    // By path through the policy names, too.
    let space = shape2gcode::ActionSpace::shop();
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
