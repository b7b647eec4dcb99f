//! Finishes the bundled bunny, scaled to 100 mm, from the top with a 6 mm ball end mill at
//! a 0.01 mm scallop by each strategy, and prints passes, lengths, machining time at
//! 1500 mm/min, computing time and the surface deviation of the result (height field at
//! 0.2 mm columns): `cargo run --release -p s2g-toolpath --example finish_bunny [scallop]`.

use std::time::Instant;

use s2g_gcode::MotionRecorder;
use s2g_geom::{Cutter, MeshIndex, Setup};
use s2g_toolpath::Tool;
use s2g_toolpath::finish::{
    FinishOptions, FinishingStrategy, Parallel, SteepShallow, Waterline, finish_setup_opt,
};
use s2g_voxsim::{HeightField, HeightFieldOptions, ToolTable, surface_deviation};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scallop: f64 = std::env::args().nth(1).map_or(Ok(0.01), |s| s.parse())?;
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/stanford_bunny.stl");
    let mesh = s2g_geom::load_mesh(path)?;
    let b = mesh.bbox().ok_or("empty mesh")?;
    let s = 100.0 / b.extent().max();
    let mesh =
        mesh.transformed(&s2g_geom::Similarity3::new(-b.min.coords * s, nalgebra::Vector3::zeros(), s));
    let t0 = Instant::now();
    let index = MeshIndex::new(&mesh)?;
    println!("bunny 100 mm: {} triangles, index {:.2} s", index.num_triangles(), t0.elapsed().as_secs_f64());
    let cutter = Cutter::ball(3.0, 30.0);
    let tool = Tool { feed: 1500.0, plunge_feed: 500.0, number: 2, ..Tool::new(cutter) };
    let strategies: [&dyn FinishingStrategy; 3] =
        [&Parallel::default(), &Waterline::default(), &SteepShallow::default()];
    let bb = mesh.bbox().ok_or("empty mesh")?;
    for st in strategies {
        let opts = FinishOptions { scallop, floor: Some(bb.min.z + 1.0), ..Default::default() };
        let mut rec = MotionRecorder::default();
        let t = Instant::now();
        let sum = finish_setup_opt(&index, &Setup::top(), &tool, st, &opts, &mut rec)?;
        let plan_s = t.elapsed().as_secs_f64();
        // The deepest point of any feed move below the drop-cutter surface, 20 samples a move.
        let dc = s2g_geom::DropCutter::new(&index, &cutter)?;
        let (mut worst, mut at, mut prev) = (0.0f64, None, None::<s2g_geom::Point3>);
        for (_, m) in &rec.motions {
            match m {
                s2g_gcode::Motion::Linear { to, .. } => {
                    if let Some(p) = prev {
                        for k in 0..=20 {
                            let q = p + (to - p) * (k as f64 / 20.0);
                            let g = dc.height(q.x, q.y).map_or(0.0, |h| h - q.z);
                            if g > worst {
                                (worst, at) = (g, Some((p, *to)));
                            }
                        }
                    }
                    prev = Some(*to);
                }
                s2g_gcode::Motion::Rapid { to } => prev = Some(*to),
                _ => {}
            }
        }
        println!("{:>13}: deepest feed below the drop-cutter surface {worst:.5} on {at:?}", st.name());
        let t = Instant::now();
        let fo = HeightFieldOptions { spacing: 0.2, ..Default::default() };
        let r = 3.5;
        let mut field = HeightField::new_opt(
            [bb.min.x - r, bb.min.y - r],
            [bb.max.x + r, bb.max.y + r],
            ToolTable::single(cutter),
            &fo,
        )?;
        for (_, m) in &rec.motions {
            s2g_gcode::MotionSink::motion(&mut field, m)?;
        }
        let d = surface_deviation(&field, &index);
        println!(
            "{:>13}: {} passes, {} links, {} retracts, cutting {:.0} mm, rapid {:.0} mm, time {:.1} min, \
             {} motions, planned in {:.2} s; deviation (0.2 mm columns, {:.1} s): max {:.4} mean {:.4} gouge {:.4} over {} columns",
            st.name(),
            sum.passes,
            sum.links,
            sum.retracts,
            sum.cutting_length,
            sum.rapid_length,
            sum.time_s / 60.0,
            rec.motions.len(),
            plan_s,
            t.elapsed().as_secs_f64(),
            d.max,
            d.mean,
            d.gouge_depth,
            d.columns
        );
    }
    Ok(())
}
