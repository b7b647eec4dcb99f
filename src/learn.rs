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
//! is kept, and an episode simulates only when it leaves what was tried. It then continues
//! a copy of the run at the longest prefix of its actions that was simulated (copies are
//! kept for the most recent [`MachiningEnv::SNAPSHOTS`] prefixes and for every part's
//! start), so no setup is machined twice while its copy is kept.

use std::collections::{HashMap, VecDeque};
use std::path::Path;

use s2g_rl::{DgcnnConfig, DgcnnEncoder, Dqn, DqnConfig, Encoder, Environment, EpisodeStats, RlError, Step};
use serde::{Deserialize, Serialize};

use crate::geom::Mesh;
use crate::pipeline::{MillError, MillOptions, MillRun, Preset, SetupCount};
use crate::policy::{Action, ActionSpace, Policy, SetupContext, SetupFeatures};
use crate::voxsim::RewardWeights;

/// The cheap geometric shape descriptor: for each tool radius, how much of the visible
/// surface it reaches (relative to the smallest tool); the fraction of the part visible
/// from the setup; the histogram of where that surface lies along the tool axis. With
/// [`at_resolution`](Self::at_resolution), also for each radius how much it reaches to
/// within half a voxel of the simulation grid ([`SetupFeatures::reach_at_resolution`],
/// relative to the smallest tool): what a finer tool buys that the simulation, and so the
/// reward, can see.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GeometricEncoder {
    /// Radii of the action space.
    pub radii: usize,
    /// Add the reach at the grid's resolution ([`EncoderKind::GeometricAtResolution`]).
    pub at_resolution: bool,
}

impl Encoder for GeometricEncoder {
    type Input = SetupFeatures;

    fn dim(&self) -> usize {
        self.radii * (1 + self.at_resolution as usize) + 1 + SetupFeatures::DEPTH_BINS
    }

    fn encode(&self, f: &SetupFeatures) -> Vec<f32> {
        let relative = |reach: &[f64]| -> Vec<f32> {
            let best = reach.first().copied().filter(|&r| r > 0.0).unwrap_or(1.0);
            (0..self.radii).map(|i| reach.get(i).map_or(0.0, |&r| (r / best) as f32)).collect()
        };
        let mut out = relative(&f.reach_by_radius);
        if self.at_resolution {
            out.extend(relative(&f.reach_at_resolution));
        }
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

/// The shape encoders a policy can read its states from.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum EncoderKind {
    /// The cheap [`GeometricEncoder`] (the default).
    #[default]
    Geometric,
    /// The [`GeometricEncoder`] with the reach at the grid's resolution added.
    GeometricAtResolution,
    /// A DGCNN ([`DgcnnEncoder`], seed 000 §3.5) on the setup's visible surface samples
    /// ([`SetupFeatures::points`]). Its weights are the config's seeded initialisation,
    /// frozen: no pretrained DGCNN can be had offline, and the Q-network learns on top of
    /// the random EdgeConv features.
    Dgcnn(DgcnnConfig),
}

/// A built encoder of [`SetupFeatures`]: what [`EncoderKind`] names.
pub enum SetupEncoder {
    /// See [`GeometricEncoder`].
    Geometric(GeometricEncoder),
    /// See [`EncoderKind::Dgcnn`].
    Dgcnn(Box<DgcnnEncoder>),
}

impl std::fmt::Debug for SetupEncoder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Geometric(g) => f.debug_tuple("Geometric").field(g).finish(),
            Self::Dgcnn(d) => f.debug_tuple("Dgcnn").field(d.config()).finish(),
        }
    }
}

impl SetupEncoder {
    /// The encoder `kind` names for an action space of `radii` tool radii.
    pub fn new(kind: &EncoderKind, radii: usize) -> Result<Self, MillError> {
        Ok(match kind {
            EncoderKind::Geometric => Self::Geometric(GeometricEncoder { radii, at_resolution: false }),
            EncoderKind::GeometricAtResolution => {
                Self::Geometric(GeometricEncoder { radii, at_resolution: true })
            }
            EncoderKind::Dgcnn(config) => {
                Self::Dgcnn(Box::new(DgcnnEncoder::new(config.clone()).map_err(rl_error)?))
            }
        })
    }

    /// The name policy files give it: `geometric`, `geometric-res` or `dgcnn`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Geometric(g) if g.at_resolution => "geometric-res",
            Self::Geometric(_) => "geometric",
            Self::Dgcnn(_) => "dgcnn",
        }
    }
}

impl Encoder for SetupEncoder {
    type Input = SetupFeatures;

    fn dim(&self) -> usize {
        match self {
            Self::Geometric(g) => g.dim(),
            Self::Dgcnn(d) => d.dim(),
        }
    }

    fn encode(&self, f: &SetupFeatures) -> Vec<f32> {
        match self {
            Self::Geometric(g) => g.encode(f),
            Self::Dgcnn(d) => d.encode(&f.points),
        }
    }
}

/// The state the Q-network reads: the encoder's features, then the setup's index over the
/// number of setups and the fraction of the stock still to remove.
pub fn observation(encoder: &impl Encoder<Input = SetupFeatures>, ctx: &SetupContext<'_>) -> Vec<f32> {
    let mut s = encoder.encode(ctx.features);
    s.push(ctx.index as f32 / ctx.setups.max(1) as f32);
    s.push(ctx.features.removal_fraction.clamp(0.0, 1.0) as f32);
    s
}

/// What the state of a setup is made of: its features (the removal fraction as left by
/// the setups before it), its index and the number of setups.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct View {
    features: SetupFeatures,
    index: usize,
    setups: usize,
}

impl View {
    /// The view of `run`'s next setup.
    fn of(run: &MillRun) -> Self {
        Self { features: run.features(), index: run.machined().len(), setups: run.setup_count() }
    }

    fn state(&self, encoder: &SetupEncoder, space: &ActionSpace) -> Vec<f32> {
        let ctx = SetupContext { index: self.index, setups: self.setups, space, features: &self.features };
        observation(encoder, &ctx)
    }
}

/// What one step gave, whatever the encoder and the reward weights, so that it can be
/// kept, shared by trainings and written to an [outcome file](MachiningEnv::save_outcomes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Outcome {
    /// `R_s` after the step (Eq. 10).
    preservation: f64,
    /// `R_f` (Eq. 11) after the last step, 0 before.
    final_iou: f64,
    /// `R_MRR` (Eq. 12, cm³/min) after the last step, 0 before.
    mrr_cm3_per_min: f64,
    /// The next setup; `None` once every setup is machined.
    next: Option<View>,
}

impl Outcome {
    /// The outcome of the step that machined `run`'s latest setup.
    fn of(run: &MillRun) -> Result<Self, MillError> {
        let r = run.rewards(&RewardWeights::default())?;
        let last = run.next_setup().is_none();
        Ok(Self {
            preservation: r.preservation,
            final_iou: if last { r.final_iou } else { 0.0 },
            mrr_cm3_per_min: if last { run.report().mrr_mm3_per_min / 1000.0 } else { 0.0 },
            next: (!last).then(|| View::of(run)),
        })
    }

    /// The step: `λ_s R_s`, plus `λ_f R_f + λ_MRR R_MRR` on the last step (Eq. 13).
    fn step(&self, w: &RewardWeights, encoder: &SetupEncoder, space: &ActionSpace) -> Step {
        let reward = w.lambda_s * self.preservation
            + w.lambda_f * self.final_iou
            + w.lambda_mrr * self.mrr_cm3_per_min;
        let state = match &self.next {
            Some(view) => view.state(encoder, space),
            None => vec![0.0; encoder.dim() + 2],
        };
        Step { state, reward: reward as f32, done: self.next.is_none() }
    }
}

/// One line of an outcome file: a part's first view (empty prefix) or a step's outcome.
#[derive(Debug, Serialize, Deserialize)]
struct OutcomeLine {
    /// The part's [fingerprint](MachiningEnv::fingerprint).
    part: String,
    prefix: Vec<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    first: Option<View>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    outcome: Option<Outcome>,
}

/// The first line of an outcome file. Outcomes are what this build's pipeline gives: a
/// change to planning, simulation or features that changes them must change this line, so
/// that older files are refused rather than trusted.
const OUTCOME_MAGIC: &str = concat!("S2GOUTCOMES 1 shape2gcode ", env!("CARGO_PKG_VERSION"));

/// Options of [`train_policy`] and of the machining environment.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainOptions {
    /// Episodes (the paper trains 300).
    pub episodes: usize,
    /// Seed of the agent (weights, exploration, replay) and of the parts' order.
    pub seed: u64,
    /// How each episode mills its part. Default: the paper preset on a 48³ grid, 2,048
    /// orientation points, 128 candidates, at most three setups, and the paper's
    /// front-facing visibility (`flank_walls: false`, what the shipped policy learned on):
    /// small enough to train in minutes on two cores.
    pub mill: MillOptions,
    /// Reward weights (Eq. 13). Default: the paper's 1, 1, 0.1; a zero weight drops its term
    /// (Table 5's ablations).
    pub weights: RewardWeights,
    /// The agent. Default: the paper's network (two layers of 128, Adam 1e-3, γ 0.95,
    /// ε 1 → 0.01) with the buffer, batch and schedule scaled to a few hundred steps.
    pub dqn: DqnConfig,
    /// The shape encoder of the states. Default [`EncoderKind::Geometric`].
    pub encoder: EncoderKind,
    /// An outcome file ([`MachiningEnv::save_outcomes`]): read before training, so that
    /// what an earlier training (any encoder, seed or reward weights) simulated is not
    /// simulated again, written as training goes ([`MachiningEnv::autosave`]) and after it.
    /// Default `None`.
    pub outcomes: Option<std::path::PathBuf>,
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
                flank_walls: false,
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
            encoder: EncoderKind::Geometric,
            outcomes: None,
        }
    }
}

/// The machining environment: one episode mills one part of the corpus, one step one setup.
pub struct MachiningEnv {
    parts: Vec<(String, Mesh)>,
    /// Per part: its name, a hash of its mesh and one of the milling options.
    fingerprints: Vec<String>,
    opts: MillOptions,
    weights: RewardWeights,
    encoder: SetupEncoder,
    space: ActionSpace,
    /// The part of the current episode and the actions taken so far.
    part: usize,
    taken: Vec<usize>,
    /// Every (part, action prefix) tried: what it gave.
    outcomes: HashMap<(usize, Vec<usize>), Outcome>,
    /// Per part: the view of its first setup.
    first: HashMap<usize, View>,
    /// Per part: its run before any setup is machined (made when first needed).
    bases: HashMap<usize, MillRun>,
    /// Runs after the setups of a (part, action prefix), the most recent first out of
    /// `order` once there are more than [`SNAPSHOTS`](Self::SNAPSHOTS).
    snapshots: HashMap<(usize, Vec<usize>), MillRun>,
    order: VecDeque<(usize, Vec<usize>)>,
    /// Where new outcomes are written as they come ([`autosave`](Self::autosave)), and how
    /// many came since the last write.
    autosave: Option<(std::path::PathBuf, usize)>,
}

impl MachiningEnv {
    /// An environment over `parts` (named meshes) milled with `opts`, rewarded with
    /// `weights`, its states from the geometric encoder.
    pub fn new(
        parts: Vec<(String, Mesh)>,
        opts: MillOptions,
        weights: RewardWeights,
    ) -> Result<Self, MillError> {
        Self::with_encoder(parts, opts, weights, &EncoderKind::Geometric)
    }

    /// [`new`](Self::new) with the states from `encoder`.
    pub fn with_encoder(
        parts: Vec<(String, Mesh)>,
        opts: MillOptions,
        weights: RewardWeights,
        encoder: &EncoderKind,
    ) -> Result<Self, MillError> {
        if parts.is_empty() {
            return Err(MillError::InvalidOption("the training corpus has no part".into()));
        }
        let space = opts.action_space();
        let opts = per_setup(&opts);
        Ok(Self {
            fingerprints: parts.iter().map(|(name, mesh)| Self::fingerprint(name, mesh, &opts)).collect(),
            parts,
            encoder: SetupEncoder::new(encoder, space.radii.len())?,
            space,
            opts,
            weights,
            part: 0,
            taken: Vec::new(),
            outcomes: HashMap::new(),
            first: HashMap::new(),
            bases: HashMap::new(),
            snapshots: HashMap::new(),
            order: VecDeque::new(),
            autosave: None,
        })
    }

    /// Writes every outcome to `path` ([`save_outcomes`](Self::save_outcomes)) after each
    /// [`AUTOSAVE_EVERY`](Self::AUTOSAVE_EVERY) new simulated steps, so that a training
    /// stopped part way keeps what it simulated.
    pub fn autosave(&mut self, path: &Path) {
        self.autosave = Some((path.to_path_buf(), 0));
    }

    /// New simulated steps between two writes of [`autosave`](Self::autosave).
    pub const AUTOSAVE_EVERY: usize = 4;

    /// Most runs kept at action prefixes besides each part's start.
    pub const SNAPSHOTS: usize = 256;

    /// The action space (planning units).
    pub fn space(&self) -> &ActionSpace {
        &self.space
    }

    /// What identifies a part's outcomes in an outcome file: its name, then an FNV-1a hash
    /// of its vertices, faces and the milling options (outcomes of another mesh or other
    /// options are not reused).
    fn fingerprint(name: &str, mesh: &Mesh, opts: &MillOptions) -> String {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bytes: &[u8]| {
            for &b in bytes {
                h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
            }
        };
        for v in mesh.vertices() {
            v.coords.iter().for_each(|c| eat(&c.to_bits().to_le_bytes()));
        }
        for f in mesh.triangles() {
            f.iter().for_each(|i| eat(&i.to_le_bytes()));
        }
        eat(format!("{opts:?}").as_bytes());
        format!("{name}#{h:016x}")
    }

    /// Reads the outcomes in `path` (written by [`save_outcomes`](Self::save_outcomes)) of
    /// this environment's parts and options, and returns how many it took. A missing file
    /// is no outcome; a file that is not an outcome file is an error. Outcomes are
    /// deterministic, so a training that reads them gives what it would have simulated.
    pub fn load_outcomes(&mut self, path: &Path) -> Result<usize, MillError> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0),
            Err(source) => return Err(MillError::Io { path: path.to_owned(), source }),
        };
        let mut lines = text.lines();
        if lines.next() != Some(OUTCOME_MAGIC) {
            return Err(MillError::BadFile {
                path: path.to_owned(),
                line: None,
                what: "not an outcome file".into(),
                source: None,
            });
        }
        let index: HashMap<&str, usize> =
            self.fingerprints.iter().enumerate().map(|(i, f)| (f.as_str(), i)).collect();
        let mut taken = 0;
        for (n, line) in lines.enumerate() {
            let entry: OutcomeLine = serde_json::from_str(line).map_err(|e| MillError::BadFile {
                path: path.to_owned(),
                line: Some(n + 2),
                what: "not an outcome".into(),
                source: Some(e.into()),
            })?;
            let Some(&part) = index.get(entry.part.as_str()) else { continue };
            if entry.prefix.iter().any(|&a| a >= self.space.len()) {
                continue;
            }
            if let Some(view) = entry.first {
                self.first.insert(part, view);
                taken += 1;
            }
            if let Some(outcome) = entry.outcome {
                self.outcomes.insert((part, entry.prefix), outcome);
                taken += 1;
            }
        }
        Ok(taken)
    }

    /// Writes every outcome this environment knows to `path`, atomically, in a fixed
    /// order (one JSON line each after a magic line).
    pub fn save_outcomes(&self, path: &Path) -> Result<(), MillError> {
        let mut lines: Vec<(usize, Vec<usize>, String)> = Vec::new();
        let json = |e: &OutcomeLine| serde_json::to_string(e).map_err(|e| encode_error("an outcome", e));
        for (&part, view) in &self.first {
            let e = OutcomeLine {
                part: self.fingerprints[part].clone(),
                prefix: Vec::new(),
                first: Some(view.clone()),
                outcome: None,
            };
            lines.push((part, Vec::new(), json(&e)?));
        }
        for ((part, prefix), outcome) in &self.outcomes {
            let e = OutcomeLine {
                part: self.fingerprints[*part].clone(),
                prefix: prefix.clone(),
                first: None,
                outcome: Some(outcome.clone()),
            };
            lines.push((*part, prefix.clone(), json(&e)?));
        }
        lines.sort();
        let mut text = String::from(OUTCOME_MAGIC);
        text.push('\n');
        for (_, _, l) in lines {
            text.push_str(&l);
            text.push('\n');
        }
        crate::geom::write_bytes_atomic(path, text.as_bytes())?;
        Ok(())
    }

    /// Starts an episode on `part`: its first state, computed once per part.
    fn start(&mut self, part: usize) -> Result<Vec<f32>, MillError> {
        self.part = part;
        self.taken.clear();
        if !self.first.contains_key(&part) {
            let view = View::of(self.base(part)?);
            self.first.insert(part, view);
        }
        Ok(self.first[&part].state(&self.encoder, &self.space))
    }

    /// `part`'s run before any setup (made the first time it is asked for).
    fn base(&mut self, part: usize) -> Result<&MillRun, MillError> {
        if !self.bases.contains_key(&part) {
            let mut run = MillRun::new(&self.parts[part].1, &self.opts, &mut |_| {})?;
            // Only the outcomes are wanted: programs stream from planner to simulator, and
            // the copies kept to continue from (every run here descends from this one) hold
            // no text or trace.
            run.keep_programs(false);
            self.bases.insert(part, run);
        }
        Ok(&self.bases[&part])
    }

    /// A run after the current episode's actions: a copy of the one kept at the longest
    /// prefix of them, with the setups after that prefix machined.
    fn run_at_taken(&mut self) -> Result<MillRun, MillError> {
        let part = self.part;
        let mut done = self.taken.len();
        let mut run = loop {
            if done == 0 {
                break self.base(part)?.clone();
            }
            if let Some(run) = self.snapshots.get(&(part, self.taken[..done].to_vec())) {
                break run.clone();
            }
            done -= 1;
        };
        for k in done..self.taken.len() {
            let a = self.taken[k];
            let action = self.space.action(a).ok_or_else(|| bad_action(a, self.space.len()))?;
            run.machine(action, &mut |_| {})?;
            self.keep(part, self.taken[..=k].to_vec(), run.clone());
        }
        Ok(run)
    }

    /// Keeps `run`, the run after `prefix`, unless it is complete.
    fn keep(&mut self, part: usize, prefix: Vec<usize>, run: MillRun) {
        if run.next_setup().is_none() || self.snapshots.contains_key(&(part, prefix.clone())) {
            return;
        }
        if self.order.len() >= Self::SNAPSHOTS
            && let Some(old) = self.order.pop_front()
        {
            self.snapshots.remove(&old);
        }
        self.order.push_back((part, prefix.clone()));
        self.snapshots.insert((part, prefix), run);
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
        if let Some(outcome) = self.outcomes.get(&key) {
            self.taken.push(action);
            return Ok(outcome.step(&self.weights, &self.encoder, &self.space));
        }
        let mut run = self.run_at_taken()?;
        let chosen = self.space.action(action).ok_or_else(|| bad_action(action, self.space.len()))?;
        run.machine(chosen, &mut |_| {})?;
        self.taken.push(action);
        let outcome = Outcome::of(&run)?;
        // The run is kept, not copied: a later step continues a copy of it.
        self.keep(self.part, self.taken.clone(), run);
        let step = outcome.step(&self.weights, &self.encoder, &self.space);
        self.outcomes.insert(key, outcome);
        if let Some((path, new)) = self.autosave.as_mut() {
            *new += 1;
            if *new >= Self::AUTOSAVE_EVERY {
                *new = 0;
                let path = path.clone();
                self.save_outcomes(&path)?;
            }
        }
        Ok(step)
    }
}

/// What a policy file says about how its network was made.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PolicyInfo {
    /// The encoder its states come from (`geometric` or `dgcnn`).
    pub encoder: String,
    /// The DGCNN's shape when `encoder` is `dgcnn` (its weights are its seed's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dgcnn: Option<DgcnnShape>,
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
    /// Whether it was trained with double-DQN targets ([`DqnConfig::double`]); fine-tuning
    /// keeps the rule. Absent (false) in files written before the option.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub double: bool,
}

/// The shape and seed of a policy's DGCNN encoder, as its file states them.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct DgcnnShape {
    /// Neighbours per point.
    pub k: usize,
    /// EdgeConv widths.
    pub edge_widths: Vec<usize>,
    /// Embedding width (features are twice as long).
    pub embedding: usize,
    /// Seed of the weights.
    pub seed: u64,
}

impl DgcnnShape {
    fn of(config: &DgcnnConfig) -> Self {
        Self {
            k: config.k,
            edge_widths: config.edge_widths.clone(),
            embedding: config.embedding,
            seed: config.seed,
        }
    }

    fn config(&self) -> DgcnnConfig {
        DgcnnConfig {
            k: self.k,
            edge_widths: self.edge_widths.clone(),
            embedding: self.embedding,
            seed: self.seed,
            ..DgcnnConfig::default()
        }
    }
}

/// A trained DQN as a [`Policy`]: the greedy action of its Q-network on the setup's state.
pub struct LearnedPolicy {
    agent: Dqn,
    info: PolicyInfo,
    encoder: SetupEncoder,
    /// Setups the heuristic chose for it (another action space, or acting failed).
    deferred: usize,
}

const POLICY_MAGIC: &[u8; 10] = b"S2GPOLICY\n";

/// The bytes of [`LearnedPolicy::bundled`].
const BUNDLED_POLICY: &[u8] = include_bytes!("../assets/policy/learned.s2gp");

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

    /// The policy shipped in the crate (`assets/policy/learned.s2gp`, built in): trained by
    /// `s2g train` on the repository's training split of meshes, never on its evaluation
    /// split (`assets/policy/README.md` says which and how).
    pub fn bundled() -> Result<Self, MillError> {
        Self::from_bytes(BUNDLED_POLICY, Path::new("assets/policy/learned.s2gp"))
    }

    /// `learned` (the [bundled](Self::bundled) policy) or the path of a policy file.
    pub fn named(name: &str) -> Result<Self, MillError> {
        if name == "learned" { Self::bundled() } else { Self::load(Path::new(name)) }
    }

    /// Reads a policy file written by [`save`](Self::save).
    pub fn load(path: &Path) -> Result<Self, MillError> {
        let bytes = std::fs::read(path).map_err(|source| MillError::Io { path: path.to_owned(), source })?;
        Self::from_bytes(&bytes, path)
    }

    fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, MillError> {
        let bad = |why: String| MillError::BadFile {
            path: path.to_owned(),
            line: None,
            what: format!("not a policy file: {why}"),
            source: None,
        };
        let rest = bytes.strip_prefix(POLICY_MAGIC.as_slice()).ok_or_else(|| bad("bad magic".into()))?;
        let eol = rest.iter().position(|&b| b == b'\n').ok_or_else(|| bad("no header line".into()))?;
        let info: PolicyInfo = serde_json::from_slice(&rest[..eol]).map_err(|e| bad(e.to_string()))?;
        let config = DqnConfig { hidden: info.hidden.clone(), ..DqnConfig::default() };
        let agent = Dqn::from_bytes(&rest[eol + 1..], config).map_err(|e| bad(e.to_string()))?;
        let kind = match (info.encoder.as_str(), &info.dgcnn) {
            ("geometric", _) => EncoderKind::Geometric,
            ("geometric-res", _) => EncoderKind::GeometricAtResolution,
            ("dgcnn", Some(shape)) => EncoderKind::Dgcnn(shape.config()),
            (e, _) => return Err(bad(format!("unknown encoder {e:?}"))),
        };
        let encoder = SetupEncoder::new(&kind, info.radii.len()).map_err(|e| bad(e.to_string()))?;
        if agent.state_dim() != encoder.dim() + 2 || agent.state_dim() != info.state_dim {
            return Err(bad(format!(
                "states of {} values, the {} encoder gives {}",
                agent.state_dim(),
                encoder.name(),
                encoder.dim() + 2
            )));
        }
        let actions = info.radii.len() * info.layer_heights.len() * info.strategies.len();
        if agent.num_actions() != actions {
            return Err(bad(format!("{} actions for an action space of {actions}", agent.num_actions())));
        }
        Ok(Self { agent, info, encoder, deferred: 0 })
    }

    /// Writes the policy atomically: a magic line, a JSON line of [`PolicyInfo`], then the
    /// Q-network's checkpoint.
    pub fn save(&self, path: &Path) -> Result<(), MillError> {
        let mut bytes = POLICY_MAGIC.to_vec();
        bytes.extend(serde_json::to_vec(&self.info).map_err(|e| encode_error("a policy header", e))?);
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

    /// The kind of encoder the policy reads.
    fn encoder_kind(&self) -> EncoderKind {
        match &self.encoder {
            SetupEncoder::Geometric(g) if g.at_resolution => EncoderKind::GeometricAtResolution,
            SetupEncoder::Geometric(_) => EncoderKind::Geometric,
            SetupEncoder::Dgcnn(d) => EncoderKind::Dgcnn(d.config().clone()),
        }
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
            double: self.info.double,
            ..opts.dqn.clone()
        };
        let bytes = self.agent.to_bytes().map_err(rl_error)?;
        let mut agent = Dqn::from_bytes(&bytes, DqnConfig { seed: opts.seed, ..config }).map_err(rl_error)?;
        let mut env = MachiningEnv::with_encoder(
            vec![(name.to_owned(), mesh.clone())],
            opts.mill.clone(),
            opts.weights,
            &self.encoder_kind(),
        )?;
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
    MillError::Learning(e)
}

fn encode_error(what: &'static str, e: serde_json::Error) -> MillError {
    MillError::Encode { what, source: Box::new(e) }
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
        learned.unwrap_or_else(|| {
            self.deferred += 1;
            crate::policy::HeuristicPolicy::default().choose(ctx)
        })
    }

    /// `learned`, or `learned (heuristic)` once the heuristic has chosen for it, so that a
    /// report says which rule chose its actions.
    fn name(&self) -> String {
        if self.deferred == 0 { "learned".into() } else { "learned (heuristic)".into() }
    }
}

/// Trains a policy on `parts` (Algorithm: DQN, seed 000 Appendix A.1); `on_episode` is told
/// after each episode.
pub fn train_policy(
    parts: &[(String, Mesh)],
    opts: &TrainOptions,
    on_episode: &mut dyn FnMut(EpisodeStats),
) -> Result<LearnedPolicy, MillError> {
    let mut env = MachiningEnv::with_encoder(parts.to_vec(), opts.mill.clone(), opts.weights, &opts.encoder)?;
    if let Some(path) = &opts.outcomes {
        env.load_outcomes(path)?;
        env.autosave(path);
    }
    let mut agent =
        Dqn::for_env(DqnConfig { seed: opts.seed, ..opts.dqn.clone() }, &env).map_err(rl_error)?;
    let trained = agent.train(&mut env, opts.episodes, on_episode).map_err(rl_error);
    // What was simulated is kept even when training failed part way.
    if let Some(path) = &opts.outcomes {
        env.save_outcomes(path)?;
    }
    trained?;
    let space = env.space();
    let scale = match opts.mill.preset {
        Preset::Paper => opts.mill.paper_scale_mm,
        Preset::Shop => 1.0,
    };
    let info = PolicyInfo {
        encoder: env.encoder.name().into(),
        dgcnn: match &opts.encoder {
            EncoderKind::Geometric | EncoderKind::GeometricAtResolution => None,
            EncoderKind::Dgcnn(config) => Some(DgcnnShape::of(config)),
        },
        hidden: opts.dqn.hidden.clone(),
        state_dim: env.state_dim(),
        radii: space.radii.iter().map(|r| r / scale).collect(),
        layer_heights: space.layer_heights.iter().map(|h| h / scale).collect(),
        strategies: space.strategies.iter().map(|s| s.name().to_owned()).collect(),
        trained_on: parts.iter().map(|(n, _)| n.clone()).collect(),
        episodes: opts.episodes as u64,
        seed: opts.seed,
        resolution: opts.mill.resolution,
        double: opts.dqn.double,
    };
    Ok(LearnedPolicy { encoder: env.encoder, agent, info, deferred: 0 })
}

/// Rewards follow each setup only in the per-setup layout.
fn per_setup(opts: &MillOptions) -> MillOptions {
    MillOptions { layout: crate::pipeline::ProgramLayout::PerSetup, ..opts.clone() }
}
