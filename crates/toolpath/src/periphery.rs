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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::region::point_segment_distance;

    /// Distance from `p` to the nearest path.
    fn distance(paths: &[Polyline2], p: &Point2) -> f64 {
        paths
            .iter()
            .flat_map(|l| l.segments())
            .map(|(a, b)| point_segment_distance(p, &a, &b))
            .fold(f64::INFINITY, f64::min)
    }

    /// Every point of the region lies within the tool radius of a ring or of the region's
    /// boundary (which the contour pass follows), for stepovers below, at and above the
    /// radius. The strips are `2 d0 + 4 s + w` wide, with rings at depths `d0 = min(s, r)`
    /// and `d0 + s`, so their last erosion leaves a sliver of width `w` whose centre line
    /// is `s + w / 2` from the second ring. Thinning drops a sliver thinner than its
    /// tolerance, and at `s = r` (the default stepover, half the diameter) that centre line
    /// was left uncut (points 1.0075 r from every ring at `w = 0.02 r`).
    #[test]
    fn rings_cover_the_region_when_thinning_drops_a_sliver() {
        let r = 1.0;
        for s in [0.6f64, 1.0, 1.4] {
            for w in [0.005, 0.02, 0.04, 0.3] {
                let width = 2.0 * s.min(r) + 4.0 * s + w;
                let region = Region2::rect(Point2::new(0.0, 0.0), Point2::new(10.0, width));
                for strategy in [
                    &Periphery { arc_step: 0.1, climb: true } as &dyn ClearingStrategy,
                    &Spiral { arc_step: 0.1, climb: true },
                ] {
                    let paths = strategy.clear(&region, r, s, Point2::origin());
                    for i in 0..=40 {
                        for j in 0..=40 {
                            // Row 20 is the centre line.
                            let p = Point2::new(10.0 * i as f64 / 40.0, width * j as f64 / 40.0);
                            let edge = p.x.min(10.0 - p.x).min(p.y).min(width - p.y);
                            let d = distance(&paths, &p);
                            assert!(
                                d.min(edge) <= r * (1.0 + 1e-9),
                                "s {s} w {w}: {p:?} is {d} from every ring"
                            );
                        }
                    }
                }
            }
        }
    }
}
