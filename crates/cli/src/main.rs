//! `s2g`: the Shape2Gcode command line.
//!
//! Argument parsing, file I/O, progress bars, reports and exit codes; all the work
//! is done by the `shape2gcode` library.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod eval;
mod feature;
mod field;
mod field_print;
mod gcode;
mod r#gen;
mod inspect;
mod mill;
mod orient;
mod reconstruct;
mod simulate;
mod tools;
mod train;

/// Shape2Gcode: 3-D shapes to machine programs and machine programs back to shapes.
#[derive(Debug, Parser)]
#[command(name = "s2g", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Evaluate policies and orientation strategies: the paper's Tables 1-4 on our data.
    Eval(eval::Args),
    /// Program machining features (pockets, slots, holes) on a block from a TOML job (seed 001).
    Feature(feature::Args),
    /// Implicit neural fields (seed 002): `sdf` fits a neural signed distance field to a mesh.
    Field(field::Args),
    /// Mill a mesh: orientations, toolpaths, G-code, then simulate the written G-code and score it.
    // Boxed: its many options make it far larger than the other commands.
    Mill(Box<mill::Args>),
    /// Generate CAD-like parts (prismatic, turned, freeform, mix, or the five shop parts) as STL plus a manifest.
    Gen(r#gen::Args),
    /// Parse a G-code program: `check` errors, `stats`, or `motions` as JSON lines.
    Gcode(gcode::Args),
    /// Load a mesh and print its checks (closed, manifold, volume, bounding box, ...).
    Inspect(inspect::Args),
    /// Choose tool orientations by visibility; optionally write each setup's reconstruction.
    Orient(orient::Args),
    /// Rebuild the printed geometry from FDM G-code: a watertight solid or one tube per path.
    Reconstruct(reconstruct::Args),
    /// Simulate a G-code program on a voxel stock: removed volume, gouges, collisions, time.
    Simulate(simulate::Args),
    /// A tool library's feeds and speeds in a material; write it as TOML or a LinuxCNC tool table.
    Tools(tools::Args),
    /// Train the DQN policy that picks tool radius, layer height and strategy per setup.
    Train(train::Args),
}

/// `--dialect` of the milling commands: a dialect by name ([`Dialect`]'s `FromStr`), one
/// that writes milling programs (not a printer's).
fn milling_dialect(name: &str) -> Result<shape2gcode::gcode::Dialect, String> {
    let dialect: shape2gcode::gcode::Dialect = name.parse().map_err(|e| format!("{e}"))?;
    if dialect.spec().extrusion {
        return Err(format!("{dialect} is a printer's dialect: use linuxcnc, grbl or fanuc"));
    }
    Ok(dialect)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Eval(args) => eval::run(args),
        Command::Feature(args) => feature::run(args),
        Command::Field(args) => field::run(args),
        Command::Mill(args) => mill::run(*args),
        Command::Gcode(args) => gcode::run(args),
        Command::Gen(args) => r#gen::run(args),
        Command::Inspect(args) => inspect::run(args),
        Command::Orient(args) => orient::run(args),
        Command::Reconstruct(args) => reconstruct::run(args),
        Command::Simulate(args) => simulate::run(args),
        Command::Tools(args) => tools::run(args),
        Command::Train(args) => train::run(args),
    };
    match result {
        Ok(code) => code,
        Err(err) => {
            // One line: the error and its causes, joined.
            eprintln!("s2g: error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
