//! [`LearnedPolicy`]: a trained Q-network as a [`Policy`], its policy files, and
//! [`train_policy`].

use super::*;

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
    /// Whether its rewards paid the removal rate step by step
    /// ([`RewardShaping::Telescoped`]); fine-tuning keeps the rule. Absent (false: the
    /// paper's [`RewardShaping::Terminal`]) in files written before the option.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub telescoped: bool,
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

pub(super) const POLICY_MAGIC: &[u8; 10] = b"S2GPOLICY\n";

/// The bytes of [`LearnedPolicy::bundled`].
pub(super) const BUNDLED_POLICY: &[u8] = include_bytes!("../../assets/policy/learned.s2gp");

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

    /// Which of the policy's actions `space` keeps: for each action of the space the
    /// policy was trained on (normalised units for the paper preset: `scale` is millimetres
    /// per unit, 1 for the shop preset), the same action's index in `space`, or `None` where
    /// `space` left its clearing strategy out. `None` when `space` is not the policy's space
    /// with some strategies left out (other radii or layers, a strategy it never saw).
    fn action_map(&self, space: &ActionSpace, scale: f64) -> Option<Vec<Option<usize>>> {
        let close = |a: &[f64], b: &[f64]| {
            a.len() == b.len()
                && a.iter().zip(b).all(|(x, y)| (x * scale - y).abs() <= 1e-9 * y.abs().max(1.0))
        };
        let known = |s: &crate::StrategyKind| self.info.strategies.iter().any(|n| n == s.name());
        if !close(&self.info.radii, &space.radii)
            || !close(&self.info.layer_heights, &space.layer_heights)
            || !space.strategies.iter().all(known)
        {
            return None;
        }
        let kept: Vec<Option<usize>> = (self.info.strategies.iter())
            .map(|n| space.strategies.iter().position(|s| s.name() == n))
            .collect();
        let (ns, ns_kept) = (self.info.strategies.len(), space.strategies.len());
        let actions = self.info.radii.len() * self.info.layer_heights.len() * ns;
        Some((0..actions).map(|i| kept[i % ns].map(|k| i / ns * ns_kept + k)).collect())
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
        env.set_shaping(match self.info.telescoped {
            true => RewardShaping::Telescoped,
            false => RewardShaping::Terminal,
        });
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

impl Policy for LearnedPolicy {
    fn choose(&mut self, ctx: &SetupContext<'_>) -> Action {
        let scale = ctx.space.radii.first().zip(self.info.radii.first()).map_or(1.0, |(a, b)| a / b);
        // With strategies left out (Table 4's ablation) the policy chooses the best of the
        // actions that are left. In another action space (the shop preset's tools) the
        // Q-network's actions mean nothing, so the heuristic decides; so it does if acting
        // fails.
        let learned = self.action_map(ctx.space, scale).and_then(|map| {
            let state = observation(&self.encoder, ctx);
            let allowed: Vec<bool> = map.iter().map(Option::is_some).collect();
            let a = self.agent.act_among(&state, &allowed).ok()??;
            ctx.space.action(map[a]?)
        });
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
    env.set_shaping(opts.shaping);
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
        telescoped: opts.shaping == RewardShaping::Telescoped,
    };
    Ok(LearnedPolicy { encoder: env.encoder, agent, info, deferred: 0 })
}
