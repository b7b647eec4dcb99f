//! [`mill`]: mesh to checked, simulated and scored G-code (seed 000 Figure 2).
//!
//! load -> check -> normalise -> choose setups (orient) -> per setup: features ->
//! policy -> plan (toolpath) -> write G-code text (gcode) -> **parse the text back**
//! -> simulate every setup in the part frame (voxsim) -> score (geom metrics,
//! rewards). What is scored is what a machine would run.
//!
//! # Program layouts
//!
//! [`ProgramLayout::PerSetup`] writes one 3-axis program per setup, its fixture rotation in
//! its `SETUP` header comment; each is parsed back on its own and the simulator is told
//! the setup's frame. [`ProgramLayout::Rotary`] writes **one** 3+2 program for a
//! table-table machine: before each setup the tool rapids straight up (program +Z) to a
//! height where the whole stock can turn under it (the stock's farthest corner from the
//! rotary centre, plus the clearance), then `G0 A.. C..` (or `B.. C..`) turns the part.
//! The rotary centre is the part frame's origin (the program origin). The program is
//! parsed back in one pass with [`ParseOptions::rotary`], so the simulator learns every
//! frame from the rotary words alone.
//!
//! Rotary words fix the tool axis but not the turn about it: the part turns by the
//! kinematic rotation of its angles ([`rotary_frame`]). Each setup is still planned in
//! the frame orientation selection gave it, and its program coordinates are turned about
//! Z (and shifted by that frame's translation, zero today) into the kinematic frame as
//! they are written, so both layouts cut the same paths in the part frame.

use std::cell::RefCell;
use std::io::{BufRead, Read, Write};
use std::sync::Arc;
use std::time::Instant;

use crate::gcode::{
    Dialect, FooterRetract, GcodeWriter, Motion, MotionSink, ParseOptions, Plane, RotaryAxes, WriterOptions,
    linearize_arc, parse_reader, rotary_angles, rotary_frame,
};
use crate::geom::{
    Aabb, GridSpec, Isometry3, Mesh, MeshIndex, MetricOptions, Normalization, Point3, Rotation3, Setup,
    ShapeMetrics, TAUBIN_LAMBDA, TAUBIN_MU, Vector3, VoxelGrid, compare, marching_cubes_voxels,
    sample_surface, taubin_smooth, unit_cube_normalization, voxelize,
};
use crate::orient::{OrientOptions, OrientationResult, select_orientations};
use crate::policy::{Action, ActionSpace, Policy, SetupContext, SetupFeatures, StrategyKind};
use crate::render::PathTrace;
use crate::toolpath::{
    PlanOptions, PlanProgress, PlanSummary, Tool, VoxelMaterial, plan_setup_rest, plan_setup_watched,
    strategies,
};
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
    /// One 3+2 program for a table-table machine with these rotary axes (A/C or B/C),
    /// whose tilt axis travels [`MillOptions::rotary_tilt_range_deg`]. Needs a dialect
    /// with rotary axes: LinuxCNC or Fanuc (grbl has none).
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
    /// Travel of the rotary layout's tilt axis (A for [`RotaryAxes::AC`], B for
    /// [`RotaryAxes::BC`]) in degrees, `[min, max]`. A tool axis at angle θ from +Z is
    /// reached with tilt θ (and C as [`rotary_angles`] solves it) or with tilt −θ and C
    /// turned by 180°, whichever lies in the range first; a setup that neither reaches is
    /// a [`MillError::Unreachable`]. Ignored by the per-setup layout. Default
    /// `[-180, 180]`: every direction (real trunnions are narrower, e.g. `[-30, 110]`).
    pub rotary_tilt_range_deg: [f64; 2],
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
    /// Largest axial depth of a roughing cut, in tool diameters: each setup clears its
    /// free region once per this depth and machines the layers in between with their
    /// contour and the steps the roughing cut left along the walls
    /// ([`PlanOptions::roughing_depth`]); the finished shape is the same as clearing every
    /// layer. 0 clears every layer whole, as the paper does. Default 1 (a full-width
    /// slot one diameter deep, a usual roughing limit for end mills).
    pub roughing_depth_diameters: f64,
    /// Count faces parallel to a tool axis as reachable from it (the tool's flank cuts
    /// them), and faces overhanging by less than half a voxel over the stock's extent:
    /// orientation selection then sees all four walls of a prismatic part from above, and
    /// chooses axis-aligned setups where the paper's front-facing test (`n . v > 0`)
    /// prefers oblique ones that see three faces each and terrace all of them. Default
    /// true; false is the paper's test, on which the learning environment
    /// ([`TrainOptions`](crate::TrainOptions)) and the shipped policy were trained.
    pub flank_walls: bool,
    /// Refuse a setup whose action would machine for longer than this, in hours, by an
    /// upper estimate made before planning (every level cleared whole over the stock's
    /// outline at the stepover, at the cutting feed): an action far too fine for its part
    /// (a 4 µm end mill on 8 µm layers over a 100 mm block would write about 10^11 bytes of
    /// G-code) stops at once with [`MillError::ActionTooLarge`] instead of writing for
    /// days. Default 10,000 h (the shipped policy's bunny estimates at about 140 h).
    pub max_estimated_hours: f64,
}

impl MillOptions {
    /// The action space these options mill with, in planning units: the paper's scaled to
    /// [`paper_scale_mm`](Self::paper_scale_mm), or the shop's, limited to
    /// [`strategies`](Self::strategies).
    pub fn action_space(&self) -> ActionSpace {
        let mut space = match self.preset {
            Preset::Paper => ActionSpace::paper().scaled(self.paper_scale_mm),
            Preset::Shop => ActionSpace::shop(),
        };
        space.strategies.retain(|s| self.strategies.contains(s));
        space
    }
}

impl Default for MillOptions {
    fn default() -> Self {
        Self {
            preset: Preset::Paper,
            setups: SetupCount::Auto,
            resolution: 256,
            dialect: Dialect::LinuxCnc,
            layout: ProgramLayout::PerSetup,
            rotary_tilt_range_deg: [-180.0, 180.0],
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
            roughing_depth_diameters: 1.0,
            flank_walls: true,
            max_estimated_hours: 10_000.0,
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
    /// The part fills no voxel of the simulation grid: nothing to machine toward.
    #[error(
        "the mesh encloses no voxel of the {resolution}^3 grid (an open surface, or thinner than a voxel): there is no part to machine"
    )]
    NoVolume {
        /// The grid's voxels along the stock's longest axis.
        resolution: usize,
    },
    /// A setup's action would machine for longer than [`MillOptions::max_estimated_hours`].
    #[error(
        "setup {setup}: the action (tool radius {tool_radius}, layer height {layer_height}) would machine for up to {hours:.3e} h ({length_mm:.3e} mm of toolpath), beyond the limit of {limit_hours} h: choose a larger tool or layer height, or raise the limit"
    )]
    ActionTooLarge {
        /// 1-based setup.
        setup: usize,
        /// The action's tool radius and layer height, planning units.
        tool_radius: f64,
        /// See `tool_radius`.
        layer_height: f64,
        /// The upper estimate of the toolpath's length and of its machining time.
        length_mm: f64,
        /// See `length_mm`.
        hours: f64,
        /// [`MillOptions::max_estimated_hours`].
        limit_hours: f64,
    },
    /// The run passed its time limit ([`MillRun::time_limit`]); nothing it made is kept.
    #[error("time limit of {limit_s} s reached while {stage}")]
    TimeLimit {
        /// What the run was doing.
        stage: String,
        /// The limit, seconds.
        limit_s: f64,
    },
    /// The rotary layout's machine cannot tilt the part to a setup's tool axis.
    #[error(
        "setup {setup}: tool axis {tool_axis:?} needs a {letter} tilt of +/-{tilt_deg:.4} degrees, outside the machine's {letter} range {range_deg:?} (widen the tilt range or use the per-setup layout)"
    )]
    Unreachable {
        /// 1-based setup.
        setup: usize,
        /// Its tool axis in the part frame.
        tool_axis: [f64; 3],
        /// The tilt axis: `'A'` or `'B'`.
        letter: char,
        /// The tilt it needs (either sign would do), in degrees.
        tilt_deg: f64,
        /// The machine's tilt range, in degrees.
        range_deg: [f64; 2],
    },
}

/// A stage of the pipeline, for progress reports and timings (seed 000 Table A1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Orientation selection.
    Orientation,
    /// Features and the policy's choice.
    ActionSelection,
    /// Planning and writing G-code of one setup (in the per-setup layout, parsed back and
    /// simulated as it is written).
    GcodeTranslation {
        /// The setup, 1-based.
        setup: usize,
        /// Number of setups.
        setups: usize,
    },
    /// Parsing one setup's program back and simulating it (in the per-setup layout, what
    /// is left of it once the planner is done).
    Simulation {
        /// The setup, 1-based.
        setup: usize,
        /// Number of setups.
        setups: usize,
    },
    /// Within a setup's planning and simulation (per-setup layout), every few thousand
    /// moves simulated: how far the planner and the simulator have come.
    Layers {
        /// The setup, 1-based.
        setup: usize,
        /// Number of setups.
        setups: usize,
        /// Levels the planner has emitted (or found empty).
        done: usize,
        /// The setup's number of levels (0 until it is sliced).
        levels: usize,
        /// Moves parsed back and simulated.
        moves: u64,
    },
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
    /// Toolpath planning and G-code writing. In the per-setup layout the planner writes
    /// each program while the simulator reads it, so this and `simulation` overlap: each
    /// counts the time its side was busy (not waiting for the other), and the stages may
    /// add up to more than the wall time.
    pub gcode_translation: f64,
    /// Parsing back and simulating.
    pub simulation: f64,
    /// Marching cubes and metrics.
    pub scoring: f64,
}

/// One setup's program and what went into it.
#[derive(Debug, Clone, PartialEq)]
pub struct SetupProgram {
    /// The setup (frame: program coordinates to part coordinates, in part units). In the
    /// rotary layout this is the kinematic frame its rotary words realise
    /// ([`rotary_frame`] of `rotary_deg`): the same tool axis as orientation selection's
    /// setup, turned about it.
    pub setup: Setup,
    /// The action the policy chose.
    pub action: Action,
    /// The planner's summary.
    pub plan: PlanSummary,
    /// The G-code text: this setup's program, or in the rotary layout this setup's section
    /// of the one program (from the safe retract before its rotation to the next
    /// section; the first holds the header, the last the footer), so that the sections
    /// joined are the program.
    pub text: String,
    /// Rotary layout: the angles `[A, B, C]` in degrees this setup's rotary words state
    /// (the unused tilt letter is 0). `None` in the per-setup layout.
    pub rotary_deg: Option<[f64; 3]>,
    /// Lines of this setup's program (or section), whether or not its text is kept.
    pub lines: u64,
    /// Target voxels this setup's program (or section) removed.
    pub gouge_voxels: u64,
    /// Lines of this setup's program where a rapid move removed material (in the rotary
    /// layout: lines of the one program, within this setup's section).
    pub rapid_collision_lines: Vec<u64>,
    /// The paper's preservation `R_s` (Eq. 10) after this setup: the fraction of the part's
    /// voxels still there.
    pub preservation: f64,
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

    /// The paper's total reward (Eq. 13) of the run with `weights`:
    /// `λ_s Σ_s R_s + λ_f R_f + λ_MRR R_MRR`, one `R_s` per setup, `R_MRR` in cm³ of
    /// material removed per minute of machining (the machined part's units).
    pub fn total_reward(&self, weights: &RewardWeights) -> f64 {
        weights.lambda_s * self.setups.iter().map(|s| s.preservation).sum::<f64>()
            + weights.lambda_f * self.rewards.final_iou
            + weights.lambda_mrr * self.simulation.mrr_mm3_per_min / 1000.0
    }

    /// Whether the programs are safe: no gouge into the part and no rapid through material.
    pub fn is_safe(&self) -> bool {
        self.simulation.gouge_voxels == 0 && self.rapid_collisions() == 0
    }
}

/// Mills `mesh` with `policy`. See the module docs for the stages; `progress` is told
/// when each stage starts.
///
/// In the per-setup layout the policy chooses each setup's action after the earlier
/// setups were simulated, so [`SetupFeatures::removal_fraction`] is what is really left;
/// the rotary layout parses its one program in one pass, so every action is chosen
/// before the first setup is cut (see [`MillRun`]).
pub fn mill(
    mesh: &Mesh,
    policy: &mut dyn Policy,
    opts: &MillOptions,
    progress: &mut dyn FnMut(Stage),
) -> Result<Milled, MillError> {
    MillRun::new(mesh, opts, progress)?.complete(policy, progress)
}

/// A milling run one setup at a time: what [`mill`] does, opened up so that a caller (the
/// learning environment, an interactive tool) picks each setup's [`Action`] after seeing
/// what the earlier setups left.
///
/// [`MillRun::new`] normalises the part, selects the orientations and prepares the
/// simulator; then, while [`next_setup`](Self::next_setup) is `Some`, read
/// [`features`](Self::features) and [`machine`](Self::machine) an action; then
/// [`finish`](Self::finish) scores the result. In the per-setup layout `machine` plans,
/// writes, parses back and simulates the setup at once, so [`rewards`](Self::rewards) is
/// up to date after each setup. The rotary layout's one program is parsed in one pass, so
/// its setups are cut in `finish`, and until then `rewards` and the features' removal
/// fraction describe the uncut stock.
///
/// A run is `Clone`: a copy continues independently from the same state (the learning
/// environment keeps copies at the action prefixes it has simulated).
#[derive(Clone)]
pub struct MillRun {
    opts: MillOptions,
    /// The input mesh in the unit cube, for scoring.
    unit_part: Mesh,
    unit: Normalization,
    /// The part in planning units.
    part: Mesh,
    space: ActionSpace,
    /// The radius of each tool the simulator knows, tool `i + 1` at `i`: the action
    /// space's radii, then those of actions outside it, in the order first used.
    tool_radii: Vec<f64>,
    stock: Aabb,
    to_input: Normalization,
    orientation: OrientationResult,
    placements: Option<Vec<Placement>>,
    /// The geometric features of each setup (the removal fraction is filled in later).
    features: Vec<SetupFeatures>,
    target: VoxelGrid,
    sim: RefCell<Simulator>,
    jobs: Vec<Job>,
    setups: Vec<SetupProgram>,
    /// The material still to cut after the setups machined so far.
    remaining: VoxelGrid,
    trace: PathTrace,
    times: StageSeconds,
    wopts: WriterOptions,
    /// Whether the per-setup programs' text and trace are kept (see
    /// [`keep_programs`](Self::keep_programs)).
    keep_programs: bool,
    /// Whether the first setup's toolpath is kept for rendering ([`Self::keep_trace`]).
    keep_trace: bool,
    /// Where each per-setup program is written as it is made ([`Self::stream_programs`]).
    outputs: Option<ProgramOutputs>,
    /// When the run must have finished, and its limit ([`Self::time_limit`]).
    deadline: Option<(Instant, f64)>,
    diag: f64,
    feed: f64,
    rapid: f64,
    clearance: f64,
}

impl MillRun {
    /// Loads `mesh` into a run: checks the options, normalises the part, selects the
    /// setups (stage [`Stage::Orientation`]), computes every setup's features (stage
    /// [`Stage::ActionSelection`]) and prepares the simulation grid and the part's voxels.
    pub fn new(mesh: &Mesh, opts: &MillOptions, progress: &mut dyn FnMut(Stage)) -> Result<Self, MillError> {
        if opts.resolution < 8 || opts.resolution > 2048 {
            return Err(MillError::InvalidOption(format!(
                "resolution must be 8..=2048, got {}",
                opts.resolution
            )));
        }
        if mesh.is_empty() {
            return Err(crate::geom::GeomError::EmptyMesh.into());
        }
        let d = opts.roughing_depth_diameters;
        if !(d.is_finite() && d >= 0.0) {
            return Err(MillError::InvalidOption(format!(
                "roughing depth must be finite and >= 0 diameters, got {d}"
            )));
        }
        if let ProgramLayout::Rotary(_) = opts.layout {
            if matches!(opts.dialect, Dialect::Grbl | Dialect::Marlin) {
                return Err(MillError::InvalidOption(format!(
                    "the rotary layout needs a dialect with rotary axes (linuxcnc or fanuc), not {:?}",
                    opts.dialect
                )));
            }
            let [lo, hi] = opts.rotary_tilt_range_deg;
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(MillError::InvalidOption(format!(
                    "rotary tilt range must be finite with min <= max, got [{lo}, {hi}]"
                )));
            }
        }
        let mut times = StageSeconds::default();
        let decimals = 4;

        // Units: the paper plans in the unit cube; the shop in part units. `to_input`
        // maps planning units back to the input mesh's units.
        let unit: Normalization = unit_cube_normalization(mesh)?;
        let (part, stock, to_input) = match opts.preset {
            Preset::Paper => {
                let k = opts.paper_scale_mm;
                if !(k.is_finite() && k > 0.0) {
                    return Err(MillError::InvalidOption(format!(
                        "paper_scale_mm must be positive, got {k}"
                    )));
                }
                let norm = Normalization { scale: unit.scale * k, translation: unit.translation * k };
                let part = mesh.transformed(&norm.as_similarity());
                let half = 0.5 * k;
                let stock = Aabb::new(Point3::new(-half, -half, -half), Point3::new(half, half, half));
                (part, stock, norm)
            }
            Preset::Shop => {
                let bbox = mesh.bbox().ok_or(crate::geom::GeomError::EmptyMesh)?;
                let margin = opts.stock_margin.max(0.0) * bbox.extent().max();
                (mesh.clone(), bbox.inflated(margin), Normalization::identity())
            }
        };
        let space = opts.action_space();
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
            // A wall overhanging by less than half a voxel over the stock hides nothing the
            // grid can show.
            min_cos: if opts.flank_walls { -0.5 / opts.resolution as f64 } else { 0.0 },
            ..OrientOptions::default()
        };
        if let SetupCount::Exactly(n) = opts.setups {
            oopts.max_setups = n.max(1);
            oopts.coverage_target = 1.0;
        }
        // What does not depend on the setups (the part's voxels on the simulation grid, its
        // index and the samples the features read) is computed beside the orientation
        // search, whose serial steps leave a core idle.
        let spec = GridSpec::cubic(&stock, opts.resolution)?;
        let (orientation, (target, index, samples, beside)) = rayon::join(
            || select_orientations(&part, &oopts),
            || {
                let t = Instant::now();
                let target = voxelize(&part, &spec);
                let voxelized = t.elapsed();
                let index = MeshIndex::new(&part);
                let samples = sample_surface(&part, 4096, opts.seed ^ 0x5eed);
                (target, index, samples, [voxelized, t.elapsed() - voxelized])
            },
        );
        let orientation = orientation?;
        let (target, index, samples) = (target?, index?, samples?);
        // Every setup would cut the whole stock away, and the scores have no part to compare.
        if target.count() == 0 {
            return Err(MillError::NoVolume { resolution: opts.resolution });
        }
        // The rotary layout fails here, before any planning, on a setup its machine cannot reach.
        let placements = match opts.layout {
            ProgramLayout::PerSetup => None,
            ProgramLayout::Rotary(axes) => Some(
                orientation
                    .setups
                    .iter()
                    .enumerate()
                    .map(|(i, s)| Placement::new(axes, s, opts.rotary_tilt_range_deg, decimals, i))
                    .collect::<Result<Vec<_>, _>>()?,
            ),
        };
        times.orientation = t.elapsed().as_secs_f64();

        // What the policy will look at.
        progress(Stage::ActionSelection);
        let t = Instant::now();
        let diag = stock.extent().norm();
        let voxel = stock.extent().max() / opts.resolution as f64;
        let features = orientation
            .setups
            .iter()
            .map(|setup| setup_features(&index, &samples, setup, &space, diag, &stock, voxel))
            .collect();
        times.action_selection = (t.elapsed() + beside[1]).as_secs_f64();

        // The simulator knows every tool of the action space: T1 is the smallest radius.
        let (feed, rapid) = feeds(opts.preset);
        let t = Instant::now();
        let first = space.radii.first().copied().unwrap_or(1.0);
        let mut tools = ToolTable::single(planned_tool(first, 1, diag, feed).cutter);
        for (i, &r) in space.radii.iter().enumerate() {
            tools = tools.with(i as u32 + 1, planned_tool(r, i as u32 + 1, diag, feed).cutter);
        }
        let sim_opts =
            SimOptions { carver: opts.carver, rapid_rate_mm_per_min: rapid, ..SimOptions::default() };
        let mut sim = Simulator::new(VoxelGrid::full(spec), tools, sim_opts)
            .map_err(sim_error)?
            .with_target(&target)
            .map_err(sim_error)?;
        let mut remaining = sim.residual_grid();
        remaining.andnot(&target).map_err(|e| MillError::Simulation(e.to_string()))?;
        times.simulation += (t.elapsed() + beside[0]).as_secs_f64();

        Ok(Self {
            opts: opts.clone(),
            unit_part: mesh.transformed(&unit.as_similarity()),
            unit,
            part,
            tool_radii: space.radii.clone(),
            space,
            stock,
            to_input,
            orientation,
            placements,
            features,
            target,
            sim: RefCell::new(sim),
            jobs: Vec::new(),
            setups: Vec::new(),
            remaining,
            trace: PathTrace::default(),
            times,
            // Every program ends with the planner's retract to the clearance plane. No
            // `G53 G0 Z0` after it: the program sets no work offset, so a reader (the
            // simulator, `rs274`) takes machine Z0 for work Z0, and where the last pass ends
            // over the part that is a rapid plunge into it.
            wopts: WriterOptions { decimals, retract: FooterRetract::None, ..WriterOptions::default() },
            keep_programs: true,
            keep_trace: true,
            outputs: None,
            deadline: None,
            diag,
            feed,
            rapid,
            // Appendix A.1: start 0.1 (of the normalised part) above the top.
            clearance: 0.1 * stock.extent().max(),
        })
    }

    /// What both layouts' machining reads.
    fn ctx(&self) -> Ctx<'_> {
        Ctx {
            part: &self.part,
            target: &self.target,
            jobs: &self.jobs,
            sim: &self.sim,
            setups: self.orientation.setups.len(),
            dialect: self.opts.dialect,
            wopts: &self.wopts,
            keep_programs: self.keep_programs,
            outputs: self.outputs.as_ref(),
            deadline: self.deadline,
        }
    }

    /// Stops the run with [`MillError::TimeLimit`] once `limit` has passed since `started`:
    /// before each setup, within a setup's planning and simulation (the planner stops
    /// before its next layer), and before scoring.
    pub fn time_limit(&mut self, started: Instant, limit: std::time::Duration) {
        self.deadline = Some((started + limit, limit.as_secs_f64()));
    }

    fn check_deadline(&self, stage: impl FnOnce() -> String) -> Result<(), MillError> {
        match self.deadline {
            Some((at, limit_s)) if Instant::now() >= at => {
                Err(MillError::TimeLimit { stage: stage(), limit_s })
            }
            _ => Ok(()),
        }
    }

    /// Whether the per-setup programs are kept (the default): their text in
    /// [`SetupProgram::text`] and [`Milled::programs`], the first setup's toolpath in
    /// [`Milled::trace`] for the rendering. A caller that only wants the simulated outcome
    /// (the learning environment) turns it off: each program is then streamed from the
    /// planner to the parser and simulator and never held whole, which matters for the
    /// finest actions (a 0.1 mm tool clearing rings on 1/512 layers writes over a gigabyte
    /// and tens of millions of moves for one setup). The rotary layout always keeps its
    /// program.
    pub fn keep_programs(&mut self, keep: bool) {
        self.keep_programs = keep;
        self.keep_trace = keep;
    }

    /// Whether the first setup's toolpath is kept in [`Milled::trace`] for the rendering
    /// (default: as [`keep_programs`](Self::keep_programs)). The trace keeps one level in
    /// two, four, ... as needed to stay within [`PathTrace::CAPACITY`] segments.
    pub fn keep_trace(&mut self, keep: bool) {
        self.keep_trace = keep;
    }

    /// Writes each per-setup program into `open(setup)` (setup counted from 0) as it is
    /// planned, instead of keeping its text ([`keep_programs`](Self::keep_programs) is
    /// turned off): memory then stays bounded by the simulation grid whatever the
    /// program's size. A writer that fails stops the run with [`MillError::Program`]; the
    /// caller decides what becomes of what was written (the CLI writes to temporary files
    /// and renames them only when the whole run succeeds). The rotary layout's one
    /// program is always kept whole, as before.
    pub fn stream_programs(
        &mut self,
        open: impl Fn(usize) -> std::io::Result<Box<dyn std::io::Write + Send>> + Send + Sync + 'static,
    ) {
        let keep_trace = self.keep_trace;
        self.keep_programs(false);
        self.keep_trace = keep_trace;
        self.outputs = Some(Arc::new(open));
    }

    /// The action space, in planning units.
    pub fn space(&self) -> &ActionSpace {
        &self.space
    }

    /// Orientation selection's result: the setups in machining order.
    pub fn orientation(&self) -> &OrientationResult {
        &self.orientation
    }

    /// Number of setups.
    pub fn setup_count(&self) -> usize {
        self.orientation.setups.len()
    }

    /// The 0-based setup [`machine`](Self::machine) cuts next; `None` once every setup has
    /// its action.
    pub fn next_setup(&self) -> Option<usize> {
        let i = self.jobs.len();
        (i < self.setup_count()).then_some(i)
    }

    /// The features of the next setup (those of the last one once all are machined), with
    /// the removal fraction of the material left now.
    pub fn features(&self) -> SetupFeatures {
        let i = self.jobs.len().min(self.features.len().saturating_sub(1));
        let mut f = self.features.get(i).cloned().unwrap_or_default();
        let stock = self.target.spec().len() as f64;
        f.removal_fraction = if stock > 0.0 { self.remaining.count() as f64 / stock } else { 0.0 };
        f
    }

    /// The policy's view of the next setup, given its `features`.
    pub fn context<'a>(&'a self, features: &'a SetupFeatures) -> SetupContext<'a> {
        SetupContext { index: self.jobs.len(), setups: self.setup_count(), space: &self.space, features }
    }

    /// The paper's rewards (Eq. 10-12 and the one-step total of Eq. 13, default weights)
    /// of the stock as simulated so far against the part.
    pub fn rewards(&self, weights: &RewardWeights) -> Result<Rewards, MillError> {
        let residual = self.sim.borrow_mut().residual_grid();
        let report = self.sim.borrow().report().clone();
        crate::voxsim::rewards(&residual, &self.target, &report, weights).map_err(sim_error)
    }

    /// The simulator's report so far (complete for the setups machined in the per-setup
    /// layout).
    pub fn report(&self) -> SimReport {
        self.sim.borrow().report().clone()
    }

    /// The setups machined so far (per-setup layout; empty for the rotary layout until
    /// [`finish`](Self::finish)).
    pub fn machined(&self) -> &[SetupProgram] {
        &self.setups
    }

    /// The tool number of `radius`. A radius outside the action space (a fixed action's)
    /// gets a tool of its own, added to the simulator's table, so that the simulation cuts
    /// with the radius the planner planned for.
    fn tool_number(&mut self, radius: f64) -> Result<u32, MillError> {
        if let Some(i) = self.tool_radii.iter().position(|&r| r == radius) {
            return Ok(i as u32 + 1);
        }
        let number = self.tool_radii.len() as u32 + 1;
        let cutter = planned_tool(radius, number, self.diag, self.feed).cutter;
        self.sim.get_mut().add_tool(number, cutter).map_err(sim_error)?;
        self.tool_radii.push(radius);
        Ok(number)
    }

    /// Cuts the next setup with `action`: plans it against the material left, writes its
    /// program, parses the text back and simulates it (per-setup layout), or records the
    /// action for [`finish`](Self::finish) (rotary layout). Errors when every setup already
    /// has its action.
    pub fn machine(&mut self, action: Action, progress: &mut dyn FnMut(Stage)) -> Result<(), MillError> {
        let Some(i) = self.next_setup() else {
            return Err(MillError::InvalidOption(format!("all {} setups are machined", self.setup_count())));
        };
        self.check_deadline(|| format!("starting setup {} of {}", i + 1, self.setup_count()))?;
        let number = self.tool_number(action.tool_radius)?;
        let o = &self.opts;
        let job = Job::new(
            &self.orientation.setups[i],
            &action,
            number,
            &self.stock,
            self.diag,
            self.feed,
            self.rapid,
            self.clearance,
            o,
        )?;
        let (length_mm, hours) = job.estimate();
        if hours.is_nan() || hours > o.max_estimated_hours {
            return Err(MillError::ActionTooLarge {
                setup: i + 1,
                tool_radius: action.tool_radius,
                layer_height: action.layer_height,
                length_mm,
                hours,
                limit_hours: o.max_estimated_hours,
            });
        }
        self.jobs.push(job);
        if self.placements.is_some() {
            return Ok(());
        }
        let (mut trace, mut times) = (std::mem::take(&mut self.trace), self.times);
        let result = machine_setup(
            &self.ctx(),
            i,
            &self.remaining,
            (i == 0 && self.keep_trace).then_some(&mut trace),
            &mut times,
            progress,
        );
        (self.trace, self.times) = (trace, times);
        let (program, remaining) = result?;
        self.setups.push(program);
        self.remaining = remaining;
        Ok(())
    }

    /// Machines every setup still without an action with `policy`'s choice, then
    /// [`finish`](Self::finish)es: the rest of what [`mill`] does.
    pub fn complete(
        mut self,
        policy: &mut dyn Policy,
        progress: &mut dyn FnMut(Stage),
    ) -> Result<Milled, MillError> {
        while self.next_setup().is_some() {
            let t = Instant::now();
            let features = self.features();
            let action = policy.choose(&self.context(&features));
            self.times.action_selection += t.elapsed().as_secs_f64();
            self.machine(action, progress)?;
        }
        self.finish(&policy.name(), progress)
    }

    /// Finishes the run: the rotary layout's program is written and simulated now, then
    /// the residual stock is meshed and scored (stage [`Stage::Scoring`]). `policy` names
    /// the policy in the result. Errors when a setup has no action yet.
    pub fn finish(mut self, policy: &str, progress: &mut dyn FnMut(Stage)) -> Result<Milled, MillError> {
        if let Some(i) = self.next_setup() {
            return Err(MillError::InvalidOption(format!(
                "setup {} of {} has no action yet",
                i + 1,
                self.setup_count()
            )));
        }
        let opts = &self.opts;
        if let (ProgramLayout::Rotary(axes), Some(placements)) = (opts.layout, &self.placements) {
            // Above this height (program +Z, rotary centre at the origin) the tool clears
            // every point of the stock in every orientation of the table.
            let turn_z =
                self.stock.corners().iter().map(|c| c.coords.norm()).fold(0.0, f64::max) + self.clearance;
            let (mut trace, mut times) = (std::mem::take(&mut self.trace), self.times);
            let setups = mill_rotary(&self.ctx(), axes, placements, turn_z, &mut trace, &mut times, progress);
            (self.trace, self.times) = (trace, times);
            self.setups = setups?;
        }
        let part_voxels = self.target.count() as f64;
        let mut gouged = 0;
        for s in &mut self.setups {
            gouged += s.gouge_voxels;
            s.preservation = if part_voxels > 0.0 { 1.0 - gouged as f64 / part_voxels } else { 1.0 };
        }
        let t = Instant::now();
        self.check_deadline(|| "scoring the residual stock".into())?;
        let simulated = self.sim.into_inner().into_simulation().map_err(sim_error)?;
        let rewards = simulated.rewards(&self.target, &RewardWeights::default()).map_err(sim_error)?;
        let simulation = simulated.report().clone();
        let programs: Vec<String> = match opts.layout {
            ProgramLayout::PerSetup => self.setups.iter().map(|s| s.text.clone()).collect(),
            ProgramLayout::Rotary(_) => vec![self.setups.iter().map(|s| s.text.as_str()).collect()],
        };
        self.times.simulation += t.elapsed().as_secs_f64();

        // Score in the unit cube.
        progress(Stage::Scoring);
        let t = Instant::now();
        let mut residual_plan = marching_cubes_voxels(simulated.residual())?;
        if opts.residual_smoothing > 0 {
            residual_plan = taubin_smooth(&residual_plan, opts.residual_smoothing, TAUBIN_LAMBDA, TAUBIN_MU)?;
        }
        let to_input = self.to_input;
        let residual = residual_plan.transformed(&to_input.inverse_similarity());
        let metrics = compare(
            &residual.transformed(&self.unit.as_similarity()),
            &self.unit_part,
            &MetricOptions { samples: opts.metric_samples, seed: opts.seed, ..MetricOptions::default() },
        )?;
        self.times.scoring = t.elapsed().as_secs_f64();

        let stock = Aabb::new(to_input.from_unit(&self.stock.min), to_input.from_unit(&self.stock.max));
        let trace_axis = self.orientation.setups.first().map_or(Vector3::z(), |s| s.tool_axis().into_inner());
        let back = to_input.inverse_similarity();
        let mut trace = self.trace;
        trace.segments.iter_mut().for_each(|(a, b, _)| {
            *a = back * *a;
            *b = back * *b;
        });
        Ok(Milled {
            preset: opts.preset,
            policy: policy.to_owned(),
            programs,
            setups: self.setups,
            orientation: self.orientation,
            simulation,
            rewards,
            metrics,
            residual,
            stock,
            trace,
            trace_axis,
            stage_seconds: self.times,
        })
    }
}

/// The stock box as seen in a setup's frame (the box around its rotated corners).
fn stock_in_setup(stock: &Aabb, setup: &Setup) -> Aabb {
    let mut b = Aabb::empty();
    for c in stock.corners() {
        b.grow(&setup.to_setup(&c));
    }
    b
}

/// The tool a setup is planned with, whose cutter the simulator cuts with (tool `number`
/// of its table): a flat end mill of `radius` with flutes as long as the stock's diagonal
/// `diag`, at the cutting `feed`, a third of it for plunges, and 12,000 rpm.
fn planned_tool(radius: f64, number: u32, diag: f64, feed: f64) -> Tool {
    Tool {
        feed,
        plunge_feed: feed / 3.0,
        spindle_rpm: 12000.0,
        number,
        ..Tool::new(Cutter::flat(radius, diag))
    }
}

/// What one setup is planned with.
#[derive(Clone)]
struct Job {
    setup: Setup,
    action: Action,
    tool: Tool,
    popts: PlanOptions,
}

impl Job {
    #[allow(clippy::too_many_arguments)] // Private: the run's constants, passed once per setup.
    fn new(
        setup: &Setup,
        action: &Action,
        number: u32,
        stock: &Aabb,
        diag: f64,
        feed: f64,
        rapid: f64,
        clearance: f64,
        opts: &MillOptions,
    ) -> Result<Self, MillError> {
        let tool = planned_tool(action.tool_radius, number, diag, feed);
        let strategy =
            strategies().get(action.strategy.name()).map_err(|e| MillError::InvalidOption(e.to_string()))?;
        let popts = PlanOptions {
            layer_height: action.layer_height,
            strategy,
            contour: opts.contour,
            roughing_depth: (opts.roughing_depth_diameters > 0.0)
                .then(|| opts.roughing_depth_diameters * tool.diameter()),
            clearance_height: clearance,
            stock: Some(stock_in_setup(stock, setup)),
            rapid_feed: rapid,
            ..PlanOptions::default()
        };
        Ok(Self { setup: *setup, action: *action, tool, popts })
    }

    /// An upper estimate of the setup's toolpath length and machining time (hours): every
    /// level cleared whole over the stock's outline at the stepover, at the cutting feed.
    fn estimate(&self) -> (f64, f64) {
        let stock = self.popts.stock.unwrap_or_else(Aabb::empty).extent();
        let depth = stock.z.min(self.tool.flute_length());
        let levels = (depth / self.popts.layer_height).ceil().max(1.0);
        let stepover = self.popts.stepover * self.tool.diameter();
        let length =
            levels * (stock.x + 2.0 * self.tool.radius()) * (stock.y + 2.0 * self.tool.radius()) / stepover;
        (length, length / self.tool.feed / 60.0)
    }
}

/// What both layouts share.
struct Ctx<'a> {
    part: &'a Mesh,
    /// The part's voxels on the simulation grid.
    target: &'a VoxelGrid,
    jobs: &'a [Job],
    sim: &'a RefCell<Simulator>,
    /// Number of setups of the run (`jobs` may hold only those chosen so far).
    setups: usize,
    dialect: Dialect,
    wopts: &'a WriterOptions,
    /// Keep the per-setup programs' text ([`MillRun::keep_programs`]).
    keep_programs: bool,
    /// Where the per-setup programs are written ([`MillRun::stream_programs`]).
    outputs: Option<&'a ProgramOutputs>,
    /// When the run must have finished, and its limit in seconds.
    deadline: Option<(Instant, f64)>,
}

/// Opens the writer of each per-setup program ([`MillRun::stream_programs`]).
type ProgramOutputs = Arc<dyn Fn(usize) -> std::io::Result<Box<dyn std::io::Write + Send>> + Send + Sync>;

impl Ctx<'_> {
    /// The material still to cut: the simulated stock less the part. The part is never
    /// cut, so counting it as material would make later setups trace the finished walls
    /// again in air (rest machining skips what is gone, not what must stay).
    fn excess(&self) -> Result<VoxelGrid, MillError> {
        let mut g = self.sim.borrow_mut().residual_grid();
        g.andnot(self.target).map_err(|e| MillError::Simulation(e.to_string()))?;
        Ok(g)
    }
}

fn sim_error(e: crate::voxsim::SimError) -> MillError {
    MillError::Simulation(e.to_string())
}

/// Setup `i` as its own 3-axis program: plans it against `remaining`, writes it, parses the
/// text back into the simulator. Returns the setup's program and the material left after it.
fn machine_setup(
    ctx: &Ctx<'_>,
    i: usize,
    remaining: &VoxelGrid,
    trace: Option<&mut PathTrace>,
    times: &mut StageSeconds,
    progress: &mut dyn FnMut(Stage),
) -> Result<(SetupProgram, VoxelGrid), MillError> {
    let job = &ctx.jobs[i];
    let setups = ctx.setups;
    progress(Stage::GcodeTranslation { setup: i + 1, setups });
    let t = Instant::now();
    // The simulator was flushed at the end of the previous setup: its counts so far
    // belong to earlier programs.
    let (gouges_before, rapids_before) = {
        let sim = ctx.sim.borrow();
        let r = sim.report();
        (r.gouge_voxels, r.rapid_collision_lines.iter().copied().collect::<std::collections::BTreeSet<u64>>())
    };
    let mut tee = Tee::new(ctx.sim, trace);
    // A 3-axis program per setup: the fixture rotation is in its header comment,
    // so the simulator is told the frame here.
    tee.motion(&Motion::Setup { frame: job.setup.frame, rotary: [None; 3] }).map_err(sim_error)?;
    // The planner writes the program on its own thread while this one parses it back
    // and simulates it, chunk by chunk: planning and simulation overlap, and the text is
    // held whole only when it is kept.
    let (part, dialect, wopts, keep) = (ctx.part, ctx.dialect, ctx.wopts.clone(), ctx.keep_programs);
    let copy = match ctx.outputs {
        Some(open) => Some(open(i).map_err(|e| MillError::Program { setup: i + 1, message: e.to_string() })?),
        None => None,
    };
    let watch = PlanProgress::default();
    let mut tee = tee.watching(&mut *progress, &watch, i + 1, setups);
    let (planned, parsed, waited) = std::thread::scope(|scope| {
        let (mut out, mut reader) = chunk_channel(keep);
        out.copy = copy;
        reader.deadline = ctx.deadline.map(|(at, _)| at);
        let watch = &watch;
        let planner = scope.spawn(move || {
            let t = Instant::now();
            let rest = VoxelMaterial::new(remaining, job.setup);
            let mut writer = GcodeWriter::new(out, dialect, wopts);
            let plan =
                plan_setup_watched(part, &job.setup, &job.tool, &job.popts, Some(&rest), &mut writer, watch)
                    .map_err(|e| MillError::Plan { setup: i + 1, message: e.to_string() });
            plan.and_then(|plan| {
                writer.finish().map_err(|e| MillError::Program { setup: i + 1, message: e.to_string() })?;
                let (text, blocked) = writer
                    .into_inner()
                    .finish()
                    .map_err(|e| MillError::Program { setup: i + 1, message: e.to_string() })?;
                Ok((plan, text, t.elapsed().saturating_sub(blocked)))
            })
        });
        let parsed = parse_reader(&mut reader, &ParseOptions::default(), &mut tee);
        if parsed.is_ok() {
            // The parser stops at the program end; the writer may still send what follows.
            while reader.rx.recv().is_ok() {}
        }
        let waited = reader.waited;
        // Hanging up stops a planner whose program is no longer read, and cancelling
        // stops one that is still planning a batch of layers.
        drop(reader);
        watch.cancel();
        let planned = planner.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
        (planned, parsed, waited)
    });
    if let (Some((at, limit_s)), Err(_)) = (ctx.deadline, &parsed)
        && Instant::now() >= at
    {
        return Err(MillError::TimeLimit {
            stage: format!("planning and simulating setup {} of {setups}", i + 1),
            limit_s,
        });
    }
    let (plan, text, planning) = match (planned, &parsed) {
        (Ok(done), _) => done,
        // A parser that stopped hung up on the planner: its error is the cause.
        (Err(_), Err(e)) => {
            return Err(MillError::Program { setup: i + 1, message: format!("re-reading the program: {e}") });
        }
        (Err(e), Ok(_)) => return Err(e),
    };
    let text =
        String::from_utf8(text).map_err(|e| MillError::Program { setup: i + 1, message: e.to_string() })?;
    // Planning ran beside the simulation: each stage counts the time its side was busy.
    times.gcode_translation += planning.as_secs_f64();
    progress(Stage::Simulation { setup: i + 1, setups });
    let summary = parsed
        .map_err(|e| MillError::Program { setup: i + 1, message: format!("re-reading the program: {e}") })?;
    if let Some(err) = summary.errors.first() {
        return Err(MillError::Program { setup: i + 1, message: format!("re-reading the program: {err}") });
    }
    // Flushes the simulator, so its report is complete for this setup.
    let remaining = ctx.excess()?;
    let sim = ctx.sim.borrow();
    let report = sim.report();
    let gouge_voxels = report.gouge_voxels - gouges_before;
    // The simulator keeps one set of lines over all programs; this setup's are the new
    // ones (a line number that already collided in an earlier program is not repeated).
    let rapid_collision_lines =
        report.rapid_collision_lines.iter().copied().filter(|l| !rapids_before.contains(l)).collect();
    times.simulation += t.elapsed().saturating_sub(waited).as_secs_f64();
    let program = SetupProgram {
        setup: job.setup,
        action: job.action,
        plan,
        text,
        rotary_deg: None,
        lines: summary.lines,
        gouge_voxels,
        rapid_collision_lines,
        preservation: 1.0,
    };
    Ok((program, remaining))
}

/// Bytes per chunk of [`chunk_channel`], and chunks in flight.
const CHUNK_BYTES: usize = 1 << 18;
const CHUNKS_IN_FLIGHT: usize = 8;

/// A bounded byte stream from a writer on one thread to a [`BufRead`] on another, in
/// chunks of [`CHUNK_BYTES`], at most [`CHUNKS_IN_FLIGHT`] of them waiting: memory stays
/// bounded whatever the program's size. With `keep`, the writer also keeps every byte
/// and [`ChunkWriter::finish`] returns them.
fn chunk_channel(keep: bool) -> (ChunkWriter, ChunkReader) {
    let (tx, rx) = std::sync::mpsc::sync_channel(CHUNKS_IN_FLIGHT);
    let writer = ChunkWriter {
        buf: Vec::with_capacity(CHUNK_BYTES),
        tx,
        kept: keep.then(Vec::new),
        copy: None,
        blocked: std::time::Duration::ZERO,
    };
    (writer, ChunkReader { rx, chunk: Vec::new(), pos: 0, waited: std::time::Duration::ZERO, deadline: None })
}

/// The writing end of [`chunk_channel`]. A write fails once the reader has hung up.
struct ChunkWriter {
    buf: Vec<u8>,
    tx: std::sync::mpsc::SyncSender<Vec<u8>>,
    kept: Option<Vec<u8>>,
    /// Where every byte is also written.
    copy: Option<Box<dyn std::io::Write + Send>>,
    /// Time spent waiting for the reader.
    blocked: std::time::Duration,
}

impl ChunkWriter {
    fn send(&mut self) -> std::io::Result<()> {
        if self.buf.is_empty() {
            return Ok(());
        }
        let chunk = std::mem::replace(&mut self.buf, Vec::with_capacity(CHUNK_BYTES));
        if let Some(kept) = &mut self.kept {
            kept.extend_from_slice(&chunk);
        }
        if let Some(copy) = &mut self.copy {
            copy.write_all(&chunk)?;
        }
        let t = Instant::now();
        let sent = self.tx.send(chunk);
        self.blocked += t.elapsed();
        sent.map_err(|_| std::io::Error::new(std::io::ErrorKind::BrokenPipe, "the program's reader stopped"))
    }

    /// Sends what is buffered and closes the stream; returns the kept bytes (empty
    /// without `keep`) and the time spent waiting for the reader.
    fn finish(mut self) -> std::io::Result<(Vec<u8>, std::time::Duration)> {
        self.send()?;
        if let Some(copy) = &mut self.copy {
            copy.flush()?;
        }
        Ok((self.kept.take().unwrap_or_default(), self.blocked))
    }
}

impl std::io::Write for ChunkWriter {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.buf.extend_from_slice(bytes);
        if self.buf.len() >= CHUNK_BYTES {
            self.send()?;
        }
        Ok(bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.send()
    }
}

/// The reading end of [`chunk_channel`]: ends when the writer is dropped.
struct ChunkReader {
    rx: std::sync::mpsc::Receiver<Vec<u8>>,
    chunk: Vec<u8>,
    pos: usize,
    /// Time spent waiting for the writer.
    waited: std::time::Duration,
    /// Reading fails with [`std::io::ErrorKind::TimedOut`] from this time on.
    deadline: Option<Instant>,
}

impl Read for ChunkReader {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        read_from_buffer(self, buf)
    }
}

impl BufRead for ChunkReader {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        while self.pos == self.chunk.len() {
            let t = Instant::now();
            let next = match self.deadline {
                Some(at) => loop {
                    if Instant::now() >= at {
                        return Err(std::io::Error::new(
                            std::io::ErrorKind::TimedOut,
                            "the time limit passed",
                        ));
                    }
                    match self.rx.recv_timeout(std::time::Duration::from_millis(100)) {
                        Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                        Ok(chunk) => break Ok(chunk),
                        Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break Err(()),
                    }
                },
                None => self.rx.recv().map_err(|_| ()),
            };
            self.waited += t.elapsed();
            match next {
                Ok(chunk) => (self.chunk, self.pos) = (chunk, 0),
                // The writer is gone: the end of the program.
                Err(()) => return Ok(&[]),
            }
        }
        Ok(&self.chunk[self.pos..])
    }

    fn consume(&mut self, n: usize) {
        self.pos = (self.pos + n).min(self.chunk.len());
    }
}

/// How a setup is put under the spindle of a table-table machine.
#[derive(Debug, Clone, Copy)]
struct Placement {
    /// The kinematic frame of `angles` (program to part).
    frame: Isometry3,
    /// `[A, B, C]` in degrees, rounded to the program's decimals.
    angles: [f64; 3],
    /// Planning-frame coordinates to program coordinates: a turn about Z (and the planning
    /// frame's translation), so that XY arcs stay XY arcs.
    to_program: Isometry3,
}

impl Placement {
    /// The placement of `setup` (0-based `index`) under `axes` with the tilt axis limited
    /// to `range` degrees, or [`MillError::Unreachable`].
    fn new(
        axes: RotaryAxes,
        setup: &Setup,
        range: [f64; 2],
        decimals: usize,
        index: usize,
    ) -> Result<Self, MillError> {
        let (li, letter) = match axes {
            RotaryAxes::AC => (0, 'A'),
            RotaryAxes::BC => (1, 'B'),
        };
        let solved = rotary_angles(axes, &setup.frame);
        let (tilt, c) = (solved[li], solved[2]);
        let q = 10f64.powi(decimals as i32);
        let round = |v: f64| (v * q).round() / q;
        // C in (-180, 180] after rounding.
        let wrap = |v: f64| {
            let v = round(v);
            if v > 180.0 {
                v - 360.0
            } else if v <= -180.0 {
                v + 360.0
            } else {
                v
            }
        };
        // The same tool axis with the tilt's sign flipped: Rz(C + 180) Rx(-θ) = Rz(C) Rx(θ) Rz(180).
        let [lo, hi] = range;
        let (tilt, c) = [(round(tilt), wrap(c)), (round(-tilt), wrap(c + 180.0))]
            .into_iter()
            .find(|(t, _)| (lo..=hi).contains(t))
            .ok_or_else(|| {
                let t = setup.tool_axis();
                MillError::Unreachable {
                    setup: index + 1,
                    tool_axis: [t.x, t.y, t.z],
                    letter,
                    tilt_deg: tilt,
                    range_deg: range,
                }
            })?;
        let mut angles = [0.0; 3];
        angles[li] = tilt;
        angles[2] = c;
        let frame = rotary_frame(axes, angles);
        // frame * program = setup.frame * planned; up to the rounding of the angles the
        // difference is a turn about Z: keep exactly that, from where it sends +X.
        let d = frame.inverse() * setup.frame;
        let x = d.rotation * Vector3::x();
        let turn = Rotation3::from_axis_angle(&Vector3::z_axis(), x.y.atan2(x.x));
        Ok(Self { frame, angles, to_program: Isometry3::from_parts(d.translation, turn) })
    }
}

/// [`Read::read`] of a source that is a [`BufRead`] at heart.
fn read_from_buffer(source: &mut impl BufRead, buf: &mut [u8]) -> std::io::Result<usize> {
    let avail = source.fill_buf()?;
    let n = avail.len().min(buf.len());
    buf[..n].copy_from_slice(&avail[..n]);
    source.consume(n);
    Ok(n)
}

/// One section of the rotary program, as written.
struct Section {
    /// Its first line in the program (1-based).
    first_line: u64,
    /// Its bytes in the program.
    bytes: std::ops::Range<usize>,
    /// Target voxels removed before the parser reached it.
    gouges_before: u64,
    plan: PlanSummary,
}

/// The one 3+2 program, written setup by setup *while the parser reads it*: when the
/// parser has read every line so far (so the simulator has seen every move before them),
/// the next setup is planned against the material the simulator left and its section is
/// appended. So the program is parsed in one pass, with the modal state a controller
/// would carry, and every setup is still planned against the simulated rest material.
struct RotarySource<'a, 'p> {
    ctx: &'a Ctx<'a>,
    axes: RotaryAxes,
    placements: &'a [Placement],
    turn_z: f64,
    progress: &'p mut dyn FnMut(Stage),
    text: String,
    pos: usize,
    lines: u64,
    sections: Vec<Section>,
    /// The last programmed point, in program coordinates.
    last: Option<Point3>,
    error: Option<MillError>,
    plan_seconds: f64,
}

impl RotarySource<'_, '_> {
    fn write_next(&mut self) -> Result<(), MillError> {
        let i = self.sections.len();
        let (job, place) = (&self.ctx.jobs[i], &self.placements[i]);
        let remaining = self.ctx.excess()?;
        let gouges_before = self.ctx.sim.borrow().report().gouge_voxels;
        (self.progress)(Stage::GcodeTranslation { setup: i + 1, setups: self.ctx.jobs.len() });
        let t = Instant::now();
        let program_err =
            |e: &dyn std::fmt::Display| MillError::Program { setup: i + 1, message: e.to_string() };
        // A writer per section, so that its text is complete when the parser needs it; the
        // first writes the header, the last the footer, and every axis word and feed is
        // stated again after a rotation anyway.
        let wopts = WriterOptions {
            rotary: Some(self.axes),
            header: i == 0,
            footer: i + 1 == self.ctx.jobs.len(),
            ..self.ctx.wopts.clone()
        };
        let mut writer = GcodeWriter::new(Vec::new(), self.ctx.dialect, wopts);
        // Safe retract before the rotation: straight up from where the tool is (above the
        // origin before the first), high enough for the stock to turn under it.
        let from = self.last.unwrap_or_else(Point3::origin);
        let up = Point3::new(from.x, from.y, self.turn_z);
        writer.motion(&Motion::Rapid { to: up }).map_err(|e| program_err(&e))?;
        let rest = VoxelMaterial::new(&remaining, job.setup);
        let mut sink = ToProgram { inner: &mut writer, place, last_in: None, last_out: None };
        let plan = plan_setup_rest(self.ctx.part, &job.setup, &job.tool, &job.popts, Some(&rest), &mut sink)
            .map_err(|e| MillError::Plan { setup: i + 1, message: e.to_string() })?;
        self.last = Some(sink.last_out.unwrap_or(up));
        writer.finish().map_err(|e| program_err(&e))?;
        let mut text = String::from_utf8(writer.into_inner()).map_err(|e| program_err(&e))?;
        if i > 0 {
            // Each section's writer counts its setup as the first.
            text = text.replacen("SETUP 1: ", &format!("SETUP {}: ", i + 1), 1);
        }
        let start = self.text.len();
        self.text.push_str(&text);
        self.sections.push(Section {
            first_line: self.lines + 1,
            bytes: start..self.text.len(),
            gouges_before,
            plan,
        });
        self.lines += text.lines().count() as u64;
        self.plan_seconds += t.elapsed().as_secs_f64();
        (self.progress)(Stage::Simulation { setup: i + 1, setups: self.ctx.jobs.len() });
        Ok(())
    }
}

impl Read for RotarySource<'_, '_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        read_from_buffer(self, buf)
    }
}

impl BufRead for RotarySource<'_, '_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.pos == self.text.len()
            && self.sections.len() < self.ctx.jobs.len()
            && self.error.is_none()
            && let Err(e) = self.write_next()
        {
            let message = e.to_string();
            self.error = Some(e);
            return Err(std::io::Error::other(message));
        }
        Ok(&self.text.as_bytes()[self.pos..])
    }

    fn consume(&mut self, n: usize) {
        self.pos = (self.pos + n).min(self.text.len());
    }
}

/// One 3+2 program for all setups, parsed back in one pass with the rotary kinematics.
fn mill_rotary(
    ctx: &Ctx<'_>,
    axes: RotaryAxes,
    placements: &[Placement],
    turn_z: f64,
    trace: &mut PathTrace,
    times: &mut StageSeconds,
    progress: &mut dyn FnMut(Stage),
) -> Result<Vec<SetupProgram>, MillError> {
    let t = Instant::now();
    let mut source = RotarySource {
        ctx,
        axes,
        placements,
        turn_z,
        progress,
        text: String::new(),
        pos: 0,
        lines: 0,
        sections: Vec::new(),
        last: None,
        error: None,
        plan_seconds: 0.0,
    };
    let popts = ParseOptions { rotary: Some(axes), ..ParseOptions::default() };
    let mut tee = Tee::new(ctx.sim, Some(trace));
    let parsed = parse_reader(&mut source, &popts, &mut tee);
    let section_of = |sections: &[Section], line: u64| sections.iter().rposition(|s| s.first_line <= line);
    let summary = match parsed {
        Ok(summary) => summary,
        Err(e) => {
            return Err(source.error.take().unwrap_or_else(|| MillError::Program {
                setup: source.sections.len().max(1),
                message: format!("re-reading the program: {e}"),
            }));
        }
    };
    if let Some(err) = summary.errors.first() {
        return Err(MillError::Program {
            setup: section_of(&source.sections, err.line).map_or(1, |s| s + 1),
            message: format!("re-reading the program: {err}"),
        });
    }
    if source.sections.len() < ctx.jobs.len() {
        return Err(MillError::Program {
            setup: source.sections.len() + 1,
            message: "re-reading the program: it ended before this setup".into(),
        });
    }
    // The parser finished the simulator, so its report is complete.
    let sim = ctx.sim.borrow();
    let report = sim.report();
    let mut setups = Vec::with_capacity(ctx.jobs.len());
    for (i, (sec, job)) in source.sections.iter().zip(ctx.jobs).enumerate() {
        let next = source.sections.get(i + 1);
        let gouges_after = next.map_or(report.gouge_voxels, |n| n.gouges_before);
        let lines = sec.first_line..next.map_or(u64::MAX, |n| n.first_line);
        setups.push(SetupProgram {
            setup: Setup { frame: placements[i].frame },
            action: job.action,
            plan: sec.plan.clone(),
            text: source.text[sec.bytes.clone()].to_owned(),
            rotary_deg: Some(placements[i].angles),
            lines: next.map_or(source.lines + 1, |n| n.first_line) - sec.first_line,
            gouge_voxels: gouges_after - sec.gouges_before,
            rapid_collision_lines: report
                .rapid_collision_lines
                .iter()
                .copied()
                .filter(|l| lines.contains(l))
                .collect(),
            preservation: 1.0,
        });
    }
    times.gcode_translation += source.plan_seconds;
    times.simulation += (t.elapsed().as_secs_f64() - source.plan_seconds).max(0.0);
    Ok(setups)
}

/// Planning-frame motions of one setup, as program coordinates of its rotary placement;
/// its `Setup` becomes the placement's kinematic frame with its rotary angles.
struct ToProgram<'a, S> {
    inner: S,
    place: &'a Placement,
    /// The last programmed point before and after the transform.
    last_in: Option<Point3>,
    last_out: Option<Point3>,
}

impl<S: MotionSink> MotionSink for ToProgram<'_, S> {
    type Error = S::Error;

    fn motion(&mut self, m: &Motion<'_>) -> Result<(), S::Error> {
        let t = self.place.to_program;
        match m {
            Motion::Setup { .. } => {
                let a = self.place.angles;
                let rotary = [Some(a[0]), Some(a[1]), Some(a[2])];
                self.inner.motion(&Motion::Setup { frame: self.place.frame, rotary })?;
                self.last_out = None;
            }
            Motion::Rapid { to } => self.inner.motion(&Motion::Rapid { to: t * to })?,
            Motion::Linear { to, feed, extrude } => {
                self.inner.motion(&Motion::Linear { to: t * to, feed: *feed, extrude: *extrude })?
            }
            Motion::Arc { to, center, plane: Plane::XY, direction, turns, feed, extrude } => {
                // A turn about Z keeps XY arcs in the XY plane.
                self.inner.motion(&Motion::Arc {
                    to: t * to,
                    center: t * center,
                    plane: Plane::XY,
                    direction: *direction,
                    turns: *turns,
                    feed: *feed,
                    extrude: *extrude,
                })?
            }
            Motion::Arc { to, feed, .. } => {
                // Arcs in the other planes do not survive a turn about Z: straight moves
                // instead (the planner writes none today). Without a start point, or for
                // an arc too degenerate to split, the move goes straight to its end, as
                // the simulator treats a zero-radius arc.
                let mut points = Vec::new();
                let ok = self.last_in.is_some_and(|from| {
                    linearize_arc(&from, m, WriterOptions::default().arc_tolerance, |p| points.push(p))
                        .is_ok()
                });
                if !ok || points.is_empty() {
                    points = vec![*to];
                }
                for p in points {
                    self.inner.motion(&Motion::Linear { to: t * p, feed: *feed, extrude: None })?;
                }
            }
            Motion::Cycle(c) => {
                let xy = t * Point3::new(c.x, c.y, 0.0);
                let dz = t.translation.vector.z;
                let c = crate::gcode::DrillCycle {
                    x: xy.x,
                    y: xy.y,
                    clearance: c.clearance + dz,
                    r_plane: c.r_plane + dz,
                    bottom: c.bottom + dz,
                    ..*c
                };
                self.inner.motion(&Motion::Cycle(c))?;
                self.last_in = Some(Point3::new(c.x, c.y, c.clearance.max(c.r_plane)));
                self.last_out = Some(Point3::new(xy.x, xy.y, c.clearance.max(c.r_plane)));
                return Ok(());
            }
            other => self.inner.motion(other)?,
        }
        if let Some(p) = m.end_point() {
            self.last_in = Some(p);
            self.last_out = Some(t * p);
        }
        Ok(())
    }

    fn source_line(&mut self, line: u64) -> Result<(), S::Error> {
        self.inner.source_line(line)
    }
}

/// Feed and rapid rates (per minute, in planning units) of a preset.
fn feeds(_preset: Preset) -> (f64, f64) {
    // Both presets plan in millimetres: 600 mm/min cutting, 5000 mm/min rapids.
    (600.0, 5000.0)
}

/// Tool numbers follow the action space's radii: T1 is the smallest.
/// Features of one setup: for each radius, the fraction of the surface samples visible
/// from the setup that a ball of that radius touches without entering the part.
fn setup_features(
    index: &MeshIndex,
    samples: &crate::geom::SurfaceSamples,
    setup: &Setup,
    space: &ActionSpace,
    diag: f64,
    stock: &Aabb,
    voxel: f64,
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
    // Per radius: at how many visible samples the ball touching there (centre one radius
    // out along the normal) is clear of the part, all but 2 % of its radius; and all but
    // half a voxel, if that is more.
    let (reach_by_radius, reach_at_resolution) = space
        .radii
        .iter()
        .map(|&r| {
            if visible.is_empty() {
                return (0.0, 0.0);
            }
            let (clear, within_voxel) = visible
                .par_iter()
                .map(|(p, n)| {
                    let d = index.signed_distance(&(*p + *n * r));
                    (usize::from(d >= r * 0.98), usize::from(d >= r - (0.02 * r).max(0.5 * voxel)))
                })
                .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
            let n = visible.len() as f64;
            (clear as f64 / n, within_voxel as f64 / n)
        })
        .unzip();
    // The stock's extent along the tool axis: its top and bottom.
    let zs: Vec<f64> = stock.corners().iter().map(|c| c.coords.dot(&axis)).collect();
    let top = zs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let depth = top - zs.iter().copied().fold(f64::INFINITY, f64::min);
    let bins = SetupFeatures::DEPTH_BINS;
    let mut depth_histogram = vec![0.0; bins];
    if !visible.is_empty() && depth > 0.0 {
        for (p, _) in &visible {
            let h = ((top - p.coords.dot(&axis)) / depth).clamp(0.0, 1.0);
            depth_histogram[((h * bins as f64) as usize).min(bins - 1)] += 1.0;
        }
        depth_histogram.iter_mut().for_each(|b| *b /= visible.len() as f64);
    }
    let scale = 1.0 / stock.extent().max().max(f64::MIN_POSITIVE);
    let step = visible.len().div_ceil(SetupFeatures::MAX_POINTS).max(1);
    let points = visible
        .iter()
        .step_by(step)
        .map(|(p, _)| {
            let q = setup.to_setup(p);
            [(q.x * scale) as f32, (q.y * scale) as f32, (q.z * scale) as f32]
        })
        .collect();
    SetupFeatures {
        reach_by_radius,
        reach_at_resolution,
        depth,
        removal_fraction: 0.0,
        voxel,
        visible_fraction: visible.len() as f64 / samples.points.len().max(1) as f64,
        depth_histogram,
        points,
    }
}

/// Forwards motions to the simulator and records the first setup's path in part units.
struct Tee<'a> {
    sim: &'a RefCell<Simulator>,
    trace: Option<&'a mut PathTrace>,
    /// The current frame and how many setups have begun.
    frame: Setup,
    setups: usize,
    /// The last point, in the part frame and the program's (setup) frame.
    last: Option<(Point3, Point3)>,
    /// Where to report [`Stage::Layers`] ([`Tee::watching`]).
    watch: Option<Watch<'a>>,
}

/// What a [`Tee`] reports progress with.
struct Watch<'a> {
    progress: &'a mut dyn FnMut(Stage),
    planner: &'a PlanProgress,
    setup: usize,
    setups: usize,
    moves: u64,
}

impl<'a> Tee<'a> {
    fn new(sim: &'a RefCell<Simulator>, trace: Option<&'a mut PathTrace>) -> Self {
        Self { sim, trace, frame: Setup::top(), setups: 0, last: None, watch: None }
    }

    /// Reports [`Stage::Layers`] of setup `setup` (1-based) of `setups` to `progress`
    /// every few thousand moves, with the levels `planner` has emitted.
    fn watching<'b>(
        self,
        progress: &'b mut dyn FnMut(Stage),
        planner: &'b PlanProgress,
        setup: usize,
        setups: usize,
    ) -> Tee<'b>
    where
        'a: 'b,
    {
        Tee {
            sim: self.sim,
            trace: self.trace,
            frame: self.frame,
            setups: self.setups,
            last: self.last,
            watch: Some(Watch { progress, planner, setup, setups, moves: 0 }),
        }
    }
}

impl MotionSink for Tee<'_> {
    type Error = crate::voxsim::SimError;
    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        if let Motion::Setup { frame, .. } = m {
            self.frame = Setup { frame: *frame };
            self.setups += 1;
            self.last = None;
        } else if let (Some(trace), Some(at), 1) = (self.trace.as_deref_mut(), m.end_point(), self.setups) {
            let to = self.frame.to_part(&at);
            if let Some((from, was)) = self.last {
                // Program coordinates of one level are written alike.
                trace.push(from, to, !matches!(m, Motion::Rapid { .. }), [was.z, at.z], 1e-9);
            }
            self.last = Some((to, at));
        }
        if let Some(w) = &mut self.watch {
            w.moves += 1;
            if w.moves % (1 << 14) == 0 {
                let (done, levels) = w.planner.levels();
                (w.progress)(Stage::Layers {
                    setup: w.setup,
                    setups: w.setups,
                    done,
                    levels,
                    moves: w.moves,
                });
            }
        }
        self.sim.borrow_mut().motion(m)
    }
    fn source_line(&mut self, line: u64) -> Result<(), Self::Error> {
        self.sim.borrow_mut().source_line(line)
    }
    fn finish(&mut self) -> Result<(), Self::Error> {
        self.sim.borrow_mut().finish()
    }
}

#[cfg(test)]
mod tests {
    use std::io::{BufRead, Read, Write};

    use super::{CHUNK_BYTES, CHUNKS_IN_FLIGHT, chunk_channel};

    /// Bytes written on one thread arrive in order on the other, across many chunks, and
    /// the kept copy is the same bytes.
    #[test]
    fn a_chunk_channel_delivers_every_byte_in_order() {
        let data: Vec<u8> = (0..3 * CHUNK_BYTES + 12_345).map(|i| (i * 7 % 251) as u8).collect();
        let (mut w, mut r) = chunk_channel(true);
        let (kept, read) = std::thread::scope(|s| {
            let writer = s.spawn(|| {
                for piece in data.chunks(1000) {
                    w.write_all(piece).unwrap();
                }
                w.finish().unwrap().0
            });
            let mut read = Vec::new();
            r.read_to_end(&mut read).unwrap();
            (writer.join().unwrap(), read)
        });
        assert_eq!(read.len(), data.len());
        assert!(read == data, "bytes differ");
        assert!(kept == data, "kept bytes differ");
        assert!(r.fill_buf().unwrap().is_empty(), "the stream ended");
    }

    /// Without `keep` nothing is kept; a writer dropped part way ends the stream there.
    #[test]
    fn a_dropped_writer_ends_the_stream() {
        let (mut w, mut r) = chunk_channel(false);
        w.write_all(b"G0 X1\n").unwrap();
        w.flush().unwrap();
        drop(w);
        let mut text = String::new();
        r.read_to_string(&mut text).unwrap();
        assert_eq!(text, "G0 X1\n");
        let (w, _r) = chunk_channel(false);
        assert!(w.finish().unwrap().0.is_empty());
    }

    /// A reader that hangs up makes the writer fail instead of blocking for ever.
    #[test]
    fn a_writer_fails_once_the_reader_hangs_up() {
        let (mut w, r) = chunk_channel(false);
        drop(r);
        let piece = vec![b'x'; CHUNK_BYTES];
        let failed = (0..=CHUNKS_IN_FLIGHT).find_map(|_| w.write_all(&piece).err());
        let e = failed.expect("writing into a closed stream failed");
        assert_eq!(e.kind(), std::io::ErrorKind::BrokenPipe);
    }
}
