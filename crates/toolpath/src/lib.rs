//! `s2g-toolpath`: layer toolpaths per setup (seed 000 §3.3), built exactly on 2-D regions.
//!
//! Planning happens in the setup frame, where the tool approaches from +Z
//! ([`s2g_geom::Setup`]). For each layer, from the stock top down to the lowest reachable
//! level:
//!
//! 1. the **keep-out** region is the XY projection of the part above the layer (the
//!    cross-section of its visibility closure), computed exactly and incrementally from
//!    the part's triangles with `i_overlay` booleans;
//! 2. it is grown by the tool radius (+ finishing allowance) with round joins; the tool
//!    centre stays out of it, so the tool body never cuts the part;
//! 3. the **contour** follows that grown region's boundary (always run, §3.3.1), climb or
//!    conventional;
//! 4. a [`ClearingStrategy`] fills the rest of the stock outline: [`Zigzag`] (§3.3.2),
//!    [`Periphery`] (§3.3.3) or [`Spiral`] (§3.3.4);
//! 5. passes are linked at feed when the link is short and inside the free region,
//!    otherwise through the clearance plane (Eq. 4) and back in by helix, ramp or plunge.
//!
//! With a [`RemainingMaterial`], areas without material are skipped (rest machining).
//! Motions stream into any [`s2g_gcode::MotionSink`] through [`plan_setup`].
//! Machining features (pockets, slots, holes on a block; seed 001) live in [`features`].
//!
//! ```
//! use s2g_gcode::MotionRecorder;
//! use s2g_geom::{Mesh, Point3, Setup};
//! use s2g_toolpath::{plan_setup, PlanOptions, Tool};
//!
//! // A 1 x 1 x 0.5 box.
//! let v = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
//! let c = [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.),
//!          v(0., 0., 0.5), v(1., 0., 0.5), v(1., 1., 0.5), v(0., 1., 0.5)];
//! let t = vec![[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
//!              [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]];
//! let part = Mesh::new(c.to_vec(), t).unwrap();
//! let opts = PlanOptions { layer_height: 0.125, stock_margin: 0.1, ..Default::default() };
//! let mut rec = MotionRecorder::default();
//! let summary = plan_setup(&part, &Setup::top(), &Tool::flat(0.05), &opts, &mut rec).unwrap();
//! assert_eq!(summary.layers, 5); // 0.6 (stock top) down to 0 in steps of at most 0.125
//! assert!(summary.cutting_length > 0.0);
//! ```

// `!(x > 0.0)` is deliberate throughout: it rejects NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod baseline;
mod error;
pub mod features;
mod link;
mod periphery;
mod plan;
mod region;
mod rest;
mod slice;
mod strategy;
mod tool;
mod zigzag;

pub use crate::error::ToolpathError;
pub use crate::periphery::{Periphery, Spiral};
pub use crate::plan::{
    DEFAULT_ARC_STEP, LayerPlan, PlanOptions, PlanProgress, PlanSummary, RampOptions, SetupSlices,
    plan_layers, plan_setup, plan_setup_rest, plan_setup_watched, slice_setup,
};
pub use crate::region::{Point2, Polyline2, Region2, RegionIndex, Vector2, point_segment_distance};
pub use crate::rest::{RemainingMaterial, VoxelMaterial};
pub use crate::slice::region_signed_distance;
pub use crate::strategy::{ClearingStrategy, Strategy};
pub use crate::tool::{Tool, ToolKind};
pub use crate::zigzag::Zigzag;
