//! [`MachiningEnv`]: the machining environment of the DQN, with its outcome cache.

use super::*;

/// What the state of a setup is made of: its features (the removal fraction as left by
/// the setups before it), its index and the number of setups.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct View {
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
        let ctx = SetupContext {
            index: self.index,
            setups: self.setups,
            space,
            features: &self.features,
            finishing: None,
        };
        observation(encoder, &ctx)
    }
}

/// What one step gave, whatever the encoder and the reward weights, so that it can be
/// kept, shared by trainings and written to an [outcome file](MachiningEnv::save_outcomes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct Outcome {
    /// `R_s` after the step (Eq. 10).
    preservation: f64,
    /// `R_f` (Eq. 11) after the last step, 0 before.
    final_iou: f64,
    /// `R_MRR` (Eq. 12, cm³/min) of the setups machined so far, this one included: the
    /// removed volume over their machining time (the episode's `R_MRR` after its last).
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
            mrr_cm3_per_min: run.report().mrr_mm3_per_min / 1000.0,
            next: (!last).then(|| View::of(run)),
        })
    }

    /// The step's reward, `λ_s R_s` plus, on the last step, `λ_f R_f`, and the removal
    /// rate's share by `shaping` (`before`: the removal rate after the step before, `None`
    /// on the first): [`RewardShaping::Terminal`] adds `λ_MRR R_MRR` on the last step (Eq. 13 as
    /// the paper splits it), [`RewardShaping::Telescoped`] adds on every step `λ_MRR`
    /// times the change this step made to the removal rate of the setups so far. Either
    /// way the rewards of an episode sum to Eq. 13.
    fn reward(&self, before: Option<f64>, w: &RewardWeights, shaping: RewardShaping) -> f64 {
        let last = self.next.is_none();
        let mrr = match shaping {
            RewardShaping::Terminal if last => self.mrr_cm3_per_min,
            RewardShaping::Terminal => 0.0,
            RewardShaping::Telescoped => self.mrr_cm3_per_min - before.unwrap_or(0.0),
        };
        w.lambda_s * self.preservation + w.lambda_f * self.final_iou + w.lambda_mrr * mrr
    }

    /// The step: its [`reward`](Self::reward) and the next state.
    fn step(&self, before: Option<f64>, env: &MachiningEnv) -> Step {
        let reward = self.reward(before, &env.weights, env.shaping);
        let state = match &self.next {
            Some(view) => view.state(&env.encoder, &env.space),
            None => vec![0.0; env.encoder.dim() + 2],
        };
        Step { state, reward: reward as f32, done: self.next.is_none() }
    }
}

/// How the removal rate's term of Eq. 13 is shared among an episode's steps
/// ([`TrainOptions::shaping`]). Both give each episode the same return (undiscounted);
/// they differ in which step is paid for the machining time a step spends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RewardShaping {
    /// The paper's split: `λ_MRR R_MRR` of the whole part on the last step only. The
    /// state carries no machining time, so a slow tool chosen on an early step costs that
    /// step nothing the Q-network can trace back to it: the last step's state is the same
    /// whichever tool came before, and its reward is not.
    #[default]
    Terminal,
    /// Each step is paid `λ_MRR` times the change it made to the removal rate of the
    /// setups machined so far (the first step, the rate of its own setup): the terms
    /// telescope to `λ_MRR R_MRR` over the episode, and a slow tool lowers the reward of
    /// the step that chose it.
    Telescoped,
}

impl RewardShaping {
    /// The name `s2g train --reward-shaping` takes: `terminal` or `telescoped`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Terminal => "terminal",
            Self::Telescoped => "telescoped",
        }
    }

    /// The shaping `name` names ([`name`](Self::name)); `None` for any other.
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::Terminal, Self::Telescoped].into_iter().find(|s| s.name() == name)
    }
}

/// One line of an outcome file: a part's first view (empty prefix) or a step's outcome.
#[derive(Debug, Serialize, Deserialize)]
pub(super) struct OutcomeLine {
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
pub(super) const OUTCOME_MAGIC: &str = concat!("S2GOUTCOMES 3 shape2gcode ", env!("CARGO_PKG_VERSION"));

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
    /// How the removal rate's term is shared among an episode's steps. Default
    /// [`RewardShaping::Terminal`], the paper's.
    pub shaping: RewardShaping,
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
            shaping: RewardShaping::Terminal,
        }
    }
}

/// The machining environment: one episode mills one part of the corpus, one step one setup.
/// The shop preset's rest roughing ([`MillOptions::rest_roughing`]) is part of a step: a
/// setup's rest passes follow its roughing within the setup, and an episode's return is
/// Eq. 13 of its setups, each `R_s` after the setup's last program, as [`Milled::total_reward`](crate::Milled::total_reward).
pub struct MachiningEnv {
    parts: Vec<(String, Mesh)>,
    /// Per part: its name, a hash of its mesh and one of the milling options.
    fingerprints: Vec<String>,
    opts: MillOptions,
    weights: RewardWeights,
    shaping: RewardShaping,
    pub(super) encoder: SetupEncoder,
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
            shaping: RewardShaping::Terminal,
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

    /// Shares the removal rate's term among the steps by `shaping` from now on (the
    /// environment starts with [`RewardShaping::Terminal`]).
    pub fn set_shaping(&mut self, shaping: RewardShaping) {
        self.shaping = shaping;
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

pub(super) fn bad_action(a: usize, n: usize) -> MillError {
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
        // The removal rate after the step before (every step's outcome is kept as it is
        // taken); `None` on the first step.
        let before = (!self.taken.is_empty())
            .then(|| self.outcomes.get(&(self.part, self.taken.clone())).map(|o| o.mrr_cm3_per_min))
            .flatten();
        if let Some(outcome) = self.outcomes.get(&key) {
            let step = outcome.step(before, self);
            self.taken.push(action);
            return Ok(step);
        }
        let mut run = self.run_at_taken()?;
        let chosen = self.space.action(action).ok_or_else(|| bad_action(action, self.space.len()))?;
        run.machine(chosen, &mut |_| {})?;
        self.taken.push(action);
        let outcome = Outcome::of(&run)?;
        // The run is kept, not copied: a later step continues a copy of it.
        self.keep(self.part, self.taken.clone(), run);
        let step = outcome.step(before, self);
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
