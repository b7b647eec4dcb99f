//! The two small traits a problem implements to be learned by this crate.

/// The result of one [`Environment::step`].
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// The state after the action, `Environment::state_dim()` finite values.
    pub state: Vec<f32>,
    /// The reward for the action; must be finite.
    pub reward: f32,
    /// Whether `state` is terminal: the episode ended and no future reward follows it. An
    /// episode cut short only because it ran out of time is *not* terminal; leave `done`
    /// false and let [`DqnConfig::max_episode_steps`](crate::DqnConfig::max_episode_steps)
    /// truncate it.
    pub done: bool,
}

/// An episodic decision problem with a fixed-length state vector and a finite set of
/// actions `0..num_actions()`.
///
/// All four methods are required; they are the whole contract. States are plain `f32`
/// vectors so that an [`Encoder`] (or the environment itself) decides the features.
pub trait Environment {
    /// The environment's own error type, returned by [`reset`](Self::reset) and
    /// [`step`](Self::step) and wrapped in [`RlError::Env`](crate::RlError::Env).
    type Error: std::error::Error + Send + Sync + 'static;

    /// Length of every state vector.
    fn state_dim(&self) -> usize;

    /// Number of discrete actions; valid actions are `0..num_actions()`.
    fn num_actions(&self) -> usize;

    /// Start a new episode and return its first state. `rng_seed` is the seed for any
    /// randomness of the episode (start state, noise): the same seed must give the same
    /// episode, which is what makes training reproducible.
    fn reset(&mut self, rng_seed: u64) -> Result<Vec<f32>, Self::Error>;

    /// Apply `action` (always `< num_actions()`) and return the next state, the reward and
    /// whether the episode ended.
    fn step(&mut self, action: usize) -> Result<Step, Self::Error>;
}

/// Turns a problem's input (a shape, a part, a sensor reading) into the fixed-length feature
/// vector a Q-network reads.
///
/// Both methods are required. `encode` must return exactly `dim()` values.
pub trait Encoder {
    /// What is encoded; may be unsized (`[f32]`, `str`).
    type Input: ?Sized;

    /// Length of every encoded vector.
    fn dim(&self) -> usize;

    /// Encode `input` into `dim()` values.
    fn encode(&self, input: &Self::Input) -> Vec<f32>;
}

/// The trivial [`Encoder`]: a slice of `dim` values is its own feature vector.
///
/// Shorter inputs are padded with zeros and longer ones truncated, so the output always has
/// `dim` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdentityEncoder {
    /// Length of the feature vector.
    pub dim: usize,
}

impl Encoder for IdentityEncoder {
    type Input = [f32];

    fn dim(&self) -> usize {
        self.dim
    }

    fn encode(&self, input: &[f32]) -> Vec<f32> {
        let mut out: Vec<f32> = input.iter().copied().take(self.dim).collect();
        out.resize(self.dim, 0.0);
        out
    }
}
