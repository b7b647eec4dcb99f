//! The stock-removal term of orientation selection: which of the stock's material (the
//! stock less the part) the setups can cut away, and a change of setups when visibility
//! alone leaves much of it uncut.
//!
//! Visibility (seed 000 §3.1) chooses setups that *see* the part's surface; a setup's
//! layers then cut from the stock's top down to the part's lowest point along its tool
//! axis. Material below that level, or under the part, stays. On a flat part in a cube of
//! stock two setups (a side and the top, say) see every face, yet the slab under the part
//! on the side's far face is never cut: the residual is five times the part. This term
//! samples the stock's material on a grid and counts a sample as *removable* from tool
//! axis `v` when it lies at or above the part's lowest point along `v` and the ray from
//! it along `+v` meets no part: a straight tool along `-v` reaches it with the layers
//! that setup cuts, and, with a [`ToolReach`], lies no deeper than the tools reach below
//! the stock's top along `v`.

use rayon::prelude::*;
use s2g_geom::{Aabb, MeshIndex, Point3, Real, UnitVector3};

use crate::error::Result;
use crate::tool_reach::ToolReach;
use crate::visibility::{VisibilityMatrix, words_for};

/// Options of the stock-removal term ([`OrientOptions::stock_removal`](crate::OrientOptions::stock_removal)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StockRemovalOptions {
    /// The setups are changed only when the stock samples they leave uncut (but some
    /// candidate direction could cut) exceed this fraction of the samples inside the
    /// part, i.e. when the stock left would cost more than about this fraction of IoU.
    /// Default `0.005`.
    pub max_left: Real,
}

impl Default for StockRemovalOptions {
    fn default() -> Self {
        Self { max_left: 0.005 }
    }
}

/// What the stock-removal term found ([`OrientationResult::stock`](crate::OrientationResult::stock)).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StockRemovalReport {
    /// Stock samples outside the part.
    pub material: usize,
    /// Stock samples inside the part (its volume on the sampling grid).
    pub part: usize,
    /// Material samples that no candidate direction can remove.
    pub unreachable: usize,
    /// Material samples the setups chosen by visibility alone leave.
    pub left_by_visibility: usize,
    /// Material samples the final setups leave.
    pub left: usize,
    /// Whether the setups were changed for the stock.
    pub changed: bool,
}

/// Cell centres of a grid of about `count` cubic cells over `bounds`, those for which
/// `inside` holds, in x-fastest order: the stock samples of
/// [`select_orientations_in_stock`](crate::select_orientations_in_stock). Empty for an
/// empty or degenerate box.
pub fn stock_grid_points(bounds: &Aabb, count: usize, inside: impl Fn(&Point3) -> bool) -> Vec<Point3> {
    let e = bounds.extent();
    let volume = e.x * e.y * e.z;
    if !(volume.is_finite() && volume > 0.0) || count == 0 {
        return Vec::new();
    }
    let cell = (volume / count as Real).cbrt();
    let n = |a: Real| ((a / cell).round() as usize).max(1);
    let (nx, ny, nz) = (n(e.x), n(e.y), n(e.z));
    let mut out = Vec::with_capacity(nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = Point3::new(
                    bounds.min.x + (i as Real + 0.5) * e.x / nx as Real,
                    bounds.min.y + (j as Real + 0.5) * e.y / ny as Real,
                    bounds.min.z + (k as Real + 0.5) * e.z / nz as Real,
                );
                if inside(&p) {
                    out.push(p);
                }
            }
        }
    }
    out
}

/// The stock's material samples and what each direction removes of them.
pub(crate) struct StockSamples<'a> {
    index: &'a MeshIndex,
    /// Samples outside the part.
    material: Vec<Point3>,
    /// Samples inside the part.
    part: usize,
    vertices: &'a [Point3],
    /// Rays stop this far past the part's support plane.
    eps: Real,
    /// How deep the tools reach below the stock's top.
    reach: Option<ToolReach>,
}

impl<'a> StockSamples<'a> {
    /// Splits `points` into the part's and the material's.
    pub(crate) fn new(
        index: &'a MeshIndex,
        vertices: &'a [Point3],
        points: &[Point3],
        diag: Real,
        reach: Option<ToolReach>,
    ) -> Self {
        let inside = index.par_contains(points);
        let material: Vec<Point3> =
            points.iter().zip(&inside).filter(|(_, i)| !**i).map(|(p, _)| *p).collect();
        let part = points.len() - material.len();
        Self { index, material, part, vertices, eps: 1e-9 * diag, reach }
    }

    pub(crate) fn material(&self) -> usize {
        self.material.len()
    }

    pub(crate) fn part(&self) -> usize {
        self.part
    }

    /// Which material samples tool axis `v` removes, as a bitset.
    pub(crate) fn row(&self, v: &UnitVector3) -> Vec<u64> {
        let (lo, hi) = self
            .vertices
            .iter()
            .map(|p| v.dot(&p.coords))
            .fold((Real::INFINITY, Real::NEG_INFINITY), |(a, b), h| (a.min(h), b.max(h)));
        // Below the tools' reach nothing is removed either.
        let lo = lo.max(self.reach.map_or(Real::NEG_INFINITY, |r| r.floor(&v.into_inner())));
        let mut out = vec![0u64; words_for(self.material.len())];
        out.par_chunks_mut(8).enumerate().for_each(|(c, chunk)| {
            for (w, word) in chunk.iter_mut().enumerate() {
                let base = (c * 8 + w) * 64;
                for (b, p) in self.material.iter().skip(base).take(64).enumerate() {
                    let h = v.dot(&p.coords);
                    // The setup's layers stop at the part's lowest point along `v`; above
                    // the part's highest one nothing blocks the tool.
                    let removable = h >= lo - self.eps
                        && (h > hi || !self.index.ray_hits_any(p, &v.into_inner(), hi - h + self.eps));
                    if removable {
                        *word |= 1 << b;
                    }
                }
            }
        });
        out
    }

    /// The removal matrix over `dirs`.
    pub(crate) fn matrix(&self, dirs: &[UnitVector3]) -> Result<VisibilityMatrix> {
        let rows = dirs.iter().map(|v| (*v, self.row(v))).collect();
        VisibilityMatrix::from_rows(self.material.len(), rows)
    }
}

/// Material samples left by `set` of removal matrix `r`.
pub(crate) fn left(r: &VisibilityMatrix, set: &[usize]) -> usize {
    r.points() - r.covered(set)
}

/// Changes `chosen` (indices into `m` and `r`, which share their directions) so that the
/// setups leave at most `allowed` removable material samples where visibility alone left
/// more: repeatedly takes the single swap of one direction for another candidate, or the
/// addition of one (while fewer than `max_setups`), that leaves the least material,
/// fewer setups and then more coverage breaking ties, among the sets that keep at least
/// `floor` samples covered; stops when nothing leaves less. Deterministic: ties go to
/// the first set tried.
pub(crate) fn improve_for_stock(
    m: &VisibilityMatrix,
    r: &VisibilityMatrix,
    chosen: &[usize],
    max_setups: usize,
    floor: usize,
    allowed: usize,
) -> Vec<usize> {
    let unreachable = left(r, &(0..r.len()).collect::<Vec<_>>());
    let excess = |set: &[usize]| (left(r, set) - unreachable).saturating_sub(allowed);
    let mut best = chosen.to_vec();
    let mut best_excess = excess(&best);
    while best_excess > 0 {
        let mut trials: Vec<Vec<usize>> = Vec::new();
        for pos in 0..best.len() {
            for d in (0..m.len()).filter(|d| !best.contains(d)) {
                let mut t = best.clone();
                t[pos] = d;
                trials.push(t);
            }
        }
        if best.len() < max_setups {
            for d in (0..m.len()).filter(|d| !best.contains(d)) {
                let mut t = best.clone();
                t.push(d);
                trials.push(t);
            }
        }
        let found = trials
            .par_iter()
            .enumerate()
            .filter_map(|(i, t)| {
                let covered = m.covered(t);
                (covered >= floor).then(|| ((excess(t), t.len(), usize::MAX - covered, i), i))
            })
            .min_by_key(|(key, _)| *key);
        match found {
            Some(((e, ..), i)) if e < best_excess => {
                best = trials.swap_remove(i);
                best_excess = e;
            }
            _ => break,
        }
    }
    best
}
