//! Learning the machining parameters (seed 000 §3.4-3.5, Appendix A.1): the machining
//! [`Environment`] the DQN of `s2g-rl` trains on, the shape [`Encoder`]s, and the learned
//! [`Policy`] that plugs into [`mill`](crate::mill).
//!
//! # Episodes
//!
//! An episode is one part; a step is one setup in the greedy orientation order; an action
//! is an index into the part's [`ActionSpace`] (tool radius, layer height, clearing
//! strategy; the contour pass always runs). Each step plans, writes, parses back and
//! simulates the setup through [`MillRun`], exactly as `s2g mill` does, on the grid of
//! [`TrainOptions::mill`].
//!
//! The state is the encoder's features of the setup's visible surface followed by the
//! progress: the setup's index over the number of setups, and the fraction of the stock
//! still to remove.
//!
//! # Rewards (Eq. 10-13)
//!
//! After setup `s` the step's reward is `λ_s R_s`, the preservation of the part's voxels
//! (Eq. 10). The last step adds `λ_f R_f + λ_MRR R_MRR`: the final IoU of stock and part
//! voxels (Eq. 11) and the material removal rate (Eq. 12). So the episode's return is
//! Eq. 13, `λ_s Σ_s R_s + λ_f R_f + λ_MRR R_MRR`, with the paper's weights 1, 1, 0.1 by
//! default. The paper leaves the unit of `R_MRR` open; here it is the removed volume per
//! machining time in **cm³ per minute** of the machined part (the paper preset machines the
//! unit cube at 100 mm), so that it does not change with the grid's resolution.
//!
//! A deterministic environment repeats itself: the outcome of every action sequence tried
//! is kept, and an episode replays the simulation only when it leaves what was tried.

use std::collections::HashMap;
use std::path::Path;

use s2g_rl::{Dqn, DqnConfig, Encoder, Environment, EpisodeStats, RlError, Step};
use serde::{Deserialize, Serialize};

use crate::geom::Mesh;
use crate::pipeline::{MillError, MillOptions, MillRun, Preset, SetupCount};
use crate::policy::{Action, ActionSpace, Policy, SetupContext, SetupFeatures};
use crate::voxsim::RewardWeights;

/// The cheap geometric shape descriptor: for each tool radius, how much of the visible
/// surface it reaches (relative to the smallest tool); the fraction of the part visible
/// from the setup; the histogram of where that surface lies along the tool axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GeometricEncoder {
    /// Radii of the action space.
    pub radii: usize,
}

impl Encoder for GeometricEncoder {
    type Input = SetupFeatures;

    fn dim(&self) -> usize {
        self.radii + 1 + SetupFeatures::DEPTH_BINS
    }

    fn encode(&self, f: &SetupFeatures) -> Vec<f32> {
        let best = f.reach_by_radius.first().copied().filter(|&r| r > 0.0).unwrap_or(1.0);
        let mut out: Vec<f32> =
            (0..self.radii).map(|i| f.reach_by_radius.get(i).map_or(0.0, |&r| (r / best) as f32)).collect();
        out.push(f.visible_fraction as f32);
        out.extend(
            (0..SetupFeatures::DEPTH_BINS).map(|i| f.depth_histogram.get(i).copied().unwrap_or(0.0) as f32),
        );
        out.iter_mut().for_each(|v| {
            if !v.is_finite() {
                *v = 0.0;
            }
        });
        out
    }
}

/// The state the Q-network reads: the encoder's features, then the setup's index over the
/// number of setups and the fraction of the stock still to remove.
pub fn observation(encoder: &GeometricEncoder, ctx: &SetupContext<'_>) -> Vec<f32> {
    let mut s = encoder.encode(ctx.features);
    s.push(ctx.index as f32 / ctx.setups.max(1) as f32);
    s.push(ctx.features.removal_fraction.clamp(0.0, 1.0) as f32);
    s
}

/// The state of `run`'s next setup.
fn state(encoder: &GeometricEncoder, run: &MillRun) -> Vec<f32> {
    let features = run.features();
    observation(encoder, &run.context(&features))
}

/// Options of [`train_policy`] and of the machining environment.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainOptions {
    /// Episodes (the paper trains 300).
    pub episodes: usize,
    /// Seed of the agent (weights, exploration, replay) and of the parts' order.
    pub seed: u64,
    /// How each episode mills its part. Default: the paper preset on a 48³ grid, 2,048
    /// orientation points, 128 candidates, at most three setups: small enough to train in
    /// minutes on two cores.
    pub mill: MillOptions,
    /// Reward weights (Eq. 13). Default: the paper's 1, 1, 0.1; a zero weight drops its term
    /// (Table 5's ablations).
    pub weights: RewardWeights,
    /// The agent. Default: the paper's network (two layers of 128, Adam 1e-3, γ 0.95,
    /// ε 1 → 0.01) with the buffer, batch and schedule scaled to a few hundred steps.
    pub dqn: DqnConfig,
}

impl Default for TrainOptions {
    fn default() -> Self {
        Self {
            episodes: 300,
            seed: 0,
            mill: MillOptions {
                resolution: 48,
                orient_points: 2048,
                orient_candidates: 128,
                setups: SetupCount::Exactly(3),
                ..MillOptions::default()
            },
            weights: RewardWeights::default(),
            dqn: DqnConfig {
                epsilon_decay_steps: 600,
                replay_capacity: 10_000,
                batch_size: 32,
                learning_starts: 64,
                target_sync_every: 100,
                ..DqnConfig::default()
            },
        }
    }
}

/// The machining environment: one episode mills one part of the corpus, one step one setup.
pub struct MachiningEnv {
    parts: Vec<(String, Mesh)>,
    opts: MillOptions,
    weights: RewardWeights,
    encoder: GeometricEncoder,
    space: ActionSpace,
    /// The part of the current episode and the actions taken so far.
    part: usize,
    taken: Vec<usize>,
    /// A run at some prefix of `taken` (`None` until one is needed).
    run: Option<(usize, Vec<usize>, MillRun)>,
    /// Every (part, action prefix) tried: the step it gave.
    outcomes: HashMap<(usize, Vec<usize>), Step>,
    /// First states per part.
    first: HashMap<usize, Vec<f32>>,
}

impl MachiningEnv {
    /// An environment over `parts` (named meshes) milled with `opts`, rewarded with `weights`.
    pub fn new(
        parts: Vec<(String, Mesh)>,
        opts: MillOptions,
        weights: RewardWeights,
    ) -> Result<Self, MillError> {
        if parts.is_empty() {
            return Err(MillError::InvalidOption("the training corpus has no part".into()));
        }
        let space = opts.action_space();
        Ok(Self {
            parts,
            encoder: GeometricEncoder { radii: space.radii.len() },
            space,
            opts: per_setup(&opts),
            weights,
            part: 0,
            taken: Vec::new(),
            run: None,
            outcomes: HashMap::new(),
            first: HashMap::new(),
        })
    }

    /// The action space (planning units).
    pub fn space(&self) -> &ActionSpace {
        &self.space
    }

    /// Starts an episode on `part`: its first state, computed once per part.
    fn start(&mut self, part: usize) -> Result<Vec<f32>, MillError> {
        self.part = part;
        self.taken.clear();
        if let Some(s) = self.first.get(&part) {
            return Ok(s.clone());
        }
        let run = self.fresh_run(part)?;
        let s = state(&self.encoder, &run);
        self.first.insert(part, s.clone());
        self.run = Some((part, Vec::new(), run));
        Ok(s)
    }

    fn fresh_run(&self, part: usize) -> Result<MillRun, MillError> {
        MillRun::new(&self.parts[part].1, &self.opts, &mut |_| {})
    }

    /// Brings the kept run to the current prefix: replays the missing setups when it is at
    /// a prefix of it, else starts the part again.
    fn sync_run(&mut self) -> Result<(), MillError> {
        let usable =
            matches!(&self.run, Some((p, done, _)) if *p == self.part && self.taken.starts_with(done));
        if !usable {
            self.run = Some((self.part, Vec::new(), self.fresh_run(self.part)?));
        }
        if let Some((_, done, run)) = self.run.as_mut() {
            while done.len() < self.taken.len() {
                let a = self.taken[done.len()];
                let action = self.space.action(a).ok_or_else(|| bad_action(a, self.space.len()))?;
                run.machine(action, &mut |_| {})?;
                done.push(a);
            }
        }
        Ok(())
    }
}

fn bad_action(a: usize, n: usize) -> MillError {
    MillError::InvalidOption(format!("action {a} is outside the action space of {n}"))
}

impl Environment for MachiningEnv {
    type Error = MillError;

    fn state_dim(&self) -> usize {
        self.encoder.dim() + 2
    }

    fn num_actions(&self) -> usize {
        self.space.len()
    }

    fn reset(&mut self, rng_seed: u64) -> Result<Vec<f32>, MillError> {
        let part = (rng_seed % self.parts.len() as u64) as usize;
        self.start(part)
    }

    fn step(&mut self, action: usize) -> Result<Step, MillError> {
        if action >= self.space.len() {
            return Err(bad_action(action, self.space.len()));
        }
        let mut key = (self.part, self.taken.clone());
        key.1.push(action);
        if let Some(step) = self.outcomes.get(&key) {
            self.taken.push(action);
            return Ok(step.clone());
        }
        self.sync_run()?;
        let chosen = self.space.action(action).ok_or_else(|| bad_action(action, self.space.len()))?;
        let state_dim = self.encoder.dim() + 2;
        let Some((_, done_actions, run)) = self.run.as_mut() else {
            return Err(MillError::InvalidOption("no run to step (reset first)".into()));
        };
        run.machine(chosen, &mut |_| {})?;
        done_actions.push(action);
        self.taken.push(action);
        let done = run.next_setup().is_none();
        let reward = step_reward(run, &self.weights)?;
        let state = if done { vec![0.0; state_dim] } else { state(&self.encoder, run) };
        let step = Step { state, reward: reward as f32, done };
        self.outcomes.insert(key, step.clone());
        Ok(step)
    }
}

/// What a policy file says about how its network was made.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PolicyInfo {
    /// The encoder its states come from (`geometric`).
    pub encoder: String,
    /// Hidden layer widths of the Q-network.
    pub hidden: Vec<usize>,
    /// Length of its states.
    pub state_dim: usize,
    /// Its action space, in normalised units for the paper preset (radii, layer heights,
    /// strategies by name), so that a file is refused by a build with another space.
    pub radii: Vec<f64>,
    /// Layer heights of its action space.
    pub layer_heights: Vec<f64>,
    /// Clearing strategies of its action space, by name.
    pub strategies: Vec<String>,
    /// Names of the parts it was trained on.
    pub trained_on: Vec<String>,
    /// Training episodes (fine-tuning included).
    pub episodes: u64,
    /// Training seed.
    pub seed: u64,
    /// Simulation resolution it was trained at.
    pub resolution: usize,
}

/// A trained DQN as a [`Policy`]: the greedy action of its Q-network on the setup's state.
pub struct LearnedPolicy {
    agent: Dqn,
    info: PolicyInfo,
    encoder: GeometricEncoder,
}

const POLICY_MAGIC: &[u8; 10] = b"S2GPOLICY\n";

impl std::fmt::Debug for LearnedPolicy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LearnedPolicy").field("info", &self.info).finish_non_exhaustive()
    }
}

impl LearnedPolicy {
    /// What the file says about the policy.
    pub fn info(&self) -> &PolicyInfo {
        &self.info
    }

    /// Reads a policy file written by [`save`](Self::save).
    pub fn load(path: &Path) -> Result<Self, MillError> {
        let bytes =
            std::fs::read(path).map_err(|e| MillError::InvalidOption(format!("{}: {e}", path.display())))?;
        Self::from_bytes(&bytes, path)
    }

    fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, MillError> {
        let bad =
            |why: String| MillError::InvalidOption(format!("{}: not a policy file: {why}", path.display()));
        let rest = bytes.strip_prefix(POLICY_MAGIC.as_slice()).ok_or_else(|| bad("bad magic".into()))?;
        let eol = rest.iter().position(|&b| b == b'\n').ok_or_else(|| bad("no header line".into()))?;
        let info: PolicyInfo = serde_json::from_slice(&rest[..eol]).map_err(|e| bad(e.to_string()))?;
        let config = DqnConfig { hidden: info.hidden.clone(), ..DqnConfig::default() };
        let agent = Dqn::from_bytes(&rest[eol + 1..], config).map_err(|e| bad(e.to_string()))?;
        if info.encoder != "geometric" {
            return Err(bad(format!("unknown encoder {:?}", info.encoder)));
        }
        let encoder = GeometricEncoder { radii: info.radii.len() };
        if agent.state_dim() != encoder.dim() + 2 || agent.state_dim() != info.state_dim {
            return Err(bad(format!(
                "states of {} values, the encoder gives {}",
                agent.state_dim(),
                encoder.dim() + 2
            )));
        }
        let actions = info.radii.len() * info.layer_heights.len() * info.strategies.len();
        if agent.num_actions() != actions {
            return Err(bad(format!("{} actions for an action space of {actions}", agent.num_actions())));
        }
        Ok(Self { agent, info, encoder })
    }

    /// Writes the policy atomically: a magic line, a JSON line of [`PolicyInfo`], then the
    /// Q-network's checkpoint.
    pub fn save(&self, path: &Path) -> Result<(), MillError> {
        let mut bytes = POLICY_MAGIC.to_vec();
        bytes.extend(serde_json::to_vec(&self.info).map_err(|e| MillError::InvalidOption(e.to_string()))?);
        bytes.push(b'\n');
        bytes.extend(self.agent.to_bytes().map_err(rl_error)?);
        crate::geom::write_bytes_atomic(path, &bytes)?;
        Ok(())
    }

    /// Whether `space` is the action space the policy was trained on (normalised units
    /// for the paper preset: `scale` is millimetres per unit, 1 for the shop preset).
    fn fits(&self, space: &ActionSpace, scale: f64) -> bool {
        let close = |a: &[f64], b: &[f64]| {
            a.len() == b.len()
                && a.iter().zip(b).all(|(x, y)| (x * scale - y).abs() <= 1e-9 * y.abs().max(1.0))
        };
        close(&self.info.radii, &space.radii)
            && close(&self.info.layer_heights, &space.layer_heights)
            && self.info.strategies.iter().map(String::as_str).eq(space.strategies.iter().map(|s| s.name()))
    }

    /// Fine-tunes the policy on one part for `episodes` episodes (Appendix A.7: five),
    /// exploring from ε = 0.1 down, and returns each episode's return.
    pub fn finetune(
        &mut self,
        mesh: &Mesh,
        name: &str,
        episodes: usize,
        opts: &TrainOptions,
        on_episode: &mut dyn FnMut(EpisodeStats),
    ) -> Result<Vec<f32>, MillError> {
        let config = DqnConfig {
            hidden: self.info.hidden.clone(),
            epsilon_start: 0.1,
            epsilon_end: 0.01,
            epsilon_decay_steps: (episodes as u64 * 3).max(1),
            learning_starts: 8,
            batch_size: 8,
            ..opts.dqn.clone()
        };
        let bytes = self.agent.to_bytes().map_err(rl_error)?;
        let mut agent = Dqn::from_bytes(&bytes, DqnConfig { seed: opts.seed, ..config }).map_err(rl_error)?;
        let mut env =
            MachiningEnv::new(vec![(name.to_owned(), mesh.clone())], opts.mill.clone(), opts.weights)?;
        let mut returns = Vec::with_capacity(episodes);
        agent
            .train(&mut env, episodes, |e| {
                returns.push(e.total_reward);
                on_episode(e);
            })
            .map_err(rl_error)?;
        self.agent = agent;
        self.info.episodes += episodes as u64;
        Ok(returns)
    }
}

fn rl_error(e: RlError) -> MillError {
    MillError::InvalidOption(format!("learning: {e}"))
}

impl Policy for LearnedPolicy {
    fn choose(&mut self, ctx: &SetupContext<'_>) -> Action {
        let scale = ctx.space.radii.first().zip(self.info.radii.first()).map_or(1.0, |(a, b)| a / b);
        // In another action space (the shop preset, a strategy left out) the Q-network's
        // actions mean nothing, so the heuristic decides; so it does if acting fails.
        let learned = if self.fits(ctx.space, scale) {
            let state = observation(&self.encoder, ctx);
            self.agent.act(&state, false).ok().and_then(|a| ctx.space.action(a))
        } else {
            None
        };
        learned.unwrap_or_else(|| crate::policy::HeuristicPolicy::default().choose(ctx))
    }

    fn name(&self) -> String {
        "learned".into()
    }
}

/// Trains a policy on `parts` (Algorithm: DQN, seed 000 Appendix A.1); `on_episode` is told
/// after each episode.
pub fn train_policy(
    parts: &[(String, Mesh)],
    opts: &TrainOptions,
    on_episode: &mut dyn FnMut(EpisodeStats),
) -> Result<LearnedPolicy, MillError> {
    let mut env = MachiningEnv::new(parts.to_vec(), opts.mill.clone(), opts.weights)?;
    let mut agent =
        Dqn::for_env(DqnConfig { seed: opts.seed, ..opts.dqn.clone() }, &env).map_err(rl_error)?;
    agent.train(&mut env, opts.episodes, on_episode).map_err(rl_error)?;
    let space = env.space();
    let scale = match opts.mill.preset {
        Preset::Paper => opts.mill.paper_scale_mm,
        Preset::Shop => 1.0,
    };
    let info = PolicyInfo {
        encoder: "geometric".into(),
        hidden: opts.dqn.hidden.clone(),
        state_dim: env.state_dim(),
        radii: space.radii.iter().map(|r| r / scale).collect(),
        layer_heights: space.layer_heights.iter().map(|h| h / scale).collect(),
        strategies: space.strategies.iter().map(|s| s.name().to_owned()).collect(),
        trained_on: parts.iter().map(|(n, _)| n.clone()).collect(),
        episodes: opts.episodes as u64,
        seed: opts.seed,
        resolution: opts.mill.resolution,
    };
    Ok(LearnedPolicy { encoder: GeometricEncoder { radii: info.radii.len() }, agent, info })
}

/// The reward of the step that machined `run`'s latest setup: `λ_s R_s` (Eq. 10), plus
/// `λ_f R_f + λ_MRR R_MRR` (Eq. 11-12, `R_MRR` in cm³/min) once every setup is machined.
fn step_reward(run: &MillRun, w: &RewardWeights) -> Result<f64, MillError> {
    let r = run.rewards(w)?;
    let mut reward = w.lambda_s * r.preservation;
    if run.next_setup().is_none() {
        reward += w.lambda_f * r.final_iou + w.lambda_mrr * run.report().mrr_mm3_per_min / 1000.0;
    }
    Ok(reward)
}

/// Rewards follow each setup only in the per-setup layout.
fn per_setup(opts: &MillOptions) -> MillOptions {
    MillOptions { layout: crate::pipeline::ProgramLayout::PerSetup, ..opts.clone() }
}
