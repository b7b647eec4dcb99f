//! Motions beyond straight moves, arcs and drilling cycles, as LinuxCNC runs them:
//! spindle-synchronised feeds (`G33`, rigid tapping `G33.1`), probing (`G38.2`-`G38.5`),
//! splines (`G5` cubic, `G5.1` quadratic, in the XY plane), and inverse-time feed (`G93`).

use nalgebra::Point3;

use super::interp::{Fail, Interp, Res, hyp};
use crate::error::GcodeErrorKind;
use crate::motion::{Motion, MotionSink, Plane};

/// `rs274`'s probe back-off (0.01 inch; 0.254 mm in metric programs, the same length).
const PROBE_BACKOFF_MM: f64 = 0.254;
/// A probe move toward a point must be longer than this (`rs274` refuses a zero one).
const PROBE_MIN_MM: f64 = 1e-9;
/// Most straight segments one spline block becomes.
const MAX_SPLINE_SEGMENTS: usize = 10_000;

impl Interp<'_> {
    /// Runs motion code `code` (× 10): `G5`, `G5.1`, `G33`, `G33.1`, `G38.x` or `G76`.
    pub(super) fn special<S: MotionSink>(
        &mut self,
        code: u16,
        col: usize,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        if self.comp.side.is_some() && !super::lathe_cycle::is_lathe_cycle(code) {
            let refused = match code {
                50 | 51 => Some("cannot convert spline with cutter radius compensation"),
                382..=385 => Some("cannot probe with cutter radius comp on"),
                // LinuxCNC runs these through its straight moves, whose compensation
                // knows G0 and G1 only.
                _ if self.comp.active() => Some("G33, G33.1 and G76 are not G0 or G1"),
                _ => None,
            };
            if let Some(what) = refused {
                return Err(super::comp::comp_refused(col, what));
            }
        }
        match code {
            50 | 51 => self.spline(code == 50, col, sink),
            330 | 331 => self.spindle_sync(code == 331, col, sink),
            760 => self.g76(col, sink),
            c if super::lathe_cycle::is_lathe_cycle(c) => self.g7x(c, col, sink),
            _ => self.probe(code, col, sink),
        }
    }

    /// The feed rate (mm/min) of a feed move of `len` mm: the modal one, or under `G93`
    /// the block's F word (moves per minute) times the length, which the block must give.
    pub(super) fn move_feed<E>(&mut self, len: f64, what: &str) -> Res<f64, E> {
        if !self.inverse_time {
            self.need_feed(what)?;
            return Ok(self.feed);
        }
        match self.block.get(b'f') {
            Some(f) if f > 0.0 => Ok(f * len),
            _ => {
                let col = if self.block.has(b'f') { self.block.col(b'f') } else { 0 };
                Err(Fail::Line(
                    col,
                    GcodeErrorKind::ZeroFeed(format!("F word missing with inverse time {what} move")),
                ))
            }
        }
    }

    /// `G33` (a straight feed whose speed follows the spindle: K is the distance per
    /// revolution) and `G33.1` (rigid tapping: in to the target and back out to the start
    /// along the same line; the position does not change).
    fn spindle_sync<S: MotionSink>(&mut self, tap: bool, col: usize, sink: &mut S) -> Res<(), S::Error> {
        let Some(k) = self.block.get(b'k') else {
            let code = if tap { "G33.1" } else { "G33" };
            return Err(Fail::Line(col, GcodeErrorKind::MissingWord { code: code.into(), letter: 'K' }));
        };
        if k <= 0.0 {
            return Err(Fail::Line(self.block.col(b'k'), GcodeErrorKind::BadValue(format!("pitch K{k}"))));
        }
        let start = self.work_pos();
        let t = self.target(false);
        let to = Point3::new(t[0], t[1], t[2]);
        let feed = k * self.scale() * self.rpm;
        self.emit(sink, &Motion::Linear { to, feed, extrude: None })?;
        if tap {
            return self.emit(sink, &Motion::Linear { to: start, feed, extrude: None });
        }
        self.set_work(t);
        Ok(())
    }

    /// `G38.2`-`G38.5`: a feed toward the target. Without a probe input the probe never
    /// trips before it, as in `rs274`'s simulation: the move reaches the target, the
    /// position backs off 0.254 mm towards the start, `#5061`-`#5063` hold the target
    /// (program units) and `#5070` is 0.
    fn probe<S: MotionSink>(&mut self, code: u16, col: usize, sink: &mut S) -> Res<(), S::Error> {
        let start = [self.work(0), self.work(1), self.work(2)];
        let t = self.target(false);
        let d = [start[0] - t[0], start[1] - t[1], start[2] - t[2]];
        let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        // Probing toward a point needs a move; probing away (`G38.4`, `G38.5`) does not.
        if dist <= PROBE_MIN_MM && code <= 383 {
            return Err(Fail::Line(
                col,
                GcodeErrorKind::BadValue("start point too close to probe point".into()),
            ));
        }
        let feed = self.move_feed(dist, "G38")?;
        self.emit(sink, &Motion::Linear { to: Point3::new(t[0], t[1], t[2]), feed, extrude: None })?;
        let s = self.scale();
        for (i, v) in t.iter().enumerate() {
            self.params.numbered[5061 + i] = v / s;
        }
        self.params.numbered[5070] = 0.0;
        let k = if dist > 0.0 { PROBE_BACKOFF_MM / dist } else { 0.0 };
        self.set_work([t[0] + k * d[0], t[1] + k * d[1], t[2] + k * d[2]]);
        Ok(())
    }

    /// `G5` (cubic: `I J` from the start to the first control point, `P Q` from the end
    /// to the second; after a `G5`, `I J` may be left out and mirror its `P Q`) and `G5.1`
    /// (quadratic: `I J` from the start to the control point), in the XY plane, as
    /// straight feeds within [`ParseOptions::spline_tolerance_mm`](crate::ParseOptions::spline_tolerance_mm).
    fn spline<S: MotionSink>(&mut self, cubic: bool, col: usize, sink: &mut S) -> Res<(), S::Error> {
        if self.plane != Plane::XY {
            return Err(Fail::Line(
                col,
                GcodeErrorKind::ModalConflict("splines need the XY plane (G17)".into()),
            ));
        }
        let s = self.scale();
        let p0 = [self.work(0), self.work(1)];
        let t = self.target(false);
        let p3 = [t[0], t[1]];
        let word = |l: u8| self.block.get(l).map(|v| v * s);
        let mut ctrl = Vec::with_capacity(4);
        ctrl.push(p0);
        if cubic {
            let ij = match (word(b'i'), word(b'j'), self.last_spline_pq) {
                (None, None, Some((p, q))) => [-p, -q],
                (None, None, None) => {
                    return Err(Fail::Line(
                        col,
                        GcodeErrorKind::MissingWord { code: "G5".into(), letter: 'I' },
                    ));
                }
                (i, j, _) => [i.unwrap_or(0.0), j.unwrap_or(0.0)],
            };
            let (Some(p), Some(q)) = (word(b'p'), word(b'q')) else {
                return Err(Fail::Line(col, GcodeErrorKind::MissingWord { code: "G5".into(), letter: 'P' }));
            };
            ctrl.push([p0[0] + ij[0], p0[1] + ij[1]]);
            ctrl.push([p3[0] + p, p3[1] + q]);
            self.last_spline_pq = Some((p, q));
        } else {
            let (i, j) = (word(b'i').unwrap_or(0.0), word(b'j').unwrap_or(0.0));
            if i == 0.0 && j == 0.0 {
                return Err(Fail::Line(
                    col,
                    GcodeErrorKind::MissingWord { code: "G5.1".into(), letter: 'I' },
                ));
            }
            ctrl.push([p0[0] + i, p0[1] + j]);
            self.last_spline_pq = None;
        }
        ctrl.push(p3);
        // The chord of a segment strays at most |B''| h² / 8 from a curve of parameter step h.
        let bend = ctrl
            .windows(3)
            .map(|w| hyp(w[0][0] - 2.0 * w[1][0] + w[2][0], w[0][1] - 2.0 * w[1][1] + w[2][1]))
            .fold(0.0, f64::max)
            * (ctrl.len() - 1) as f64
            * (ctrl.len() - 2) as f64;
        let tol = self.opts.spline_tolerance_mm.max(1e-9);
        let n = ((bend / (8.0 * tol)).sqrt().ceil() as usize).clamp(1, MAX_SPLINE_SEGMENTS);
        let len: f64 = ctrl.windows(2).map(|w| hyp(w[1][0] - w[0][0], w[1][1] - w[0][1])).sum();
        let feed = self.move_feed(len, if cubic { "G5" } else { "G5.1" })?;
        let (z0, z1) = (self.work(2), t[2]);
        for k in 1..=n {
            let u = k as f64 / n as f64;
            let p = bezier(&ctrl, u);
            let z = z0 + (z1 - z0) * u;
            let to = if k == n { Point3::new(t[0], t[1], t[2]) } else { Point3::new(p[0], p[1], z) };
            self.set_work([to.x, to.y, to.z]);
            self.emit(sink, &Motion::Linear { to, feed, extrude: None })?;
        }
        Ok(())
    }
}

/// De Casteljau's point at parameter `u` of the Bézier curve with control points `ctrl`.
fn bezier(ctrl: &[[f64; 2]], u: f64) -> [f64; 2] {
    let mut p = [[0.0; 2]; 4];
    let n = ctrl.len().min(4);
    p[..n].copy_from_slice(&ctrl[..n]);
    for r in 1..n {
        for i in 0..n - r {
            let next = p[i + 1];
            for (a, b) in p[i].iter_mut().zip(next) {
                *a = *a * (1.0 - u) + b * u;
            }
        }
    }
    p[0]
}
