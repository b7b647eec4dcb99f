//! `s2g orient [MESH] [--points N] [--candidates N] [--max-setups K] [--target F] [--json]
//! [--out-dir DIR]`: tool-orientation selection (seed 000 §3.1) and, with `--out-dir`,
//! the visibility-based reconstruction of every setup (§3.2).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use shape2gcode::geom::{GridSpec, load_mesh, save_mesh};
use shape2gcode::orient::{OrientOptions, ReconstructOptions, Strategy, reconstruct, select_orientations};

/// The bundled sample mesh.
const DEFAULT_MESH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/stanford_bunny.stl");

/// Arguments of `s2g orient`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The mesh (STL, OBJ, glTF/GLB, PLY). Default: the bundled Stanford bunny.
    mesh: Option<PathBuf>,
    /// Surface samples.
    #[arg(long, default_value_t = 16384)]
    points: usize,
    /// Fibonacci candidate directions (the six axes are always added).
    #[arg(long, default_value_t = 512)]
    candidates: usize,
    /// Most setups to choose.
    #[arg(long, default_value_t = 5)]
    max_setups: usize,
    /// Coverage target (fraction of samples) at which no more setups are added.
    #[arg(long, default_value_t = 0.99)]
    target: f64,
    /// Seed of sampling, search and random baselines.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Use the paper's plain greedy instead of the multi-start search.
    #[arg(long)]
    plain_greedy: bool,
    /// Tool-aware visibility with a ball-end tool of this radius (mesh units).
    #[arg(long)]
    tool_radius: Option<f64>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
    /// Write the reconstructed (height-closure) mesh of every setup here, as setup_<i>.stl.
    #[arg(long)]
    out_dir: Option<PathBuf>,
    /// Voxels along the longest axis of the reconstruction grid.
    #[arg(long, default_value_t = 128)]
    resolution: usize,
}

/// Runs `s2g orient`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let start = Instant::now();
    let path = args.mesh.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_MESH));
    let mesh = load_mesh(&path).with_context(|| format!("loading {}", path.display()))?;
    let opts = OrientOptions {
        points: args.points,
        candidates: args.candidates,
        max_setups: args.max_setups,
        coverage_target: args.target,
        seed: args.seed,
        strategy: if args.plain_greedy { Strategy::PlainGreedy } else { Strategy::LocalSearch },
        tool_radius: args.tool_radius,
        ..OrientOptions::default()
    };
    let r = select_orientations(&mesh, &opts).with_context(|| format!("orienting {}", path.display()))?;

    let mut written = Vec::new();
    if let Some(dir) = &args.out_dir {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let bbox = mesh.bbox().context("the mesh has no vertices")?;
        let n = args.resolution.max(2);
        // Two voxels of margin so the closure's surface is closed inside the grid.
        let h = bbox.extent().max() / n as f64;
        let spec = GridSpec::cubic(&bbox.inflated(2.0 * h), n + 4).context("reconstruction grid")?;
        for (i, setup) in r.setups.iter().enumerate() {
            let rec = reconstruct(&mesh, setup, &spec, &ReconstructOptions::default())
                .with_context(|| format!("reconstructing setup {i}"))?;
            let file = dir.join(format!("setup_{i}.stl"));
            save_mesh(&file, &rec.mesh).with_context(|| format!("writing {}", file.display()))?;
            written.push(file);
        }
    }
    let seconds = start.elapsed().as_secs_f64();

    if args.json {
        let t = &r.stage_seconds;
        let out = serde_json::json!({
            "mesh": path.display().to_string(),
            "directions": r.directions.iter().map(|d| [d.x, d.y, d.z]).collect::<Vec<_>>(),
            "coverage": r.coverage,
            "upper_bound": r.upper_bound,
            "baselines": {
                "six_axes": r.baselines.six_axes,
                "random5": r.baselines.random5,
                "random6": r.baselines.random6,
                "plain_greedy": r.baselines.plain_greedy,
                "swap_search": r.baselines.swap_search,
            },
            "seconds": seconds,
            "stage_seconds": {
                "sampling": t.sampling, "index": t.index, "visibility": t.visibility,
                "search": t.search, "refine": t.refine, "baselines": t.baselines, "total": t.total,
            },
            "meshes": written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!("{}: {} setups", path.display(), r.directions.len());
        for (i, (d, c)) in r.directions.iter().zip(&r.coverage).enumerate() {
            println!(
                "  setup {i}: tool axis ({:+.4}, {:+.4}, {:+.4})  coverage {:.2} %",
                d.x,
                d.y,
                d.z,
                100.0 * c
            );
        }
        let b = &r.baselines;
        println!("upper bound {:.2} %", 100.0 * r.upper_bound);
        println!(
            "baselines: six axes {:.2} %, random5 {:.2} %, random6 {:.2} %, plain greedy {:.2} %, swap search {:.2} %",
            100.0 * b.six_axes,
            100.0 * b.random5,
            100.0 * b.random6,
            100.0 * b.plain_greedy,
            100.0 * b.swap_search
        );
        let t = &r.stage_seconds;
        println!(
            "time: sampling {:.3} s, index {:.3} s, visibility {:.3} s, search {:.3} s, refine {:.3} s, baselines {:.3} s; total {:.3} s",
            t.sampling, t.index, t.visibility, t.search, t.refine, t.baselines, seconds
        );
        for p in &written {
            println!("wrote {}", p.display());
        }
    }
    Ok(ExitCode::SUCCESS)
}
