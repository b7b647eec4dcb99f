//! The crate's one error type.

use std::path::PathBuf;

/// Everything that can go wrong in this crate.
///
/// Bad configurations, environments that break their own contract (a state of the wrong
/// length, a NaN), unreadable checkpoints and I/O failures all come back as a variant of this
/// enum; no public function of this crate panics on such input.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RlError {
    /// A [`DqnConfig`](crate::DqnConfig) field is out of range.
    #[error("invalid DQN configuration: `{field}` {reason}")]
    InvalidConfig {
        /// The offending field.
        field: &'static str,
        /// Why its value was refused.
        reason: String,
    },
    /// An argument no agent can work with: zero state dimensions or zero actions, zero
    /// evaluation episodes.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// The environment's `state_dim()` / `num_actions()` differ from the agent's.
    #[error(
        "environment does not match the agent: agent has {agent_state_dim} state dims and \
         {agent_actions} actions, environment has {env_state_dim} and {env_actions}"
    )]
    EnvMismatch {
        /// State dimension the agent was built for.
        agent_state_dim: usize,
        /// Number of actions the agent was built for.
        agent_actions: usize,
        /// State dimension the environment reports.
        env_state_dim: usize,
        /// Number of actions the environment reports.
        env_actions: usize,
    },
    /// A state vector has the wrong length.
    #[error("state has {got} values, expected {expected}")]
    StateDim {
        /// The agent's state dimension.
        expected: usize,
        /// The length that was given (or that the environment returned).
        got: usize,
    },
    /// A state vector holds a NaN or an infinity.
    #[error("state value {index} is not finite ({value})")]
    NonFiniteState {
        /// Index of the first bad value.
        index: usize,
        /// The bad value.
        value: f32,
    },
    /// The environment returned a NaN or infinite reward.
    #[error("reward is not finite ({0})")]
    NonFiniteReward(f32),
    /// The training loss became NaN or infinite: the learning rate or the reward scale is too
    /// large for the network.
    #[error("training diverged: loss is {loss} after {updates} updates")]
    Diverged {
        /// The non-finite loss.
        loss: f32,
        /// Gradient updates done before it.
        updates: u64,
    },
    /// The environment's own error, from `reset` or `step`.
    #[error("environment error")]
    Env(#[source] Box<dyn std::error::Error + Send + Sync + 'static>),
    /// A file could not be read or written.
    #[error("{}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A checkpoint file is malformed or was written for another network shape.
    #[error("checkpoint {}: {reason}", path.display())]
    Checkpoint {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// The tensor backend reported a failure (reading data back, applying a record).
    #[error("tensor backend: {0}")]
    Backend(String),
}

impl RlError {
    pub(crate) fn config(field: &'static str, reason: impl Into<String>) -> Self {
        Self::InvalidConfig { field, reason: reason.into() }
    }
}
