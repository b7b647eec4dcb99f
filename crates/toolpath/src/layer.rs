//! [`LayerPlan`]: one layer's regions and paths, between planning and emission.

use std::sync::Arc;

use crate::region::{Polyline2, Region2, RegionIndex};

/// One layer's plan: its regions and paths (tool-centre XY at level `z`).
#[derive(Debug, Clone)]
pub struct LayerPlan {
    /// Layer index from the top.
    pub index: usize,
    /// Level of the tool tip.
    pub z: f64,
    /// The level above (previous layer, or the stock top; for a roughing level, the
    /// previous roughing level): material above it is gone.
    pub z_above: f64,
    /// Where the tool centre may go: stock outline grown by the radius, minus the keep-out
    /// grown by radius + allowance.
    pub free: Region2,
    /// The region the clearing strategy fills (`free`, restricted to remaining material and,
    /// on a level above a roughing level, to what the roughing cut could not reach).
    pub clearing_region: Region2,
    /// Contour passes along the offset keep-out (closed loops, or pieces where clipped).
    pub contour: Vec<Polyline2>,
    /// Clearing passes, in order.
    pub clearing: Vec<Polyline2>,
    /// Cut and air length of contour + clearing (air only with rest information).
    pub cut_air: (f64, f64),
    /// On a finer level above a roughing level, with [`PlanOptions::lead_in`]: the roughing
    /// level's free region, whose cut already removed the material its tool centres reach
    /// up to this level (where the paths may enter from the side).
    ///
    /// [`PlanOptions::lead_in`]: crate::PlanOptions::lead_in
    pub roughed: Option<Region2>,
    /// The level's keep-out (the part's projection), indexed, where arcs are fitted: a
    /// fitted piece that leaves its path by more than the arc tolerance must keep the
    /// tool's distance from it ([`PlanOptions::arc_tolerance`](crate::PlanOptions::arc_tolerance)).
    pub(crate) keepout: Option<Arc<RegionIndex>>,
}

impl LayerPlan {
    /// A layer with nothing to cut.
    pub(crate) fn empty(index: usize, z: f64, z_above: f64, free: &Region2) -> Self {
        LayerPlan {
            index,
            z,
            z_above,
            free: free.clone(),
            clearing_region: Region2::empty(),
            contour: Vec::new(),
            clearing: Vec::new(),
            cut_air: (0.0, 0.0),
            roughed: None,
            keepout: None,
        }
    }
}
