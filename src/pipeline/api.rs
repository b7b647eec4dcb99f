//! The public types of a milling run: options, presets, layouts, stages, errors and results.

use crate::gcode::{Dialect, MachineProfile, RotaryAxes};
use crate::geom::{Aabb, Mesh, Setup, ShapeMetrics, Vector3};
use crate::orient::OrientationResult;
use crate::policy::{Action, ActionSpace, FinishChoice, StrategyKind};
use crate::toolpath::finish::FinishSummary;
use crate::toolpath::library::ToolLibrary;
use crate::toolpath::{PlanSummary, Tool};
use crate::trace::PathTrace;
use crate::voxsim::{Carver, RewardWeights, Rewards, SimReport, SurfaceDeviation};

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

/// The stock a run cuts from, in planning units (millimetres; the paper preset's part is
/// normalised to [`MillOptions::paper_scale_mm`] first) and the part's frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Stock {
    /// The preset's stock: the paper's cube of the part's longest side centred on it, or
    /// the shop's bounding box grown by [`MillOptions::stock_margin`]. The default.
    #[default]
    Preset,
    /// A box of this size (X, Y, Z) centred on the part's bounding box.
    BoxSize([f64; 3]),
    /// A box between two corners.
    BoxCorners {
        /// The lowest corner.
        min: [f64; 3],
        /// The highest corner.
        max: [f64; 3],
    },
    /// Bar stock: a cylinder of this diameter and length whose axis is the principal
    /// axis `axis` (0 = X, 1 = Y, 2 = Z), centred on the part's bounding box. Setups plan
    /// over the bar's bounding box; the simulator starts from the round bar.
    Cylinder {
        /// Diameter.
        diameter: f64,
        /// Length.
        length: f64,
        /// The bar's axis: 0 = X, 1 = Y, 2 = Z.
        axis: usize,
    },
}

/// Where each program's work coordinate system (G54) has its origin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Datum {
    /// X0 Y0 at the centre of the stock's box in the setup's X and Y, Z0 on its top.
    TopCentre,
    /// X0 Y0 at the stock box's lowest X and Y corner in the setup's frame, Z0 on its top.
    Corner,
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
    /// Shop preset: put the simulation grid's voxel planes through the part's flat faces
    /// (the voxel within 2 % of the resolution's, offsets per axis with the least
    /// misplaced face volume, no face on a row of voxel centres) rather than on the lattice
    /// of the report's scorer, so that the residual's flat faces lie where the part has
    /// them for any scorer. Default true; the paper preset ignores it (its grid is the
    /// scorer's, as in the paper).
    pub face_grid: bool,
    /// Shop preset: orientation selection counts a surface reached only as deep as a
    /// library tool that fits there reaches with its holder clear of the stock's top
    /// (`s2g_orient::ToolReach::of_tools`), rather than as deep as the longest flat end
    /// mill reaches wherever the surface is; a tilted setup then gives way to a principal
    /// axis that meets the coverage target, a flip first. It gives the stress bushings and
    /// example002 the -Z setups their deep holes need (at 256^3: bushings 0.961-0.968 ->
    /// 0.988, example002 0.986 -> 0.993, example004 0.959 -> 0.968; 22 of the 26 swept
    /// parts at IoU 0.98 against 19 without). Default true; the paper preset ignores it
    /// (its tools reach through the stock).
    pub tool_aware_reach: bool,
    /// With [`tool_aware_reach`](Self::tool_aware_reach): a tool that comes within this
    /// of a surface (part units, mm in the shop preset) reaches it, as a tool no wider
    /// than the surface's room plus this fits there ([`ToolReach::slack`](crate::orient::ToolReach::slack)).
    /// `None` (the default): [`REACH_SLACK_MM`](Self::REACH_SLACK_MM), or half the
    /// simulation's voxel where that is more (what its grid can show).
    pub reach_slack: Option<f64>,
    /// Millimetres per normalised unit in the paper preset. Default 100.
    pub paper_scale_mm: f64,
    /// Paper preset: the action space's radii and layer heights multiplied by this
    /// (normalised units), so that a coarse grid sees its tools as the paper's 256³ grid
    /// does: 256 / resolution makes the tools of a 64³ grid 0.26-2.56 voxels in radius (5
    /// voxels across for the largest) where the paper's are 0.06-0.64 ([`ActionSpace::paper_at_resolution`]). Must be positive;
    /// default 1 (the paper's space).
    pub paper_space_scale: f64,
    /// The stock. Default [`Stock::Preset`].
    pub stock: Stock,
    /// The origin of each per-setup program's coordinates (G54), stated in its header
    /// comment and the report. `None` (the default, the paper's programs) writes program
    /// coordinates in the part's frame turned to the setup, with no statement. The rotary
    /// layout's origin is its rotary centre and takes no datum.
    pub datum: Option<Datum>,
    /// Choose setups so that the stock's material, not only the part's surface, can be cut
    /// away ([`select_orientations_in_stock`](crate::orient::select_orientations_in_stock)):
    /// where the setups that see the part leave stock that other directions would reach,
    /// directions are swapped or added. `false` is the paper's visibility-only selection,
    /// the named baseline. Default true.
    pub stock_removal: bool,
    /// Millimetres per unit of the input mesh in the shop preset (25.4 for a mesh in
    /// inches, 1000 for one in metres, or any scale of the part): mesh files carry no unit.
    /// The paper preset normalises the part and does not read it. Default 1.
    pub input_scale: f64,
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
    /// Write G2/G3 arcs (and one line for a run that a line fits) within this distance in
    /// program units (mm), `None` (the default, the paper's programs): straight moves
    /// through every planned point. The planner fits each roughing pass on the part's side
    /// of its path ([`PlanOptions::arc_tolerance`](crate::toolpath::PlanOptions::arc_tolerance)):
    /// the walls keep the tolerance as allowance, so no arc comes nearer the part than
    /// planned and none leaves material the path would have cut. Finishing passes along X
    /// or Y become G18/G19 arcs above their cutter-location points, each checked with the
    /// drop-cutter as a straight move is
    /// ([`FinishOptions::arc_tolerance`](crate::toolpath::finish::FinishOptions::arc_tolerance)).
    /// The simulator follows arcs within 1/64 of a voxel.
    pub arc_tolerance: Option<f64>,
    /// With [`arc_tolerance`](Self::arc_tolerance): fit arcs (default true). False plans
    /// the same paths (the walls keep the tolerance) and writes them straight: the program
    /// the fitted one is compared with.
    pub fit_arcs: bool,
    /// Shop preset: the tool library whose flat end mills rough (the action space's radii
    /// are theirs), at their cutting data in [`material`](Self::material) on the library's
    /// machine. `None`: the shipped library ([`default_tool_library`](super::default_tool_library),
    /// `assets/tools/default.toml`). The paper preset machines with the paper's tools and
    /// refuses a library. Default `None`.
    pub tools: Option<ToolLibrary>,
    /// Shop preset: the workpiece material, a name in the tool library. Default
    /// `aluminium-6061`.
    pub material: String,
    /// Shop preset: the machine that limits spindle speeds and feeds and times the
    /// programs (with acceleration). `None`: the library's `[machine]`, else
    /// [`MachineProfile::default`]. Default `None`.
    pub machine: Option<MachineProfile>,
    /// Finish each setup after its roughing, in the same program (a tool change to a ball
    /// or bull-nose end mill, its passes over the part's drop-cutter surface), with this
    /// choice as the default the policy may change ([`Policy::finish`](crate::Policy::finish)).
    /// Per-setup layout and a dialect with a tool changer only. `None` (default, the
    /// paper's programs): rough only.
    pub finish: Option<FinishChoice>,
    /// Stock the roughing leaves for the finisher, `[radial, axial]`, where
    /// [`finish`](Self::finish) is on ([`PlanOptions::finishing_allowance`] and
    /// [`PlanOptions::axial_allowance`](crate::toolpath::PlanOptions::axial_allowance));
    /// without finishing the roughing leaves none. Default `[0.0, 0.0]`: the roughing cuts
    /// walls and flats to size and the finisher takes off the layer steps on the slopes
    /// (a ball raster leaves a radial allowance on the part's outer walls, which it never
    /// descends, and an axial one on flats it does not reach; issue 35's flat parts kept
    /// IoU 0.95-0.96 with `[0.3, 0.3]`).
    ///
    /// [`PlanOptions::finishing_allowance`]: crate::toolpath::PlanOptions::finishing_allowance
    pub finish_allowance: [f64; 2],
    /// Column spacing of the height field on which each finished setup's surface
    /// deviation is measured ([`SetupFinish::deviation`]), in part units. Default 0.1.
    pub surface_spacing: f64,
    /// Shop preset, per-setup layout: rest roughing ([`Milled::setups`] entries with
    /// [`SetupProgram::rest_of`]). Right after a setup's roughing, and before its
    /// finishing (which moves into the last rest program), the setup is machined again, in
    /// its own program and fixture, with a smaller flat end mill of the library over the
    /// material the earlier programs left (the simulated in-process stock), as deep below
    /// the stock's top as that tool's flutes are long, or as keeps its holder above the
    /// stock left where [`rest_continue`](Self::rest_continue) finds material there. At
    /// most this many smaller tools are considered per setup, each a flat end mill at
    /// most 0.7 times as wide as the one before, the one of those whose flutes reach
    /// deepest into the setup's stock (the widest of equals), and each runs only where
    /// [`rest_continue`](Self::rest_continue) says; 0 keeps one roughing tool per setup.
    /// Corners keep the roughing tool's radius and slots narrower than it keep their
    /// material otherwise (12 mm, then 8 and 5; 5 mm, then 3 and 2 with the shipped
    /// library). The paper preset ignores it. Default 3.
    pub rest_roughing: usize,
    /// Rest roughing ([`rest_roughing`](Self::rest_roughing)): a rest pass runs, and cuts
    /// deeper than its flutes, only where the material left that it is for is at least
    /// this fraction of the part's volume: material the pass's tool can take (lowered
    /// over the part from a place whose cutter covers it) and the wider tool before it
    /// cannot, farther from the part than the finishing allowance and a quarter voxel, seen
    /// along the setup's axis, and where the setup is finished, out of the finishing tool's
    /// reach. Default 0.0005 (0.05 %: the turned shaft's 2.5 mm grooves, 36 mm³ a setup of
    /// its 38.7 cm³, get their 2 mm passes and IoU* 0.9805; on the bunny at 100 mm no setup
    /// has that much, 82 mm³ at most of 200 cm³, and its rest passes would cost an hour of
    /// machining for no IoU); 0 runs every pass [`rest_roughing`](Self::rest_roughing) allows.
    pub rest_continue: f64,
}

impl MillOptions {
    /// The resolutions a run accepts ([`resolution`](Self::resolution)): voxels along the
    /// stock's longest side.
    pub const RESOLUTIONS: std::ops::RangeInclusive<usize> = 8..=2048;

    /// The tool-aware reach's default slack (mm, [`reach_slack`](Self::reach_slack)): the
    /// roughing's allowance, which a tool that comes this close to a surface leaves as the
    /// roughing does. Half a voxel, the slack before, fell at 256^3 to 0.14 mm on
    /// gearwheel_40t, whose tooth roots the 1 mm end mill misses by 0.03-0.34 mm: they
    /// counted as unreached from +Z and -Z and side setups took their place (IoU 0.993 ->
    /// 0.940; with 0.3 mm the gear's run is main's, 0.9926).
    pub const REACH_SLACK_MM: f64 = 0.3;

    /// The action space these options mill with, in planning units: the paper's scaled to
    /// [`paper_scale_mm`](Self::paper_scale_mm), or the shop's, limited to
    /// [`strategies`](Self::strategies).
    pub fn action_space(&self) -> ActionSpace {
        let mut space = match self.preset {
            Preset::Paper => ActionSpace::paper().scaled(self.paper_space_scale * self.paper_scale_mm),
            Preset::Shop => ActionSpace {
                radii: super::tooling::flat_end_mills(self.library())
                    .iter()
                    .map(|t| t.cutter.radius)
                    .collect(),
                ..ActionSpace::shop()
            },
        };
        space.strategies.retain(|s| self.strategies.contains(s));
        space
    }
}

impl MillOptions {
    /// The shop preset's tool library: [`tools`](Self::tools), or the shipped one.
    pub fn library(&self) -> &ToolLibrary {
        self.tools.as_ref().unwrap_or_else(|| super::default_tool_library())
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
            face_grid: true,
            tool_aware_reach: true,
            reach_slack: None,
            paper_scale_mm: 100.0,
            paper_space_scale: 1.0,
            stock: Stock::Preset,
            datum: None,
            stock_removal: true,
            strategies: StrategyKind::all(),
            residual_smoothing: 8,
            carver: Carver::Exact,
            contour: true,
            roughing_depth_diameters: 1.0,
            flank_walls: true,
            max_estimated_hours: 10_000.0,
            input_scale: 1.0,
            arc_tolerance: None,
            fit_arcs: true,
            tools: None,
            material: "aluminium-6061".into(),
            machine: None,
            finish: None,
            finish_allowance: [0.0, 0.0],
            surface_spacing: 0.1,
            rest_roughing: 3,
            rest_continue: 0.0005,
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
    #[error("orientation selection")]
    Orient(#[from] crate::orient::OrientError),
    /// Planning a setup failed.
    #[error("planning setup {setup}")]
    Plan {
        /// 1-based setup.
        setup: usize,
        /// The planner's error.
        #[source]
        source: crate::toolpath::ToolpathError<crate::gcode::WriteError>,
    },
    /// Writing or re-reading a program failed.
    #[error("program of setup {setup}: {what}")]
    Program {
        /// 1-based setup.
        setup: usize,
        /// What was being done (`writing the program`, `re-reading the program`).
        what: String,
        /// The writer's, reader's or parser's error, where one failed.
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// The simulation failed.
    #[error("simulation")]
    Simulation(#[source] crate::voxsim::SimError),
    /// Reading or writing a file (an outcome or policy file) failed.
    #[error("{}", path.display())]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// A file is not what it should be: an outcome file (`line` where one is at fault) or a
    /// policy file.
    #[error("{}{}: {what}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    BadFile {
        /// The file.
        path: std::path::PathBuf,
        /// The 1-based line at fault, where the file has lines.
        line: Option<usize>,
        /// What is wrong.
        what: String,
        /// The decoder's error, when one found it.
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// Encoding a record (an outcome or a policy's header) as JSON failed.
    #[error("encoding {what} as JSON")]
    Encode {
        /// What was being encoded.
        what: &'static str,
        /// The encoder's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The learning agent failed (training, a checkpoint's bytes).
    #[cfg(feature = "learn")]
    #[error("learning")]
    Learning(#[source] crate::rl::RlError),
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

impl MillError {
    /// A [`MillError::Program`] of setup `setup` (1-based): `what` failed with `source`.
    pub(crate) fn program(
        setup: usize,
        what: &str,
        source: impl Into<Box<dyn std::error::Error + Send + Sync>>,
    ) -> Self {
        MillError::Program { setup, what: what.to_owned(), source: Some(source.into()) }
    }
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
    /// The finished surfaces' deviation from the part (height fields against the mesh),
    /// where the run finishes.
    pub surface: f64,
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
    /// The tool it was machined with: the cutter, its number, spindle speed, feeds and
    /// coolant.
    pub tool: Tool,
    /// Seconds this setup's program runs on the run's machine, acceleration included
    /// ([`MachineTime`](crate::gcode::MachineTime)): the shop preset's (its library's
    /// machine) in the per-setup layout; `None` in the paper preset, whose times are the
    /// paper's (length / feed), and in the rotary layout.
    pub machine_time_s: Option<f64>,
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
    /// Lines of this setup's program where the shank or holder met stock (in the rotary
    /// layout: lines of the one program, within this setup's section).
    pub holder_collision_lines: Vec<u64>,
    /// The paper's preservation `R_s` (Eq. 10) after this setup: the fraction of the part's
    /// voxels still there.
    pub preservation: f64,
    /// The finishing after the roughing, where the run finishes ([`MillOptions::finish`]):
    /// in a setup's own program, or, where rest roughing follows it, in its last rest
    /// program's, after the rest pass.
    pub finish: Option<SetupFinish>,
    /// A rest-roughing program ([`MillOptions::rest_roughing`]): the 1-based setup whose
    /// fixture and axis it machines again with a smaller tool. `None` for a setup's own.
    pub rest_of: Option<usize>,
}

/// A setup's finishing: what it was done with, its time, and the surface it left.
#[derive(Debug, Clone, PartialEq)]
pub struct SetupFinish {
    /// The choice it was made with (the policy's).
    pub choice: FinishChoice,
    /// The finishing tool.
    pub tool: Tool,
    /// The finisher's summary (passes, links, retracts, lengths, its own time estimate).
    pub summary: FinishSummary,
    /// Seconds of the setup's program before the finishing tool change (the roughing) and
    /// from it on (the finishing): on the run's machine where it has one
    /// ([`SetupProgram::machine_time_s`] is their sum), else the planners' length / feed
    /// estimates.
    pub roughing_time_s: f64,
    /// See [`roughing_time_s`](Self::roughing_time_s).
    pub finishing_time_s: f64,
    /// Deviation of the surface the finishing moves cut, as a height field of columns
    /// [`MillOptions::surface_spacing`] apart in the setup's frame, from the part: max and
    /// mean over the columns the finisher reached, gouge depth over all.
    pub deviation: SurfaceDeviation,
    /// The material this setup's finishing left at each of the run's surface samples
    /// ([`PartDeviation::SAMPLES`] points of the part's surface), for
    /// [`Milled::surface_deviation`]: the thickness along the surface's normal up to the
    /// cut, where the finisher's ball reaches the point and cut to within 1 mm of it; NaN
    /// where not.
    pub reached: Vec<f32>,
}

/// The deviation of the finished part's surface from the part, over every setup: at each
/// surface sample a setup's finishing reached ([`SetupFinish::reached`]), the least of
/// those setups' (where one setup finished a place, another that only brushed it leaves
/// no more material).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PartDeviation {
    /// Largest deviation, in part units (mm).
    pub max: f64,
    /// Mean over the reached samples.
    pub mean: f64,
    /// 99th percentile over the reached samples.
    pub p99: f64,
    /// Samples reached by some setup's finishing.
    pub samples: usize,
}

impl PartDeviation {
    /// Surface samples (area-weighted) at which the deviation is measured.
    pub const SAMPLES: usize = 100_000;

    /// The setups' per-sample deviations ([`SetupFinish::reached`]) combined; `None` where
    /// no setup reached any sample.
    pub fn combine<'a>(reached: impl IntoIterator<Item = &'a [f32]>) -> Option<Self> {
        let mut best: Vec<f32> = Vec::new();
        for r in reached {
            if best.is_empty() {
                best = vec![f32::NAN; r.len()];
            }
            for (b, &d) in best.iter_mut().zip(r) {
                if !d.is_nan() && (b.is_nan() || *b > d) {
                    *b = d;
                }
            }
        }
        let mut ds: Vec<f64> = best.iter().filter(|d| !d.is_nan()).map(|&d| f64::from(d)).collect();
        if ds.is_empty() {
            return None;
        }
        ds.sort_by(f64::total_cmp);
        let n = ds.len();
        let p99 = ds[((0.99 * (n - 1) as f64).round() as usize).min(n - 1)];
        Some(Self { max: ds[n - 1], mean: ds.iter().sum::<f64>() / n as f64, p99, samples: n })
    }
}

impl SetupFinish {
    /// Cuts into the part deeper than this (mm) by the finishing height field count as
    /// a gouge ([`Milled::is_safe`]): the finisher's links are checked by the drop-cutter
    /// at samples 0.05 mm apart, so a chord between two may dip by a few micrometres.
    pub const GOUGE_TOLERANCE: f64 = 0.005;

    /// Whether the finishing gouged the part (beyond [`GOUGE_TOLERANCE`](Self::GOUGE_TOLERANCE)).
    pub fn gouged(&self) -> bool {
        self.deviation.gouge_depth > Self::GOUGE_TOLERANCE
    }
}

/// The outcome of [`mill`].
#[derive(Debug, Clone)]
pub struct Milled {
    /// The preset the run used.
    pub preset: Preset,
    /// The stock option the run used ([`MillOptions::stock`]).
    pub stock_option: Stock,
    /// The datum of the programs ([`MillOptions::datum`]); each setup's program origin is
    /// its [`SetupProgram::setup`] frame's translation.
    pub datum: Option<Datum>,
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
    /// The finished surface's deviation from the part over every setup, where the run
    /// finishes ([`PartDeviation`]).
    pub surface_deviation: Option<PartDeviation>,
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
        // Eq. 13's setups are those the policy chose actions for, not the rest-roughing
        // programs within them: R_s is the preservation once setup s is machined whole,
        // after its last program (its rest passes and finishing follow its roughing).
        let last = |i: usize| self.setups.get(i + 1).is_none_or(|next| next.rest_of.is_none());
        let ends = self.setups.iter().enumerate().filter(|&(i, _)| last(i));
        weights.lambda_s * ends.map(|(_, s)| s.preservation).sum::<f64>()
            + weights.lambda_f * self.rewards.final_iou
            + weights.lambda_mrr * self.simulation.mrr_mm3_per_min / 1000.0
    }

    /// Whether the programs are safe: no gouge into the part (in the voxels or, deeper than
    /// the finishing check's tolerance, in a finished surface), no rapid through material and
    /// no shank or holder touching the stock (`s2g mill` exits with status 2 otherwise).
    pub fn is_safe(&self) -> bool {
        self.simulation.gouge_voxels == 0
            && self.rapid_collisions() == 0
            && !self.setups.iter().any(|s| s.finish.as_ref().is_some_and(SetupFinish::gouged))
            && self.simulation.holder_collisions.is_empty()
    }
}
