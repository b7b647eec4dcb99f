//! Finishing with ball and bull-nose cutters over a mesh (issue 36): the scallop left
//! between passes and the stepover that keeps it under a target ([`scallop_height`],
//! [`stepover_for_scallop`]), and parallel (raster) finishing paths sampled with
//! `s2g_geom::DropCutter` and refined where the cutter-location surface bends
//! ([`parallel_finish`]); three finishing strategies behind one trait
//! ([`FinishingStrategy`]: [`Parallel`], [`Waterline`], [`SteepShallow`]) that return
//! cutter-location polylines (tool-tip points, setup frame, tool axis +Z); and
//! [`finish_setup`], which turns a strategy's polylines into motions (tool change, rapids
//! on a clearance plane, plunges, gouge-checked links) and sums their length and time.

mod emit;
mod guard;
mod order;
mod parallel;
mod scallop;
mod strategy;

pub use emit::{
    FinishOptions, FinishPaths, FinishSummary, KeepPoint, LeftOut, finish_paths, finish_setup,
    finish_setup_keep, finish_setup_left_out, finish_setup_opt, finish_setup_paths, part_in_setup_frame,
};
pub use guard::RoughedStock;
pub use parallel::{
    FillOptions, ParallelFinishOptions, centre_distances, parallel_finish, parallel_finish_opt,
};
pub use scallop::{scallop_height, stepover_for_scallop};
pub use strategy::{Crossed, FinishContext, FinishingStrategy, Parallel, SteepShallow, Waterline, cl_slope};

/// Everything finishing can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FinishError {
    /// An argument or option is out of its range (the message names it).
    #[error("invalid finishing option: {0}")]
    InvalidOptions(String),
    /// The cutter cannot exist.
    #[error("invalid cutter")]
    InvalidTool(#[source] s2g_geom::GeomError),
    /// A drop-cutter or waterline query refused its arguments.
    #[error("finishing geometry query failed")]
    Geometry(#[source] s2g_geom::GeomError),
    /// The planning was stopped ([`FinishContext::cancel`]).
    #[error("finishing planning was cancelled")]
    Cancelled,
}
