//! `s2g simulate PROGRAM --stock box:X0,Y0,Z0,X1,Y1,Z1 | --stock-mesh FILE --tool SPEC --res N
//! [--target FILE] [--carver exact|dexel|paper] [-o residual.stl] [--json]`: voxel material
//! simulation of a G-code program (seed 000 §3.4, Appendix A.2).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, bail};
use shape2gcode::geom::{Aabb, GridSpec, Point3, VoxelGrid, load_mesh, save_mesh, voxelize};
use shape2gcode::voxsim::{Carver, Cutter, RewardWeights, SimOptions, ToolTable, simulate_file};

/// Which carver to run.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum CarverArg {
    /// Exact swept volumes on the voxel grid.
    Exact,
    /// Dexel columns for 3-axis setups (exact elsewhere).
    Dexel,
    /// The paper's Monte-Carlo Algorithm A1 (baseline).
    Paper,
}

/// Arguments of `s2g simulate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The G-code program.
    program: PathBuf,
    /// Stock box in program units (mm): `box:X0,Y0,Z0,X1,Y1,Z1`.
    #[arg(long, conflicts_with = "stock_mesh", required_unless_present = "stock_mesh")]
    stock: Option<String>,
    /// Stock as a closed mesh (voxelised on the grid).
    #[arg(long)]
    stock_mesh: Option<PathBuf>,
    /// Cutter: `flat:R[:FLUTE]`, `ball:R[:FLUTE]` or `bull:R:CORNER[:FLUTE]` (mm; flute
    /// length defaults to 4 R).
    #[arg(long, default_value = "flat:1.5")]
    tool: String,
    /// Voxels along the stock's longest axis (cubic voxels).
    #[arg(long, default_value_t = 256)]
    res: usize,
    /// Target part mesh, for gouges and the paper's rewards.
    #[arg(long)]
    target: Option<PathBuf>,
    /// Carving algorithm.
    #[arg(long, value_enum, default_value_t = CarverArg::Exact)]
    carver: CarverArg,
    /// Samples per mm for `--carver paper`.
    #[arg(long, default_value_t = 64.0)]
    paper_density: f64,
    /// RNG seed for `--carver paper`.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Rapid rate in mm/min for the machining time.
    #[arg(long, default_value_t = 5000.0)]
    rapid_rate: f64,
    /// Skip the shank/holder collision checks.
    #[arg(long)]
    no_holder_check: bool,
    /// Write the residual stock mesh (marching cubes) here (.stl, .obj or .ply).
    #[arg(short = 'o', long)]
    output: Option<PathBuf>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

fn parse_tool(spec: &str) -> anyhow::Result<Cutter> {
    let mut parts = spec.split(':');
    let kind = parts.next().unwrap_or_default();
    let nums: Vec<f64> = parts
        .map(|s| s.trim().parse::<f64>().with_context(|| format!("--tool {spec}: bad number {s:?}")))
        .collect::<anyhow::Result<_>>()?;
    let c = match (kind, nums.as_slice()) {
        ("flat", [r]) => Cutter::flat(*r, 4.0 * r),
        ("flat", [r, f]) => Cutter::flat(*r, *f),
        ("ball", [r]) => Cutter::ball(*r, 4.0 * r),
        ("ball", [r, f]) => Cutter::ball(*r, *f),
        ("bull", [r, c]) => Cutter::bull(*r, *c, 4.0 * r),
        ("bull", [r, c, f]) => Cutter::bull(*r, *c, *f),
        _ => bail!("--tool {spec}: expected flat:R[:FLUTE], ball:R[:FLUTE] or bull:R:CORNER[:FLUTE]"),
    };
    c.validate().with_context(|| format!("--tool {spec}"))?;
    Ok(c)
}

fn parse_box(spec: &str) -> anyhow::Result<Aabb> {
    let body = spec
        .strip_prefix("box:")
        .with_context(|| format!("--stock {spec}: expected box:X0,Y0,Z0,X1,Y1,Z1"))?;
    let v: Vec<f64> = body
        .split(',')
        .map(|s| s.trim().parse::<f64>().with_context(|| format!("--stock {spec}: bad number {s:?}")))
        .collect::<anyhow::Result<_>>()?;
    let [x0, y0, z0, x1, y1, z1] = v[..] else { bail!("--stock {spec}: expected six numbers") };
    let b = Aabb::new(
        Point3::new(x0.min(x1), y0.min(y1), z0.min(z1)),
        Point3::new(x0.max(x1), y0.max(y1), z0.max(z1)),
    );
    if !b.is_valid() || b.volume() <= 0.0 {
        bail!("--stock {spec}: the box is empty or not finite");
    }
    Ok(b)
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let start = Instant::now();
    let cutter = parse_tool(&args.tool)?;
    if args.res == 0 || args.res > 4096 {
        bail!("--res must be in 1..=4096, got {}", args.res);
    }
    let stock = match (&args.stock, &args.stock_mesh) {
        (Some(b), _) => {
            let b = parse_box(b)?;
            VoxelGrid::full(GridSpec::cubic(&b, args.res).context("stock grid")?)
        }
        (None, Some(path)) => {
            let mesh = load_mesh(path).with_context(|| format!("loading stock {}", path.display()))?;
            let bb = mesh.bbox().context("the stock mesh has no vertices")?;
            let spec = GridSpec::cubic(&bb, args.res).context("stock grid")?;
            voxelize(&mesh, &spec).with_context(|| format!("voxelising stock {}", path.display()))?
        }
        (None, None) => bail!("give --stock box:... or --stock-mesh FILE"),
    };
    let target = match &args.target {
        Some(path) => {
            let mesh = load_mesh(path).with_context(|| format!("loading target {}", path.display()))?;
            Some(
                voxelize(&mesh, stock.spec())
                    .with_context(|| format!("voxelising target {}", path.display()))?,
            )
        }
        None => None,
    };
    let carver = match args.carver {
        CarverArg::Exact => Carver::Exact,
        CarverArg::Dexel => Carver::Dexel,
        CarverArg::Paper => Carver::PaperMonteCarlo { samples_per_unit: args.paper_density, seed: args.seed },
    };
    let opts = SimOptions {
        carver,
        rapid_rate_mm_per_min: args.rapid_rate,
        check_holder: !args.no_holder_check,
        ..Default::default()
    };
    let sim = if let Some(t) = &target {
        // Gouges need the target inside the simulator: stream through a targeted simulator.
        let s =
            shape2gcode::voxsim::Simulator::new(stock, ToolTable::single(cutter), opts)?.with_target(t)?;
        simulate_with(&args.program, s)?
    } else {
        simulate_file(&args.program, stock, ToolTable::single(cutter), &opts)
            .with_context(|| format!("simulating {}", args.program.display()))?
    };
    let rewards = match &target {
        Some(t) => Some(sim.rewards(t, &RewardWeights::default())?),
        None => None,
    };
    if let Some(out) = &args.output {
        let mesh = sim.residual_mesh().context("residual mesh")?;
        save_mesh(out, &mesh).with_context(|| format!("writing {}", out.display()))?;
    }
    let r = sim.report();
    let seconds = start.elapsed().as_secs_f64();
    if args.json {
        let mut j = serde_json::json!({
            "program": args.program.display().to_string(),
            "removed_voxels": r.removed_voxels,
            "removed_volume_mm3": r.removed_volume_mm3,
            "gouge_voxels": r.gouge_voxels,
            "first_gouge_line": r.first_gouge_line,
            "rapid_collisions": r.rapid_collision_lines,
            "rapid_collision_voxels": r.rapid_collision_voxels,
            "holder_collisions": r.holder_collisions,
            "holder_collision_voxels": r.holder_collision_voxels,
            "machining_time_s": r.machining_time_s,
            "feed_length_mm": r.feed_length_mm,
            "rapid_length_mm": r.rapid_length_mm,
            "feedless_moves": r.feedless_moves,
            "mrr_mm3_per_min": r.mrr_mm3_per_min,
            "moves": r.moves,
            "voxel_mm": sim.residual().spec().voxel.x,
            "dims": sim.residual().dims(),
            "seconds": seconds,
        });
        if let Some(w) = rewards {
            j["rewards"] = serde_json::json!({
                "preservation": w.preservation, "final_iou": w.final_iou, "mrr": w.mrr, "total": w.total,
            });
        }
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        println!("program            {}", args.program.display());
        println!(
            "grid               {:?} voxels of {:.4} mm",
            sim.residual().dims(),
            sim.residual().spec().voxel.x
        );
        println!("moves              {}", r.moves);
        println!("removed            {} voxels, {:.3} mm3", r.removed_voxels, r.removed_volume_mm3);
        println!("gouges             {} voxels, first at line {:?}", r.gouge_voxels, r.first_gouge_line);
        println!(
            "rapid collisions   {} voxels at lines {:?}",
            r.rapid_collision_voxels, r.rapid_collision_lines
        );
        println!("holder collisions  lines {:?}", r.holder_collisions);
        println!(
            "machining time     {:.2} s (feed {:.1} mm, rapid {:.1} mm)",
            r.machining_time_s, r.feed_length_mm, r.rapid_length_mm
        );
        println!("MRR                {:.2} mm3/min", r.mrr_mm3_per_min);
        if let Some(w) = rewards {
            println!(
                "rewards            R_s {:.4}  R_f {:.4}  R_MRR {:.2}  total {:.4}",
                w.preservation, w.final_iou, w.mrr, w.total
            );
        }
        println!("seconds            {seconds:.3}");
    }
    Ok(ExitCode::SUCCESS)
}

fn simulate_with(
    program: &std::path::Path,
    mut sim: shape2gcode::voxsim::Simulator,
) -> anyhow::Result<shape2gcode::voxsim::Simulation> {
    let popts = shape2gcode::gcode::ParseOptions { stop_at_first_error: true, ..Default::default() };
    shape2gcode::gcode::parse_file(program, &popts, &mut sim)
        .map_err(|e| match e.into_sink() {
            Ok(e) => anyhow::Error::new(e),
            Err(other) => anyhow::Error::new(other),
        })
        .with_context(|| format!("simulating {}", program.display()))?;
    Ok(sim.into_simulation()?)
}
