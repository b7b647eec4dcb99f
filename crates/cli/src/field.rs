//! `s2g field sdf MESH [--epochs N] [--seed S] -o SDF [--json]`: implicit neural fields
//! (seed 002). `sdf` fits a SIREN signed distance field to a mesh (§6.2), writes it
//! atomically and reports its held-out error.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use s2g_field::{SdfOptions, fit_sdf_opt, sdf_error, validation_points};
use shape2gcode::geom::{MeshIndex, load_mesh, sample_surface};

/// Arguments of `s2g field`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: FieldCommand,
}

#[derive(Debug, clap::Subcommand)]
enum FieldCommand {
    /// Fit a neural signed distance field (SIREN) to a mesh and write it.
    Sdf(SdfArgs),
}

/// Arguments of `s2g field sdf`.
#[derive(Debug, clap::Args)]
struct SdfArgs {
    /// The mesh (STL, OBJ, glTF/GLB, PLY), closed.
    mesh: PathBuf,
    /// Passes over the surface samples (the library's default when absent).
    #[arg(long)]
    epochs: Option<usize>,
    /// Seed of the samples, the batches and the network's initialisation.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Where to write the field (written atomically).
    #[arg(short, long)]
    output: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// Held-out points per kind (near the surface, uniform in the box).
const HELD_OUT: usize = 5_000;

/// Runs `s2g field`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    match args.command {
        FieldCommand::Sdf(a) => sdf(a),
    }
}

fn sdf(args: SdfArgs) -> anyhow::Result<ExitCode> {
    let start = Instant::now();
    let path = &args.mesh;
    let mesh = load_mesh(path).with_context(|| format!("loading {}", path.display()))?;
    let mut options = SdfOptions::default();
    if let Some(e) = args.epochs {
        options.epochs = e;
    }
    options.seed = args.seed;
    options.network.seed = args.seed;
    let (field, report) = fit_sdf_opt(&mesh, &options)
        .with_context(|| format!("fitting a neural SDF to {}", path.display()))?;

    // Held-out points from other seeds: near the surface (1 % of the largest side) and
    // uniform in the bounding box, against the exact mesh distance.
    let bbox = mesh.bbox().context("the mesh has no vertices")?;
    let extent = (bbox.max - bbox.min).max();
    let diag = (bbox.max - bbox.min).norm();
    let held =
        sample_surface(&mesh, HELD_OUT, args.seed ^ 0xDEAD_BEEF).context("sampling held-out points")?;
    let points =
        validation_points(&held, HELD_OUT, 0.01 * extent, &bbox, HELD_OUT, args.seed.wrapping_add(1))
            .context("held-out points")?;
    let index = MeshIndex::new(&mesh).context("indexing the mesh")?;
    let err = sdf_error(&field, &index, &points).context("measuring the field")?;
    let mae_over_diag = err.mean_abs / diag;

    field.save(&args.output).with_context(|| format!("writing {}", args.output.display()))?;
    let seconds = start.elapsed().as_secs_f64();

    if args.json {
        let out = serde_json::json!({
            "mesh": path.display().to_string(),
            "output": args.output.display().to_string(),
            "epochs": options.epochs,
            "steps": report.steps,
            "mae_over_diag": mae_over_diag,
            "max_over_diag": err.max_abs / diag,
            "train_seconds": report.train_seconds,
            "seconds": seconds,
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{}: neural SDF, {} steps; held-out MAE/diag {:.4} % (max {:.3} %)",
            path.display(),
            report.steps,
            100.0 * mae_over_diag,
            100.0 * err.max_abs / diag
        );
        println!(
            "wrote {} in {:.2} s (training {:.2} s)",
            args.output.display(),
            seconds,
            report.train_seconds
        );
    }
    Ok(ExitCode::SUCCESS)
}
