//! The agent learns the known optimal policy of small environments.

use s2g_rl::{Dqn, DqnConfig, Environment};

use crate::envs::{Bandit, Corridor, one_hot};

/// Mean return of the uniformly random policy over `episodes` seeded episodes, each cut at
/// `cap` steps (as the agent cuts them).
fn random_policy_return(env: &mut impl Environment, episodes: u64, cap: usize) -> f32 {
    // A small LCG is enough for a baseline; the DQN's own generator is private.
    let mut x: u64 = 0x2545_F491_4F6C_DD1D;
    let mut next = move || {
        x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        x >> 33
    };
    let mut sum = 0.0f64;
    for e in 0..episodes {
        env.reset(e).unwrap();
        for _ in 0..cap {
            let a = (next() % env.num_actions() as u64) as usize;
            let step = env.step(a).unwrap();
            sum += f64::from(step.reward);
            if step.done {
                break;
            }
        }
    }
    (sum / episodes as f64) as f32
}

pub fn corridor_config(seed: u64) -> DqnConfig {
    DqnConfig {
        hidden: vec![32, 32],
        learning_rate: 2e-3,
        gamma: 0.95,
        epsilon_decay_steps: 2_000,
        replay_capacity: 5_000,
        batch_size: 32,
        learning_starts: 200,
        target_sync_every: 100,
        max_episode_steps: 20,
        seed,
        ..DqnConfig::default()
    }
}

#[test]
fn corridor_greedy_policy_reaches_the_goal_in_the_minimum_number_of_steps() {
    assert_learns_the_corridor(corridor_config(11));
}

/// Double-DQN targets learn the corridor too (its discount makes them differ from the
/// plain targets, unlike the bandit's).
#[test]
fn double_dqn_learns_the_corridor() {
    assert_learns_the_corridor(DqnConfig { double: true, ..corridor_config(11) });
}

/// Trains on a six-cell corridor for 300 episodes and checks the greedy policy walks
/// straight to the goal from every cell with the optimal return, and beats random.
fn assert_learns_the_corridor(config: DqnConfig) {
    let n = 6;
    let mut env = Corridor::new(n);
    let cap = config.max_episode_steps;
    let mut agent = Dqn::for_env(config, &env).unwrap();
    let stats = agent.train(&mut env, 300, |_| {}).unwrap();
    assert_eq!(stats.episodes, 300);
    assert!(stats.updates > 1_000, "only {} updates", stats.updates);

    for s in 0..n - 1 {
        let q = agent.q_values(&one_hot(s, n)).unwrap();
        assert_eq!(
            agent.act(&one_hot(s, n), false).unwrap(),
            1,
            "greedy action in cell {s} is not 'right' (Q = {q:?})"
        );
        // Roll the greedy policy out from every start cell.
        let mut probe = Corridor::new(n);
        probe.fixed_start = Some(s);
        let mut state = probe.reset(0).unwrap();
        let mut steps = 0;
        let mut ret = 0.0;
        loop {
            let step = probe.step(agent.act(&state, false).unwrap()).unwrap();
            steps += 1;
            ret += step.reward;
            state = step.state;
            if step.done || steps >= cap {
                break;
            }
        }
        assert_eq!(steps, n - 1 - s, "from cell {s}: {steps} steps");
        assert!((ret - probe.optimal_return(s)).abs() < 1e-5, "from cell {s}: return {ret}");
    }

    let trained = agent.evaluate(&mut env, 50, 1).unwrap();
    let random = random_policy_return(&mut env, 2_000, cap);
    assert!(trained > random + 0.5, "greedy mean return {trained} does not beat random {random} by 0.5");
}

#[test]
fn bandit_greedy_policy_picks_each_contexts_best_arm() {
    let mut env = Bandit::default();
    let config = DqnConfig {
        hidden: vec![32],
        learning_rate: 5e-3,
        gamma: 0.0,
        epsilon_decay_steps: 300,
        replay_capacity: 1_000,
        batch_size: 32,
        learning_starts: 64,
        target_sync_every: 50,
        seed: 5,
        ..DqnConfig::default()
    };
    let mut agent = Dqn::for_env(config, &env).unwrap();
    agent.train(&mut env, 600, |_| {}).unwrap();
    for c in 0..Bandit::CONTEXTS {
        let state = one_hot(c, Bandit::CONTEXTS);
        let q = agent.q_values(&state).unwrap();
        assert_eq!(agent.act(&state, false).unwrap(), Bandit::best_arm(c), "context {c}: Q = {q:?}");
        // With gamma = 0 the Q-values estimate the expected reward itself.
        for (arm, &v) in q.iter().enumerate() {
            let want = if arm == Bandit::best_arm(c) { 1.0 } else { 0.0 };
            assert!((v - want).abs() < 0.25, "context {c} arm {arm}: Q {v}, want ~{want}");
        }
    }
    let trained = agent.evaluate(&mut env, 100, 2).unwrap();
    let random = random_policy_return(&mut env, 4_000, 1);
    assert!((trained - 1.0).abs() < 1e-6, "greedy mean return {trained}");
    assert!(random < 0.35, "random baseline {random}");
}

/// Several updates per environment step learn the bandit from a fifth of the steps: the
/// update count is the trained steps times `updates_per_train`, and the greedy policy is
/// still each context's best arm.
#[test]
fn several_updates_per_step_learn_from_fewer_steps() {
    let mut env = Bandit::default();
    let config = DqnConfig {
        hidden: vec![32],
        learning_rate: 5e-3,
        gamma: 0.0,
        epsilon_decay_steps: 60,
        replay_capacity: 1_000,
        batch_size: 32,
        learning_starts: 32,
        target_sync_every: 50,
        updates_per_train: 5,
        seed: 5,
        ..DqnConfig::default()
    };
    let mut agent = Dqn::for_env(config, &env).unwrap();
    let stats = agent.train(&mut env, 120, |_| {}).unwrap();
    assert_eq!(stats.env_steps, 120, "one step per bandit episode");
    assert_eq!(stats.updates, 5 * (120 - 32 + 1), "five updates from step 32 on");
    for c in 0..Bandit::CONTEXTS {
        let state = one_hot(c, Bandit::CONTEXTS);
        assert_eq!(agent.act(&state, false).unwrap(), Bandit::best_arm(c), "context {c}");
    }
}
