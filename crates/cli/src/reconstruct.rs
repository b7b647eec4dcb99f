//! `s2g reconstruct PRINT.gcode [--profile circle|rect|slot] [--width auto|W]
//! [--layer-height auto|H] [--filament 1.75] [--solid|--tubes] [--res MM] -o OUT.(stl|obj|ply|3mf|step)
//! [--json]`: rebuild the printed geometry from FDM G-code (seed 004).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail};
use shape2gcode::geom::{save_mesh, write_bytes_atomic};
use shape2gcode::{
    BeadShape, Deposition, FdmOptions, FdmOutput, reconstruct_file, render_layer, render_result,
};

/// Bead cross-section.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum ProfileArg {
    /// Circle below the nozzle tip.
    Circle,
    /// Rectangle.
    Rect,
    /// Rectangle with half-disc sides (closest to a real bead).
    Slot,
}

/// Solid deposition algorithm.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum DepositArg {
    /// Slice raster for horizontal beads, voxsim for the others.
    Raster,
    /// voxsim's additive mode for every bead.
    Voxsim,
}

/// Arguments of `s2g reconstruct`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The FDM G-code program.
    program: PathBuf,
    /// Bead cross-section swept along the extrusion paths.
    #[arg(long, value_enum, default_value_t = ProfileArg::Slot)]
    profile: ProfileArg,
    /// Bead width in mm (circle: diameter), or `auto` (from the extruded volume per segment).
    #[arg(long, default_value = "auto")]
    width: String,
    /// Layer height in mm, or `auto` (from the layers' Z).
    #[arg(long, default_value = "auto")]
    layer_height: String,
    /// Filament diameter in mm.
    #[arg(long, default_value_t = 1.75)]
    filament: f64,
    /// One watertight solid: the union of the beads (the default).
    #[arg(long, conflicts_with = "tubes")]
    solid: bool,
    /// One closed tube per extrusion path (the paper's output).
    #[arg(long)]
    tubes: bool,
    /// Voxel size of the solid in mm (default: a quarter of the median bead width).
    #[arg(long)]
    res: Option<f64>,
    /// Solid deposition algorithm.
    #[arg(long, value_enum, default_value_t = DepositArg::Raster)]
    deposit: DepositArg,
    /// Keep the beads as sliced instead of widening them until the solid holds the extruded volume.
    #[arg(long)]
    no_volume_match: bool,
    /// Fail on the first bad G-code line instead of skipping it with a warning.
    #[arg(long)]
    strict: bool,
    /// Output mesh (.stl, .obj, .ply, .3mf, or .step: faceted B-rep AP214), written atomically.
    #[arg(short, long)]
    output: PathBuf,
    /// Write three shaded views of the result here (PNG).
    #[arg(long)]
    png: Option<PathBuf>,
    /// Write a top view of one layer's beads here (PNG), one colour per extrusion path.
    #[arg(long)]
    layer_png: Option<PathBuf>,
    /// The layer of `--layer-png` (0-based; default: the middle layer).
    #[arg(long)]
    layer: Option<usize>,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    json: bool,
}

fn size(text: &str, what: &str) -> anyhow::Result<Option<f64>> {
    if text.eq_ignore_ascii_case("auto") {
        return Ok(None);
    }
    let v: f64 =
        text.parse().with_context(|| format!("--{what}: expected auto or a size in mm, got {text:?}"))?;
    if !(v.is_finite() && v > 0.0) {
        bail!("--{what}: must be finite and > 0, got {v}");
    }
    Ok(Some(v))
}

/// Runs `s2g reconstruct`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let ext = args.output.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("stl" | "obj" | "ply" | "3mf" | "step" | "stp")) {
        bail!("{}: output must end in .stl, .obj, .ply, .3mf or .step", args.output.display());
    }
    let opts = FdmOptions {
        profile: match args.profile {
            ProfileArg::Circle => BeadShape::Circle,
            ProfileArg::Rect => BeadShape::Rect,
            ProfileArg::Slot => BeadShape::Slot,
        },
        output: if args.tubes { FdmOutput::Tubes } else { FdmOutput::Solid },
        width: size(&args.width, "width")?,
        layer_height: size(&args.layer_height, "layer-height")?,
        filament_diameter: args.filament,
        resolution: args.res,
        deposition: match args.deposit {
            DepositArg::Raster => Deposition::Raster,
            DepositArg::Voxsim => Deposition::Voxsim,
        },
        match_volume: !args.no_volume_match,
        strict: args.strict,
        ..FdmOptions::default()
    };
    let _ = args.solid;
    let rec = reconstruct_file(&args.program, &opts)
        .with_context(|| format!("reconstructing {}", args.program.display()))?;
    save_mesh(&args.output, &rec.mesh).with_context(|| format!("writing {}", args.output.display()))?;
    if let Some(p) = &args.png {
        let img = render_result(&rec.mesh, 512).context("empty mesh: nothing to render")?;
        write_bytes_atomic(p, &img.to_png()).with_context(|| format!("writing {}", p.display()))?;
    }
    if let Some(p) = &args.layer_png {
        let layer = args.layer.unwrap_or(rec.extrusion.layers / 2);
        let img = render_layer(&rec.extrusion, layer, opts.profile, 20.0)
            .with_context(|| format!("layer {layer} has no beads ({} layers)", rec.extrusion.layers))?;
        write_bytes_atomic(p, &img.to_png()).with_context(|| format!("writing {}", p.display()))?;
    }
    let r = &rec.report;
    for w in &r.warnings {
        eprintln!("s2g: warning: {}: {w}", args.program.display());
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(r)?);
    } else {
        println!(
            "{}: {} spines, {} segments, {} layers; extruded {:.2} mm^3, mesh {:.2} mm^3 ({:+.2} %), \
             {} triangles, watertight {}; {:.3} s",
            args.output.display(),
            r.spines,
            r.segments,
            r.layers,
            r.extruded_volume_mm3,
            r.solid_volume_mm3,
            100.0 * r.volume_error,
            r.triangles,
            r.watertight,
            r.stage_seconds.total
        );
    }
    Ok(ExitCode::SUCCESS)
}
