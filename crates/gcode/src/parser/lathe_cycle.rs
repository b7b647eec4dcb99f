//! `G70` (finishing), `G71`/`G71.1`/`G71.2` and `G72`/`G72.1`/`G72.2` (roughing along Z
//! and along X): LinuxCNC's lathe cycles, whose profile is the subroutine `o<Q>`.
//!
//! As in `rs274` (`interp_g7x.cc`): the block's line makes a rapid to the cycle's start
//! `X Z` and asks for the cycle ([`Interp::lathe`]); the control-flow driver then runs the
//! subroutine, whose lines make no moves but add segments to the profile
//! ([`Interp::profile_line`]); then [`Interp::lathe_run`] computes the passes
//! ([`super::lathe_path`]) and sends them as straight moves and arcs in the XZ plane,
//! through cutter compensation when it is on (`G70` only).

use nalgebra::Point3;

use super::comp::comp_refused;
use super::interp::{Fail, Interp, Mode, Res, hyp};
use super::lathe_geom::{C, Out, Seg, c};
use super::lathe_path::{Path, Rough};
use crate::error::GcodeErrorKind;
use crate::motion::{ArcDirection, Motion, MotionSink, Plane};

/// LinuxCNC `TOLERANCE_EQUAL`: an arc ending where the tool is is not made.
const EQUAL: f64 = 0.0001;

/// A lathe cycle whose block has run, waiting for its profile.
#[derive(Debug, Clone)]
pub(super) struct LatheRequest {
    /// The motion code × 10: 700, 710, 711, 712, 720, 721, 722.
    pub(super) code: u16,
    /// The profile subroutine's number.
    pub(super) q: i64,
    /// The cycle's start point (program units).
    x: f64,
    z: f64,
    /// `D E I P R U W`, or their defaults.
    words: [f64; 7],
    /// The block's stop (`M2`...), run after the cycle.
    pub(super) m_stop: Option<(u16, usize)>,
}

/// The profile being read: its segments and where it is (program units).
#[derive(Debug)]
pub(super) struct Profile {
    segs: Vec<Seg>,
    at: C,
    /// The motion mode of its lines (× 10), from the block's `G0`.
    mode: u16,
    incremental: bool,
    ijk_incremental: bool,
}

/// Whether motion code `code` (× 10) is a lathe cycle.
pub(super) fn is_lathe_cycle(code: u16) -> bool {
    matches!(code, 700 | 710 | 711 | 712 | 720 | 721 | 722)
}

/// `G71.2` style text of a cycle code.
fn name(code: u16) -> String {
    format!("G{}.{}", code / 10, code % 10)
}

impl Interp<'_> {
    /// The block of a lathe cycle: checks, the rapid to its start, and the request that
    /// the driver runs ([`super::flow`]).
    pub(super) fn g7x<S: MotionSink>(&mut self, code: u16, col: usize, sink: &mut S) -> Res<(), S::Error> {
        let Some(q) = self.block.get(b'q') else {
            return Err(Fail::Line(col, GcodeErrorKind::MissingWord { code: "G7x.x".into(), letter: 'Q' }));
        };
        if self.comp.side.is_some() && code / 10 != 70 {
            let what = format!("{} cannot be used with cutter compensation enabled", name(code));
            return Err(comp_refused(col, &what));
        }
        if self.plane != Plane::ZX {
            let what = format!("{} can only be used in XZ plane (G18)", name(code));
            return Err(Fail::Line(col, GcodeErrorKind::ModalConflict(what)));
        }
        if !self.in_flow {
            let what = "a lathe cycle outside O-word control flow".to_string();
            return Err(Fail::Line(col, GcodeErrorKind::ControlFlow(what)));
        }
        let s = self.scale();
        let before = [self.work(0), self.work(1), self.work(2)];
        let (mut x, mut z) = (before[0] / s, before[2] / s);
        let (bx, bz) = (self.block.get(b'x'), self.block.get(b'z'));
        if self.absolute {
            x = bx.unwrap_or(x);
            z = bz.unwrap_or(z);
        } else {
            x += bx.unwrap_or(0.0);
            z += bz.unwrap_or(0.0);
        }
        let defaults =
            [(b'd', 0.0), (b'e', 0.0), (b'i', 1.0), (b'p', 1.0), (b'r', 0.5), (b'u', 0.0), (b'w', 0.0)];
        let words = defaults.map(|(l, v)| self.block.get(l).unwrap_or(v));
        // LinuxCNC makes this rapid with the block's words read as absolute ones (even
        // under `G91`), through cutter compensation when it is on.
        let mut t = before;
        for (i, l) in [b'x', b'y', b'z'].into_iter().enumerate() {
            if let Some(v) = self.block.get(l) {
                t[i] = v * s;
            }
        }
        self.g7x_straight(true, t, sink)?;
        let q = q.round() as i64;
        self.lathe = Some(Box::new(LatheRequest { code, q, x, z, words, m_stop: None }));
        Ok(())
    }

    /// The profile's reading state, at the cycle's start.
    pub(super) fn profile_start(&self, req: &LatheRequest) -> Profile {
        Profile {
            segs: Vec::new(),
            at: c(req.z, req.x),
            mode: 0,
            incremental: !self.absolute,
            ijk_incremental: !self.ijk_absolute,
        }
    }

    /// One line of the profile subroutine (not an O-word line): its parameters are set and
    /// its move, if any, becomes a segment; nothing moves.
    pub(super) fn profile_line(
        &mut self,
        line: &[u8],
        prof: &mut Profile,
    ) -> Result<(), (usize, GcodeErrorKind)> {
        self.synced_line = u64::MAX;
        match self.lex(line) {
            Ok(true) => {}
            Ok(false) => return Ok(()),
            Err(Fail::Line(col, kind)) => return Err((col, kind)),
            Err(Fail::Sink(())) => return Ok(()),
        }
        let motion = match self.g_groups::<()>() {
            Ok(Some(g)) => g.g[1],
            Ok(None) => None,
            Err(Fail::Line(col, kind)) => return Err((col, kind)),
            Err(Fail::Sink(())) => None,
        };
        self.apply_assignments(line);
        if let Some((code, _)) = motion {
            prof.mode = code;
        }
        let end = self.profile_end(prof)?;
        if end == prof.at {
            return Ok(());
        }
        let start = prof.at;
        match prof.mode {
            0 | 10 => prof.segs.push(Seg::straight(start, end)),
            20 | 30 => {
                let center = self.profile_center(prof, start, end)?;
                prof.segs.push(Seg::round(prof.mode == 30, start, center, end));
            }
            _ => {}
        }
        if matches!(prof.mode, 0 | 10 | 20 | 30) {
            let (a, cw) = (self.block.get(b'a'), self.block.get(b'c'));
            if a.is_some() && cw.is_some() {
                let what = "G7X error: Both A and C parameters on a corner".to_string();
                return Err((self.block.col(b'c'), GcodeErrorKind::CannedCycle(what)));
            }
            if let Some(a) = a {
                prof.segs.push(Seg::finish(true, a, end));
            }
            if let Some(cw) = cw {
                prof.segs.push(Seg::finish(false, cw, end));
            }
        }
        let s = self.scale();
        let y = self.work(1);
        self.set_work([end.im * s, y, end.re * s]);
        prof.at = end;
        Ok(())
    }

    /// The end point of a profile line's move: `X Z`, or `U W` added.
    fn profile_end(&self, prof: &Profile) -> Result<C, (usize, GcodeErrorKind)> {
        let blk = &self.block;
        let err =
            |l: u8, what: &str| Err((blk.col(l), GcodeErrorKind::CannedCycle(format!("G7x error: {what}"))));
        let mut end = if prof.incremental { c(0.0, 0.0) } else { prof.at };
        for (rel, abs, axis) in [(b'u', b'x', 'X'), (b'w', b'z', 'Z')] {
            let v = if let Some(d) = blk.get(rel) {
                let letter = rel.to_ascii_uppercase() as char;
                if prof.incremental {
                    return err(rel, &format!("Cannot use {letter} in incremental mode (G91)"));
                }
                if blk.has(abs) {
                    return err(rel, &format!("Cannot use {letter} and {axis} in the same block"));
                }
                Some(if rel == b'u' { end.im } else { end.re } + d)
            } else {
                blk.get(abs)
            };
            if let Some(v) = v {
                if rel == b'u' {
                    end.im = v;
                } else {
                    end.re = v;
                }
            }
        }
        if prof.incremental {
            end += prof.at;
        }
        Ok(end)
    }

    /// The centre of a profile arc from `start` to `end`: `R`, or `I K`.
    fn profile_center(&self, prof: &Profile, start: C, end: C) -> Result<C, (usize, GcodeErrorKind)> {
        let blk = &self.block;
        let col = [b'r', b'i', b'k', b'x', b'z'].iter().find(|&&l| blk.has(l)).map_or(0, |&l| blk.col(l));
        let err = |what: &str| Err((col, GcodeErrorKind::CannedCycle(format!("G7X error: {what}"))));
        if let Some(r) = blk.get(b'r') {
            if blk.has(b'i') || blk.has(b'k') {
                return err("both R and I or K flag used for arc");
            }
            let chord = end - start;
            let n = chord.norm();
            let d = super::lathe_geom::I * ((r * r - n / 4.0) / n).sqrt() * chord;
            let mid = (start + end) / 2.0;
            return Ok(if prof.mode == 30 { mid + d } else { mid - d });
        }
        if !blk.has(b'i') && !blk.has(b'k') {
            return err("either I or K must be present for arc");
        }
        let center = c(blk.get(b'k').unwrap_or(0.0), blk.get(b'i').unwrap_or(0.0));
        Ok(if prof.ijk_incremental { center + start } else { center })
    }

    /// The cycle itself, once its profile is read: its passes as moves.
    pub(super) fn lathe_run<S: MotionSink>(
        &mut self,
        req: &LatheRequest,
        prof: Profile,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let mode = match prof.mode {
            0 => Some(Mode::Rapid),
            10 => Some(Mode::Linear),
            20 => Some(Mode::Arc(ArcDirection::Clockwise)),
            30 => Some(Mode::Arc(ArcDirection::CounterClockwise)),
            _ => None,
        };
        self.mode = mode;
        let segs = prof.segs;
        if segs.len() <= 1 {
            // LinuxCNC leaves the point at the profile's end.
            return Ok(());
        }
        let [d, e, i, p, r, u, w] = req.words;
        if i <= 0.0 {
            let what = "G7X error: I must be greater than zero.".to_string();
            return Err(Fail::Line(0, GcodeErrorKind::CannedCycle(what)));
        }
        // The installed `rs274` (2.9.0~pre1) neither puts the point back at the block's
        // start here nor closes a `G71`/`G72` profile back to the start's X (Z), as later
        // LinuxCNC does: the passes start from the profile's end.
        let (x, z) = (req.x, req.z);
        let cycle = req.code / 10;
        let path = Path::new(segs);
        let mut moves = Vec::new();
        let rough = Rough { cycle: (req.code % 10) as u8, x, z, u, w, d, i, r };
        let result = match cycle {
            70 => path.g70(x, z, d, e, p, &mut moves),
            71 => path.rough(&rough, false, &mut moves),
            _ => path.rough(&rough, true, &mut moves),
        };
        // A degenerate profile (an arc whose radius is shorter than half its chord, an
        // offset of nothing) can give passes at NaN: refused whole, before any is made.
        if !moves.iter().all(Out::is_finite) {
            let what = "G7X error: the profile gives passes at no finite point".to_string();
            return Err(Fail::Line(0, GcodeErrorKind::CannedCycle(what)));
        }
        for m in moves {
            self.g7x_move(m, sink)?;
        }
        result.map_err(|why| Fail::Line(0, GcodeErrorKind::CannedCycle(format!("G7X error: {why}"))))
    }

    /// One move of a cycle (program units), as LinuxCNC's `convert_straight` or
    /// `convert_arc` makes it.
    fn g7x_move<S: MotionSink>(&mut self, m: Out, sink: &mut S) -> Res<(), S::Error> {
        let s = self.scale();
        let y = self.work(1);
        let at = |p: C| [p.im * s, y, p.re * s];
        match m {
            Out::Rapid(p) => self.g7x_straight(true, at(p), sink),
            Out::Feed(p) => self.g7x_straight(false, at(p), sink),
            Out::Arc { ccw, center, end } => {
                let (cx, cz) = (self.work(0) / s, self.work(2) / s);
                if (cz - end.re).abs() < EQUAL && (cx - end.im).abs() < EQUAL {
                    return Ok(());
                }
                self.g7x_arc(ccw, at(center), at(end), sink)
            }
        }
    }

    /// A straight move of a cycle to `t` (work coordinates, mm).
    fn g7x_straight<S: MotionSink>(&mut self, rapid: bool, t: [f64; 3], sink: &mut S) -> Res<(), S::Error> {
        self.mode = Some(if rapid { Mode::Rapid } else { Mode::Linear });
        if !rapid {
            self.need_feed("G1")?;
        }
        if self.comp.side.is_some() || self.comp.arc_not_allowed {
            self.comp.arc_not_allowed = false;
            self.comp.tool_at = None;
            if self.comp.active() {
                return self.comp_straight(rapid, self.feed, t, sink);
            }
        }
        self.set_work(t);
        let to = Point3::new(t[0], t[1], t[2]);
        if rapid {
            self.emit(sink, &Motion::Rapid { to })
        } else {
            self.emit(sink, &Motion::Linear { to, feed: self.feed, extrude: None })
        }
    }

    /// An arc of a cycle about `center` to `end` (work coordinates, mm).
    fn g7x_arc<S: MotionSink>(
        &mut self,
        ccw: bool,
        center: [f64; 3],
        end: [f64; 3],
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let dir = if ccw { ArcDirection::CounterClockwise } else { ArcDirection::Clockwise };
        self.mode = Some(Mode::Arc(dir));
        if self.comp.arc_not_allowed {
            return Err(comp_refused(
                0,
                "the move just after exiting cutter compensation mode must be straight, not an arc",
            ));
        }
        self.need_feed(if ccw { "G3" } else { "G2" })?;
        let start = self.move_start();
        let r1 = hyp(center[2] - start[2], center[0] - start[0]);
        let r2 = hyp(center[2] - end[2], center[0] - end[0]);
        let abs_tol = self.opts.arc_tolerance_mm * if self.inch { 2.54 } else { 1.0 };
        let abs_err = (r1 - r2).abs();
        if abs_err > abs_tol * 100.0
            || (abs_err / r1.max(r2) > self.opts.arc_relative_tolerance && abs_err > abs_tol)
        {
            return Err(Fail::Line(
                0,
                GcodeErrorKind::ArcRadiusMismatch { start_radius: r1, end_radius: r2 },
            ));
        }
        if self.comp.active() {
            return self.comp_arc(self.feed, end, [center[2], center[0]], if ccw { 1 } else { -1 }, sink);
        }
        self.set_work(end);
        let motion = Motion::Arc {
            to: Point3::new(end[0], end[1], end[2]),
            center: Point3::new(center[0], start[1], center[2]),
            plane: Plane::ZX,
            direction: dir,
            turns: 0,
            feed: self.feed,
            extrude: None,
        };
        self.emit(sink, &motion)
    }
}
