//! Multi-axis printing end to end on the parts that need curved layers (issue 39): for
//! each part, support-free layers (Eq. 37) are optimised, the layers and their toolpaths
//! extracted, the A/C program (a turning platform's, or with `--mount head` a tilting
//! head's) written and checked for collisions along its interpolated
//! path, read back with the parser, rebuilt with tilted beads and scored; planar slicing
//! of the same part beside it. Prints a Markdown table and one JSON line per part.
//!
//! ```text
//! cargo run --release -p s2g-field --example print_parts [-- --parts arm,overhang-arch,bracket,bunny,arch
//!     --steps N --pretrain N --seed S --layer MM --bead MM --lattice MM --margin DEG --first-layers MM --first-factor F --lean DEG --voxel MM --min-spacing W
//!     --min-path W --overlap W --rings N --dump DIR --mount table|head]
//! ```
//!
//! `--dump DIR` writes each part's program and its planar program there
//! (`PART.gcode`, `PART_planar.gcode`).
//!
//! The parts, standing on `z = 0`: the bent arm of `support_free` (radius 6, column 12,
//! bend 16 through 60°, arm 24), an overhanging arch on one foot (`overhang-arch`: a pillar
//! 10 high turning over on an arc of centreline radius 14 through 120°, band 6 wide, 10
//! deep, its free end hanging over the platform), the arch on two feet (`arch`: centreline
//! radius 14, band 6 wide, pillars 10 high, 10 deep; the documented limit), a bracket
//! with a tip (post 6 wide and 12 high, bend 10, arm 20 tapering to 2, 10 deep) and the
//! bundled bunny (`assets/stanford_bunny.stl`, Y up
//! turned Z up, scaled 5×: about 50 mm, the ears leaning out).

use s2g_field::{PrintMeshOptions, PrintStage, overhang_misses, print_mesh, print_part, read_beads};
use s2g_geom::{Mesh, Point3, load_mesh};

fn part(name: &str) -> Result<Mesh, Box<dyn std::error::Error>> {
    Ok(match name {
        "bunny" => {
            let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/stanford_bunny.stl");
            let m = load_mesh(path)?;
            let v: Vec<Point3> =
                m.vertices().iter().map(|p| Point3::new(5.0 * p.x, -5.0 * p.z, 5.0 * p.y)).collect();
            let m = Mesh::new(v, m.triangles().to_vec())?;
            let z0 = m.bbox().map_or(0.0, |b| b.min.z);
            Mesh::new(
                m.vertices().iter().map(|p| Point3::new(p.x, p.y, p.z - z0)).collect(),
                m.triangles().to_vec(),
            )?
        }
        _ => print_part(name)?,
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut options = PrintMeshOptions::default();
    let mut parts = "arm,overhang-arch,bracket,bunny,arch".to_string();
    let mut dump: Option<std::path::PathBuf> = None;
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let value = args.next().ok_or_else(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--parts" => parts = value,
            "--dump" => dump = Some(value.into()),
            "--steps" => options.optimisation.steps = value.parse()?,
            "--pretrain" => options.optimisation.pretrain_steps = value.parse()?,
            "--seed" => {
                options.optimisation.seed = value.parse()?;
                options.optimisation.network.seed = options.optimisation.seed;
            }
            "--layer" => options.paths.layer_height = value.parse()?,
            "--bead" => options.paths.bead_width = value.parse()?,
            "--lattice" => options.paths.lattice = value.parse()?,
            "--margin" => options.optimisation.constants.overhang_margin_deg = value.parse()?,
            "--first-factor" => options.optimisation.constants.first_layers_factor = value.parse()?,
            "--lean" => options.optimisation.pretrain_lean_deg = value.parse()?,
            "--voxel" => options.voxel = value.parse()?,
            "--min-spacing" => options.paths.min_spacing = value.parse()?,
            "--min-path" => options.paths.min_path_widths = value.parse()?,
            "--overlap" => options.paths.infill_overlap = value.parse()?,
            "--rings" => options.paths.rings = value.parse()?,
            "--first-layers" => options.optimisation.constants.first_layers = value.parse()?,
            "--mount" => {
                options.program.mount = match value.as_str() {
                    "table" => s2g_gcode::RotaryMount::Table,
                    "head" => s2g_gcode::RotaryMount::Head,
                    _ => return Err(format!("--mount {value}: table or head").into()),
                }
            }
            _ => return Err(format!("unknown flag {flag}").into()),
        }
    }
    println!(
        "| part | layers | iou | overhang | collisions / poses | unprintable mm | spacing ±25 % | planar iou | planar overhang | planar collisions | planar support mm³ | optimise s | extract s | program s | rebuild s |"
    );
    println!("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    let mut lines = Vec::new();
    for name in parts.split(',') {
        let mesh = part(name)?;
        let run = print_mesh(&mesh, &options, &mut |stage: PrintStage| eprintln!("{name}: {stage:?}"))?;
        let (p, s, sp, t) = (&run.program, &run.score, &run.spacing, &run.seconds);
        let (pp, ps) = run.planar.as_ref().ok_or("no planar baseline")?;
        // Where the overhang lies: the share of the failing bead samples within 2 mm of
        // the platform.
        let (o, w) = (&options.program, options.paths.bead_width);
        let beads = read_beads(&run.program.text, o.rotary, o.mount, w, o.filament_diameter)?;
        let (_, misses) = overhang_misses(&beads, w, options.optimisation.constants.max_overhang_deg, 0.0);
        let low = misses.iter().filter(|q| q.z < 2.0).count();
        if let Some(dir) = &dump {
            std::fs::write(dir.join(format!("{name}.gcode")), &p.text)?;
            std::fs::write(dir.join(format!("{name}_planar.gcode")), &pp.text)?;
        }
        println!(
            "| {name} | {} | {:.3} | {:.4} | {} / {} | {:.1} | {:.3} | {:.3} | {:.4} | {} | {:.0} | {:.1} | {:.1} | {:.1} | {:.1} |",
            p.layers,
            s.iou,
            s.overhang_fraction,
            p.collisions,
            p.poses_checked,
            p.unprintable_length,
            sp.within_25,
            ps.iou,
            ps.overhang_fraction,
            pp.collisions,
            run.planar_support.volume,
            t.optimise,
            t.extract,
            t.program,
            t.rebuild
        );
        lines.push(format!(
            "{{\"part\":\"{name}\",\"layers\":{},\"paths\":{},\"iou\":{:.4},\"overhang_fraction\":{:.5},\"planar_iou\":{:.4},\
             \"planar_overhang_fraction\":{:.5},\"collisions\":{},\"poses_checked\":{},\"planar_collisions\":{},\
             \"spacing_within_25\":{:.4},\"spacing_median\":{:.3},\"lone_length\":{:.1},\"measured_length\":{:.1},\
             \"volume_ratio\":{:.3},\"blocks\":{},\"travel_collisions\":{},\"turned_axes\":{},\"unclear_points\":{},\"unprintable_length\":{:.1},\"overhang_misses\":{},\"overhang_misses_below_2mm\":{},\"planar_support_volume\":{:.1},\"planar_support_area\":{:.1},\"part_volume\":{:.1},\"seconds\":{{\"optimise\":{:.1},\"extract\":{:.1},\"program\":{:.1},\"rebuild\":{:.1}}}}}",
            p.layers,
            p.paths,
            s.iou,
            s.overhang_fraction,
            ps.iou,
            ps.overhang_fraction,
            p.collisions,
            p.poses_checked,
            pp.collisions,
            sp.within_25,
            sp.median_ratio,
            sp.lone_length,
            sp.measured_length,
            s.volume_ratio,
            p.blocks,
            p.travel_collisions,
            p.turned_axes,
            p.unclear_points,
            p.unprintable_length,
            misses.len(),
            low,
            run.planar_support.volume,
            run.planar_support.area,
            mesh.signed_volume(),
            t.optimise,
            t.extract,
            t.program,
            t.rebuild
        ));
    }
    for l in lines {
        println!("{l}");
    }
    Ok(())
}
