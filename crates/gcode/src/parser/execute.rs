//! Executing a block: its words by modal group, in LinuxCNC's order of execution.

use std::borrow::Cow;

use super::comp::comp_refused;
use super::interp::{Fail, Interp, Mode, POLAR_A, POLAR_R, Res, bit, fmt_code};
use super::lathe_cycle::is_lathe_cycle;
use super::words::Pre;
use crate::error::GcodeErrorKind;
use crate::expr::ParamKey;
use crate::motion::{ArcDirection, Marker, Motion, MotionSink, Plane};

/// A block's G codes by modal group (index: group; 0 non-modal, 12 `G53`).
pub(super) struct Groups {
    pub(super) g: [Option<(u16, usize)>; 14],
    g53: bool,
}

impl Interp<'_> {
    pub(super) fn process<S: MotionSink>(
        &mut self,
        line: &[u8],
        pre: Option<Pre<'_>>,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let lexed = match pre {
            Some(p) => Ok(self.load_pre(p)),
            None => self.lex(line),
        };
        let has = match lexed {
            Ok(h) => h,
            Err(Fail::Line(c, k)) => return Err(Fail::Line(c, k)),
            Err(Fail::Sink(())) => return Ok(()),
        };
        if !has {
            return Ok(());
        }
        if self.block.mask & bit(b'e') != 0 && !self.fdm {
            self.exponent_check(line)?;
        }
        // One test on the common path for the rare words: polar ones, and Q (a lathe cycle).
        if self.block.mask & (bit(POLAR_R) | bit(POLAR_A) | bit(b'q')) != 0 && self.rare_words()? {
            return Ok(());
        }
        self.comments_and_markers(line, sink)?;
        if self.block.mask == 0 && self.block.ng == 0 && self.block.nm == 0 {
            self.apply_assignments(line);
            return Ok(());
        }
        self.execute(sink)?;
        self.apply_assignments(line);
        Ok(())
    }

    /// Polar words become X and Y; a lathe cycle (`G70`-`G72` with its `Q` word) outside
    /// control flow asks for it, as an O-word line does. Returns `true` for the latter
    /// (the driver runs the line again under control flow).
    #[cold]
    fn rare_words<E>(&mut self) -> Res<bool, E> {
        if self.block.mask & (bit(POLAR_R) | bit(POLAR_A)) != 0 {
            self.polar()?;
        }
        let blk = &self.block;
        if blk.has(b'q') && !self.in_flow && blk.g[..blk.ng].iter().any(|&(g, _)| is_lathe_cycle(g)) {
            // The cycle calls its profile subroutine: control flow from this line on.
            self.flow_request = true;
            self.done = true;
            return Ok(true);
        }
        Ok(false)
    }

    /// Turns the block's polar words into X and Y words (LinuxCNC): the point at radius `@`
    /// and angle `^` (degrees, counter-clockwise from +X) about the XY origin of the work
    /// coordinates; a missing one keeps the current point's. Under `G91` both are added to
    /// the current point's radius and angle.
    #[cold]
    fn polar<E>(&mut self) -> Res<(), E> {
        let blk = &self.block;
        let at = [POLAR_R, POLAR_A].iter().filter(|&&l| blk.has(l)).map(|&l| blk.col(l)).min().unwrap_or(0);
        if blk.has(b'x') || blk.has(b'y') {
            return Err(Fail::Line(
                at,
                GcodeErrorKind::ModalConflict("X or Y words with polar coordinates (@, ^)".into()),
            ));
        }
        let codes = &blk.g[..blk.ng];
        let absolute = codes.iter().rev().find_map(|&(g, _)| match g {
            900 => Some(true),
            910 => Some(false),
            _ => None,
        });
        let inch = codes.iter().rev().find_map(|&(g, _)| match g {
            200 => Some(true),
            210 => Some(false),
            _ => None,
        });
        let absolute = absolute.unwrap_or(self.absolute);
        let scale = if inch.unwrap_or(self.inch) { super::interp::INCH } else { 1.0 };
        let (cx, cy) = (self.work(0) / scale, self.work(1) / scale);
        let (r0, a0) = (cx.hypot(cy), cy.atan2(cx));
        let (r, a) = (blk.get(POLAR_R), blk.get(POLAR_A).map(f64::to_radians));
        let (r, a) = if absolute {
            (r.unwrap_or(r0), a.unwrap_or(a0))
        } else {
            (r0 + r.unwrap_or(0.0), a0 + a.unwrap_or(0.0))
        };
        let (x, y) = (r * a.cos(), r * a.sin());
        let (x, y) = if absolute { (x, y) } else { (x - cx, y - cy) };
        let step = (!absolute).then(|| {
            (blk.get(POLAR_R).unwrap_or(0.0) * scale, blk.get(POLAR_A).map_or(0.0, f64::to_radians))
        });
        let blk = &mut self.block;
        blk.polar = step;
        blk.mask &= !(bit(POLAR_R) | bit(POLAR_A));
        for (l, v) in [(b'x', x), (b'y', y)] {
            blk.mask |= bit(l);
            blk.vals[(l - b'a') as usize] = v;
            blk.cols[(l - b'a') as usize] = at as u32;
        }
        Ok(())
    }

    /// An `E` word glued to the number before it (`X1e999`, `X1E5`) in a program with no
    /// printer evidence yet: exponent notation, which G-code does not have; `rs274` rejects
    /// the E word ("E word with no G70, G76, M66, M67 or M68 to use it").
    #[cold]
    fn exponent_check<E>(&mut self, line: &[u8]) -> Res<(), E> {
        let c = self.block.col(b'e');
        if c > 0 && matches!(line.get(c - 1), Some(b'0'..=b'9' | b'.')) {
            return Err(Fail::Line(
                c,
                GcodeErrorKind::NotGcode(
                    "E word with no G70, G76, M66, M67 or M68 to use it (exponent notation such as \
                     1e5 is not G-code)"
                        .into(),
                ),
            ));
        }
        Ok(())
    }

    #[inline]
    pub(super) fn apply_assignments(&mut self, line: &[u8]) {
        if self.assigns.is_empty() {
            return;
        }
        for k in 0..self.assigns.len() {
            let (key, v) = self.assigns[k];
            match key {
                ParamKey::Num(n) => self.params.numbered[n] = v,
                ParamKey::Named(s, e) => self.params.set_named(&line[s..e], v),
            }
        }
    }

    pub(super) fn comments_and_markers<S: MotionSink>(
        &mut self,
        line: &[u8],
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let mut consumed_pending = false;
        for k in 0..self.comments.len() {
            let (s, e) = self.comments[k];
            let text = String::from_utf8_lossy(&line[s..e]);
            let t = text.trim();
            let marker = if let Some(rest) = t.strip_prefix("LAYER:") {
                Some(Marker::Layer { index: rest.trim().parse().ok(), z: None })
            } else if t == "LAYER_CHANGE" {
                if self.pending_layer {
                    self.emit(sink, &Motion::Marker(Marker::Layer { index: None, z: None }))?;
                }
                self.pending_layer = true;
                consumed_pending = true;
                continue;
            } else if let Some(rest) = t.strip_prefix("Z:") {
                consumed_pending = true;
                self.pending_layer = false;
                Some(Marker::Layer { index: None, z: rest.trim().parse().ok() })
            } else if let Some(rest) = t.strip_prefix("TYPE:") {
                Some(Marker::Type(Cow::Borrowed(rest.trim())))
            } else if let Some(rest) = t.strip_prefix("move to next layer (") {
                let idx = rest.trim_end_matches(')').trim().parse().ok();
                let z = self.block.get(b'z').filter(|_| self.block.novalue & bit(b'z') == 0).map(|z| {
                    let z = z * self.scale();
                    if self.absolute { z } else { self.work(2) + z }
                });
                Some(Marker::Layer { index: idx, z })
            } else {
                None
            };
            if self.pending_layer && !consumed_pending {
                self.pending_layer = false;
                self.emit(sink, &Motion::Marker(Marker::Layer { index: None, z: None }))?;
            }
            match marker {
                Some(m) => self.emit(sink, &Motion::Marker(m))?,
                None => self.emit(sink, &Motion::Comment(Cow::Borrowed(t)))?,
            }
        }
        if self.pending_layer && !consumed_pending {
            self.pending_layer = false;
            self.emit(sink, &Motion::Marker(Marker::Layer { index: None, z: None }))?;
        }
        Ok(())
    }

    /// Executes one lexed block: the fast path when it applies, otherwise the words by
    /// modal group in LinuxCNC's order (F, S, T, M6, spindle, coolant, dwell, plane,
    /// units, distance modes, coordinate system, non-modal codes, motion, stop).
    pub(super) fn execute<S: MotionSink>(&mut self, sink: &mut S) -> Res<(), S::Error> {
        if self.fast_path && self.fast_straight(sink)? {
            return Ok(());
        }
        let Some(Groups { g: groups, g53 }) = self.g_groups()? else { return Ok(()) };
        let m = self.m_codes()?;
        self.check_words(&groups)?;
        let spindle_changed = self.feed_speed_tool(groups[5].map_or(self.inverse_time, |g| g.0 == 930))?;
        self.m_actions(&m, spindle_changed, sink)?;
        self.dwell(groups[0], sink)?;
        self.modal_settings(&groups, sink)?;
        // `G43.1 Z..` (dynamic tool length) takes the axis words: they move nothing.
        let axis_words_used = self.non_modal(groups[0], sink)? | groups[8].is_some_and(|g| g.0 == 431);
        self.motion(&groups, g53, axis_words_used, m.stop, sink)
    }

    /// Classifies the block's G codes by modal group and checks conflicts. `None`: an
    /// unknown code (lenient) skips the line.
    pub(super) fn g_groups<E>(&mut self) -> Res<Option<Groups>, E> {
        let mut groups: [Option<(u16, usize)>; 14] = [None; 14];
        let mut g53 = false;
        let mut skip_line = false;
        for k in 0..self.block.ng {
            let (code, col) = self.block.g[k];
            let col = col as usize;
            let group = match code {
                0
                | 10
                | 20
                | 30
                | 50
                | 51
                | 730
                | 800
                | 810
                | 820
                | 830
                | 840
                | 850
                | 860
                | 870
                | 880
                | 890
                | 330
                | 331
                | 382..=385
                | 760 => 1,
                170 | 180 | 190 => 2,
                900 | 910 => 3,
                901 | 911 => 4,
                930 | 940 | 950 => 5,
                200 | 210 => 6,
                400 | 410 | 420 | 411 | 421 => 7,
                430 | 431 | 490 => 8,
                980 | 990 => 9,
                540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => 10,
                610 | 611 | 640 => 11,
                // Lathe radius mode, LinuxCNC's default (G7 diameter mode is not supported).
                80 => 13,
                110 if self.fdm || !self.strict => 0,
                40 | 100 | 280 | 281 | 300 | 301 | 920 | 921 | 922 | 923 => 0,
                530 => 12,
                // Old Fanuc/Mach inch/mm, when lenient; with a Q word (its profile
                // subroutine) LinuxCNC's lathe cycle.
                700 | 710 if !self.strict && !self.block.has(b'q') => 6,
                700 | 710 | 711 | 712 | 720 | 721 | 722 => 1,
                _ => {
                    let name = format!("G{}", fmt_code(code));
                    if self.strict {
                        return Err(Fail::Line(col, GcodeErrorKind::UnknownCode(name)));
                    }
                    self.warn(col, GcodeErrorKind::UnknownCode(format!("{name} (line skipped)")));
                    skip_line = true;
                    continue;
                }
            };
            if code == 530 {
                g53 = true;
            }
            if let Some((other, _)) = groups[group] {
                // `G80` next to another motion code (common in preambles) is accepted by rs274.
                if group == 1 && (code == 800 || other == 800) {
                    if code != 800 {
                        groups[1] = Some((code, col));
                    }
                    continue;
                }
                return Err(Fail::Line(
                    col,
                    GcodeErrorKind::ModalConflict(format!(
                        "G{} and G{} are in the same modal group",
                        fmt_code(other),
                        fmt_code(code)
                    )),
                ));
            }
            groups[group] = Some((code, col));
        }
        if skip_line {
            return Ok(None);
        }
        Ok(Some(Groups { g: groups, g53 }))
    }

    /// Word sanity: line number, value-less words, unsupported feed modes.
    fn check_words<E>(&mut self, groups: &[Option<(u16, usize)>; 14]) -> Res<(), E> {
        // `G76 E` is the threading cycle's taper, `G70 E` its last pass's distance: not
        // extrusion. `rs274` refuses it on the other lathe cycles.
        if self.block.has(b'e') {
            match groups[1] {
                Some((760 | 700, _)) => {}
                Some((code, _)) if is_lathe_cycle(code) => {
                    if self.strict {
                        return Err(Fail::Line(
                            self.block.col(b'e'),
                            GcodeErrorKind::NotGcode(
                                "E word with no G70, G76, M66, M67 or M68 to use it".into(),
                            ),
                        ));
                    }
                }
                _ => self.fdm_evidence(),
            }
        }
        if let Some(n) = self.block.get(b'n') {
            // LinuxCNC accepts fractional line numbers (`N4567.789`); only negative ones are refused.
            if n < 0.0 {
                return Err(Fail::Line(
                    self.block.col(b'n'),
                    GcodeErrorKind::BadValue(format!("line number N{n}")),
                ));
            }
        }
        if self.strict
            && self.block.has(b'd')
            && !groups[7].is_some_and(|g| matches!(g.0, 410 | 420 | 411 | 421))
            && !groups[1].is_some_and(|g| is_lathe_cycle(g.0))
        {
            return Err(Fail::Line(
                self.block.col(b'd'),
                GcodeErrorKind::NotGcode("D word with no G41, G41.1, G42 or G42.1 to use it".into()),
            ));
        }
        if self.strict {
            // `rs274` (no U, V, W axes configured): "Bad character 'w' used".
            if let Some(l) = [b'u', b'v', b'w'].into_iter().find(|&l| self.block.has(l)) {
                return Err(Fail::Line(
                    self.block.col(l),
                    GcodeErrorKind::NotGcode(format!("bad character '{}' used", l as char)),
                ));
            }
        }
        let non_modal = groups[0];
        // Marlin style `G28 X Y` and `M84 X Y E`.
        let novalue_allowed = (matches!(non_modal, Some((280 | 300, _))) && self.fdm)
            || (self.block.nm > 0 && self.block.ng == 0);
        if self.block.novalue != 0 && !novalue_allowed {
            let l = (b'a'..=b'z').find(|&l| self.block.novalue & bit(l) != 0).unwrap_or(b'x');
            return Err(Fail::Line(
                self.block.col(l),
                GcodeErrorKind::NotGcode(format!(
                    "expected a number after '{}'",
                    l.to_ascii_uppercase() as char
                )),
            ));
        }
        if self.block.novalue != 0 && !matches!(non_modal, Some((280 | 300, _))) {
            // `M84 X Y E`: the letters name axes, they are not moves.
            self.block.mask &= !self.block.novalue;
        }
        if groups[5].is_some_and(|(c, _)| c == 950) {
            let (c, col) = groups[5].unwrap_or((950, 0));
            return Err(Fail::Line(col, GcodeErrorKind::Unsupported(format!("G{} feed mode", fmt_code(c)))));
        }

        Ok(())
    }

    /// F, S and T words (in that order); under `G93` (`inverse`) F belongs to the block's
    /// move. Returns whether S changed the speed.
    fn feed_speed_tool<E>(&mut self, inverse: bool) -> Res<bool, E> {
        if let Some(f) = self.block.get(b'f') {
            if f < 0.0 {
                return Err(Fail::Line(
                    self.block.col(b'f'),
                    GcodeErrorKind::BadValue("negative feed rate".into()),
                ));
            }
            if !inverse {
                self.feed = f * self.scale();
            }
        }
        let mut spindle_changed = false;
        if let Some(s) = self.block.get(b's') {
            if s < 0.0 {
                return Err(Fail::Line(
                    self.block.col(b's'),
                    GcodeErrorKind::BadValue("negative spindle speed".into()),
                ));
            }
            spindle_changed = s != self.rpm;
            self.rpm = s;
        }
        if let Some(t) = self.block.get(b't') {
            if t < 0.0 || t.fract() != 0.0 || t > u32::MAX as f64 {
                return Err(Fail::Line(
                    self.block.col(b't'),
                    GcodeErrorKind::BadValue(format!("tool number T{t}")),
                ));
            }
            self.tool = Some(t as u32);
        }
        Ok(spindle_changed)
    }

    /// `G4`: dwell (milliseconds in FDM, Fanuc's `G4 X` when lenient).
    fn dwell<S: MotionSink>(&mut self, non_modal: Option<(u16, usize)>, sink: &mut S) -> Res<(), S::Error> {
        if let Some((40, col)) = non_modal {
            let secs = if self.fdm {
                match (self.block.get(b'p'), self.block.get(b's')) {
                    (Some(p), _) => p / 1000.0,
                    (None, Some(s)) => s,
                    (None, None) => 0.0,
                }
            } else {
                match (self.block.get(b'p'), self.block.get(b'x')) {
                    (Some(p), _) => p,
                    (None, Some(x)) if !self.strict => {
                        // Fanuc `G4 X<seconds>`: the X word is the time, not a move.
                        self.block.mask &= !bit(b'x');
                        if !self.warned_fanuc_dwell {
                            self.warned_fanuc_dwell = true;
                            self.warn(
                                col,
                                GcodeErrorKind::Unsupported(
                                    "G4 X read as a Fanuc dwell in seconds (warned once)".into(),
                                ),
                            );
                        }
                        x
                    }
                    _ => {
                        return Err(Fail::Line(
                            col,
                            GcodeErrorKind::MissingWord { code: "G4".into(), letter: 'P' },
                        ));
                    }
                }
            };
            if secs < 0.0 || !secs.is_finite() {
                return Err(Fail::Line(col, GcodeErrorKind::BadValue("negative dwell time".into())));
            }
            self.emit(sink, &Motion::Dwell { seconds: secs })?;
        }
        Ok(())
    }

    /// Plane (group 2), units (6), cutter radius compensation (7), tool length (8),
    /// distance modes (3, 4), feed mode (5), cycle return (9) and coordinate system (10).
    fn modal_settings<S: MotionSink>(
        &mut self,
        groups: &[Option<(u16, usize)>; 14],
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let comp_on = self.comp.side.is_some();
        if let Some((code, col)) = groups[2] {
            let plane = match code {
                170 => Plane::XY,
                180 => Plane::ZX,
                _ => Plane::YZ,
            };
            if comp_on && plane != self.plane {
                return Err(comp_refused(col, "cannot change planes with cutter radius compensation on"));
            }
            self.plane = plane;
        }
        if let Some((code, col)) = groups[6] {
            if code == 700 || code == 710 {
                self.warn(
                    col,
                    GcodeErrorKind::Unsupported(format!("G{} read as G{}", code / 10, code / 10 - 50)),
                );
            }
            self.inch = code == 200 || code == 700;
        }
        match groups[7] {
            Some((400, _)) => self.comp_off(sink)?,
            Some((code, col)) => self.comp_on(code, col)?,
            None => {}
        }
        if let Some((_, col)) = groups[8]
            && comp_on
        {
            return Err(comp_refused(col, "cannot change tool offset with cutter radius compensation on"));
        }
        if let Some((_, col)) = groups[10]
            && comp_on
        {
            return Err(comp_refused(
                col,
                "cannot change coordinate systems with cutter radius compensation on",
            ));
        }
        if let Some((code, _)) = groups[8] {
            // `G43.1 Z`: the given length; `G43` reads the tool table, which the parser
            // does not have (as `rs274`'s with zero lengths); `G49` cancels.
            let z = if code == 431 { self.block.get(b'z').unwrap_or(0.0) * self.scale() } else { 0.0 };
            self.tlo = if z.is_finite() { z } else { 0.0 };
            self.update_frame();
        }
        if let Some((code, _)) = groups[3] {
            self.absolute = code == 900;
            if self.fdm {
                self.e_relative = code == 910;
            }
        }
        if let Some((code, _)) = groups[4] {
            self.ijk_absolute = code == 901;
        }
        if let Some((code, _)) = groups[5] {
            self.inverse_time = code == 930;
        }
        if let Some((code, _)) = groups[9] {
            self.retract_r_plane = code == 990;
        }
        if let Some((code, _)) = groups[10] {
            self.coord = match code {
                540 => 1,
                550 => 2,
                560 => 3,
                570 => 4,
                580 => 5,
                590 => 6,
                591 => 7,
                592 => 8,
                _ => 9,
            };
            self.load_g5x();
        }
        Ok(())
    }

    /// Non-modal group 0 (`G10`, `G11`, `G28`, `G30`, `G28.1`, `G30.1`, `G92`..).
    /// Returns whether the code used the axis words.
    fn non_modal<S: MotionSink>(
        &mut self,
        non_modal: Option<(u16, usize)>,
        sink: &mut S,
    ) -> Res<bool, S::Error> {
        let mut axis_words_used = false;
        if let Some((code, col)) = non_modal
            && self.comp.side.is_some()
        {
            match code {
                280 | 300 => return Err(comp_refused(col, "cannot use G28 or G30 with cutter radius comp")),
                920..=923 => {
                    return Err(comp_refused(col, "cannot change axis offsets with cutter radius comp"));
                }
                _ => {}
            }
        }
        match non_modal {
            Some((100, col)) => {
                axis_words_used = true;
                self.g10(col, sink)?;
            }
            Some((110, _)) => {
                self.e_axis = true;
                let to = self.work_pos();
                self.emit(sink, &Motion::Linear { to, feed: self.feed, extrude: Some(self.retract_len) })?;
            }
            Some((code @ (280 | 300), col)) => {
                axis_words_used = true;
                self.home(code, col, sink)?;
            }
            Some((code @ (281 | 301), _)) => {
                let base = if code == 281 { 5161 } else { 5181 };
                for i in 0..3 {
                    self.params.numbered[base + i] = self.mpos[i];
                }
            }
            Some((code @ 920..=923, col)) => {
                axis_words_used = true;
                self.g92(code, col)?;
            }
            _ => {}
        }
        Ok(axis_words_used)
    }

    /// Motion group 1 (`G0`-`G3`, cycles, `G80`) with `G53`, then the block's stop.
    fn motion<S: MotionSink>(
        &mut self,
        groups: &[Option<(u16, usize)>; 14],
        mut g53: bool,
        axis_words_used: bool,
        m_stop: Option<(u16, usize)>,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let motion_g = groups[1];
        if let Some((code, col)) = motion_g {
            let m = match code {
                0 => Mode::Rapid,
                10 => Mode::Linear,
                20 => Mode::Arc(ArcDirection::Clockwise),
                30 => Mode::Arc(ArcDirection::CounterClockwise),
                800 => {
                    self.mode = None;
                    self.cycle_il = None;
                    return self.end_of_block(m_stop, sink);
                }
                730 | 810 | 820 | 830 => Mode::Cycle(code),
                50 | 51 | 330 | 331 | 382..=385 | 760 => Mode::Special(code),
                c if is_lathe_cycle(c) => Mode::Special(code),
                _ => {
                    return Err(Fail::Line(col, GcodeErrorKind::Unsupported(format!("G{}", fmt_code(code)))));
                }
            };
            if !matches!(m, Mode::Cycle(_)) {
                self.cycle_il = None;
            }
            if axis_words_used {
                return Err(Fail::Line(
                    col,
                    GcodeErrorKind::ModalConflict(format!(
                        "G{} and a G-code that uses axis words on one line",
                        fmt_code(code)
                    )),
                ));
            }
        }
        let axes = bit(b'x')
            | bit(b'y')
            | bit(b'z')
            | bit(b'a')
            | bit(b'b')
            | bit(b'c')
            | bit(b'u')
            | bit(b'v')
            | bit(b'w');
        let has_axes = self.block.mask & axes != 0;
        let has_e = self.block.has(b'e');
        let effective = match motion_g {
            Some((0, _)) => Some(Mode::Rapid),
            Some((10, _)) => Some(Mode::Linear),
            Some(_) => None,
            None if has_axes => self.mode,
            None => None,
        };
        if g53 && !matches!(effective, Some(Mode::Rapid | Mode::Linear)) {
            let col = groups[12].map_or(0, |g| g.1);
            if self.strict {
                return Err(Fail::Line(col, GcodeErrorKind::ModalConflict("G53 needs G0 or G1".into())));
            }
            self.warn(col, GcodeErrorKind::ModalConflict("G53 without G0 or G1: ignored".into()));
            g53 = false;
        }
        if !axis_words_used {
            let explicit = motion_g;
            let prev_mode = self.mode;
            if let Some((code, _)) = explicit {
                self.mode = Some(match code {
                    0 => Mode::Rapid,
                    10 => Mode::Linear,
                    20 => Mode::Arc(ArcDirection::Clockwise),
                    30 => Mode::Arc(ArcDirection::CounterClockwise),
                    c @ (50 | 51 | 330 | 331 | 382..=385 | 760) => Mode::Special(c),
                    c if is_lathe_cycle(c) => Mode::Special(c),
                    c => Mode::Cycle(c),
                });
            }
            let run = explicit.is_some() || has_axes || (has_e && self.fdm);
            if run {
                self.comp.tool_at = None;
                match self.mode {
                    None => {
                        let col = (b'a'..=b'z')
                            .filter(|&l| axes & bit(l) != 0 && self.block.has(l))
                            .map(|l| self.block.col(l))
                            .min()
                            .unwrap_or(0);
                        if self.strict || has_axes {
                            self.lenient(col, GcodeErrorKind::AxisWordsWithoutMotion)?;
                        }
                    }
                    Some(m @ (Mode::Rapid | Mode::Linear)) => {
                        if !(self.opts.rotary.is_some() && self.rotary_setup(sink)?) {
                            self.straight(m == Mode::Rapid, g53, sink)?;
                        }
                    }
                    Some(Mode::Arc(dir)) => self.arc(dir, explicit.map(|e| e.1), sink)?,
                    Some(Mode::Special(code)) => {
                        let col = explicit.map_or(0, |e| e.1);
                        self.special(code, col, sink)?;
                        if let Some(req) = self.lathe.as_mut() {
                            // The cycle runs once its profile is read; the block's stop after it.
                            req.m_stop = m_stop;
                            return Ok(());
                        }
                    }
                    Some(Mode::Cycle(code)) => {
                        let r = if self.comp.side.is_some() {
                            let col = explicit.map_or(0, |e| e.1);
                            Err(comp_refused(col, "cannot use canned cycles with cutter compensation on"))
                        } else {
                            self.cycle(code, prev_mode, sink)
                        };
                        if let Err(e) = r {
                            // LinuxCNC discards a failing block, its motion mode included.
                            self.mode = prev_mode;
                            return Err(e);
                        }
                    }
                }
            }
        }
        self.end_of_block(m_stop, sink)
    }

    pub(super) fn end_of_block<S: MotionSink>(
        &mut self,
        m_stop: Option<(u16, usize)>,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        if let Some((code, _)) = m_stop
            && (self.comp.side.is_some() || self.comp.holding())
        {
            self.comp_stop(code == 2 || code == 30, sink)?;
        }
        if let Some((2 | 30, _)) = m_stop {
            self.emit(sink, &Motion::End)?;
            self.summary.program_end = Some(self.lineno);
            if self.opts.stop_at_program_end {
                self.done = true;
            }
        }
        Ok(())
    }
}
