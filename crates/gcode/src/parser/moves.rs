//! Moves: straight moves (with the fast path), arcs, rotary setups, homing and offsets.

use nalgebra::Point3;

use super::comp::comp_refused;
use super::interp::{AXES, Fail, Interp, Mode, OFFS, RADIUS_TOLERANCE_MM, Res, bit, hyp};
use crate::error::GcodeErrorKind;
use crate::motion::{ArcDirection, Motion, MotionSink, Plane};
use crate::rotary::{RotaryAxes, RotaryMount, rotary_axis, rotary_frame};

impl Interp<'_> {
    /// The common block `[G0|G1] [X..] [Y..] [Z..] [E..] [F..] [N..]` in G0/G1 mode, with
    /// the general path's semantics. Returns `false` (nothing done) for any other block.
    #[inline]
    pub(super) fn fast_straight<S: MotionSink>(&mut self, sink: &mut S) -> Res<bool, S::Error> {
        const WORDS: u32 = bit(b'x') | bit(b'y') | bit(b'z') | bit(b'e') | bit(b'f') | bit(b'n');
        const XYZ: u32 = bit(b'x') | bit(b'y') | bit(b'z');
        let blk = &self.block;
        if blk.nm != 0 || blk.novalue != 0 || blk.mask & !WORDS != 0 || blk.ng > 1 {
            return Ok(false);
        }
        let explicit = match (blk.ng, blk.g[0].0) {
            (0, _) => None,
            (_, 0) => Some(Mode::Rapid),
            (_, 10) => Some(Mode::Linear),
            _ => return Ok(false),
        };
        let mode = match explicit.or(self.mode) {
            Some(m @ (Mode::Rapid | Mode::Linear)) if !self.inverse_time => m,
            _ => return Ok(false),
        };
        if blk.get(b'n').is_some_and(|n| n < 0.0) || blk.get(b'f').is_some_and(|f| f < 0.0) {
            return Ok(false);
        }
        let has_e = blk.has(b'e');
        let has_axes = blk.mask & XYZ != 0;
        if has_e {
            self.fdm_evidence();
        }
        if let Some(f) = self.block.get(b'f') {
            self.feed = f * self.scale();
        }
        if explicit.is_some() {
            self.cycle_il = None;
            self.mode = Some(mode);
        }
        if explicit.is_some() || has_axes || (has_e && self.fdm) {
            self.straight(mode == Mode::Rapid, false, sink)?;
        }
        Ok(true)
    }

    /// Target of a straight move in work coordinates, from the axis words.
    #[inline]
    pub(super) fn target(&self, g53: bool) -> [f64; 3] {
        let s = self.scale();
        if g53 {
            let mut m = self.mpos;
            for (i, &axis) in AXES.iter().enumerate() {
                if let Some(v) = self.block.get(axis) {
                    m[i] = v * s;
                }
            }
            return self.work_of(m);
        }
        let mut t = self.move_start();
        for i in 0..3 {
            if let Some(v) = self.block.get(AXES[i]) {
                let v = v * s;
                t[i] = if self.absolute { v } else { t[i] + v };
            }
        }
        t
    }

    /// Where a move starts, for its incremental words and arc centre: the current point,
    /// or under cutter compensation (after the entry move) the programmed one.
    #[inline]
    pub(super) fn move_start(&self) -> [f64; 3] {
        if self.comp.active() && !self.comp.first {
            self.comp.program
        } else {
            [self.work(0), self.work(1), self.work(2)]
        }
    }

    /// Extrusion of this block's E word (mm of filament), updating the E position.
    pub(super) fn extrusion(&mut self) -> Option<f64> {
        let e = self.block.get(b'e').map(|e| e * self.scale());
        if !self.e_axis {
            return None;
        }
        Some(match e {
            None => 0.0,
            Some(e) if self.e_relative => {
                self.e_pos += e;
                e
            }
            Some(e) => {
                let d = e - self.e_pos;
                self.e_pos = e;
                d
            }
        })
    }

    pub(super) fn straight<S: MotionSink>(
        &mut self,
        rapid: bool,
        g53: bool,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let t = self.target(g53);
        if self.comp.side.is_some() || self.comp.arc_not_allowed {
            self.comp.arc_not_allowed = false;
            self.comp.tool_at = None;
            if self.comp.active() {
                return self.straight_compensated(rapid, g53, t, sink);
            }
        }
        let extrude = self.extrusion();
        let to = Point3::new(t[0], t[1], t[2]);
        // Marlin treats G0 like G1: a G0 that extrudes is reported as a feed move.
        if rapid && extrude.is_none_or(|e| e == 0.0) {
            self.set_work(t);
            return self.emit(sink, &Motion::Rapid { to });
        }
        let what = if rapid { "G0 with E" } else { "G1" };
        let feed = if self.inverse_time {
            let start = self.work_pos();
            self.move_feed((to - start).norm(), what)?
        } else {
            self.need_feed(what)?;
            self.feed
        };
        self.set_work(t);
        self.emit(sink, &Motion::Linear { to, feed, extrude })
    }

    /// A straight move to `t` under cutter radius compensation.
    #[cold]
    fn straight_compensated<S: MotionSink>(
        &mut self,
        rapid: bool,
        g53: bool,
        t: [f64; 3],
        sink: &mut S,
    ) -> Res<(), S::Error> {
        if g53 {
            let col =
                AXES.iter().filter(|&&l| self.block.has(l)).map(|&l| self.block.col(l)).min().unwrap_or(0);
            return Err(comp_refused(col, "cannot use G53 with cutter radius comp"));
        }
        let feed = if rapid {
            self.feed
        } else if self.inverse_time {
            let s = self.move_start();
            self.move_feed(hyp(hyp(t[0] - s[0], t[1] - s[1]), t[2] - s[2]), "G1")?
        } else {
            self.need_feed("G1")?;
            self.feed
        };
        self.comp_straight(rapid, feed, t, sink)
    }

    /// With [`ParseOptions::rotary`](crate::ParseOptions::rotary): emits the setup (on a
    /// head, [`ParseOptions::rotary_mount`](crate::ParseOptions::rotary_mount), the tool
    /// axis) of the block's rotary words, if any. Returns `true` when the block has no
    /// other move words (nothing else moves).
    pub(super) fn rotary_setup<S: MotionSink>(&mut self, sink: &mut S) -> Res<bool, S::Error> {
        let Some(axes) = self.opts.rotary else { return Ok(false) };
        let letters: [Option<u8>; 3] = match axes {
            RotaryAxes::AC => [Some(b'a'), None, Some(b'c')],
            RotaryAxes::BC => [None, Some(b'b'), Some(b'c')],
        };
        let mask = letters.iter().flatten().fold(0, |m, &l| m | bit(l));
        if self.block.mask & mask == 0 {
            return Ok(false);
        }
        for (i, l) in letters.iter().enumerate() {
            if let Some(v) = l.and_then(|l| self.block.get(l)) {
                self.rot[i] = if self.absolute { v } else { self.rot[i] + v };
            }
        }
        let rotary = [0, 1, 2].map(|i| letters[i].map(|_| self.rot[i]));
        let turn = match self.opts.rotary_mount {
            RotaryMount::Table => Motion::Setup { frame: rotary_frame(axes, self.rot), rotary },
            RotaryMount::Head => Motion::ToolAxis { axis: rotary_axis(axes, self.rot), rotary },
        };
        self.emit(sink, &turn)?;
        let others = bit(b'x') | bit(b'y') | bit(b'z') | bit(b'u') | bit(b'v') | bit(b'w') | bit(b'e');
        Ok(self.block.mask & others == 0)
    }

    pub(super) fn plane_axes(&self) -> (usize, usize, usize) {
        match self.plane {
            Plane::XY => (0, 1, 2),
            Plane::ZX => (2, 0, 1),
            Plane::YZ => (1, 2, 0),
        }
    }

    pub(super) fn arc<S: MotionSink>(
        &mut self,
        dir: ArcDirection,
        explicit_col: Option<usize>,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        if self.comp.arc_not_allowed {
            let col = explicit_col.unwrap_or(0);
            return Err(comp_refused(
                col,
                "the move just after exiting cutter compensation mode must be straight, not an arc",
            ));
        }
        let (u, v, w) = self.plane_axes();
        let s = self.scale();
        let start = self.move_start();
        let end = self.target(false);
        let has_r = self.block.has(b'r');
        let has_ij = self.block.has(OFFS[u]) || self.block.has(OFFS[v]);
        let has_end = self.block.has(AXES[0]) || self.block.has(AXES[1]) || self.block.has(AXES[2]);
        let col0 = explicit_col.unwrap_or_else(|| {
            AXES.iter().filter(|&&l| self.block.has(l)).map(|&l| self.block.col(l)).min().unwrap_or(0)
        });
        if !has_r && !has_ij {
            if !self.strict && !has_end {
                // `G2` alone on a line: only the mode changes (grbl, cncjs).
                return Ok(());
            }
            if self.fdm {
                // Printer firmware drift: a straight move, with a warning.
                self.warn(col0, GcodeErrorKind::ArcMissingCenter);
            } else {
                // `rs274`: "R, I, J, K words all missing for arc".
                return Err(Fail::Line(col0, GcodeErrorKind::ArcMissingCenter));
            }
            self.need_feed("arc")?;
            let extrude = self.extrusion();
            self.set_work(end);
            let to = Point3::new(end[0], end[1], end[2]);
            return self.emit(sink, &Motion::Linear { to, feed: self.feed, extrude });
        }
        let turns = match self.block.get(b'p') {
            None => 0,
            Some(p) if p >= 1.0 && p.fract() == 0.0 && p < 1e6 => p as u32 - 1,
            Some(p) => {
                return Err(Fail::Line(
                    self.block.col(b'p'),
                    GcodeErrorKind::BadValue(format!("arc turns P{p}")),
                ));
            }
        };
        let (su, sv, eu, ev) = (start[u], start[v], end[u], end[v]);
        let (cu, cv);
        if has_r {
            let Some(c) = self.r_center(dir, [su, sv, eu, ev])? else { return Ok(()) };
            (cu, cv) = c;
        } else {
            let i = self.block.get(OFFS[u]).unwrap_or(0.0) * s;
            let j = self.block.get(OFFS[v]).unwrap_or(0.0) * s;
            if self.ijk_absolute {
                cu = i;
                cv = j;
            } else {
                cu = su + i;
                cv = sv + j;
            }
            let r1 = hyp(cu - su, cv - sv);
            let r2 = hyp(cu - eu, cv - ev);
            if r1 < RADIUS_TOLERANCE_MM || r2 < RADIUS_TOLERANCE_MM {
                return Err(Fail::Line(col0, GcodeErrorKind::ArcDegenerate("zero radius".into())));
            }
            let abs_tol = self.opts.arc_tolerance_mm * if self.inch { 2.54 } else { 1.0 };
            let abs_err = (r1 - r2).abs();
            let rel_err = abs_err / r1.max(r2);
            if abs_err > abs_tol * 100.0 || (rel_err > self.opts.arc_relative_tolerance && abs_err > abs_tol)
            {
                return Err(Fail::Line(
                    col0,
                    GcodeErrorKind::ArcRadiusMismatch { start_radius: r1, end_radius: r2 },
                ));
            }
        }
        let what = if dir == ArcDirection::Clockwise { "G2" } else { "G3" };
        let feed = if self.inverse_time {
            // Under G93 the feed follows the arc's length (angle swept times radius, with
            // the helix); computed only then, to keep plain arcs cheap.
            let (a0, a1) = ((sv - cv).atan2(su - cu), (end[v] - cv).atan2(end[u] - cu));
            let mut sweep = if dir == ArcDirection::Clockwise { a0 - a1 } else { a1 - a0 };
            if sweep <= 0.0 {
                sweep += std::f64::consts::TAU;
            }
            sweep += std::f64::consts::TAU * turns as f64;
            self.move_feed(hyp(sweep * hyp(su - cu, sv - cv), end[w] - start[w]), what)?
        } else {
            self.need_feed(what)?;
            self.feed
        };
        if self.comp.active() {
            let n = turns as i32 + 1;
            let turn = if dir == ArcDirection::CounterClockwise { n } else { -n };
            return self.comp_arc(feed, end, [cu, cv], turn, sink);
        }
        let mut c = start;
        c[u] = cu;
        c[v] = cv;
        c[w] = start[w];
        let extrude = self.extrusion();
        self.set_work(end);
        let plane = self.plane;
        self.emit(
            sink,
            &Motion::Arc {
                to: Point3::new(end[0], end[1], end[2]),
                center: Point3::new(c[0], c[1], c[2]),
                plane,
                direction: dir,
                turns,
                feed,
                extrude,
            },
        )
    }

    /// The centre of an `R` arc from `(su, sv)` to `(eu, ev)` in the plane; `None` when
    /// the lenient fallback makes no move.
    fn r_center<E>(&mut self, dir: ArcDirection, [su, sv, eu, ev]: [f64; 4]) -> Res<Option<(f64, f64)>, E> {
        let s = self.scale();
        let r_raw = self.block.get(b'r').unwrap_or(0.0) * s;
        let col = self.block.col(b'r');
        if su == eu && sv == ev {
            // Lenient fallback: the centre is unknown, so no move is reported.
            self.lenient(col, GcodeErrorKind::ArcDegenerate("R-format arc ends at its start".into()))?;
            return Ok(None);
        }
        let mut ar = r_raw.abs();
        let (mu, mv) = ((eu + su) / 2.0, (ev + sv) / 2.0);
        let mut half = hyp(mu - eu, mv - ev);
        if half - ar > RADIUS_TOLERANCE_MM {
            // Lenient fallback: a half circle through both points.
            self.lenient(col, GcodeErrorKind::ArcRadiusTooSmall { radius: ar, half_chord: half })?;
            ar = half;
        }
        if ar == 0.0 {
            return Err(Fail::Line(col, GcodeErrorKind::ArcDegenerate("zero radius".into())));
        }
        if half / ar > 1.0 - 1e-12 {
            half = ar;
        }
        let cw = dir == ArcDirection::Clockwise;
        let base = (ev - sv).atan2(eu - su);
        let theta = if (cw && r_raw > 0.0) || (!cw && r_raw < 0.0) {
            base - std::f64::consts::FRAC_PI_2
        } else {
            base + std::f64::consts::FRAC_PI_2
        };
        let turn2 = (half / ar).asin();
        let off = ar * turn2.cos();
        Ok(Some((mu + off * theta.cos(), mv + off * theta.sin())))
    }

    pub(super) fn home<S: MotionSink>(&mut self, code: u16, col: usize, sink: &mut S) -> Res<(), S::Error> {
        let given: Vec<usize> = (0..3).filter(|&i| self.block.has(AXES[i])).collect();
        if self.fdm && code == 280 {
            // Marlin homing: the named axes (all when none) go to machine zero.
            let all = given.is_empty();
            for i in 0..3 {
                if all || given.contains(&i) {
                    self.mpos[i] = 0.0;
                    self.g92[i] = 0.0;
                }
            }
            let _ = col;
            let to = self.work_pos();
            return self.emit(sink, &Motion::Rapid { to });
        }
        self.comp.tool_at = None;
        let base = if code == 280 { 5161 } else { 5181 };
        // The intermediate point (the current one when no axis word is given), as rs274 does.
        let t = self.target(false);
        self.set_work(t);
        self.emit(sink, &Motion::Rapid { to: Point3::new(t[0], t[1], t[2]) })?;
        for i in 0..3 {
            if given.is_empty() || given.contains(&i) {
                self.mpos[i] = self.params.numbered[base + i];
            }
        }
        let to = self.work_pos();
        self.emit(sink, &Motion::Rapid { to })
    }

    pub(super) fn g92<E>(&mut self, code: u16, col: usize) -> Res<(), E> {
        match code {
            920 => {
                let s = self.scale();
                let mut any = false;
                let q = self.unrotated(self.mpos);
                for (i, &axis) in AXES.iter().enumerate() {
                    if let Some(v) = self.block.get(axis) {
                        any = true;
                        self.g92[i] = q[i] - v * s;
                        self.params.numbered[5211 + i] = self.g92[i];
                    }
                }
                if let Some(e) = self.block.get(b'e') {
                    any = true;
                    self.e_axis = true;
                    self.e_pos = e * s;
                }
                let others = bit(b'a') | bit(b'b') | bit(b'c') | bit(b'u') | bit(b'v') | bit(b'w');
                if !any && self.block.mask & others == 0 {
                    if self.fdm {
                        // Marlin: a bare G92 zeroes every axis.
                        self.g92 = self.unrotated(self.mpos);
                        self.e_pos = 0.0;
                    } else {
                        return Err(Fail::Line(
                            col,
                            GcodeErrorKind::MissingWord { code: "G92".into(), letter: 'X' },
                        ));
                    }
                }
                self.params.numbered[5210] = 1.0;
            }
            921 => {
                self.g92 = [0.0; 3];
                for i in 0..9 {
                    self.params.numbered[5211 + i] = 0.0;
                }
                self.params.numbered[5210] = 0.0;
            }
            922 => {
                self.g92 = [0.0; 3];
                self.params.numbered[5210] = 0.0;
            }
            _ => {
                for i in 0..3 {
                    self.g92[i] = self.params.numbered[5211 + i];
                }
                self.params.numbered[5210] = 1.0;
            }
        }
        Ok(())
    }
}
