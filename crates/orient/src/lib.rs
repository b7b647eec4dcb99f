//! `s2g-orient`: tool-orientation selection by ray-cast visibility and
//! visibility-based (height-closure) reconstruction, after seed 000 (Shape2Gcode) §3.1-3.2.
//!
//! - [`select_orientations`] samples the part's surface, builds the visibility matrix of
//!   samples against candidate directions ([`candidate_directions`]: a Fibonacci sphere
//!   plus the six axes) as bitsets, and covers the samples with few directions: the
//!   paper's greedy (Eq. 3, [`Strategy::PlainGreedy`]) or, by default, a multi-start swap
//!   search with continuous refinement ([`Strategy::LocalSearch`]). It also reports the
//!   Table 2 baselines (six axes, random 5 and 6 directions).
//! - [`height_closure`] fills, for a setup, everything occluded from its tool axis (the
//!   manufacturable shape from that side); [`closure_mesh`] makes it a smooth mesh and
//!   [`HeightMap::section`] / [`closure_section`] give its cross-sections.
//!
//! Directions are tool axes, from the part towards the spindle; see [`visibility`]
//! for the convention against the paper's wording.

mod closure;
mod cover;
mod directions;
mod error;
mod reach;
mod select;
mod stock;
mod tool_reach;
pub mod visibility;

pub use crate::closure::{
    HeightMap, ReconstructOptions, Reconstruction, Section, closure_mesh, closure_section, height_closure,
    reconstruct,
};
pub use crate::cover::{SearchOptions, best_subset, greedy, greedy_order, multi_start_search, swap_search};
pub use crate::directions::{
    candidate_directions, cone_directions, fibonacci_sphere, orthonormal_basis, principal_axes,
    random_direction,
};
pub use crate::error::{OrientError, Result};
pub use crate::reach::{Unreached, unreached};
pub use crate::select::{
    Baselines, OrientOptions, OrientationResult, RefineOptions, StageTimes, Strategy, select_orientations,
    select_orientations_in_stock,
};
pub use crate::stock::{StockRemovalOptions, StockRemovalReport, stock_grid_points};
pub use crate::tool_reach::{REACH_TOOLS, ReachTool, ToolReach, ball_clearance, sample_gaps};
pub use crate::visibility::{VisibilityContext, VisibilityMatrix, VisibilityOptions};
