//! [`mill`]: mesh to checked, simulated and scored G-code (seed 000 Figure 2).
//!
//! load -> check -> normalise -> choose setups (orient) -> per setup: features ->
//! policy -> plan (toolpath) -> write G-code text (gcode) -> **parse the text back**
//! -> simulate every setup in the part frame (voxsim) -> score (geom metrics,
//! rewards). What is scored is what a machine would run.

use std::time::Instant;

use crate::gcode::{
    Dialect, GcodeWriter, Motion, MotionSink, ParseOptions, RotaryAxes, WriterOptions, parse_str,
};
use crate::geom::{
    Aabb, GridSpec, Mesh, MeshIndex, MetricOptions, Normalization, Point3, Setup, ShapeMetrics,
    TAUBIN_LAMBDA, TAUBIN_MU, Vector3, VoxelGrid, compare, marching_cubes_voxels, sample_surface,
    taubin_smooth, unit_cube_normalization, voxelize,
};
use crate::orient::{OrientOptions, OrientationResult, select_orientations};
use crate::policy::{Action, ActionSpace, Policy, SetupContext, SetupFeatures, StrategyKind};
use crate::render::PathTrace;
use crate::toolpath::{PlanOptions, PlanSummary, Strategy, Tool, ToolKind, VoxelMaterial, plan_setup_rest};
use crate::voxsim::{Carver, Cutter, RewardWeights, Rewards, SimOptions, SimReport, Simulator, ToolTable};

/// Units and action space of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Preset {
    /// The paper's convention: the part is normalised into [-0.5, 0.5]^3 (max extent 1,
    /// centred) and the action space is the paper's (tool radius 0.001-0.01, layer
    /// height 1/512-1/64, in normalised units). A machine needs real sizes, so the
    /// normalised part is machined at [`MillOptions::paper_scale_mm`] millimetres per
    /// unit (default 100: tools of 0.1-1 mm radius, layers of 0.2-1.6 mm).
    #[default]
    Paper,
    /// Part units (mm) with a shop tool library ([`ActionSpace::shop`]).
    Shop,
}

/// How many setups.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SetupCount {
    /// Up to five, fewer when 99 % coverage is reached sooner.
    #[default]
    Auto,
    /// Exactly this many (the best set of that size).
    Exactly(usize),
}

/// How the setups become programs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ProgramLayout {
    /// One 3-axis program per setup; the fixture rotation is stated in its header comment.
    #[default]
    PerSetup,
    /// One 3+2 program for a table-table machine with these rotary axes.
    Rotary(RotaryAxes),
}

/// Options of [`mill`]. Every field has a documented default.
#[derive(Debug, Clone, PartialEq)]
pub struct MillOptions {
    /// Units and action space. Default: [`Preset::Paper`].
    pub preset: Preset,
    /// Number of setups. Default: [`SetupCount::Auto`].
    pub setups: SetupCount,
    /// Voxels along the stock's longest axis in the simulation. Default 256 (the paper's).
    pub resolution: usize,
    /// Controller dialect of the programs. Default LinuxCNC.
    pub dialect: Dialect,
    /// One program per setup or one 3+2 program. Default: per setup.
    pub layout: ProgramLayout,
    /// Surface points for orientation selection. Default 16,384 (the paper's).
    pub orient_points: usize,
    /// Candidate directions for orientation selection. Default 512 (+ the six axes).
    pub orient_candidates: usize,
    /// Samples per mesh for Chamfer and normal consistency. Default 8,000 (the paper's).
    pub metric_samples: usize,
    /// Seed of every random choice. Default 0.
    pub seed: u64,
    /// Stock margin around the part's bounding box, as a fraction of its largest
    /// extent (shop preset only; the paper preset's stock is the unit cube). Default 0.02.
    pub stock_margin: f64,
    /// Millimetres per normalised unit in the paper preset. Default 100.
    pub paper_scale_mm: f64,
    /// Clearing strategies the policy may choose from. Default: all three.
    pub strategies: Vec<StrategyKind>,
    /// Taubin smoothing iterations (lambda 0.5, mu -0.53) applied to the residual mesh
    /// before scoring and writing. Marching cubes of a voxel occupancy puts every vertex on
    /// an edge midpoint, so a wall that is not parallel to a grid plane comes out as a
    /// staircase whose normals are off by up to 45 degrees; a few volume-preserving
    /// low-pass steps recover the wall's direction while moving vertices by well under a
    /// voxel. 0 keeps the raw staircase. Default 8.
    pub residual_smoothing: usize,
    /// How the simulator removes material. Default [`Carver::Exact`]; [`Carver::Dexel`]
    /// falls back to exact for setups whose axis is not a grid axis; the paper's
    /// Monte-Carlo carver is there to compare against.
    pub carver: Carver,
    /// Run the contour pass on every layer (the paper always does). Default true.
    pub contour: bool,
}

impl Default for MillOptions {
    fn default() -> Self {
        Self {
            preset: Preset::Paper,
            setups: SetupCount::Auto,
            resolution: 256,
            dialect: Dialect::LinuxCnc,
            layout: ProgramLayout::PerSetup,
            orient_points: 16384,
            orient_candidates: 512,
            metric_samples: 8000,
            seed: 0,
            stock_margin: 0.02,
            paper_scale_mm: 100.0,
            strategies: StrategyKind::ALL.to_vec(),
            residual_smoothing: 8,
            carver: Carver::Exact,
            contour: true,
        }
    }
}

/// Everything [`mill`] can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MillError {
    /// The mesh or a geometric step failed.
    #[error(transparent)]
    Geom(#[from] crate::geom::GeomError),
    /// Orientation selection failed.
    #[error("orientation selection: {0}")]
    Orient(#[from] crate::orient::OrientError),
    /// Planning a setup failed.
    #[error("planning setup {setup}: {message}")]
    Plan {
        /// 1-based setup.
        setup: usize,
        /// What went wrong.
        message: String,
    },
    /// Writing or re-reading a program failed.
    #[error("program of setup {setup}: {message}")]
    Program {
        /// 1-based setup.
        setup: usize,
        /// What went wrong.
        message: String,
    },
    /// The simulation failed.
    #[error("simulation: {0}")]
    Simulation(String),
    /// An option is out of range.
    #[error("invalid option: {0}")]
    InvalidOption(String),
}

/// A stage of the pipeline, for progress reports and timings (seed 000 Table A1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Orientation selection.
    Orientation,
    /// Features and the policy's choice.
    ActionSelection,
    /// Planning and writing G-code.
    GcodeTranslation,
    /// Parsing the programs back and simulating them.
    Simulation,
    /// Metrics.
    Scoring,
}

/// Seconds per stage.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StageSeconds {
    /// Orientation selection.
    pub orientation: f64,
    /// Action selection (features + policy).
    pub action_selection: f64,
    /// Toolpath planning and G-code writing.
    pub gcode_translation: f64,
    /// Parsing back and simulating.
    pub simulation: f64,
    /// Marching cubes and metrics.
    pub scoring: f64,
}

/// One setup's program and what went into it.
#[derive(Debug, Clone, PartialEq)]
pub struct SetupProgram {
    /// The setup (frame: setup coordinates to part coordinates, in part units).
    pub setup: Setup,
    /// The action the policy chose.
    pub action: Action,
    /// The planner's summary.
    pub plan: PlanSummary,
    /// The G-code text.
    pub text: String,
    /// Target voxels this setup's program removed.
    pub gouge_voxels: u64,
    /// Lines of this setup's program where a rapid move removed material.
    pub rapid_collision_lines: Vec<u64>,
}

/// The outcome of [`mill`].
#[derive(Debug, Clone)]
pub struct Milled {
    /// The preset the run used.
    pub preset: Preset,
    /// The policy's name.
    pub policy: String,
    /// The programs: one per setup, or one 3+2 program (then `programs.len() == 1`
    /// and `setups` still lists every setup).
    pub programs: Vec<String>,
    /// Per setup: frame, action, plan summary (its text is in `programs`).
    pub setups: Vec<SetupProgram>,
    /// Orientation selection (coverage, baselines).
    pub orientation: OrientationResult,
    /// The simulator's report over all setups.
    pub simulation: SimReport,
    /// The paper's rewards (Eq. 10-13).
    pub rewards: Rewards,
    /// IoU, F1, Chamfer x1000 and normal consistency of the residual stock against
    /// the part, both normalised into the unit cube.
    pub metrics: ShapeMetrics,
    /// The residual stock as a mesh, in part units (the input mesh's frame).
    pub residual: Mesh,
    /// The stock box, in part units.
    pub stock: Aabb,
    /// The first setup's toolpath in part units, for rendering.
    pub trace: PathTrace,
    /// The first setup's tool axis in the part frame.
    pub trace_axis: Vector3,
    /// Wall time per stage (not part of anything compared byte for byte).
    pub stage_seconds: StageSeconds,
}

impl Milled {
    /// Program lines, over all setups, where a rapid move removed material.
    pub fn rapid_collisions(&self) -> usize {
        self.setups.iter().map(|s| s.rapid_collision_lines.len()).sum()
    }

    /// Whether the programs are safe: no gouge into the part and no rapid through material.
    pub fn is_safe(&self) -> bool {
        self.simulation.gouge_voxels == 0 && self.rapid_collisions() == 0
    }
}

/// Mills `mesh` with `policy`. See the module docs for the stages; `progress` is told
/// when each stage starts.
pub fn mill(
    mesh: &Mesh,
    policy: &mut dyn Policy,
    opts: &MillOptions,
    progress: &mut dyn FnMut(Stage),
) -> Result<Milled, MillError> {
    if opts.resolution < 8 || opts.resolution > 2048 {
        return Err(MillError::InvalidOption(format!(
            "resolution must be 8..=2048, got {}",
            opts.resolution
        )));
    }
    if mesh.is_empty() {
        return Err(crate::geom::GeomError::EmptyMesh.into());
    }
    let mut times = StageSeconds::default();

    // Units: the paper plans in the unit cube; the shop in part units. `to_input`
    // maps planning units back to the input mesh's units.
    let unit: Normalization = unit_cube_normalization(mesh)?;
    let (part, space, stock, to_input) = match opts.preset {
        Preset::Paper => {
            let k = opts.paper_scale_mm;
            if !(k.is_finite() && k > 0.0) {
                return Err(MillError::InvalidOption(format!("paper_scale_mm must be positive, got {k}")));
            }
            let norm = Normalization { scale: unit.scale * k, translation: unit.translation * k };
            let part = mesh.transformed(&norm.as_similarity());
            let half = 0.5 * k;
            let stock = Aabb::new(Point3::new(-half, -half, -half), Point3::new(half, half, half));
            (part, ActionSpace::paper().scaled(k), stock, norm)
        }
        Preset::Shop => {
            let bbox = mesh.bbox().ok_or(crate::geom::GeomError::EmptyMesh)?;
            let margin = opts.stock_margin.max(0.0) * bbox.extent().max();
            (mesh.clone(), ActionSpace::shop(), bbox.inflated(margin), Normalization::identity())
        }
    };
    let mut space = space;
    space.strategies.retain(|s| opts.strategies.contains(s));
    if space.strategies.is_empty() {
        return Err(MillError::InvalidOption("no clearing strategy left to choose from".into()));
    }

    // Orientation selection.
    progress(Stage::Orientation);
    let t = Instant::now();
    let mut oopts = OrientOptions {
        points: opts.orient_points,
        candidates: opts.orient_candidates,
        seed: opts.seed,
        ..OrientOptions::default()
    };
    if let SetupCount::Exactly(n) = opts.setups {
        oopts.max_setups = n.max(1);
        oopts.coverage_target = 1.0;
    }
    let orientation = select_orientations(&part, &oopts)?;
    times.orientation = t.elapsed().as_secs_f64();

    // Actions.
    progress(Stage::ActionSelection);
    let t = Instant::now();
    let index = MeshIndex::new(&part)?;
    let samples = sample_surface(&part, 4096, opts.seed ^ 0x5eed)?;
    let diag = stock.extent().norm();
    let mut actions = Vec::with_capacity(orientation.setups.len());
    for (i, setup) in orientation.setups.iter().enumerate() {
        let mut features = setup_features(&index, &samples, setup, &space, diag, &stock);
        features.voxel = stock.extent().max() / opts.resolution as f64;
        let ctx = SetupContext { index: i, space: &space, features: &features };
        actions.push(policy.choose(&ctx));
    }
    times.action_selection = t.elapsed().as_secs_f64();

    // Per setup: plan against the material earlier setups left (rest machining), write
    // the program, then parse the written text back into the simulator.
    let decimals = 4;
    let (feed, rapid) = feeds(opts.preset);
    let t = Instant::now();
    let spec = GridSpec::cubic(&stock, opts.resolution)?;
    let target = voxelize(&part, &spec)?;
    let mut tools = ToolTable::single(Cutter::flat(actions.first().map_or(1.0, |a| a.tool_radius), diag));
    for a in &actions {
        tools = tools.with(tool_number(&space, a), Cutter::flat(a.tool_radius, diag));
    }
    let sim_opts = SimOptions { carver: opts.carver, rapid_rate_mm_per_min: rapid, ..SimOptions::default() };
    let sim_err = |e: crate::voxsim::SimError| MillError::Simulation(e.to_string());
    let mut sim = Simulator::new(VoxelGrid::full(spec), tools, sim_opts)
        .map_err(sim_err)?
        .with_target(&target)
        .map_err(sim_err)?;
    times.simulation += t.elapsed().as_secs_f64();

    let mut setups = Vec::with_capacity(actions.len());
    let mut trace = PathTrace::default();
    let mut remaining = sim.residual_grid();
    for (i, (setup, action)) in orientation.setups.iter().zip(&actions).enumerate() {
        progress(Stage::GcodeTranslation);
        let t = Instant::now();
        let rest = VoxelMaterial { grid: &remaining, setup: *setup };
        let tool = Tool {
            radius: action.tool_radius,
            kind: ToolKind::Flat,
            flute_length: diag,
            feed,
            plunge_feed: feed / 3.0,
            spindle_rpm: 12000.0,
            number: tool_number(&space, action),
        };
        let popts = PlanOptions {
            layer_height: action.layer_height,
            strategy: match action.strategy {
                StrategyKind::Zigzag => Strategy::Zigzag { angle_deg: 0.0 },
                StrategyKind::Periphery => Strategy::Periphery,
                StrategyKind::Spiral => Strategy::Spiral,
            },
            contour: opts.contour,
            // Appendix A.1: start 0.1 (of the normalised part) above the top.
            clearance_height: 0.1 * stock.extent().max(),
            stock: Some(stock_in_setup(&stock, setup)),
            rapid_feed: rapid,
            ..PlanOptions::default()
        };
        let wopts = WriterOptions { decimals, ..WriterOptions::default() };
        let mut writer = GcodeWriter::new(Vec::new(), opts.dialect, wopts);
        let plan = plan_setup_rest(&part, setup, &tool, &popts, Some(&rest), &mut writer)
            .map_err(|e| MillError::Plan { setup: i + 1, message: e.to_string() })?;
        writer.finish().map_err(|e| MillError::Program { setup: i + 1, message: e.to_string() })?;
        let text = String::from_utf8(writer.into_inner())
            .map_err(|e| MillError::Program { setup: i + 1, message: e.to_string() })?;
        times.gcode_translation += t.elapsed().as_secs_f64();

        progress(Stage::Simulation);
        let t = Instant::now();
        // The simulator was flushed at the end of the previous setup: its counts so far
        // belong to earlier programs.
        let gouges_before = sim.report().gouge_voxels;
        let rapids_before: std::collections::BTreeSet<u64> =
            sim.report().rapid_collision_lines.iter().copied().collect();
        // A 3-axis program per setup: the fixture rotation is in its header comment,
        // so the simulator is told the frame here.
        sim.motion(&Motion::Setup { frame: setup.frame, rotary: [None; 3] }).map_err(sim_err)?;
        let mut tee = Tee { sim: &mut sim, trace: (i == 0).then_some(&mut trace), frame: *setup, last: None };
        let summary = parse_str(&text, &ParseOptions::default(), &mut tee).map_err(|e| {
            MillError::Program { setup: i + 1, message: format!("re-reading the program: {e}") }
        })?;
        if let Some(err) = summary.errors.first() {
            return Err(MillError::Program {
                setup: i + 1,
                message: format!("re-reading the program: {err}"),
            });
        }
        // Flushes the simulator, so its report is complete for this setup.
        remaining = sim.residual_grid();
        let report = sim.report();
        let gouge_voxels = report.gouge_voxels - gouges_before;
        // The simulator keeps one set of lines over all programs; this setup's are the new
        // ones (a line number that already collided in an earlier program is not repeated).
        let rapid_collision_lines =
            report.rapid_collision_lines.iter().copied().filter(|l| !rapids_before.contains(l)).collect();
        times.simulation += t.elapsed().as_secs_f64();
        setups.push(SetupProgram {
            setup: *setup,
            action: *action,
            plan,
            text,
            gouge_voxels,
            rapid_collision_lines,
        });
    }
    let t = Instant::now();
    let simulated = sim.into_simulation().map_err(sim_err)?;
    let rewards = simulated.rewards(&target, &RewardWeights::default()).map_err(sim_err)?;
    let simulation = simulated.report().clone();
    let programs: Vec<String> = setups.iter().map(|s| s.text.clone()).collect();
    times.simulation += t.elapsed().as_secs_f64();

    // Score in the unit cube.
    progress(Stage::Scoring);
    let t = Instant::now();
    let mut residual_plan = marching_cubes_voxels(simulated.residual())?;
    if opts.residual_smoothing > 0 {
        residual_plan = taubin_smooth(&residual_plan, opts.residual_smoothing, TAUBIN_LAMBDA, TAUBIN_MU)?;
    }
    let to_unit = |m: &Mesh| m.transformed(&unit.as_similarity());
    let residual = residual_plan.transformed(&to_input.inverse_similarity());
    let metrics = compare(
        &to_unit(&residual),
        &to_unit(mesh),
        &MetricOptions { samples: opts.metric_samples, seed: opts.seed, ..MetricOptions::default() },
    )?;
    times.scoring = t.elapsed().as_secs_f64();

    let stock_input = Aabb::new(to_input.from_unit(&stock.min), to_input.from_unit(&stock.max));
    let trace_axis = orientation.setups.first().map_or(Vector3::z(), |s| s.tool_axis().into_inner());
    let back = to_input.inverse_similarity();
    trace.segments.iter_mut().for_each(|(a, b, _)| {
        *a = back * *a;
        *b = back * *b;
    });
    Ok(Milled {
        preset: opts.preset,
        policy: policy.name(),
        programs,
        setups,
        orientation,
        simulation,
        rewards,
        metrics,
        residual,
        stock: stock_input,
        trace,
        trace_axis,
        stage_seconds: times,
    })
}

/// The stock box as seen in a setup's frame (the box around its rotated corners).
fn stock_in_setup(stock: &Aabb, setup: &Setup) -> Aabb {
    let mut b = Aabb::empty();
    for i in 0..8 {
        let c = Point3::new(
            if i & 1 == 0 { stock.min.x } else { stock.max.x },
            if i & 2 == 0 { stock.min.y } else { stock.max.y },
            if i & 4 == 0 { stock.min.z } else { stock.max.z },
        );
        b.grow(&setup.to_setup(&c));
    }
    b
}

/// Feed and rapid rates (per minute, in planning units) of a preset.
fn feeds(_preset: Preset) -> (f64, f64) {
    // Both presets plan in millimetres: 600 mm/min cutting, 5000 mm/min rapids.
    (600.0, 5000.0)
}

/// Tool numbers follow the action space's radii: T1 is the smallest.
fn tool_number(space: &ActionSpace, a: &Action) -> u32 {
    space.radii.iter().position(|&r| r == a.tool_radius).map_or(1, |i| i as u32 + 1)
}

/// Features of one setup: for each radius, the fraction of the surface samples visible
/// from the setup that a ball of that radius touches without entering the part.
fn setup_features(
    index: &MeshIndex,
    samples: &crate::geom::SurfaceSamples,
    setup: &Setup,
    space: &ActionSpace,
    diag: f64,
    stock: &Aabb,
) -> SetupFeatures {
    use rayon::prelude::*;
    let axis = setup.tool_axis().into_inner();
    let eps = 1e-6 * diag;
    let visible: Vec<(Point3, Vector3)> = samples
        .points
        .par_iter()
        .zip(samples.normals.par_iter())
        .filter(|(p, n)| n.dot(&axis) > 0.0 && !index.ray_hits_any(&(*p + *n * eps), &axis, diag))
        .map(|(p, n)| (*p, *n))
        .collect();
    let reach_by_radius = space
        .radii
        .iter()
        .map(|&r| {
            if visible.is_empty() {
                return 0.0;
            }
            let ok =
                visible.par_iter().filter(|(p, n)| index.signed_distance(&(*p + *n * r)) >= r * 0.98).count();
            ok as f64 / visible.len() as f64
        })
        .collect();
    let depth = {
        let corners = (0..8).map(|i| {
            Point3::new(
                if i & 1 == 0 { stock.min.x } else { stock.max.x },
                if i & 2 == 0 { stock.min.y } else { stock.max.y },
                if i & 4 == 0 { stock.min.z } else { stock.max.z },
            )
        });
        let zs: Vec<f64> = corners.map(|c| c.coords.dot(&axis)).collect();
        zs.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            - zs.iter().copied().fold(f64::INFINITY, f64::min)
    };
    SetupFeatures { reach_by_radius, depth, removal_fraction: 0.0, voxel: 0.0 }
}

/// Forwards motions to the simulator and records the first setup's path in part units.
struct Tee<'a> {
    sim: &'a mut Simulator,
    trace: Option<&'a mut PathTrace>,
    frame: Setup,
    last: Option<Point3>,
}

impl MotionSink for Tee<'_> {
    type Error = crate::voxsim::SimError;
    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        if let (Some(trace), Some(to)) = (self.trace.as_deref_mut(), m.end_point()) {
            let to = self.frame.to_part(&to);
            if let Some(from) = self.last {
                trace.segments.push((from, to, !matches!(m, Motion::Rapid { .. })));
            }
            self.last = Some(to);
        }
        self.sim.motion(m)
    }
    fn source_line(&mut self, line: u64) -> Result<(), Self::Error> {
        self.sim.source_line(line)
    }
}
