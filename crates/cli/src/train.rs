//! `s2g train`: train the DQN policy on a corpus of meshes (seed 000 Appendix A.1).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use std::io::IsTerminal;

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use shape2gcode::rl::DgcnnConfig;
use shape2gcode::voxsim::RewardWeights;
use shape2gcode::{EncoderKind, RewardShaping, SetupCount, TrainOptions, train_policy};

use crate::eval::parts;

/// Arguments of `s2g train`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The meshes to train on.
    meshes: Vec<PathBuf>,
    /// Train on every STL, OBJ, PLY, glTF or GLB file in this folder instead.
    #[arg(long)]
    corpus: Option<PathBuf>,
    /// Training episodes (one part each).
    #[arg(long, default_value_t = 300)]
    episodes: usize,
    /// Seed of the agent and of the parts' order.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Where to write the policy.
    #[arg(short, long)]
    output: PathBuf,
    /// Simulation resolution of the training episodes.
    #[arg(long, default_value_t = 48)]
    res: usize,
    /// Action space: `paper` (the paper's tools in units of the part) or `grid` (the
    /// paper's tools as its 256^3 grid sees them, scaled by 256 / --res: 0.26-2.56 voxels of
    /// radius at 64^3, so that the choice of tool shows in the reward).
    #[arg(long, default_value = "paper")]
    space: String,
    /// Setups per part.
    #[arg(long, default_value_t = 3)]
    setups: usize,
    /// Surface points for orientation selection.
    #[arg(long, default_value_t = 2048)]
    points: usize,
    /// Shape encoder of the states: `geometric` (the cheap descriptor), `geometric-res`
    /// (with the reach at the grid's resolution added) or `dgcnn`
    /// (DGCNN on the setup's surface points, seeded frozen weights).
    #[arg(long, default_value = "geometric")]
    encoder: String,
    /// Reward weights `LAMBDA_S,LAMBDA_F,LAMBDA_MRR` of Eq. 13 (a zero drops its term, as in
    /// the paper's Table 5).
    #[arg(long, default_value = "1,1,0.1")]
    reward_weights: String,
    /// How the removal rate's term of Eq. 13 is paid among an episode's steps: `terminal`
    /// (the paper's: all of it on the last step) or `telescoped` (each step the change it
    /// made to the removal rate of the setups so far, so that a slow tool costs the step
    /// that chose it). Both sum to Eq. 13 over an episode.
    #[arg(long, default_value = "terminal")]
    reward_shaping: String,
    /// Gradient updates per environment step (each on its own batch): more extract more from
    /// each costly simulated setup.
    #[arg(long, default_value_t = 1)]
    updates_per_step: u32,
    /// Steps over which exploration decays from 1 to 0.01 (default: the first two thirds
    /// of the steps asked for). Fixing it lets a shorter run of the same seed take exactly
    /// the first episodes of a longer one, replayed from its outcome file.
    #[arg(long)]
    epsilon_decay_steps: Option<u64>,
    /// Double-DQN targets: the next state's action is chosen by the online network and
    /// valued by the target network, which removes most of the upward bias of the plain
    /// DQN's maximum over many noisy action values.
    #[arg(long)]
    double: bool,
    /// Outcome file: read first (steps an earlier training simulated are not simulated
    /// again, whatever its encoder, seed or reward weights) and written after training.
    #[arg(long)]
    outcomes: Option<PathBuf>,
    /// Print a JSON summary.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let parts = parts(&args.meshes, args.corpus.as_deref())?;
    let defaults = TrainOptions::default();
    let encoder = match args.encoder.as_str() {
        "geometric" => EncoderKind::Geometric,
        "geometric-res" => EncoderKind::GeometricAtResolution,
        "dgcnn" => EncoderKind::Dgcnn(DgcnnConfig { seed: args.seed, ..DgcnnConfig::default() }),
        e => bail!("unknown encoder {e:?} (geometric, geometric-res or dgcnn)"),
    };
    let w: Vec<f64> = args
        .reward_weights
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .ok()
        .filter(|w: &Vec<f64>| w.len() == 3 && w.iter().all(|x| x.is_finite() && *x >= 0.0))
        .with_context(|| {
            format!("--reward-weights needs three weights >= 0, got {:?}", args.reward_weights)
        })?;
    let weights = RewardWeights { lambda_s: w[0], lambda_f: w[1], lambda_mrr: w[2] };
    let Some(shaping) = RewardShaping::from_name(&args.reward_shaping) else {
        bail!("unknown reward shaping {:?} (terminal or telescoped)", args.reward_shaping)
    };
    let opts = TrainOptions {
        episodes: args.episodes,
        seed: args.seed,
        mill: shape2gcode::MillOptions {
            resolution: args.res,
            paper_space_scale: crate::mill::parse_space(&args.space, args.res)?,
            orient_points: args.points,
            setups: SetupCount::Exactly(args.setups.max(1)),
            seed: args.seed,
            ..defaults.mill
        },
        // Explore over the first two thirds of the steps, as the defaults do for 300 episodes.
        dqn: shape2gcode::rl::DqnConfig {
            epsilon_decay_steps: args
                .epsilon_decay_steps
                .unwrap_or(2 * args.episodes as u64 * args.setups.max(1) as u64 / 3)
                .max(1),
            updates_per_train: args.updates_per_step,
            double: args.double,
            ..defaults.dqn
        },
        encoder,
        weights,
        outcomes: args.outcomes.clone(),
        shaping,
    };
    let bar = ProgressBar::new(args.episodes as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed} [{bar:24}] {pos}/{len} episodes, {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let t = Instant::now();
    let log_lines = !std::io::stderr().is_terminal();
    let mut returns = Vec::with_capacity(args.episodes);
    let policy = train_policy(&parts, &opts, &mut |e| {
        returns.push(e.total_reward);
        bar.set_position(e.episode + 1);
        bar.set_message(format!("return {:.4}, epsilon {:.3}", e.total_reward, e.epsilon));
        if !log_lines {
            return;
        }
        // Without a terminal the bar is hidden: one line per episode instead.
        eprintln!(
            "s2g train: episode {}/{} return {:.4} epsilon {:.3} ({:.0} s)",
            e.episode + 1,
            args.episodes,
            e.total_reward,
            e.epsilon,
            t.elapsed().as_secs_f64()
        );
    })
    .context("training")?;
    bar.finish_and_clear();
    let seconds = t.elapsed().as_secs_f64();
    policy.save(&args.output)?;
    let tail = &returns[returns.len().saturating_sub(20)..];
    let mean_last = tail.iter().map(|&r| f64::from(r)).sum::<f64>() / tail.len().max(1) as f64;
    if args.json {
        let summary = serde_json::json!({
            "output": args.output.display().to_string(),
            "parts": policy.info().trained_on,
            "episodes": args.episodes,
            "seconds": seconds,
            "encoder": policy.info().encoder,
            "mean_return_last_20": mean_last,
            "returns": returns,
        });
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        println!(
            "trained on {} part(s), {} episodes in {seconds:.1} s; mean return of the last {} episodes {mean_last:.4}; wrote {}",
            parts.len(),
            args.episodes,
            tail.len(),
            args.output.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}
