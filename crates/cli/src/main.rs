//! `s2g`: the Shape2Gcode command line.
//!
//! Argument parsing, file I/O, progress bars, reports and exit codes; all the work
//! is done by the `shape2gcode` library.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod inspect;

/// Shape2Gcode: 3-D shapes to machine programs and machine programs back to shapes.
#[derive(Debug, Parser)]
#[command(name = "s2g", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Load a mesh and print its checks (closed, manifold, volume, bounding box, ...).
    Inspect(inspect::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Inspect(args) => inspect::run(args),
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
