//! Layer slicing in the setup frame: layer levels and the exact keep-out region per layer.
//!
//! The keep-out region at level `z` is the XY projection of the part's material above
//! `z`, i.e. the union of all cross-sections at and above `z`: the cross-section of the
//! part's visibility closure along the tool axis (seed 000 §3.2), which is exactly the
//! set the tool body (a vertical cylinder from the tip upward) must stay out of. For a
//! closed mesh it equals the union of the projections of the boundary triangles clipped
//! to `z' >= z`, which is what is computed, incrementally from the top down.

use rayon::prelude::*;
use s2g_geom::{Mesh, Point3, Setup};

use crate::region::{Point2, Region2, ccw_contour};

/// Faces with `|n_z| <= VERTICAL_TOLERANCE * |n|` count as vertical: their projection (a
/// sliver at most this relative width) is left out of the keep-out.
pub(crate) const VERTICAL_TOLERANCE: f64 = 1e-9;

/// The part's triangles in the setup frame.
pub(crate) fn setup_triangles(part: &Mesh, setup: &Setup) -> Vec<[Point3; 3]> {
    let inv = setup.frame.inverse();
    part.triangle_points().map(|t| t.map(|p| inv * p)).collect()
}

/// The z values of horizontal faces (|n_z| >= 1 - `cos_tol`), descending, merged within `merge_tol`.
pub(crate) fn flat_levels(tris: &[[Point3; 3]], cos_tol: f64, merge_tol: f64) -> Vec<f64> {
    let mut zs: Vec<f64> = tris
        .iter()
        .filter_map(|[a, b, c]| {
            let n = (b - a).cross(&(c - a));
            let len = n.norm();
            (len > 0.0 && n.z.abs() >= (1.0 - cos_tol) * len).then(|| a.z.max(b.z).max(c.z))
        })
        .collect();
    zs.sort_by(|a, b| b.total_cmp(a));
    let mut out: Vec<f64> = Vec::new();
    for z in zs {
        match out.last() {
            Some(&last) if last - z <= merge_tol => {}
            _ => out.push(z),
        }
    }
    out
}

/// Layer levels from `top` (exclusive) down to `bottom` (inclusive), descending.
///
/// With `flats`, every flat level strictly between becomes a layer and the steps between
/// consecutive targets are split evenly into steps of at most `h`; otherwise the levels are
/// `top - h, top - 2h, ...` with the last one exactly at `bottom`.
pub(crate) fn layer_levels(top: f64, bottom: f64, h: f64, flats: &[f64], tol: f64) -> Vec<f64> {
    let mut out = Vec::new();
    if !(top - bottom > tol) || !(h > 0.0) {
        return out;
    }
    let mut targets: Vec<f64> =
        flats.iter().copied().filter(|&f| f > bottom + tol && f < top - tol).collect();
    targets.push(bottom);
    let mut prev = top;
    for t in targets {
        if prev - t <= tol {
            continue;
        }
        let n = (((prev - t) / h) - 1e-9).ceil().max(1.0) as usize;
        for k in 1..n {
            out.push(prev - (prev - t) * k as f64 / n as f64);
        }
        out.push(t);
        prev = t;
    }
    out
}

/// The keep-out regions (XY projection of material above each level + `tol`, one per
/// level) as a running union of slab regions from the top down, computed a range
/// of levels at a time so that a caller can plan the levels it has while the next ones
/// are computed (the union is the one sequential step of slicing).
///
/// Holes of area below `min_hole_area` are filled after every union
/// ([`Region2::with_small_holes_filled`]): with `π d²` for a keep-out grown by `d`, the
/// grown regions are the same, and the running union of a finely sliced mesh no longer
/// carries thousands of sliver holes from level to level.
///
/// The running union's vertices are bounded: where it has more than [`Keepouts::BUDGET`]
/// times the most of any slab (and at least [`Keepouts::FLOOR`]), it is replaced by a
/// simpler region that contains it ([`Region2::simplified_outward`] at `tolerance`,
/// doubled up to three times while it stays above that: each lies within 2.5 times its
/// tolerance of what it simplifies). Walls a few tenths of a degree
/// off the tool axis (a turned part on a setup tilted by 0.3 degrees) make every slab's
/// needle-thin wall faces cross the union's boundary, which then grows by a slab's
/// vertices per level: 200,000 vertices after 200 levels, unions of seconds and offsets
/// that ran out of 24 GB. A simplified keep-out lies at most `37.5 tolerance` outside the
/// exact one, so the tool stays at most that much farther from the part; on every other
/// part the union is exact, as before.
pub(crate) struct Keepouts {
    slabs: Vec<Region2>,
    acc: Region2,
    done: usize,
    min_hole_area: f64,
    tolerance: f64,
    /// The most vertices of a slab so far.
    widest: usize,
}

impl Keepouts {
    /// Vertices of the running union allowed per vertex of the largest slab.
    pub(crate) const BUDGET: usize = 32;
    /// Vertices of the running union always allowed.
    pub(crate) const FLOOR: usize = 50_000;

    pub(crate) fn new(slabs: Vec<Region2>, min_hole_area: f64, tolerance: f64) -> Self {
        Self { slabs, acc: Region2::empty(), done: 0, min_hole_area, tolerance, widest: 0 }
    }

    /// The keep-outs of the levels after those already returned, up to `end` (exclusive,
    /// at most the number of levels).
    pub(crate) fn advance(&mut self, end: usize) -> Vec<Region2> {
        let end = end.min(self.slabs.len());
        let mut out = Vec::with_capacity(end.saturating_sub(self.done));
        for s in &mut self.slabs[self.done.min(end)..end] {
            if !s.is_empty() {
                self.widest = self.widest.max(s.vertex_count());
                self.acc = self.acc.union(&std::mem::take(s)).with_small_holes_filled(self.min_hole_area);
                let budget = (Self::BUDGET * self.widest).max(Self::FLOOR);
                let mut tol = self.tolerance;
                for _ in 0..4 {
                    if self.acc.vertex_count() <= budget || !(tol > 0.0) {
                        break;
                    }
                    self.acc = self.acc.simplified_outward(tol);
                    tol *= 2.0;
                }
            }
            out.push(self.acc.clone());
        }
        self.done = self.done.max(end);
        out
    }
}

/// Faces steeper than this (`|n_z| <= STEEP * |n|`, within about 0.6 degrees of vertical)
/// may be left out of the keep-out as slivers ([`slab_regions`]).
pub(crate) const SLIVER_STEEPNESS: f64 = 0.01;

/// Whether a face is a sliver of the projection: steeper than [`SLIVER_STEEPNESS`] and
/// projecting to a triangle narrower than `width` (twice its area over its longest edge).
/// Every point of such a projection lies within `width` of the projection of the face's
/// longest edge, an edge it shares with the rest of the closed surface.
pub(crate) fn is_sliver(tri: &[Point3; 3], width: f64) -> bool {
    let n = (tri[1] - tri[0]).cross(&(tri[2] - tri[0]));
    if n.z.abs() > SLIVER_STEEPNESS * n.norm() {
        return false;
    }
    let edge = |a: usize, b: usize| (tri[a].x - tri[b].x).hypot(tri[a].y - tri[b].y);
    let longest = edge(0, 1).max(edge(1, 2)).max(edge(2, 0));
    // |n_z| is twice the projected area.
    n.z.abs() <= width * longest
}

/// The XY projection of the part's material in each level's slab (from the level + `tol`
/// up to the level above + `tol`, the first one unbounded above), one per level, with its
/// holes of area below `min_hole_area` filled. A negative `tol` (the level tolerance less
/// an axial allowance) reaches below the level: the tool tip then stays `-tol` above
/// every face under it.
///
/// Faces that project to slivers narrower than `sliver_width` ([`is_sliver`]) are left
/// out, so the regions are exact to within that width. Such faces are the walls of a mesh
/// written in single precision or cut by a boolean (the flanks of a cross hole in a
/// tube, rounded from vertical): each is a needle along the part's outline, the union of
/// a few hundred of them is a boundary of tens of thousands of nearly collinear vertices,
/// and every later union of the running keep-out grows it further (a flanged bushing at
/// 256^3 never finished). The caller grows the tool-centre keep-out by `sliver_width`
/// more, so it stays conservative.
pub(crate) fn slab_regions(
    tris: &[[Point3; 3]],
    levels: &[f64],
    tol: f64,
    min_hole_area: f64,
    sliver_width: f64,
) -> Vec<Region2> {
    let n = levels.len();
    if n == 0 {
        return Vec::new();
    }
    // Slab l spans [levels[l] + tol, levels[l-1] + tol] (the first one reaches +inf).
    let lo = |l: usize| levels[l] + tol;
    let hi = |l: usize| if l == 0 { f64::INFINITY } else { levels[l - 1] + tol };
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (t, tri) in tris.iter().enumerate() {
        let zmax = tri.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max);
        let zmin = tri.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
        // First slab whose lower bound is at or below zmax.
        let a = levels.partition_point(|&z| z + tol > zmax);
        // Slabs whose upper bound is at or above zmin: l == 0 or levels[l-1] + tol >= zmin.
        let b = levels.partition_point(|&z| z + tol >= zmin); // l - 1 < b  <=>  l <= b
        for bucket in buckets.iter_mut().take(b.min(n - 1) + 1).skip(a) {
            bucket.push(t as u32);
        }
    }
    buckets
        .par_iter()
        .enumerate()
        .map(|(l, bucket)| {
            let contours: Vec<Vec<[f64; 2]>> = bucket
                .iter()
                .filter_map(|&t| {
                    let tri = &tris[t as usize];
                    // Vertical (and numerically vertical) faces project to needles inside
                    // their neighbours' projections; they only add noise to the union.
                    let n = (tri[1] - tri[0]).cross(&(tri[2] - tri[0]));
                    if n.z.abs() <= VERTICAL_TOLERANCE * n.norm() || is_sliver(tri, sliver_width) {
                        return None;
                    }
                    let poly = clip_to_slab(tri, lo(l), hi(l));
                    ccw_contour(poly)
                })
                .collect();
            Region2::union_contours(contours).with_small_holes_filled(min_hole_area)
        })
        .collect()
}

/// The XY projection of a triangle clipped to `lo <= z <= hi` (Sutherland-Hodgman).
fn clip_to_slab(tri: &[Point3; 3], lo: f64, hi: f64) -> Vec<[f64; 2]> {
    let mut poly: Vec<Point3> = tri.to_vec();
    for (bound, keep_above) in [(lo, true), (hi, false)] {
        if !bound.is_finite() || poly.is_empty() {
            continue;
        }
        let inside = |p: &Point3| if keep_above { p.z >= bound } else { p.z <= bound };
        let mut out = Vec::with_capacity(poly.len() + 2);
        for i in 0..poly.len() {
            let a = poly[i];
            let b = poly[(i + 1) % poly.len()];
            let (ia, ib) = (inside(&a), inside(&b));
            if ia {
                out.push(a);
            }
            if ia != ib {
                out.push(cross_level(&a, &b, bound));
            }
        }
        poly = out;
    }
    poly.iter().map(|p| [p.x, p.y]).collect()
}

/// Where the segment `a`-`b` crosses the level `z`, computed from its endpoints in a fixed
/// order (lower z first, then x, then y), so that the two triangles sharing an edge put
/// bit-identical points on it. Computed from each triangle's own direction of travel, the
/// two points differ in the last bits; the union of the projections then keeps a hairline
/// slit between the triangles, and a keep-out made of thousands of such slits (the long
/// steep facets of a rounded box) made each offset of it take tens of seconds.
fn cross_level(a: &Point3, b: &Point3, z: f64) -> Point3 {
    let key = |p: &Point3| (p.z, p.x, p.y);
    let (lo, hi) =
        if key(a).partial_cmp(&key(b)) == Some(std::cmp::Ordering::Greater) { (b, a) } else { (a, b) };
    let t = (z - lo.z) / (hi.z - lo.z);
    let mut p = lo + (hi - lo) * t;
    p.z = z;
    p
}

/// Exact distance from a point to a region's boundary, negative inside (test helper and
/// diagnostics): brute force over every edge.
pub fn region_signed_distance(region: &Region2, p: &Point2) -> f64 {
    let idx = region.index();
    let d = idx.boundary_distance(p, f64::INFINITY);
    if idx.contains(p) { -d } else { d }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A face rounded from vertical and narrower than the width is a sliver; a steep face
    /// wider than it, or a narrow face that is not steep, is not.
    #[test]
    fn slivers_are_steep_and_narrow() {
        let p = Point3::new;
        // A vertical wall 10 long and 1 high, its top edge moved by 1e-7 in y.
        let wall = [p(0.0, 0.0, 0.0), p(10.0, 0.0, 0.0), p(10.0, 1e-7, 1.0)];
        assert!(is_sliver(&wall, 1e-6));
        assert!(!is_sliver(&wall, 1e-8), "wider than the width");
        // Steeper than 89.4 degrees but 0.005 wide in projection.
        let steep = [p(0.0, 0.0, 0.0), p(10.0, 0.0, 0.0), p(10.0, 0.005, 1.0)];
        assert!(!is_sliver(&steep, 1e-3) && is_sliver(&steep, 1e-2));
        // A flat needle is narrow but lies flat: its projection is the face itself.
        let needle = [p(0.0, 0.0, 0.0), p(10.0, 0.0, 0.0), p(10.0, 1e-7, 1e-9)];
        assert!(!is_sliver(&needle, 1e-3));
    }

    #[test]
    fn levels_land_on_flats_and_floor() {
        let lv = layer_levels(1.0, 0.0, 0.3, &[0.5], 1e-9);
        assert!(lv.contains(&0.5) && *lv.last().unwrap() == 0.0, "{lv:?}");
        assert!(lv.windows(2).all(|w| w[0] > w[1] && w[0] - w[1] <= 0.3 + 1e-12), "{lv:?}");
        let top_gap = 1.0 - lv[0];
        assert!(top_gap <= 0.3 + 1e-12);
    }
}
