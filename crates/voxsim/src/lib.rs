//! `s2g-voxsim`: voxel material simulation of machine programs.
//!
//! A [`Simulator`] is a [`s2g_gcode::MotionSink`]: feed it the parser's motions (G-code
//! text -> parse -> simulate streams, see [`simulate_str`]) or a planner's motions directly.
//! It carves a stock [`VoxelGrid`] in the part frame and reports removed volume, gouges into
//! an optional target grid, rapid moves through material, shank/holder collisions,
//! machining time and the Shape2Gcode paper's rewards (Eqs. 10-13).
//!
//! # Model
//! - **Cutters** ([`Cutter`]): flat, ball and bull nose, with flute length, shank and optional
//!   holder. The programmed point is the tool **tip** (lowest point along the tool axis); a
//!   ball's centre is `tip + radius * axis`.
//! - **Frames.** `Motion::Setup { frame }` maps program points to part points (`frame * p`);
//!   the tool axis in the part frame is `frame * Z`; identity before any setup. A setup
//!   reported on the same (non-zero) source line as the following move is a simultaneous
//!   axis change: the move is split into sub-steps, the frame interpolated (rotation slerp,
//!   translation lerp) and each sub-step swept with the axis of its midpoint; the number of
//!   sub-steps keeps the tool's deviation under the arc tolerance (capped by
//!   [`SimOptions::max_substeps`]). Otherwise the setup is indexed: the rotation itself is not
//!   simulated and the next move is a positioning move (the tool appears at its end point).
//!   A tilting head (`Motion::ToolAxis`) is not simulated: an axis off `+Z` is an error.
//! - **Voxel rule.** A voxel is removed iff its **centre** lies in the volume swept by the
//!   cutter's fluted part along the move (exactly, for a fixed axis: see the `sweep` module
//!   notes in the source). Arcs are split into chords whose sagitta is below a quarter of
//!   a voxel ([`SimOptions::arc_tolerance`]); helices are fine.
//! - **Rapids cut too** (physically they do); a voxel a rapid removes is a rapid collision,
//!   reported with its source line, when its centre lies deeper inside the swept tool than
//!   [`SimOptions::collision_tolerance`] (1 % of a voxel): shallower, the rapid only grazes
//!   it, as the rounding of program coordinates and the chords of offset arcs make rapids
//!   do along walls that passes above traced.
//! - **Shank and holder.** After each move's cut, stock left inside the swept shank/holder
//!   region, past the same tolerance, is a holder collision (line reported; the stock is
//!   not removed).
//! - **Start.** The tool position before the first move is unknown by default: the first
//!   move is a positioning move (only the tool at its end point cuts).
//!
//! # Carvers ([`Carver`])
//! - `Exact` (default): brick-parallel exact swept volumes, batched many moves per pass.
//! - `Dexel`: per-column material intervals for setups whose tool axis is a grid axis;
//!   column intervals in closed form, merged into the voxels at the end of the setup; uses
//!   the same voxel-centre rule, so it agrees with `Exact` (tests check <= 0.1 %).
//! - `PaperMonteCarlo`: the paper's Algorithm A1 as printed, a baseline for comparison.
//!
//! # Bull nose
//! A bull nose end is the lower half of the set of points within the corner radius of a
//! flat disc of radius `radius - corner_radius` (a "rounded puck"); that set is convex, so the
//! squared distance from a voxel centre to the moving disc is convex in the move parameter
//! and its minimum is found by bisection on the derivative to machine precision: exact up
//! to rounding. This is why the flute length must be at least twice the corner radius.
//!
//! # Surface deviation
//! [`HeightField`] is a second sink for 3-axis programs: columns at a fine spacing (default
//! 0.05 mm), each cut to the lowest point of the swept cutter on its line (exact in Z), and
//! [`surface_deviation`] measures the cut points' distance from the part (max, mean, gouge
//! depth): a finishing pass's scallops are far below a voxel, so IoU cannot see them.
//!
//! # Additive mode
//! [`Simulator::depositor`] deposits a bead ([`BeadProfile`]) below the nozzle tip along every
//! extrusion move, for the FDM reconstruction.
//!
//! # Errors
//! Impossible tools, non-finite motions and mismatched grids are [`SimError`]s; feed moves
//! without a usable feed are counted ([`SimReport::feedless_moves`]) and left out of the time;
//! an unknown tool number selects the default tool; an arc of zero radius is a straight move.

mod columns;
mod dexel;
mod engine;
mod error;
mod paper;
mod sim;
mod surface;
mod sweep;
mod tool;

pub use s2g_geom::VoxelGrid;

pub use crate::error::{Result, SimError};
pub use crate::sim::{
    Carver, RewardWeights, Rewards, SimOptions, SimReport, Simulation, Simulator, rewards, simulate_file,
    simulate_str,
};
pub use crate::surface::{
    DeviationOptions, HeightField, HeightFieldOptions, SurfaceDeviation, deviation_at, surface_deviation,
    surface_deviation_opt, surface_deviation_reference, surface_deviation_where,
};
pub use crate::tool::{BeadProfile, Cutter, CutterShape, Holder, Neck, ToolTable};
