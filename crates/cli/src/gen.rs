//! `s2g gen --out DIR [--count N] [--seed S] [--kind KIND] [--size MM]`: generate CAD-like
//! parts (issue 37) as binary STL files plus a `manifest.json` (file, kind, features with
//! their parameters, volume, bounding box, seed). The same arguments give the same bytes.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use s2g_gen::{GenOptions, Kind, MIX, Part, SHOP_PARTS, generate, shop_part};
use serde_json::json;
use shape2gcode::geom::{save_mesh, write_bytes_atomic};

/// Arguments of `s2g gen`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The folder to write into (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// How many parts (default 10; for --kind shop at most 5, default 5).
    #[arg(long)]
    count: Option<u64>,
    /// The seed: part i is a function of (seed, i, kind, size) alone.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// prismatic, turned, freeform, mix (1/2 prismatic, 1/4 turned, 1/4 freeform) or shop
    /// (the five named shop parts of issue 35, fixed, in mm).
    #[arg(long, default_value = "mix", value_parser = parse_kind)]
    kind: Kind,
    /// The longest side of each part, mm (1-1000; default 100). Not for --kind shop.
    #[arg(long, allow_negative_numbers = true)]
    size: Option<f64>,
}

fn parse_kind(s: &str) -> Result<Kind, String> {
    s.parse().map_err(|e| format!("{e}"))
}

/// Generates the parts, writes them and the manifest, and prints a one-line summary.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let shop = args.kind == Kind::Shop;
    if shop && args.size.is_some() {
        bail!("--size does not apply to --kind shop: the shop parts are fixed, in mm");
    }
    let count = args.count.unwrap_or(if shop { SHOP_PARTS.len() as u64 } else { 10 });
    if shop && count > SHOP_PARTS.len() as u64 {
        bail!("--count {count}: there are {} shop parts", SHOP_PARTS.len());
    }
    let options = GenOptions { kind: args.kind, size: args.size.unwrap_or(GenOptions::default().size) };
    options.validate().context("bad options")?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let mut entries = Vec::with_capacity(count as usize);
    let mut triangles = 0;
    for index in 0..count {
        let part = if shop { shop_part(index) } else { generate(args.seed, index, &options) }
            .with_context(|| format!("part {index}"))?;
        let file = format!("{}.stl", part.name);
        save_mesh(args.out.join(&file), &part.mesh).with_context(|| format!("writing {file}"))?;
        triangles += part.mesh.triangles().len();
        entries.push(entry(&part, &file, index, (!shop).then_some(args.seed))?);
    }
    let manifest = json!({
        "generator": "s2g gen",
        "kind": args.kind.name(),
        "seed": if shop { serde_json::Value::Null } else { json!(args.seed) },
        "size": if shop { serde_json::Value::Null } else { json!(options.size) },
        "count": count,
        "mix": MIX.iter().map(|(k, p)| json!({"kind": k.name(), "proportion": p})).collect::<Vec<_>>(),
        "parts": entries,
    });
    let path = args.out.join("manifest.json");
    let mut text = serde_json::to_string_pretty(&manifest)?;
    text.push('\n');
    write_bytes_atomic(&path, text.as_bytes()).with_context(|| format!("writing {}", path.display()))?;
    println!("wrote {count} parts ({triangles} triangles) and {}", display(&path));
    Ok(ExitCode::SUCCESS)
}

fn display(p: &Path) -> String {
    p.display().to_string()
}

/// One part's manifest entry.
fn entry(part: &Part, file: &str, index: u64, seed: Option<u64>) -> anyhow::Result<serde_json::Value> {
    let b = part.mesh.bbox().context("an empty mesh")?;
    Ok(json!({
        "file": file,
        "name": part.name,
        "kind": part.kind.name(),
        "index": index,
        "seed": seed,
        "volume": part.volume,
        "bbox": {"min": [b.min.x, b.min.y, b.min.z], "max": [b.max.x, b.max.y, b.max.z]},
        "triangles": part.mesh.triangles().len(),
        "features": serde_json::to_value(&part.features)?,
    }))
}
