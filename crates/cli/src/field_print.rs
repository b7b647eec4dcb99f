//! `s2g field print (MESH | --part arm|arch|overhang-arch|bracket)
//! --objective support-free|planar|aligned[:DIRECTIONS]|coopt[:DIRECTIONS] -o PROGRAM [--rotary ac|bc]
//! [--mount table|head] [--layers L.ply] [--paths P.ply] [--json]`: multi-axis printing end to end
//! (seed 002's layers and toolpaths, closed with seed 004's reconstruction). Progress and
//! per-stage time go to stderr; the report to stdout.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, bail};
use s2g_field::{
    AlignDirection, PRINT_PARTS, PrintMeshOptions, PrintObjective, PrintStage, print_mesh, print_part,
};
use shape2gcode::gcode::{RotaryAxes, RotaryMount};
use shape2gcode::geom::{load_mesh, save_mesh, write_bytes_atomic};

/// Arguments of `s2g field print`.
#[derive(Debug, clap::Args)]
pub struct PrintArgs {
    /// The part (STL, OBJ, glTF/GLB, PLY, 3MF), closed, standing on its lowest point.
    #[arg(required_unless_present = "part", conflicts_with = "part")]
    mesh: Option<PathBuf>,
    /// A built-in part instead of a mesh: the bent arm, the arch on two feet, the
    /// overhanging arch on one foot or the bracket with a tip.
    #[arg(long, value_parser = PRINT_PARTS)]
    part: Option<String>,
    /// Which layers: `support-free` (Eq. 37), `planar`, `aligned[:DIRECTIONS]` (layers
    /// along a direction field, Eq. 38) or `coopt[:DIRECTIONS]` (layers and toolpaths
    /// co-optimised along it, Eq. 39, the toolpaths the path field's iso-curves).
    /// DIRECTIONS: `X,Y,Z` (one direction everywhere) or `arm` (the bent arm's axis, the
    /// default with `--part arm`).
    #[arg(long, default_value = "support-free")]
    objective: String,
    /// Adam steps on the layer loss (the library's default when absent).
    #[arg(long)]
    steps: Option<usize>,
    /// Layer height, mm.
    #[arg(long, default_value_t = 0.8)]
    layer_height: f64,
    /// Bead width and path spacing, mm.
    #[arg(long, default_value_t = 1.0)]
    bead_width: f64,
    /// Voxel edge of the rebuilt print's score and of the planar support, mm.
    #[arg(long, default_value_t = 0.5)]
    voxel: f64,
    /// Seed of the network, the samples and the batches.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Where to write the program (written atomically).
    #[arg(short, long)]
    output: PathBuf,
    /// Also write the layers (inside the part) as a mesh, e.g. `layers.ply`.
    #[arg(long)]
    layers: Option<PathBuf>,
    /// Also write the toolpaths as thin tubes, e.g. `paths.ply`.
    #[arg(long)]
    paths: Option<PathBuf>,
    /// The printer's rotary axes: `ac` (A about X, then C about Z) or `bc` (B about Y,
    /// then C).
    #[arg(long, value_parser = ["ac", "bc"], default_value = "ac")]
    rotary: String,
    /// What the rotary axes turn: `table` (a tilting and rotating platform under a
    /// vertical nozzle) or `head` (a tilting head with tool-centre-point control over a
    /// still platform: X, Y, Z are the tip in the part frame).
    #[arg(long, value_parser = ["table", "head"], default_value = "table")]
    mount: String,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// The direction field of `aligned[:DIRECTIONS]`: `X,Y,Z`, or `arm` (the default for the
/// built-in arm).
fn direction(directions: Option<&str>, part: Option<&str>) -> anyhow::Result<AlignDirection> {
    let arm = AlignDirection::BentArm { column: 12.0, bend_radius: 16.0, bend_deg: 60.0 };
    match directions {
        None if part == Some("arm") => Ok(arm),
        None => bail!("aligned and coopt need directions (aligned:X,Y,Z) except on --part arm"),
        Some("arm") => Ok(arm),
        Some(text) => {
            let v: Vec<f64> = text
                .split(',')
                .map(|c| c.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .with_context(|| format!("directions {text}: X,Y,Z or arm"))?;
            match v.as_slice() {
                [x, y, z] if v.iter().all(|c| c.is_finite()) && v.iter().any(|c| *c != 0.0) => {
                    Ok(AlignDirection::Constant(shape2gcode::geom::Vector3::new(*x, *y, *z)))
                }
                _ => bail!("directions {text}: three finite numbers, not all zero, or arm"),
            }
        }
    }
}

/// Runs `s2g field print`.
pub fn print(args: PrintArgs) -> anyhow::Result<ExitCode> {
    let start = Instant::now();
    let (name, mesh) = match (&args.mesh, &args.part) {
        (Some(path), _) => (
            path.display().to_string(),
            load_mesh(path).with_context(|| format!("loading {}", path.display()))?,
        ),
        (None, Some(p)) => (p.clone(), print_part(p).with_context(|| format!("building the {p}"))?),
        (None, None) => bail!("give a mesh or --part"),
    };
    let (kind, directions) = match args.objective.split_once(':') {
        Some((k, d)) => (k, Some(d)),
        None => (args.objective.as_str(), None),
    };
    let objective = match kind {
        "support-free" => PrintObjective::SupportFree,
        "planar" => PrintObjective::Planar,
        "aligned" => PrintObjective::Aligned,
        "coopt" => PrintObjective::Coopt,
        other => bail!("unknown objective {other} (support-free, planar, aligned, coopt)"),
    };
    let mut options = PrintMeshOptions { objective, ..PrintMeshOptions::default() };
    if matches!(objective, PrintObjective::Aligned | PrintObjective::Coopt) {
        options.direction = direction(directions, args.part.as_deref())?;
    } else if directions.is_some() {
        bail!("--objective {}: only aligned and coopt take directions", args.objective);
    }
    if let Some(s) = args.steps {
        options.optimisation.steps = s;
        options.dac.steps = s;
        options.tgc.steps = s;
    }
    options.optimisation.seed = args.seed;
    options.optimisation.network.seed = args.seed;
    options.dac.seed = args.seed;
    options.dac.network.seed = args.seed;
    options.tgc.seed = args.seed;
    options.tgc.layer_network.seed = args.seed;
    options.tgc.path_network.seed = args.seed.wrapping_add(1);
    options.program.rotary = if args.rotary == "bc" { RotaryAxes::BC } else { RotaryAxes::AC };
    options.program.mount = if args.mount == "head" { RotaryMount::Head } else { RotaryMount::Table };
    options.paths.layer_height = args.layer_height;
    options.paths.bead_width = args.bead_width;
    options.voxel = args.voxel;
    let json = args.json;
    let mut progress = |stage: PrintStage| {
        if !json {
            eprintln!("{name}: {stage:?} from {:.1} s", start.elapsed().as_secs_f64());
        }
    };
    let run = print_mesh(&mesh, &options, &mut progress).with_context(|| format!("printing {name}"))?;
    write_bytes_atomic(&args.output, run.program.text.as_bytes())
        .with_context(|| format!("writing {}", args.output.display()))?;
    if let Some(path) = &args.layers {
        save_mesh(path, &run.plan.layers_mesh()?).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = &args.paths {
        let tubes = run.plan.paths_mesh(0.1 * args.bead_width)?;
        save_mesh(path, &tubes).with_context(|| format!("writing {}", path.display()))?;
    }
    let (p, s, sp, t) = (&run.program, &run.score, &run.spacing, &run.seconds);
    let planar = run.planar.as_ref();
    if args.json {
        let out = serde_json::json!({
            "mesh": name,
            "output": args.output.display().to_string(),
            "objective": args.objective,
            "rotary": args.rotary,
            "mount": args.mount,
            "layers": p.layers,
            "paths": p.paths,
            "blocks": p.blocks,
            "iou": s.iou,
            "overhang_fraction": s.overhang_fraction,
            "planar_overhang_fraction": planar.map(|(_, ps)| ps.overhang_fraction),
            "planar_iou": planar.map(|(_, ps)| ps.iou),
            "planar_collisions": planar.map(|(pp, _)| pp.collisions),
            "planar_support_volume": run.planar_support.volume,
            "planar_support_area": run.planar_support.area,
            "collisions": p.collisions,
            "poses_checked": p.poses_checked,
            "travel_collisions": p.travel_collisions,
            "turned_axes": p.turned_axes,
            "unclear_points": p.unclear_points,
            "unprintable_length": p.unprintable_length,
            "spacing_within_25": sp.within_25,
            "spacing_median_ratio": sp.median_ratio,
            "extruded_mm": p.extruded_length,
            "travel_mm": p.travel_length,
            "stage_seconds": {"optimise": t.optimise, "extract": t.extract, "program": t.program, "rebuild": t.rebuild},
            "seconds": start.elapsed().as_secs_f64(),
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{name}: {} layers, {} paths, {} blocks; {:.0} mm extruded, {:.0} mm travel",
            p.layers, p.paths, p.blocks, p.extruded_length, p.travel_length
        );
        println!(
            "rebuilt print: IoU {:.3}, overhang {:.2} %, {} of {} poses colliding, {:.0} mm of path unprintable; spacing within ±25 % on {:.1} % of the paths",
            s.iou,
            100.0 * s.overhang_fraction,
            p.collisions,
            p.poses_checked,
            p.unprintable_length,
            100.0 * sp.within_25
        );
        if let Some((pp, ps)) = planar {
            println!(
                "planar slicing: IoU {:.3}, overhang {:.2} %, {} colliding poses",
                ps.iou,
                100.0 * ps.overhang_fraction,
                pp.collisions
            );
        }
        println!(
            "a planar slicer's support: {:.0} mm3 under {:.0} mm2",
            run.planar_support.volume, run.planar_support.area
        );
        println!(
            "optimise {:.1} s, extract {:.1} s, program {:.1} s, rebuild {:.1} s; wrote {} in {:.1} s",
            t.optimise,
            t.extract,
            t.program,
            t.rebuild,
            args.output.display(),
            start.elapsed().as_secs_f64()
        );
    }
    Ok(if p.collisions == 0 { ExitCode::SUCCESS } else { ExitCode::from(2) })
}
