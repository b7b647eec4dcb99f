//! The interpreter's state ([`Interp`]) and what every part of it shares: the block of
//! words being executed, failures, motion modes, constants, and the line driver that
//! runs a line through the lexer ([`super::lex`]) and the executor ([`super::execute`]).

use std::path::PathBuf;

use nalgebra::Point3;

use super::options::{ParseDialect, ParseOptions, ParseSummary};
use super::words::{Pre, find_eol};
use crate::error::{GcodeError, GcodeErrorKind, ParseError};
use crate::expr::{ParamKey, Params};
use crate::motion::{ArcDirection, Marker, Motion, MotionSink, Plane, SpindleDirection};

pub(super) const INCH: f64 = 25.4;
/// LinuxCNC `RADIUS_TOLERANCE_INCH * MM_PER_INCH`: zero-radius and R-arc reach tolerance.
pub(super) const RADIUS_TOLERANCE_MM: f64 = 0.00005 * INCH;
/// LinuxCNC `G83_RAPID_DELTA`: 0.010 inch back off above the previous peck.
pub(super) const PECK_RAPID_DELTA_MM: f64 = 0.010 * INCH;
/// Most moves one canned-cycle block may expand into.
pub(super) const MAX_CYCLE_MOVES: u32 = 1_000_000;

/// `√(a² + b²)` without the libm call of `hypot` (the operands are mm, far from overflow);
/// `hypot` when the sum is not finite.
#[inline]
pub(super) fn hyp(a: f64, b: f64) -> f64 {
    let s = a * a + b * b;
    if s.is_finite() { s.sqrt() } else { a.hypot(b) }
}

#[cold]
pub(super) fn bad_code<E>(l: u8, v: f64, at: usize) -> Fail<E> {
    Fail::Line(at, GcodeErrorKind::UnknownCode(format!("{}{v}", l.to_ascii_uppercase() as char)))
}

#[cold]
pub(super) fn too_many<E>(l: u8, at: usize) -> Fail<E> {
    let what = format!("too many {} words", l.to_ascii_uppercase() as char);
    Fail::Line(at, GcodeErrorKind::ModalConflict(what))
}

#[cold]
pub(super) fn repeated<E>(l: u8, at: usize) -> Fail<E> {
    Fail::Line(at, GcodeErrorKind::RepeatedWord(l.to_ascii_uppercase() as char))
}

/// Why a line stopped: a G-code error (column, kind) or the sink.
pub(super) enum Fail<E> {
    Line(usize, GcodeErrorKind),
    Sink(E),
}

impl<E> From<(usize, GcodeErrorKind)> for Fail<E> {
    fn from((c, k): (usize, GcodeErrorKind)) -> Self {
        Fail::Line(c, k)
    }
}

pub(super) type Res<T, E> = Result<T, Fail<E>>;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Mode {
    Rapid,
    Linear,
    Arc(ArcDirection),
    /// G73, G81, G82, G83 (code × 10).
    Cycle(u16),
    /// G5, G5.1, G33, G33.1, G38.x, G76 (code × 10): see [`super::special`].
    Special(u16),
}

pub(super) const fn bit(letter: u8) -> u32 {
    1 << (letter - b'a')
}
/// The internal letters of the polar words `@` (radius) and `^` (angle): the two slots
/// after `z`.
pub(super) const POLAR_R: u8 = b'a' + 26;
pub(super) const POLAR_A: u8 = b'a' + 27;
pub(super) const AXES: [u8; 3] = [b'x', b'y', b'z'];
pub(super) const OFFS: [u8; 3] = [b'i', b'j', b'k'];

/// One line's words.
pub(super) struct Block {
    /// Values by letter `a`..`z`, then [`POLAR_R`] (`@`) and [`POLAR_A`] (`^`).
    pub(super) vals: [f64; 28],
    pub(super) cols: [u32; 28],
    pub(super) mask: u32,
    pub(super) novalue: u32,
    pub(super) g: [(u16, u32); 16],
    pub(super) ng: usize,
    pub(super) m: [(u16, u32); 8],
    pub(super) nm: usize,
    /// Under `G91`, the block's polar increments (`@` in program units, `^` in radians):
    /// each `L` repeat of a canned cycle turns and stretches the point again.
    pub(super) polar: Option<(f64, f64)>,
}

impl Block {
    #[inline]
    pub(super) fn has(&self, l: u8) -> bool {
        self.mask & bit(l) != 0
    }
    #[inline]
    pub(super) fn get(&self, l: u8) -> Option<f64> {
        if self.has(l) { Some(self.vals[(l - b'a') as usize]) } else { None }
    }
    #[inline]
    pub(super) fn col(&self, l: u8) -> usize {
        self.cols[(l - b'a') as usize] as usize
    }
}

pub(super) struct Interp<'o> {
    pub(super) opts: &'o ParseOptions,
    pub(super) path: Option<PathBuf>,
    pub(super) summary: ParseSummary,
    pub(super) lineno: u64,
    pub(super) reported_line: u64,
    pub(super) done: bool,
    pub(super) seen_percent: bool,
    pub(super) strict: bool,
    pub(super) fdm: bool,
    pub(super) params: Params,
    // Positions and offsets, all mm: machine = rot(work + g92) + g5x, where rot turns
    // X and Y about Z by the coordinate system's `G10 L2 R` angle (LinuxCNC's order).
    pub(super) mpos: [f64; 3],
    pub(super) g5x: [f64; 3],
    pub(super) g92: [f64; 3],
    /// The active coordinate system's XY rotation as (cos, sin); (1, 0) when none.
    pub(super) rot_xy: (f64, f64),
    /// Tool length offset along Z (mm; `G43.1 Z`, `G49`): the machine point is the work
    /// point's plus this, so a change moves the program's Z without a move.
    pub(super) tlo: f64,
    /// No rotation and no tool length offset: the plain arithmetic of the fast path.
    pub(super) plain_frame: bool,
    pub(super) coord: usize,
    pub(super) inch: bool,
    pub(super) absolute: bool,
    pub(super) ijk_absolute: bool,
    pub(super) plane: Plane,
    pub(super) mode: Option<Mode>,
    pub(super) feed: f64,
    /// `G93`: a feed move's F word is moves per minute.
    pub(super) inverse_time: bool,
    /// The `P Q` offsets (mm) of the last `G5`, which a following `G5` may mirror.
    pub(super) last_spline_pq: Option<(f64, f64)>,
    pub(super) warned_feed: bool,
    pub(super) warned_fanuc_dwell: bool,
    /// Cutter radius compensation and its held moves.
    pub(super) comp: super::comp::Comp,
    /// Use [`Self::fast_straight`] (always, except in tests).
    pub(super) fast_path: bool,
    pub(super) rpm: f64,
    pub(super) spindle: SpindleDirection,
    pub(super) tool: Option<u32>,
    /// The tool in the spindle (`M6`, `M61`): whose diameter `G41`/`G42` without `D` use.
    pub(super) spindle_tool: u32,
    // FDM extrusion.
    pub(super) e_pos: f64,
    pub(super) e_relative: bool,
    pub(super) e_axis: bool,
    pub(super) retract_len: f64,
    // Canned cycles.
    pub(super) retract_r_plane: bool,
    pub(super) cycle_il: Option<f64>,
    pub(super) cycle_r: f64,
    pub(super) cycle_cc: f64,
    pub(super) cycle_p: f64,
    pub(super) cycle_q: f64,
    /// Rotary axis positions A, B, C in degrees (with [`ParseOptions::rotary`]).
    pub(super) rot: [f64; 3],
    // Slicer markers.
    pub(super) pending_layer: bool,
    /// The line just lexed starts O-word control flow: the driver runs the rest with
    /// [`super::flow`]. Set with [`Self::done`], so that drivers test one flag per line.
    pub(super) flow_request: bool,
    /// Lines are run by [`super::flow`], which takes O-word lines itself.
    pub(super) in_flow: bool,
    /// [`ParseSummary::lines`] when [`Self::sync_params`] last ran.
    pub(super) synced_line: u64,
    /// A lathe cycle (`G70`-`G72`) whose block has run: [`super::flow`] reads its profile
    /// and runs it.
    pub(super) lathe: Option<Box<super::lathe_cycle::LatheRequest>>,
    // Scratch reused across lines.
    pub(super) comments: Vec<(usize, usize)>,
    pub(super) assigns: Vec<(ParamKey, f64)>,
    pub(super) block: Block,
}

impl<'o> Interp<'o> {
    pub(super) fn new(opts: &'o ParseOptions, path: Option<PathBuf>) -> Self {
        Self {
            opts,
            path,
            summary: ParseSummary::default(),
            lineno: 0,
            reported_line: 0,
            done: false,
            seen_percent: false,
            strict: opts.dialect == ParseDialect::Cnc,
            fdm: opts.dialect == ParseDialect::Fdm,
            params: Params::default(),
            mpos: [0.0; 3],
            g5x: [0.0; 3],
            g92: [0.0; 3],
            rot_xy: (1.0, 0.0),
            tlo: 0.0,
            plain_frame: true,
            coord: 1,
            inch: false,
            absolute: true,
            ijk_absolute: false,
            plane: Plane::XY,
            mode: None,
            feed: 0.0,
            inverse_time: false,
            last_spline_pq: None,
            warned_feed: false,
            warned_fanuc_dwell: false,
            comp: super::comp::Comp::default(),
            fast_path: true,
            rpm: 0.0,
            spindle: SpindleDirection::Off,
            tool: None,
            spindle_tool: 0,
            e_pos: 0.0,
            e_relative: false,
            e_axis: opts.dialect == ParseDialect::Fdm,
            retract_len: opts.firmware_retract_mm,
            retract_r_plane: true,
            cycle_il: None,
            cycle_r: 0.0,
            cycle_cc: 0.0,
            cycle_p: 0.0,
            cycle_q: 0.0,
            rot: [0.0; 3],
            pending_layer: false,
            flow_request: false,
            in_flow: false,
            synced_line: 0,
            lathe: None,
            comments: Vec::new(),
            assigns: Vec::new(),
            block: Block {
                vals: [0.0; 28],
                cols: [0; 28],
                mask: 0,
                novalue: 0,
                g: [(0, 0); 16],
                ng: 0,
                m: [(0, 0); 8],
                nm: 0,
                polar: None,
            },
        }
    }

    /// Sets the read-only parameters a line's expressions may read, once per line, before
    /// any of them is evaluated (as LinuxCNC, they show the state before the line): the
    /// position `#5420`..`#5422` and `#<_x>`, `#<_y>`, `#<_z>` in program units,
    /// `#<_metric>`, `#<_imperial>`, `#<_absolute>`, `#<_incremental>`, `#<_feed>`, `#<_rpm>`.
    #[cold]
    pub(super) fn sync_params(&mut self) {
        // Keyed on the count of lines run, which grows when a loop runs a line again.
        if self.synced_line == self.summary.lines {
            return;
        }
        self.synced_line = self.summary.lines;
        let s = self.scale();
        let bool_v = |b: bool| if b { 1.0 } else { 0.0 };
        for (i, name) in [b"_x", b"_y", b"_z"].iter().enumerate() {
            let v = self.work(i) / s;
            self.params.numbered[5420 + i] = v;
            self.params.set_named(*name, v);
        }
        let named: [(&[u8], f64); 6] = [
            (b"_metric", bool_v(!self.inch)),
            (b"_imperial", bool_v(self.inch)),
            (b"_absolute", bool_v(self.absolute)),
            (b"_incremental", bool_v(!self.absolute)),
            (b"_feed", self.feed / s),
            (b"_rpm", self.rpm),
        ];
        for (name, v) in named {
            self.params.set_named(name, v);
        }
    }

    pub(super) fn make_error(&self, col: usize, kind: GcodeErrorKind) -> GcodeError {
        GcodeError { path: self.path.clone(), line: self.lineno, column: col as u32 + 1, kind }
    }

    pub(super) fn warn(&mut self, col: usize, kind: GcodeErrorKind) {
        if self.summary.warnings.len() < self.opts.max_reported {
            let e = self.make_error(col, kind);
            self.summary.warnings.push(e);
        } else {
            self.summary.dropped += 1;
        }
    }

    /// A lenient-mode deviation: an error under strict LinuxCNC, a warning otherwise.
    pub(super) fn lenient<E>(&mut self, col: usize, kind: GcodeErrorKind) -> Res<(), E> {
        if self.strict {
            Err(Fail::Line(col, kind))
        } else {
            self.warn(col, kind);
            Ok(())
        }
    }

    pub(super) fn line_checked<S: MotionSink>(
        &mut self,
        line: &[u8],
        too_long: bool,
        sink: &mut S,
    ) -> Result<(), ParseError<S::Error>> {
        if too_long {
            self.lineno += 1;
            self.summary.lines += 1;
            return self.record(0, GcodeErrorKind::NotGcode("line longer than 16 MiB".into()));
        }
        self.line(line, sink)
    }

    pub(super) fn record<E>(&mut self, col: usize, kind: GcodeErrorKind) -> Result<(), ParseError<E>> {
        let e = self.make_error(col, kind);
        if self.opts.stop_at_first_error {
            return Err(ParseError::Gcode(e));
        }
        if self.summary.errors.len() < self.opts.max_reported {
            self.summary.errors.push(e);
        } else {
            self.summary.dropped += 1;
        }
        Ok(())
    }

    pub(super) fn line<S: MotionSink>(
        &mut self,
        line: &[u8],
        sink: &mut S,
    ) -> Result<(), ParseError<S::Error>> {
        self.line_pre(line, None, sink)
    }

    /// [`Self::line`] with the line's words already lexed, when `pre` is given.
    pub(super) fn line_pre<S: MotionSink>(
        &mut self,
        line: &[u8],
        pre: Option<Pre<'_>>,
        sink: &mut S,
    ) -> Result<(), ParseError<S::Error>> {
        self.lineno += 1;
        self.summary.lines += 1;
        if self.done {
            return Ok(());
        }
        match self.process(line, pre, sink) {
            Ok(()) => Ok(()),
            Err(Fail::Sink(e)) => Err(ParseError::Sink(e)),
            Err(Fail::Line(col, kind)) => self.record(col, kind),
        }
    }

    pub(super) fn finish<S: MotionSink>(
        mut self,
        sink: &mut S,
    ) -> Result<ParseSummary, ParseError<S::Error>> {
        if self.pending_layer {
            self.pending_layer = false;
            self.emit(sink, &Motion::Marker(Marker::Layer { index: None, z: None })).map_err(
                |e| match e {
                    Fail::Sink(e) => ParseError::Sink(e),
                    Fail::Line(c, k) => ParseError::Gcode(self.make_error(c, k)),
                },
            )?;
        }
        sink.finish().map_err(ParseError::Sink)?;
        Ok(self.summary)
    }

    #[inline]
    pub(super) fn emit<S: MotionSink>(&mut self, sink: &mut S, m: &Motion<'_>) -> Res<(), S::Error> {
        if self.comp.holding() {
            // Behind moves that cutter compensation holds back: in order, with them.
            self.comp_hold(m);
            return Ok(());
        }
        self.emit_at(self.lineno, sink, m)
    }

    /// Sends `m` as a motion of source line `line`.
    #[inline]
    pub(super) fn emit_at<S: MotionSink>(
        &mut self,
        line: u64,
        sink: &mut S,
        m: &Motion<'_>,
    ) -> Res<(), S::Error> {
        if self.reported_line != line {
            self.reported_line = line;
            sink.source_line(line).map_err(Fail::Sink)?;
        }
        self.summary.motions += 1;
        sink.motion(m).map_err(Fail::Sink)
    }

    #[inline]
    pub(super) fn scale(&self) -> f64 {
        if self.inch { INCH } else { 1.0 }
    }

    #[inline]
    pub(super) fn work(&self, i: usize) -> f64 {
        if self.plain_frame { self.mpos[i] - self.g5x[i] - self.g92[i] } else { self.work_rotated(i) }
    }

    /// [`Self::work`] in a rotated coordinate system: X and Y turned back by its angle.
    #[cold]
    fn work_rotated(&self, i: usize) -> f64 {
        if i == 2 {
            return self.mpos[2] - self.g5x[2] - self.g92[2] - self.tlo;
        }
        let (c, s) = self.rot_xy;
        let (px, py) = (self.mpos[0] - self.g5x[0], self.mpos[1] - self.g5x[1]);
        let q = if i == 0 { c * px + s * py } else { -s * px + c * py };
        q - self.g92[i]
    }

    /// The work position of machine point `m` in the active system.
    pub(super) fn work_of(&self, m: [f64; 3]) -> [f64; 3] {
        let q = self.unrotated(m);
        [q[0] - self.g92[0], q[1] - self.g92[1], q[2] - self.g92[2]]
    }

    /// Machine point `m` less the `G5x` offset, turned back by the system's rotation:
    /// the work position before the `G92` offset.
    pub(super) fn unrotated(&self, m: [f64; 3]) -> [f64; 3] {
        let (c, s) = self.rot_xy;
        let (px, py) = (m[0] - self.g5x[0], m[1] - self.g5x[1]);
        [c * px + s * py, -s * px + c * py, m[2] - self.g5x[2] - self.tlo]
    }

    /// The machine position of work point `w` in the active system (offsets and rotation).
    pub(super) fn machine_of(&self, w: [f64; 3]) -> [f64; 3] {
        let (c, s) = self.rot_xy;
        let (qx, qy) = (w[0] + self.g92[0], w[1] + self.g92[1]);
        [
            c * qx - s * qy + self.g5x[0],
            s * qx + c * qy + self.g5x[1],
            w[2] + self.g92[2] + self.g5x[2] + self.tlo,
        ]
    }

    pub(super) fn work_pos(&self) -> Point3<f64> {
        Point3::new(self.work(0), self.work(1), self.work(2))
    }

    #[inline]
    pub(super) fn set_work(&mut self, w: [f64; 3]) {
        if self.plain_frame {
            for (i, &v) in w.iter().enumerate() {
                self.mpos[i] = v + self.g5x[i] + self.g92[i];
            }
        } else {
            self.mpos = self.machine_of(w);
        }
    }

    /// Sets [`Self::plain_frame`] after a change of rotation or tool length offset.
    pub(super) fn update_frame(&mut self) {
        self.plain_frame = self.rot_xy == (1.0, 0.0) && self.tlo == 0.0;
    }

    /// Loads the active coordinate system's offsets and rotation (`#5221`.. and `#5230`
    /// for `G54`, 20 apart for the others; the rotation in degrees).
    pub(super) fn load_g5x(&mut self) {
        let base = 5201 + 20 * self.coord;
        for i in 0..3 {
            self.g5x[i] = self.params.numbered[base + i];
        }
        self.rot_xy = rotation_of(self.params.numbered[base + 9]);
        self.update_frame();
        self.params.numbered[5220] = self.coord as f64;
    }

    pub(super) fn fdm_evidence(&mut self) {
        if self.opts.dialect == ParseDialect::Auto {
            self.fdm = true;
        }
        self.e_axis = true;
    }

    pub(super) fn need_feed<E>(&mut self, what: &str) -> Res<(), E> {
        if self.feed <= 0.0 {
            if self.strict {
                return Err(Fail::Line(0, GcodeErrorKind::ZeroFeed(what.into())));
            }
            if !self.warned_feed {
                self.warned_feed = true;
                self.warn(0, GcodeErrorKind::ZeroFeed(format!("{what} (feed 0 reported; warned once)")));
            }
        }
        Ok(())
    }
}

/// (cos, sin) of a rotation in degrees; exactly (1, 0) for none, so that unrotated
/// systems keep the plain arithmetic.
pub(super) fn rotation_of(deg: f64) -> (f64, f64) {
    if deg == 0.0 || !deg.is_finite() {
        return (1.0, 0.0);
    }
    let r = deg.to_radians();
    (r.cos(), r.sin())
}

/// `G91.1` style text of a code stored × 10.
pub(super) fn fmt_code(code: u16) -> String {
    if code.is_multiple_of(10) { format!("{}", code / 10) } else { format!("{}.{}", code / 10, code % 10) }
}

/// [`parse_str`](super::parse_str) over bytes, in one stage; `fast_path: false` sends every block through the general
/// interpreter (the tests compare both).
pub(super) fn parse_bytes<S: MotionSink>(
    b: &[u8],
    opts: &ParseOptions,
    sink: &mut S,
    fast_path: bool,
) -> Result<ParseSummary, ParseError<S::Error>> {
    let mut it = Interp::new(opts, None);
    it.fast_path = fast_path;
    let mut i = 0;
    while i < b.len() {
        let rest = &b[i..];
        let end = find_eol(rest).unwrap_or(rest.len());
        it.line(&rest[..end], sink)?;
        if it.done {
            if it.flow_request {
                let mut j = i + end;
                if j < b.len() {
                    j += if b[j] == b'\r' && b.get(j + 1) == Some(&b'\n') { 2 } else { 1 };
                }
                super::flow::run(&mut it, &rest[..end], &b[j..], sink)?;
            }
            break;
        }
        i += end;
        if i < b.len() {
            if b[i] == b'\r' && b.get(i + 1) == Some(&b'\n') {
                i += 1;
            }
            i += 1;
        }
    }
    it.summary.bytes = b.len() as u64;
    it.finish(sink)
}
