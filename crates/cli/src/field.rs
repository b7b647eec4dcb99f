//! `s2g field sdf MESH [--epochs N] [--seed S] -o SDF [--json]` and
//! `s2g field mill (MESH | --cup) [--tool-radius R] [--tool-length L] [--steps N] [--grid MM]
//! [--voxel MM] [--seed S] -o PROGRAM [--json]`: implicit neural fields (seed 002). `sdf`
//! fits a SIREN signed distance field to a mesh (§6.2), writes it atomically and reports
//! its held-out error. `mill` optimises collision-free milling layers for a part in a block
//! (§4.2, §7.4), writes the five-axis program atomically and reports the colliding tool
//! poses before and after, the optimisation time and the simulated gouges.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use s2g_field::{
    MillOptions, SdfOptions, Tool, cup_mesh, fit_sdf_opt, mill_mesh, sdf_error, validation_points,
};
use shape2gcode::geom::{MeshIndex, load_mesh, sample_surface, save_mesh, write_bytes_atomic};

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
    /// Optimise collision-free milling layers for a part in a block and write the
    /// five-axis program (table-table A/C, LinuxCNC).
    Mill(MillArgs),
    /// Print a part on curved layers: optimise the layer field, extract layers and
    /// toolpaths, write the A/C printing program, check it for collisions, read it back,
    /// rebuild the print and score it against the part and against planar slicing.
    Print(crate::field_print::PrintArgs),
}

/// Arguments of `s2g field mill`.
#[derive(Debug, clap::Args)]
struct MillArgs {
    /// The part (STL, OBJ, glTF/GLB, PLY), closed; its bounding box grown by 6 mm sideways
    /// and 2 mm on top is the block.
    #[arg(required_unless_present = "cup", conflicts_with = "cup")]
    mesh: Option<PathBuf>,
    /// Mill the built-in cup (outer radius 30, height 50, cavity radius 24 above an 8 mm
    /// base, 5 mm lip leaving a 20 mm opening) instead of a mesh.
    #[arg(long)]
    cup: bool,
    /// Tool (flat end mill and shank) radius, mm.
    #[arg(long, default_value_t = 2.5)]
    tool_radius: f64,
    /// Tool length from the tip, mm (the length checked for collisions).
    #[arg(long, default_value_t = 40.0)]
    tool_length: f64,
    /// Adam steps on the milling loss before the repair rounds (the library's default when
    /// absent).
    #[arg(long, alias = "epochs")]
    steps: Option<usize>,
    /// Pose grid spacing and layer spacing, mm.
    #[arg(long, default_value_t = 3.0)]
    grid: f64,
    /// Voxel edge of the simulation, mm.
    #[arg(long, default_value_t = 1.0)]
    voxel: f64,
    /// Seed of the network, the batches and the ring phases.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Where to write the program (written atomically).
    #[arg(short, long)]
    output: PathBuf,
    /// Also write the optimised layers (iso-surfaces of the layer field in the material to
    /// remove) as a mesh, e.g. `layers.ply` (written atomically).
    #[arg(long)]
    layers: Option<PathBuf>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
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
        FieldCommand::Mill(a) => mill(a),
        FieldCommand::Print(a) => crate::field_print::print(a),
    }
}

fn mill(args: MillArgs) -> anyhow::Result<ExitCode> {
    let (name, mesh) = match &args.mesh {
        Some(path) => (
            path.display().to_string(),
            load_mesh(path).with_context(|| format!("loading {}", path.display()))?,
        ),
        None => {
            ("cup".to_string(), cup_mesh(30.0, 50.0, 24.0, 20.0, 8.0, 5.0, 96).context("building the cup")?)
        }
    };
    let mut options = MillOptions::default();
    options.tool.cutter = Tool::cylinder(args.tool_radius, args.tool_length).cutter;
    options.layers.check_tool = Some(options.tool);
    if let Some(s) = args.steps {
        options.layers.steps = s;
    }
    options.layers.seed = args.seed;
    options.layers.network.seed = args.seed;
    options.grid = args.grid;
    options.program.layer_step = args.grid;
    options.program.link_distance = 1.5 * args.grid;
    options.voxel = args.voxel;
    options.layers_mesh = args.layers.as_ref().map(|_| 0.5 * args.grid);
    let report = mill_mesh(&mesh, &options).with_context(|| format!("milling {name}"))?;
    write_bytes_atomic(&args.output, report.program.text.as_bytes())
        .with_context(|| format!("writing {}", args.output.display()))?;
    if let (Some(path), Some(mesh)) = (&args.layers, &report.layers) {
        save_mesh(path, mesh).with_context(|| format!("writing {}", path.display()))?;
    }
    let (before, after, sim) = (&report.collisions_before, &report.collisions_after, &report.simulation);
    if args.json {
        let out = serde_json::json!({
            "mesh": name,
            "output": args.output.display().to_string(),
            "poses": before.poses,
            "collisions_before": before.part,
            "collisions_after": after.part,
            "layer_collisions_before": before.layer,
            "layer_collisions_after": after.layer,
            "steps": report.optimisation.steps,
            "repair_rounds": report.optimisation.repair_rounds,
            "seconds": report.optimisation.seconds,
            "layers": report.program.layers,
            "poses_used": report.program.poses_used,
            "poses_skipped": report.program.poses_skipped,
            "poses_reoriented": report.program.poses_reoriented,
            "blocks": report.program.blocks,
            "gouge_voxels": sim.gouge_voxels,
            "removed_fraction": sim.removed_fraction,
            "shank_collision_voxels": sim.shank_collision_voxels,
            "rapid_collision_voxels": sim.rapid_collision_voxels,
            "machining_time_s": sim.machining_time_s,
            "total_seconds": report.seconds,
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{name}: {} tool poses; colliding with the part: {} on planar layers, {} optimised \
             ({} hit unmilled layers before, {} after)",
            before.poses, before.part, after.part, before.layer, after.layer
        );
        println!(
            "optimisation {:.1} s ({} steps, {} repair rounds)",
            report.optimisation.seconds, report.optimisation.steps, report.optimisation.repair_rounds
        );
        println!(
            "program: {} layers, {} poses ({} skipped), {} blocks; simulated: {} gouge voxels, \
             removed {:.1} % of the removable stock, {} shank-contact voxels",
            report.program.layers,
            report.program.poses_used,
            report.program.poses_skipped,
            report.program.blocks,
            sim.gouge_voxels,
            100.0 * sim.removed_fraction,
            sim.shank_collision_voxels
        );
        println!("wrote {} in {:.1} s", args.output.display(), report.seconds);
    }
    let clean = after.part == 0 && after.layer == 0 && sim.gouge_voxels == 0;
    Ok(if clean { ExitCode::SUCCESS } else { ExitCode::from(2) })
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
