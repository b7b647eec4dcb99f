//! Bad configurations and misbehaving environments give typed errors, never panics.

use s2g_rl::{Dqn, DqnConfig, Encoder, EpsilonDecay, IdentityEncoder, RlError};

use crate::envs::{Broken, BrokenEnv, Corridor};

/// Builds an agent from `config` and expects an `InvalidConfig` naming `field`.
fn check(name: &str, config: DqnConfig, field: &str) {
    match Dqn::new(config, 3, 2) {
        Err(RlError::InvalidConfig { field: f, .. }) => {
            assert_eq!(f, field, "case {name}: wrong field named")
        }
        other => panic!("case {name}: expected InvalidConfig({field}), got {other:?}"),
    }
}

#[test]
fn bad_configs_are_refused_naming_the_field() {
    let d = DqnConfig::default;
    check("zero batch", DqnConfig { batch_size: 0, ..d() }, "batch_size");
    check("gamma > 1", DqnConfig { gamma: 1.5, ..d() }, "gamma");
    check("gamma < 0", DqnConfig { gamma: -0.1, ..d() }, "gamma");
    check("gamma NaN", DqnConfig { gamma: f32::NAN, ..d() }, "gamma");
    check("zero width", DqnConfig { hidden: vec![8, 0], ..d() }, "hidden");
    check("lr 0", DqnConfig { learning_rate: 0.0, ..d() }, "learning_rate");
    check("lr NaN", DqnConfig { learning_rate: f64::NAN, ..d() }, "learning_rate");
    check("eps > 1", DqnConfig { epsilon_start: 1.5, ..d() }, "epsilon_start");
    check("eps end > start", DqnConfig { epsilon_start: 0.5, epsilon_end: 0.6, ..d() }, "epsilon_end");
    check(
        "exp decay to 0",
        DqnConfig { epsilon_end: 0.0, epsilon_decay: EpsilonDecay::Exponential, ..d() },
        "epsilon_end",
    );
    check("capacity < batch", DqnConfig { replay_capacity: 10, batch_size: 64, ..d() }, "replay_capacity");
    check("train_every 0", DqnConfig { train_every: 0, ..d() }, "train_every");
    check("updates_per_train 0", DqnConfig { updates_per_train: 0, ..d() }, "updates_per_train");
    check("sync 0", DqnConfig { target_sync_every: 0, ..d() }, "target_sync_every");
    check("huber 0", DqnConfig { huber_delta: 0.0, ..d() }, "huber_delta");
    check("huber inf", DqnConfig { huber_delta: f32::INFINITY, ..d() }, "huber_delta");
    check("episode cap 0", DqnConfig { max_episode_steps: 0, ..d() }, "max_episode_steps");
    assert!(DqnConfig::default().validate().is_ok());
}

fn small_config() -> DqnConfig {
    DqnConfig { hidden: vec![8], batch_size: 2, learning_starts: 0, ..DqnConfig::default() }
}

#[test]
fn misbehaving_environments_are_typed_errors() {
    let kinds = [
        Broken::ResetWrongLength,
        Broken::StepWrongLength,
        Broken::NanState,
        Broken::InfiniteState,
        Broken::NanReward,
        Broken::EnvError,
    ];
    for kind in kinds {
        let mut env = BrokenEnv { kind, steps: 0 };
        let mut agent = Dqn::for_env(small_config(), &env).unwrap();
        let r = agent.train(&mut env, 2, |_| {});
        let ok = match kind {
            Broken::ResetWrongLength => {
                matches!(r, Err(RlError::StateDim { expected: 2, got: 3 }))
            }
            Broken::StepWrongLength => {
                matches!(r, Err(RlError::StateDim { expected: 2, got: 1 }))
            }
            Broken::NanState => matches!(r, Err(RlError::NonFiniteState { index: 1, .. })),
            Broken::InfiniteState => matches!(r, Err(RlError::NonFiniteState { index: 0, .. })),
            Broken::NanReward => matches!(r, Err(RlError::NonFiniteReward(_))),
            Broken::EnvError => matches!(r, Err(RlError::Env(_))),
        };
        assert!(ok, "{kind:?}: got {r:?}");
    }
}

#[test]
fn size_mismatches_and_bad_arguments_are_typed_errors() {
    let r = Dqn::new(small_config(), 0, 2);
    assert!(matches!(r, Err(RlError::InvalidArgument(_))), "zero state dim: {r:?}");
    let r = Dqn::new(small_config(), 3, 0);
    assert!(matches!(r, Err(RlError::InvalidArgument(_))), "zero actions: {r:?}");

    let mut agent = Dqn::new(small_config(), 3, 2).unwrap();
    let mut env = Corridor::new(6);
    let r = agent.train(&mut env, 1, |_| {});
    assert!(
        matches!(r, Err(RlError::EnvMismatch { agent_state_dim: 3, env_state_dim: 6, .. })),
        "train on a mismatched env: {r:?}"
    );
    let r = agent.evaluate(&mut env, 1, 0);
    assert!(matches!(r, Err(RlError::EnvMismatch { .. })), "evaluate: {r:?}");

    let r = agent.act(&[0.0; 4], false);
    assert!(matches!(r, Err(RlError::StateDim { expected: 3, got: 4 })), "act: {r:?}");
    let r = agent.q_values(&[0.0, f32::NAN, 0.0]);
    assert!(matches!(r, Err(RlError::NonFiniteState { index: 1, .. })), "q_values: {r:?}");
    let r = agent.act_among(&[0.0; 3], &[true]);
    assert!(matches!(r, Err(RlError::InvalidArgument(_))), "act_among, one flag for two actions: {r:?}");

    let env6 = Corridor::new(6);
    let mut agent6 = Dqn::for_env(small_config(), &env6).unwrap();
    let r = agent6.evaluate(&mut Corridor::new(6), 0, 0);
    assert!(matches!(r, Err(RlError::InvalidArgument(_))), "zero episodes: {r:?}");
    // Nothing has been trained yet, and a zero-episode train call is a no-op.
    let stats = agent6.train(&mut Corridor::new(6), 0, |_| {}).unwrap();
    assert_eq!((stats.episodes, stats.env_steps, stats.updates), (0, 0, 0));
}

/// Acting among a subset of the actions is the greedy choice restricted to it: with every
/// action allowed it is `act`'s, and it never returns an action taken away.
#[test]
fn acting_among_allowed_actions_restricts_the_greedy_choice() {
    let agent = Dqn::new(small_config(), 3, 4).unwrap();
    let states = [[0.3f32, -1.0, 2.0], [1.0, 0.5, -0.25], [-2.0, 0.0, 0.75]];
    for state in states {
        let q = agent.q_values(&state).unwrap();
        let all = agent.act_among(&state, &[true; 4]).unwrap();
        assert_eq!(all, Some(agent.act(&state, false).unwrap()));
        let best = all.unwrap();
        let mut allowed = [true; 4];
        allowed[best] = false;
        let second = agent.act_among(&state, &allowed).unwrap().unwrap();
        assert_ne!(second, best);
        assert!(q.iter().enumerate().filter(|&(i, _)| allowed[i]).all(|(_, &v)| v <= q[second]), "{q:?}");
    }
    assert_eq!(agent.act_among(&states[0], &[false; 4]).unwrap(), None);
}

#[test]
fn identity_encoder_pads_and_truncates_to_its_dim() {
    let enc = IdentityEncoder { dim: 3 };
    assert_eq!(enc.dim(), 3);
    assert_eq!(enc.encode(&[1.0, 2.0]), vec![1.0, 2.0, 0.0]);
    assert_eq!(enc.encode(&[1.0, 2.0, 3.0, 4.0]), vec![1.0, 2.0, 3.0]);
}

#[test]
fn agent_is_send_and_sync() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<Dqn>();
    assert_send_sync::<RlError>();
}
