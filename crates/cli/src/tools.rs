//! `s2g tools`: a tool library's feeds and speeds chart in one material, and the library
//! written as TOML or as a LinuxCNC tool table.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use shape2gcode::default_tool_library;
use shape2gcode::geom::{CutterShape, write_bytes_atomic};
use shape2gcode::toolpath::library::ToolLibrary;

/// Arguments of `s2g tools`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The library: TOML (the format of assets/tools/default.toml), a LinuxCNC tool table
    /// (.tbl) or a FreeCAD tool bit (.fctb); without materials or machine it takes the
    /// shipped library's. Default: the shipped library
    #[arg(long, value_name = "FILE")]
    tools: Option<PathBuf>,
    /// The material of the chart, a name in the library
    #[arg(long, value_name = "NAME", default_value = "aluminium-6061")]
    material: String,
    /// Write the library as TOML here
    #[arg(long, value_name = "FILE")]
    toml: Option<PathBuf>,
    /// Write the library as a LinuxCNC tool table here
    #[arg(long, value_name = "FILE")]
    table: Option<PathBuf>,
}

/// The library of `--tools` (or the shipped one), with the shipped materials and machine
/// where the file has none.
pub fn library(path: Option<&PathBuf>) -> anyhow::Result<ToolLibrary> {
    let Some(path) = path else { return Ok(default_tool_library().clone()) };
    let mut lib = ToolLibrary::load(path)?;
    if lib.materials.is_empty() {
        lib.materials = default_tool_library().materials.clone();
    }
    if lib.machine.is_none() {
        lib.machine = default_tool_library().machine.clone();
    }
    Ok(lib)
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let lib = library(args.tools.as_ref())?;
    let material = lib.material(&args.material)?;
    let machine = lib.machine.clone().unwrap_or_default();
    println!(
        "{} tools, {} ({}), on {} (spindle {}-{} rpm, feed up to {} mm/min)",
        lib.tools.len(),
        material.name,
        material.description,
        machine.name,
        machine.spindle_rpm[0],
        machine.spindle_rpm[1],
        machine.max_feed
    );
    println!(
        "{:>5}  {:<5} {:>6} {:>3} {:>6} {:>7} {:>7} {:>7} {:>6} {:>6}  name",
        "T", "shape", "D", "z", "flutes", "rpm", "feed", "plunge", "ap", "ae"
    );
    for t in &lib.tools {
        let shape = match t.cutter.shape {
            CutterShape::Flat(_) => "flat",
            CutterShape::Ball(_) => "ball",
            CutterShape::BullNose(_) => "bull",
            CutterShape::TSlot(_) => "tslot",
        };
        let c = t.cutting(material, &machine)?;
        println!(
            "{:>5}  {:<5} {:>6} {:>3} {:>6} {:>7.0} {:>7.0} {:>7.0} {:>6.2} {:>6.2}  {}",
            t.number,
            shape,
            t.cutter.diameter(),
            t.flutes,
            t.cutter.flute_length,
            c.spindle_rpm,
            c.feed,
            c.plunge_feed,
            c.max_axial_depth,
            c.max_radial_depth,
            t.name
        );
    }
    if let Some(path) = &args.toml {
        write_bytes_atomic(path, lib.to_toml().as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = &args.table {
        write_bytes_atomic(path, lib.to_linuxcnc_table().as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(ExitCode::SUCCESS)
}
