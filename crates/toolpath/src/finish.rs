//! Finishing with ball and bull-nose cutters over a mesh (issue 36): the scallop left
//! between passes and the stepover that keeps it under a target ([`scallop_height`],
//! [`stepover_for_scallop`]), and parallel (raster) finishing paths sampled with
//! `s2g_geom::DropCutter` and refined where the cutter-location surface bends
//! ([`parallel_finish`]). These are library pieces for the milling pipeline: they return
//! cutter-location polylines (tool-tip points, setup frame, tool axis +Z) and write no
//! motions.

mod parallel;
mod scallop;

pub use parallel::{ParallelFinishOptions, parallel_finish, parallel_finish_opt};
pub use scallop::{scallop_height, stepover_for_scallop};

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
}
