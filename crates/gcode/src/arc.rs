//! Arc geometry: sweep angle, length, point at a parameter, linearisation at a
//! chordal tolerance, and the [`ArcFitter`] that turns polylines back into G2/G3 arcs.
//!
//! Planes map to local `(u, v, w)` axes the way RS274NGC defines them, so that a
//! counter-clockwise arc turns from `+u` towards `+v` and `w` is the helix axis:
//! G17 `(X, Y, Z)`, G18 `(Z, X, Y)`, G19 `(Y, Z, X)`.

use std::f64::consts::{PI, TAU};

use nalgebra::Point3;

use crate::motion::{ArcDirection, Motion, MotionSink, Plane};

/// Errors of the arc helpers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ArcError {
    /// The chordal tolerance is not a positive finite number.
    #[error("chordal tolerance must be positive and finite, got {0}")]
    BadTolerance(f64),
    /// A start, end or centre coordinate is NaN or infinite.
    #[error("arc has a non-finite coordinate")]
    NonFinite,
    /// Linearising would need more segments than [`MAX_ARC_SEGMENTS`].
    #[error("arc needs {0} segments at this tolerance (more than the limit)")]
    TooManySegments(f64),
}

/// Upper bound on the segments one arc may be split into (guards against a
/// tolerance that is tiny relative to the radius).
pub const MAX_ARC_SEGMENTS: f64 = 10_000_000.0;

/// Indices `(u, v, w)` of a plane's in-plane axes and its normal (helix) axis.
pub fn plane_axes(plane: Plane) -> (usize, usize, usize) {
    match plane {
        Plane::XY => (0, 1, 2),
        Plane::ZX => (2, 0, 1),
        Plane::YZ => (1, 2, 0),
    }
}

/// A circular or helical arc from a known start point: the geometry of a
/// [`Motion::Arc`] once the machine's position before it is known.
///
/// When the end lies at a different distance from the centre than the start (a
/// "spiral" within the controller's tolerance), the radius is interpolated
/// linearly along the sweep, as LinuxCNC does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArcSpec {
    /// Start point (the position before the move).
    pub start: Point3<f64>,
    /// End point.
    pub end: Point3<f64>,
    /// Centre; only its in-plane coordinates matter.
    pub center: Point3<f64>,
    /// Arc plane.
    pub plane: Plane,
    /// Direction.
    pub direction: ArcDirection,
    /// Extra full turns.
    pub turns: u32,
}

impl ArcSpec {
    /// The arc of `motion` started at `start`; `None` if `motion` is not an arc.
    pub fn from_motion(start: Point3<f64>, motion: &Motion<'_>) -> Option<ArcSpec> {
        match *motion {
            Motion::Arc { to, center, plane, direction, turns, .. } => {
                Some(ArcSpec { start, end: to, center, plane, direction, turns })
            }
            _ => None,
        }
    }

    fn finite(&self) -> bool {
        [self.start, self.end, self.center].iter().all(|p| p.iter().all(|c| c.is_finite()))
    }

    /// Radius at the start.
    pub fn radius(&self) -> f64 {
        let (u, v, _) = plane_axes(self.plane);
        (self.start[u] - self.center[u]).hypot(self.start[v] - self.center[v])
    }

    /// Radius at the end.
    pub fn end_radius(&self) -> f64 {
        let (u, v, _) = plane_axes(self.plane);
        (self.end[u] - self.center[u]).hypot(self.end[v] - self.center[v])
    }

    /// Unsigned sweep angle in radians, including extra turns. An end point equal
    /// to the start (in the plane) is a full circle, as in RS274NGC.
    pub fn sweep(&self) -> f64 {
        let (u, v, _) = plane_axes(self.plane);
        let a0 = (self.start[v] - self.center[v]).atan2(self.start[u] - self.center[u]);
        let a1 = (self.end[v] - self.center[v]).atan2(self.end[u] - self.center[u]);
        let mut d = match self.direction {
            ArcDirection::CounterClockwise => a1 - a0,
            ArcDirection::Clockwise => a0 - a1,
        };
        d = d.rem_euclid(TAU);
        // Same in-plane point: a full circle. The threshold is relative to the
        // radius so that rounding in the program does not turn a full circle into
        // a zero-length arc.
        let r = self.radius().max(self.end_radius());
        let chord = (self.end[u] - self.start[u]).hypot(self.end[v] - self.start[v]);
        if chord <= 1e-12 * r.max(1.0) || d == 0.0 {
            d = TAU;
        }
        d + TAU * self.turns as f64
    }

    /// Length of the (possibly helical) path.
    pub fn length(&self) -> f64 {
        let (_, _, w) = plane_axes(self.plane);
        let planar = self.sweep() * 0.5 * (self.radius() + self.end_radius());
        planar.hypot(self.end[w] - self.start[w])
    }

    /// Point at parameter `t` in `[0, 1]` along the sweep (0 = start, 1 = end).
    /// The helix coordinate and the radius vary linearly with `t`; `t = 1`
    /// returns `end` exactly.
    pub fn point_at(&self, t: f64) -> Point3<f64> {
        if t >= 1.0 {
            return self.end;
        }
        if t <= 0.0 {
            return self.start;
        }
        let (u, v, w) = plane_axes(self.plane);
        let a0 = (self.start[v] - self.center[v]).atan2(self.start[u] - self.center[u]);
        let sign = match self.direction {
            ArcDirection::CounterClockwise => 1.0,
            ArcDirection::Clockwise => -1.0,
        };
        let a = a0 + sign * self.sweep() * t;
        let r = self.radius() + (self.end_radius() - self.radius()) * t;
        let mut p = self.start;
        p[u] = self.center[u] + r * a.cos();
        p[v] = self.center[v] + r * a.sin();
        p[w] = self.start[w] + (self.end[w] - self.start[w]) * t;
        p
    }

    /// Number of equal-angle chords whose sagitta `r (1 - cos(theta / 2))` stays
    /// within `chord_tol`.
    pub fn segments(&self, chord_tol: f64) -> Result<usize, ArcError> {
        if !(chord_tol > 0.0 && chord_tol.is_finite()) {
            return Err(ArcError::BadTolerance(chord_tol));
        }
        if !self.finite() {
            return Err(ArcError::NonFinite);
        }
        let r = self.radius().max(self.end_radius());
        if r <= 0.0 {
            return Ok(1);
        }
        // Largest chord angle with sagitta <= tol: theta = 2 acos(1 - tol / r).
        let max_theta = 2.0 * (1.0 - chord_tol / r).clamp(-1.0, 1.0).acos();
        // Keep every chord below half a turn so the polyline follows the sweep.
        let max_theta = max_theta.min(PI * 0.5);
        let n = (self.sweep() / max_theta).ceil().max(1.0);
        if n > MAX_ARC_SEGMENTS {
            return Err(ArcError::TooManySegments(n));
        }
        Ok(n as usize)
    }

    /// Calls `emit` with the end points of chords approximating the arc within
    /// `chord_tol` (the start is not emitted; the last point is `end` exactly).
    /// Returns the number of points emitted.
    pub fn linearize(&self, chord_tol: f64, mut emit: impl FnMut(Point3<f64>)) -> Result<usize, ArcError> {
        let n = self.segments(chord_tol)?;
        for i in 1..=n {
            emit(self.point_at(i as f64 / n as f64));
        }
        Ok(n)
    }
}

/// Linearises `motion` (a [`Motion::Arc`]) started at `start` into chords whose
/// sagitta is at most `chord_tol`, calling `emit` with each chord's end point
/// (the last is the arc's end exactly). Any other motion emits its end point once
/// (nothing for motions without one). Returns the number of points emitted.
pub fn linearize_arc(
    start: &Point3<f64>,
    motion: &Motion<'_>,
    chord_tol: f64,
    mut emit: impl FnMut(Point3<f64>),
) -> Result<usize, ArcError> {
    match ArcSpec::from_motion(*start, motion) {
        Some(spec) => spec.linearize(chord_tol, emit),
        None => Ok(motion.end_point().map(&mut emit).map_or(0, |_| 1)),
    }
}

/// Length of the move `motion` started at `start` (helical arcs included);
/// 0 for motions that do not move.
pub fn arc_length(start: &Point3<f64>, motion: &Motion<'_>) -> f64 {
    match ArcSpec::from_motion(*start, motion) {
        Some(spec) => spec.length(),
        None => motion.end_point().map_or(0.0, |p| (p - start).norm()),
    }
}

/// Unsigned sweep angle (radians) of `motion` started at `start`, or `None` if it is not an arc.
pub fn sweep_angle(start: &Point3<f64>, motion: &Motion<'_>) -> Option<f64> {
    ArcSpec::from_motion(*start, motion).map(|s| s.sweep())
}

/// Points past a failed fit that [`ArcFitter`] still tries before it closes a run.
const FIT_LOOKAHEAD: usize = 3;

/// Options of [`ArcFitter`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArcFitOptions {
    /// Largest distance from the fitted arc's circle to any point of the input run
    /// (its vertices and its segments), in mm. Default 0.01.
    pub tolerance: f64,
    /// Fewest input segments one arc replaces. Default 3.
    pub min_segments: usize,
    /// Most input segments one arc replaces (bounds the quadratic fitting work). Default 400.
    pub max_segments: usize,
    /// Arcs of larger radius are left as lines (nearly straight runs). Default 1000 mm.
    pub max_radius: f64,
    /// Largest angle one input segment may turn about the centre. Default 45 degrees (in radians).
    pub max_segment_angle: f64,
    /// Relative tolerance on extrusion per mm for runs with extrusion to count as
    /// one arc (the extrusion rate must be this close to constant). Default 0.05.
    pub extrusion_rate_tolerance: f64,
    /// Fit arcs in the XY plane only (runs at one Z), as a 3-axis mill's layers are cut;
    /// otherwise runs in the ZX and YZ planes count too. Default false.
    pub xy_only: bool,
}

impl Default for ArcFitOptions {
    fn default() -> Self {
        ArcFitOptions {
            tolerance: 0.01,
            min_segments: 3,
            max_segments: 400,
            max_radius: 1000.0,
            max_segment_angle: PI / 4.0,
            extrusion_rate_tolerance: 0.05,
            xy_only: false,
        }
    }
}

/// A [`MotionSink`] adapter that replaces runs of [`Motion::Linear`] moves lying on
/// a circle by G2/G3 arcs and forwards everything else unchanged.
///
/// A run qualifies when its moves share the feed, keep one coordinate constant
/// (the normal of the XY, ZX or YZ plane, tried in that order), turn
/// monotonically about one centre, and either all carry no extrusion or all
/// extrude at the same rate per mm (within
/// [`ArcFitOptions::extrusion_rate_tolerance`]). A fitted arc passes exactly
/// through the run's first and last points, with its centre on their bisector where its
/// circle deviates least from the run, and every point of the run (vertices and segments)
/// lies within [`ArcFitOptions::tolerance`] of its circle; otherwise the moves are
/// forwarded as they came.
#[derive(Debug)]
pub struct ArcFitter<S: MotionSink> {
    inner: S,
    opts: ArcFitOptions,
    /// Position before the first buffered move.
    pos: Option<Point3<f64>>,
    /// Buffered linear moves: end point, extrusion.
    buf: Vec<(Point3<f64>, Option<f64>)>,
    feed: f64,
    moves_in: u64,
    moves_out: u64,
}

impl<S: MotionSink> ArcFitter<S> {
    /// Wraps `inner`.
    pub fn new(inner: S, opts: ArcFitOptions) -> Self {
        ArcFitter { inner, opts, pos: None, buf: Vec::new(), feed: 0.0, moves_in: 0, moves_out: 0 }
    }

    /// Input moves (rapid, linear, arc) divided by output moves; 1 before any output.
    pub fn compression_ratio(&self) -> f64 {
        if self.moves_out == 0 { 1.0 } else { self.moves_in as f64 / self.moves_out as f64 }
    }

    /// Moves received so far.
    pub fn moves_in(&self) -> u64 {
        self.moves_in
    }

    /// Moves forwarded so far.
    pub fn moves_out(&self) -> u64 {
        self.moves_out
    }

    /// The wrapped sink (flush with [`MotionSink::finish`] first).
    pub fn into_inner(self) -> S {
        self.inner
    }

    /// The wrapped sink.
    pub fn inner(&self) -> &S {
        &self.inner
    }

    /// The wrapped sink, mutably (what it is sent directly comes before the held run).
    pub fn inner_mut(&mut self) -> &mut S {
        &mut self.inner
    }

    fn forward(&mut self, m: &Motion<'_>) -> Result<(), S::Error> {
        if m.end_point().is_some() {
            self.moves_out += 1;
        }
        self.inner.motion(m)
    }

    /// Whether a linear move to `to` may join the buffered run.
    fn compatible(&self, start: Point3<f64>, to: Point3<f64>, feed: f64, extrude: Option<f64>) -> bool {
        if self.buf.is_empty() {
            return true;
        }
        if feed != self.feed || self.buf.len() >= self.opts.max_segments {
            return false;
        }
        let first = self.buf[0].1;
        match (first, extrude) {
            (None, None) => {}
            (Some(e0), Some(e)) => {
                let Some(p0) = self.pos else { return false };
                let l0 = (self.buf[0].0 - p0).norm();
                let prev = self.buf.last().map_or(start, |b| b.0);
                let l = (to - prev).norm();
                if l0 <= 0.0 || l <= 0.0 || e0 <= 0.0 || e <= 0.0 {
                    return false;
                }
                let (r0, r) = (e0 / l0, e / l);
                if (r - r0).abs() > self.opts.extrusion_rate_tolerance * r0 {
                    return false;
                }
            }
            _ => return false,
        }
        true
    }

    fn flush(&mut self) -> Result<(), S::Error> {
        let Some(start) = self.pos else {
            // Unknown start: cannot fit; forward as lines.
            let buf = std::mem::take(&mut self.buf);
            for (to, extrude) in &buf {
                self.forward(&Motion::Linear { to: *to, feed: self.feed, extrude: *extrude })?;
            }
            return Ok(());
        };
        let buf = std::mem::take(&mut self.buf);
        let mut pts = Vec::with_capacity(buf.len() + 1);
        pts.push(start);
        pts.extend(buf.iter().map(|b| b.0));
        let mut i = 0;
        while i + 1 < pts.len() {
            let mut best: Option<(usize, Point3<f64>, Plane, ArcDirection)> = None;
            let mut k = i + self.opts.min_segments.max(2);
            // A run that fails may fit again a point later (its end landed on a vertex
            // off the circle the run follows): look a few points past a failure.
            let mut misses = 0;
            while k < pts.len() && misses <= FIT_LOOKAHEAD {
                match fit_arc(&pts[i..=k], &self.opts) {
                    Some((c, plane, dir)) => {
                        best = Some((k, c, plane, dir));
                        misses = 0;
                    }
                    None => misses += 1,
                }
                k += 1;
            }
            match best {
                Some((k, center, plane, direction)) => {
                    let extrude = buf[i..k].iter().map(|b| b.1).try_fold(0.0, |acc, e| e.map(|e| acc + e));
                    self.forward(&Motion::Arc {
                        to: pts[k],
                        center,
                        plane,
                        direction,
                        turns: 0,
                        feed: self.feed,
                        extrude,
                    })?;
                    i = k;
                }
                None => {
                    self.forward(&Motion::Linear { to: pts[i + 1], feed: self.feed, extrude: buf[i].1 })?;
                    i += 1;
                }
            }
        }
        self.pos = pts.last().copied();
        Ok(())
    }
}

/// Centre of the circle through three in-plane points `(u, v)`, if not collinear.
fn circle_through(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> Option<[f64; 2]> {
    let (bx, by) = (b[0] - a[0], b[1] - a[1]);
    let (cx, cy) = (c[0] - a[0], c[1] - a[1]);
    let d = 2.0 * (bx * cy - by * cx);
    let scale = (bx * bx + by * by).max(cx * cx + cy * cy);
    if d.abs() <= 1e-12 * scale || scale == 0.0 {
        return None;
    }
    let b2 = bx * bx + by * by;
    let c2 = cx * cx + cy * cy;
    let ux = (cy * b2 - by * c2) / d;
    let uy = (bx * c2 - cx * b2) / d;
    Some([a[0] + ux, a[1] + uy])
}

/// Largest distance between the circle of centre `c` and radius `r` and the polyline `uv`:
/// over its vertices and, for each segment, its point nearest the centre (the distance to
/// the centre is convex along a segment, so its extremes are there and at the ends).
fn circle_deviation(uv: &[[f64; 2]], c: [f64; 2], r: f64) -> f64 {
    let dist = |p: [f64; 2]| (p[0] - c[0]).hypot(p[1] - c[1]);
    let mut worst = uv.iter().map(|&p| (dist(p) - r).abs()).fold(0.0, f64::max);
    for w in uv.windows(2) {
        let (a, b) = (w[0], w[1]);
        let ab = [b[0] - a[0], b[1] - a[1]];
        let l2 = ab[0] * ab[0] + ab[1] * ab[1];
        let t = if l2 > 0.0 {
            (((c[0] - a[0]) * ab[0] + (c[1] - a[1]) * ab[1]) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        worst = worst.max((dist([a[0] + t * ab[0], a[1] + t * ab[1]]) - r).abs());
    }
    worst
}

/// The centre on the perpendicular bisector of the run's ends (so that both ends lie on
/// the arc exactly, as G2/G3 need) whose circle deviates least from the polyline, starting
/// from the circle through the first, middle and last points: a golden-section search
/// along the bisector. Polylines of offsets and thinned rings have their vertices off the
/// circle they follow (an offset's round joins put the vertices outside the arc and the
/// chords' midpoints on it), where the circle through three vertices deviates by twice
/// the best one's deviation. Returns the centre and its deviation.
fn best_centre(uv: &[[f64; 2]], c0: [f64; 2], tol: f64) -> ([f64; 2], f64) {
    let (a, b) = (uv[0], uv[uv.len() - 1]);
    let radius = |c: [f64; 2]| (a[0] - c[0]).hypot(a[1] - c[1]);
    let d0 = circle_deviation(uv, c0, radius(c0));
    // Within tolerance already, or too far off for any centre near it to help (the search
    // moves the circle by little more than its deviation): the answer as it is.
    if d0 <= tol || d0 > 4.0 * tol {
        return (c0, d0);
    }
    let m = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
    let chord = (b[0] - a[0]).hypot(b[1] - a[1]);
    if chord <= 0.0 {
        return (c0, d0);
    }
    let n = [-(b[1] - a[1]) / chord, (b[0] - a[0]) / chord];
    let at = |s: f64| [m[0] + s * n[0], m[1] + s * n[1]];
    let f = |s: f64| {
        let c = at(s);
        circle_deviation(uv, c, radius(c))
    };
    let s0 = (c0[0] - m[0]) * n[0] + (c0[1] - m[1]) * n[1];
    // Moving the centre by ds along the bisector moves the arc's middle by about
    // ds * (1 - cos(half sweep)) and its sides by less; a bracket of a few deviations
    // over that factor, and a fraction of the distance, holds the best centre.
    let half = (0.5 * chord / radius(c0)).clamp(0.0, 1.0).asin();
    let span = (8.0 * d0 / (1.0 - half.cos()).max(1e-9)).min(0.5 * s0.abs() + chord);
    let (mut lo, mut hi) = (s0 - span, s0 + span);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..48 {
        if f1 < f2 {
            (hi, x2, f2) = (x2, x1, f1);
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        } else {
            (lo, x1, f1) = (x1, x2, f2);
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        }
    }
    let s = 0.5 * (lo + hi);
    let d = f(s);
    if d < d0 { (at(s), d) } else { (c0, d0) }
}

/// Fits one arc through `pts` (first and last exactly, the centre chosen by
/// [`best_centre`]); checks the whole polyline against the tolerance and the monotonic turn.
fn fit_arc(pts: &[Point3<f64>], opts: &ArcFitOptions) -> Option<(Point3<f64>, Plane, ArcDirection)> {
    let first = pts[0];
    let planes: &[Plane] = if opts.xy_only { &[Plane::XY] } else { &[Plane::XY, Plane::ZX, Plane::YZ] };
    let plane = planes.iter().copied().find(|&pl| {
        let (_, _, w) = plane_axes(pl);
        pts.iter().all(|p| (p[w] - first[w]).abs() <= 1e-9)
    })?;
    let (u, v, _) = plane_axes(plane);
    let uv: Vec<[f64; 2]> = pts.iter().map(|p| [p[u], p[v]]).collect();
    let c0 = circle_through(uv[0], uv[uv.len() / 2], uv[uv.len() - 1])?;
    let (c, dev) = best_centre(&uv, c0, opts.tolerance);
    let r = (uv[0][0] - c[0]).hypot(uv[0][1] - c[1]);
    if !(r.is_finite() && r <= opts.max_radius && r > opts.tolerance && dev <= opts.tolerance) {
        return None;
    }
    let ang = |q: [f64; 2]| (q[1] - c[1]).atan2(q[0] - c[0]);
    let mut total = 0.0;
    let mut sign = 0.0;
    for w in uv.windows(2) {
        let mut d = ang(w[1]) - ang(w[0]);
        if d > PI {
            d -= TAU;
        } else if d < -PI {
            d += TAU;
        }
        if d == 0.0 || d.abs() > opts.max_segment_angle {
            return None;
        }
        let s = d.signum();
        if sign != 0.0 && s != sign {
            return None;
        }
        sign = s;
        total += d.abs();
    }
    // Stay clearly below a full turn so the end point does not read as a full circle.
    if total >= TAU - 1e-3 {
        return None;
    }
    let mut center = first;
    center[u] = c[0];
    center[v] = c[1];
    let dir = if sign > 0.0 { ArcDirection::CounterClockwise } else { ArcDirection::Clockwise };
    Some((center, plane, dir))
}

impl<S: MotionSink> MotionSink for ArcFitter<S> {
    type Error = S::Error;

    fn motion(&mut self, motion: &Motion<'_>) -> Result<(), S::Error> {
        if motion.end_point().is_some() {
            self.moves_in += 1;
        }
        if let Motion::Linear { to, feed, extrude } = *motion {
            let start = self.buf.last().map(|b| b.0).or(self.pos);
            if let Some(start) = start
                && self.pos.is_some()
                && to.iter().all(|c| c.is_finite())
                && to != start
            {
                if !self.compatible(start, to, feed, extrude) {
                    self.flush()?;
                }
                self.feed = feed;
                self.buf.push((to, extrude));
                return Ok(());
            }
        }
        self.flush()?;
        if let Some(p) = motion.end_point() {
            self.pos = Some(p);
        }
        self.forward(motion)
    }

    fn source_line(&mut self, line: u64) -> Result<(), S::Error> {
        // Buffered moves keep the line they are flushed under; lines are advisory.
        if self.buf.is_empty() { self.inner.source_line(line) } else { Ok(()) }
    }

    fn finish(&mut self) -> Result<(), S::Error> {
        self.flush()?;
        self.inner.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(plane: Plane, dir: ArcDirection, turns: u32) -> ArcSpec {
        let (u, v, w) = plane_axes(plane);
        let mut start = Point3::origin();
        start[u] = 10.0;
        let mut end = Point3::origin();
        end[v] = 10.0;
        end[w] = 3.0;
        ArcSpec { start, end, center: Point3::origin(), plane, direction: dir, turns }
    }

    #[test]
    fn sweep_and_length_quarter_and_three_quarter() {
        for plane in [Plane::XY, Plane::ZX, Plane::YZ] {
            let ccw = spec(plane, ArcDirection::CounterClockwise, 0);
            assert!((ccw.sweep() - PI / 2.0).abs() < 1e-12, "{plane:?}");
            let cw = spec(plane, ArcDirection::Clockwise, 1);
            assert!((cw.sweep() - (1.5 * PI + TAU)).abs() < 1e-12, "{plane:?}");
            let l = (10.0 * PI / 2.0f64).hypot(3.0);
            assert!((ccw.length() - l).abs() < 1e-9, "{plane:?}");
            // Midpoint of the CCW quarter lies at 45 degrees in the plane.
            let m = ccw.point_at(0.5);
            let (u, v, w) = plane_axes(plane);
            let s = 10.0 / 2f64.sqrt();
            assert!((m[u] - s).abs() < 1e-9 && (m[v] - s).abs() < 1e-9 && (m[w] - 1.5).abs() < 1e-12);
        }
    }

    #[test]
    fn full_circle_when_end_equals_start() {
        let mut s = spec(Plane::XY, ArcDirection::Clockwise, 0);
        s.end = s.start;
        assert!((s.sweep() - TAU).abs() < 1e-12);
    }

    #[test]
    fn linearization_respects_sagitta() {
        let s = spec(Plane::XY, ArcDirection::CounterClockwise, 2);
        let tol = 0.001;
        let mut pts = vec![s.start];
        let n = s.linearize(tol, |p| pts.push(p)).expect("valid");
        assert_eq!(pts.len(), n + 1);
        assert_eq!(*pts.last().expect("points"), s.end);
        for w in pts.windows(2) {
            let m = nalgebra::center(&w[0], &w[1]);
            let r = m.x.hypot(m.y);
            assert!(10.0 - r <= tol * 1.0001, "sagitta {} > {tol}", 10.0 - r);
        }
        // Roughly the minimum count: the same formula with one segment less would break the tolerance.
        let theta = s.sweep() / (n - 1) as f64;
        assert!(10.0 * (1.0 - (theta / 2.0).cos()) > tol);
    }

    #[test]
    fn bad_tolerance_and_nan_are_errors() {
        let s = spec(Plane::XY, ArcDirection::Clockwise, 0);
        assert!(matches!(s.linearize(0.0, |_| {}), Err(ArcError::BadTolerance(_))));
        assert!(matches!(s.linearize(f64::NAN, |_| {}), Err(ArcError::BadTolerance(_))));
        let mut bad = s;
        bad.center.x = f64::NAN;
        assert_eq!(bad.linearize(0.1, |_| {}), Err(ArcError::NonFinite));
        assert!(matches!(s.linearize(1e-300, |_| {}), Err(ArcError::TooManySegments(_))));
    }
}
