//! `s2g feature JOB.toml [-o PROGRAM] [--dialect linuxcnc|grbl|fanuc] [--json] [--check VOXEL]`:
//! a complete numbered CNC program from a feature job (pockets, slots, holes on a block;
//! seed 001). Without `-o` the program goes to stdout (unless `--json`).

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use serde_json::json;
use shape2gcode::gcode::Dialect;
use shape2gcode::{FeatureProgram, feature_program, load_job};

/// Arguments of `s2g feature`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The job file (TOML: block, allowance, tools, features).
    job: PathBuf,
    /// Write the program here (atomically); default stdout unless --json.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// G-code dialect: linuxcnc, grbl (drilling cycles expanded, no tool changer) or fanuc.
    #[arg(long, default_value = "linuxcnc", value_parser = crate::milling_dialect)]
    dialect: Dialect,
    /// Print per-feature rules and extents as JSON on stdout.
    #[arg(long)]
    json: bool,
    /// Simulate the written program in voxels of this edge (mm) and report gouges, rapid
    /// collisions and what each feature left.
    #[arg(long, value_name = "VOXEL")]
    check: Option<f64>,
}

fn write_atomic(path: &Path, text: &str) -> anyhow::Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "program".into());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("renaming to {}", path.display()))?;
    Ok(())
}

fn summary_json(p: &FeatureProgram) -> serde_json::Value {
    let features: Vec<_> = p
        .plan
        .summaries
        .iter()
        .map(|s| {
            json!({
                "name": s.name,
                "kind": s.kind,
                "operation": s.operation,
                "depth_of_cut": s.depth_of_cut,
                "cuts": s.cuts,
                "stepover": s.stepover,
                "passes": s.passes,
                "pass_length": s.pass_length,
                "tool": s.tool,
                "finish_tool": s.finish_tool,
                "extents": {"min": s.min, "max": s.max},
            })
        })
        .collect();
    json!({ "features": features, "motions": p.plan.motions.len() })
}

/// Runs `s2g feature`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let spec = load_job(&args.job)?;
    let program = feature_program(&spec)?;
    let dialect = args.dialect;
    let text = program.gcode(dialect)?;
    if let Some(out) = &args.output {
        write_atomic(out, &text)?;
    }
    let mut value = summary_json(&program);
    if let Some(voxel) = args.check {
        // The check parses the program: simulate the LinuxCNC text (the parser expands cycles).
        let lcnc = if matches!(dialect, Dialect::LinuxCnc) {
            text.clone()
        } else {
            program.gcode(Dialect::LinuxCnc)?
        };
        let c = program.voxel_check(&lcnc, voxel)?;
        let per: Vec<_> = c
            .features
            .iter()
            .map(|f| json!({"name": f.name, "left_inside": f.left_inside, "floor_z": f.floor_z, "overcut": f.overcut}))
            .collect();
        value["check"] = json!({
            "voxel": c.voxel,
            "removed_voxels": c.removed_voxels,
            "gouge_voxels": c.gouge_voxels,
            "rapid_collision_voxels": c.rapid_collision_voxels,
            "holder_collision_voxels": c.holder_collision_voxels,
            "features": per,
        });
        if !args.json {
            eprintln!(
                "check at {:.3} mm voxels: {} removed, {} gouges, {} rapid collisions",
                c.voxel, c.removed_voxels, c.gouge_voxels, c.rapid_collision_voxels
            );
            for f in &c.features {
                eprintln!(
                    "  {}: {} voxels left inside, floor {:?}, overcut {:.4} mm",
                    f.name, f.left_inside, f.floor_z, f.overcut
                );
            }
        }
    }
    let stdout = std::io::stdout();
    let mut lock = stdout.lock();
    if args.json {
        writeln!(lock, "{}", serde_json::to_string_pretty(&value)?)?;
    } else if args.output.is_none() {
        lock.write_all(text.as_bytes())?;
    }
    Ok(ExitCode::SUCCESS)
}
