//! Offset-ring clearing: periphery (seed 000 §3.3.3, rings outermost first) and spiral
//! (§3.3.4, rings from the inside out linked into continuous paths).

use crate::region::{Point2, Polyline2, Region2};
use crate::strategy::ClearingStrategy;

/// Rings offset inward from the region boundary, each starting at the vertex nearest the
/// current position; outer rings run counter-clockwise (climb) or clockwise (conventional).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Periphery {
    /// Radians per arc segment in the offsets.
    pub arc_step: f64,
    /// Climb milling (region on the left of travel) rather than conventional.
    pub climb: bool,
}

/// Rings from the start point outward, each linked to the next when the link stays inside
/// the region, into continuous paths.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spiral {
    /// Radians per arc segment in the offsets.
    pub arc_step: f64,
    /// Climb milling (region on the left of travel) rather than conventional.
    pub climb: bool,
}

/// The offset depths and their rings, outermost first. Depths start at `min(s, r)` and step
/// by `s`; near the middle, extra rings are added until every point of the region is within
/// `r` of a ring (or of the boundary, which the contour pass follows).
pub(crate) fn rings(region: &Region2, r: f64, s: f64, arc_step: f64) -> Vec<(f64, Vec<Polyline2>)> {
    let mut out = Vec::new();
    if region.is_empty() || !(s > 0.0) || !(r > 0.0) {
        return out;
    }
    // Each ring is the previous one eroded by the step (erosion by discs composes:
    // eroding by a then by b is eroding by a + b). Offsetting by a small distance keeps
    // the offset engine fast (one large inward offset of a long, finely divided boundary
    // overlaps every segment strip with many others: about a second for 2,000 vertices);
    // each ring is then thinned (Douglas-Peucker) at a small fraction of the step: the
    // round joins of every vertex of the previous ring, and the rounded staircase of a
    // clearing region made of material-map cells, would otherwise come back ring after
    // ring as segments a tenth of the radius long, millions of lines a setup that
    // neither the finish nor the clearing needs; finally it is clipped to its parent so
    // that neither thinning nor a numerical artefact of the offset can put a ring outside
    // the region. The first ring is the region itself thinned, then eroded: offsetting
    // the staircase whole costs more than all the rings after it.
    let eps = 0.25 * arc_step.max(0.01) * s.min(r);
    let erode = |from: &Region2, d: f64, parent: &Region2| {
        from.offset(-d, arc_step).thinned(eps).intersection(parent)
    };
    let mut d = s.min(r);
    let mut inner = erode(&region.thinned(eps), d, region);
    // A bound on the number of rings: the region's half-width over the smallest step.
    let max_rings =
        region.bbox().map(|(lo, hi)| ((hi - lo).norm() / (0.9 * r.min(s))).ceil() as usize + 2).unwrap_or(0);
    while !inner.is_empty() && out.len() <= max_rings {
        out.push((d, inner.loops()));
        let next = erode(&inner, s, &inner);
        if !next.is_empty() {
            d += s;
            inner = next;
            continue;
        }
        // The deepest points are within s of this ring; if some are farther than r, add
        // a ring in between.
        if s > r && !inner.offset(-r, arc_step).is_empty() {
            d += 0.95 * r;
            inner = erode(&inner, 0.95 * r, &inner);
            continue;
        }
        break;
    }
    out
}

fn orient(mut lp: Polyline2, climb: bool) -> Polyline2 {
    // Loops come region-on-the-left; conventional milling runs them the other way.
    if !climb {
        lp.reverse();
    }
    lp
}

impl ClearingStrategy for Periphery {
    fn clear(&self, region: &Region2, tool_radius: f64, stepover: f64, start: Point2) -> Vec<Polyline2> {
        let mut out = Vec::new();
        let mut cur = start;
        for (_, loops) in rings(region, tool_radius, stepover, self.arc_step) {
            let mut loops: Vec<Polyline2> = loops.into_iter().map(|l| orient(l, self.climb)).collect();
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

impl ClearingStrategy for Spiral {
    fn clear(&self, region: &Region2, tool_radius: f64, stepover: f64, start: Point2) -> Vec<Polyline2> {
        let mut out: Vec<Polyline2> = Vec::new();
        let index = region.index();
        let tol = 1e-7 * tool_radius;
        let mut cur = start;
        let mut all = rings(region, tool_radius, stepover, self.arc_step);
        all.reverse();
        let mut chain: Vec<Point2> = Vec::new();
        for (_, loops) in all {
            let mut loops: Vec<Polyline2> = loops.into_iter().map(|l| orient(l, self.climb)).collect();
            while !loops.is_empty() {
                let i = nearest_loop(&loops, &cur);
                let mut lp = loops.swap_remove(i);
                lp.rotate_to_nearest(&cur);
                let Some(s) = lp.start() else { continue };
                let linked = !chain.is_empty()
                    && (s - cur).norm() <= 2.0 * stepover.max(tool_radius)
                    && index.segment_inside(&cur, &s, tol);
                if !linked && !chain.is_empty() {
                    out.push(Polyline2::open(std::mem::take(&mut chain)));
                }
                chain.extend(lp.points.iter().copied());
                chain.push(s);
                cur = s;
            }
        }
        if chain.len() >= 2 {
            out.push(Polyline2::open(chain));
        }
        out
    }
}

fn nearest_loop(loops: &[Polyline2], p: &Point2) -> usize {
    let mut best = (f64::INFINITY, 0);
    for (i, l) in loops.iter().enumerate() {
        for q in &l.points {
            let d = (q - p).norm_squared();
            if d < best.0 {
                best = (d, i);
            }
        }
    }
    best.1
}
