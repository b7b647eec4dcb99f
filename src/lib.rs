//! `shape2gcode`: the composed Shape2Gcode pipeline.
//!
//! Mesh to G-code (`mill`) and G-code back to geometry, built from the workspace
//! crates, which are re-exported here so that one dependency gives the whole system.

pub use s2g_gcode as gcode;
pub use s2g_geom as geom;
pub use s2g_orient as orient;
pub use s2g_toolpath as toolpath;
pub use s2g_voxsim as voxsim;

mod eval;
mod pipeline;
mod policy;
mod render;
mod report;

pub use crate::eval::{CoverageRow, Row, Tables, evaluate, policy_by_name};
pub use crate::pipeline::{
    MillError, MillOptions, Milled, Preset, ProgramLayout, SetupCount, SetupProgram, Stage, StageSeconds,
    mill,
};
pub use crate::policy::{
    Action, ActionSpace, FixedPolicy, HeuristicPolicy, Policy, RandomPolicy, SetupContext, SetupFeatures,
    StrategyKind,
};
pub use crate::render::{Image, PathTrace, render_machining};
