//! Periphery clearing (seed 000 §3.3.3): rings offset inward from the region boundary,
//! outermost first.

use crate::region::{Polyline2, Region2};
use crate::rings::{nearest_loop, orient, rings};
use crate::strategy::{ClearingContext, ClearingStrategy};

/// Rings offset inward from the region boundary, each starting at the vertex nearest the
/// current position; outer rings run counter-clockwise (climb) or clockwise (conventional),
/// as [`ClearingContext::climb`] says, with the context's arc step in the offsets.
/// Registered as `periphery`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Periphery;

impl ClearingStrategy for Periphery {
    fn name(&self) -> &str {
        "periphery"
    }

    fn clear(&self, region: &Region2, ctx: &ClearingContext) -> Vec<Polyline2> {
        let mut out = Vec::new();
        let mut cur = ctx.start;
        for (_, loops) in rings(region, ctx.tool_radius, ctx.stepover, ctx.arc_step) {
            let mut loops: Vec<Polyline2> = loops.into_iter().map(|l| orient(l, ctx.climb)).collect();
            while !loops.is_empty() {
                let i = nearest_loop(&loops, &cur);
                let mut lp = loops.swap_remove(i);
                lp.rotate_to_nearest(&cur);
                cur = lp.start().unwrap_or(cur);
                out.push(lp);
            }
        }
        out
    }
}
