//! `s2g inspect MESH [--json]`.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use shape2gcode::geom::Mesh;

/// Arguments of `s2g inspect`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The mesh to inspect (STL, OBJ, glTF/GLB, PLY). Default: the bundled sample.
    mesh: Option<PathBuf>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let _ = (args.mesh, args.json);
    let _ = Mesh::default;
    anyhow::bail!("inspect is being built").context("inspect")
}
