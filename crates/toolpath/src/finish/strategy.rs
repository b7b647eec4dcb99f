//! Finishing strategies behind one trait ([`FinishingStrategy`]): parallel (raster at an
//! angle), waterline (constant-Z loops on steep walls) and steep-and-shallow (split by the
//! slope of the cutter-location surface, with overlap).

// NaN-aware negated comparisons (`!(x > 0.0)`) are deliberate: NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;
use s2g_geom::{Cutter, DropCutter, Point3, WaterlineOptions};

use super::parallel::{Keep, parallel_finish_until};
use super::{FillOptions, FinishError, ParallelFinishOptions, stepover_for_scallop};

/// What a finishing strategy plans over: a drop-cutter over the part in the setup frame
/// (tool axis +Z), the XY rectangle to finish, and the scallop height allowed.
#[derive(Debug, Clone, Copy)]
pub struct FinishContext<'a> {
    /// The finishing cutter over the part, in the setup frame.
    pub drop_cutter: &'a DropCutter<'a>,
    /// The finishing cutter (the one `drop_cutter` was built with).
    pub cutter: &'a Cutter,
    /// Lower XY corner of the region to finish (tool-centre positions).
    pub min: [f64; 2],
    /// Upper XY corner of the region to finish.
    pub max: [f64; 2],
    /// Tip heights range `[low, high]` to finish: waterline levels lie in it and parallel
    /// points below `low` are left out.
    pub z_range: [f64; 2],
    /// The scallop height allowed, in mesh units (mm).
    pub scallop: f64,
    /// Set (by another thread) to stop the planning early: the strategies look at it
    /// between passes and levels and then fail with [`FinishError::Cancelled`]. `None`:
    /// never stopped.
    pub cancel: Option<&'a AtomicBool>,
}

impl FinishContext<'_> {
    /// Whether [`FinishContext::cancel`] is set.
    pub fn cancelled(&self) -> bool {
        self.cancel.is_some_and(|c| c.load(Ordering::Relaxed))
    }
}

/// A finishing strategy: cutter-location polylines (tool-tip points on the drop-cutter
/// surface, setup frame) for a setup. Two required methods, [`name`](Self::name) and
/// [`paths`](Self::paths). Every point returned must be a gouge-free tip position (at or
/// above the drop-cutter height there); the segments between points are chords of the
/// cutter-location surface, within the strategy's sampling tolerance of it.
pub trait FinishingStrategy: Send + Sync + std::fmt::Debug {
    /// The strategy's name (`parallel`, `waterline`, `steep-shallow`).
    fn name(&self) -> &str;

    /// The passes, in machining order; a closed loop repeats its first point at the end.
    fn paths(&self, ctx: &FinishContext<'_>) -> Result<Vec<Vec<Point3>>, FinishError>;
}

/// Parallel (raster) finishing along an angle, the drop-cutter surface sampled adaptively
/// (see `parallel_finish_opt`), with the stepover from the scallop height on a plane of
/// [`Parallel::design_slope`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parallel {
    /// Direction of the passes in radians from +X. Default `0`.
    pub angle: f64,
    /// The slope (radians, across the passes) the stepover is computed for: the scallop is
    /// at most the target on planes up to this slope. Default `0` (horizontal).
    pub design_slope: f64,
    /// First sampling step along a pass. Default `0.5`.
    pub sample_step: f64,
    /// Chord tolerance of the adaptive sampling (Z distance). Default `0.002`.
    pub tolerance: f64,
    /// Fill passes ([`FillOptions`], ball cutters) where two passes leave more than this
    /// multiple of the target on the part between them, two halvings deep; `0`: none. Default
    /// `1.5`: the pass lift and the arc fit ride up to 0.007 mm above the
    /// cutter-location points, so a predicted 0.015 mm stays under the target plus 0.02 mm.
    pub fill: f64,
}

impl Default for Parallel {
    fn default() -> Self {
        Self { angle: 0.0, design_slope: 0.0, sample_step: 0.5, tolerance: 0.002, fill: 1.5 }
    }
}

impl Parallel {
    /// The stepover this strategy uses for `cutter` and `scallop`.
    pub fn stepover(&self, cutter: &Cutter, scallop: f64) -> Result<f64, FinishError> {
        stepover_for_scallop(cutter, scallop, self.design_slope)
    }

    fn raw_paths(&self, ctx: &FinishContext<'_>) -> Result<Vec<Vec<Point3>>, FinishError> {
        self.raw_paths_at(ctx, self.stepover(ctx.cutter, ctx.scallop)?, None)
    }

    /// The passes `stepover` apart, cut below the floor; with `kept`, the gaps fill-checked
    /// only near the points it accepts (`parallel_finish_until`).
    fn raw_paths_at(
        &self,
        ctx: &FinishContext<'_>,
        stepover: f64,
        kept: Option<Keep<'_>>,
    ) -> Result<Vec<Vec<Point3>>, FinishError> {
        let opts = ParallelFinishOptions {
            angle: self.angle,
            stepover,
            sample_step: self.sample_step,
            tolerance: self.tolerance,
            min_step: (0.05 * self.sample_step).min(0.02),
            zigzag: true,
            floor: None,
            // A ball's contact normal gives the point the check follows; other cutters get none.
            fill: (self.fill > 0.0 && ctx.cutter.corner_radius() >= ctx.cutter.radius * (1.0 - 1e-9))
                .then_some(FillOptions {
                    radius: ctx.cutter.radius,
                    limit: self.fill * ctx.scallop,
                    depth: 2,
                }),
        };
        let runs = parallel_finish_until(ctx.drop_cutter, ctx.min, ctx.max, &opts, ctx.cancel, kept)?;
        Ok(split_at_floor(ctx.drop_cutter, runs, ctx.z_range[0]))
    }
}

impl FinishingStrategy for Parallel {
    fn name(&self) -> &str {
        "parallel"
    }

    fn paths(&self, ctx: &FinishContext<'_>) -> Result<Vec<Vec<Point3>>, FinishError> {
        self.raw_paths(ctx)
    }
}

/// Waterline finishing: the constant-Z loops of the cutter-location surface
/// (`DropCutter::waterline`, each point moved out by twice the tolerance so that it is
/// clear), top down, at a Z step that keeps the scallop under the target
/// on walls at least [`Waterline::min_slope`] steep: on a plane at slope `a`, passes `dz`
/// apart in Z are `dz / tan(a)` apart horizontally, so `dz = stepover_for_scallop(a) tan(a)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Waterline {
    /// The shallowest wall (radians from horizontal) the Z step is computed for; shallower
    /// walls get taller scallops. Default 50 degrees.
    pub min_slope: f64,
    /// Sampling grid step of the waterline loops. Default `0.5`.
    pub step: f64,
    /// Accuracy of each loop point. Default `1e-4`.
    pub tolerance: f64,
    /// The most Z levels (an error beyond). Default `100_000`.
    pub max_levels: usize,
}

impl Default for Waterline {
    fn default() -> Self {
        Self { min_slope: 50f64.to_radians(), step: 0.5, tolerance: 1e-4, max_levels: 100_000 }
    }
}

impl Waterline {
    /// The Z step between levels for `cutter` and `scallop`.
    pub fn z_step(&self, cutter: &Cutter, scallop: f64) -> Result<f64, FinishError> {
        let a = self.min_slope;
        if !(a > 0.0 && a < std::f64::consts::FRAC_PI_2) {
            return Err(FinishError::InvalidOptions(format!(
                "min_slope must be in (0, 90) degrees, got {a} rad"
            )));
        }
        Ok(stepover_for_scallop(cutter, scallop, a)? * a.tan())
    }

    /// The levels, top down: the highest one `z_step` below the top of the range, the
    /// lowest at the bottom of the range.
    fn levels(&self, ctx: &FinishContext<'_>) -> Result<Vec<f64>, FinishError> {
        let dz = self.z_step(ctx.cutter, ctx.scallop)?;
        let [lo, hi] = ctx.z_range;
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(FinishError::InvalidOptions(format!(
                "z range must be finite and ordered, got {lo} .. {hi}"
            )));
        }
        let n = ((hi - lo) / dz).ceil().max(1.0);
        if n > self.max_levels as f64 {
            return Err(FinishError::InvalidOptions(format!(
                "{n} waterline levels, more than {}",
                self.max_levels
            )));
        }
        let n = n as usize;
        Ok((0..n).map(|k| hi - (hi - lo) * (k + 1) as f64 / n as f64).collect())
    }

    fn loops(&self, ctx: &FinishContext<'_>) -> Result<Vec<Vec<Point3>>, FinishError> {
        let levels = self.levels(ctx)?;
        let opts = WaterlineOptions { step: self.step, tolerance: self.tolerance, ..Default::default() };
        let per_level: Result<Vec<_>, _> = levels
            .par_iter()
            .map(|&z| match ctx.cancelled() {
                true => Ok(Vec::new()),
                false => ctx.drop_cutter.waterline_opt(z, &opts).map_err(FinishError::Geometry),
            })
            .collect();
        if ctx.cancelled() {
            return Err(FinishError::Cancelled);
        }
        let (min, max) = (ctx.min, ctx.max);
        let inside = |p: &Point3| p.x >= min[0] && p.x <= max[0] && p.y >= min[1] && p.y <= max[1];
        let mut out = Vec::new();
        let rings: Vec<Vec<Point3>> = per_level?
            .into_par_iter()
            .flatten()
            .map(|ring| {
                let mut ring = outward(&ring, 2.0 * self.tolerance);
                if let Some(&first) = ring.first() {
                    ring.push(first);
                }
                clear_chords(ctx.drop_cutter, &ring, 2.0 * self.tolerance)
            })
            .collect();
        for ring in rings {
            out.extend(split_runs(vec![ring], inside));
        }
        Ok(out)
    }
}

impl FinishingStrategy for Waterline {
    fn name(&self) -> &str {
        "waterline"
    }

    fn paths(&self, ctx: &FinishContext<'_>) -> Result<Vec<Vec<Point3>>, FinishError> {
        self.loops(ctx)
    }
}

/// Steep-and-shallow finishing: waterline where the cutter-location surface is steeper
/// than [`SteepShallow::threshold`], parallel where it is shallower, the two overlapping
/// by [`SteepShallow::overlap`] in slope (waterline keeps points steeper than `threshold -
/// overlap`, parallel points shallower than `threshold + overlap`). The slope at a point is
/// that of the drop-cutter surface, by central differences [`SteepShallow::slope_step`]
/// apart. Waterline passes come first, then the parallel ones.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteepShallow {
    /// The slope (radians from horizontal) that separates steep from shallow. Default 50
    /// degrees.
    pub threshold: f64,
    /// Overlap of the two in slope (radians). Default 5 degrees.
    pub overlap: f64,
    /// The parallel part (its `design_slope` is replaced by `threshold + overlap`).
    pub parallel: Parallel,
    /// The waterline part (its `min_slope` is replaced by `threshold - overlap`).
    pub waterline: Waterline,
    /// Finite-difference step of the slope estimate. Default `0.05`.
    pub slope_step: f64,
}

impl Default for SteepShallow {
    fn default() -> Self {
        Self {
            threshold: 50f64.to_radians(),
            overlap: 5f64.to_radians(),
            parallel: Parallel::default(),
            waterline: Waterline::default(),
            slope_step: 0.05,
        }
    }
}

/// Crossed parallel finishing: raster passes along several directions (`directions` of
/// them, evenly spread over 180 degrees from [`Parallel::angle`]), each machined where its
/// passes lie closest together on the surface. Passes along `d`, `stepover` apart across
/// it, lie `stepover / sqrt(1 - (n . p)^2)` apart on a surface of unit normal `n` (`p` the
/// horizontal unit vector across the passes): as tight as on flat ground where the surface
/// slopes along the passes, however steep, and ever wider where it slopes across them. So
/// a point goes to the direction whose `|n . p|` is least (to every direction within
/// [`Crossed::overlap`] of it, so that the regions overlap), except where the first
/// direction already spaces it within the design slope's factor. The first direction's
/// stepover is set for [`Parallel::design_slope`] (default 0: flat ground) and the others
/// share it; with two directions a steep wall facing halfway between them sees passes
/// `sqrt(2)` times the flat stepover apart (twice the scallop height), with three
/// `2 / sqrt(3)` times. The normal is a ball's contact normal
/// (`DropCutter::contact_normal`); for other cutters the drop-cutter surface's, by central
/// differences [`Crossed::slope_step`] apart, and where a neighbour finds no contact (the
/// part's outline) the first direction keeps the point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossed {
    /// The passes of every direction; `angle` is the first direction's.
    pub parallel: Parallel,
    /// Number of raster directions, at least 1. Default `2`.
    pub directions: usize,
    /// Overlap of the directions' regions, in `|n . p|`. Default `0.05`.
    pub overlap: f64,
    /// Finite-difference step of the normal estimate. Default `0.05`.
    pub slope_step: f64,
    /// A run of points another direction takes, shorter than this along a pass between
    /// two this one keeps, is kept too (cut twice rather than entered twice). Default `5`.
    pub max_gap: f64,
    /// Fill-check a direction's gaps only near the points it keeps (within four sampling
    /// steps along its passes) and over every fill stretch that reaches there, whole
    /// (`parallel_finish_until`), rather than over the whole part: the same passes
    /// wherever no fill stretch wholly away from the kept points of both its passes holds
    /// a point the direction keeps. Default `true`.
    pub narrow_fills: bool,
}

impl Default for Crossed {
    fn default() -> Self {
        Self {
            parallel: Parallel::default(),
            directions: 2,
            overlap: 0.05,
            slope_step: 0.05,
            max_gap: 5.0,
            narrow_fills: true,
        }
    }
}

/// The drop-cutter surface's unit normal at `(x, y)` by central differences `e` apart;
/// `None` where a neighbour is not touched.
fn cl_normal(dc: &DropCutter<'_>, x: f64, y: f64, e: f64) -> Option<[f64; 3]> {
    let gx = (dc.height(x + e, y)? - dc.height(x - e, y)?) / (2.0 * e);
    let gy = (dc.height(x, y + e)? - dc.height(x, y - e)?) / (2.0 * e);
    let l = (gx * gx + gy * gy + 1.0).sqrt();
    Some([-gx / l, -gy / l, 1.0 / l])
}

impl FinishingStrategy for Crossed {
    fn name(&self) -> &str {
        "crossed"
    }

    fn paths(&self, ctx: &FinishContext<'_>) -> Result<Vec<Vec<Point3>>, FinishError> {
        let k = self.directions;
        let (o, e) = (self.overlap, self.slope_step);
        if !((1..=12).contains(&k) && o.is_finite() && o >= 0.0 && e.is_finite() && e > 0.0) {
            return Err(FinishError::InvalidOptions(format!(
                "crossed needs 1 to 12 directions, an overlap >= 0 and a positive slope step, got {k}, {o}, {e}"
            )));
        }
        let d = self.parallel.design_slope;
        if !(d.is_finite() && (0.0..std::f64::consts::FRAC_PI_2).contains(&d)) {
            return Err(FinishError::InvalidOptions(format!(
                "design slope must be in [0, 90) degrees, got {d}"
            )));
        }
        let stepover = self.parallel.stepover(ctx.cutter, ctx.scallop)?;
        // Within this `|n . p|` the first direction spaces the surface within the design.
        let easy = d.sin();
        let across: Vec<[f64; 2]> = (0..k)
            .map(|i| {
                let a = self.parallel.angle + std::f64::consts::PI * i as f64 / k as f64;
                [-a.sin(), a.cos()]
            })
            .collect();
        let dc = ctx.drop_cutter;
        let mut out = Vec::new();
        for (i, p) in across.iter().enumerate() {
            if ctx.cancelled() {
                return Err(FinishError::Cancelled);
            }
            let par = Parallel {
                angle: self.parallel.angle + std::f64::consts::PI * i as f64 / k as f64,
                ..self.parallel
            };
            let keep =
                |q: &Point3| match dc.contact_normal(q.x, q.y, q.z).or_else(|| cl_normal(dc, q.x, q.y, e)) {
                    None => i == 0,
                    Some(n) => {
                        let dot = |v: &[f64; 2]| (n[0] * v[0] + n[1] * v[1]).abs();
                        let first = dot(&across[0]);
                        if first <= easy {
                            return i == 0;
                        }
                        let least = across.iter().map(dot).fold(f64::INFINITY, f64::min);
                        dot(p) <= least + o
                    }
                };
            let paths = par.raw_paths_at(ctx, stepover, self.narrow_fills.then_some(&keep))?;
            out.extend(split_par(paths, keep, self.max_gap, 0.0));
        }
        Ok(out)
    }
}

/// The slope (radians) of the drop-cutter surface at `(x, y)`; `None` where a neighbour
/// is not touched (an edge of the part: treated as steep).
pub fn cl_slope(dc: &DropCutter<'_>, x: f64, y: f64, e: f64) -> Option<f64> {
    let gx = dc.height(x + e, y)? - dc.height(x - e, y)?;
    let gy = dc.height(x, y + e)? - dc.height(x, y - e)?;
    Some((gx.hypot(gy) / (2.0 * e)).atan())
}

impl FinishingStrategy for SteepShallow {
    fn name(&self) -> &str {
        "steep-shallow"
    }

    fn paths(&self, ctx: &FinishContext<'_>) -> Result<Vec<Vec<Point3>>, FinishError> {
        let (t, o, e) = (self.threshold, self.overlap, self.slope_step);
        if !(t > o && o >= 0.0 && t + o < std::f64::consts::FRAC_PI_2 && e.is_finite() && e > 0.0) {
            return Err(FinishError::InvalidOptions(format!(
                "steep-shallow needs 0 <= overlap < threshold < 90 degrees - overlap and a positive slope step, got {t}, {o}, {e}"
            )));
        }
        let dc = ctx.drop_cutter;
        let wl = Waterline { min_slope: t - o, ..self.waterline };
        let steep = |p: &Point3| cl_slope(dc, p.x, p.y, e).is_none_or(|a| a >= t - o);
        let mut out = split_par(wl.loops(ctx)?, steep, 0.0, 0.0);
        let par = Parallel { design_slope: t + o, ..self.parallel };
        let shallow = |p: &Point3| cl_slope(dc, p.x, p.y, e).is_some_and(|a| a <= t + o);
        out.extend(split_par(par.raw_paths(ctx)?, shallow, 0.0, 0.0));
        Ok(out)
    }
}

/// Spacing of the interference checks along a loop's chords.
const CHORD_CHECK: f64 = 0.05;

/// Whether the cutter with its tip anywhere on the chord `a`-`b` (one height) is clear of
/// the part, checked at points [`CHORD_CHECK`] apart.
fn chord_clear(dc: &DropCutter<'_>, a: &Point3, b: &Point3) -> bool {
    let d = b - a;
    let n = ((d.norm() / CHORD_CHECK).ceil().min(1e6) as usize).max(1);
    (1..n).all(|k| {
        let p = a + d * (k as f64 / n as f64);
        !dc.interferes(p.x, p.y, p.z)
    })
}

/// The point of the loop's contour beside the chord `a`-`b` at its middle: the midpoint
/// moved to its right (out of the cutter's interference region, the cutter cutting on
/// its left) just far enough to be clear, by bisection, plus `margin`; `None` where no
/// clear point lies within a cutter radius.
fn contour_beside(dc: &DropCutter<'_>, a: &Point3, b: &Point3, margin: f64) -> Option<Point3> {
    let t = (b - a).xy();
    let l = t.norm();
    if !(l > 0.0) {
        return None;
    }
    let n = [t.y / l, -t.x / l];
    let m = a + (b - a) * 0.5;
    let at = |s: f64| Point3::new(m.x + s * n[0], m.y + s * n[1], m.z);
    let blocked = |s: f64| {
        let p = at(s);
        dc.interferes(p.x, p.y, p.z)
    };
    let (mut lo, mut hi) = (0.0, margin.max(1e-6));
    while blocked(hi) {
        lo = hi;
        hi *= 2.0;
        if hi > dc.radius() {
            return None;
        }
    }
    for _ in 0..40 {
        if hi - lo <= 0.25 * margin {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if blocked(mid) { lo = mid } else { hi = mid }
    }
    Some(at(hi + margin))
}

/// `ring` (a closed waterline loop, first point repeated at the end) with points of the
/// contour inserted where a chord between two of its points would cut into the part (on
/// a convex bend of the contour the chord runs inside it, by its sagitta; across a kink
/// the grid smoothed, by more): each such chord is split at the contour point beside its
/// middle, to a depth of eight halvings, so that the emitter can feed along the loop
/// instead of lifting over, or retracting at, every such chord.
fn clear_chords(dc: &DropCutter<'_>, ring: &[Point3], margin: f64) -> Vec<Point3> {
    fn split(dc: &DropCutter<'_>, a: Point3, b: Point3, margin: f64, depth: u32, out: &mut Vec<Point3>) {
        if depth == 0 || chord_clear(dc, &a, &b) {
            return;
        }
        let Some(m) = contour_beside(dc, &a, &b, margin) else { return };
        split(dc, a, m, margin, depth - 1, out);
        out.push(m);
        split(dc, m, b, margin, depth - 1, out);
    }
    let mut out = Vec::with_capacity(ring.len());
    for w in ring.windows(2) {
        out.push(w[0]);
        split(dc, w[0], w[1], margin, 8, &mut out);
    }
    if let Some(&last) = ring.last() {
        out.push(last);
    }
    out
}

/// A closed loop (the cutter cuts on its left) moved `d` to its right, out of the
/// interference region: its points are on the contour only within the bisection
/// tolerance, on either side, and this puts them (and chords along straight walls) on the
/// clear side.
fn outward(ring: &[Point3], d: f64) -> Vec<Point3> {
    let n = ring.len();
    (0..n)
        .map(|i| {
            let (a, b) = (ring[(i + n - 1) % n], ring[(i + 1) % n]);
            let t = (b - a).xy();
            let l = t.norm();
            let p = ring[i];
            if !(l > 0.0) {
                return p;
            }
            Point3::new(p.x + d * t.y / l, p.y - d * t.x / l, p.z)
        })
        .collect()
}

/// [`split_runs`] with the predicate evaluated in parallel, every accepted point's
/// neighbours accepted with it, and every point within `grow` (in XY) of an accepted
/// point of any path accepted too (`0`: none); a run of rejected points shorter than
/// `gap` (along the path) between accepted ones is accepted too.
pub(super) fn split_par(
    paths: Vec<Vec<Point3>>,
    keep: impl Fn(&Point3) -> bool + Sync,
    gap: f64,
    grow: f64,
) -> Vec<Vec<Point3>> {
    let flags: Vec<Vec<bool>> = paths.par_iter().map(|p| p.iter().map(&keep).collect()).collect();
    let flags = grown(&paths, flags, grow);
    paths
        .into_par_iter()
        .zip(flags)
        .map(|(p, flags)| {
            // Each kept point takes its neighbours along: the chords to them run over the
            // surface it stands for (a narrow region a pass crosses in one point is cut,
            // and neighbouring regions overlap by a chord).
            let mut flags: Vec<bool> = (0..flags.len())
                .map(|i| flags[i] || (i > 0 && flags[i - 1]) || flags.get(i + 1).copied().unwrap_or(false))
                .collect();
            fill_gaps(&p, &mut flags, gap);
            let mut k = flags.into_iter();
            split_runs(vec![p], |_| k.next().unwrap_or(false))
        })
        .collect::<Vec<_>>()
        .into_iter()
        .flatten()
        .collect()
}

/// `flags` (one per point of `paths`) with every point within `r` in XY of a flagged
/// point flagged as well: a region kept on one pass and left out on the next one is cut
/// by the passes on both sides of its edge, as inside it, rather than by one (whose
/// neighbour across, left out, would leave twice the stepover's scallop along the edge).
fn grown(paths: &[Vec<Point3>], flags: Vec<Vec<bool>>, r: f64) -> Vec<Vec<bool>> {
    if !(r > 0.0 && r.is_finite()) {
        return flags;
    }
    let cell = |p: &Point3| ((p.x / r).floor() as i64, (p.y / r).floor() as i64);
    let mut grid: std::collections::HashMap<(i64, i64), Vec<[f64; 2]>> = std::collections::HashMap::new();
    for (p, f) in paths.iter().zip(&flags) {
        for (q, _) in p.iter().zip(f).filter(|(_, f)| **f) {
            grid.entry(cell(q)).or_default().push([q.x, q.y]);
        }
    }
    let near = |q: &Point3| {
        let (i, j) = cell(q);
        (i - 1..=i + 1).any(|a| {
            (j - 1..=j + 1).any(|b| {
                grid.get(&(a, b)).is_some_and(|v| v.iter().any(|c| (c[0] - q.x).hypot(c[1] - q.y) <= r))
            })
        })
    };
    paths.par_iter().zip(flags).map(|(p, f)| p.iter().zip(f).map(|(q, f)| f || near(q)).collect()).collect()
}

/// Sets the flags of every run of cleared flags shorter than `gap` along `path` that has
/// set flags on both sides.
fn fill_gaps(path: &[Point3], flags: &mut [bool], gap: f64) {
    if !(gap > 0.0) {
        return;
    }
    let mut i = 0;
    while i < flags.len() {
        if flags[i] {
            i += 1;
            continue;
        }
        let start = i;
        while i < flags.len() && !flags[i] {
            i += 1;
        }
        // Points start..i are rejected; the gap runs from start - 1 to i.
        if start > 0 && i < flags.len() {
            let len: f64 = path[start - 1..=i].windows(2).map(|w| (w[1] - w[0]).norm()).sum();
            if len < gap {
                flags[start..i].iter_mut().for_each(|f| *f = true);
            }
        }
    }
}

/// The runs of each pass at or above `floor`, each run carried on to where the
/// cutter-location surface crosses the floor between its last point and the next one
/// (by bisection on the drop-cutter over the chord's XY line, to 1e-4 of its length, on
/// the side at or above the floor), and likewise back from its first point: on a steep
/// wall points a sampling step apart lie far apart in Z, and a run cut at its last point
/// above the floor would leave the wall unfinished down to it.
fn split_at_floor(dc: &DropCutter<'_>, paths: Vec<Vec<Point3>>, floor: f64) -> Vec<Vec<Point3>> {
    // The point between `above` (at or above the floor) and `below` where the surface
    // crosses the floor, at or above it; `None` where the drop-cutter finds no contact.
    let crossing = |above: &Point3, below: &Point3| -> Option<Point3> {
        let at = |t: f64| {
            let (x, y) = (above.x + (below.x - above.x) * t, above.y + (below.y - above.y) * t);
            dc.height(x, y).map(|z| Point3::new(x, y, z))
        };
        let (mut lo, mut hi) = (0.0, 1.0);
        let mut best = *above;
        while hi - lo > 1e-4 {
            let mid = 0.5 * (lo + hi);
            match at(mid) {
                Some(p) if p.z >= floor => {
                    (lo, best) = (mid, p);
                }
                Some(_) => hi = mid,
                None => return None,
            }
        }
        (lo > 0.0).then_some(best)
    };
    let mut out = Vec::new();
    for path in paths {
        let mut run: Vec<Point3> = Vec::new();
        for (i, p) in path.iter().enumerate() {
            if p.z >= floor {
                if run.is_empty()
                    && i > 0
                    && let Some(c) = crossing(p, &path[i - 1])
                {
                    run.push(c);
                }
                run.push(*p);
                continue;
            }
            if let Some(last) = run.last()
                && let Some(c) = crossing(last, p)
            {
                run.push(c);
            }
            end_run(&mut run, &mut out);
        }
        end_run(&mut run, &mut out);
    }
    out
}

/// Ends the run of points `run`: moved into `out` as a path when it has at least two
/// points, else dropped; `run` is left empty.
pub(super) fn end_run(run: &mut Vec<Point3>, out: &mut Vec<Vec<Point3>>) {
    if run.len() >= 2 {
        out.push(std::mem::take(run));
    } else {
        run.clear();
    }
}

/// The runs of consecutive points that `keep` accepts, each of at least two points.
fn split_runs(paths: Vec<Vec<Point3>>, mut keep: impl FnMut(&Point3) -> bool) -> Vec<Vec<Point3>> {
    let mut out = Vec::new();
    for path in paths {
        let mut run = Vec::new();
        for p in path {
            if keep(&p) {
                run.push(p);
            } else {
                end_run(&mut run, &mut out);
            }
        }
        end_run(&mut run, &mut out);
    }
    out
}
