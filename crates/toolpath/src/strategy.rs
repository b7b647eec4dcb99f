//! The [`ClearingStrategy`] trait (seed 000 §3.3.2-3.3.4) and the [`ClearingContext`] the
//! planner hands it.

use std::fmt::Debug;

use crate::region::{Point2, Polyline2, Region2};

/// What the planner knows that a clearing strategy may need, per layer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClearingContext {
    /// The cutter radius ([`Envelope::radius`](crate::Envelope::radius) of the tool).
    pub tool_radius: f64,
    /// Distance between neighbouring passes: an absolute distance, at most the tool
    /// diameter ([`PlanOptions::stepover`](crate::PlanOptions::stepover) times the diameter).
    pub stepover: f64,
    /// Where the tool is now (after the layer's contour).
    pub start: Point2,
    /// Radians per arc segment in offsets ([`PlanOptions::arc_step`](crate::PlanOptions::arc_step)).
    pub arc_step: f64,
    /// Climb milling (region on the left of travel) rather than conventional
    /// ([`PlanOptions::climb`](crate::PlanOptions::climb)).
    pub climb: bool,
}

/// Fills a free 2-D region with tool-centre paths.
///
/// Two required methods: [`name`](Self::name) and [`clear`](Self::clear);
/// [`validate`](Self::validate) is provided. `region` is where the tool centre may go
/// (already offset from the part); `ctx` carries the tool radius, the step-over, the start
/// point, the arc step and the milling direction. Paths are returned in machining order;
/// every point lies in `region`. Together with the contour along the region's part-side
/// boundary, the paths must leave no point of the region farther than `ctx.tool_radius`
/// from the tool centre's path.
///
/// Strategies are shared between threads (layers are planned in parallel) and held in
/// [`PlanOptions::strategy`](crate::PlanOptions::strategy) as
/// `Arc<dyn ClearingStrategy>`, hence the `Send + Sync + Debug` bounds. The
/// [`StrategyRegistry`](crate::StrategyRegistry) maps names to strategies.
pub trait ClearingStrategy: Debug + Send + Sync {
    /// The strategy's short, lower-case name (`zigzag`, `periphery`, `spiral`): its key in a
    /// [`StrategyRegistry`](crate::StrategyRegistry), also written into the program's
    /// header comment.
    fn name(&self) -> &str;

    /// The clearing paths of `region`, in order.
    fn clear(&self, region: &Region2, ctx: &ClearingContext) -> Vec<Polyline2>;

    /// Checks the strategy's own parameters before planning; the message names the
    /// offending one. Default: nothing to check.
    fn validate(&self) -> Result<(), String> {
        Ok(())
    }
}
