//! `s2g train`: train the DQN policy on a corpus of meshes (seed 000 Appendix A.1).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use shape2gcode::{SetupCount, TrainOptions, train_policy};

use crate::eval::corpus;

/// Arguments of `s2g train`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Train on every STL, OBJ, PLY, glTF or GLB file in this folder.
    #[arg(long)]
    corpus: PathBuf,
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
    /// Setups per part.
    #[arg(long, default_value_t = 3)]
    setups: usize,
    /// Surface points for orientation selection.
    #[arg(long, default_value_t = 2048)]
    points: usize,
    /// Print a JSON summary.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let parts = corpus(&args.corpus)?;
    let defaults = TrainOptions::default();
    let opts = TrainOptions {
        episodes: args.episodes,
        seed: args.seed,
        mill: shape2gcode::MillOptions {
            resolution: args.res,
            orient_points: args.points,
            setups: SetupCount::Exactly(args.setups.max(1)),
            seed: args.seed,
            ..defaults.mill.clone()
        },
        ..defaults
    };
    let bar = ProgressBar::new(args.episodes as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed} [{bar:24}] {pos}/{len} episodes, {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let t = Instant::now();
    let mut returns = Vec::with_capacity(args.episodes);
    let policy = train_policy(&parts, &opts, &mut |e| {
        returns.push(e.total_reward);
        bar.set_position(e.episode + 1);
        bar.set_message(format!("return {:.4}, epsilon {:.3}", e.total_reward, e.epsilon));
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
