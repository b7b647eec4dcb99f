//! Drop-cutter: the lowest tip height at which a cutter with its axis along +Z, lowered
//! from above at a point `(x, y)`, touches a triangle mesh.
//!
//! The reference is OpenCAMLib's algorithm (Anders Wallin, `dropcutter/` and
//! `cutters/millingcutter.cpp`): each triangle under the cutter's disc is tested for
//! contacts with its vertices (from the cutter's profile), its interior (through the
//! facet's normal offset) and its edges, and the highest contact wins. The triangles come
//! from the mesh index's BVH, visited highest first, and a triangle or subtree is skipped
//! as soon as its highest point is not above the best contact so far (a tip never sits
//! above the point it touches), so on a raster most triangles under the disc are never
//! tested.
//!
//! # Tolerances per contact type
//!
//! - **Vertex**: exact (one square root).
//! - **Facet**: exact (the normal offset and a barycentric inside test).
//! - **Edge, flat end**: exact (the contact is where the edge leaves the disc, or a vertex).
//! - **Edge, ball end**: exact (closed form in the edge's vertical plane).
//! - **Edge, bull nose (torus)**: the contact height is concave along the edge (the
//!   cutter's profile is convex in the distance from the axis), so the maximum is where its
//!   derivative changes sign, bracketed (Illinois regula falsi, bisection where the
//!   derivative is infinite) until the bracket is
//!   [`DropCutterOptions::edge_tolerance`] long (default 1e-9, in mesh units) along the
//!   edge; the height's error is second order in that (the derivative vanishes at the
//!   maximum), far below 1e-9 for any cutter of practical size.
//!
//! All tests run in f64 relative to the mesh's bounding-box centre; expect agreement with
//! other exact implementations to about 1e-9 of the part's size.

// NaN-aware negated comparisons (`!(x > 0.0)`) are deliberate: NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use rayon::prelude::*;

use super::MeshIndex;
use super::bvh::{Bvh, Node, STACK};
use super::contact::{Profile, triangle_drop};
use super::drop_tris::DropTris;
use crate::cutter::Cutter;
use crate::error::{GeomError, Result};

/// Options of [`DropCutter::new_opt`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DropCutterOptions {
    /// Length, along the edge and in mesh units, of the bracket at which the bull nose's
    /// edge-contact root search stops (the other contacts are exact). Default `1e-9`.
    pub edge_tolerance: f64,
}

impl Default for DropCutterOptions {
    fn default() -> Self {
        Self { edge_tolerance: 1e-9 }
    }
}

/// A cutter, with its axis along +Z, ready to be dropped onto an indexed mesh.
///
/// The cutter is its end (flat, ball or bull nose, from [`Cutter::radius`] and
/// [`Cutter::corner_radius`]) with a cylinder of the cutting radius above it, as long as
/// needed: the flute length, shank and holder play no part (a tool that is too short to
/// reach is the caller's check). Cheap to build; `Send + Sync`.
///
/// ```
/// use s2g_geom::{Aabb, Cutter, DropCutter, Mesh, MeshIndex, Point3};
/// let block = Mesh::cuboid(&Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(10.0, 10.0, 5.0))).unwrap();
/// let index = MeshIndex::new(&block).unwrap();
/// let dc = DropCutter::new(&index, &Cutter::ball(2.0, 8.0)).unwrap();
/// // Over the top face the tip rests on it.
/// assert!((dc.height(5.0, 5.0).unwrap() - 5.0).abs() < 1e-12);
/// // Beyond the block's edge by one radius, the ball touches that edge only.
/// assert!((dc.height(-1.0, 5.0).unwrap() - (5.0 + 3f64.sqrt() - 2.0)).abs() < 1e-12);
/// // Farther than the radius from the block, nothing is touched.
/// assert_eq!(dc.height(-2.5, 5.0), None);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct DropCutter<'a> {
    bvh: &'a Bvh,
    /// The triangles' contact terms, computed once per index.
    tris: &'a DropTris,
    profile: Profile,
}

impl<'a> DropCutter<'a> {
    /// [`DropCutter::new_opt`] with the default options.
    pub fn new(index: &'a MeshIndex, cutter: &Cutter) -> Result<Self> {
        Self::new_opt(index, cutter, &DropCutterOptions::default())
    }

    /// The cutter over `index`'s mesh. [`GeomError::InvalidTool`] for a cutter that
    /// [`Cutter::validate`] refuses; [`GeomError::InvalidArgument`] for a tolerance that is
    /// not finite and positive.
    pub fn new_opt(index: &'a MeshIndex, cutter: &Cutter, options: &DropCutterOptions) -> Result<Self> {
        cutter.validate()?;
        let tol = options.edge_tolerance;
        if !(tol.is_finite() && tol > 0.0) {
            return Err(GeomError::InvalidArgument(format!(
                "edge tolerance must be finite and > 0, got {tol}"
            )));
        }
        let (radius, corner) = (cutter.radius, cutter.corner_radius().clamp(0.0, cutter.radius));
        let profile = Profile { radius, corner, flat: radius - corner, edge_tolerance: tol };
        let tris = index.drop.get_or_init(|| DropTris::new(&index.bvh.tris));
        Ok(Self { bvh: &index.bvh, tris, profile })
    }

    /// The cutting radius.
    pub fn radius(&self) -> f64 {
        self.profile.radius
    }

    /// The mesh's outward unit normal where a ball cutter with its tip at `(x, y, z)`
    /// touches it: the direction from the mesh's nearest point to the ball's centre,
    /// which at a contact is the surface's normal there (at an edge or a vertex, the
    /// normal of the ball's contact). `None` for other end shapes, non-finite input, or a
    /// centre on the mesh.
    pub fn contact_normal(&self, x: f64, y: f64, z: f64) -> Option<[f64; 3]> {
        self.contact_normal_opt(x, y, z, true)
    }

    /// [`DropCutter::contact_normal`] with the nearest point searched over the whole mesh
    /// from the start: the same normal bit for bit. Its baseline, for tests.
    #[doc(hidden)]
    pub fn contact_normal_unbounded(&self, x: f64, y: f64, z: f64) -> Option<[f64; 3]> {
        self.contact_normal_opt(x, y, z, false)
    }

    fn contact_normal_opt(&self, x: f64, y: f64, z: f64, bounded: bool) -> Option<[f64; 3]> {
        let r = self.profile.radius;
        if self.profile.flat > 1e-12 * r || !(x.is_finite() && y.is_finite() && z.is_finite()) {
            return None;
        }
        let c = [x, y, z + r];
        let local = self.bvh.to_local(c);
        // A ball resting on the mesh lies about `r` from it: searching within a little
        // more finds the same point as the unbounded search (the same first nearest
        // triangle, with fewer subtrees opened); only where nothing is that near is the
        // whole mesh searched.
        let near = r * (1.0 + 1e-3);
        let found = if bounded { self.bvh.closest(local, near * near) } else { None };
        let (d2, q, _) = found.or_else(|| self.bvh.closest(local, f64::INFINITY))?;
        let d = d2.sqrt();
        let q = [q[0] + self.bvh.center[0], q[1] + self.bvh.center[1], q[2] + self.bvh.center[2]];
        (d > 1e-12 * r).then(|| [(c[0] - q[0]) / d, (c[1] - q[1]) / d, (c[2] - q[2]) / d])
    }

    /// The mesh's bounding box as `(min, max)` corners (conservative: possibly a little
    /// larger, never smaller).
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let root = &self.bvh.nodes[0];
        let c = self.bvh.center;
        ([0, 1, 2].map(|a| root.min[a] as f64 + c[a]), [0, 1, 2].map(|a| root.max[a] as f64 + c[a]))
    }

    /// The lowest tip height at which the cutter, lowered along -Z above `(x, y)`, touches
    /// the mesh: the highest of its contacts with the vertices, facets and edges within
    /// its radius. `None` when no triangle comes within the radius of `(x, y)` (nothing
    /// stops the cutter), or when `x` or `y` is not finite. Degenerate triangles take part
    /// through their vertices and edges only.
    pub fn height(&self, x: f64, y: f64) -> Option<f64> {
        let h = self.drop_local::<false>(x, y, f64::NEG_INFINITY, false)?;
        (h > f64::NEG_INFINITY).then_some(h + self.bvh.center[2])
    }

    /// [`DropCutter::height`] with each triangle's contact computed from its vertices on
    /// every call (the search before the terms were stored once per index): the same
    /// value bit for bit. The baseline of `benches/drop_cutter.rs` and its tests.
    #[doc(hidden)]
    pub fn height_per_call(&self, x: f64, y: f64) -> Option<f64> {
        let h = self.drop_local::<true>(x, y, f64::NEG_INFINITY, false)?;
        (h > f64::NEG_INFINITY).then_some(h + self.bvh.center[2])
    }

    /// [`DropCutter::height`] where it lies above `floor` (taken into the mesh's frame, so
    /// to its rounding), else `None` (also where nothing stops the cutter): where it is
    /// `Some`, the same value bit for bit, found sooner, as the search passes over every
    /// part of the mesh no higher than `floor` from the start. For a caller that compares
    /// the height with a level a little above `floor`, and asks [`DropCutter::height`]
    /// only where this says `None`.
    pub fn height_above(&self, x: f64, y: f64, floor: f64) -> Option<f64> {
        if !floor.is_finite() {
            return self.height(x, y).filter(|h| *h > floor);
        }
        let local = floor - self.bvh.center[2];
        let h = self.drop_local::<false>(x, y, local, false)?;
        // Above the (local) floor, the highest contact: what `height` finds from below.
        (h > local).then_some(h + self.bvh.center[2])
    }

    /// Whether the cutter lowered over `(x, y)` stops at or below `level`:
    /// `self.height(x, y).is_some_and(|h| h <= level)`, the same answer always, sooner
    /// where the height lies above `level - slack` (the search starts from there; only
    /// where nothing lies above it is the whole height asked for). For a tool known to
    /// touch a little below `level` (a ball resting on a surface point along its normal
    /// touches at its tip), with `slack` a little more than that.
    pub fn stops_at_most(&self, x: f64, y: f64, level: f64, slack: f64) -> bool {
        match self.height_above(x, y, level - slack) {
            Some(h) => h <= level,
            None => self.height(x, y).is_some_and(|h| h <= level),
        }
    }

    /// [`DropCutter::height`] by testing every triangle of the mesh in turn, without the
    /// BVH or its pruning: the same answer, in time proportional to the mesh. A reference
    /// for checks and the baseline of `benches/drop_cutter.rs`.
    pub fn height_all_triangles(&self, x: f64, y: f64) -> Option<f64> {
        if !(x.is_finite() && y.is_finite()) {
            return None;
        }
        let c = self.bvh.center;
        let q = [x - c[0], y - c[1]];
        let h =
            self.bvh.tris.iter().fold(f64::NEG_INFINITY, |best, t| triangle_drop(t, q, &self.profile, best));
        (h > f64::NEG_INFINITY).then_some(h + c[2])
    }

    /// [`DropCutter::height`] at many points, in parallel (rayon), in input order.
    pub fn heights(&self, points: &[[f64; 2]]) -> Vec<Option<f64>> {
        points.par_iter().with_min_len(64).map(|p| self.height(p[0], p[1])).collect()
    }

    /// Whether the cutter with its tip at `(x, y, z)` cuts into the mesh: whether the drop
    /// height at `(x, y)` is above `z` (a cutter that only touches does not). Stops at the
    /// first contact above `z`, so it is cheaper than [`DropCutter::height`]. `false` for
    /// non-finite input.
    pub fn interferes(&self, x: f64, y: f64, z: f64) -> bool {
        if !z.is_finite() {
            return false;
        }
        let floor = z - self.bvh.center[2];
        self.drop_local::<false>(x, y, floor, true).is_some_and(|h| h > floor)
    }

    /// The highest contact above `floor` (local frame), or `floor`; stops at the first
    /// contact above `floor` when `first` is set. `None` for non-finite input. `PER_CALL`:
    /// each triangle's contact from its vertices ([`DropCutter::height_per_call`]).
    fn drop_local<const PER_CALL: bool>(&self, x: f64, y: f64, floor: f64, first: bool) -> Option<f64> {
        if !(x.is_finite() && y.is_finite()) {
            return None;
        }
        let c = self.bvh.center;
        let q = [x - c[0], y - c[1]];
        let p = &self.profile;
        let r2 = p.radius * p.radius;
        let reaches = |n: &Node| {
            let gx = (n.min[0] as f64 - q[0]).max(q[0] - n.max[0] as f64).max(0.0);
            let gy = (n.min[1] as f64 - q[1]).max(q[1] - n.max[1] as f64).max(0.0);
            gx * gx + gy * gy <= r2
        };
        let nodes = &self.bvh.nodes;
        let mut best = floor;
        let mut stack = [0u32; STACK];
        let mut sp = 0usize;
        if reaches(&nodes[0]) {
            stack[0] = 0;
            sp = 1;
        }
        while sp > 0 {
            sp -= 1;
            let n = &nodes[stack[sp] as usize];
            // The tip never sits above the highest point of what it touches.
            if !(n.max[2] as f64 > best) {
                continue;
            }
            if n.count > 0 {
                let s = n.start as usize;
                if PER_CALL {
                    for tri in &self.bvh.tris[s..s + n.count as usize] {
                        best = triangle_drop(tri, q, p, best);
                    }
                } else {
                    for i in s..s + n.count as usize {
                        best = self.tris.triangle_drop(i, q, p, best);
                    }
                }
                if first && best > floor {
                    return Some(best);
                }
                continue;
            }
            // Push the lower child first so that the higher one is visited first.
            let (l, r) = (n.start as usize, n.start as usize + 1);
            let (lo, hi) = if nodes[l].max[2] <= nodes[r].max[2] { (l, r) } else { (r, l) };
            for k in [lo, hi] {
                if nodes[k].max[2] as f64 > best && reaches(&nodes[k]) && sp < STACK {
                    stack[sp] = k as u32;
                    sp += 1;
                }
            }
        }
        Some(best)
    }
}
