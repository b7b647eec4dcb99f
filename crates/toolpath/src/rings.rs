//! Offset rings of a region, shared by the ring-based clearing strategies: periphery
//! (seed 000 §3.3.3, rings outermost first) and spiral (§3.3.4, rings from the inside out
//! linked into continuous paths).

use crate::region::{Point2, Polyline2, Region2};

/// The offset depths and their rings, outermost first. Depths start at `min(s, r)` and step
/// by `s`, or by a little less than `r` where a step of `s` would leave points farther than
/// `r` from every ring: every point of the region is within `r` of a ring (or of the
/// boundary, which the contour pass follows).
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
    let eps = 0.25 * arc_step.clamp(0.01 * std::f64::consts::PI, 0.25 * std::f64::consts::PI) * s.min(r);
    // Each erosion also says whether thinning made a part of the offset vanish (a sliver
    // narrower than 2 eps, all of it within eps of its boundary).
    let erode = |from: &Region2, d: f64, parent: &Region2| {
        let (thin, vanished) = from.offset(-d, arc_step).thinned_with_vanished(eps);
        (thin.intersection(parent), vanished)
    };
    // The ring `depth` inside `base` (the previous ring's region, or for the first the
    // region thinned), clipped to `parent`, and its depth below `base`. What the rings
    // from there on leave to the ring at `base` lies within `depth + eps` of it: a
    // vanished sliver, or where the offset is empty the deepest points (within `depth`).
    // Where that can exceed the radius, the ring comes at depth `step` instead, whose
    // leftovers lie within `step + eps < r`.
    let step = r - 2.0 * eps;
    let deeper = |base: &Region2, parent: &Region2, depth: f64| {
        let (next, vanished) = erode(base, depth, parent);
        let left_deep = || depth > r && next.is_empty() && !base.offset(-step, arc_step).is_empty();
        if depth > step && (vanished || left_deep()) {
            (erode(base, step, parent).0, step)
        } else {
            (next, depth)
        }
    };
    let (mut inner, mut d) = deeper(&region.thinned(eps), region, s.min(r));
    // A bound on the number of rings: the region's half-width over the smallest step.
    let max_rings = region
        .bbox()
        .map(|(lo, hi)| ((hi - lo).norm() / (0.9 * step.min(s))).ceil() as usize + 2)
        .unwrap_or(0);
    while !inner.is_empty() && out.len() <= max_rings {
        out.push((d, inner.loops()));
        let (next, advance) = deeper(&inner, &inner, s);
        if next.is_empty() {
            break;
        }
        d += advance;
        inner = next;
    }
    out
}

/// `lp` (region on the left) in the milling direction.
pub(crate) fn orient(mut lp: Polyline2, climb: bool) -> Polyline2 {
    // Loops come region-on-the-left; conventional milling runs them the other way.
    if !climb {
        lp.reverse();
    }
    lp
}

/// The index of the loop with the vertex nearest to `p`.
pub(crate) fn nearest_loop(loops: &[Polyline2], p: &Point2) -> usize {
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
