//! Collision-free milling layers on a cup in a block (§5.4, §7.4 of seed 002): starts the
//! layer field from planar layers (`G = z`), optimises Eq. 40, and prints how many sampled
//! tool poses (tool along the layer normal) hit the part before and after, and the
//! optimisation time.
//!
//! ```text
//! cargo run --release -p s2g-field --example cup_layers [-- --steps N --batch N --grid MM
//!     --lr LR --seed S]
//! ```
//!
//! The cup: outer radius 30 mm, height 50 mm, cavity radius 24 mm above an 8 mm base, and a
//! 5 mm inward lip leaving a 20 mm opening radius. The block: the cup's box grown by 6 mm
//! sideways and 2 mm on top. The tool: radius 2.5 mm, 40 mm long. Collisions are counted
//! with a denser tool sampling (2 mm rings of 24 points) than the training's.

use std::time::Instant;

use s2g_field::{
    LayerOptions, MeshSdf, MillingProblem, Tool, count_collisions, cup_mesh, optimize_layers, pretrain_planar,
};
use s2g_geom::{Aabb, Point3};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut options =
        LayerOptions { steps: 600, batch_size: 192, learning_rate: 1e-4, ..LayerOptions::default() };
    let mut grid = 3.0;
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let value = args.next().ok_or_else(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--steps" => options.steps = value.parse()?,
            "--batch" => options.batch_size = value.parse()?,
            "--grid" => grid = value.parse()?,
            "--lr" => options.learning_rate = value.parse()?,
            "--seed" => options.seed = value.parse()?,
            _ => return Err(format!("unknown flag {flag}").into()),
        }
    }
    let t0 = Instant::now();
    let cup = cup_mesh(30.0, 50.0, 24.0, 20.0, 8.0, 5.0, 96)?;
    let part = MeshSdf::new(&cup)?;
    let block = Aabb::new(Point3::new(-36.0, -36.0, 0.0), Point3::new(36.0, 36.0, 52.0));
    let train_tool = Tool { axial_step: 6.0, ring_points: 8, ..Tool::default() };
    let check_tool = Tool { axial_step: 2.0, ring_points: 24, ..Tool::default() };
    let problem = MillingProblem::new(&part, block, train_tool, grid, 0.5)?;
    println!("cup: {} triangles; {} poses on a {grid} mm grid", cup.triangles().len(), problem.poses().len());

    let planar = pretrain_planar(&options)?;
    let before = count_collisions(&planar.to_f64()?, &problem, &check_tool)?;
    println!(
        "planar layers: {} of {} poses hit the part, {} hit unmilled layers ({:.1} s)",
        before.part,
        before.poses,
        before.layer,
        t0.elapsed().as_secs_f64()
    );
    let (g, report) = optimize_layers(planar, &problem, &options)?;
    let after = count_collisions(&g.to_f64()?, &problem, &check_tool)?;
    println!(
        "optimised layers: {} of {} poses hit the part, {} hit unmilled layers",
        after.part, after.poses, after.layer
    );
    println!("final losses (part, layer, spacing, zero-gradient, curvature): {:?}", report.final_losses);
    println!(
        "collisions_before {} collisions_after {}; optimisation {:.1} s ({} steps), total {:.1} s",
        before.part,
        after.part,
        report.seconds,
        report.steps,
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
