//! The drop-cutter contact of a cutter with one triangle: the highest tip height at which
//! a cutter above a point touches the triangle's vertices, interior or edges.
//!
//! The cutter's end is a solid of revolution whose surface lies at height `h(d)` above the
//! tip at distance `d` from the axis: `h(d) = 0` on the flat part (`d <= radius - corner`)
//! and `corner - sqrt(corner^2 - (d - radius + corner)^2)` on the rounded rim, with an
//! infinitely long cylinder above (the flute length is not a limit). The cutter dropped
//! at `q` touches a surface point `p` within its radius at tip height `p.z - h(|p - q|)`,
//! so a triangle's contact is the maximum of that over the triangle (within the radius).
//! `h` is convex and non-decreasing and `|p - q|` is convex in `p`, so that function is
//! concave on the triangle: its maximum is either a stationary point inside (the facet
//! test through the normal offset), a stationary point along an edge (the edge test) or
//! a corner of the domain (vertices, and the points where an edge leaves the cutter's
//! disc), which is what this module evaluates.

// NaN-aware negated comparisons (`!(x > 0.0)`) are deliberate: NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::bvh::{Tri, cross};

/// Most steps of the bull-nose edge test's root search (bisection alone would reach f64's
/// resolution in fewer).
const MAX_BISECTIONS: usize = 200;

/// Relative rounding slack under which an edge counts as tangent to the cutter's rim.
pub(crate) const TANGENT_SLACK: f64 = 1e-13;

/// A cutter's end as the contact tests need it (all lengths in the mesh's units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Profile {
    /// Cutting radius `R`.
    pub radius: f64,
    /// Corner radius `r` (`0`: flat, `R`: ball).
    pub corner: f64,
    /// Radius of the flat bottom, `R - r`.
    pub flat: f64,
    /// Position tolerance of the bull-nose edge test's bisection.
    pub edge_tolerance: f64,
}

impl Profile {
    /// The surface's height above the tip at distance `d <= radius` from the axis.
    #[inline]
    pub fn height(&self, d: f64) -> f64 {
        let e = d - self.flat;
        if e <= 0.0 {
            return 0.0;
        }
        self.corner - (self.corner * self.corner - e * e).max(0.0).sqrt()
    }
}

/// `best` raised to the highest tip height at which the cutter above `q` (local frame)
/// touches `tri`; `best` unchanged when the contact is not higher (or there is none).
#[inline]
pub(crate) fn triangle_drop(tri: &Tri, q: [f64; 2], p: &Profile, best: f64) -> f64 {
    let vs = tri.vertices();
    let top = vs[0][2].max(vs[1][2]).max(vs[2][2]);
    // The tip never sits above the highest point it touches.
    if !(top > best) {
        return best;
    }
    let (lo_x, hi_x) = (vs[0][0].min(vs[1][0]).min(vs[2][0]), vs[0][0].max(vs[1][0]).max(vs[2][0]));
    let (lo_y, hi_y) = (vs[0][1].min(vs[1][1]).min(vs[2][1]), vs[0][1].max(vs[1][1]).max(vs[2][1]));
    let gx = (lo_x - q[0]).max(q[0] - hi_x).max(0.0);
    let gy = (lo_y - q[1]).max(q[1] - hi_y).max(0.0);
    let r2 = p.radius * p.radius;
    if !(gx * gx + gy * gy <= r2) {
        return best;
    }
    let mut best = best;
    for v in &vs {
        // A vertex no higher than `best` cannot raise it (the profile is never negative).
        if !(v[2] > best) {
            continue;
        }
        let (dx, dy) = (v[0] - q[0], v[1] - q[1]);
        let d2 = dx * dx + dy * dy;
        if d2 <= r2 {
            best = best.max(v[2] - p.height(d2.sqrt()));
        }
    }
    best = facet(tri, q, p, best);
    for (a, b) in [(0, 1), (1, 2), (2, 0)] {
        best = edge(vs[a], vs[b], q, p, best);
    }
    best
}

/// The facet test: the cutter point whose outward normal is the facet's downward normal
/// touches the facet's plane; it counts when that point lies inside the triangle.
#[inline]
fn facet(tri: &Tri, q: [f64; 2], p: &Profile, best: f64) -> f64 {
    let mut n = cross(tri.e1, tri.e2);
    if n[2] < 0.0 {
        n = [-n[0], -n[1], -n[2]];
    }
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    // Vertical (or degenerate) facets have no interior contact: their edges do.
    if !(n[2] > 1e-12 * len) {
        return best;
    }
    let n = [n[0] / len, n[1] / len, n[2] / len];
    let nxy = (n[0] * n[0] + n[1] * n[1]).sqrt();
    // The contact point's horizontal offset from the axis: `flat` along the normal's
    // horizontal direction plus `corner` times the normal's horizontal part.
    let shift = if nxy > 0.0 { p.flat / nxy + p.corner } else { 0.0 };
    let c = [q[0] - shift * n[0], q[1] - shift * n[1]];
    let (e1, e2) = (tri.e1, tri.e2);
    let det = e1[0] * e2[1] - e1[1] * e2[0];
    let (wx, wy) = (c[0] - tri.v0[0], c[1] - tri.v0[1]);
    let s = (wx * e2[1] - wy * e2[0]) / det;
    let t = (e1[0] * wy - e1[1] * wx) / det;
    if !(s >= 0.0 && t >= 0.0 && s + t <= 1.0) {
        return best;
    }
    let z = tri.v0[2] + s * e1[2] + t * e2[2];
    best.max(z - p.corner + p.corner * n[2])
}

/// The edge test on `a`-`b`: the maximum of the (concave) contact height along the part
/// of the edge within the cutter's radius.
#[inline]
fn edge(a: [f64; 3], b: [f64; 3], q: [f64; 2], p: &Profile, best: f64) -> f64 {
    if !(a[2].max(b[2]) > best) {
        return best;
    }
    let u = [b[0] - a[0], b[1] - a[1]];
    let dz = b[2] - a[2];
    let l2 = u[0] * u[0] + u[1] * u[1];
    // A vertical edge's highest contact is its top vertex, which the vertex test has.
    if !(l2 > 0.0) {
        return best;
    }
    let w = [a[0] - q[0], a[1] - q[1]];
    let wu = w[0] * u[0] + w[1] * u[1];
    let ww = w[0] * w[0] + w[1] * w[1];
    let r2 = p.radius * p.radius;
    // `wu^2 - l2 (ww - r2)` by Lagrange's identity, without its cancellation.
    let cr = w[0] * u[1] - w[1] * u[0];
    let mut disc = l2 * r2 - cr * cr;
    // An edge tangent to the disc's rim touches it; rounding must not lose that point.
    if disc < 0.0 && disc > -TANGENT_SLACK * l2 * r2 {
        disc = 0.0;
    }
    if !(disc >= 0.0) {
        return best;
    }
    let sq = disc.sqrt();
    let t0 = ((-wu - sq) / l2).max(0.0);
    let t1 = ((-wu + sq) / l2).min(1.0);
    if !(t0 <= t1) {
        return best;
    }
    let z = |t: f64| a[2] + t * dz;
    if !(z(t0).max(z(t1)) > best) {
        return best;
    }
    let dist = |t: f64| ((w[0] + t * u[0]).powi(2) + (w[1] + t * u[1]).powi(2)).sqrt();
    let f = |t: f64| z(t) - p.height(dist(t).min(p.radius));
    // The ends of the part within the radius (where a flat end's contact always is).
    let mut best = best.max(f(t0)).max(f(t1));
    if p.corner <= 0.0 {
        return best;
    }
    if p.flat <= 0.0 {
        best = best.max(ball_edge(dz, l2, (wu, ww), p.corner, (t0, t1), z));
    } else {
        best = best.max(bull_edge(w, u, dz, (t0, t1), p, f));
    }
    best
}

/// The ball's edge contact in closed form: in the vertical plane of the edge the ball is a
/// circle of radius `s = sqrt(r^2 - d0^2)` (`d0` the axis' horizontal distance from the
/// edge's line), tangent to the edge from above at `s * m / sqrt(1 + m^2)` along it from the
/// foot of the perpendicular (`m` the edge's slope). `-inf` when that point is off the part
/// `range` of the edge.
#[inline]
fn ball_edge(
    dz: f64,
    l2: f64,
    (wu, ww): (f64, f64),
    r: f64,
    range: (f64, f64),
    z: impl Fn(f64) -> f64,
) -> f64 {
    let d02 = (ww - wu * wu / l2).max(0.0);
    let s2 = r * r - d02;
    if !(s2 > 0.0) {
        return f64::NEG_INFINITY;
    }
    let (s, l) = (s2.sqrt(), l2.sqrt());
    let m = dz / l;
    let k = 1.0 / (1.0 + m * m).sqrt();
    let tc = -wu / l2 + s * m * k / l;
    if !(tc >= range.0 && tc <= range.1) {
        return f64::NEG_INFINITY;
    }
    z(tc) + s * k - r
}

/// The bull nose's (torus') edge contact: the contact height `f` is concave along the
/// edge, so its derivative is non-increasing and the maximum is where the derivative
/// changes sign, bracketed (Illinois regula falsi, bisection where a slope is infinite)
/// until the bracket is `edge_tolerance` long along the edge (the height's error is second
/// order in that, as the derivative vanishes there). `-inf` when the
/// maximum is at an end of `range` (which the caller evaluated).
#[inline]
pub(crate) fn bull_edge(
    w: [f64; 2],
    u: [f64; 2],
    dz: f64,
    range: (f64, f64),
    p: &Profile,
    f: impl Fn(f64) -> f64,
) -> f64 {
    // f'(t) = dz - h'(d(t)) d'(t), with h'(d) = e / sqrt(r^2 - e^2), e = d - flat.
    let slope = |t: f64| {
        let x = [w[0] + t * u[0], w[1] + t * u[1]];
        let d = (x[0] * x[0] + x[1] * x[1]).sqrt();
        let e = d - p.flat;
        if e <= 0.0 {
            return dz;
        }
        let root = p.corner * p.corner - e * e;
        let dd = (x[0] * u[0] + x[1] * u[1]) / d;
        if !(root > 0.0) {
            // The rim's tangent is vertical: the slope is infinite, signed by d'.
            return if dd > 0.0 { f64::NEG_INFINITY } else { f64::INFINITY };
        }
        dz - e / root.sqrt() * dd
    };
    let (mut lo, mut hi) = range;
    let (mut glo, mut ghi) = (slope(lo), slope(hi));
    if !(glo > 0.0) || !(ghi < 0.0) {
        return f64::NEG_INFINITY;
    }
    let len = (u[0] * u[0] + u[1] * u[1] + dz * dz).sqrt();
    // Regula falsi with the Illinois modification (superlinear) while both ends' slopes are
    // finite, bisection otherwise; the bracket always holds the sign change.
    let mut last_side = 0i8;
    for _ in 0..MAX_BISECTIONS {
        if (hi - lo) * len <= p.edge_tolerance {
            break;
        }
        let mut mid = 0.5 * (lo + hi);
        if glo.is_finite() && ghi.is_finite() {
            let m = lo + (hi - lo) * glo / (glo - ghi);
            if m > lo && m < hi {
                mid = m;
            }
        }
        let g = slope(mid);
        if g > 0.0 {
            (lo, glo) = (mid, g);
            if last_side == 1 {
                ghi *= 0.5;
            }
            last_side = 1;
        } else if g < 0.0 {
            (hi, ghi) = (mid, g);
            if last_side == -1 {
                glo *= 0.5;
            }
            last_side = -1;
        } else {
            return f(mid);
        }
    }
    f(0.5 * (lo + hi))
}
