//! `shape2gcode`: the composed Shape2Gcode pipeline.
//!
//! Mesh to G-code (`mill`) and G-code back to geometry, built from the workspace
//! crates, which are re-exported here so that one dependency gives the whole system.

pub use s2g_gcode as gcode;
pub use s2g_geom as geom;
pub use s2g_orient as orient;
#[cfg(feature = "learn")]
pub use s2g_rl as rl;
pub use s2g_toolpath as toolpath;
pub use s2g_voxsim as voxsim;

mod eval;
pub mod fdm;
mod feature;
#[cfg(feature = "learn")]
mod learn;
mod pipeline;
mod policy;
mod render;
mod report;
mod trace;

pub use crate::eval::{
    Ci95, CoverageRow, EvalOptions, EvalPlan, PartResult, PartScores, RESULT_SUFFIX, Row, RunKey, SeedGroup,
    Shard, TableSet, Tables, default_ablated, evaluate, evaluate_part, merge_results, part_result_path,
    policy_by_name, tables_from_parts, write_part_result,
};
pub use crate::fdm::{
    Bead, BeadShape, Deposition, Extrusion, FdmError, FdmOptions, FdmOutput, FdmReport, FdmStageSeconds,
    Reconstruction, Solid, deposit_beads, deposit_beads_naive, extract_beads, indexed_check, profile_area,
    profile_width, reconstruct, reconstruct_file, render_layer, render_result, save_step, solid_grid_spec,
    solid_mesh, sweep_spine, tube_mesh, write_step,
};
pub use crate::feature::{
    FeatureCheck, FeatureError, FeatureProgram, FeatureResidual, JobSpec, feature_program,
    feature_writer_options, load_job, parse_job,
};
#[cfg(feature = "learn")]
pub use crate::learn::{
    DgcnnShape, EncoderKind, GeometricEncoder, LearnedPolicy, MachiningEnv, PolicyInfo, RewardShaping,
    SetupEncoder, TrainOptions, observation, train_policy,
};
pub use crate::pipeline::{
    Datum, MillError, MillOptions, MillRun, Milled, PartDeviation, Preset, ProgramLayout, SetupChoice,
    SetupCount, SetupFinish, SetupProgram, Stage, StageSeconds, Stock, default_tool_library, mill,
};
pub use crate::policy::{
    Action, ActionSpace, FinishChoice, FinishStrategyKind, FixedPolicy, HeuristicPolicy, Policy,
    RandomPolicy, SetupContext, SetupFeatures, StrategyKind,
};
pub use crate::render::{Image, render_machining};
pub use crate::trace::PathTrace;
