//! The agent's hyper-parameters.

use crate::RlError;

/// Which Burn CPU backend runs the Q-network.
///
/// The variants present depend on this crate's cargo features (`flex`, the default, and
/// `ndarray`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Backend {
    /// Burn's pure-Rust Flex CPU backend (feature `flex`, on by default).
    #[cfg(feature = "flex")]
    Flex,
    /// Burn's NdArray CPU backend (feature `ndarray`; deprecated by Burn 0.22 in favour of
    /// Flex).
    #[cfg(feature = "ndarray")]
    NdArray,
}

impl Default for Backend {
    /// Flex when the `flex` feature is on, otherwise NdArray.
    fn default() -> Self {
        #[cfg(feature = "flex")]
        {
            Backend::Flex
        }
        #[cfg(not(feature = "flex"))]
        {
            Backend::NdArray
        }
    }
}

/// How the exploration rate falls from [`DqnConfig::epsilon_start`] to
/// [`DqnConfig::epsilon_end`] over [`DqnConfig::epsilon_decay_steps`] environment steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EpsilonDecay {
    /// `eps(t) = start + (end - start) * min(t / T, 1)`. The default.
    #[default]
    Linear,
    /// `eps(t) = start * (end / start)^min(t / T, 1)`: geometric, reaching `end` at `T`;
    /// needs `end > 0`.
    Exponential,
}

/// Hyper-parameters of a [`Dqn`](crate::Dqn) agent.
///
/// Every field is public and documented with its default; [`DqnConfig::validate`] (called
/// by every constructor) refuses out-of-range values with [`RlError::InvalidConfig`].
/// The defaults are the Shape2Gcode paper's: two fully connected hidden layers of 128,
/// Adam at 1e-3, discount 0.95.
#[derive(Debug, Clone, PartialEq)]
pub struct DqnConfig {
    /// Widths of the hidden layers, each followed by a ReLU; empty gives a linear Q-function.
    /// Default `vec![128, 128]`.
    pub hidden: Vec<usize>,
    /// Adam learning rate, finite and `> 0`. Default `1e-3`.
    pub learning_rate: f64,
    /// Discount factor in `[0, 1]`. Default `0.95`.
    pub gamma: f32,
    /// Exploration rate at step 0, in `[0, 1]`. Default `1.0`.
    pub epsilon_start: f64,
    /// Exploration rate after the decay, in `[0, epsilon_start]`. Default `0.01`.
    pub epsilon_end: f64,
    /// Environment steps over which epsilon decays; `0` means `epsilon_end` from the start.
    /// Default `10_000`.
    pub epsilon_decay_steps: u64,
    /// Shape of the decay. Default [`EpsilonDecay::Linear`].
    pub epsilon_decay: EpsilonDecay,
    /// Transitions the replay buffer keeps (oldest overwritten first), `>= batch_size`.
    /// Default `50_000`.
    pub replay_capacity: usize,
    /// Transitions per gradient update, `> 0`. Default `64`.
    pub batch_size: usize,
    /// Environment steps taken before the first update (and the buffer must also hold
    /// `batch_size` transitions). Default `1_000`.
    pub learning_starts: u64,
    /// One gradient update every this many environment steps, `> 0`. Default `1`.
    pub train_every: u64,
    /// Gradient updates (each on its own sampled batch) every `train_every` steps,
    /// `1..=1024`. More than one suits environments whose steps cost far more than an
    /// update (a simulated machining setup against a small network). Default `1`.
    pub updates_per_train: u32,
    /// The target network is copied from the online one every this many environment steps,
    /// `> 0`. Default `500`.
    pub target_sync_every: u64,
    /// Huber loss threshold, finite and `> 0`. Default `1.0`.
    pub huber_delta: f32,
    /// Double DQN (van Hasselt, Guez and Silver, AAAI 2016): the TD target of a
    /// non-terminal transition evaluates, with the target network, the action the *online*
    /// network prefers in the next state, `r + gamma * Q_target(s', argmax_a' Q_online(s', a'))`,
    /// rather than the target network's own maximum. The maximum over noisy estimates of
    /// many actions is biased upwards; choosing and evaluating with different networks
    /// removes most of that bias. Default `false` (the paper's DQN).
    pub double: bool,
    /// Episodes longer than this are truncated (not treated as terminal), `> 0`.
    /// Default `1_000`.
    pub max_episode_steps: usize,
    /// Seed of every random choice: weight initialisation, exploration, replay sampling and
    /// the seeds passed to [`Environment::reset`](crate::Environment::reset). Default `0`.
    pub seed: u64,
    /// Backend that runs the network. Default [`Backend::default`].
    pub backend: Backend,
}

impl Default for DqnConfig {
    fn default() -> Self {
        Self {
            hidden: vec![128, 128],
            learning_rate: 1e-3,
            gamma: 0.95,
            epsilon_start: 1.0,
            epsilon_end: 0.01,
            epsilon_decay_steps: 10_000,
            epsilon_decay: EpsilonDecay::Linear,
            replay_capacity: 50_000,
            batch_size: 64,
            learning_starts: 1_000,
            train_every: 1,
            updates_per_train: 1,
            target_sync_every: 500,
            huber_delta: 1.0,
            double: false,
            max_episode_steps: 1_000,
            seed: 0,
            backend: Backend::default(),
        }
    }
}

impl DqnConfig {
    /// Check every field's range; the first bad field is named in the error.
    pub fn validate(&self) -> Result<(), RlError> {
        if let Some(i) = self.hidden.iter().position(|&w| w == 0) {
            return Err(RlError::config("hidden", format!("layer {i} has width 0")));
        }
        if !(self.learning_rate.is_finite() && self.learning_rate > 0.0) {
            return Err(RlError::config(
                "learning_rate",
                format!("must be finite and > 0, got {}", self.learning_rate),
            ));
        }
        if !(0.0..=1.0).contains(&self.gamma) {
            return Err(RlError::config("gamma", format!("must be in [0, 1], got {}", self.gamma)));
        }
        if !(0.0..=1.0).contains(&self.epsilon_start) {
            return Err(RlError::config(
                "epsilon_start",
                format!("must be in [0, 1], got {}", self.epsilon_start),
            ));
        }
        if !(0.0..=self.epsilon_start).contains(&self.epsilon_end) {
            return Err(RlError::config(
                "epsilon_end",
                format!("must be in [0, epsilon_start = {}], got {}", self.epsilon_start, self.epsilon_end),
            ));
        }
        if self.epsilon_decay == EpsilonDecay::Exponential && self.epsilon_end <= 0.0 {
            return Err(RlError::config("epsilon_end", "must be > 0 for an exponential decay"));
        }
        if self.batch_size == 0 {
            return Err(RlError::config("batch_size", "must be > 0"));
        }
        if self.replay_capacity < self.batch_size {
            return Err(RlError::config(
                "replay_capacity",
                format!("must be >= batch_size = {}, got {}", self.batch_size, self.replay_capacity),
            ));
        }
        if !(1..=1024).contains(&self.updates_per_train) {
            return Err(RlError::config(
                "updates_per_train",
                format!("must be in 1..=1024, got {}", self.updates_per_train),
            ));
        }
        if self.train_every == 0 {
            return Err(RlError::config("train_every", "must be > 0"));
        }
        if self.target_sync_every == 0 {
            return Err(RlError::config("target_sync_every", "must be > 0"));
        }
        if !(self.huber_delta.is_finite() && self.huber_delta > 0.0) {
            return Err(RlError::config(
                "huber_delta",
                format!("must be finite and > 0, got {}", self.huber_delta),
            ));
        }
        if self.max_episode_steps == 0 {
            return Err(RlError::config("max_episode_steps", "must be > 0"));
        }
        Ok(())
    }

    /// The exploration rate after `step` environment steps.
    pub fn epsilon_at(&self, step: u64) -> f64 {
        let frac = if self.epsilon_decay_steps == 0 {
            1.0
        } else {
            (step as f64 / self.epsilon_decay_steps as f64).min(1.0)
        };
        match self.epsilon_decay {
            EpsilonDecay::Linear => self.epsilon_start + (self.epsilon_end - self.epsilon_start) * frac,
            EpsilonDecay::Exponential => {
                if self.epsilon_start <= 0.0 {
                    0.0
                } else {
                    self.epsilon_start * (self.epsilon_end / self.epsilon_start).powf(frac)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epsilon_schedules_hit_their_end_points() {
        let mut c = DqnConfig { epsilon_decay_steps: 100, ..DqnConfig::default() };
        for decay in [EpsilonDecay::Linear, EpsilonDecay::Exponential] {
            c.epsilon_decay = decay;
            assert!((c.epsilon_at(0) - 1.0).abs() < 1e-12, "{decay:?} at 0");
            assert!((c.epsilon_at(100) - 0.01).abs() < 1e-12, "{decay:?} at T");
            assert!((c.epsilon_at(10_000) - 0.01).abs() < 1e-12, "{decay:?} past T");
            let mid = c.epsilon_at(50);
            assert!(mid < 1.0 && mid > 0.01, "{decay:?} at T/2 is {mid}");
        }
        c.epsilon_decay = EpsilonDecay::Linear;
        assert!((c.epsilon_at(50) - 0.505).abs() < 1e-12);
        c.epsilon_decay = EpsilonDecay::Exponential;
        assert!((c.epsilon_at(50) - 0.1).abs() < 1e-12);
        c.epsilon_decay_steps = 0;
        assert!((c.epsilon_at(0) - 0.01).abs() < 1e-12);
    }
}
