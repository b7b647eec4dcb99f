//! `s2g mill`: mesh to checked, simulated, scored G-code.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use shape2gcode::gcode::{Dialect, RotaryAxes};
use shape2gcode::geom::{Mesh, load_mesh, save_mesh, write_bytes_atomic};
use shape2gcode::{
    Datum, FinishChoice, FinishStrategyKind, LearnedPolicy, MillOptions, MillRun, Milled, Policy, Preset,
    ProgramLayout, SetupCount, Stage, Stock, TrainOptions, policy_by_name, render_machining,
};

/// The bundled sample mesh.
pub const DEFAULT_MESH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/stanford_bunny.stl");

/// Arguments of `s2g mill`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The mesh to mill (STL, OBJ, glTF/GLB, PLY). Default: the bundled Stanford bunny.
    mesh: Option<PathBuf>,
    /// Program path; with several setups in the per-setup layout, `NAME.N.EXT` per setup.
    /// Default: out/<mesh stem>.ngc.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Program layout: `per-setup` (one 3-axis program per setup, re-fixtured by hand), or
    /// one 3+2 program for a table-table machine: `ac` (A then C) or `bc` (B then C).
    #[arg(long, default_value = "per-setup")]
    layout: String,
    /// Travel of the tilt axis (A or B) of `--layout ac|bc`, in degrees: `MIN,MAX`.
    #[arg(long, default_value = "-180,180", allow_hyphen_values = true)]
    tilt_range: String,
    /// Units and action space: `paper` (unit cube) or `shop` (mm, shop tools).
    #[arg(long, default_value = "paper")]
    preset: String,
    /// Unit of the mesh's coordinates (shop preset; mesh files carry none): `mm`, `in` or
    /// `m`. The paper preset normalises the part to 100 mm instead
    #[arg(long, value_name = "UNIT")]
    units: Option<String>,
    /// Scale the part by this factor after `--units` (shop preset)
    #[arg(long, value_name = "FACTOR", conflicts_with = "size")]
    scale: Option<f64>,
    /// Scale the part so that its longest side is this many millimetres (shop preset)
    #[arg(long, value_name = "MM", conflicts_with = "units")]
    size: Option<f64>,
    /// Number of setups: `auto` or a count.
    #[arg(long, default_value = "auto")]
    setups: String,
    /// Policy: `learned` (the DQN policy shipped with s2g, see assets/policy/README.md;
    /// outside the paper's action space, as with `--preset shop`, the heuristic chooses for
    /// it and the report names the policy `learned (heuristic)`), `heuristic` (the geometric
    /// rule: about half the computing time, about 1.5x the machining time on the bundled
    /// bunny), `random`, `fixed-fine`, `fixed-coarse`, `fixed:RADIUS,LAYER,STRATEGY`
    /// (zigzag|periphery|spiral), or the path of a policy file written by `s2g train`.
    #[arg(long, default_value = "learned")]
    policy: String,
    /// Fine-tune the learned policy (`learned` or a policy file given by --policy) on this
    /// mesh for this many episodes first (the paper uses five), each episode milled as this
    /// run mills the part, on the grid of --finetune-res.
    #[arg(long, default_value_t = 0)]
    finetune: usize,
    /// Simulation resolution of the fine-tuning episodes. Default: the one the policy was
    /// trained at (its states and rewards are what it learned on, at a fraction of the
    /// cost of this run's grid).
    #[arg(long)]
    finetune_res: Option<usize>,
    /// Controller dialect: linuxcnc, grbl or fanuc.
    #[arg(long, default_value = "linuxcnc", value_parser = crate::milling_dialect)]
    dialect: Dialect,
    /// Largest depth of a roughing cut, in tool diameters: the free region is cleared once
    /// per this depth and the layers between get their contour and the steps left along
    /// the walls. 0 clears every layer whole, as the paper does.
    #[arg(long, default_value_t = 1.0)]
    roughing_depth: f64,
    /// The paper's front-facing visibility: a surface counts as reachable from a tool axis
    /// only when it faces it. By default walls parallel to a tool axis count too (the
    /// tool's flank cuts them), so prismatic parts get axis-aligned setups instead of
    /// oblique ones. The shipped policy was trained with the paper's test.
    #[arg(long)]
    front_facing: bool,
    /// Shop preset: keep the simulation grid on the report's scorer's lattice instead of
    /// putting its voxel planes through the part's flat faces (the default: the voxel
    /// within 2 % of --res's, so that the residual's flat faces lie where the part has them
    /// for any scorer; MillOptions::face_grid). The paper preset's grid is the paper's
    /// either way.
    #[arg(long, overrides_with = "face_grid")]
    no_face_grid: bool,
    /// The default (kept so that older command lines run); the later of it and
    /// --no-face-grid wins.
    #[arg(long, hide = true, overrides_with = "no_face_grid")]
    face_grid: bool,
    /// Shop preset: choose setups by the reach of the longest flat end mill wherever a
    /// surface is, instead of by what a tool that fits each surface reaches with its
    /// holder clear of the stock (the default, MillOptions::tool_aware_reach, which gives
    /// deep holes beside tall features setups from the other side).
    #[arg(long, overrides_with = "tool_aware_reach")]
    no_tool_aware_reach: bool,
    /// The default (kept so that older command lines run); the later of it and
    /// --no-tool-aware-reach wins.
    #[arg(long, hide = true, overrides_with = "no_tool_aware_reach")]
    tool_aware_reach: bool,
    /// With the tool-aware reach: a tool that comes within MM of a surface reaches it
    /// (MillOptions::reach_slack; default 0.3, or half a simulation voxel where more).
    #[arg(long, value_name = "MM")]
    reach_slack: Option<f64>,
    /// Simulation resolution (voxels along the stock's longest axis).
    #[arg(long, default_value_t = 256)]
    res: usize,
    /// Simulation voxel size in mm (in the paper preset, mm of its 100 mm part), instead of
    /// --res: the resolution becomes the part's longest side over it, so that a part a few
    /// millimetres thick is resolved whatever its length (a 2 mm bar 200 mm long is 1.3
    /// voxels thick at --res 128, 10 at --voxel 0.2). Bounded by --max-voxels and by 2048
    /// along the longest side, with a note on stderr when a bound coarsens it.
    #[arg(long, conflicts_with = "res")]
    voxel: Option<f64>,
    /// Shop preset: the most smaller tools considered for rest roughing per setup, right
    /// after its roughing and before its finishing, each a flat end mill of the library at
    /// most 0.7 times as wide as the one before (the one whose flutes reach deepest), over
    /// the material the earlier programs left; each pass is a program of its own, the
    /// setup's finishing in the last. A tool runs only where --rest-continue finds
    /// material for it. 0: one roughing tool per setup.
    #[arg(long, default_value_t = 3)]
    rest_roughing: usize,
    /// Shop preset: the least material left that a rest pass is for, as a fraction of the
    /// part's volume: what its tool can take and the wider tool before it could not, out of
    /// the finishing tool's reach (MillOptions::rest_continue).
    #[arg(long, default_value_t = 0.0005)]
    rest_continue: f64,
    /// With --voxel: the most voxels the simulation grid may hold (over the part's box with
    /// the stock margin); the voxel grows until the grid fits.
    #[arg(long, default_value_t = 1 << 28)]
    max_voxels: u64,
    /// Paper preset's action space: `paper` (the paper's tools in units of the part) or
    /// `grid` (the paper's tools as its 256^3 grid sees them, scaled by 256 / --res; the
    /// same as `paper` at 256^3).
    #[arg(long, default_value = "paper")]
    space: String,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Surface points for orientation selection.
    #[arg(long, default_value_t = 16384)]
    points: usize,
    /// Write the JSON report here.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Write the residual stock mesh here (STL, OBJ or PLY by extension).
    #[arg(long)]
    residual: Option<PathBuf>,
    /// Write a PNG of the simulated part and one setup's toolpath here.
    #[arg(long)]
    render: Option<PathBuf>,
    /// Print the JSON report on stdout instead of the summary.
    #[arg(long)]
    json: bool,
    /// Leave wall-clock timings out of the report, so that two runs give identical bytes.
    #[arg(long)]
    reproducible: bool,
    /// Stop with an error (exit status 1, naming the stage, nothing written) once the run
    /// has taken this many seconds.
    #[arg(long, value_name = "SECONDS")]
    time_limit: Option<f64>,
    /// Refuse, before planning, a setup whose action would machine for longer than this
    /// many hours by an upper estimate (every layer cleared whole at the stepover).
    #[arg(long, value_name = "HOURS", default_value_t = 10_000.0)]
    max_hours: f64,
    /// Fit G2/G3 arcs within this distance (mm) in the planner: roughing passes on the
    /// part's side of their path (the walls keep the tolerance as more allowance, so no
    /// arc comes nearer the part than planned and none leaves stock the path would have
    /// cut), finishing passes along X or Y as G18/G19 arcs above their points, each checked
    /// as a straight move is. 0 writes straight moves only. Default: 0.005 in the shop
    /// preset (about 78 % fewer lines on the bunny at 100 mm), 0 in the paper preset, as
    /// the paper's programs
    #[arg(long, value_name = "MM")]
    arc_tolerance: Option<f64>,
    /// Stock box, in mm of the planned part (the paper preset's part is 100 mm long):
    /// `X,Y,Z` (a box of that size centred on the part) or `MINX,MINY,MINZ,MAXX,MAXY,MAXZ`.
    /// Default: the preset's (the paper's cube, the shop's box with a margin)
    #[arg(long, value_name = "SIZE", conflicts_with = "stock_cylinder")]
    stock_box: Option<String>,
    /// Bar stock: `D,L` (diameter and length, mm) along Z, or `D,L,AXIS` with AXIS x, y or z;
    /// centred on the part. Setups plan over its box, the simulator cuts the round bar
    #[arg(long, value_name = "D,L[,AXIS]")]
    stock_cylinder: Option<String>,
    /// Origin of each program's work coordinates (G54), stated in its header comment and
    /// the report: `top-centre` (the stock's top, centred) or `corner` (its top, lowest X
    /// and Y). Default: the part's frame, as the paper's programs
    #[arg(long, value_name = "DATUM")]
    datum: Option<String>,
    /// Choose setups for the part's visible surface alone, as the paper does, even where
    /// they leave stock that other directions would cut (the baseline of the stock-removal
    /// term)
    #[arg(long)]
    visibility_only_setups: bool,
    /// Tool library (shop preset): TOML in the format of assets/tools/default.toml, a
    /// LinuxCNC tool table (.tbl) or a FreeCAD tool bit (.fctb). Its flat end mills rough,
    /// at the cutting data of --material on its [machine]; a file without materials or
    /// machine takes those of the shipped library. Default: the shipped library
    #[arg(long, value_name = "FILE")]
    tools: Option<PathBuf>,
    /// Workpiece material (shop preset), a name in the tool library: aluminium-6061,
    /// mild-steel, pom or wax in the shipped one
    #[arg(long, value_name = "NAME", default_value = "aluminium-6061")]
    material: String,
    /// Write the tool library as a LinuxCNC tool table here (shop preset), so the programs
    /// run in `rs274 -t FILE` and on a machine with the same tool numbers
    #[arg(long, value_name = "FILE")]
    tool_table: Option<PathBuf>,
    /// Finish each setup after roughing (default in the shop preset with the per-setup
    /// layout and a tool changer): the roughing leaves --allowance, then a ball end mill
    /// of the library (the largest no wider than the roughing tool that reaches the
    /// setup; the paper preset: a ball of the roughing radius) follows the part's surface
    #[arg(long, conflicts_with = "no_finish")]
    finish: bool,
    /// Rough only (the default of the paper preset)
    #[arg(long)]
    no_finish: bool,
    /// Scallop height allowed between finishing passes, mm
    #[arg(long, value_name = "MM", default_value_t = 0.01)]
    scallop: f64,
    /// Finishing strategy: parallel, waterline, steep-shallow or crossed
    #[arg(long, value_name = "STRATEGY", default_value = "crossed")]
    finish_strategy: String,
    /// Finishing tool number in the library (a ball or bull-nose end mill). Default: the rule above
    #[arg(long, value_name = "T")]
    finish_tool: Option<u32>,
    /// Stock the roughing leaves for the finisher, `RADIAL[,AXIAL]` mm: by default none, the
    /// roughing cuts walls and flats to size and the finisher takes the layer steps off the
    /// slopes (a ball raster never descends the outer walls)
    #[arg(long, value_name = "MM", default_value = "0")]
    allowance: String,
    /// Column spacing of the height field that measures the finished surface, mm
    #[arg(long, value_name = "MM", default_value_t = 0.1)]
    surface_spacing: f64,
    /// Surface samples of each mesh for the Chamfer distance and normal consistency (seeded
    /// by --seed): at the default 8,000 the two move by about 0.01 (Chamfer x1000) and 0.003
    /// (NC) between seeds on the shop parts at 128^3; more samples, less spread
    #[arg(long, value_name = "N", default_value_t = 8000)]
    metric_samples: usize,
}

/// `--finish`, `--no-finish` and the finishing options as the run's choice: on by default
/// in the shop preset where the layout and dialect allow it.
fn finish_choice(args: &Args, preset: Preset, layout: ProgramLayout) -> anyhow::Result<Option<FinishChoice>> {
    let default_on = preset == Preset::Shop
        && layout == ProgramLayout::PerSetup
        && args.dialect.spec().tool_change != shape2gcode::gcode::ToolChange::Pause;
    if args.no_finish || !(args.finish || default_on) {
        return Ok(None);
    }
    let Some(strategy) = FinishStrategyKind::from_name(&args.finish_strategy) else {
        bail!(
            "unknown finishing strategy {:?} (parallel, waterline, steep-shallow or crossed)",
            args.finish_strategy
        );
    };
    Ok(Some(FinishChoice { tool: args.finish_tool, scallop: args.scallop, strategy }))
}

/// The shop preset's arc tolerance when `--arc-tolerance` is not given (mm): issue 35's.
const SHOP_ARC_TOLERANCE: f64 = 0.005;

/// `--arc-tolerance` as the run's: `None` (straight moves) for 0, the preset's default
/// when not given.
fn arc_tolerance(given: Option<f64>, preset: Preset) -> Option<f64> {
    match given {
        Some(t) => (t != 0.0).then_some(t),
        None => (preset == Preset::Shop).then_some(SHOP_ARC_TOLERANCE),
    }
}

/// `--allowance RADIAL[,AXIAL]` (one value for both).
fn parse_allowance(s: &str) -> anyhow::Result<[f64; 2]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .context("--allowance RADIAL[,AXIAL]")?;
    match v[..] {
        [a] => Ok([a, a]),
        [r, a] => Ok([r, a]),
        _ => bail!("--allowance takes RADIAL[,AXIAL], got {s:?}"),
    }
}

/// `--stock-box` and `--stock-cylinder` as a [`Stock`].
fn parse_stock(args: &Args) -> anyhow::Result<Stock> {
    let numbers = |flag: &str, spec: &str| -> anyhow::Result<Vec<f64>> {
        spec.split(',')
            .map(|x| x.trim().parse::<f64>().with_context(|| format!("{flag}: bad number {x:?} in {spec:?}")))
            .collect()
    };
    if let Some(spec) = &args.stock_box {
        let v = numbers("--stock-box", spec)?;
        return Ok(match v[..] {
            [x, y, z] => Stock::BoxSize([x, y, z]),
            [a, b, c, d, e, f] => Stock::BoxCorners { min: [a, b, c], max: [d, e, f] },
            _ => bail!("--stock-box X,Y,Z or MINX,MINY,MINZ,MAXX,MAXY,MAXZ, got {spec:?}"),
        });
    }
    if let Some(spec) = &args.stock_cylinder {
        let parts: Vec<&str> = spec.split(',').collect();
        let (dims, axis) = match parts[..] {
            [d, l] => (format!("{d},{l}"), 2),
            [d, l, a] => (
                format!("{d},{l}"),
                match a.trim() {
                    "x" | "X" => 0,
                    "y" | "Y" => 1,
                    "z" | "Z" => 2,
                    _ => bail!("--stock-cylinder: axis x, y or z, got {a:?}"),
                },
            ),
            _ => bail!("--stock-cylinder D,L or D,L,AXIS, got {spec:?}"),
        };
        let v = numbers("--stock-cylinder", &dims)?;
        return Ok(Stock::Cylinder { diameter: v[0], length: v[1], axis });
    }
    Ok(Stock::Preset)
}

/// `--datum`.
fn parse_datum(spec: Option<&str>) -> anyhow::Result<Option<Datum>> {
    Ok(match spec {
        None => None,
        Some("top-centre" | "top-center") => Some(Datum::TopCentre),
        Some("corner") => Some(Datum::Corner),
        Some(d) => bail!("unknown datum {d:?} (top-centre or corner)"),
    })
}

/// `--space paper|grid` at `--res res`: the paper preset's `paper_space_scale`.
pub fn parse_space(spec: &str, res: usize) -> anyhow::Result<f64> {
    match spec {
        "paper" => Ok(1.0),
        "grid" => Ok(shape2gcode::ActionSpace::paper_space_scale(res)),
        s => bail!("--space paper|grid, got {s:?}"),
    }
}

/// `--setups auto|N`.
pub fn parse_setups(spec: &str) -> anyhow::Result<SetupCount> {
    Ok(match spec {
        "auto" => SetupCount::Auto,
        n => SetupCount::Exactly(n.parse().with_context(|| format!("--setups auto|N, got {n:?}"))?),
    })
}

fn parse_range(spec: &str) -> anyhow::Result<[f64; 2]> {
    let parts: Vec<&str> = spec.split(',').collect();
    let [lo, hi] = parts[..] else { bail!("--tilt-range MIN,MAX in degrees, got {spec:?}") };
    let num = |s: &str| s.trim().parse::<f64>().with_context(|| format!("--tilt-range: bad angle {s:?}"));
    Ok([num(lo)?, num(hi)?])
}

/// `1234567` as `1.2M`.
fn human_count(n: u64) -> String {
    match n {
        0..1_000 => n.to_string(),
        1_000..1_000_000 => format!("{:.1}k", n as f64 / 1e3),
        _ => format!("{:.1}M", n as f64 / 1e6),
    }
}

/// Seconds as `m:ss` (or `h:mm:ss`).
fn human_duration(s: f64) -> String {
    let s = s.round() as u64;
    let (h, m, s) = (s / 3600, s / 60 % 60, s % 60);
    if h > 0 { format!("{h}:{m:02}:{s:02}") } else { format!("{m}:{s:02}") }
}

/// Where a program is written before it is renamed to `path`: a hidden file beside it.
fn partial_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.partial-{}", std::process::id()))
}

fn program_paths(output: &Path, n: usize) -> Vec<PathBuf> {
    if n == 1 {
        return vec![output.to_path_buf()];
    }
    let stem =
        output.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "program".into());
    let ext = output.extension().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "ngc".into());
    (1..=n).map(|i| output.with_file_name(format!("{stem}.{i}.{ext}"))).collect()
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    // `--time-limit` counts from here: loading and fine-tuning are part of the run.
    let started = std::time::Instant::now();
    let mesh_path = args.mesh.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_MESH));
    let mesh = load_mesh(&mesh_path)?;
    let opts = mill_options(&args, &mesh)?;
    let mut policy = choose_policy(&args, &mesh, &mesh_path, &opts)?;
    let limit = match args.time_limit {
        Some(s) if s.is_finite() && s > 0.0 => Some(Duration::from_secs_f64(s)),
        Some(s) => bail!("--time-limit must be a positive number of seconds, got {s}"),
        None => None,
    };
    let past_limit = |stage: &str| -> anyhow::Result<()> {
        match limit {
            Some(limit) if started.elapsed() >= limit => bail!(
                "milling {}: time limit of {} s reached while {stage}",
                mesh_path.display(),
                limit.as_secs_f64()
            ),
            _ => Ok(()),
        }
    };
    past_limit("loading the mesh and the policy")?;
    let mut bar = Progress::new(args.json, started);
    let mut progress = |stage: Stage| bar.stage(stage);
    let stem =
        mesh_path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "part".into());
    let output = args.output.clone().unwrap_or_else(|| PathBuf::from("out").join(format!("{stem}.ngc")));
    if let Some(dir) = output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    // Per-setup programs are streamed into temporary files beside their paths as they are
    // planned (never held whole: a fine action writes gigabytes), and renamed into place
    // only once the whole run has succeeded; the rotary layout's one program is kept.
    let mut run = MillRun::new(&mesh, &opts, &mut progress)
        .with_context(|| format!("milling {}", mesh_path.display()))?;
    if let Some(limit) = limit {
        past_limit("choosing tool orientations")?;
        run.time_limit(started, limit);
    }
    run.keep_trace(args.render.is_some());
    let streamed = matches!(opts.layout, ProgramLayout::PerSetup);
    // Rest roughing may add a program per setup and pass: names for as many, of which the
    // run's programs take the first.
    let paths = program_paths(&output, if streamed { run.program_bound() } else { 1 });
    let partial: Vec<PathBuf> = paths.iter().map(|p| partial_path(p)).collect();
    if streamed {
        let files = partial.clone();
        run.stream_programs(move |i| {
            let file = std::fs::File::create(&files[i])?;
            Ok(Box::new(std::io::BufWriter::with_capacity(1 << 20, file)) as Box<dyn std::io::Write + Send>)
        });
    }
    let milled = match run.complete(policy.as_mut(), &mut progress) {
        Ok(milled) => milled,
        Err(e) => {
            for p in &partial {
                let _ = std::fs::remove_file(p);
            }
            return Err(e).with_context(|| format!("milling {}", mesh_path.display()));
        }
    };
    bar.finish();
    // The programs written, named for their number (one program is `output` itself).
    let paths = if streamed { program_paths(&output, milled.programs.len()) } else { paths };

    if streamed {
        for (from, to) in partial.iter().zip(&paths) {
            std::fs::rename(from, to).with_context(|| format!("writing {}", to.display()))?;
        }
    } else {
        for (path, text) in paths.iter().zip(&milled.programs) {
            write_bytes_atomic(path, text.as_bytes())?;
        }
    }
    if let Some(path) = &args.tool_table {
        write_bytes_atomic(path, opts.library().to_linuxcnc_table().as_bytes())?;
    }
    let text = write_report(&args, &milled, &mesh_path, &paths)?;
    if args.json {
        print!("{text}");
    } else {
        print_summary(&milled, &mesh_path, &paths, opts.layout);
    }
    // An open mesh has no inside of its own: the simulation's part is a vote of voxel
    // columns (and the winding number), while the planner keeps the tool off the surfaces
    // alone, so it may reach into the part where the mesh is open. (After the run, so that
    // a run that fails says one line.)
    let check = shape2gcode::geom::report(&mesh);
    if !check.closed {
        eprintln!(
            "s2g mill: warning: {} is not closed ({} boundary edges): the tool may enter the part where it is open, and the simulation counts that as gouges",
            mesh_path.display(),
            check.boundary_edges
        );
    }
    Ok(if milled.is_safe() { ExitCode::SUCCESS } else { ExitCode::from(2) })
}

/// Whether the shop preset's grid goes through the part's flat faces: unless
/// `--no-face-grid` (the later of it and `--face-grid` stands).
fn face_grid(args: &Args) -> bool {
    args.face_grid || !args.no_face_grid
}

/// Whether the shop preset's setups are chosen for a tool-aware reach: unless
/// `--no-tool-aware-reach` (the later of it and `--tool-aware-reach` stands).
fn tool_aware_reach(args: &Args) -> bool {
    args.tool_aware_reach || !args.no_tool_aware_reach
}

/// The library's options from the command line.
fn mill_options(args: &Args, mesh: &Mesh) -> anyhow::Result<MillOptions> {
    let preset = match args.preset.as_str() {
        "paper" => Preset::Paper,
        "shop" => Preset::Shop,
        p => bail!("unknown preset {p:?} (paper or shop)"),
    };
    let layout = match args.layout.as_str() {
        "per-setup" => ProgramLayout::PerSetup,
        "ac" => ProgramLayout::Rotary(RotaryAxes::AC),
        "bc" => ProgramLayout::Rotary(RotaryAxes::BC),
        l => bail!("unknown layout {l:?} (per-setup, ac or bc)"),
    };
    let input_scale = input_scale(args, mesh, preset)?;
    let shop_only = args.tools.is_some() || args.tool_table.is_some() || args.material != "aluminium-6061";
    if preset == Preset::Paper && shop_only {
        bail!(
            "--tools, --material and --tool-table are for the shop preset; the paper preset machines with the paper's tools"
        );
    }
    let tools = args.tools.as_ref().map(|p| crate::tools::library(Some(p))).transpose()?;
    let resolution = match args.voxel {
        None => args.res,
        Some(voxel) => {
            let extent = mesh.bbox().map(|b| b.extent()).unwrap_or_default();
            // The paper preset scales the part's longest side to its 100 mm.
            let mm = match preset {
                Preset::Paper => MillOptions::default().paper_scale_mm / extent.max().max(f64::MIN_POSITIVE),
                Preset::Shop => input_scale,
            };
            let extent = [extent.x * mm, extent.y * mm, extent.z * mm];
            let (resolution, bounded) =
                resolution_for_voxel(extent, voxel, MillOptions::default().stock_margin, args.max_voxels)?;
            if bounded {
                eprintln!(
                    "note: --voxel {voxel} mm needs more than {} voxels or 2048 along the longest side; simulating at --res {resolution}",
                    args.max_voxels
                );
            }
            resolution
        }
    };
    Ok(MillOptions {
        tools,
        material: args.material.clone(),
        preset,
        input_scale,
        setups: parse_setups(&args.setups)?,
        dialect: args.dialect,
        layout,
        rotary_tilt_range_deg: parse_range(&args.tilt_range)?,
        resolution,
        paper_space_scale: parse_space(&args.space, resolution)?,
        seed: args.seed,
        orient_points: args.points,
        roughing_depth_diameters: args.roughing_depth,
        flank_walls: !args.front_facing,
        face_grid: face_grid(args),
        tool_aware_reach: tool_aware_reach(args),
        reach_slack: args.reach_slack,
        max_estimated_hours: args.max_hours,
        arc_tolerance: arc_tolerance(args.arc_tolerance, preset),
        stock: parse_stock(args)?,
        datum: parse_datum(args.datum.as_deref())?,
        stock_removal: !args.visibility_only_setups,
        finish: finish_choice(args, preset, layout)?,
        finish_allowance: parse_allowance(&args.allowance)?,
        surface_spacing: args.surface_spacing,
        metric_samples: args.metric_samples,
        rest_roughing: args.rest_roughing,
        rest_continue: args.rest_continue,
        ..MillOptions::default()
    })
}

/// The resolution (voxels along the longest side of a part of `extent` mm) whose voxels are
/// `voxel` mm, and whether a bound coarsened it: the grid over the part's box grown by
/// `margin` of its longest side on every side holds at most `max_voxels`, and the resolution
/// stays within the run's limits ([`MillOptions::RESOLUTIONS`], 8 to 2048).
pub fn resolution_for_voxel(
    extent: [f64; 3],
    voxel: f64,
    margin: f64,
    max_voxels: u64,
) -> anyhow::Result<(usize, bool)> {
    let l = extent.iter().copied().fold(0.0, f64::max);
    if !(voxel.is_finite() && voxel > 0.0) {
        bail!("--voxel must be a positive length in mm, got {voxel}");
    }
    if !(l.is_finite() && l > 0.0) {
        bail!("--voxel needs a part with extent");
    }
    let count = |r: usize| {
        let h = l / r as f64;
        extent.iter().map(|e| ((e + 2.0 * margin * l) / h).ceil().max(1.0)).product::<f64>()
    };
    // Voxels strictly finer than asked: a round size over a part of round length would put
    // voxel centres on the faces at round millimetres (the grid is centred on the part),
    // where a flat end mill's bottom at the face takes the voxel the part counts as its own.
    let (lo, hi) = (*MillOptions::RESOLUTIONS.start(), *MillOptions::RESOLUTIONS.end());
    let wanted = ((l / voxel).floor() as usize + 1).max(lo);
    let mut r = wanted.min(hi);
    while r > lo && count(r) > max_voxels as f64 {
        r = ((r as f64 * (max_voxels as f64 / count(r)).cbrt()).floor() as usize).clamp(lo, r - 1);
    }
    Ok((r, r < wanted))
}

/// Millimetres per mesh unit from `--units`, `--scale` and `--size` (shop preset only).
fn input_scale(args: &Args, mesh: &Mesh, preset: Preset) -> anyhow::Result<f64> {
    if preset == Preset::Paper {
        if args.units.is_some() || args.scale.is_some() || args.size.is_some() {
            bail!(
                "--units, --scale and --size size the part in the shop preset; the paper preset normalises it to 100 mm"
            );
        }
        return Ok(1.0);
    }
    let unit = match args.units.as_deref() {
        None | Some("mm") => 1.0,
        Some("in") => 25.4,
        Some("m") => 1000.0,
        Some(u) => bail!("unknown unit {u:?} (mm, in or m)"),
    };
    if let Some(size) = args.size {
        let longest = mesh.bbox().map_or(0.0, |b| b.extent().max());
        if !(size.is_finite() && size > 0.0 && longest > 0.0) {
            bail!(
                "--size must be a positive length of a mesh with extent, got {size} for a mesh {longest} long"
            );
        }
        return Ok(size / longest);
    }
    let scale = args.scale.unwrap_or(1.0);
    if !(scale.is_finite() && scale > 0.0) {
        bail!("--scale must be a positive number, got {scale}");
    }
    Ok(unit * scale)
}

/// The policy `--policy` names, fine-tuned on the mesh first when `--finetune` asks.
fn choose_policy(
    args: &Args,
    mesh: &Mesh,
    mesh_path: &Path,
    opts: &MillOptions,
) -> anyhow::Result<Box<dyn Policy>> {
    if args.finetune == 0 {
        return policy_by_name(&args.policy, &opts.action_space(), args.seed).with_context(|| {
            format!(
                "unknown policy {:?} (learned, heuristic, random, fixed-fine, fixed-coarse, fixed:R,H,S or a policy file)",
                args.policy
            )
        });
    }
    let mut learned = LearnedPolicy::named(&args.policy).with_context(|| {
        format!("--finetune needs `learned` or a policy file as --policy, got {:?}", args.policy)
    })?;
    // Fine-tuning episodes mill the part as this run will, on the training grid.
    let resolution = args.finetune_res.unwrap_or(learned.info().resolution);
    let train = TrainOptions {
        seed: args.seed,
        mill: MillOptions { resolution, ..opts.clone() },
        ..TrainOptions::default()
    };
    let stem = mesh_path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let returns = learned.finetune(mesh, &stem, args.finetune, &train, &mut |e| {
        eprintln!(
            "s2g mill: fine-tuning episode {} of {}: return {:.4}",
            e.episode + 1,
            args.finetune,
            e.total_reward
        )
    })?;
    eprintln!(
        "s2g mill: fine-tuned for {} episodes, last return {:.4}",
        returns.len(),
        returns.last().copied().unwrap_or(0.0)
    );
    Ok(Box::new(learned))
}

/// The progress line on stderr: steps are orientation, action selection, then planning and
/// simulation per setup, then scoring; the number of setups is known once planning starts.
/// Only for a person at a terminal (indicatif draws nothing otherwise), and never with
/// `--json`.
struct Progress {
    bar: ProgressBar,
    /// When the current setup's planning began, for its estimate of the time left.
    setup_started: std::time::Instant,
}

impl Progress {
    fn new(hidden: bool, started: std::time::Instant) -> Self {
        let bar = if hidden { ProgressBar::hidden() } else { ProgressBar::new(3) };
        bar.set_style(
            ProgressStyle::with_template("{spinner} {elapsed} [{bar:24}] {pos}/{len} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.enable_steady_tick(Duration::from_millis(120));
        Self { bar, setup_started: started }
    }

    fn stage(&mut self, stage: Stage) {
        let bar = &self.bar;
        let (pos, msg) = match stage {
            Stage::Orientation => (0, "choosing tool orientations".to_string()),
            Stage::ActionSelection => (1, "choosing tool, layer height and strategy".to_string()),
            Stage::GcodeTranslation { setup, setups } => {
                self.setup_started = std::time::Instant::now();
                bar.set_length(3 + 2 * setups as u64);
                (
                    2 * setup as u64,
                    format!("setup {setup}/{setups}: planning toolpaths, writing and simulating G-code"),
                )
            }
            Stage::Layers { setup, setups, done, levels, moves } => {
                let eta = (done > 0 && levels > done).then(|| {
                    let left =
                        self.setup_started.elapsed().as_secs_f64() * (levels - done) as f64 / done as f64;
                    format!(", about {} left in this setup", human_duration(left))
                });
                (
                    2 * setup as u64,
                    format!(
                        "setup {setup}/{setups}: layer {done}/{levels} planned, {} moves simulated{}",
                        human_count(moves),
                        eta.unwrap_or_default()
                    ),
                )
            }
            Stage::Simulation { setup, setups } => {
                (1 + 2 * setup as u64, format!("setup {setup}/{setups}: simulating the G-code"))
            }
            Stage::Scoring => (bar.length().unwrap_or(3) - 1, "scoring the residual stock".to_string()),
        };
        bar.set_position(pos);
        bar.set_message(msg);
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// The JSON report, with the files written beside it (`--residual`, `--render`, and
/// `--report` itself); returns its text.
fn write_report(args: &Args, milled: &Milled, mesh_path: &Path, paths: &[PathBuf]) -> anyhow::Result<String> {
    let mut report = milled.report_json(!args.reproducible);
    report["input"] = serde_json::json!(mesh_path.display().to_string());
    report["programs"] = serde_json::json!(paths.iter().map(|p| p.display().to_string()).collect::<Vec<_>>());
    report["layout"] = serde_json::json!(args.layout);
    if let Some(setups) = report["setups"].as_array_mut() {
        for (s, sp) in setups.iter_mut().zip(&milled.setups) {
            if let Some(a) = sp.rotary_deg {
                s["rotary_deg"] = serde_json::json!(a);
            }
        }
    }
    if let Some(p) = &args.residual {
        save_mesh(p, &milled.residual)?;
        report["residual"] = serde_json::json!(p.display().to_string());
    }
    if let Some(p) = &args.render {
        let img =
            render_machining(&milled.residual, &milled.stock, Some((&milled.trace, milled.trace_axis)), 480);
        write_bytes_atomic(p, &img.to_png())?;
        report["render"] = serde_json::json!(p.display().to_string());
    }
    let text = serde_json::to_string_pretty(&report)? + "\n";
    if let Some(p) = &args.report {
        write_bytes_atomic(p, text.as_bytes())?;
    }
    Ok(text)
}

/// The summary on stdout: setups, metrics, safety and stage times.
fn print_summary(milled: &Milled, mesh_path: &Path, paths: &[PathBuf], layout: ProgramLayout) {
    let m = &milled.metrics;
    let s = &milled.simulation;
    let own = milled.setups.iter().filter(|s| s.rest_of.is_none()).count();
    println!(
        "{}: {own} setup(s) in {} program(s), policy {}",
        mesh_path.display(),
        milled.setups.len(),
        milled.policy
    );
    let mut own = 0;
    for (i, sp) in milled.setups.iter().enumerate() {
        let a = sp.setup.tool_axis();
        // A setup's rest-roughing programs follow its own, under its number.
        let label = match sp.rest_of {
            Some(k) => format!("setup {k}, rest roughing"),
            None => {
                own += 1;
                format!("setup {own}")
            }
        };
        let rotary = match (sp.rotary_deg, layout) {
            (Some([a, _, c]), ProgramLayout::Rotary(RotaryAxes::AC)) => format!(" at A{a} C{c}"),
            (Some([_, b, c]), ProgramLayout::Rotary(RotaryAxes::BC)) => format!(" at B{b} C{c}"),
            _ => String::new(),
        };
        println!(
            "  {label}: tool axis ({:+.3} {:+.3} {:+.3}){rotary}, radius {}, layer {:.6}, {}, {} layers -> {}",
            a.x,
            a.y,
            a.z,
            sp.action.tool_radius,
            sp.action.layer_height,
            sp.action.strategy.name(),
            sp.plan.layers,
            paths.get(i).unwrap_or(&paths[0]).display()
        );
        if let Some(t) = sp.machine_time_s {
            let tool = &sp.tool;
            println!(
                "    T{} ({} mm, flutes {} mm) S{:.0} F{:.0}: {} on the machine",
                tool.number,
                tool.diameter(),
                tool.flute_length(),
                tool.spindle_rpm,
                tool.feed,
                human_duration(t)
            );
        }
        if let Some(f) = &sp.finish {
            let d = &f.deviation;
            println!(
                "    finish T{} ({} mm {}) {} passes, scallop {} mm: roughing {}, finishing {}; surface max {:.4} mean {:.4} gouge {:.4} mm",
                f.tool.number,
                f.tool.diameter(),
                f.choice.strategy.name(),
                f.summary.passes,
                f.choice.scallop,
                human_duration(f.roughing_time_s),
                human_duration(f.finishing_time_s),
                d.max,
                d.mean,
                d.gouge_depth
            );
            if f.summary.guarded_points > 0 {
                println!(
                    "    finish left out {} pass points where the shank or holder would meet the roughing's stock",
                    f.summary.guarded_points
                );
            }
            if d.unpassed > 0 {
                println!(
                    "    surface no finishing pass went over: {} columns, {:.2} mm2, max {:.4} mm (not in the max above)",
                    d.unpassed, d.unpassed_area, d.unpassed_max
                );
            }
        }
        if !sp.holder_collision_lines.is_empty() {
            println!("    holder collisions at lines {:?}", sp.holder_collision_lines);
        }
    }
    if let Some(d) = &milled.surface_deviation {
        println!(
            "finished surface over all setups: max {:.4} mm, 99 % under {:.4} mm, mean {:.4} mm ({} of {} samples reached)",
            d.max,
            d.p99,
            d.mean,
            d.samples,
            shape2gcode::PartDeviation::SAMPLES
        );
    }
    // The shop's time is the machine's (acceleration included), the paper's length / feed.
    let machine: Option<f64> = milled.setups.iter().map(|sp| sp.machine_time_s).sum();
    println!(
        "IoU {:.4}  F1 {:.4}  CD x1000 {:.4}  NC {:.4}  time {:.1} s",
        m.iou,
        m.f1,
        m.chamfer_x1000,
        m.normal_consistency,
        machine.unwrap_or(s.machining_time_s)
    );
    println!(
        "gouges {} voxels, rapid collisions {}, holder collisions {}",
        s.gouge_voxels,
        milled.rapid_collisions(),
        s.holder_collisions.len()
    );
    let t = &milled.stage_seconds;
    println!(
        "stages: orientation {:.2} s, actions {:.3} s, G-code {:.2} s, simulation {:.2} s, scoring {:.2} s",
        t.orientation, t.action_selection, t.gcode_translation, t.simulation, t.scoring
    );
}

#[cfg(test)]
mod tests {
    use super::{Args, face_grid, resolution_for_voxel, tool_aware_reach};
    use clap::Parser;

    /// `s2g mill part.stl EXTRA...` parsed.
    fn parsed(extra: &[&str]) -> Args {
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            args: Args,
        }
        let argv = ["s2g", "part.stl"].into_iter().chain(extra.iter().copied());
        Cli::try_parse_from(argv).expect("arguments s2g mill takes").args
    }

    #[test]
    fn the_face_grid_is_on_unless_no_face_grid_comes_last() {
        let on = |extra: &[&str]| face_grid(&parsed(extra));
        assert!(on(&[]));
        assert!(on(&["--face-grid"]));
        assert!(!on(&["--no-face-grid"]));
        assert!(on(&["--no-face-grid", "--face-grid"]));
        assert!(!on(&["--face-grid", "--no-face-grid"]));
    }

    #[test]
    fn the_tool_aware_reach_is_on_unless_no_tool_aware_reach_comes_last() {
        let on = |extra: &[&str]| tool_aware_reach(&parsed(extra));
        assert!(on(&[]));
        assert!(on(&["--tool-aware-reach"]));
        assert!(!on(&["--no-tool-aware-reach"]));
        assert!(on(&["--no-tool-aware-reach", "--tool-aware-reach"]));
        assert!(!on(&["--tool-aware-reach", "--no-tool-aware-reach"]));
    }

    #[test]
    fn voxel_size_sets_the_resolution_within_the_bounds() {
        // A 2 mm bar 200 mm long: 0.2 mm voxels are 1,000 along it, 10 across; one more
        // puts the voxels' centres off the round millimetres.
        let (r, bounded) = resolution_for_voxel([200.0, 2.0, 2.0], 0.2, 0.02, 1 << 28).unwrap();
        assert_eq!((r, bounded), (1001, false));
        assert_eq!(resolution_for_voxel([200.0, 2.0, 2.0], 0.3, 0.02, 1 << 28).unwrap(), (667, false));
        // A 100 mm cube at 0.05 mm would need 2,000^3 voxels: the bound coarsens it, and the
        // grid (the part's box and margin) then fits the bound.
        let (r, bounded) = resolution_for_voxel([100.0; 3], 0.05, 0.02, 1 << 28).unwrap();
        assert!(bounded && r < 2001, "{r}");
        let h = 100.0 / r as f64;
        let count = (104.0 / h).ceil().powi(3);
        assert!(count <= (1u64 << 28) as f64, "{count}");
        assert!(((104.0 / (100.0 / (r + 1) as f64)).ceil().powi(3)) > (1u64 << 28) as f64 * 0.9);
        // The longest side's limit.
        assert_eq!(resolution_for_voxel([1000.0, 1.0, 1.0], 0.1, 0.0, u64::MAX).unwrap(), (2048, true));
        assert!(resolution_for_voxel([10.0; 3], 0.0, 0.02, 1 << 28).is_err());
        assert!(resolution_for_voxel([0.0; 3], 0.1, 0.02, 1 << 28).is_err());
    }
}
