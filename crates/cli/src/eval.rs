//! `s2g eval`: the paper's tables on our data.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use shape2gcode::geom::{Mesh, load_mesh};
use shape2gcode::{
    EvalOptions, EvalPlan, MillOptions, SeedGroup, Shard, TableSet, Tables, evaluate_part, merge_results,
    policy_by_name, tables_from_parts, write_part_result,
};

use crate::mill::{DEFAULT_MESH, parse_setups, parse_space};

/// Arguments of `s2g eval`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Meshes to evaluate. Default: the bundled sample (unless --corpus is given).
    meshes: Vec<PathBuf>,
    /// Evaluate every STL, OBJ, PLY, glTF or GLB file in this folder instead.
    #[arg(long)]
    corpus: Option<PathBuf>,
    /// Comma-separated policies: learned (the bundled policy), heuristic, random,
    /// fixed-fine, fixed-coarse, fixed:R,H,S, or policy files written by `s2g train`.
    #[arg(long, default_value = "learned,heuristic,random,fixed-fine,fixed-coarse")]
    policies: String,
    /// Comma-separated tables: `policies` (Tables 1 and 3), `orientation` (Table 2),
    /// `strategies` (Table 4).
    #[arg(long, default_value = "policies,orientation,strategies")]
    tables: String,
    /// The policy Table 4 takes each clearing strategy (and the contour pass) away from,
    /// one at a time (a name as --policies takes): the shipped learned policy, as the paper
    /// ablates its own, which then chooses the best action that is left.
    #[arg(long, value_name = "POLICY", default_value = shape2gcode::default_ablated())]
    ablate: String,
    /// Simulation resolution.
    #[arg(long, default_value_t = 256)]
    res: usize,
    /// Action space: `paper` (the paper's tools in units of the part) or `grid` (the
    /// paper's tools as its 256^3 grid sees them, scaled by 256 / --res: 0.26-2.56 voxels of
    /// radius at 64^3).
    #[arg(long, default_value = "paper")]
    space: String,
    /// Surface points for orientation selection.
    #[arg(long, default_value_t = 16384)]
    points: usize,
    /// Also evaluate each learned policy fine-tuned on each part for this many episodes
    /// first (Appendix A.7: five); a row `NAME +ftN` each.
    #[arg(long, default_value_t = 0)]
    finetune: usize,
    /// `NAME=POLICY+POLICY+...`: policies trained with different seeds, reported as one row
    /// with 95 % confidence intervals (Appendix A.8). Repeatable.
    #[arg(long = "seed-group")]
    seed_groups: Vec<String>,
    /// Number of setups: `auto` or a count.
    #[arg(long, default_value = "auto")]
    setups: String,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The paper's front-facing visibility, as `s2g mill --front-facing`: the environment
    /// the shipped policy was trained in.
    #[arg(long)]
    front_facing: bool,
    /// Evaluate only shard K of N (0 <= K < N): the parts at places K, K+N, K+2N, ... of
    /// the sorted part list (as Slurm's `SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT` or
    /// Kubernetes' `JOB_COMPLETION_INDEX` give them). Needs --results; prints no table.
    #[arg(long, requires = "results", value_parser = parse_shard)]
    shard: Option<Shard>,
    /// Also write one result file per part, `PART.eval.json`, into this folder (created if
    /// missing), for --merge.
    #[arg(long)]
    results: Option<PathBuf>,
    /// Evaluate nothing: print the tables of the result files in this folder (written by
    /// runs with --results, one per --shard), byte for byte what one run over all the parts
    /// prints. The policies, tables and options are the files'.
    #[arg(long, value_name = "DIR", conflicts_with_all = [
        "meshes", "corpus", "shard", "results", "policies", "tables", "ablate", "res", "space", "points", "finetune",
        "seed_groups", "setups", "seed", "front_facing",
    ])]
    merge: Option<PathBuf>,
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

fn parse_shard(s: &str) -> Result<Shard, String> {
    s.parse().map_err(|e| format!("{e}"))
}

/// The meshes of a command line: the `files` named, or every STL, OBJ, PLY, glTF or GLB
/// file in `dir`; loaded, named by stem, in file-name order (so that a corpus trains alike
/// however it is given).
pub fn parts(files: &[PathBuf], dir: Option<&Path>) -> anyhow::Result<Vec<(String, Mesh)>> {
    mesh_files(files, dir)?.iter().map(|p| Ok((stem(p), load(p)?))).collect()
}

fn load(p: &Path) -> anyhow::Result<Mesh> {
    load_mesh(p).with_context(|| format!("loading {}", p.display()))
}

/// The mesh files of [`parts`], in its order, not loaded.
fn mesh_files(files: &[PathBuf], dir: Option<&Path>) -> anyhow::Result<Vec<PathBuf>> {
    let mut files = match (dir, files) {
        (Some(_), [_, ..]) => bail!("give meshes or --corpus, not both"),
        (None, []) => bail!("no meshes (give mesh files or --corpus DIR)"),
        (None, files) => files.to_vec(),
        (Some(dir), []) => {
            let files: Vec<PathBuf> = std::fs::read_dir(dir)
                .with_context(|| format!("reading {}", dir.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    p.extension().and_then(|e| e.to_str()).is_some_and(|e| {
                        matches!(e.to_ascii_lowercase().as_str(), "stl" | "obj" | "ply" | "gltf" | "glb")
                    })
                })
                .collect();
            if files.is_empty() {
                bail!("{}: no mesh files", dir.display());
            }
            files
        }
    };
    files.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
    Ok(files)
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if let Some(dir) = &args.merge {
        let (tables, plan) = merge_results(dir).with_context(|| format!("merging {}", dir.display()))?;
        eprintln!("s2g eval: merged the results of {} parts from {}", plan.count, dir.display());
        return print_tables(&tables, args.json);
    }
    let files = if args.corpus.is_none() && args.meshes.is_empty() {
        vec![PathBuf::from(DEFAULT_MESH)]
    } else {
        mesh_files(&args.meshes, args.corpus.as_deref())?
    };
    let names: Vec<String> = files.iter().map(|p| stem(p)).collect();
    let mut seen = std::collections::BTreeSet::new();
    if args.results.is_some()
        && let Some(twice) = names.iter().find(|n| !seen.insert(n.as_str()))
    {
        bail!("two parts are named {twice:?}: their result files would be one");
    }
    let policies: Vec<String> = args.policies.split(',').map(|s| s.trim().to_owned()).collect();
    let mut which = TableSet { policies: false, orientation: false, strategies: false };
    for t in args.tables.split(',').map(str::trim) {
        match t {
            "policies" => which.policies = true,
            "orientation" => which.orientation = true,
            "strategies" => which.strategies = true,
            t => bail!("unknown table {t:?} (policies, orientation or strategies)"),
        }
    }
    let mut seed_groups = Vec::new();
    for g in &args.seed_groups {
        let Some((name, members)) = g.split_once('=') else {
            bail!("--seed-group needs NAME=POLICY+POLICY+..., got {g:?}");
        };
        let members: Vec<String> = members.split('+').map(|m| m.trim().to_owned()).collect();
        if name.trim().is_empty() || members.iter().any(String::is_empty) {
            bail!("--seed-group needs NAME=POLICY+POLICY+..., got {g:?}");
        }
        seed_groups.push(SeedGroup { name: name.trim().to_owned(), members });
    }
    let setups = parse_setups(&args.setups)?;
    let opts = MillOptions {
        resolution: args.res,
        paper_space_scale: parse_space(&args.space, args.res)?,
        orient_points: args.points,
        seed: args.seed,
        setups,
        flank_walls: !args.front_facing,
        ..MillOptions::default()
    };
    if which.strategies && policy_by_name(&args.ablate, &opts.action_space(), args.seed).is_none() {
        bail!(
            "unknown policy {:?} for --ablate (learned, heuristic, random, fixed-fine, fixed-coarse, fixed:R,H,S or a policy file)",
            args.ablate
        );
    }
    let eval =
        EvalOptions { tables: which, finetune_episodes: args.finetune, seed_groups, ablated: args.ablate };
    let plan = EvalPlan::new(&names, &policies, &eval, &opts);
    let shard = args.shard.unwrap_or(Shard::ALL);
    if let Some(dir) = &args.results {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let mut results = Vec::new();
    for (index, path) in files.iter().enumerate().filter(|(i, _)| shard.takes(*i)) {
        let mesh = load(path)?;
        let result = evaluate_part(&names[index], &mesh, &policies, &eval, &opts, &mut |part, policy| {
            eprintln!("s2g eval: {part} with {policy}")
        })
        .with_context(|| format!("evaluating {}", path.display()))?;
        if let Some(dir) = &args.results {
            let written = write_part_result(dir, &result, index, &plan)?;
            eprintln!("s2g eval: wrote {}", written.display());
        }
        results.push(result);
    }
    if args.shard.is_some() {
        eprintln!("s2g eval: shard {shard}: {} of {} parts evaluated", results.len(), names.len());
        return Ok(ExitCode::SUCCESS);
    }
    print_tables(&tables_from_parts(&results, &policies, &eval)?, args.json)
}

fn print_tables(tables: &Tables, json: bool) -> anyhow::Result<ExitCode> {
    if json {
        println!("{}", serde_json::to_string_pretty(&tables.to_json())?);
    } else {
        print!("{}", tables.to_markdown());
    }
    Ok(ExitCode::SUCCESS)
}
