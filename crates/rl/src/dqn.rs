//! The DQN agent: acting, learning, evaluation.

use std::sync::atomic::{AtomicU64, Ordering};

use burn::module::Module;
use burn::nn::loss::{HuberLoss, HuberLossConfig, Reduction};
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Int, Tensor, TensorData};

use crate::RlError;
use crate::config::{Backend, DqnConfig};
use crate::env::Environment;
use crate::network::QNetwork;
use crate::replay::{Batch, ReplayBuffer};
use crate::rng::{self, GOLDEN_GAMMA, SplitMix64};

/// Stream numbers that split the one user seed into independent generators.
const STREAM_INIT: u64 = 1;
const STREAM_EXPLORE: u64 = 2;
const STREAM_REPLAY: u64 = 3;
const STREAM_ENV: u64 = 4;
const STREAM_EVAL: u64 = 5;

/// What happened in one training episode, passed to the `on_episode` callback of
/// [`Dqn::train`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpisodeStats {
    /// Index of the episode over the agent's lifetime (0 for its first).
    pub episode: u64,
    /// Environment steps taken in the episode.
    pub steps: usize,
    /// Undiscounted sum of the episode's rewards.
    pub total_reward: f32,
    /// Exploration rate at the end of the episode.
    pub epsilon: f64,
    /// Mean Huber loss of the gradient updates made during the episode; `None` if none were
    /// (still filling the buffer).
    pub mean_loss: Option<f32>,
    /// Whether the episode was cut at `max_episode_steps` rather than ending in a terminal
    /// state.
    pub truncated: bool,
}

/// Summary of one call to [`Dqn::train`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrainStats {
    /// Episodes run in this call.
    pub episodes: usize,
    /// Environment steps taken in this call.
    pub env_steps: u64,
    /// Gradient updates made in this call.
    pub updates: u64,
    /// Mean undiscounted return of this call's episodes (0 when none ran).
    pub mean_return: f32,
}

/// A deep Q-network agent (Mnih et al., "Human-level control through deep reinforcement
/// learning", Nature 2015): an online Q-network trained by Adam on Huber TD errors against a
/// periodically synchronised target network, from an experience replay buffer, exploring
/// epsilon-greedily.
///
/// The agent is fully determined by its [`DqnConfig`] (seed included) and the environment:
/// the same seed and environment give the same actions, rewards and weights, bit for bit.
pub struct Dqn {
    config: DqnConfig,
    state_dim: usize,
    num_actions: usize,
    /// The backend device with autodiff, where the online network lives.
    train_device: Device,
    /// The same backend without autodiff, for acting and the target network.
    infer_device: Device,
    online: QNetwork,
    target: QNetwork,
    optimizer: ModuleOptimizer,
    loss: HuberLoss,
    replay: ReplayBuffer,
    batch: Batch,
    /// SplitMix64 counter of the exploration generator, atomic so that [`Dqn::act`] can take
    /// `&self` and the agent stays `Sync`.
    explore_rng: AtomicU64,
    replay_rng: SplitMix64,
    env_rng: SplitMix64,
    env_steps: u64,
    updates: u64,
    episodes: u64,
}

impl std::fmt::Debug for Dqn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Dqn")
            .field("config", &self.config)
            .field("state_dim", &self.state_dim)
            .field("num_actions", &self.num_actions)
            .field("env_steps", &self.env_steps)
            .field("updates", &self.updates)
            .field("episodes", &self.episodes)
            .field("replay_len", &self.replay.len())
            .finish_non_exhaustive()
    }
}

/// The device of a CPU backend (shared with the DGCNN encoder).
pub(crate) fn backend_device(backend: Backend) -> Device {
    match backend {
        #[cfg(feature = "flex")]
        Backend::Flex => Device::flex(),
        // Burn 0.22 deprecates NdArray in favour of Flex; it is kept here, behind its own
        // feature, as the backend the design named and as a cross-check of Flex.
        #[cfg(feature = "ndarray")]
        #[allow(deprecated)]
        Backend::NdArray => Device::ndarray(),
    }
}

pub(crate) fn backend_err(e: impl std::fmt::Debug) -> RlError {
    RlError::Backend(format!("{e:?}"))
}

fn env_err<E: std::error::Error + Send + Sync + 'static>(e: E) -> RlError {
    RlError::Env(Box::new(e))
}

/// Index of the largest value, the lowest index on ties; NaNs never win.
fn argmax(values: &[f32]) -> usize {
    argmax_among(values, |_| true).unwrap_or(0)
}

/// The index of the largest of the `values` whose index `allowed` keeps (the lowest on
/// ties, a NaN never preferred), or `None` when it keeps none.
fn argmax_among(values: &[f32], allowed: impl Fn(usize) -> bool) -> Option<usize> {
    let mut best: Option<usize> = None;
    for (i, &v) in values.iter().enumerate().filter(|&(i, _)| allowed(i)) {
        if best.is_none_or(|b| v > values[b] || values[b].is_nan()) {
            best = Some(i);
        }
    }
    best
}

impl Dqn {
    /// A fresh agent for states of `state_dim` values and `num_actions` actions.
    ///
    /// Fails with [`RlError::InvalidConfig`] for a bad config and
    /// [`RlError::InvalidArgument`] for a zero dimension.
    pub fn new(config: DqnConfig, state_dim: usize, num_actions: usize) -> Result<Self, RlError> {
        config.validate()?;
        if state_dim == 0 || num_actions == 0 {
            return Err(RlError::InvalidArgument(format!(
                "a Q-network needs state_dim > 0 and num_actions > 0, got {state_dim} and \
                 {num_actions}"
            )));
        }
        if u32::try_from(num_actions).is_err() {
            return Err(RlError::InvalidArgument(format!(
                "{num_actions} actions is more than the replay buffer stores"
            )));
        }
        let infer_device = backend_device(config.backend);
        let train_device = infer_device.clone().autodiff();
        let mut widths = Vec::with_capacity(config.hidden.len() + 2);
        widths.push(state_dim);
        widths.extend_from_slice(&config.hidden);
        widths.push(num_actions);
        let mut init_rng = SplitMix64::new(config.seed, STREAM_INIT);
        let online = QNetwork::new(&widths, &mut init_rng, &train_device);
        let target = online.valid();
        // `HuberLossConfig::init` asserts `delta >= 0`; `validate` has already refused
        // anything but a finite positive delta, so it cannot panic here.
        let loss = HuberLossConfig::new(config.huber_delta).init();
        let optimizer = AdamConfig::new().init();
        Ok(Self {
            state_dim,
            num_actions,
            train_device,
            infer_device,
            online,
            target,
            optimizer,
            loss,
            replay: ReplayBuffer::new(state_dim, config.replay_capacity),
            batch: Batch::default(),
            explore_rng: AtomicU64::new(SplitMix64::new(config.seed, STREAM_EXPLORE).state()),
            replay_rng: SplitMix64::new(config.seed, STREAM_REPLAY),
            env_rng: SplitMix64::new(config.seed, STREAM_ENV),
            env_steps: 0,
            updates: 0,
            episodes: 0,
            config,
        })
    }

    /// A fresh agent sized for `env`.
    pub fn for_env(config: DqnConfig, env: &impl Environment) -> Result<Self, RlError> {
        Self::new(config, env.state_dim(), env.num_actions())
    }

    /// The agent's configuration.
    pub fn config(&self) -> &DqnConfig {
        &self.config
    }

    /// Length of the state vectors the agent reads.
    pub fn state_dim(&self) -> usize {
        self.state_dim
    }

    /// Number of actions the agent chooses from.
    pub fn num_actions(&self) -> usize {
        self.num_actions
    }

    /// Environment steps taken in training over the agent's lifetime.
    pub fn env_steps(&self) -> u64 {
        self.env_steps
    }

    /// Gradient updates made over the agent's lifetime.
    pub fn updates(&self) -> u64 {
        self.updates
    }

    /// Training episodes run over the agent's lifetime.
    pub fn episodes(&self) -> u64 {
        self.episodes
    }

    /// The current exploration rate (from the schedule and [`env_steps`](Self::env_steps)).
    pub fn epsilon(&self) -> f64 {
        self.config.epsilon_at(self.env_steps)
    }

    fn check_state(&self, state: &[f32]) -> Result<(), RlError> {
        if state.len() != self.state_dim {
            return Err(RlError::StateDim { expected: self.state_dim, got: state.len() });
        }
        if let Some((index, &value)) = state.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(RlError::NonFiniteState { index, value });
        }
        Ok(())
    }

    fn check_env(&self, env: &impl Environment) -> Result<(), RlError> {
        if env.state_dim() != self.state_dim || env.num_actions() != self.num_actions {
            return Err(RlError::EnvMismatch {
                agent_state_dim: self.state_dim,
                agent_actions: self.num_actions,
                env_state_dim: env.state_dim(),
                env_actions: env.num_actions(),
            });
        }
        Ok(())
    }

    /// The online network's Q-value of every action in `state` (`num_actions` values).
    pub fn q_values(&self, state: &[f32]) -> Result<Vec<f32>, RlError> {
        self.check_state(state)?;
        let x =
            Tensor::<2>::from_data(TensorData::new(state.to_vec(), [1, self.state_dim]), &self.infer_device);
        // `valid` drops autodiff from the parameters, so acting records no graph.
        let q = self.online.valid().forward(x);
        q.try_into_data().map_err(backend_err)?.try_into_vec::<f32>().map_err(backend_err)
    }

    /// Choose an action for `state`: the greedy one (largest Q-value, lowest index on ties)
    /// or, when `explore` is true, a uniformly random one with probability
    /// [`epsilon`](Self::epsilon).
    ///
    /// Exploration draws from the agent's own seeded generator, so a sequence of calls is
    /// reproducible.
    pub fn act(&self, state: &[f32], explore: bool) -> Result<usize, RlError> {
        self.check_state(state)?;
        if explore {
            let u = rng::unit_f64(self.next_explore_bits());
            if u < self.epsilon() {
                return Ok(rng::below(self.next_explore_bits(), self.num_actions));
            }
        }
        Ok(argmax(&self.q_values(state)?))
    }

    /// The greedy action for `state` among the actions `allowed` marks (one flag per
    /// action): the largest Q-value, the lowest index on ties, as [`act`](Self::act) without
    /// exploration chooses among all of them; `None` when no action is allowed. An
    /// action space with some actions taken away (a clearing strategy left out, as the
    /// paper's Table 4 ablates) is acted in this way.
    pub fn act_among(&self, state: &[f32], allowed: &[bool]) -> Result<Option<usize>, RlError> {
        if allowed.len() != self.num_actions {
            return Err(RlError::InvalidArgument(format!(
                "{} action flags for an agent of {} actions",
                allowed.len(),
                self.num_actions
            )));
        }
        Ok(argmax_among(&self.q_values(state)?, |i| allowed[i]))
    }

    /// One SplitMix64 step of the exploration generator.
    fn next_explore_bits(&self) -> u64 {
        let counter = self.explore_rng.fetch_add(GOLDEN_GAMMA, Ordering::Relaxed).wrapping_add(GOLDEN_GAMMA);
        rng::mix64(counter)
    }

    /// Train for `episodes` episodes of `env`, calling `on_episode` after each.
    ///
    /// Each step acts epsilon-greedily, stores the transition, and every
    /// [`train_every`](DqnConfig::train_every) steps (once
    /// [`learning_starts`](DqnConfig::learning_starts) steps are taken and the buffer holds a
    /// batch) makes [`updates_per_train`](DqnConfig::updates_per_train) Adam updates of the Huber loss between `Q(s, a)` and
    /// `r + gamma * max_a' Q_target(s', a') * (1 - done)` (or its [double](DqnConfig::double)
    /// form); the target network is copied from
    /// the online one every [`target_sync_every`](DqnConfig::target_sync_every) steps.
    /// Counters, the schedule and the buffer carry over between calls.
    ///
    /// Fails if the environment's sizes differ from the agent's, if it returns a state of the
    /// wrong length or with a non-finite value, a non-finite reward, or its own error, or if
    /// the loss diverges.
    pub fn train<E: Environment>(
        &mut self,
        env: &mut E,
        episodes: usize,
        mut on_episode: impl FnMut(EpisodeStats),
    ) -> Result<TrainStats, RlError> {
        self.check_env(env)?;
        let (steps_before, updates_before) = (self.env_steps, self.updates);
        let mut return_sum = 0.0f64;
        for _ in 0..episodes {
            let mut state = env.reset(self.env_rng.next_u64()).map_err(env_err)?;
            self.check_state(&state)?;
            let (mut steps, mut total_reward, mut terminal) = (0usize, 0.0f32, false);
            let (mut loss_sum, mut loss_count) = (0.0f64, 0u32);
            while steps < self.config.max_episode_steps {
                let action = self.act(&state, true)?;
                let step = env.step(action).map_err(env_err)?;
                self.check_state(&step.state)?;
                if !step.reward.is_finite() {
                    return Err(RlError::NonFiniteReward(step.reward));
                }
                self.replay.push(&state, action, step.reward, &step.state, step.done);
                self.env_steps += 1;
                steps += 1;
                total_reward += step.reward;
                if self.env_steps >= self.config.learning_starts
                    && self.replay.len() >= self.config.batch_size
                    && self.env_steps.is_multiple_of(self.config.train_every)
                {
                    for _ in 0..self.config.updates_per_train {
                        loss_sum += f64::from(self.update()?);
                        loss_count += 1;
                    }
                }
                if self.env_steps.is_multiple_of(self.config.target_sync_every) {
                    self.sync_target();
                }
                state = step.state;
                if step.done {
                    terminal = true;
                    break;
                }
            }
            self.episodes += 1;
            return_sum += f64::from(total_reward);
            on_episode(EpisodeStats {
                episode: self.episodes - 1,
                steps,
                total_reward,
                epsilon: self.epsilon(),
                mean_loss: (loss_count > 0).then(|| (loss_sum / f64::from(loss_count)) as f32),
                truncated: !terminal,
            });
        }
        Ok(TrainStats {
            episodes,
            env_steps: self.env_steps - steps_before,
            updates: self.updates - updates_before,
            mean_return: if episodes == 0 { 0.0 } else { (return_sum / episodes as f64) as f32 },
        })
    }

    /// Copy the online network into the target network now.
    pub fn sync_target(&mut self) {
        self.target = self.online.valid();
    }

    /// The TD targets of the sampled batch: `r` for a terminal transition, otherwise
    /// `r + gamma * Q_target(s', a*)` with `a*` the target network's best action in `s'`,
    /// or the online network's with [`double`](DqnConfig::double).
    ///
    /// Computed on the host: they are constants for the gradient, and a batch of `b`
    /// maxima is cheaper there than another graph.
    fn td_targets(&self) -> Result<Vec<f32>, RlError> {
        let (b, d, a) = (self.config.batch_size, self.state_dim, self.num_actions);
        let next_states = || {
            Tensor::<2>::from_data(
                TensorData::new(self.batch.next_states.clone(), [b, d]),
                &self.infer_device,
            )
        };
        let host = |q: Tensor<2>| -> Result<Vec<f32>, RlError> {
            q.try_into_data().map_err(backend_err)?.try_into_vec::<f32>().map_err(backend_err)
        };
        let next_q = host(self.target.forward(next_states()))?;
        // The online network's choice in each next state, when it chooses.
        let chosen = if self.config.double {
            let online_q = host(self.online.valid().forward(next_states()))?;
            Some(online_q.chunks_exact(a).map(argmax).collect::<Vec<_>>())
        } else {
            None
        };
        let gamma = self.config.gamma;
        Ok((0..b)
            .map(|i| {
                let r = self.batch.rewards[i];
                if self.batch.dones[i] {
                    return r;
                }
                let q = &next_q[i * a..(i + 1) * a];
                let next = match &chosen {
                    Some(c) => q[c[i]],
                    None => q.iter().copied().fold(f32::NEG_INFINITY, f32::max),
                };
                r + gamma * next
            })
            .collect())
    }

    /// One gradient update on a uniformly sampled batch; returns its loss.
    fn update(&mut self) -> Result<f32, RlError> {
        let (b, d) = (self.config.batch_size, self.state_dim);
        self.replay.sample(b, &mut self.replay_rng, &mut self.batch);

        let targets = self.td_targets()?;
        let states =
            Tensor::<2>::from_data(TensorData::new(self.batch.states.clone(), [b, d]), &self.train_device);
        let actions = Tensor::<2, Int>::from_data(
            TensorData::new(self.batch.actions.clone(), [b, 1]),
            &self.train_device,
        );
        let targets = Tensor::<2>::from_data(TensorData::new(targets, [b, 1]), &self.train_device);
        let q_taken = self.online.forward(states).gather(1, actions);
        let loss = self.loss.forward(q_taken, targets, Reduction::Mean);
        let loss_value = loss
            .clone()
            .try_into_data()
            .map_err(backend_err)?
            .try_into_vec::<f32>()
            .map_err(backend_err)?
            .first()
            .copied()
            .unwrap_or(f32::NAN);
        if !loss_value.is_finite() {
            return Err(RlError::Diverged { loss: loss_value, updates: self.updates });
        }
        let grads = GradientsParams::from_grads(loss.backward(), &self.online);
        self.online = self.optimizer.step(self.config.learning_rate, self.online.clone(), grads);
        self.updates += 1;
        Ok(loss_value)
    }

    /// Mean undiscounted return of the greedy policy over `episodes` episodes of `env`, each
    /// cut at `max_episode_steps`. The episodes' reset seeds come from `seed`, so the result
    /// is reproducible; the agent is not changed.
    pub fn evaluate<E: Environment>(&self, env: &mut E, episodes: usize, seed: u64) -> Result<f32, RlError> {
        self.check_env(env)?;
        if episodes == 0 {
            return Err(RlError::InvalidArgument("evaluate needs at least one episode".into()));
        }
        let mut seeds = SplitMix64::new(seed, STREAM_EVAL);
        let mut sum = 0.0f64;
        for _ in 0..episodes {
            let mut state = env.reset(seeds.next_u64()).map_err(env_err)?;
            for _ in 0..self.config.max_episode_steps {
                let step = env.step(self.act(&state, false)?).map_err(env_err)?;
                self.check_state(&step.state)?;
                if !step.reward.is_finite() {
                    return Err(RlError::NonFiniteReward(step.reward));
                }
                sum += f64::from(step.reward);
                state = step.state;
                if step.done {
                    break;
                }
            }
        }
        Ok((sum / episodes as f64) as f32)
    }

    /// The online network, for checkpoints.
    pub(crate) fn online(&self) -> &QNetwork {
        &self.online
    }

    /// Replace the online network (and the target with it), for checkpoints.
    pub(crate) fn set_online(&mut self, online: QNetwork) {
        self.online = online;
        self.sync_target();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn argmax_prefers_lowest_index_and_skips_nan() {
        assert_eq!(argmax(&[1.0, 3.0, 3.0, 2.0]), 1);
        assert_eq!(argmax(&[f32::NAN, 0.5, 0.7]), 2);
        assert_eq!(argmax(&[-1.0]), 0);
    }

    #[test]
    fn argmax_among_keeps_to_the_allowed_actions() {
        let q = [1.0, 3.0, 3.0, 2.0, f32::NAN];
        assert_eq!(argmax_among(&q, |i| i != 1), Some(2));
        assert_eq!(argmax_among(&q, |i| i == 0 || i == 3), Some(3));
        assert_eq!(argmax_among(&q, |i| i == 4 || i == 0), Some(0));
        assert_eq!(argmax_among(&q, |_| false), None);
    }

    /// The TD targets follow their formulas: terminal transitions give `r`; otherwise the
    /// plain form takes the target network's maximum and the double form the target
    /// network's value of the online network's choice. The online network is trained away
    /// from the target first, so the two choices differ somewhere and the forms can be told
    /// apart.
    #[test]
    fn td_targets_take_the_target_networks_value_of_the_right_action() {
        let (d, a) = (3, 5);
        let mut agent = Dqn::new(
            DqnConfig {
                hidden: vec![16],
                learning_rate: 1e-2,
                batch_size: 32,
                replay_capacity: 256,
                target_sync_every: 1_000_000,
                seed: 3,
                ..DqnConfig::default()
            },
            d,
            a,
        )
        .unwrap();
        let mut rng = SplitMix64::new(11, 0);
        let mut unit = || rng::unit_f64(rng.next_u64()) as f32 * 2.0 - 1.0;
        for k in 0..200 {
            let s: Vec<f32> = (0..d).map(|_| unit()).collect();
            let s2: Vec<f32> = (0..d).map(|_| unit()).collect();
            let r = 3.0 * unit();
            agent.replay.push(&s, k % a, r, &s2, k % 7 == 0);
        }
        for _ in 0..40 {
            agent.update().unwrap();
        }
        let target_q = |agent: &Dqn, s: &[f32]| {
            let x = Tensor::<2>::from_data(TensorData::new(s.to_vec(), [1, d]), &agent.infer_device);
            agent.target.forward(x).try_into_data().unwrap().try_into_vec::<f32>().unwrap()
        };
        let (mut disagree, mut terminal) = (0, 0);
        for double in [false, true] {
            agent.config.double = double;
            agent.replay.sample(32, &mut agent.replay_rng, &mut agent.batch);
            let got = agent.td_targets().unwrap();
            for (i, &t) in got.iter().enumerate() {
                let r = agent.batch.rewards[i];
                if agent.batch.dones[i] {
                    assert_eq!(t, r, "terminal transition {i}");
                    terminal += 1;
                    continue;
                }
                let next = &agent.batch.next_states[i * d..(i + 1) * d];
                let (qt, qo) = (target_q(&agent, next), agent.q_values(next).unwrap());
                let pick = if double { argmax(&qo) } else { argmax(&qt) };
                disagree += usize::from(argmax(&qo) != argmax(&qt));
                let want = r + agent.config.gamma * qt[pick];
                assert!(
                    (t - want).abs() <= 1e-5 * want.abs().max(1.0),
                    "double {double}, {i}: {t} vs {want}"
                );
            }
        }
        assert!(disagree > 0 && terminal > 0, "{disagree} disagreements, {terminal} terminal transitions");
    }
}
