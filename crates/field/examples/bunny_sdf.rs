//! Fits a neural SDF to the bundled Stanford bunny (normalised to the unit cube) and prints
//! its mean absolute error on held-out points, as a fraction of the bounding-box diagonal,
//! and the training time.
//!
//! ```text
//! cargo run --release -p s2g-field --example bunny_sdf [-- --epochs N --width N --layers N
//!     --batch N --samples N --omega W0 --lr LR --seed S --out FILE]
//! ```
//!
//! Held-out points: 10,000 near the surface (a surface sample from another seed moved by
//! N(0, 0.01^2) per axis, in unit-cube lengths) and 10,000 uniform in the bounding box,
//! against the exact signed distance of geom's `MeshIndex`.

use std::path::PathBuf;
use std::time::Instant;

use s2g_field::{NeuralSdf, SdfOptions, fit_sdf_opt, sdf_error, validation_points};
use s2g_geom::{MeshIndex, load_mesh, normalize_unit_cube, sample_surface};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut options = SdfOptions::default();
    let mut out: Option<PathBuf> = None;
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let value = args.next().ok_or_else(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--epochs" => options.epochs = value.parse()?,
            "--width" => options.network.width = value.parse()?,
            "--layers" => options.network.sine_layers = value.parse()?,
            "--batch" => options.batch_size = value.parse()?,
            "--samples" => {
                options.surface_samples = value.parse()?;
                options.general_samples = options.surface_samples;
            }
            "--omega" => options.network.first_omega = value.parse()?,
            "--hidden-omega" => options.network.hidden_omega = value.parse()?,
            "--lr" => options.learning_rate = value.parse()?,
            "--sigma" => options.near_sigma = value.parse()?,
            "--seed" => options.seed = value.parse()?,
            "--out" => out = Some(PathBuf::from(value)),
            _ => return Err(format!("unknown flag {flag}").into()),
        }
    }

    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/stanford_bunny.stl");
    let (mesh, _) = normalize_unit_cube(&load_mesh(path)?)?;
    let bbox = mesh.bbox().ok_or("empty mesh")?;
    let diag = (bbox.max - bbox.min).norm();
    println!(
        "bunny: {} triangles; network {} x {}, omega0 {}, epochs {}, batch {}, {} steps",
        mesh.triangles().len(),
        options.network.sine_layers,
        options.network.width,
        options.network.first_omega,
        options.epochs,
        options.batch_size,
        options.steps()
    );

    let t0 = Instant::now();
    let (sdf, report) = fit_sdf_opt(&mesh, &options)?;
    let total = t0.elapsed().as_secs_f64();

    let held_out = sample_surface(&mesh, 10_000, options.seed ^ 0xDEAD_BEEF)?;
    let points = validation_points(&held_out, 10_000, 0.01, &bbox, 10_000, options.seed + 1)?;
    let index = MeshIndex::new(&mesh)?;
    let (near, uniform) = points.split_at(10_000);
    let all = sdf_error(&sdf, &index, &points)?;
    let near_err = sdf_error(&sdf, &index, near)?;
    let uniform_err = sdf_error(&sdf, &index, uniform)?;
    println!("final losses (surface, normal, general, eikonal): {:?}", report.final_losses);
    println!(
        "MAE/diag {:.4} % (near {:.4} %, uniform {:.4} %), max/diag {:.3} %",
        100.0 * all.mean_abs / diag,
        100.0 * near_err.mean_abs / diag,
        100.0 * uniform_err.mean_abs / diag,
        100.0 * all.max_abs / diag
    );
    println!("training {:.1} s (fit_sdf_opt total {:.1} s)", report.train_seconds, total);
    if let Some(out) = out {
        sdf.save(&out)?;
        let back = NeuralSdf::load(&out)?;
        println!("saved to {} (reloads identical: {})", out.display(), back == sdf);
    }
    Ok(())
}
