//! The drop-cutter's triangles with what its contact tests compute per triangle done once:
//! each triangle's vertices, its horizontal box and top (the tests that pass most
//! triangles over, in an array of their own so that those tests read 40 bytes a
//! triangle), its facet normal and the determinant of its XY projection, and per edge the
//! horizontal direction, rise, length and slope terms of the ball's edge contact.
//!
//! [`triangle_drop`] on these gives [`contact::triangle_drop`](super::contact::triangle_drop)'s
//! answer bit for bit: every value stored is computed by the same expressions, in the same
//! order, as the per-call test computes it, and the tests run in the same order on them.

// NaN-aware negated comparisons (`!(x > 0.0)`) are deliberate: NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::bvh::{Tri, cross};
use super::contact::{Profile, TANGENT_SLACK, bull_edge};

/// A triangle's horizontal box and highest point: `[lo_x, hi_x, lo_y, hi_y, top]`.
type Cull = [f64; 5];

/// One edge `a`-`b` as the edge test needs it.
#[derive(Debug, Clone, Copy)]
struct Edge {
    /// `b - a` in XY.
    u: [f64; 2],
    /// `b.z - a.z`.
    dz: f64,
    /// `|u|^2`.
    l2: f64,
    /// `|u|`.
    l: f64,
    /// The slope `dz / l`.
    m: f64,
    /// `1 / sqrt(1 + m^2)`.
    k: f64,
}

impl Edge {
    fn new(a: [f64; 3], b: [f64; 3]) -> Self {
        let u = [b[0] - a[0], b[1] - a[1]];
        let dz = b[2] - a[2];
        let l2 = u[0] * u[0] + u[1] * u[1];
        let l = l2.sqrt();
        let m = dz / l;
        let k = 1.0 / (1.0 + m * m).sqrt();
        Self { u, dz, l2, l, m, k }
    }
}

/// Everything but the box of one triangle.
#[derive(Debug, Clone, Copy)]
struct Full {
    vs: [[f64; 3]; 3],
    e1: [f64; 3],
    e2: [f64; 3],
    /// The unit normal facing up, where the facet test applies (not vertical or
    /// degenerate), and its horizontal length.
    normal: Option<([f64; 3], f64)>,
    /// The determinant of `e1`, `e2` in XY.
    det: f64,
    edges: [Edge; 3],
}

/// The drop-cutter's triangles, in the BVH's leaf order.
#[derive(Debug, Clone)]
pub(crate) struct DropTris {
    cull: Vec<Cull>,
    full: Vec<Full>,
}

impl DropTris {
    pub fn new(tris: &[Tri]) -> Self {
        let cull = tris
            .iter()
            .map(|t| {
                let vs = t.vertices();
                let (lo_x, hi_x) =
                    (vs[0][0].min(vs[1][0]).min(vs[2][0]), vs[0][0].max(vs[1][0]).max(vs[2][0]));
                let (lo_y, hi_y) =
                    (vs[0][1].min(vs[1][1]).min(vs[2][1]), vs[0][1].max(vs[1][1]).max(vs[2][1]));
                [lo_x, hi_x, lo_y, hi_y, vs[0][2].max(vs[1][2]).max(vs[2][2])]
            })
            .collect();
        let full = tris
            .iter()
            .map(|t| {
                let vs = t.vertices();
                let mut n = cross(t.e1, t.e2);
                if n[2] < 0.0 {
                    n = [-n[0], -n[1], -n[2]];
                }
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                let normal = (n[2] > 1e-12 * len).then(|| {
                    let n = [n[0] / len, n[1] / len, n[2] / len];
                    (n, (n[0] * n[0] + n[1] * n[1]).sqrt())
                });
                let det = t.e1[0] * t.e2[1] - t.e1[1] * t.e2[0];
                let edges = [(0, 1), (1, 2), (2, 0)].map(|(a, b)| Edge::new(vs[a], vs[b]));
                Full { vs, e1: t.e1, e2: t.e2, normal, det, edges }
            })
            .collect();
        Self { cull, full }
    }

    /// [`contact::triangle_drop`](super::contact::triangle_drop) on triangle `i`.
    #[inline]
    pub fn triangle_drop(&self, i: usize, q: [f64; 2], p: &Profile, best: f64) -> f64 {
        let [lo_x, hi_x, lo_y, hi_y, top] = self.cull[i];
        // The tip never sits above the highest point it touches.
        if !(top > best) {
            return best;
        }
        let gx = (lo_x - q[0]).max(q[0] - hi_x).max(0.0);
        let gy = (lo_y - q[1]).max(q[1] - hi_y).max(0.0);
        let r2 = p.radius * p.radius;
        if !(gx * gx + gy * gy <= r2) {
            return best;
        }
        let t = &self.full[i];
        let vs = &t.vs;
        let mut best = best;
        for v in vs {
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
        best = facet(t, q, p, best);
        for (e, (a, b)) in t.edges.iter().zip([(0, 1), (1, 2), (2, 0)]) {
            best = edge(vs[a], vs[b], e, q, p, best);
        }
        best
    }
}

/// The facet test of `contact`, on the stored normal and determinant.
#[inline]
fn facet(t: &Full, q: [f64; 2], p: &Profile, best: f64) -> f64 {
    let Some((n, nxy)) = t.normal else { return best };
    let shift = if nxy > 0.0 { p.flat / nxy + p.corner } else { 0.0 };
    let c = [q[0] - shift * n[0], q[1] - shift * n[1]];
    let (e1, e2, v0) = (t.e1, t.e2, t.vs[0]);
    let (wx, wy) = (c[0] - v0[0], c[1] - v0[1]);
    let s = (wx * e2[1] - wy * e2[0]) / t.det;
    let u = (e1[0] * wy - e1[1] * wx) / t.det;
    if !(s >= 0.0 && u >= 0.0 && s + u <= 1.0) {
        return best;
    }
    let z = v0[2] + s * e1[2] + u * e2[2];
    best.max(z - p.corner + p.corner * n[2])
}

/// The edge test of `contact` on `a`-`b`, on the stored edge terms.
#[inline]
fn edge(a: [f64; 3], b: [f64; 3], e: &Edge, q: [f64; 2], p: &Profile, best: f64) -> f64 {
    if !(a[2].max(b[2]) > best) {
        return best;
    }
    let (u, dz, l2) = (e.u, e.dz, e.l2);
    // A vertical edge's highest contact is its top vertex, which the vertex test has.
    if !(l2 > 0.0) {
        return best;
    }
    let w = [a[0] - q[0], a[1] - q[1]];
    let wu = w[0] * u[0] + w[1] * u[1];
    let ww = w[0] * w[0] + w[1] * w[1];
    let r2 = p.radius * p.radius;
    let cr = w[0] * u[1] - w[1] * u[0];
    let mut disc = l2 * r2 - cr * cr;
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
    // The profile is never negative, so an end lower than `best` cannot raise it: its
    // contact is not computed (the maximum is the same; `<`, not `<=`, so that an end
    // level with `best` still takes part, as in `contact`).
    let mut best = best;
    for t in [t0, t1] {
        if !(z(t) < best) {
            best = best.max(f(t));
        }
    }
    if p.corner <= 0.0 {
        return best;
    }
    if p.flat <= 0.0 {
        best = best.max(ball_edge(e, (wu, ww), p.corner, (t0, t1), z));
    } else {
        best = best.max(bull_edge(w, u, dz, (t0, t1), p, f));
    }
    best
}

/// The ball's edge contact of `contact`, on the stored length and slope terms.
#[inline]
fn ball_edge(e: &Edge, (wu, ww): (f64, f64), r: f64, range: (f64, f64), z: impl Fn(f64) -> f64) -> f64 {
    let d02 = (ww - wu * wu / e.l2).max(0.0);
    let s2 = r * r - d02;
    if !(s2 > 0.0) {
        return f64::NEG_INFINITY;
    }
    let (s, l, m, k) = (s2.sqrt(), e.l, e.m, e.k);
    let tc = -wu / e.l2 + s * m * k / l;
    if !(tc >= range.0 && tc <= range.1) {
        return f64::NEG_INFINITY;
    }
    z(tc) + s * k - r
}
