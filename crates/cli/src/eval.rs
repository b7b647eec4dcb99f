//! `s2g eval`: the paper's tables on our data.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use shape2gcode::geom::{Mesh, load_mesh};
use shape2gcode::{MillOptions, evaluate};

use crate::mill::DEFAULT_MESH;

/// Arguments of `s2g eval`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// One mesh to evaluate. Default: the bundled sample (unless --corpus is given).
    mesh: Option<PathBuf>,
    /// Evaluate every STL, OBJ, PLY, glTF or GLB file in this folder instead.
    #[arg(long)]
    corpus: Option<PathBuf>,
    /// Comma-separated policies: heuristic, random, fine, coarse.
    #[arg(long, default_value = "heuristic,random,fine,coarse")]
    policies: String,
    /// Simulation resolution.
    #[arg(long, default_value_t = 256)]
    res: usize,
    /// Surface points for orientation selection.
    #[arg(long, default_value_t = 16384)]
    points: usize,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Print JSON.
    #[arg(long, conflicts_with = "markdown")]
    json: bool,
    /// Print Markdown tables (the default).
    #[arg(long)]
    markdown: bool,
}

/// The name of a mesh file: its stem.
fn stem(p: &Path) -> String {
    p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
}

/// Every STL, OBJ, PLY, glTF or GLB file in `dir`, loaded, named by stem, in name order.
pub fn corpus(dir: &Path) -> anyhow::Result<Vec<(String, Mesh)>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension().and_then(|e| e.to_str()).is_some_and(|e| {
                matches!(e.to_ascii_lowercase().as_str(), "stl" | "obj" | "ply" | "gltf" | "glb")
            })
        })
        .collect();
    files.sort();
    if files.is_empty() {
        bail!("{}: no mesh files", dir.display());
    }
    files
        .iter()
        .map(|p| Ok((stem(p), load_mesh(p).with_context(|| format!("loading {}", p.display()))?)))
        .collect()
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let parts = match (&args.corpus, &args.mesh) {
        (Some(_), Some(_)) => bail!("give a mesh or --corpus, not both"),
        (Some(dir), None) => corpus(dir)?,
        (None, m) => {
            let p = m.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_MESH));
            vec![(stem(&p), load_mesh(&p)?)]
        }
    };
    let policies: Vec<String> = args.policies.split(',').map(|s| s.trim().to_owned()).collect();
    let opts = MillOptions {
        resolution: args.res,
        orient_points: args.points,
        seed: args.seed,
        ..MillOptions::default()
    };
    let tables =
        evaluate(&parts, &policies, &opts, &mut |part, policy| eprintln!("s2g eval: {part} with {policy}"))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&tables.to_json())?);
    } else {
        print!("{}", tables.to_markdown());
    }
    Ok(ExitCode::SUCCESS)
}
