//! Parallel (raster) finishing: straight passes at an angle over an XY rectangle, the tip
//! height at each point from drop-cutter, sampled adaptively: a segment is split where the
//! drop-cutter height at its midpoint leaves the chord by more than the tolerance, so flat
//! areas stay coarse and curved ones get the points they need. With [`FillOptions`], a
//! pass is added midway between two neighbouring passes wherever the cross-section between
//! them predicts a scallop above a limit (a hollow of the surface between them, whose
//! scallop the flat-ground stepover does not bound), and again between it and each
//! neighbour, to a depth.

// NaN-aware negated comparisons (`!(x > 0.0)`) are deliberate: NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;
use s2g_geom::{DropCutter, Point3};

use super::FinishError;

/// Options of [`parallel_finish_opt`] (lengths in the mesh's units, mm for real parts).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParallelFinishOptions {
    /// Direction of the passes in radians from +X, counter-clockwise. Default `0`.
    pub angle: f64,
    /// Distance between neighbouring passes (see `stepover_for_scallop`). Default `0.5`.
    pub stepover: f64,
    /// Spacing of the first, uniform samples along a pass. Default `1.0`.
    pub sample_step: f64,
    /// Largest allowed distance in Z between the drop-cutter height at a segment's midpoint
    /// and the segment's chord; a segment above it is split. Default `0.005`.
    pub tolerance: f64,
    /// Segments no longer than this are not split. Default `0.02`.
    pub min_step: f64,
    /// Every other pass runs backwards (zigzag) rather than all in `angle`'s direction.
    /// Default `true`.
    pub zigzag: bool,
    /// The tip height where the cutter touches nothing: `None` (default) ends the polyline
    /// there and starts a new one where contact resumes; `Some(z)` uses `z`.
    pub floor: Option<f64>,
    /// Fill passes where the stepover leaves more than a limit ([`FillOptions`]); `None`
    /// (default): the passes `stepover` apart only.
    pub fill: Option<FillOptions>,
}

/// Fill passes of [`parallel_finish_opt`], for a ball cutter. Between two neighbouring
/// passes the cut is checked at every quarter of [`ParallelFinishOptions::sample_step`]
/// along them (closer where the drop-cutter heights at the checks rise or fall more than
/// that between two of them, so that on a wall steeper than one step crosses, up to 88
/// degrees and more, the checks stand at most that far apart in Z too), a quarter, half
/// and three quarters of the way across: the ball dropped
/// there touches the part at a point (its centre less the radius along the contact
/// normal), and the material the two passes leave on that point is its distance from the
/// nearer of the two passes' swept balls (the polylines of their centres, chords between
/// samples as machined) less the radius. Where that exceeds [`FillOptions::limit`], a pass midway between them is sampled (from a quarter of
/// the sampling step) over the stretch, grown by a sampling step each way, and the same
/// check runs between it and each neighbour, to [`FillOptions::depth`] halvings. On flat
/// ground the stepover for scallop `h` leaves `h` midway; a hollow of the surface between
/// the passes (concave across them, as a scanned surface's relief often is) leaves more,
/// and on a slope along the passes the ball touches the part far up the slope from its
/// tip, so the check follows the contact, not the tip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FillOptions {
    /// The ball's radius.
    pub radius: f64,
    /// The most material left on a contact point without a fill pass (mm).
    pub limit: f64,
    /// Halvings of a gap: 1 puts a pass midway, 2 also between it and each neighbour.
    pub depth: u32,
}

impl Default for ParallelFinishOptions {
    fn default() -> Self {
        Self {
            angle: 0.0,
            stepover: 0.5,
            sample_step: 1.0,
            tolerance: 0.005,
            min_step: 0.02,
            zigzag: true,
            floor: None,
            fill: None,
        }
    }
}

/// [`parallel_finish_opt`] with the default options.
pub fn parallel_finish(
    dc: &DropCutter<'_>,
    min: [f64; 2],
    max: [f64; 2],
) -> Result<Vec<Vec<Point3>>, FinishError> {
    parallel_finish_opt(dc, min, max, &ParallelFinishOptions::default())
}

/// One pass: points `origin + t dir` for `t` in `[t0, t1]`.
#[derive(Clone, Copy)]
struct Pass {
    origin: [f64; 2],
    dir: [f64; 2],
    t0: f64,
    t1: f64,
}

impl Pass {
    fn at(&self, t: f64) -> [f64; 2] {
        [self.origin[0] + t * self.dir[0], self.origin[1] + t * self.dir[1]]
    }
}

/// Cutter-location polylines of parallel finishing over the rectangle `[min, max]` (XY):
/// passes `stepover` apart along `angle`, centred on the rectangle, each clipped to it;
/// every point is a tool-tip position whose Z is the drop-cutter height there (or the
/// floor). Passes come in order across the rectangle, each split where the cutter touches
/// nothing (unless `floor` is set). The same input gives the same output, whatever the
/// number of threads. [`FinishError::InvalidOptions`] for a rectangle or option that is
/// not finite, a non-positive length, or more than ten million first samples.
pub fn parallel_finish_opt(
    dc: &DropCutter<'_>,
    min: [f64; 2],
    max: [f64; 2],
    opts: &ParallelFinishOptions,
) -> Result<Vec<Vec<Point3>>, FinishError> {
    parallel_finish_until(dc, min, max, opts, None, None)
}

/// A predicate on cutter-location points: those a caller keeps of the passes.
pub(super) type Keep<'a> = &'a (dyn Fn(&Point3) -> bool + Sync);

/// [`parallel_finish_opt`], stopped with [`FinishError::Cancelled`] once `cancel` is set
/// (looked at before each pass and each gap's fill check). With `kept` (the points a
/// caller keeps of the passes, the rest left out), a gap is fill-checked only near the
/// points of its two passes that `kept` accepts (within [`KEPT_REACH`] sampling steps
/// along them) and over every fill stretch that reaches there, whole: see
/// [`fill_between`].
pub(super) fn parallel_finish_until(
    dc: &DropCutter<'_>,
    min: [f64; 2],
    max: [f64; 2],
    opts: &ParallelFinishOptions,
    cancel: Option<&AtomicBool>,
    kept: Option<Keep<'_>>,
) -> Result<Vec<Vec<Point3>>, FinishError> {
    check(min, max, opts)?;
    let stop = || cancel.is_some_and(|c| c.load(Ordering::Relaxed));
    let (sin, cos) = opts.angle.sin_cos();
    let (dir, normal) = ([cos, sin], [-sin, cos]);
    let corners = [[min[0], min[1]], [max[0], min[1]], [max[0], max[1]], [min[0], max[1]]];
    let along = |p: &[f64; 2], v: [f64; 2]| p[0] * v[0] + p[1] * v[1];
    let (olo, ohi) = corners
        .iter()
        .map(|c| along(c, normal))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), o| (a.min(o), b.max(o)));
    let count = ((ohi - olo) / opts.stepover).floor() as usize + 1;
    let first = 0.5 * (olo + ohi) - 0.5 * (count - 1) as f64 * opts.stepover;
    let diag = ((max[0] - min[0]).powi(2) + (max[1] - min[1]).powi(2)).sqrt();
    if count as f64 * (diag / opts.sample_step + 1.0) > 1e7 {
        return Err(FinishError::InvalidOptions("more than ten million first samples".into()));
    }
    let line = |o: f64| {
        let origin = [o * normal[0], o * normal[1]];
        clip(origin, dir, min, max).map(|(t0, t1)| Pass { origin, dir, t0, t1 })
    };
    let sampled: Vec<Option<Line>> = (0..count)
        .into_par_iter()
        .map(|k| {
            let o = first + k as f64 * opts.stepover;
            line(o).filter(|_| !stop()).map(|pass| Line {
                offset: o,
                pass,
                points: sample_points(dc, &pass, opts),
            })
        })
        .collect();
    // Where each pass has points the caller keeps, grown along it (`None`: everywhere).
    let reach = KEPT_REACH * opts.sample_step;
    let near_kept: Vec<Option<Vec<(f64, f64)>>> = match (kept, opts.fill) {
        (Some(keep), Some(_)) => sampled
            .par_iter()
            .map(|l| Some(l.as_ref().map_or_else(Vec::new, |l| kept_spans(l, keep, reach))))
            .collect(),
        _ => vec![None; count],
    };
    // The fill passes after each pass, between it and the next.
    let fills: Vec<Vec<Line>> = (0..count)
        .into_par_iter()
        .map(|k| match (opts.fill, sampled.get(k), sampled.get(k + 1)) {
            (Some(f), Some(Some(a)), Some(Some(b))) if !stop() => {
                let spans = match (&near_kept[k], near_kept.get(k + 1)) {
                    (Some(x), Some(Some(y))) => Some(merge_spans(x, y)),
                    _ => None,
                };
                fill_between(dc, opts, &f, &line, (a, b), f.depth, spans.as_deref())
            }
            _ => Vec::new(),
        })
        .collect();
    if stop() {
        return Err(FinishError::Cancelled);
    }
    let mut out = Vec::new();
    for (k, (main, fills)) in sampled.into_iter().zip(fills).enumerate() {
        let lines =
            main.into_iter().map(|l| (l, k % 2 == 1)).chain(fills.into_iter().map(|l| (l, k % 2 == 0)));
        for (l, backwards) in lines {
            let mut runs = to_runs(&l.pass, l.points);
            if opts.zigzag && backwards {
                runs.reverse();
                runs.iter_mut().for_each(|r| r.reverse());
            }
            out.extend(runs);
        }
    }
    Ok(out)
}

/// A sampled pass: its offset across the passes, its line and its samples `(t, height)`
/// in increasing `t`.
struct Line {
    offset: f64,
    pass: Pass,
    points: Vec<(f64, Option<f64>)>,
}

impl Line {
    /// The distance from `p` to the polyline of the centres of a ball of radius `r` whose
    /// tip follows the samples (`+inf` where none lies within `2 r` along the pass): the
    /// value [`centre_distance_reference`](Self::centre_distance_reference) gives, bit for
    /// bit, found from the segment at `p` outwards, each side stopping at the first segment
    /// whose distance along the pass alone (less 1e-9 for rounding) is no nearer than the
    /// nearest so far, and with one square root.
    fn centre_distance(&self, p: &[f64; 3], r: f64) -> f64 {
        let d = self.pass.dir;
        let t = p[0] * d[0] + p[1] * d[1];
        let across = p[0] * -d[1] + p[1] * d[0] - self.offset;
        let pts = &self.points;
        // The segments the reference scans: from `start`, while the first end is within 2 r.
        let start = pts.partition_point(|q| q.0 < t - 2.0 * r).saturating_sub(1);
        let end = pts.partition_point(|q| q.0 <= t + 2.0 * r).min(pts.len().saturating_sub(1));
        if start >= end {
            return f64::INFINITY;
        }
        // The squared distance to segment `i` (the reference's terms, summed the same way);
        // a square root is monotonic, so the least of these gives the least distance.
        let squared = |i: usize| -> Option<f64> {
            let (Some(za), Some(zb)) = (pts[i].1, pts[i + 1].1) else { return None };
            let (a, b) = ([pts[i].0, za + r], [pts[i + 1].0, zb + r]);
            let e = [b[0] - a[0], b[1] - a[1]];
            let l = e[0] * e[0] + e[1] * e[1];
            let u =
                if l > 0.0 { (((t - a[0]) * e[0] + (p[2] - a[1]) * e[1]) / l).clamp(0.0, 1.0) } else { 0.0 };
            let q = [a[0] + u * e[0] - t, a[1] + u * e[1] - p[2]];
            Some(q[0] * q[0] + q[1] * q[1] + across * across)
        };
        // No nearer than `gap` along the pass (less the rounding margin) to the best so far.
        let beyond = |gap: f64, best: f64| {
            let g = gap - 1e-9;
            g > 0.0 && g * g >= best
        };
        let mid = pts.partition_point(|q| q.0 < t).clamp(start + 1, end) - 1;
        let mut best = f64::INFINITY;
        for (i, at) in pts.iter().enumerate().take(end).skip(mid) {
            if beyond(at.0 - t, best) {
                break;
            }
            if let Some(q) = squared(i) {
                best = best.min(q);
            }
        }
        for i in (start..mid).rev() {
            if beyond(t - pts[i + 1].0, best) {
                break;
            }
            if let Some(q) = squared(i) {
                best = best.min(q);
            }
        }
        best.sqrt()
    }

    /// [`centre_distance`](Self::centre_distance)'s baseline: every segment within `2 r`
    /// along the pass, a square root each.
    fn centre_distance_reference(&self, p: &[f64; 3], r: f64) -> f64 {
        let d = self.pass.dir;
        let t = p[0] * d[0] + p[1] * d[1];
        let across = p[0] * -d[1] + p[1] * d[0] - self.offset;
        let pts = &self.points;
        let mut best = f64::INFINITY;
        let start = pts.partition_point(|q| q.0 < t - 2.0 * r).saturating_sub(1);
        for w in pts[start..].windows(2) {
            if w[0].0 > t + 2.0 * r {
                break;
            }
            let (Some(za), Some(zb)) = (w[0].1, w[1].1) else { continue };
            let (a, b) = ([w[0].0, za + r], [w[1].0, zb + r]);
            let e = [b[0] - a[0], b[1] - a[1]];
            let l = e[0] * e[0] + e[1] * e[1];
            let u =
                if l > 0.0 { (((t - a[0]) * e[0] + (p[2] - a[1]) * e[1]) / l).clamp(0.0, 1.0) } else { 0.0 };
            let q = [a[0] + u * e[0] - t, a[1] + u * e[1] - p[2]];
            best = best.min((q[0] * q[0] + q[1] * q[1] + across * across).sqrt());
        }
        best
    }
}

/// The distances from each of `queries` to the ball centres over a pass along `dir` at
/// `offset` across it, with tip samples `points` (`(t, height)`, increasing `t`), for a
/// ball of radius `r`: the fill check's [`Line::centre_distance`], or with `reference`
/// its baseline. For the bench and tests; not part of the stable API.
#[doc(hidden)]
pub fn centre_distances(
    points: &[(f64, Option<f64>)],
    dir: [f64; 2],
    offset: f64,
    r: f64,
    queries: &[[f64; 3]],
    reference: bool,
) -> Vec<f64> {
    let (t0, t1) = (points.first().map_or(0.0, |p| p.0), points.last().map_or(0.0, |p| p.0));
    let origin = [-dir[1] * offset, dir[0] * offset];
    let line = Line { offset, pass: Pass { origin, dir, t0, t1 }, points: points.to_vec() };
    let one = |q: &[f64; 3]| match reference {
        true => line.centre_distance_reference(q, r),
        false => line.centre_distance(q, r),
    };
    queries.iter().map(one).collect()
}

/// The most checks a fill check puts between two of its fine steps on a steep stretch.
const MAX_STEEP_CHECKS: f64 = 256.0;

/// The fill passes between `a` and `b` (neighbours, `a` at the lower offset), in order of
/// offset: see [`FillOptions`]. With `spans` (increasing, disjoint ranges along the
/// passes), only the checks there are asked for, and from each such run of checks on
/// outwards until it has no flagged check within two sampling steps of either end (or the
/// gap ends), so that every fill stretch with a flagged check in `spans` is found whole,
/// with the same samples as without: what is left out is the stretches wholly outside.
fn fill_between(
    dc: &DropCutter<'_>,
    o: &ParallelFinishOptions,
    f: &FillOptions,
    line: &impl Fn(f64) -> Option<Pass>,
    (a, b): (&Line, &Line),
    depth: u32,
    spans: Option<&[(f64, f64)]>,
) -> Vec<Line> {
    if depth == 0 {
        return Vec::new();
    }
    let w = b.offset - a.offset;
    let (t0, t1) = (a.pass.t0.max(b.pass.t0), a.pass.t1.min(b.pass.t1));
    if !(w > 0.0 && t1 > t0) {
        return Vec::new();
    }
    // A hollow of the scanned surface may be narrower than a sampling step: check a
    // quarter step apart, and sample the fill passes that finely too.
    let fine = ParallelFinishOptions { sample_step: 0.25 * o.sample_step, ..*o };
    let n = ((t1 - t0) / fine.sample_step).ceil().max(1.0) as usize;
    let gap = Gap { dc, f, a, b, w, normal: [-a.pass.dir[1], a.pass.dir[0]] };
    let grid = |i: usize| t0 + (t1 - t0) * i as f64 / n as f64;
    let wanted: Vec<bool> = match spans {
        None => vec![true; n + 1],
        Some(s) => (0..=n)
            .map(|i| {
                let t = grid(i);
                let k = s.partition_point(|r| r.1 < t);
                s.get(k).is_some_and(|r| r.0 <= t)
            })
            .collect(),
    };
    let flagged = flagged_checks(&gap, &fine, n, &grid, wanted, o.sample_step);
    // Stretches of flagged samples, each grown by a sampling step.
    let grow = o.sample_step;
    let mut stretches: Vec<(f64, f64)> = Vec::new();
    for t in flagged {
        match stretches.last_mut() {
            Some(s) if t - grow <= s.1 => s.1 = t + grow,
            _ => stretches.push((t - grow, t + grow)),
        }
    }
    let mid = a.offset + 0.5 * w;
    let Some(full) = line(mid) else { return Vec::new() };
    let mut out = Vec::new();
    for (lo, hi) in stretches {
        let pass = Pass { t0: lo.max(full.t0), t1: hi.min(full.t1), ..full };
        if !(pass.t1 > pass.t0) {
            continue;
        }
        let m = Line { offset: mid, pass, points: sample_points(dc, &pass, &fine) };
        let below = fill_between(dc, o, f, line, (a, &m), depth - 1, None);
        let above = fill_between(dc, o, f, line, (&m, b), depth - 1, None);
        out.extend(below);
        out.push(m);
        out.extend(above);
    }
    out
}

/// The gap between two neighbouring passes `a` and `b` that a fill check looks at.
struct Gap<'a, 'd> {
    dc: &'a DropCutter<'d>,
    f: &'a FillOptions,
    a: &'a Line,
    b: &'a Line,
    /// `b.offset - a.offset`.
    w: f64,
    /// The unit vector across the passes.
    normal: [f64; 2],
}

impl Gap<'_, '_> {
    /// The fractions of the way across at which the checks stand.
    const ACROSS: [f64; 3] = [0.25, 0.5, 0.75];

    fn at(&self, t: f64, u: f64) -> (f64, f64) {
        let (s, d) = (self.a.offset + u * self.w, self.a.pass.dir);
        (s * self.normal[0] + t * d[0], s * self.normal[1] + t * d[1])
    }

    /// The drop-cutter heights of a check at `t`.
    fn heights(&self, t: f64) -> [Option<f64>; 3] {
        Self::ACROSS.map(|u| self.at(t, u)).map(|(x, y)| self.dc.height(x, y))
    }

    /// Whether the passes leave more than the limit at the check at `t` with heights `h`.
    fn leaves(&self, t: f64, h: &[Option<f64>; 3]) -> bool {
        let (r, dc) = (self.f.radius, self.dc);
        Self::ACROSS.iter().zip(h).any(|(&u, h)| {
            let (x, y) = self.at(t, u);
            let Some(z) = *h else { return false };
            let Some(n) = dc.contact_normal(x, y, z) else { return false };
            // The contact may lie beyond either pass (a slope across them): the balls
            // between the two cut it all the same.
            let p = [x - r * n[0], y - r * n[1], z + r - r * n[2]];
            // Where neither pass has samples near (a hole, the part's outline), the passes
            // there are not what to judge them by. The nearer pass first: where it leaves
            // no more than the limit, neither does the nearer of the two (`min` is no more
            // than either, and subtracting `r` keeps the order), so the other is not asked.
            let (first, second) = if u <= 0.5 { (self.a, self.b) } else { (self.b, self.a) };
            let near = first.centre_distance(&p, r);
            if !(near - r > self.f.limit) && !near.is_nan() {
                return false;
            }
            let left = near.min(second.centre_distance(&p, r)) - r;
            left.is_finite() && left > self.f.limit
        })
    }
}

/// The positions of the flagged checks of `gap` (increasing): those of the grid points
/// `grid(0..=n)` that `wanted` marks, each with the checks between it and the grid point
/// before (see [`Checks::unit`]), and outwards from every run of them until the run has
/// no flagged check within `2 grow` (and rounding) of an end, where a fill stretch could
/// reach beyond it, or the gap ends. Every grid point wanted: all checks, as before.
fn flagged_checks(
    gap: &Gap<'_, '_>,
    fine: &ParallelFinishOptions,
    n: usize,
    grid: &impl Fn(usize) -> f64,
    wanted: Vec<bool>,
    grow: f64,
) -> Vec<f64> {
    let mut c = Checks { gap, fine, grid, heights: vec![None; n + 1], units: vec![None; n + 1] };
    for k in (0..=n).filter(|&k| wanted[k]) {
        c.unit(k);
    }
    let reach = 2.0 * grow + 1e-9 * (1.0 + grow + grid(0).abs() + grid(n).abs());
    // Each run's start, moved back until no flagged check of the run lies within `reach`
    // of the grid point before it and the run reaches beyond that (checking on forwards
    // as far as needed): then no stretch crosses it.
    let mut k = 0;
    while k <= n {
        if c.units[k].is_none() || (k > 0 && c.units[k - 1].is_some()) {
            k += 1;
            continue;
        }
        let mut s = k;
        while s > 0 {
            let lim = grid(s - 1) + reach;
            let mut open = false;
            let mut j = s;
            loop {
                open |= c.unit(j).iter().any(|&(t, f)| f && t <= lim);
                if open || grid(j) > lim || j == n {
                    break;
                }
                j += 1;
            }
            if !open {
                break;
            }
            s -= 1;
            c.unit(s);
            if s > 0 && c.units[s - 1].is_some() {
                // Joined the run before, whose start is settled.
                break;
            }
        }
        k += 1;
    }
    // Likewise each run's end, moved on (a run with a settled start reaches back beyond
    // the test's reach, but for rounding: the test stops at the run's start).
    let mut k = n + 1;
    while k > 0 {
        k -= 1;
        if c.units[k].is_none() || (k < n && c.units[k + 1].is_some()) {
            continue;
        }
        let mut e = k;
        while e < n {
            let lim = grid(e) - reach;
            let mut open = false;
            let mut j = e;
            loop {
                open |= c.unit(j).iter().any(|&(t, f)| f && t >= lim);
                if open || j == 0 || grid(j - 1) < lim || c.units[j - 1].is_none() {
                    break;
                }
                j -= 1;
            }
            if !open {
                break;
            }
            e += 1;
            c.unit(e);
            if e < n && c.units[e + 1].is_some() {
                break;
            }
        }
    }
    c.units.into_iter().flatten().flatten().filter(|c| c.1).map(|c| c.0).collect()
}

/// The checks of a gap, computed on demand and kept: the heights at the grid points and
/// each grid point's unit of checks.
struct Checks<'a, 'g, 'd, G> {
    gap: &'a Gap<'g, 'd>,
    fine: &'a ParallelFinishOptions,
    grid: &'a G,
    heights: Vec<Option<[Option<f64>; 3]>>,
    /// Per grid point, its checks (`t`, whether flagged), once computed.
    units: Vec<Option<Vec<(f64, bool)>>>,
}

impl<G: Fn(usize) -> f64> Checks<'_, '_, '_, G> {
    fn at(&mut self, i: usize) -> (f64, [Option<f64>; 3]) {
        let t = (self.grid)(i);
        (t, *self.heights[i].get_or_insert_with(|| self.gap.heights(t)))
    }

    /// The checks up to grid point `k` from the one before, each with whether it is
    /// flagged: closer than the grid where the drop-cutter heights rise or fall fast (on
    /// a wall steeper than the XY step can see, an 88 degree one rising 3.6 mm over 0.125
    /// mm, a step of the cutter-location surface is split so that the checks stand at
    /// most a fine step apart in Z as well), then the grid point.
    fn unit(&mut self, k: usize) -> &[(f64, bool)] {
        if self.units[k].is_none() {
            let g = self.at(k);
            let mut checks = Vec::new();
            if let Some(prev) = k.checked_sub(1).map(|j| self.at(j)) {
                let rise = prev.1.iter().zip(&g.1).fold(0.0f64, |m, (p, q)| match (p, q) {
                    (Some(p), Some(q)) => m.max((q - p).abs()),
                    _ => m,
                });
                let parts = (rise / self.fine.sample_step).ceil().min(MAX_STEEP_CHECKS);
                if parts > 1.0 {
                    let parts = parts as usize;
                    checks.extend(
                        (1..parts)
                            .map(|j| prev.0 + (g.0 - prev.0) * j as f64 / parts as f64)
                            .map(|t| (t, self.gap.heights(t))),
                    );
                }
            }
            checks.push(g);
            self.units[k] = Some(checks.iter().map(|(t, h)| (*t, self.gap.leaves(*t, h))).collect());
        }
        self.units[k].as_deref().unwrap_or_default()
    }
}

/// The ranges along a pass within `reach` of a sample that `keep` accepts, increasing
/// and disjoint (the samples lie in increasing order along the pass).
fn kept_spans(l: &Line, keep: Keep<'_>, reach: f64) -> Vec<(f64, f64)> {
    union_in_order(l.points.iter().filter_map(|&(t, h)| {
        let (z, p) = (h?, l.pass.at(t));
        keep(&Point3::new(p[0], p[1], z)).then_some((t - reach, t + reach))
    }))
}

/// The union of two increasing lists of disjoint ranges, increasing and disjoint.
fn merge_spans(x: &[(f64, f64)], y: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut all: Vec<(f64, f64)> = x.iter().chain(y).copied().collect();
    all.sort_by(|p, q| p.0.total_cmp(&q.0));
    union_in_order(all)
}

/// The union of ranges given in increasing order of their starts, increasing and disjoint.
fn union_in_order(ranges: impl IntoIterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    for (lo, hi) in ranges {
        match out.last_mut() {
            Some(s) if lo <= s.1 => s.1 = s.1.max(hi),
            _ => out.push((lo, hi)),
        }
    }
    out
}

/// How far along a pass, in sampling steps, from a point the caller keeps, the gaps beside
/// it are fill-checked.
pub(super) const KEPT_REACH: f64 = 4.0;

fn check(min: [f64; 2], max: [f64; 2], o: &ParallelFinishOptions) -> Result<(), FinishError> {
    let bad = |m: String| Err(FinishError::InvalidOptions(m));
    if !(min.iter().chain(&max).all(|v| v.is_finite()) && min[0] <= max[0] && min[1] <= max[1]) {
        return bad(format!("the rectangle must be finite with min <= max, got {min:?} .. {max:?}"));
    }
    let lengths = [
        ("stepover", o.stepover),
        ("sample_step", o.sample_step),
        ("tolerance", o.tolerance),
        ("min_step", o.min_step),
    ];
    for (name, v) in lengths {
        if !(v.is_finite() && v > 0.0) {
            return bad(format!("{name} must be finite and > 0, got {v}"));
        }
    }
    if !o.angle.is_finite() || o.floor.is_some_and(|z| !z.is_finite()) {
        return bad(format!("angle and floor must be finite, got {} and {:?}", o.angle, o.floor));
    }
    if let Some(f) = o.fill
        && !(f.radius > 0.0 && f.radius.is_finite() && f.limit > 0.0 && f.limit.is_finite() && f.depth <= 8)
    {
        return bad(format!(
            "fill needs a finite radius > 0, a finite limit > 0 and at most 8 halvings, got {f:?}"
        ));
    }
    Ok(())
}

/// The parameter range of the line `origin + t dir` inside the rectangle, if any.
fn clip(origin: [f64; 2], dir: [f64; 2], min: [f64; 2], max: [f64; 2]) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..2 {
        if dir[a].abs() < 1e-15 {
            if origin[a] < min[a] || origin[a] > max[a] {
                return None;
            }
            continue;
        }
        let (p, q) = ((min[a] - origin[a]) / dir[a], (max[a] - origin[a]) / dir[a]);
        t0 = t0.max(p.min(q));
        t1 = t1.min(p.max(q));
    }
    (t0 <= t1).then_some((t0, t1))
}

/// One pass's samples `(t, height)`: uniform, refined where the surface bends.
fn sample_points(dc: &DropCutter<'_>, pass: &Pass, o: &ParallelFinishOptions) -> Vec<(f64, Option<f64>)> {
    let height = |t: f64| {
        let p = pass.at(t);
        dc.height(p[0], p[1]).or(o.floor)
    };
    let n = ((pass.t1 - pass.t0) / o.sample_step).ceil().max(1.0) as usize;
    let ts: Vec<f64> = (0..=n).map(|i| pass.t0 + (pass.t1 - pass.t0) * i as f64 / n as f64).collect();
    let mut points = vec![(ts[0], height(ts[0]))];
    for w in ts.windows(2) {
        let b = (w[1], height(w[1]));
        let a = *points.last().unwrap_or(&b);
        refine(&height, a, b, o, &mut points);
        points.push(b);
    }
    points
}

/// A pass's polylines from its samples, split where there is no contact.
fn to_runs(pass: &Pass, points: Vec<(f64, Option<f64>)>) -> Vec<Vec<Point3>> {
    let mut runs = Vec::new();
    let mut run = Vec::new();
    for (t, h) in points {
        match h {
            Some(z) => {
                let p = pass.at(t);
                run.push(Point3::new(p[0], p[1], z));
            }
            None if !run.is_empty() => runs.push(std::mem::take(&mut run)),
            None => {}
        }
    }
    if !run.is_empty() {
        runs.push(run);
    }
    runs
}

/// Pushes the points that `a`-`b` needs between them (not `a` or `b`), in order.
fn refine(
    height: &impl Fn(f64) -> Option<f64>,
    a: (f64, Option<f64>),
    b: (f64, Option<f64>),
    o: &ParallelFinishOptions,
    out: &mut Vec<(f64, Option<f64>)>,
) {
    if !(b.0 - a.0 > o.min_step) {
        return;
    }
    let tm = 0.5 * (a.0 + b.0);
    let m = (tm, height(tm));
    let split = match (a.1, m.1, b.1) {
        (Some(za), Some(zm), Some(zb)) => (zm - 0.5 * (za + zb)).abs() > o.tolerance,
        (None, None, None) => false,
        // Where contact starts or ends, home in on it.
        _ => true,
    };
    if split {
        refine(height, a, m, o, out);
        out.push(m);
        refine(height, m, b, o, out);
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::centre_distances;

    proptest! {
        /// The fill check's distance from the segment at the point outwards, with its
        /// early stops and one square root, equals the baseline's (every segment within two
        /// radii) bit for bit: on lines with gaps (no contact), steep steps and uneven
        /// sampling, at any angle, for points on either side, near and far.
        #[test]
        fn centre_distance_equals_its_reference(
            steps in prop::collection::vec((0.001f64..0.6, -3.0f64..3.0, 0u8..8), 1..120),
            start in -60.0f64..60.0,
            angle in 0.0f64..6.3,
            offset in -20.0f64..20.0,
            r in 0.05f64..6.0,
            queries in prop::collection::vec((-80.0f64..80.0, -25.0f64..25.0, -10.0f64..10.0), 1..40),
        ) {
            let mut t = start;
            let mut z = 0.0;
            let points: Vec<(f64, Option<f64>)> = steps
                .iter()
                .map(|&(dt, dz, gap)| {
                    t += dt;
                    z += dz;
                    (t, (gap != 0).then_some(z))
                })
                .collect();
            let dir = [angle.cos(), angle.sin()];
            let qs: Vec<[f64; 3]> = queries.iter().map(|&(x, y, z)| [x, y, z]).collect();
            let want = centre_distances(&points, dir, offset, r, &qs, true);
            let got = centre_distances(&points, dir, offset, r, &qs, false);
            for (w, g) in want.iter().zip(&got) {
                prop_assert_eq!(w.to_bits(), g.to_bits(), "{} against {}", g, w);
            }
        }
    }
}
