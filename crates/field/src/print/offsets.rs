//! Spacing on a curved layer: the in-layer distance to the part's boundary, measured from
//! the boundary curve itself, and the trimming of toolpaths that come closer than the
//! smallest spacing to a path printed before them on the layer.
//!
//! - **In-layer distance**: the layer's boundary is the iso-line `s = 0` of the part's
//!   signed distance on the layer mesh; a vertex within `reach` of it (`|s| ≤ reach`: the
//!   curve lies on the part's skin, so it is never nearer than `|s|`) gets the distance to
//!   the nearest segment of that curve, signed as `s`. On a planar layer that is the exact
//!   offset distance; on a curved one the chord differs from the geodesic by a term in
//!   `d³ κ²`, nothing at a few bead widths. Vertices farther in keep a first-order
//!   estimate, clamped to lie beyond `reach`.
//! - **Trimming**: the paths are taken in priority order (outer rings, inner rings,
//!   infill); a point whose distance to the paths kept so far (or to its own path more
//!   than `own_arc` away along it, cyclically for a closed path) is below `min_gap` is cut
//!   out, the cut placed where that distance crosses `min_gap` (linearly between points).
//!   A ring whose two sides meet in a thin wall keeps its first side; infill lines stop
//!   `min_gap` short of the inner ring.

use std::collections::HashMap;

use rayon::prelude::*;
use s2g_geom::{Mesh, Point3, Vector3};

/// Per-vertex data of a layer mesh.
#[derive(Debug, Clone, Copy)]
pub(super) struct Sample {
    pub(super) p: Point3,
    pub(super) n: Vector3,
    pub(super) t: f64,
    /// In-layer distance to the boundary (negative inside).
    pub(super) phi: f64,
}

impl Sample {
    pub(super) fn lerp(&self, o: &Sample, u: f64) -> Sample {
        Sample {
            p: self.p + (o.p - self.p) * u,
            n: (self.n + (o.n - self.n) * u).try_normalize(1e-12).unwrap_or(self.n),
            t: self.t + (o.t - self.t) * u,
            phi: self.phi + (o.phi - self.phi) * u,
        }
    }
}

/// Segments hashed by the cells their boxes touch.
struct SegmentGrid {
    cell: f64,
    segs: Vec<(Point3, Point3)>,
    cells: HashMap<[i64; 3], Vec<u32>>,
}

impl SegmentGrid {
    fn new(cell: f64) -> Self {
        Self { cell, segs: Vec::new(), cells: HashMap::new() }
    }

    fn key(&self, p: &Point3) -> [i64; 3] {
        [0, 1, 2].map(|a| (p[a] / self.cell).floor() as i64)
    }

    fn insert(&mut self, a: Point3, b: Point3) {
        let i = self.segs.len() as u32;
        self.segs.push((a, b));
        let (lo, hi) = (self.key(&a.inf(&b)), self.key(&a.sup(&b)));
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    self.cells.entry([x, y, z]).or_default().push(i);
                }
            }
        }
    }

    /// Distance from `p` to the nearest segment within `reach` (or `reach` when none).
    fn distance(&self, p: &Point3, reach: f64) -> f64 {
        let c = self.key(p);
        let span = (reach / self.cell).ceil() as i64;
        let mut best = reach;
        for dx in -span..=span {
            for dy in -span..=span {
                for dz in -span..=span {
                    let Some(list) = self.cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else { continue };
                    for &i in list {
                        let (a, b) = self.segs[i as usize];
                        best = best.min(point_segment(p, &a, &b));
                    }
                }
            }
        }
        best
    }
}

fn point_segment(p: &Point3, a: &Point3, b: &Point3) -> f64 {
    let ab = b - a;
    let len2 = ab.norm_squared();
    let t = if len2 > 0.0 { ((p - a).dot(&ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + ab * t)).norm()
}

/// Distance from each vertex to the iso-line `values = 0` on `mesh`, signed as `values`,
/// where it is within `reach` (`|values| ≤ reach` is a lower bound of it); `fallback`
/// elsewhere, pushed beyond `reach`.
fn curve_distance(mesh: &Mesh, points: &[Point3], values: &[f64], fallback: &[f64], reach: f64) -> Vec<f64> {
    let mut grid = SegmentGrid::new(0.5 * reach);
    for tri in mesh.triangles() {
        let mut ends = Vec::with_capacity(2);
        for e in 0..3 {
            let (a, b) = (tri[e] as usize, tri[(e + 1) % 3] as usize);
            let (va, vb) = (values[a], values[b]);
            if (va < 0.0) != (vb < 0.0) {
                ends.push(points[a] + (points[b] - points[a]) * (va / (va - vb)));
            }
        }
        if let [a, b] = ends[..] {
            grid.insert(a, b);
        }
    }
    points
        .par_iter()
        .zip(values)
        .zip(fallback)
        .map(|((p, &v), &est)| {
            let far = est.abs().max(reach * 1.001).copysign(v);
            if v.abs() > reach {
                return far;
            }
            let d = grid.distance(p, reach);
            if d >= reach { far } else { d.copysign(v) }
        })
        .collect()
}

/// Replaces each sample's `phi` (the signed distance `s` on entry, `estimate` its
/// first-order in-layer distance) by the in-layer distance of the module docs, exact
/// within `reach` of the boundary.
pub(super) fn in_layer_distance(mesh: &Mesh, samples: &mut [Sample], estimate: &[f64], reach: f64) {
    let points: Vec<Point3> = samples.iter().map(|s| s.p).collect();
    let values: Vec<f64> = samples.iter().map(|s| s.phi).collect();
    for (s, v) in samples.iter_mut().zip(curve_distance(mesh, &points, &values, estimate, reach)) {
        s.phi = v;
    }
}

/// The scalar whose zero iso-line is ring `i` of `rings` (bead width `w`), rounded at
/// the layer's convex corners: the points `ρ` outside the region whose in-layer depth
/// exceeds `(i + ½) w + ρ`, `ρ = (rings - 1 - i) w / 2` (the innermost ring, `ρ = 0`, is
/// the plain offset). Sharp offsets of a corner lie `√2 w` apart across it; with each
/// ring rounded half a width more than the one inside it, they stay within `1.21 w`.
pub(super) fn ring_scalar(mesh: &Mesh, samples: &[Sample], i: usize, rings: usize, w: f64) -> Vec<f64> {
    let rho = 0.5 * (rings - 1 - i) as f64 * w;
    let depth = (i as f64 + 0.5) * w;
    if rho == 0.0 {
        return samples.iter().map(|s| s.phi + depth).collect();
    }
    let points: Vec<Point3> = samples.iter().map(|s| s.p).collect();
    let values: Vec<f64> = samples.iter().map(|s| s.phi + depth + rho).collect();
    curve_distance(mesh, &points, &values, &values, 2.0 * rho).into_iter().map(|d| d - rho).collect()
}

/// A polyline of samples, closed or not, and what it fills.
pub(super) type Polyline<K> = (K, Vec<Sample>, bool);

/// Cumulative arc length of `pts`.
fn arcs(pts: &[Sample]) -> Vec<f64> {
    let mut out = Vec::with_capacity(pts.len());
    let mut acc = 0.0;
    for (i, s) in pts.iter().enumerate() {
        if i > 0 {
            acc += (s.p - pts[i - 1].p).norm();
        }
        out.push(acc);
    }
    out
}

/// The trimming of the module docs, over polylines in priority order.
pub(super) fn trim_close<K: Copy>(
    polylines: Vec<Polyline<K>>,
    min_gap: f64,
    own_arc: f64,
) -> Vec<Polyline<K>> {
    if min_gap <= 0.0 {
        return polylines;
    }
    let mut kept = SegmentGrid::new(min_gap);
    let mut out = Vec::with_capacity(polylines.len());
    for (kind, pts, closed) in polylines {
        let arc = arcs(&pts);
        let total = arc.last().copied().unwrap_or(0.0);
        let sep = |a: f64, b: f64| {
            let d = (a - b).abs();
            if closed { d.min(total - d) } else { d }
        };
        // Own segments kept so far, with their arc positions.
        let mut own: Vec<(usize, f64)> = Vec::new();
        let mut gaps = Vec::with_capacity(pts.len());
        let mut ok = Vec::with_capacity(pts.len());
        for (i, s) in pts.iter().enumerate() {
            let mut d = kept.distance(&s.p, min_gap);
            for &(j, aj) in &own {
                if sep(aj, arc[i]) > own_arc {
                    d = d.min(point_segment(&s.p, &pts[j].p, &pts[j + 1].p));
                }
            }
            let good = d >= min_gap;
            if good && i > 0 && ok[i - 1] {
                own.push((i - 1, 0.5 * (arc[i - 1] + arc[i])));
            }
            gaps.push(d);
            ok.push(good);
        }
        if ok.iter().all(|&g| g) {
            for w in pts.windows(2) {
                kept.insert(w[0].p, w[1].p);
            }
            out.push((kind, pts, closed));
            continue;
        }
        let cut = |i: usize| {
            let (da, db) = (gaps[i], gaps[i + 1]);
            let u = if (db - da).abs() > 1e-12 { ((min_gap - da) / (db - da)).clamp(0.0, 1.0) } else { 0.5 };
            pts[i].lerp(&pts[i + 1], u)
        };
        let mut runs: Vec<Vec<Sample>> = Vec::new();
        let mut cur: Option<Vec<Sample>> = None;
        for i in 0..pts.len() {
            match (ok[i], cur.as_mut()) {
                (true, None) => {
                    let mut run = Vec::new();
                    if i > 0 {
                        run.push(cut(i - 1));
                    }
                    run.push(pts[i]);
                    cur = Some(run);
                }
                (true, Some(run)) => run.push(pts[i]),
                (false, Some(run)) => {
                    run.push(cut(i - 1));
                    runs.extend(cur.take());
                }
                (false, None) => {}
            }
        }
        let wraps = closed && ok[0] && ok[pts.len() - 1];
        runs.extend(cur);
        if wraps && runs.len() > 1 {
            // The last run continues into the first (the loop's start point repeats).
            let first = runs.remove(0);
            if let Some(last) = runs.last_mut() {
                last.extend(first.into_iter().skip(1));
            }
        }
        for run in runs {
            if run.len() >= 2 {
                for w in run.windows(2) {
                    kept.insert(w[0].p, w[1].p);
                }
                out.push((kind, run, false));
            }
        }
    }
    out
}

/// The infill's scalar fitted to each region: the vertices inside `clip` are grouped into
/// connected regions (a vertex beside one joins it, so that its triangles interpolate
/// within one region); on each, `psi` is mapped so that its integer levels `0..=n` are
/// lines spaced `S / n` apart (`S` the region's extent along `psi` inside `edge`, `n`
/// its nearest whole number of bead widths `w`): the first and last lines lie a bead
/// width inside the inner ring where it runs along them, and neighbours stay within a
/// quarter of `w` of it from `S = 1.5 w` up. A region narrower than that gets one line
/// down its middle. Returns the scalar and the largest `n`.
pub(super) fn fitted_infill(
    mesh: &Mesh,
    samples: &[Sample],
    psi: &[f64],
    clip: f64,
    edge: f64,
    w: f64,
) -> (Vec<f64>, usize) {
    let nv = samples.len();
    let mut parent: Vec<u32> = (0..nv as u32).collect();
    fn find(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            parent[i as usize] = parent[parent[i as usize] as usize];
            i = parent[i as usize];
        }
        i
    }
    let inside = |i: u32| samples[i as usize].phi < clip;
    for tri in mesh.triangles() {
        for e in 0..3 {
            let (a, b) = (tri[e], tri[(e + 1) % 3]);
            if inside(a) && inside(b) {
                let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                if ra != rb {
                    parent[ra.max(rb) as usize] = ra.min(rb);
                }
            }
        }
    }
    const NONE: u32 = u32::MAX;
    let mut region: Vec<u32> =
        (0..nv as u32).map(|i| if inside(i) { find(&mut parent, i) } else { NONE }).collect();
    for tri in mesh.triangles() {
        if let Some(&r) = tri.iter().find(|&&i| region[i as usize] != NONE && inside(i)) {
            let r = region[r as usize];
            for &i in tri {
                if region[i as usize] == NONE {
                    region[i as usize] = r;
                }
            }
        }
    }
    // Per region: extent of psi inside `edge` (vertices and crossings), and over `clip`.
    let mut inner: HashMap<u32, (f64, f64)> = HashMap::new();
    let mut outer: HashMap<u32, (f64, f64)> = HashMap::new();
    let widen = |m: &mut HashMap<u32, (f64, f64)>, r: u32, v: f64| {
        let e = m.entry(r).or_insert((f64::INFINITY, f64::NEG_INFINITY));
        *e = (e.0.min(v), e.1.max(v));
    };
    for (i, s) in samples.iter().enumerate() {
        if inside(i as u32) {
            widen(&mut outer, region[i], psi[i]);
            if s.phi < edge {
                widen(&mut inner, region[i], psi[i]);
            }
        }
    }
    for tri in mesh.triangles() {
        for e in 0..3 {
            let (a, b) = (tri[e] as usize, tri[(e + 1) % 3] as usize);
            let (pa, pb) = (samples[a].phi, samples[b].phi);
            if (pa < edge) != (pb < edge) && region[a] != NONE && region[a] == region[b] {
                let u = (edge - pa) / (pb - pa);
                widen(&mut inner, region[a], psi[a] + (psi[b] - psi[a]) * u);
            }
        }
    }
    // Region -> (offset, spacing): level j at psi = offset + j spacing.
    let mut fit: HashMap<u32, (f64, f64)> = HashMap::new();
    let mut most = 0usize;
    for (&r, &(lo, hi)) in &outer {
        let (lo, hi) = inner.get(&r).copied().unwrap_or((0.5 * (lo + hi), 0.5 * (lo + hi)));
        let n = ((hi - lo) / w).round() as usize;
        most = most.max(n);
        // The end lines touch the region's extreme: nudged inside it.
        let (lo, hi) = (lo + 1e-4 * w, hi - 1e-4 * w);
        fit.insert(r, if n == 0 { (0.5 * (lo + hi), w) } else { (lo, (hi - lo) / n as f64) });
    }
    let scalar = (0..nv)
        .map(|i| match fit.get(&region[i]) {
            Some(&(o, s)) => (psi[i] - o) / s,
            None => f64::MAX,
        })
        .collect();
    (scalar, most)
}
