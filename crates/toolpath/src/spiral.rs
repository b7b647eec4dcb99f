//! Spiral clearing (seed 000 §3.3.4): offset rings from the inside out, linked into
//! continuous paths.

use crate::region::{Point2, Polyline2, Region2};
use crate::rings::{nearest_loop, orient, rings};
use crate::strategy::{ClearingContext, ClearingStrategy};

/// Rings from the start point outward, each linked to the next when the link stays inside
/// the region, into continuous paths; rings run as [`ClearingContext::climb`] says, with the
/// context's arc step in the offsets. Registered as `spiral`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Spiral;

impl ClearingStrategy for Spiral {
    fn name(&self) -> &str {
        "spiral"
    }

    fn clear(&self, region: &Region2, ctx: &ClearingContext) -> Vec<Polyline2> {
        let ClearingContext { tool_radius, stepover, start, arc_step, climb } = *ctx;
        let mut out: Vec<Polyline2> = Vec::new();
        let index = region.index();
        let tol = 1e-7 * tool_radius;
        let mut cur = start;
        let mut all = rings(region, tool_radius, stepover, arc_step);
        all.reverse();
        let mut chain: Vec<Point2> = Vec::new();
        for (_, loops) in all {
            let mut loops: Vec<Polyline2> = loops.into_iter().map(|l| orient(l, climb)).collect();
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
#[cfg(test)]
mod tests {
    use super::*;
    use crate::periphery::Periphery;
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
                let ctx =
                    ClearingContext { tool_radius: r, stepover: s, start: Point2::origin(), arc_step: 0.1, climb: true };
                for strategy in [&Periphery as &dyn ClearingStrategy, &Spiral] {
                    let paths = strategy.clear(&region, &ctx);
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
