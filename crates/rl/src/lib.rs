//! A generic deep Q-network (DQN) in [Burn](https://burn.dev), knowing nothing about
//! machining.
//!
//! # Design
//!
//! - A problem is an [`Environment`]: `reset(seed) -> state`, `step(action) -> Step`, a
//!   fixed state length and a fixed number of discrete actions. An [`Encoder`] turns
//!   whatever a problem observes (a shape, a part) into that state vector. Shape2Gcode's
//!   machining environment lives in the root package and implements both; this crate only
//!   tests against small environments of its own.
//! - [`DgcnnEncoder`] is an [`Encoder`] of point clouds (`[[f32; 3]]`): the DGCNN of Wang
//!   et al. (dynamic-graph EdgeConv layers, max and mean pooling) that the Shape2Gcode paper
//!   uses for its shape features, with supervised pretraining ([`DgcnnEncoder::fit`]) and
//!   its weights as bytes.
//! - [`Dqn`] is the agent: an MLP Q-network (Burn `Linear` layers, ReLU between them;
//!   the Shape2Gcode paper's two hidden layers of 128 by default), an experience replay ring
//!   buffer sampled uniformly, a target network copied from the online one every
//!   [`DqnConfig::target_sync_every`] steps, epsilon-greedy exploration on a linear or
//!   exponential schedule, and Adam on the Huber loss between `Q(s, a)` and
//!   `r + gamma * max_a' Q_target(s', a') * (1 - done)`.
//! - Every hyper-parameter is a public field of [`DqnConfig`], validated up front: bad
//!   values, and environments that break their contract (wrong state length, NaN states or
//!   rewards), give an [`RlError`], never a panic.
//! - Reproducible: one [`DqnConfig::seed`] is split into independent SplitMix64 streams
//!   for weight initialisation, exploration, replay sampling and environment reset seeds.
//!   Weights are drawn by this crate rather than by Burn's backend-wide random state, and
//!   the CPU backends run single-threaded, so the same seed gives bit-identical training.
//! - Checkpoints ([`Dqn::save`], [`Dqn::load`]) hold the online network in Burn's burnpack
//!   record format behind a small shape header, written atomically.
//! - Burn's types stay inside: the public API speaks `&[f32]`, `Vec<f32>` and `usize`.
//!   Burn 0.22 picks the backend at run time from a device; [`Backend`] names the CPU
//!   backends compiled in (features `flex`, the default, and `ndarray`).
//!
//! # Example
//!
//! ```
//! use s2g_rl::{Dqn, DqnConfig};
//!
//! let config = DqnConfig { hidden: vec![16], seed: 7, ..DqnConfig::default() };
//! let agent = Dqn::new(config, 3, 2)?;
//! let q = agent.q_values(&[0.5, -1.0, 2.0])?;
//! assert_eq!(q.len(), 2);
//! let greedy = agent.act(&[0.5, -1.0, 2.0], false)?;
//! assert_eq!(greedy, if q[1] > q[0] { 1 } else { 0 });
//! // A NaN in the state is an error, not a panic.
//! assert!(agent.act(&[f32::NAN, 0.0, 0.0], false).is_err());
//! # Ok::<(), s2g_rl::RlError>(())
//! ```

#[cfg(not(any(feature = "flex", feature = "ndarray")))]
compile_error!("s2g-rl needs a Burn backend: enable the `flex` (default) or `ndarray` feature");

mod checkpoint;
mod config;
mod dgcnn;
mod dqn;
mod env;
mod error;
mod network;
mod replay;
mod rng;

pub use checkpoint::record_bytes;
pub use config::{Backend, DqnConfig, EpsilonDecay};
#[doc(hidden)]
pub use dgcnn::knn_graph;
pub use dgcnn::{DgcnnConfig, DgcnnEncoder, FitOptions, FitReport, RegressionHead};
pub use dqn::{Dqn, EpisodeStats, TrainStats};
pub use env::{Encoder, Environment, IdentityEncoder, Step};
pub use error::RlError;
