//! The [`ClearingStrategy`] trait and the [`Strategy`] choice (seed 000 §3.3.2-3.3.4).

use crate::periphery::{Periphery, Spiral};
use crate::region::{Point2, Polyline2, Region2};
use crate::zigzag::Zigzag;

/// Fills a free 2-D region with tool-centre paths.
///
/// One required method. `region` is where the tool centre may go (already offset from
/// the part), `tool_radius` the cutter radius, `stepover` the distance between
/// neighbouring passes (an absolute distance, at most the tool diameter), `start` where the
/// tool is now. Paths are returned in machining order; every point lies in `region`.
/// Together with the contour along the region's part-side boundary, the paths must leave
/// no point of the region farther than `tool_radius` from the tool centre's path.
pub trait ClearingStrategy {
    /// The clearing paths, in order.
    fn clear(&self, region: &Region2, tool_radius: f64, stepover: f64, start: Point2) -> Vec<Polyline2>;
}

/// The clearing strategies of the paper, as an option value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Strategy {
    /// Parallel back-and-forth passes (§3.3.2) at `angle_deg` from the X axis.
    Zigzag {
        /// Pass direction, degrees counter-clockwise from +X.
        angle_deg: f64,
    },
    /// Rings offset inward from the region boundary, outermost first (§3.3.3).
    Periphery,
    /// Rings from the inside out, linked into continuous paths (§3.3.4).
    Spiral,
}

impl Default for Strategy {
    /// Zigzag along X.
    fn default() -> Self {
        Strategy::Zigzag { angle_deg: 0.0 }
    }
}

impl Strategy {
    /// The strategy's short name (`zigzag`, `periphery`, `spiral`).
    pub fn name(&self) -> &'static str {
        match self {
            Strategy::Zigzag { .. } => "zigzag",
            Strategy::Periphery => "periphery",
            Strategy::Spiral => "spiral",
        }
    }

    /// Runs the strategy with the given arc step for offsets (radians per arc segment).
    pub fn clear_with(
        &self,
        region: &Region2,
        tool_radius: f64,
        stepover: f64,
        start: Point2,
        arc_step: f64,
        climb: bool,
    ) -> Vec<Polyline2> {
        match *self {
            Strategy::Zigzag { angle_deg } => {
                Zigzag { angle_deg }.clear(region, tool_radius, stepover, start)
            }
            Strategy::Periphery => Periphery { arc_step, climb }.clear(region, tool_radius, stepover, start),
            Strategy::Spiral => Spiral { arc_step, climb }.clear(region, tool_radius, stepover, start),
        }
    }
}

impl ClearingStrategy for Strategy {
    fn clear(&self, region: &Region2, tool_radius: f64, stepover: f64, start: Point2) -> Vec<Polyline2> {
        self.clear_with(region, tool_radius, stepover, start, crate::plan::DEFAULT_ARC_STEP, true)
    }
}
