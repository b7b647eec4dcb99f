//! `s2g inspect [MESH] [--json]`: load a mesh and print its checks.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use serde_json::json;
use shape2gcode::geom::{Aabb, MeshReport, load_mesh, report};

/// The bundled sample, resolved at compile time against this crate's source folder
/// (`assets/stanford_bunny.stl` at the workspace root). A binary moved away from its
/// checkout must be given a mesh explicitly.
pub const DEFAULT_MESH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/stanford_bunny.stl");

/// Arguments of `s2g inspect`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The mesh to inspect (STL, OBJ, glTF/GLB, PLY). Default: the bundled
    /// assets/stanford_bunny.stl of the source checkout.
    mesh: Option<PathBuf>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// Loads the mesh, checks it and prints the report (text or JSON) on stdout.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let path = args.mesh.unwrap_or_else(|| PathBuf::from(DEFAULT_MESH));
    let mesh = load_mesh(&path).context("cannot load the mesh")?;
    let r = report(&mesh);
    if args.json {
        let value = to_json(&path, &r);
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        print!("{}", to_text(&path, &r));
    }
    Ok(ExitCode::SUCCESS)
}

fn bbox_json(b: &Option<Aabb>) -> serde_json::Value {
    match b {
        Some(b) => json!({
            "min": [b.min.x, b.min.y, b.min.z],
            "max": [b.max.x, b.max.y, b.max.z],
        }),
        None => serde_json::Value::Null,
    }
}

fn to_json(path: &std::path::Path, r: &MeshReport) -> serde_json::Value {
    json!({
        "file": path.display().to_string(),
        "triangles": r.triangles,
        "vertices": r.vertices,
        "unique_vertices": r.unique_vertices,
        "duplicate_vertices": r.duplicate_vertices,
        "degenerate_faces": r.degenerate_faces,
        "edges": r.edges,
        "boundary_edges": r.boundary_edges,
        "non_manifold_edges": r.non_manifold_edges,
        "non_manifold_vertices": r.non_manifold_vertices,
        "closed": r.closed,
        "manifold": r.manifold,
        "consistently_oriented": r.consistently_oriented,
        "volume": r.volume,
        "area": r.area,
        "bbox": bbox_json(&r.bbox),
        "bodies": r.bodies,
        "euler_characteristic": r.euler_characteristic,
    })
}

fn yes_no(b: bool) -> &'static str {
    if b { "yes" } else { "no" }
}

fn to_text(path: &std::path::Path, r: &MeshReport) -> String {
    let bbox = match &r.bbox {
        Some(b) => format!(
            "[{:.6}, {:.6}, {:.6}] .. [{:.6}, {:.6}, {:.6}] (extent {:.6} x {:.6} x {:.6})",
            b.min.x,
            b.min.y,
            b.min.z,
            b.max.x,
            b.max.y,
            b.max.z,
            b.extent().x,
            b.extent().y,
            b.extent().z
        ),
        None => "none".into(),
    };
    let mut s = String::new();
    s += &format!("file:                   {}\n", path.display());
    s += &format!("triangles:              {}\n", r.triangles);
    s += &format!(
        "vertices:               {} ({} unique, {} duplicates)\n",
        r.vertices, r.unique_vertices, r.duplicate_vertices
    );
    s += &format!("degenerate faces:       {}\n", r.degenerate_faces);
    s += &format!(
        "edges:                  {} ({} boundary, {} non-manifold)\n",
        r.edges, r.boundary_edges, r.non_manifold_edges
    );
    s += &format!("non-manifold vertices:  {}\n", r.non_manifold_vertices);
    s += &format!("closed:                 {}\n", yes_no(r.closed));
    s += &format!("manifold:               {}\n", yes_no(r.manifold));
    s += &format!("consistently oriented:  {}\n", yes_no(r.consistently_oriented));
    s += &format!("volume:                 {:.6}\n", r.volume);
    s += &format!("area:                   {:.6}\n", r.area);
    s += &format!("bounding box:           {bbox}\n");
    s += &format!("bodies:                 {}\n", r.bodies);
    s += &format!("euler characteristic:   {}\n", r.euler_characteristic);
    s
}
