//! Waterline: the constant-Z contours of the cutter-location surface, the closed loops the
//! tip of a cutter at height `z` follows so that it touches the mesh without cutting into it.
//!
//! The method samples the interference test ([`DropCutter::interferes`]: does the cutter
//! with its tip at `(x, y, z)` cut into the mesh) on a square grid of nodes `step` apart,
//! and on every grid edge whose ends disagree it finds the boundary by bisection of the
//! same exact test, to [`WaterlineOptions::tolerance`]. These are the points where
//! OpenCAMLib's fibres (push-cutter along X and Y lines) end, but found with drop-cutter
//! queries that stop at the first contact; they are then joined cell by cell (marching
//! squares, the ambiguous cells decided by the test at the cell's centre) into loops.
//! Every loop point is on the true contour (within the tolerance); between points the
//! loop is a chord. Like fibres, the grid can miss a feature of the contour narrower
//! than `step` (a wall thinner than a cell crossing two cell edges).

// NaN-aware negated comparisons (`!(x > 0.0)`) are deliberate: NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use rayon::prelude::*;

use super::DropCutter;
use crate::error::{GeomError, Result};
use crate::math::Point3;

/// Options of [`DropCutter::waterline_opt`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WaterlineOptions {
    /// Spacing of the sampling grid in mesh units. Default `0.5`.
    pub step: f64,
    /// Accuracy of each loop point (bisection bracket) in mesh units. Default `1e-6`.
    pub tolerance: f64,
    /// The most grid nodes a call may sample (an error beyond). Default `64_000_000`.
    pub max_nodes: usize,
}

impl Default for WaterlineOptions {
    fn default() -> Self {
        Self { step: 0.5, tolerance: 1e-6, max_nodes: 64_000_000 }
    }
}

/// The sampling grid: nodes `x0 + i step`, `y0 + j step`.
struct Grid {
    x0: f64,
    y0: f64,
    step: f64,
    nx: usize,
    ny: usize,
}

impl Grid {
    fn node(&self, i: usize, j: usize) -> [f64; 2] {
        [self.x0 + i as f64 * self.step, self.y0 + j as f64 * self.step]
    }

    /// Number of horizontal edges (`(i, j)`-`(i + 1, j)`), which come first in edge ids.
    fn horizontal(&self) -> usize {
        (self.nx - 1) * self.ny
    }

    /// The ends of edge `id`.
    fn ends(&self, id: usize) -> ([usize; 2], [usize; 2]) {
        let h = self.horizontal();
        if id < h {
            let (i, j) = (id % (self.nx - 1), id / (self.nx - 1));
            ([i, j], [i + 1, j])
        } else {
            let (i, j) = ((id - h) % self.nx, (id - h) / self.nx);
            ([i, j], [i, j + 1])
        }
    }

    /// The ids of cell `(i, j)`'s edges counter-clockwise from its bottom, each running
    /// from corner `k` to corner `k + 1` (corners counter-clockwise from bottom left).
    fn cell_edges(&self, i: usize, j: usize) -> [usize; 4] {
        let h = self.horizontal();
        [j * (self.nx - 1) + i, h + j * self.nx + i + 1, (j + 1) * (self.nx - 1) + i, h + j * self.nx + i]
    }
}

impl DropCutter<'_> {
    /// [`DropCutter::waterline_opt`] with the default options.
    pub fn waterline(&self, z: f64) -> Result<Vec<Vec<Point3>>> {
        self.waterline_opt(z, &WaterlineOptions::default())
    }

    /// The waterline loops at tip height `z`: closed polylines (the first point is not
    /// repeated at the end) at height `z`, each with the region where the cutter would cut
    /// into the mesh on its left, so loops around material run counter-clockwise seen from
    /// +Z and loops around holes clockwise. Loops come in a deterministic order (by their
    /// first grid edge, bottom row first). Empty when the cutter at `z` cuts nothing (or
    /// only features narrower than the step, see the module docs).
    /// [`GeomError::InvalidArgument`] for a non-finite `z`, a step or tolerance that is not
    /// finite and positive, or a grid above `max_nodes`.
    pub fn waterline_opt(&self, z: f64, options: &WaterlineOptions) -> Result<Vec<Vec<Point3>>> {
        let (step, tol) = (options.step, options.tolerance);
        let bad = |m: String| Err(GeomError::InvalidArgument(m));
        if !z.is_finite() {
            return bad(format!("waterline height must be finite, got {z}"));
        }
        if !(step.is_finite() && step > 0.0 && tol.is_finite() && tol > 0.0) {
            return bad(format!("waterline step and tolerance must be finite and > 0, got {step}, {tol}"));
        }
        let (lo, hi) = self.bounds();
        // Nodes more than the radius beyond the mesh's box touch nothing: the outer ring
        // of nodes is outside, so every contour closes inside the grid.
        let margin = self.radius() + step;
        let count = |a: usize| ((hi[a] - lo[a] + 2.0 * margin) / step).ceil() + 1.0;
        let (cx, cy) = (count(0), count(1));
        if !(cx * cy <= options.max_nodes as f64) {
            return bad(format!(
                "waterline grid of {cx} x {cy} nodes exceeds max_nodes {}",
                options.max_nodes
            ));
        }
        let grid = Grid { x0: lo[0] - margin, y0: lo[1] - margin, step, nx: cx as usize, ny: cy as usize };
        let inside = self.sample(&grid, z);
        let at = |i: usize, j: usize| inside[j * grid.nx + i];
        // Crossing edges, in id order, and their boundary points.
        let crossing: Vec<usize> = (0..grid.horizontal() + grid.nx * (grid.ny - 1))
            .filter(|&id| {
                let (a, b) = grid.ends(id);
                at(a[0], a[1]) != at(b[0], b[1])
            })
            .collect();
        let points: Vec<[f64; 2]> = crossing
            .par_iter()
            .with_min_len(16)
            .map(|&id| {
                let (a, b) = grid.ends(id);
                self.boundary(grid.node(a[0], a[1]), grid.node(b[0], b[1]), at(a[0], a[1]), z, tol)
            })
            .collect();
        let slot = |id: usize| crossing.binary_search(&id).unwrap_or(usize::MAX);
        let mut next = vec![usize::MAX; crossing.len()];
        for j in 0..grid.ny - 1 {
            for i in 0..grid.nx - 1 {
                let c = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                if c.iter().all(|&v| v == c[0]) {
                    continue;
                }
                let e = grid.cell_edges(i, j);
                let saddle = c[0] == c[2] && c[1] == c[3];
                let joined = saddle && {
                    let m = grid.node(i, j);
                    self.interferes(m[0] + 0.5 * step, m[1] + 0.5 * step, z)
                };
                for k in 0..4 {
                    if !c[k] || c[(k + 1) % 4] {
                        continue;
                    }
                    // Pair the edge leaving the inside with the one entering it.
                    let to = if saddle {
                        if joined { (k + 1) % 4 } else { (k + 3) % 4 }
                    } else {
                        (1..4).map(|d| (k + d) % 4).find(|&m| !c[m] && c[(m + 1) % 4]).unwrap_or(k)
                    };
                    let (a, b) = (slot(e[k]), slot(e[to]));
                    if a < next.len() && b < next.len() {
                        next[a] = b;
                    }
                }
            }
        }
        Ok(chain(&next, &points, z))
    }

    /// The interference test at every grid node, row by row in parallel.
    fn sample(&self, grid: &Grid, z: f64) -> Vec<bool> {
        let mut inside = vec![false; grid.nx * grid.ny];
        inside.par_chunks_mut(grid.nx).enumerate().for_each(|(j, row)| {
            for (i, v) in row.iter_mut().enumerate() {
                let p = grid.node(i, j);
                *v = self.interferes(p[0], p[1], z);
            }
        });
        inside
    }

    /// The point between `a` and `b` (where the test gives `a_in` and its negation) where
    /// the test changes, to `tol`.
    fn boundary(&self, a: [f64; 2], b: [f64; 2], a_in: bool, z: f64, tol: f64) -> [f64; 2] {
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        let at = |s: f64| [a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])];
        while (hi - lo) * len > tol && hi - lo > f64::EPSILON {
            let mid = 0.5 * (lo + hi);
            let p = at(mid);
            if self.interferes(p[0], p[1], z) == a_in {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        at(0.5 * (lo + hi))
    }
}

/// Follows the successor links `next` into closed loops of `points`, each started at its
/// lowest unvisited slot; open chains (which a consistent grid does not make) are dropped.
fn chain(next: &[usize], points: &[[f64; 2]], z: f64) -> Vec<Vec<Point3>> {
    let mut seen = vec![false; next.len()];
    let mut loops = Vec::new();
    for start in 0..next.len() {
        if seen[start] {
            continue;
        }
        let mut ring = Vec::new();
        let mut k = start;
        let closed = loop {
            if k >= next.len() || seen[k] {
                break k == start;
            }
            seen[k] = true;
            ring.push(Point3::new(points[k][0], points[k][1], z));
            k = next[k];
        };
        if closed && ring.len() >= 3 {
            loops.push(ring);
        }
    }
    loops
}
