//! Zigzag clearing (seed 000 §3.3.2): parallel passes clipped to the region, alternating
//! direction, linked by short straight moves when they stay inside the region.

use crate::region::{Point2, Polyline2, Region2};
use crate::strategy::{ClearingContext, ClearingStrategy};

/// Parallel passes at `angle_deg` from +X, evenly spaced at most one step-over apart,
/// the first and last half a spacing inside the region's extent. Registered as `zigzag`
/// (along X); the milling direction and arc step of the context do not apply.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Zigzag {
    /// Pass direction, degrees counter-clockwise from +X.
    pub angle_deg: f64,
}

impl ClearingStrategy for Zigzag {
    fn name(&self) -> &str {
        "zigzag"
    }

    fn validate(&self) -> Result<(), String> {
        if self.angle_deg.is_finite() { Ok(()) } else { Err("zigzag angle must be finite".into()) }
    }

    fn clear(&self, region: &Region2, ctx: &ClearingContext) -> Vec<Polyline2> {
        let ClearingContext { tool_radius, stepover, start, .. } = *ctx;
        if region.is_empty() || !(stepover > 0.0) || !stepover.is_finite() {
            return Vec::new();
        }
        let ang = if self.angle_deg.is_finite() { self.angle_deg.to_radians() } else { 0.0 };
        let (s, c) = ang.sin_cos();
        // Into the pass frame (passes along +x') and back.
        let to_local = |p: &Point2| Point2::new(c * p.x + s * p.y, -s * p.x + c * p.y);
        let to_world = |p: &Point2| Point2::new(c * p.x - s * p.y, s * p.x + c * p.y);
        let mut edges: Vec<(Point2, Point2)> = Vec::new();
        for lp in region.loops() {
            let pts: Vec<Point2> = lp.points.iter().map(to_local).collect();
            for i in 0..pts.len() {
                edges.push((pts[i], pts[(i + 1) % pts.len()]));
            }
        }
        let ymin = edges.iter().map(|e| e.0.y).fold(f64::INFINITY, f64::min);
        let ymax = edges.iter().map(|e| e.0.y).fold(f64::NEG_INFINITY, f64::max);
        if !(ymax > ymin) {
            return Vec::new();
        }
        let n = ((ymax - ymin) / stepover).ceil().max(1.0) as usize;
        let sp = (ymax - ymin) / n as f64;
        let line_y = |k: usize| line_y(ymin, sp, k);
        let crossings = crossings(&edges, ymin, sp, n);
        let min_len = 1e-9 * (ymax - ymin).max(tool_radius);
        let mut intervals: Vec<Vec<(f64, f64, bool)>> = crossings
            .into_iter()
            .map(|mut xs| {
                xs.sort_by(f64::total_cmp);
                xs.chunks_exact(2).filter(|w| w[1] - w[0] > min_len).map(|w| (w[0], w[1], false)).collect()
            })
            .collect();
        let index = region.index();
        let tol = 1e-7 * tool_radius.max(sp);
        let mut remaining: usize = intervals.iter().map(Vec::len).sum();
        let mut out = Vec::new();
        let mut cur = to_local(&start);
        let mut dir: isize = 1;
        while remaining > 0 {
            // Start a chain at the unvisited pass end nearest to where we are.
            let mut best = (f64::INFINITY, 0, 0, false);
            for (k, row) in intervals.iter().enumerate() {
                for (i, iv) in row.iter().enumerate() {
                    if iv.2 {
                        continue;
                    }
                    let y = line_y(k);
                    for (x, from_right) in [(iv.0, false), (iv.1, true)] {
                        let d = (Point2::new(x, y) - cur).norm_squared();
                        if d < best.0 {
                            best = (d, k, i, from_right);
                        }
                    }
                }
            }
            let (_, mut k, mut i, mut from_right) = best;
            let mut chain: Vec<Point2> = Vec::new();
            loop {
                let iv = &mut intervals[k][i];
                iv.2 = true;
                remaining -= 1;
                let y = line_y(k);
                let (a, b) = if from_right { (iv.1, iv.0) } else { (iv.0, iv.1) };
                chain.push(Point2::new(a, y));
                chain.push(Point2::new(b, y));
                cur = Point2::new(b, y);
                let (lo, hi) = (iv.0, iv.1);
                // The next pass: an unvisited, overlapping interval on a neighbouring line.
                let mut next = None;
                for d in [dir, -dir] {
                    let kk = k as isize + d;
                    if kk < 0 || kk as usize >= n {
                        continue;
                    }
                    let kk = kk as usize;
                    let yy = line_y(kk);
                    let mut cand = (f64::INFINITY, 0, false);
                    for (j, jv) in intervals[kk].iter().enumerate() {
                        if jv.2 || jv.1 < lo || jv.0 > hi {
                            continue;
                        }
                        for (x, fr) in [(jv.0, false), (jv.1, true)] {
                            let dd = (Point2::new(x, yy) - cur).norm_squared();
                            if dd < cand.0 {
                                cand = (dd, j, fr);
                            }
                        }
                    }
                    if cand.0.is_finite() {
                        next = Some((d, kk, cand.1, cand.2));
                        break;
                    }
                }
                let Some((d, kk, j, fr)) = next else { break };
                let jv = intervals[kk][j];
                let target = Point2::new(if fr { jv.1 } else { jv.0 }, line_y(kk));
                if !index.segment_inside(&to_world(&cur), &to_world(&target), tol) {
                    break;
                }
                dir = d;
                k = kk;
                i = j;
                from_right = fr;
            }
            let pts: Vec<Point2> = chain.iter().map(to_world).collect();
            out.push(Polyline2::open(dedup(pts)));
        }
        out
    }
}

/// Line `k` of the passes: `ymin + (k + 1/2) sp`.
fn line_y(ymin: f64, sp: f64, k: usize) -> f64 {
    ymin + (k as f64 + 0.5) * sp
}

/// Where the `n` pass lines cross the edges, per line. An edge crosses the lines with
/// `lo <= y < hi`, so a line through a vertex, or along a horizontal edge, meets the loop
/// an even number of times. Each line is compared with its own `y` for every edge: the
/// first line of an edge is estimated from its `lo`, one line early, because rounding can
/// put the estimate past a line lying exactly at `lo` (the material map's staircases put
/// horizontal edges on the lines), which dropped one crossing of that line and paired the
/// rest wrongly: a pass across the keep-out.
fn crossings(edges: &[(Point2, Point2)], ymin: f64, sp: f64, n: usize) -> Vec<Vec<f64>> {
    let mut out: Vec<Vec<f64>> = vec![Vec::new(); n];
    for (a, b) in edges {
        let (lo, hi) = if a.y < b.y { (a.y, b.y) } else { (b.y, a.y) };
        if lo == hi {
            continue;
        }
        let mut k = ((((lo - ymin) / sp) - 0.5).ceil() - 1.0).max(0.0) as usize;
        while k < n && line_y(ymin, sp, k) < hi {
            let y = line_y(ymin, sp, k);
            if y >= lo {
                out[k].push(a.x + (y - a.y) / (b.y - a.y) * (b.x - a.x));
            }
            k += 1;
        }
    }
    out
}

fn dedup(mut pts: Vec<Point2>) -> Vec<Point2> {
    pts.dedup_by(|a, b| (*a - *b).norm() == 0.0);
    pts
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step whose horizontal edge lies exactly on a pass line: the line crosses the left
    /// side and the riser above the step, once each. The estimate of the riser's first line
    /// from its `lo` rounds one line too far for these values (`ymin = -50`, spacing 0.3,
    /// line 1 at -49.55), and the line kept only the left crossing.
    #[test]
    fn a_pass_line_along_a_horizontal_edge_crosses_the_loop_twice() {
        let (ymin, sp, n) = (-50.0, 0.3, 7);
        let y1 = line_y(ymin, sp, 1);
        assert!((((y1 - ymin) / sp) - 0.5).ceil() > 1.0, "the values no longer round up");
        let p = |x: f64, y: f64| Point2::new(x, y);
        let step = [p(0.0, ymin), p(10.0, ymin), p(10.0, y1), p(5.0, y1), p(5.0, -48.0), p(0.0, -48.0)];
        let edges: Vec<(Point2, Point2)> =
            (0..step.len()).map(|i| (step[i], step[(i + 1) % step.len()])).collect();
        let mut lines = crossings(&edges, ymin, sp, n);
        for xs in &mut lines {
            xs.sort_by(f64::total_cmp);
        }
        assert_eq!(lines[0], vec![0.0, 10.0]);
        assert_eq!(lines[1], vec![0.0, 5.0]);
        assert!(lines.iter().all(|xs| xs.len() % 2 == 0), "{lines:?}");
    }
}
