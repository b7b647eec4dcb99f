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
//! That split is [`RewardShaping::Terminal`]. The state carries no machining time, so the
//! time a slow tool spends on an early setup reaches no step's reward that the Q-network
//! can trace to it: the last step's state is the same whichever tool came before. With
//! [`RewardShaping::Telescoped`] (`s2g train --reward-shaping telescoped`) each step is
//! paid `λ_MRR` times the change it made to the removal rate of the setups machined so
//! far; the terms telescope, so an episode's return is still Eq. 13.
//!
//! A deterministic environment repeats itself: the outcome of every action sequence tried
//! is kept, and an episode simulates only when it leaves what was tried. It then continues
//! a copy of the run at the longest prefix of its actions that was simulated (copies are
//! kept for the most recent [`MachiningEnv::SNAPSHOTS`] prefixes and for every part's
//! start), so no setup is machined twice while its copy is kept.

mod env;
mod policy;

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

pub use self::env::{MachiningEnv, RewardShaping, TrainOptions};
pub use self::policy::{DgcnnShape, LearnedPolicy, PolicyInfo, train_policy};

fn rl_error(e: RlError) -> MillError {
    MillError::Learning(e)
}

fn encode_error(what: &'static str, e: serde_json::Error) -> MillError {
    MillError::Encode { what, source: Box::new(e) }
}

/// Rewards follow each setup only in the per-setup layout.
fn per_setup(opts: &MillOptions) -> MillOptions {
    MillOptions { layout: crate::pipeline::ProgramLayout::PerSetup, ..opts.clone() }
}
