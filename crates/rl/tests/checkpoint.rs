//! Save, load, and the errors of bad checkpoint files.

use s2g_rl::{Dqn, DqnConfig, RlError};

use crate::envs::{Corridor, one_hot};
use crate::learning::corridor_config;

fn trained_agent() -> (Dqn, Corridor) {
    let mut env = Corridor::new(6);
    let mut agent = Dqn::for_env(corridor_config(9), &env).unwrap();
    agent.train(&mut env, 40, |_| {}).unwrap();
    assert!(agent.updates() > 0);
    (agent, env)
}

fn all_q(agent: &Dqn) -> Vec<Vec<f32>> {
    (0..6).map(|s| agent.q_values(&one_hot(s, 6)).unwrap()).collect()
}

/// The same training gives the same checkpoint bytes (Burn's random parameter ids are not
/// written), and another seed other bytes.
#[test]
fn the_same_training_gives_the_same_checkpoint_bytes() {
    let (a, _) = trained_agent();
    let (b, env) = trained_agent();
    assert_eq!(a.to_bytes().unwrap(), b.to_bytes().unwrap());
    let other = Dqn::for_env(corridor_config(10), &env).unwrap();
    assert_ne!(a.to_bytes().unwrap(), other.to_bytes().unwrap());
}

#[test]
fn round_trip_gives_bit_identical_q_values_and_keeps_training() {
    let (agent, mut env) = trained_agent();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("agent.dqn");
    agent.save(&path).unwrap();
    // Saving twice replaces the file; the atomic write leaves no temporary behind.
    agent.save(&path).unwrap();
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names, vec![std::ffi::OsString::from("agent.dqn")]);

    let mut loaded = Dqn::load(&path, corridor_config(9)).unwrap();
    assert_eq!((loaded.state_dim(), loaded.num_actions()), (6, 2));
    let before = all_q(&agent);
    assert_eq!(all_q(&loaded), before, "loaded network differs");
    // A fresh agent with the same seed is untrained: the round trip carried the weights.
    let fresh = Dqn::for_env(corridor_config(9), &env).unwrap();
    assert_ne!(all_q(&fresh), before);

    // The loaded network is still trainable (its parameters kept their gradients).
    let stats = loaded.train(&mut env, 30, |_| {}).unwrap();
    assert!(stats.updates > 0);
    assert_ne!(all_q(&loaded), before, "training the loaded agent changed nothing");
}

#[test]
fn bad_checkpoints_are_typed_errors() {
    let (agent, _) = trained_agent();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("agent.dqn");
    agent.save(&path).unwrap();

    let other_shape = DqnConfig { hidden: vec![16], ..corridor_config(9) };
    assert!(
        matches!(Dqn::load(&path, other_shape), Err(RlError::Checkpoint { .. })),
        "loading into other hidden widths"
    );

    let bytes = std::fs::read(&path).unwrap();
    // The header is magic (8), version (4), state dim, actions, layer count, two widths and
    // the payload length (8 each): the payload starts at byte 60.
    let mut other_dim = bytes.clone();
    other_dim[12] = 7; // state dim 6 -> 7: Burn's record no longer fits the network.
    let mut garbled = bytes.clone();
    for b in &mut garbled[60..80] {
        *b ^= 0xA5; // the burnpack header of the payload
    }
    let cases: [(&str, Vec<u8>); 6] = [
        ("truncated", bytes[..bytes.len() - 10].to_vec()),
        ("bad magic", [b"NOTADQN!".as_slice(), &bytes[8..]].concat()),
        ("trailing bytes", [bytes.as_slice(), &[0u8; 3]].concat()),
        ("empty", Vec::new()),
        ("state dim changed", other_dim),
        ("garbled payload", garbled),
    ];
    for (name, data) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, data).unwrap();
        let r = Dqn::load(&p, corridor_config(9));
        assert!(matches!(r, Err(RlError::Checkpoint { .. })), "{name}: got {r:?}");
    }
    let r = Dqn::load(dir.path().join("missing"), corridor_config(9));
    assert!(matches!(r, Err(RlError::Io { .. })), "missing file: {r:?}");
}
