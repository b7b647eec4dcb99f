//! Exact clearance of a fitted piece (a line or an arc, [`s2g_gcode::PlanarPiece`]) from a
//! region's boundary: whether every point of it lies at least a distance from every edge.

use std::f64::consts::{FRAC_PI_2, TAU};

use s2g_gcode::{ArcDirection, PlanarPiece};

use crate::region::{Point2, RegionIndex, point_segment_distance};

/// Whether every point of `piece`, from `from`, lies at least `d` from every boundary edge
/// of `index` (exactly: the least distance between the piece and each edge near it).
pub(crate) fn piece_clear(index: &RegionIndex, from: [f64; 2], piece: &PlanarPiece, d: f64) -> bool {
    let (a, b) = (Point2::new(from[0], from[1]), Point2::new(piece.to[0], piece.to[1]));
    let arc = piece.arc.map(|(c, dir)| Arc::new(a, b, Point2::new(c[0], c[1]), dir));
    let (lo, hi) = match &arc {
        Some(arc) => arc.bbox(),
        None => (a.inf(&b), a.sup(&b)),
    };
    let pad = nalgebra::Vector2::new(d, d);
    index.edge_ids_in(lo - pad, hi + pad).all(|e| {
        let [ax, ay, bx, by] = index.edge(e);
        let (p, q) = (Point2::new(ax, ay), Point2::new(bx, by));
        let dist = match &arc {
            Some(arc) => arc.segment_distance(&p, &q),
            None => segment_distance(&a, &b, &p, &q),
        };
        dist >= d
    })
}

/// Least distance between segments `a`-`b` and `p`-`q`.
fn segment_distance(a: &Point2, b: &Point2, p: &Point2, q: &Point2) -> f64 {
    let orient = |u: &Point2, v: &Point2, w: &Point2| (v.x - u.x) * (w.y - u.y) - (v.y - u.y) * (w.x - u.x);
    let (d1, d2) = (orient(a, b, p), orient(a, b, q));
    let (d3, d4) = (orient(p, q, a), orient(p, q, b));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return 0.0;
    }
    point_segment_distance(p, a, b)
        .min(point_segment_distance(q, a, b))
        .min(point_segment_distance(a, p, q))
        .min(point_segment_distance(b, p, q))
}

/// A circular arc: centre, radius, start angle and signed sweep (positive
/// counter-clockwise), below half a turn.
struct Arc {
    a: Point2,
    b: Point2,
    c: Point2,
    r: f64,
    a0: f64,
    sweep: f64,
}

impl Arc {
    fn new(a: Point2, b: Point2, c: Point2, dir: ArcDirection) -> Self {
        let a0 = (a.y - c.y).atan2(a.x - c.x);
        let a1 = (b.y - c.y).atan2(b.x - c.x);
        let sweep = match dir {
            ArcDirection::CounterClockwise => (a1 - a0).rem_euclid(TAU),
            ArcDirection::Clockwise => -(a0 - a1).rem_euclid(TAU),
        };
        Self { a, b, c, r: (a - c).norm(), a0, sweep }
    }

    /// Whether the direction `ang` from the centre lies within the sweep.
    fn spans(&self, ang: f64) -> bool {
        let t =
            if self.sweep >= 0.0 { (ang - self.a0).rem_euclid(TAU) } else { (self.a0 - ang).rem_euclid(TAU) };
        t <= self.sweep.abs()
    }

    fn spans_point(&self, p: &Point2) -> bool {
        self.spans((p.y - self.c.y).atan2(p.x - self.c.x))
    }

    /// Its bounding box: the ends and the circle's extremes along X and Y within the sweep.
    fn bbox(&self) -> (Point2, Point2) {
        let (mut lo, mut hi) = (self.a.inf(&self.b), self.a.sup(&self.b));
        for k in 0..4 {
            let ang = k as f64 * FRAC_PI_2;
            if self.spans(ang) {
                let p = Point2::new(self.c.x + self.r * ang.cos(), self.c.y + self.r * ang.sin());
                (lo, hi) = (lo.inf(&p), hi.sup(&p));
            }
        }
        (lo, hi)
    }

    /// Least distance from `p` to the arc.
    fn point_distance(&self, p: &Point2) -> f64 {
        if self.spans_point(p) {
            ((p - self.c).norm() - self.r).abs()
        } else {
            (p - self.a).norm().min((p - self.b).norm())
        }
    }

    /// Least distance between the arc and the segment `p`-`q`: 0 where they meet, else
    /// the least of the ends' distances to the other curve and, where the segment's point
    /// nearest the centre lies within the sweep, its distance to the circle.
    fn segment_distance(&self, p: &Point2, q: &Point2) -> f64 {
        let u = q - p;
        let w = p - self.c;
        let (aa, bb, cc) = (u.norm_squared(), 2.0 * u.dot(&w), w.norm_squared() - self.r * self.r);
        if aa > 0.0 {
            let disc = bb * bb - 4.0 * aa * cc;
            if disc >= 0.0 {
                let sq = disc.sqrt();
                for t in [(-bb - sq) / (2.0 * aa), (-bb + sq) / (2.0 * aa)] {
                    if (0.0..=1.0).contains(&t) && self.spans_point(&(p + u * t)) {
                        return 0.0;
                    }
                }
            }
        }
        let mut best = self
            .point_distance(p)
            .min(self.point_distance(q))
            .min(point_segment_distance(&self.a, p, q))
            .min(point_segment_distance(&self.b, p, q));
        if aa > 0.0 {
            let t = -(u.dot(&w)) / aa;
            let f = p + u * t;
            if (0.0..=1.0).contains(&t) && self.spans_point(&f) {
                best = best.min(((f - self.c).norm() - self.r).abs());
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact distances agree with dense sampling of both curves.
    #[test]
    fn arc_segment_distance_matches_sampling() {
        let mut rng = s2g_geom::SplitMix64(0x9e37_79b9_7f4a_7c15);
        let mut unit = move || rng.unit();
        for _ in 0..300 {
            let c = Point2::new(unit() * 4.0 - 2.0, unit() * 4.0 - 2.0);
            let r = 0.5 + 2.0 * unit();
            let a0 = unit() * TAU;
            let sweep = (unit() - 0.5) * 6.0;
            let a = Point2::new(c.x + r * a0.cos(), c.y + r * a0.sin());
            let b = Point2::new(c.x + r * (a0 + sweep).cos(), c.y + r * (a0 + sweep).sin());
            let dir = if sweep > 0.0 { ArcDirection::CounterClockwise } else { ArcDirection::Clockwise };
            let arc = Arc::new(a, b, c, dir);
            let p = Point2::new(unit() * 8.0 - 4.0, unit() * 8.0 - 4.0);
            let q = Point2::new(unit() * 8.0 - 4.0, unit() * 8.0 - 4.0);
            let exact = arc.segment_distance(&p, &q);
            let n = 2000;
            let mut sampled = f64::INFINITY;
            for i in 0..=n {
                let t = a0 + sweep * i as f64 / n as f64;
                let x = Point2::new(c.x + r * t.cos(), c.y + r * t.sin());
                sampled = sampled.min(point_segment_distance(&x, &p, &q));
            }
            assert!(exact <= sampled + 1e-9, "exact {exact} above sampled {sampled}");
            assert!(sampled - exact < 1e-2 * r, "exact {exact} far below sampled {sampled}");
        }
    }
}
