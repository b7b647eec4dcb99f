//! One-sided fitting of planar polylines with arcs and lines ([`fit_planar`]): each fitted
//! piece runs from one vertex of the polyline to a later one and lies on a stated side of
//! the polyline it replaces ([`FitSide`]), within a tolerance of it.
//!
//! Where a polyline is a tool path planned at a safe distance from the part, a piece that
//! may leave the path only away from the part (or only towards it, by at most the margin
//! the path keeps) is as safe as the path: unlike a two-sided fit ([`ArcFitter`](crate::ArcFitter)),
//! which puts the arc on both sides, it neither comes nearer the part than the margin nor
//! leaves, on the other side, material that the path would have cut.
//!
//! # Geometry
//!
//! A candidate run of vertices `A = p_i .. p_k = B` is seen in the frame of its chord:
//! `s` along `A -> B`, `h` to its left. The run qualifies only when `s` increases strictly
//! along it (it is a graph over the chord), and the arcs through `A` and `B` are the minor
//! arcs (sweep below half a turn), written by their signed mid-height `m` (positive: the
//! arc bulges to the left of the chord; `m = 0` is the chord itself), in which every
//! arc's height `y(s)` grows monotonically. For [`FitSide::Right`] the arc must lie on the
//! right of the run (`y <= h` everywhere) and within the tolerance of it
//! (`h - y <= tolerance`); the highest such arc is the one that hugs the run. The extremes
//! of `h - y` over the run are exact: at its vertices and, on each segment, where the
//! arc's tangent is parallel to the segment. The deviation is measured across the chord
//! (at equal `s`), which is never less than the distance between the curves, so every
//! point of the arc lies within the tolerance of a point of the run and on its stated side.
//! [`FitSide::Left`] is the mirror image.

use crate::motion::ArcDirection;

/// The side of the polyline, seen along its direction of travel, on which a fitted piece
/// may lie.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FitSide {
    /// Left of the polyline.
    Left,
    /// Right of the polyline.
    Right,
}

/// Options of [`fit_planar`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarFitOptions {
    /// Largest distance between a fitted piece and the run it replaces. Default 0.005.
    pub tolerance: f64,
    /// The side the pieces lie on. Default [`FitSide::Right`].
    pub side: FitSide,
    /// Fewest input segments one piece replaces (at least 2). Default 2.
    pub min_segments: usize,
    /// Most input segments one piece replaces (bounds the quadratic fitting work). Default 400.
    pub max_segments: usize,
    /// Arcs of larger radius are not written; a straight piece stands in where it fits
    /// too. Default 1000.
    pub max_radius: f64,
    /// Replace runs that a straight line fits (within the tolerance, on the side) by one
    /// line. Default true.
    pub lines: bool,
    /// Let pieces start and end half-way along a segment as well as at its vertices, and
    /// choose the pieces that are fewest (a shortest path over the candidate runs) rather
    /// than the longest run from each start. A polygon's round corner, its vertices on the
    /// circle and its chords inside it, fits on the inside only from the middle of its
    /// first chord to the middle of its last. Never more pieces than segments. Default
    /// false.
    pub midpoints: bool,
}

impl Default for PlanarFitOptions {
    fn default() -> Self {
        Self {
            tolerance: 0.005,
            side: FitSide::Right,
            min_segments: 2,
            max_segments: 400,
            max_radius: 1000.0,
            lines: true,
            midpoints: false,
        }
    }
}

/// One piece of a fitted polyline, from the end of the previous piece (or the first
/// vertex) to [`to`](Self::to).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarPiece {
    /// Where the piece ends: vertex [`end`](Self::end), or with [`mid`](Self::mid) the middle
    /// of the segment from it to the next.
    pub to: [f64; 2],
    /// Index of the input vertex the piece ends at (or, with `mid`, after which it ends).
    pub end: usize,
    /// The piece ends half-way along the segment after vertex `end`
    /// ([`PlanarFitOptions::midpoints`]).
    pub mid: bool,
    /// `None`: a straight line; `Some((centre, direction))`: an arc (direction seen with
    /// the plane's first axis to the right and its second up, as G17 sees X and Y).
    pub arc: Option<([f64; 2], ArcDirection)>,
    /// The largest distance across the chord between the piece and the run it replaces
    /// (at least the distance between the curves; 0 for an input segment or half of one).
    pub deviation: f64,
}

/// A piece as [`fit_run`] finds it: an arc (`Some`) or a line, and its deviation.
type Fit = (Option<([f64; 2], ArcDirection)>, f64);

/// Points past a failed fit that [`fit_planar`] still tries before it closes a run.
const LOOKAHEAD: usize = 3;

/// Fitted runs [`fit_planar`] offers `verify`, longest first, before it gives up on a start.
const VERIFY_TRIES: usize = 6;

/// Fits `points` (a polyline, at least two vertices) with arcs and lines on
/// [`PlanarFitOptions::side`] of it, within [`PlanarFitOptions::tolerance`] (see the
/// [module docs](self)). Greedy: from each start the longest run that fits, then the next
/// start at its end; with [`PlanarFitOptions::midpoints`] the fewest pieces instead.
/// `verify(from, piece)` is asked before a piece from `from` is taken (a check the geometry
/// cannot make, such as a cutter's clearance along it); where it refuses every run from a
/// start, or none fits, the first segment stands alone. The pieces cover the polyline in
/// order; the last ends at its last vertex. A straight piece from vertex `i` with
/// `end == i + 1` is the input segment itself.
pub fn fit_planar(
    points: &[[f64; 2]],
    opts: &PlanarFitOptions,
    mut verify: impl FnMut(&[f64; 2], &PlanarPiece) -> bool,
) -> Vec<PlanarPiece> {
    if opts.midpoints {
        return fewest(points, opts, verify);
    }
    let n = points.len();
    let mut out = Vec::new();
    let mut i = 0;
    while i + 1 < n {
        let fits = runs_from(points, i, opts);
        let piece = fits
            .iter()
            .rev()
            .take(VERIFY_TRIES)
            .map(|&(k, (arc, deviation))| PlanarPiece { to: points[k], end: k, mid: false, arc, deviation })
            .find(|p| verify(&points[i], p))
            .unwrap_or(PlanarPiece { to: points[i + 1], end: i + 1, mid: false, arc: None, deviation: 0.0 });
        out.push(piece);
        i = piece.end;
    }
    out
}

/// The runs from `i` that fit: their last vertex and piece, shortest first.
fn runs_from(points: &[[f64; 2]], i: usize, opts: &PlanarFitOptions) -> Vec<(usize, Fit)> {
    let mut fits = Vec::new();
    if !(opts.tolerance.is_finite() && opts.tolerance > 0.0 && opts.max_radius > 0.0) {
        return fits;
    }
    let mut k = i + opts.min_segments.max(2);
    let mut misses = 0;
    while k < points.len() && misses <= LOOKAHEAD && k - i <= opts.max_segments {
        match fit_run(&points[i..=k], opts) {
            Some(fit) => {
                fits.push((k, fit));
                misses = 0;
            }
            None => misses += 1,
        }
        k += 1;
    }
    fits
}

/// [`fit_planar`] with midpoints: the segments halved, every run that fits a candidate
/// piece, and the fewest pieces from the first vertex to the last (each input segment,
/// whole or in halves, always a way through).
fn fewest(
    points: &[[f64; 2]],
    opts: &PlanarFitOptions,
    mut verify: impl FnMut(&[f64; 2], &PlanarPiece) -> bool,
) -> Vec<PlanarPiece> {
    let n = points.len();
    if n < 2 {
        return Vec::new();
    }
    // Vertex `j` is point `2 j`, the middle of segment `j` point `2 j + 1`.
    let mut pts = Vec::with_capacity(2 * n - 1);
    for w in points.windows(2) {
        pts.push(w[0]);
        pts.push([0.5 * (w[0][0] + w[1][0]), 0.5 * (w[0][1] + w[1][1])]);
    }
    pts.push(points[n - 1]);
    let m = pts.len();
    let piece = |k: usize, (arc, deviation): Fit| PlanarPiece {
        to: pts[k],
        end: k / 2,
        mid: k % 2 == 1,
        arc,
        deviation,
    };
    // Fewest pieces to each point, and the last piece there.
    let mut best: Vec<(usize, usize, Fit)> = vec![(usize::MAX, 0, (None, 0.0)); m];
    best[0].0 = 0;
    let sub = PlanarFitOptions { max_segments: 2 * opts.max_segments, ..*opts };
    for i in 0..m - 1 {
        let d = best[i].0;
        if d == usize::MAX {
            continue;
        }
        let relax = |k: usize, fit: Fit, best: &mut Vec<(usize, usize, Fit)>| {
            if d + 1 < best[k].0 {
                best[k] = (d + 1, i, fit);
            }
        };
        // The segment (from a vertex) or the half of it (from a middle) as it is.
        relax(if i % 2 == 0 { i + 2 } else { i + 1 }, (None, 0.0), &mut best);
        relax(i + 1, (None, 0.0), &mut best);
        for (k, fit) in runs_from(&pts, i, &sub) {
            if verify(&pts[i], &piece(k, fit)) {
                relax(k, fit, &mut best);
            }
        }
    }
    let mut out = Vec::new();
    let mut k = m - 1;
    while k > 0 {
        let (_, i, fit) = best[k];
        out.push(piece(k, fit));
        k = i;
    }
    out.reverse();
    out
}

/// The run in its chord's frame: `(s, h)` of each vertex, mirrored for [`FitSide::Left`]
/// so that the fit is always to the right; `None` unless `s` increases strictly.
struct Chord {
    a: [f64; 2],
    dir: [f64; 2],
    len: f64,
    local: Vec<[f64; 2]>,
    mirror: bool,
}

impl Chord {
    fn new(run: &[[f64; 2]], side: FitSide) -> Option<Chord> {
        let (a, b) = (run[0], run[run.len() - 1]);
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        if len <= 1e-12 * (1.0 + a[0].abs().max(a[1].abs())) || !len.is_finite() {
            return None;
        }
        let dir = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
        let mirror = side == FitSide::Left;
        let local: Vec<[f64; 2]> = run
            .iter()
            .map(|p| {
                let (dx, dy) = (p[0] - a[0], p[1] - a[1]);
                let h = -dir[1] * dx + dir[0] * dy;
                [dx * dir[0] + dy * dir[1], if mirror { -h } else { h }]
            })
            .collect();
        let m = local.len() - 1;
        // Strictly increasing along the chord, the ends exactly at 0 and `len`.
        let inside = local[1..m].iter().all(|p| p[0] > 0.0 && p[0] < len);
        let increasing = local.windows(2).all(|w| w[1][0] > w[0][0]);
        (inside && increasing).then_some(Chord { a, dir, len, local, mirror })
    }

    /// Half the chord.
    fn half(&self) -> f64 {
        0.5 * self.len
    }

    /// The signed mid-height of the minor arc through the chord's ends and `(s, h)`.
    fn mid_height(&self, [s, h]: [f64; 2]) -> f64 {
        if h == 0.0 {
            return 0.0;
        }
        let a = self.half();
        let c = (h * h - s * (self.len - s)) / (2.0 * h);
        let r = a.hypot(c);
        // `c + r` or `c - r`, without cancellation.
        match (h > 0.0, c < 0.0) {
            (true, true) => a * a / (r - c),
            (true, false) => c + r,
            (false, false) => -a * a / (r + c),
            (false, true) => c - r,
        }
    }

    /// Height of the arc of mid-height `m` at `s` (in `[0, len]`).
    fn height(&self, m: f64, s: f64) -> f64 {
        if m == 0.0 {
            return 0.0;
        }
        let a = self.half();
        let c = (m * m - a * a) / (2.0 * m);
        let q = (s * (self.len - s)).max(0.0);
        // `c + sign(m) sqrt(c^2 + q)`, the centre on the other side of the chord.
        m.signum() * q / ((c * c + q).sqrt() + c.abs())
    }

    /// `(min, max)` of `h - y` over the run, for the arc of mid-height `m`: at the vertices
    /// and where the arc's tangent is parallel to a segment.
    fn extremes(&self, m: f64) -> (f64, f64) {
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for p in &self.local {
            let f = p[1] - self.height(m, p[0]);
            lo = lo.min(f);
            hi = hi.max(f);
        }
        if m != 0.0 {
            let a = self.half();
            let r = (a * a + m * m) / (2.0 * m.abs());
            for w in self.local.windows(2) {
                let (p, q) = (w[0], w[1]);
                let mu = (q[1] - p[1]) / (q[0] - p[0]);
                let s = a - m.signum() * r * mu / (1.0 + mu * mu).sqrt();
                if s > p[0] && s < q[0] {
                    let f = p[1] + mu * (s - p[0]) - self.height(m, s);
                    lo = lo.min(f);
                    hi = hi.max(f);
                }
            }
        }
        (lo, hi)
    }

    /// The arc of mid-height `m` in the plane: its centre and direction.
    fn arc(&self, m: f64) -> ([f64; 2], ArcDirection) {
        let a = self.half();
        let c = (m * m - a * a) / (2.0 * m);
        let (c, m) = if self.mirror { (-c, -m) } else { (c, m) };
        let n = [-self.dir[1], self.dir[0]];
        let centre = [self.a[0] + self.dir[0] * a + n[0] * c, self.a[1] + self.dir[1] * a + n[1] * c];
        // Bulging to the left of the chord, the arc turns clockwise.
        let dir = if m > 0.0 { ArcDirection::Clockwise } else { ArcDirection::CounterClockwise };
        (centre, dir)
    }
}

/// The piece that replaces `run` (`None` inside: a line; `Some(arc)`) and its deviation,
/// if one fits.
fn fit_run(run: &[[f64; 2]], opts: &PlanarFitOptions) -> Option<Fit> {
    let chord = Chord::new(run, opts.side)?;
    let a = chord.half();
    // Numerical slack on the wrong side: far below any machine's resolution.
    let eps = 1e-9 * (1.0 + chord.len);
    let cap = a * (1.0 - 1e-6);
    let inner = &chord.local[1..chord.local.len() - 1];
    // The highest arc below every vertex, then lowered until it is below every segment.
    let mut m = inner.iter().map(|&p| chord.mid_height(p)).fold(cap, f64::min).max(-cap);
    if chord.extremes(m).0 < -eps {
        let mut lo = -cap;
        if chord.extremes(lo).0 < -eps {
            return None;
        }
        let mut hi = m;
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if chord.extremes(mid).0 < -eps {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        m = lo;
    }
    let deviation = chord.extremes(m).1;
    if deviation > opts.tolerance {
        return None;
    }
    let radius = if m == 0.0 { f64::INFINITY } else { (a * a + m * m) / (2.0 * m.abs()) };
    if radius <= opts.max_radius {
        return Some((Some(chord.arc(m)), deviation.max(0.0)));
    }
    // Nearly straight: the chord itself, where it lies on the side within the tolerance.
    let (lo, hi) = chord.extremes(0.0);
    (opts.lines && lo >= -eps && hi <= opts.tolerance).then_some((None, hi.max(0.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Signed distance of `p` from the arc's circle, positive outside.
    fn radial(p: [f64; 2], c: [f64; 2], r: f64) -> f64 {
        (p[0] - c[0]).hypot(p[1] - c[1]) - r
    }

    /// A 90-degree round join of radius 6 written as chords whose vertices lie outside the
    /// circle (as an offset's round join is) is one arc through its vertices when the
    /// piece may lie outside the chords; inside them it must cut the corners' first
    /// chords too, which takes more than 0.01.
    #[test]
    fn a_round_join_is_one_arc_on_the_side_asked_for() {
        let r = 6.0;
        let k = (std::f64::consts::FRAC_PI_2 / 0.1).ceil() as usize;
        let rv = r / (0.5 * std::f64::consts::FRAC_PI_2 / k as f64).cos();
        // Counter-clockwise about the origin: the circle's inside is on the left.
        let pts: Vec<[f64; 2]> = (0..=k)
            .map(|i| {
                let t = std::f64::consts::FRAC_PI_2 * i as f64 / k as f64;
                [rv * t.cos(), rv * t.sin()]
            })
            .collect();
        let fit = |side, tolerance| {
            fit_planar(&pts, &PlanarFitOptions { tolerance, side, ..Default::default() }, |_, _| true)
        };
        let outside = fit(FitSide::Right, 0.01);
        assert_eq!(outside.len(), 1, "{outside:?}");
        let (c, dir) = outside[0].arc.expect("an arc");
        assert_eq!(dir, ArcDirection::CounterClockwise);
        assert!(c[0].hypot(c[1]) < 1e-6, "the join's own centre: {c:?}");
        // Inside the chords the pieces must cut the join's first and last chords as well:
        // a looser tolerance takes fewer of them, each flatter than the join.
        let (tight, loose) = (fit(FitSide::Left, 0.01), fit(FitSide::Left, 0.1));
        assert!(loose.len() < tight.len() && loose.len() <= 2, "{loose:?} / {tight:?}");
        let (c, _) = loose[0].arc.expect("an arc");
        assert!(radial(pts[0], c, 0.0) > rv, "flatter than the join");
    }

    /// Every fitted piece lies on its side of the run it replaces, within the tolerance:
    /// checked densely on wavy runs of chords of circles of several radii, both ways round.
    #[test]
    fn pieces_stay_on_their_side_within_the_tolerance() {
        let mut next = crate::xorshift(0x2545_f491_4f6c_dd1d);
        let mut unit = move || (next() >> 11) as f64 / (1u64 << 53) as f64;
        let mut arcs = 0;
        for case in 0..60 {
            // A polyline along a slowly turning curve with jitter.
            let mut pts = vec![[0.0, 0.0]];
            let mut heading = unit() * 6.0;
            let turn = (unit() - 0.5) * 0.3;
            for _ in 0..60 {
                heading += turn + (unit() - 0.5) * 0.02;
                let l = 0.3 + unit();
                let p = pts[pts.len() - 1];
                pts.push([p[0] + l * heading.cos(), p[1] + l * heading.sin()]);
            }
            let side = if case % 2 == 0 { FitSide::Left } else { FitSide::Right };
            let tol = 0.002 + 0.05 * unit();
            let midpoints = case % 4 >= 2;
            let opts = PlanarFitOptions { tolerance: tol, side, midpoints, ..Default::default() };
            let pieces = fit_planar(&pts, &opts, |_, _| true);
            assert_eq!(pieces.last().map(|p| (p.end, p.mid)), Some((pts.len() - 1, false)));
            assert!(pieces.len() < pts.len());
            // The polyline with its segments halved: piece ends are among its points.
            let mut halved = Vec::new();
            for w in pts.windows(2) {
                halved.push(w[0]);
                halved.push([0.5 * (w[0][0] + w[1][0]), 0.5 * (w[0][1] + w[1][1])]);
            }
            halved.push(pts[pts.len() - 1]);
            let mut start = 0;
            for piece in &pieces {
                let end = 2 * piece.end + usize::from(piece.mid);
                assert_eq!(halved[end], piece.to);
                let run = &halved[start..=end];
                // Points of the piece, densely.
                let (a, b) = (run[0], run[run.len() - 1]);
                let piece_pts: Vec<[f64; 2]> = match piece.arc {
                    None => (0..=400)
                        .map(|i| {
                            let t = i as f64 / 400.0;
                            [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
                        })
                        .collect(),
                    Some((c, dir)) => {
                        arcs += 1;
                        let r = (a[0] - c[0]).hypot(a[1] - c[1]);
                        assert!((radial(b, c, r)).abs() < 1e-9 * (1.0 + r), "the end is on the arc");
                        let a0 = (a[1] - c[1]).atan2(a[0] - c[0]);
                        let a1 = (b[1] - c[1]).atan2(b[0] - c[0]);
                        let mut sweep = a1 - a0;
                        if dir == ArcDirection::CounterClockwise {
                            sweep = sweep.rem_euclid(std::f64::consts::TAU);
                        } else {
                            sweep = -(-sweep).rem_euclid(std::f64::consts::TAU);
                        }
                        assert!(sweep.abs() < std::f64::consts::PI, "a minor arc");
                        (0..=400)
                            .map(|i| {
                                let t = a0 + sweep * i as f64 / 400.0;
                                [c[0] + r * t.cos(), c[1] + r * t.sin()]
                            })
                            .collect()
                    }
                };
                // Each point of the piece: its distance to the run, and on which side.
                for q in &piece_pts {
                    let mut best = (f64::INFINITY, 0.0);
                    for w in run.windows(2) {
                        let (p0, p1) = (w[0], w[1]);
                        let d = [p1[0] - p0[0], p1[1] - p0[1]];
                        let l2 = d[0] * d[0] + d[1] * d[1];
                        let t = (((q[0] - p0[0]) * d[0] + (q[1] - p0[1]) * d[1]) / l2).clamp(0.0, 1.0);
                        let f = [p0[0] + t * d[0], p0[1] + t * d[1]];
                        let dist = (q[0] - f[0]).hypot(q[1] - f[1]);
                        if dist < best.0 {
                            let cross = d[0] * (q[1] - p0[1]) - d[1] * (q[0] - p0[0]);
                            best = (dist, cross);
                        }
                    }
                    assert!(best.0 <= tol + 1e-9, "case {case}: {} from the run (tolerance {tol})", best.0);
                    let wrong = match side {
                        FitSide::Left => best.1 < 0.0,
                        FitSide::Right => best.1 > 0.0,
                    };
                    assert!(!wrong || best.0 <= 1e-7, "case {case}: {} on the wrong side", best.0);
                }
                start = end;
            }
        }
        assert!(arcs > 100, "{arcs} arcs: the test would see little");
    }

    /// A run that a line fits within the tolerance becomes one line; one that bends more
    /// than the tolerance on the wrong side is left alone.
    #[test]
    fn straight_runs_are_one_line_and_wrong_bends_stay() {
        let pts: Vec<[f64; 2]> = (0..=10).map(|i| [i as f64, if i % 2 == 1 { 0.001 } else { 0.0 }]).collect();
        // The odd vertices stick out to the left: a piece on the right fits.
        let right = PlanarFitOptions { tolerance: 0.005, side: FitSide::Right, ..Default::default() };
        let pieces = fit_planar(&pts, &right, |_, _| true);
        assert!(
            matches!(pieces[..], [PlanarPiece { to: [10.0, 0.0], end: 10, mid: false, arc: None, .. }]),
            "{pieces:?}"
        );
        // A zigzag of 0.02 either way fits on neither side within 0.005.
        let zigzag: Vec<[f64; 2]> =
            (0..=10).map(|i| [i as f64, if i % 2 == 1 { 0.02 } else { -0.02 }]).collect();
        for side in [FitSide::Left, FitSide::Right] {
            let opts = PlanarFitOptions { tolerance: 0.005, side, ..Default::default() };
            assert_eq!(fit_planar(&zigzag, &opts, |_, _| true).len(), 10, "{side:?}");
        }
        // A bump of 0.01 on the left: a flat arc over it on the left is within 0.005.
        let bump = [[0.0, 0.0], [1.0, 0.01], [2.0, 0.0]];
        let left = PlanarFitOptions { tolerance: 0.005, side: FitSide::Left, ..Default::default() };
        let pieces = fit_planar(&bump, &left, |_, _| true);
        assert!(
            matches!(
                pieces[..],
                [PlanarPiece { end: 2, mid: false, arc: Some((_, ArcDirection::Clockwise)), .. }]
            ),
            "{pieces:?}"
        );
        // Verification refusing everything leaves every segment.
        let pieces = fit_planar(&pts, &right, |_, _| false);
        assert_eq!(pieces.len(), 10);
    }
}
