//! Drop-cutter and waterline from the command line, on one thread, for
//! `scripts/bench_drop_cutter.sh` (which runs OpenCAMLib on the same mesh, cutter and grid).
//!
//! ```text
//! drop_cutter prepare MESH OUT.stl SIZE          scale to SIZE (largest extent), min corner at 0
//! drop_cutter drop MESH CUTTER GRID OUT          heights at the grid file's "x y" lines
//! drop_cutter waterline MESH CUTTER Z STEP OUT   loops ("loop" lines, then "x y" lines)
//! ```
//! `CUTTER` is `ball:R`, `flat:R` or `bull:R:r` (radii in mesh units). Prints the seconds the
//! queries took (mesh loading and indexing excluded, as in the OpenCAMLib script).

use std::error::Error;
use std::fmt::Write as _;
use std::time::Instant;

use s2g_geom::{Cutter, DropCutter, MeshIndex, Similarity3, Vector3, WaterlineOptions, load_mesh, save_mesh};

type Res<T> = Result<T, Box<dyn Error>>;

fn cutter(spec: &str) -> Res<Cutter> {
    let parts: Vec<&str> = spec.split(':').collect();
    let num = |i: usize| -> Res<f64> { Ok(parts.get(i).ok_or("missing cutter radius")?.parse::<f64>()?) };
    let len = 1000.0;
    Ok(match parts[0] {
        "ball" => Cutter::ball(num(1)?, len),
        "flat" => Cutter::flat(num(1)?, len),
        "bull" => Cutter::bull(num(1)?, num(2)?, len),
        other => return Err(format!("unknown cutter {other}").into()),
    })
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize| args.get(i).map(String::as_str).ok_or("missing argument (see the example's docs)");
    match arg(0)? {
        "prepare" => {
            let mesh = load_mesh(arg(1)?)?;
            let b = mesh.bbox().ok_or("empty mesh")?;
            let s = arg(3)?.parse::<f64>()? / b.extent().max();
            let t = Similarity3::new(-b.min.coords * s, Vector3::zeros(), s);
            save_mesh(arg(2)?, &mesh.transformed(&t))?;
        }
        "drop" => {
            let index = MeshIndex::new(&load_mesh(arg(1)?)?)?;
            let dc = DropCutter::new(&index, &cutter(arg(2)?)?)?;
            let grid: Vec<[f64; 2]> = std::fs::read_to_string(arg(3)?)?
                .lines()
                .map(|l| {
                    let mut it = l.split_whitespace().map(|v| v.parse::<f64>().unwrap_or(f64::NAN));
                    [it.next().unwrap_or(f64::NAN), it.next().unwrap_or(f64::NAN)]
                })
                .collect();
            let start = Instant::now();
            let heights: Vec<Option<f64>> = grid.iter().map(|p| dc.height(p[0], p[1])).collect();
            let secs = start.elapsed().as_secs_f64();
            let mut out = String::new();
            for h in heights {
                match h {
                    Some(h) => writeln!(out, "{h:.17e}")?,
                    None => writeln!(out, "nan")?,
                }
            }
            std::fs::write(arg(4)?, out)?;
            println!("points {} seconds {secs:.6}", grid.len());
        }
        "waterline" => {
            let index = MeshIndex::new(&load_mesh(arg(1)?)?)?;
            let dc = DropCutter::new(&index, &cutter(arg(2)?)?)?;
            let (z, step) = (arg(3)?.parse::<f64>()?, arg(4)?.parse::<f64>()?);
            let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
            let options = WaterlineOptions { step, ..WaterlineOptions::default() };
            let start = Instant::now();
            let loops = pool.install(|| dc.waterline_opt(z, &options))?;
            let secs = start.elapsed().as_secs_f64();
            let mut out = String::new();
            for l in &loops {
                writeln!(out, "loop")?;
                for p in l {
                    writeln!(out, "{:.17e} {:.17e}", p.x, p.y)?;
                }
            }
            std::fs::write(arg(5)?, out)?;
            println!("loops {} seconds {secs:.6}", loops.len());
        }
        other => return Err(format!("unknown command {other}").into()),
    }
    Ok(())
}
