//! The streaming G-code parser: bytes in, [`Motion`]s out into any [`MotionSink`].
//!
//! One line at a time, zero-copy over the line's bytes, no allocation per line (only
//! error messages and O-word labels allocate). Lines are split eight bytes at a time;
//! a word followed by a plain number is read without the expression machinery (G and M
//! codes as integers); a block of only `G0`/`G1`, `X Y Z E F N` in G0/G1 mode takes a
//! short path with the general interpreter's semantics (a unit test runs both on every
//! sample file and on random blocks). The semantics follow LinuxCNC's RS274NGC
//! interpreter (`rs274`), which the integration tests use as the reference, with FDM
//! (Marlin / RepRap) extensions.
//!
//! # Dialects and leniency
//! [`ParseDialect::Cnc`] is strict LinuxCNC: what `rs274` rejects is an error (a `G1` without
//! feed rate, an arc without centre, `G53` without `G0`/`G1`, unknown codes, ...).
//! [`ParseDialect::Auto`] (the default) accepts the same programs and also the usual
//! dialect drift of real files: those cases become *warnings* in
//! [`ParseSummary::warnings`] with a documented fallback (feed 0, a straight move for an
//! arc without centre, `G70`/`G71` as inch/mm, unknown codes skipped with their line).
//! Auto switches to FDM semantics (`G4 P` in milliseconds, `G10`/`G11` firmware retract,
//! `G28` homing, `G91` making `E` relative) once the program shows FDM evidence (`M82`,
//! `M83`, `M104`, `M109`, `M140`, `M190` or an `E` word). [`ParseDialect::Fdm`] has those from
//! the start.
//!
//! # Documented choices
//! - Numbers are decimals without exponent (`1E5` is `1` then an `E` word); blanks inside
//!   words are skipped as LinuxCNC does (`X - 5`, `G 1`).
//! - `N` numbers are read and ignored; fractional ones are accepted, as LinuxCNC does.
//! - Block delete `/` skips the line only when [`ParseOptions::block_delete`] is set
//!   (`rs274`'s default is off: the line runs).
//! - Firmware retract `G10`/`G11` is reported as a zero-length [`Motion::Linear`] with
//!   `extrude = -firmware_retract_mm` / `+firmware_retract_mm` (`M207 S` sets the length).
//! - Parameters: numbered `#1`..`#5601` and named `#<name>` (case and blanks ignored);
//!   all assignments of a line take effect after the line's reads. Coordinate-system
//!   parameters (`#5221`.., `#5211`.., `#5161`..) are stored in mm.
//! - `G41`/`G42` cutter compensation and `G43` tool length are accepted and ignored: the
//!   programmed path is reported (as `rs274` does with zero tool diameters and lengths).
//! - Rotary and UVW axis words are accepted and ignored, unless
//!   [`ParseOptions::rotary`] names a kinematics: then A/B/C words become
//!   [`Motion::Setup`] (see [`crate::rotary_frame`]).
//! - A Fanuc program number (`O1234` alone on a line, optionally with a comment) is a
//!   label: nothing runs, [`ParseSummary::program_number`] keeps the first one. Under
//!   [`ParseDialect::Cnc`] it is an error, as in `rs274`.
//! - `G4 X<seconds>` without `P` is Fanuc's dwell (a warning, once; an error under
//!   [`ParseDialect::Cnc`]); the X word is the time, not a move.
//! - LinuxCNC O-word control flow is not executed. A subroutine definition
//!   (`o100 sub` .. `o100 endsub`) runs nothing, so its lines are skipped with one
//!   warning. `if`/`while`/`do`/`repeat` blocks are reported as
//!   [`GcodeErrorKind::Unsupported`] on their first line and skipped up to the matching
//!   `endif`/`endwhile`/`while`/`endrepeat` (their motions are missing, never run
//!   unconditionally); `call`, `return` and stray closing lines are
//!   [`GcodeErrorKind::Unsupported`] too. A `%` line ends a skipped block.

use std::borrow::Cow;
use std::io::BufRead;
use std::path::{Path, PathBuf};

use nalgebra::Point3;

use crate::error::{GcodeError, GcodeErrorKind, ParseError};
use crate::expr::{Cursor, ParamKey, Params};
use crate::motion::{ArcDirection, Coolant, Marker, Motion, MotionSink, Plane, SpindleDirection};
use crate::rotary::{RotaryAxes, rotary_frame};

mod pipeline;

const INCH: f64 = 25.4;
/// LinuxCNC `RADIUS_TOLERANCE_INCH * MM_PER_INCH`: zero-radius and R-arc reach tolerance.
const RADIUS_TOLERANCE_MM: f64 = 0.00005 * INCH;
/// LinuxCNC `G83_RAPID_DELTA`: 0.010 inch back off above the previous peck.
const PECK_RAPID_DELTA_MM: f64 = 0.010 * INCH;
/// Most moves one canned-cycle block may expand into.
const MAX_CYCLE_MOVES: u32 = 1_000_000;
/// Lines longer than this are reported as an error instead of being buffered whole.
const MAX_LINE: usize = 16 << 20;

/// Which G-code flavour to interpret.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum ParseDialect {
    /// CNC semantics, lenient about dialect drift; FDM semantics once FDM codes appear.
    #[default]
    Auto,
    /// Strict LinuxCNC (RS274NGC): what `rs274` rejects is an error.
    Cnc,
    /// Marlin / RepRap FDM printers.
    Fdm,
}

/// Parser options. `ParseOptions::default()` gives the documented defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct ParseOptions {
    /// Stop at the first error (returned as [`ParseError::Gcode`]) instead of collecting
    /// all errors in [`ParseSummary::errors`]. Default: `false`.
    pub stop_at_first_error: bool,
    /// Absolute tolerance on the difference between an I/J/K arc's start and end radii,
    /// in mm. Default: LinuxCNC's `CENTER_ARC_RADIUS_TOLERANCE_MM` = 2·0.01·√2 mm; in
    /// `G20` programs it is scaled by 2.54, which gives LinuxCNC's inch constant.
    /// LinuxCNC's rule: error when the difference exceeds 100 × this, or exceeds this and
    /// [`Self::arc_relative_tolerance`] of the radius.
    pub arc_tolerance_mm: f64,
    /// Relative radius tolerance of I/J/K arcs. Default: 0.001 (LinuxCNC).
    pub arc_relative_tolerance: f64,
    /// Dialect. Default: [`ParseDialect::Auto`].
    pub dialect: ParseDialect,
    /// Skip lines that start with `/`. Default: `false` (as `rs274`: the `/` is ignored).
    pub block_delete: bool,
    /// Ignore everything after `M2`, `M30` or a closing `%`. Default: `true` (LinuxCNC).
    pub stop_at_program_end: bool,
    /// Firmware-retract length for `G10`/`G11` in mm of filament, until `M207 S` sets one.
    /// Default: 1.0.
    pub firmware_retract_mm: f64,
    /// At most this many errors and this many warnings are stored; the rest are counted in
    /// [`ParseSummary::dropped`]. Default: 10 000.
    pub max_reported: usize,
    /// 3+2 rotary kinematics. When set, a `G0`/`G1` block with words of its rotary axes
    /// (A and C for [`RotaryAxes::AC`], B and C for [`RotaryAxes::BC`]; degrees, not
    /// scaled by `G20`, incremental under `G91`) first emits a [`Motion::Setup`] with
    /// [`crate::rotary_frame`] of the current angles and those angles in `rotary`, then the
    /// block's move, if it has other axis or `E` words (a block with rotary words only
    /// moves nothing else). Rotary words on arcs and cycles, and the other rotary letter,
    /// are ignored. Default `None`: rotary words are ignored, and a block of rotary words
    /// only is a zero-length move, as `rs274` reports it.
    pub rotary: Option<RotaryAxes>,
}

impl Default for ParseOptions {
    fn default() -> Self {
        Self {
            stop_at_first_error: false,
            arc_tolerance_mm: 2.0 * 0.01 * std::f64::consts::SQRT_2,
            arc_relative_tolerance: 0.001,
            dialect: ParseDialect::Auto,
            block_delete: false,
            stop_at_program_end: true,
            firmware_retract_mm: 1.0,
            max_reported: 10_000,
            rotary: None,
        }
    }
}

/// What a parse saw.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ParseSummary {
    /// Lines read (including blank and comment lines).
    pub lines: u64,
    /// Bytes read.
    pub bytes: u64,
    /// Motions sent to the sink.
    pub motions: u64,
    /// Errors, in line order (the offending lines had no effect).
    pub errors: Vec<GcodeError>,
    /// Accepted deviations from strict LinuxCNC, with the fallback applied (see module docs).
    pub warnings: Vec<GcodeError>,
    /// Errors and warnings not stored because of [`ParseOptions::max_reported`].
    pub dropped: u64,
    /// The line of `M2`/`M30`/closing `%`, if the program ended explicitly.
    pub program_end: Option<u64>,
    /// The first Fanuc program number (`O1234` alone on a line), if any.
    pub program_number: Option<u32>,
}

/// Parses G-code text into `sink`.
///
/// Inputs of 1 MiB and more, on a machine with two or more cores, are parsed in two
/// stages: a scoped second thread splits and lexes lines while this thread interprets
/// them and calls `sink` (which therefore need not be `Send`). Summary, motions, errors
/// and their columns are the same as in one stage; only the speed differs.
///
/// ```
/// use s2g_gcode::{parse_str, Motion, MotionRecorder, ParseOptions};
/// let mut rec = MotionRecorder::default();
/// let summary = parse_str("G21 G90\nG0 X1 Y2\nG1 Z-1 F100\n", &ParseOptions::default(), &mut rec).unwrap();
/// assert!(summary.errors.is_empty());
/// assert_eq!(rec.motions.len(), 2);
/// assert_eq!(rec.motions[1].1.end_point().unwrap().z, -1.0);
/// ```
pub fn parse_str<S: MotionSink>(
    text: &str,
    opts: &ParseOptions,
    sink: &mut S,
) -> Result<ParseSummary, ParseError<S::Error>> {
    let b = text.as_bytes();
    if pipeline::worthwhile(b.len()) {
        return pipeline::parse_two_stage(b, opts, sink, pipeline::CHUNK_BYTES);
    }
    parse_bytes(b, opts, sink, true)
}

/// [`parse_str`] always in two stages (a lexing thread beside the interpreter), whatever
/// the input's size, with chunks of `chunk_bytes` (at least 1) instead of 128 KiB, so that
/// small inputs cross chunk boundaries too. For the fuzz target, which checks it against
/// [`parse_str`]; not part of the stable API.
#[doc(hidden)]
pub fn parse_str_two_stage<S: MotionSink>(
    text: &str,
    opts: &ParseOptions,
    sink: &mut S,
    chunk_bytes: usize,
) -> Result<ParseSummary, ParseError<S::Error>> {
    pipeline::parse_two_stage(text.as_bytes(), opts, sink, chunk_bytes)
}

/// [`parse_str`] over bytes; `fast_path: false` sends every block through the general
/// interpreter (the tests compare both).
fn parse_bytes<S: MotionSink>(
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

/// Parses G-code from a reader, streaming: one line buffer is reused, so memory stays
/// bounded by the longest line whatever the input size.
pub fn parse_reader<R: BufRead, S: MotionSink>(
    reader: R,
    opts: &ParseOptions,
    sink: &mut S,
) -> Result<ParseSummary, ParseError<S::Error>> {
    parse_reader_path(reader, opts, sink, None)
}

/// Parses a G-code file; errors carry its path.
pub fn parse_file<S: MotionSink>(
    path: impl AsRef<Path>,
    opts: &ParseOptions,
    sink: &mut S,
) -> Result<ParseSummary, ParseError<S::Error>> {
    let path = path.as_ref();
    let f = std::fs::File::open(path)
        .map_err(|source| ParseError::Io { path: path.display().to_string(), source })?;
    parse_reader_path(std::io::BufReader::with_capacity(1 << 16, f), opts, sink, Some(path.to_path_buf()))
}

fn parse_reader_path<R: BufRead, S: MotionSink>(
    mut reader: R,
    opts: &ParseOptions,
    sink: &mut S,
    path: Option<PathBuf>,
) -> Result<ParseSummary, ParseError<S::Error>> {
    let io_path = path.as_ref().map_or_else(|| "<input>".to_string(), |p| p.display().to_string());
    let mut it = Interp::new(opts, path);
    let mut line: Vec<u8> = Vec::new();
    let mut skip_lf = false;
    let mut too_long = false;
    let mut bytes = 0u64;
    let mut pending = false;
    loop {
        let buf = match reader.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(source) => return Err(ParseError::Io { path: io_path, source }),
        };
        if buf.is_empty() {
            if pending {
                it.line_checked(&line, too_long, sink)?;
            }
            break;
        }
        let mut start = 0;
        if skip_lf {
            skip_lf = false;
            if buf[0] == b'\n' {
                start = 1;
            }
        }
        let consumed = match find_eol(&buf[start..]) {
            Some(k) => {
                let end = start + k;
                if line.is_empty() && !too_long {
                    it.line(&buf[start..end], sink)?;
                } else {
                    if !too_long {
                        line.extend_from_slice(&buf[start..end]);
                    }
                    it.line_checked(&line, too_long, sink)?;
                    line.clear();
                    too_long = false;
                }
                pending = false;
                skip_lf = buf[end] == b'\r';
                end + 1
            }
            None => {
                if start == buf.len() {
                    reader.consume(start);
                    bytes += start as u64;
                    continue;
                }
                if !too_long {
                    line.extend_from_slice(&buf[start..]);
                    if line.len() > MAX_LINE {
                        too_long = true;
                        line.clear();
                    }
                }
                pending = true;
                buf.len()
            }
        };
        bytes += consumed as u64;
        reader.consume(consumed);
        if it.done {
            break;
        }
    }
    it.summary.bytes = bytes;
    it.finish(sink)
}

/// Index of the first `\n` or `\r` in `b`, eight bytes at a time.
#[inline]
fn find_eol(b: &[u8]) -> Option<usize> {
    const LO: u64 = 0x0101_0101_0101_0101;
    const HI: u64 = 0x8080_8080_8080_8080;
    let mut chunks = b.chunks_exact(8);
    let mut i = 0;
    for ch in chunks.by_ref() {
        let mut w = [0u8; 8];
        w.copy_from_slice(ch);
        let w = u64::from_le_bytes(w);
        let x = w ^ (LO * b'\n' as u64);
        let y = w ^ (LO * b'\r' as u64);
        // A zero byte of x or y marks a match; the lowest flagged byte is always exact.
        let t = (x.wrapping_sub(LO) & !x | y.wrapping_sub(LO) & !y) & HI;
        if t != 0 {
            return Some(i + (t.trailing_zeros() / 8) as usize);
        }
        i += 8;
    }
    chunks.remainder().iter().position(|&c| c == b'\n' || c == b'\r').map(|k| i + k)
}

/// Whether a plain number (digit or dot, after at most a sign) starts at `b[i]`.
#[inline(always)]
fn starts_plain_number(b: &[u8], i: usize) -> bool {
    match b.get(i) {
        Some(b'0'..=b'9' | b'.') => true,
        Some(b'-' | b'+') => matches!(b.get(i + 1), Some(b'0'..=b'9' | b'.')),
        _ => false,
    }
}

/// A G code (× 10: `G91.1` is 911) or M code written as plain digits at `b[i..]`
/// (`1`, `01`, `91.1`), and where it ends; `None` for anything else (signs, blanks inside,
/// more decimals, out of range), which the general number reader then handles.
#[inline(always)]
fn plain_code(b: &[u8], i: usize, g: bool) -> Option<(u16, usize)> {
    let mut j = i;
    let mut v = 0u32;
    while let Some(&c) = b.get(j)
        && c.is_ascii_digit()
        && j - i < 5
    {
        v = v * 10 + (c - b'0') as u32;
        j += 1;
    }
    if j == i {
        return None;
    }
    let mut code = v;
    if g {
        code *= 10;
        if b.get(j) == Some(&b'.') {
            j += 1;
            if let Some(&c) = b.get(j)
                && c.is_ascii_digit()
            {
                code += (c - b'0') as u32;
                j += 1;
            }
        }
    }
    match b.get(j) {
        Some(c) if c.is_ascii_digit() || *c == b'.' => return None,
        Some(b' ' | b'\t') => {
            // `G 1 2` continues the number: leave it to the general reader.
            let k = b[j..].iter().position(|&c| c != b' ' && c != b'\t').map_or(b.len(), |k| j + k);
            if b.get(k).is_some_and(|&c| c.is_ascii_digit() || c == b'.') {
                return None;
            }
        }
        _ => {}
    }
    if code > 9999 {
        return None;
    }
    Some((code as u16, j))
}

/// `√(a² + b²)` without the libm call of `hypot` (the operands are mm, far from overflow);
/// `hypot` when the sum is not finite.
#[inline]
fn hyp(a: f64, b: f64) -> f64 {
    let s = a * a + b * b;
    if s.is_finite() { s.sqrt() } else { a.hypot(b) }
}

#[cold]
fn bad_code<E>(l: u8, v: f64, at: usize) -> Fail<E> {
    Fail::Line(at, GcodeErrorKind::UnknownCode(format!("{}{v}", l.to_ascii_uppercase() as char)))
}

#[cold]
fn too_many<E>(l: u8, at: usize) -> Fail<E> {
    let what = format!("too many {} words", l.to_ascii_uppercase() as char);
    Fail::Line(at, GcodeErrorKind::ModalConflict(what))
}

#[cold]
fn repeated<E>(l: u8, at: usize) -> Fail<E> {
    Fail::Line(at, GcodeErrorKind::RepeatedWord(l.to_ascii_uppercase() as char))
}

/// Why a line stopped: a G-code error (column, kind) or the sink.
enum Fail<E> {
    Line(usize, GcodeErrorKind),
    Sink(E),
}

impl<E> From<(usize, GcodeErrorKind)> for Fail<E> {
    fn from((c, k): (usize, GcodeErrorKind)) -> Self {
        Fail::Line(c, k)
    }
}

type Res<T, E> = Result<T, Fail<E>>;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Rapid,
    Linear,
    Arc(ArcDirection),
    /// G73, G81, G82, G83 (code × 10).
    Cycle(u16),
}

const fn bit(letter: u8) -> u32 {
    1 << (letter - b'a')
}
const AXES: [u8; 3] = [b'x', b'y', b'z'];
const OFFS: [u8; 3] = [b'i', b'j', b'k'];

/// One line's words.
struct Block {
    vals: [f64; 26],
    cols: [u32; 26],
    mask: u32,
    novalue: u32,
    g: [(u16, u32); 16],
    ng: usize,
    m: [(u16, u32); 8],
    nm: usize,
}

impl Block {
    #[inline]
    fn has(&self, l: u8) -> bool {
        self.mask & bit(l) != 0
    }
    #[inline]
    fn get(&self, l: u8) -> Option<f64> {
        if self.has(l) { Some(self.vals[(l - b'a') as usize]) } else { None }
    }
    #[inline]
    fn col(&self, l: u8) -> usize {
        self.cols[(l - b'a') as usize] as usize
    }
}

struct Interp<'o> {
    opts: &'o ParseOptions,
    path: Option<PathBuf>,
    summary: ParseSummary,
    lineno: u64,
    reported_line: u64,
    done: bool,
    seen_percent: bool,
    strict: bool,
    fdm: bool,
    params: Params,
    // Positions and offsets, all mm: work = machine - g5x - g92.
    mpos: [f64; 3],
    g5x: [f64; 3],
    g92: [f64; 3],
    coord: usize,
    inch: bool,
    absolute: bool,
    ijk_absolute: bool,
    plane: Plane,
    mode: Option<Mode>,
    feed: f64,
    warned_feed: bool,
    warned_fanuc_dwell: bool,
    /// Use [`Self::fast_straight`] (always, except in tests).
    fast_path: bool,
    rpm: f64,
    spindle: SpindleDirection,
    tool: Option<u32>,
    // FDM extrusion.
    e_pos: f64,
    e_relative: bool,
    e_axis: bool,
    retract_len: f64,
    // Canned cycles.
    retract_r_plane: bool,
    cycle_il: Option<f64>,
    cycle_r: f64,
    cycle_cc: f64,
    cycle_p: f64,
    cycle_q: f64,
    /// Rotary axis positions A, B, C in degrees (with [`ParseOptions::rotary`]).
    rot: [f64; 3],
    // Slicer markers.
    pending_layer: bool,
    /// An O-word block being skipped: its normalised label and the keyword that closes it.
    skip_o: Option<(Vec<u8>, &'static str)>,
    // Scratch reused across lines.
    comments: Vec<(usize, usize)>,
    assigns: Vec<(ParamKey, f64)>,
    block: Block,
}

impl<'o> Interp<'o> {
    fn new(opts: &'o ParseOptions, path: Option<PathBuf>) -> Self {
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
            coord: 1,
            inch: false,
            absolute: true,
            ijk_absolute: false,
            plane: Plane::XY,
            mode: None,
            feed: 0.0,
            warned_feed: false,
            warned_fanuc_dwell: false,
            fast_path: true,
            rpm: 0.0,
            spindle: SpindleDirection::Off,
            tool: None,
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
            skip_o: None,
            comments: Vec::new(),
            assigns: Vec::new(),
            block: Block {
                vals: [0.0; 26],
                cols: [0; 26],
                mask: 0,
                novalue: 0,
                g: [(0, 0); 16],
                ng: 0,
                m: [(0, 0); 8],
                nm: 0,
            },
        }
    }

    fn make_error(&self, col: usize, kind: GcodeErrorKind) -> GcodeError {
        GcodeError { path: self.path.clone(), line: self.lineno, column: col as u32 + 1, kind }
    }

    fn warn(&mut self, col: usize, kind: GcodeErrorKind) {
        if self.summary.warnings.len() < self.opts.max_reported {
            let e = self.make_error(col, kind);
            self.summary.warnings.push(e);
        } else {
            self.summary.dropped += 1;
        }
    }

    /// A lenient-mode deviation: an error under strict LinuxCNC, a warning otherwise.
    fn lenient<E>(&mut self, col: usize, kind: GcodeErrorKind) -> Res<(), E> {
        if self.strict {
            Err(Fail::Line(col, kind))
        } else {
            self.warn(col, kind);
            Ok(())
        }
    }

    fn line_checked<S: MotionSink>(
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

    fn record<E>(&mut self, col: usize, kind: GcodeErrorKind) -> Result<(), ParseError<E>> {
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

    fn line<S: MotionSink>(&mut self, line: &[u8], sink: &mut S) -> Result<(), ParseError<S::Error>> {
        self.line_pre(line, None, sink)
    }

    /// [`Self::line`] with the line's words already lexed, when `pre` is given.
    fn line_pre<S: MotionSink>(
        &mut self,
        line: &[u8],
        pre: Option<pipeline::Pre<'_>>,
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

    fn finish<S: MotionSink>(mut self, sink: &mut S) -> Result<ParseSummary, ParseError<S::Error>> {
        if let Some((label, end)) = self.skip_o.take() {
            let label = String::from_utf8_lossy(&label).into_owned();
            self.record(
                0,
                GcodeErrorKind::Unsupported(format!(
                    "O-word block o{label} not closed by 'o{label} {end}': the rest of the program was skipped"
                )),
            )?;
        }
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
    fn emit<S: MotionSink>(&mut self, sink: &mut S, m: &Motion<'_>) -> Res<(), S::Error> {
        if self.reported_line != self.lineno {
            self.reported_line = self.lineno;
            sink.source_line(self.lineno).map_err(Fail::Sink)?;
        }
        self.summary.motions += 1;
        sink.motion(m).map_err(Fail::Sink)
    }

    // ----------------------------------------------------------------- lexing

    /// Forgets the previous line's words, comments and assignments.
    #[inline]
    fn clear_line(&mut self) {
        let blk = &mut self.block;
        blk.mask = 0;
        blk.novalue = 0;
        blk.ng = 0;
        blk.nm = 0;
        self.comments.clear();
        self.assigns.clear();
    }

    /// Splits a line into words, comments and parameter assignments. Returns `false` for
    /// a line with nothing to execute.
    fn lex(&mut self, b: &[u8]) -> Res<bool, ()> {
        self.clear_line();
        let mut c = Cursor { b, i: 0 };
        c.skip_ws();
        if c.i >= b.len() {
            return Ok(false);
        }
        if b[c.i] == b'/' {
            if self.opts.block_delete {
                return Ok(false);
            }
            c.i += 1;
            c.skip_ws();
            if c.i >= b.len() {
                return Ok(false);
            }
        }
        if b[c.i] == b'%' {
            c.i += 1;
            c.skip_ws();
            if c.i < b.len() && b[c.i] != b';' && b[c.i] != b'(' {
                return Err(Fail::Line(c.i, GcodeErrorKind::NotGcode("text after '%'".into())));
            }
            if self.seen_percent {
                self.summary.program_end = Some(self.lineno);
                if self.opts.stop_at_program_end {
                    self.done = true;
                }
            }
            self.seen_percent = true;
            return Ok(false);
        }
        // The end of the last run of letters scanned for a function call, and whether a '['
        // follows it.
        let mut letter_run = (0usize, false);
        loop {
            c.skip_ws();
            let Some(&ch) = b.get(c.i) else { break };
            let at = c.i;
            match ch {
                b'(' => {
                    let Some(k) = b[at + 1..].iter().position(|&x| x == b')') else {
                        return Err(Fail::Line(at, GcodeErrorKind::UnclosedComment));
                    };
                    self.comments.push((at + 1, at + 1 + k));
                    c.i = at + k + 2;
                }
                b';' => {
                    self.comments.push((at + 1, b.len()));
                    break;
                }
                b'*' => {
                    // RepRap checksum: XOR of every byte before '*'.
                    c.i += 1;
                    let ds = c.i;
                    while c.i < b.len() && b[c.i].is_ascii_digit() {
                        c.i += 1;
                    }
                    if ds == c.i || c.i - ds > 5 {
                        return Err(Fail::Line(
                            at,
                            GcodeErrorKind::NotGcode("'*' without a checksum".into()),
                        ));
                    }
                    let stated: u32 = b[ds..c.i].iter().fold(0, |a, &d| a * 10 + (d - b'0') as u32);
                    let computed = b[..at].iter().fold(0u8, |a, &x| a ^ x);
                    if stated != computed as u32 {
                        return Err(Fail::Line(at, GcodeErrorKind::BadChecksum { stated, computed }));
                    }
                    c.skip_ws();
                    match b.get(c.i) {
                        None => break,
                        Some(b';') => {
                            self.comments.push((c.i + 1, b.len()));
                            break;
                        }
                        Some(_) => {
                            return Err(Fail::Line(
                                c.i,
                                GcodeErrorKind::NotGcode("text after the checksum".into()),
                            ));
                        }
                    }
                }
                b'#' => {
                    let key = c.param_key(&mut self.params, 0)?;
                    if c.peek() != Some(b'=') {
                        return Err(Fail::Line(
                            at,
                            GcodeErrorKind::Expression(
                                "parameter reference without '=' outside a word".into(),
                            ),
                        ));
                    }
                    c.i += 1;
                    let v = c.real_value(&mut self.params, 0)?;
                    if self.assigns.len() >= 50 {
                        return Err(Fail::Line(
                            at,
                            GcodeErrorKind::Expression("more than 50 assignments".into()),
                        ));
                    }
                    self.assigns.push((key, v));
                }
                _ if ch.is_ascii_alphabetic() => {
                    let l = ch.to_ascii_lowercase();
                    c.i += 1;
                    // Fast path: a plain number right after the letter (`X12.5`, `Y-3`, `F.5`).
                    if starts_plain_number(b, c.i) && l != b'o' {
                        if (l == b'g' || l == b'm')
                            && let Some((code, next)) = plain_code(b, c.i, l == b'g')
                        {
                            self.store_code(l, code, at)?;
                            c.i = next;
                            continue;
                        }
                        let v = c.number()?;
                        self.store_word(l, v, at)?;
                        continue;
                    }
                    if l == b'o' {
                        let blk = &self.block;
                        let alone = blk.mask & !bit(b'n') == 0
                            && blk.ng == 0
                            && blk.nm == 0
                            && self.assigns.is_empty();
                        match self.o_word(b, at, alone)? {
                            Some(next) => {
                                c.i = next;
                                continue;
                            }
                            None => return Ok(false),
                        }
                    }
                    if !self.strict && c.peek() == Some(b'{') {
                        // A slicer template placeholder left unexpanded (`Y{machine_depth}`).
                        let close = b[c.i..].iter().position(|&x| x == b'}');
                        let Some(k) = close else {
                            return Err(Fail::Line(at, GcodeErrorKind::NotGcode("'{' without '}'".into())));
                        };
                        c.i += k + 1;
                        self.warn(
                            at,
                            GcodeErrorKind::NotGcode(format!(
                                "unexpanded template in word {}: word ignored",
                                l.to_ascii_uppercase() as char
                            )),
                        );
                        continue;
                    }
                    let blk = &mut self.block;
                    // A letter followed by another letter: a value-less word, unless a function call follows.
                    let nx = c.peek();
                    let value = match nx {
                        None | Some(b';' | b'(' | b'*') => None,
                        Some(n) if n.is_ascii_alphabetic() => {
                            // Every letter of one run of letters and blanks ends at the same
                            // place, so the run is scanned once, not once per letter.
                            if c.i >= letter_run.0 {
                                let mut j = c.i;
                                while j < b.len()
                                    && (b[j].is_ascii_alphabetic() || b[j] == b' ' || b[j] == b'\t')
                                {
                                    j += 1;
                                }
                                letter_run = (j, b.get(j) == Some(&b'['));
                            }
                            if letter_run.1 { Some(c.real_value(&mut self.params, 0)?) } else { None }
                        }
                        Some(_) => Some(c.real_value(&mut self.params, 0)?),
                    };
                    let Some(v) = value else {
                        if !self.strict && !matches!(l, b'g' | b'm' | b'n') {
                            blk.novalue |= bit(l);
                            blk.mask |= bit(l);
                            blk.vals[(l - b'a') as usize] = 0.0;
                            blk.cols[(l - b'a') as usize] = at as u32;
                            continue;
                        }
                        return Err(Fail::Line(
                            at,
                            GcodeErrorKind::NotGcode(format!(
                                "expected a number after '{}'",
                                l.to_ascii_uppercase() as char
                            )),
                        ));
                    };
                    self.store_word(l, v, at)?;
                }
                _ => {
                    let shown = if ch.is_ascii_graphic() {
                        format!("'{}'", ch as char)
                    } else {
                        format!("byte 0x{ch:02X}")
                    };
                    return Err(Fail::Line(at, GcodeErrorKind::NotGcode(format!("unexpected {shown}"))));
                }
            }
        }
        Ok(true)
    }

    /// Takes a line the pre-lexer took, as [`Self::lex`] would have left it.
    #[inline]
    fn load_pre(&mut self, pre: pipeline::Pre<'_>) -> bool {
        self.clear_line();
        let blk = &mut self.block;
        let pipeline::Pre::Lexed { words, comments } = pre else { return false };
        for w in words {
            match w.letter {
                b'g' => {
                    blk.g[blk.ng] = (w.code, w.col);
                    blk.ng += 1;
                }
                b'm' => {
                    blk.m[blk.nm] = (w.code, w.col);
                    blk.nm += 1;
                }
                l => {
                    let k = (l - b'a') as usize;
                    blk.mask |= bit(l);
                    blk.vals[k] = w.value;
                    blk.cols[k] = w.col;
                }
            }
        }
        self.comments.extend(comments.iter().map(|&(s, e)| (s as usize, e as usize)));
        true
    }

    /// Stores one word of the line being lexed (`l` lowercase, `at` its column).
    #[inline(always)]
    fn store_word(&mut self, l: u8, v: f64, at: usize) -> Res<(), ()> {
        let blk = &mut self.block;
        match l {
            b'g' | b'm' => {
                // Codes are stored × 10 for G (`G91.1` = 911), as is for M. Round half up
                // without libm (the range check comes first).
                let t = if l == b'g' { v * 10.0 } else { v };
                let code = if (0.0..=9999.0).contains(&t) { (t + 0.5) as u32 } else { u32::MAX };
                if code == u32::MAX || (t - code as f64).abs() > 1e-6 {
                    return Err(bad_code(l, v, at));
                }
                return self.store_code(l, code as u16, at);
            }
            _ => {
                let k = (l - b'a') as usize;
                if blk.mask & bit(l) != 0 {
                    return Err(repeated(l, at));
                }
                blk.mask |= bit(l);
                blk.vals[k] = v;
                blk.cols[k] = at as u32;
            }
        }
        Ok(())
    }

    /// Stores a G code (× 10) or M code.
    #[inline(always)]
    fn store_code(&mut self, l: u8, code: u16, at: usize) -> Res<(), ()> {
        let blk = &mut self.block;
        let (list, n) = if l == b'g' { (&mut blk.g[..], &mut blk.ng) } else { (&mut blk.m[..], &mut blk.nm) };
        let Some(slot) = list.get_mut(*n) else { return Err(too_many(l, at)) };
        *slot = (code, at as u32);
        *n += 1;
        Ok(())
    }

    /// Handles an O word at `at` (LinuxCNC control flow or a Fanuc program number).
    /// `alone`: no other word precedes it on the line. Returns where lexing goes on
    /// (a program number), `None` to skip the line, or the line's error.
    fn o_word(&mut self, b: &[u8], at: usize, alone: bool) -> Res<Option<usize>, ()> {
        let o = read_o_word(b, at).map_err(|k| Fail::Line(at, k))?;
        let shown = String::from_utf8_lossy(&b[at..o.end]).trim().to_string();
        let rest_empty =
            matches!(b[o.end..].iter().find(|c| !matches!(c, b' ' | b'\t')), None | Some(b'(' | b';'));
        if o.keyword.is_empty() {
            return match o.number {
                Some(n) if alone && rest_empty && !self.strict => {
                    // Fanuc program number `O1234`: a label, nothing to execute.
                    self.summary.program_number.get_or_insert(n);
                    Ok(Some(o.end))
                }
                Some(_) if alone && rest_empty => Err(Fail::Line(
                    at,
                    GcodeErrorKind::Unsupported(format!(
                        "program number {shown} (Fanuc): LinuxCNC needs an O-word keyword"
                    )),
                )),
                _ => Err(Fail::Line(
                    at,
                    GcodeErrorKind::Unsupported(format!("O-word {shown} without a control-flow keyword")),
                )),
            };
        }
        let end: Option<&'static str> = match o.keyword.as_str() {
            "sub" => Some("endsub"),
            "if" => Some("endif"),
            "while" => Some("endwhile"),
            "do" => Some("while"),
            "repeat" => Some("endrepeat"),
            _ => None,
        };
        let label = String::from_utf8_lossy(&b[o.label.0..o.label.1]).trim().to_string();
        match end {
            Some(end) if o.keyword == "sub" => {
                // A definition runs nothing: skip its body (calls are reported where they are).
                self.skip_o = Some((o.norm, end));
                self.warn(
                    at,
                    GcodeErrorKind::Unsupported(format!(
                        "O-word subroutine ({shown}): body up to 'o{label} endsub' skipped; calls are not supported"
                    )),
                );
                Ok(None)
            }
            Some(end) => {
                self.skip_o = Some((o.norm, end));
                Err(Fail::Line(
                    at,
                    GcodeErrorKind::Unsupported(format!(
                        "O-word control flow ({shown}): lines up to 'o{label} {end}' skipped"
                    )),
                ))
            }
            None => Err(Fail::Line(
                at,
                GcodeErrorKind::Unsupported(format!("O-word control flow ({shown}): line skipped")),
            )),
        }
    }

    /// While an O-word block is skipped: `true` when `line` is skipped too (the
    /// closing line included); `false` for a `%` line, which still ends the program.
    #[cold]
    fn skipped_o_line(&mut self, line: &[u8]) -> bool {
        let mut i = 0;
        let blank = |c: u8| c == b' ' || c == b'\t';
        while i < line.len() && (blank(line[i]) || line[i] == b'/') {
            i += 1;
        }
        if line.get(i) == Some(&b'%') {
            self.skip_o = None;
            return false;
        }
        if matches!(line.get(i), Some(b'n' | b'N')) {
            i += 1;
            while i < line.len() && (blank(line[i]) || line[i].is_ascii_digit() || line[i] == b'.') {
                i += 1;
            }
        }
        if matches!(line.get(i), Some(b'o' | b'O'))
            && let Ok(o) = read_o_word(line, i)
            && let Some((label, end)) = &self.skip_o
            && o.norm == *label
            && o.keyword == *end
        {
            self.skip_o = None;
        }
        true
    }

    // ---------------------------------------------------------- interpretation

    fn process<S: MotionSink>(
        &mut self,
        line: &[u8],
        pre: Option<pipeline::Pre<'_>>,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        if self.skip_o.is_some() && self.skipped_o_line(line) {
            return Ok(());
        }
        let lexed = match pre {
            // Inside a skipped O-word block the full lexer decides.
            Some(p) if self.skip_o.is_none() => Ok(self.load_pre(p)),
            _ => self.lex(line),
        };
        let has = match lexed {
            Ok(h) => h,
            Err(Fail::Line(c, k)) => return Err(Fail::Line(c, k)),
            Err(Fail::Sink(())) => return Ok(()),
        };
        if !has {
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

    #[inline]
    fn apply_assignments(&mut self, line: &[u8]) {
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

    fn comments_and_markers<S: MotionSink>(&mut self, line: &[u8], sink: &mut S) -> Res<(), S::Error> {
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

    #[inline]
    fn scale(&self) -> f64 {
        if self.inch { INCH } else { 1.0 }
    }

    #[inline]
    fn work(&self, i: usize) -> f64 {
        self.mpos[i] - self.g5x[i] - self.g92[i]
    }

    fn work_pos(&self) -> Point3<f64> {
        Point3::new(self.work(0), self.work(1), self.work(2))
    }

    #[inline]
    fn set_work(&mut self, w: [f64; 3]) {
        for (i, &v) in w.iter().enumerate() {
            self.mpos[i] = v + self.g5x[i] + self.g92[i];
        }
    }

    fn load_g5x(&mut self) {
        let base = 5201 + 20 * self.coord;
        for i in 0..3 {
            self.g5x[i] = self.params.numbered[base + i];
        }
        self.params.numbered[5220] = self.coord as f64;
    }

    /// The common block `[G0|G1] [X..] [Y..] [Z..] [E..] [F..] [N..]` in G0/G1 mode, with
    /// the general path's semantics. Returns `false` (nothing done) for any other block.
    #[inline]
    fn fast_straight<S: MotionSink>(&mut self, sink: &mut S) -> Res<bool, S::Error> {
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
            Some(m @ (Mode::Rapid | Mode::Linear)) => m,
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

    fn execute<S: MotionSink>(&mut self, sink: &mut S) -> Res<(), S::Error> {
        if self.fast_path && self.fast_straight(sink)? {
            return Ok(());
        }
        // ---- Classify G codes by modal group and check conflicts.
        let mut groups: [Option<(u16, usize)>; 14] = [None; 14];
        let mut g53 = false;
        let mut skip_line = false;
        for k in 0..self.block.ng {
            let (code, col) = self.block.g[k];
            let col = col as usize;
            let group = match code {
                0 | 10 | 20 | 30 | 730 | 800 | 810 | 820 | 830 | 840 | 850 | 860 | 870 | 880 | 890 | 331
                | 382 => 1,
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
                110 if self.fdm || !self.strict => 0,
                40 | 100 | 280 | 281 | 300 | 301 | 920 | 921 | 922 | 923 => 0,
                530 => 12,
                700 | 710 if !self.strict => 6,
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
            return Ok(());
        }
        // ---- M codes.
        let mut m_spindle: Option<(u16, usize)> = None;
        let mut m_tool = None;
        let mut m_stop = None;
        let mut coolant: [Option<Coolant>; 2] = [None, None];
        let mut m_e_mode = None;
        let mut m_retract_set = None;
        for k in 0..self.block.nm {
            let (code, col) = self.block.m[k];
            let col = col as usize;
            let slot = match code {
                3..=5 => &mut m_spindle,
                6 | 61 => &mut m_tool,
                0 | 1 | 2 | 30 | 60 => &mut m_stop,
                7..=9 => {
                    let c = match code {
                        7 => Coolant::Mist,
                        8 => Coolant::Flood,
                        _ => Coolant::Off,
                    };
                    if coolant[0].is_none() {
                        coolant[0] = Some(c);
                    } else {
                        coolant[1] = Some(c);
                    }
                    continue;
                }
                82 | 83 => {
                    self.fdm_evidence();
                    m_e_mode = Some(code);
                    continue;
                }
                207 => {
                    m_retract_set = Some(col);
                    continue;
                }
                104 | 109 | 140 | 190 => {
                    self.fdm_evidence();
                    continue;
                }
                // LinuxCNC: overrides, I/O, spindle orient, modal state save/restore.
                19 | 48..=53 | 62..=68 | 70..=73 => continue,
                // Common printer codes with no motion meaning.
                17
                | 18
                | 84
                | 105
                | 106
                | 107
                | 110
                | 112
                | 114
                | 115
                | 117
                | 80
                | 81
                | 92
                | 201..=206
                | 220
                | 221
                | 400
                | 420
                | 500
                | 501
                | 503
                | 851
                | 900
                    if !self.strict =>
                {
                    continue;
                }
                _ => {
                    let k = GcodeErrorKind::UnknownCode(format!("M{code}"));
                    if self.strict {
                        return Err(Fail::Line(col, k));
                    }
                    self.warn(col, k);
                    continue;
                }
            };
            if let Some((other, _)) = *slot {
                return Err(Fail::Line(
                    col,
                    GcodeErrorKind::ModalConflict(format!(
                        "M{other} and M{code} are in the same modal group"
                    )),
                ));
            }
            *slot = Some((code, col));
        }
        // ---- Word sanity.
        if self.block.has(b'e') {
            self.fdm_evidence();
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
        let non_modal = groups[0];
        let motion_g = groups[1];
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
        if groups[5].is_some_and(|(c, _)| c == 930 || c == 950) {
            let (c, col) = groups[5].unwrap_or((930, 0));
            return Err(Fail::Line(col, GcodeErrorKind::Unsupported(format!("G{} feed mode", fmt_code(c)))));
        }

        // ---- Feed, speed, tool select (LinuxCNC order).
        if let Some(f) = self.block.get(b'f') {
            if f < 0.0 {
                return Err(Fail::Line(
                    self.block.col(b'f'),
                    GcodeErrorKind::BadValue("negative feed rate".into()),
                ));
            }
            self.feed = f * self.scale();
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
        if let Some((code, col)) = m_tool {
            let tool = if code == 61 {
                match self.block.get(b'q') {
                    Some(q) if q >= 0.0 && q.fract() == 0.0 && q <= u32::MAX as f64 => Some(q as u32),
                    _ => {
                        return Err(Fail::Line(
                            col,
                            GcodeErrorKind::MissingWord { code: "M61".into(), letter: 'Q' },
                        ));
                    }
                }
            } else {
                self.tool
            };
            if let Some(tool) = tool {
                self.tool = Some(tool);
                self.emit(sink, &Motion::ToolChange { tool })?;
            } else {
                self.lenient(col, GcodeErrorKind::MissingWord { code: "M6".into(), letter: 'T' })?;
            }
        }
        if let Some((code, _)) = m_spindle {
            self.spindle = match code {
                3 => SpindleDirection::Clockwise,
                4 => SpindleDirection::CounterClockwise,
                _ => SpindleDirection::Off,
            };
            self.emit(sink, &Motion::Spindle { rpm: self.rpm, direction: self.spindle })?;
        } else if spindle_changed && self.spindle != SpindleDirection::Off {
            self.emit(sink, &Motion::Spindle { rpm: self.rpm, direction: self.spindle })?;
        }
        for c in coolant.into_iter().flatten() {
            self.emit(sink, &Motion::Coolant(c))?;
        }
        if let Some(code) = m_e_mode {
            self.e_relative = code == 83;
            self.e_axis = true;
        }
        if let Some(col) = m_retract_set
            && let Some(s) = self.block.get(b's')
        {
            if s < 0.0 {
                return Err(Fail::Line(col, GcodeErrorKind::BadValue("negative retract length".into())));
            }
            self.retract_len = s;
        }
        // ---- Dwell.
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
        // ---- Modal settings.
        if let Some((code, _)) = groups[2] {
            self.plane = match code {
                170 => Plane::XY,
                180 => Plane::ZX,
                _ => Plane::YZ,
            };
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
        if let Some((code, _)) = groups[3] {
            self.absolute = code == 900;
            if self.fdm {
                self.e_relative = code == 910;
            }
        }
        if let Some((code, _)) = groups[4] {
            self.ijk_absolute = code == 901;
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
        // ---- Non-modal group 0.
        let mut axis_words_used = false;
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
        // ---- Motion.
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
                    c => Mode::Cycle(c),
                });
            }
            let run = explicit.is_some() || has_axes || (has_e && self.fdm);
            if run {
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
                    Some(Mode::Cycle(code)) => {
                        if let Err(e) = self.cycle(code, prev_mode, sink) {
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

    fn end_of_block<S: MotionSink>(
        &mut self,
        m_stop: Option<(u16, usize)>,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        if let Some((2 | 30, _)) = m_stop {
            self.emit(sink, &Motion::End)?;
            self.summary.program_end = Some(self.lineno);
            if self.opts.stop_at_program_end {
                self.done = true;
            }
        }
        Ok(())
    }

    fn fdm_evidence(&mut self) {
        if self.opts.dialect == ParseDialect::Auto {
            self.fdm = true;
        }
        self.e_axis = true;
    }

    /// Target of a straight move in work coordinates, from the axis words.
    fn target(&self, g53: bool) -> [f64; 3] {
        let s = self.scale();
        let mut t = [self.work(0), self.work(1), self.work(2)];
        for i in 0..3 {
            if let Some(v) = self.block.get(AXES[i]) {
                let v = v * s;
                t[i] = if g53 {
                    v - self.g5x[i] - self.g92[i]
                } else if self.absolute {
                    v
                } else {
                    t[i] + v
                };
            }
        }
        t
    }

    /// Extrusion of this block's E word (mm of filament), updating the E position.
    fn extrusion(&mut self) -> Option<f64> {
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

    fn need_feed<E>(&mut self, what: &str) -> Res<(), E> {
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

    fn straight<S: MotionSink>(&mut self, rapid: bool, g53: bool, sink: &mut S) -> Res<(), S::Error> {
        let t = self.target(g53);
        let extrude = self.extrusion();
        let to = Point3::new(t[0], t[1], t[2]);
        // Marlin treats G0 like G1: a G0 that extrudes is reported as a feed move.
        if rapid && extrude.is_none_or(|e| e == 0.0) {
            self.set_work(t);
            return self.emit(sink, &Motion::Rapid { to });
        }
        self.need_feed(if rapid { "G0 with E" } else { "G1" })?;
        self.set_work(t);
        self.emit(sink, &Motion::Linear { to, feed: self.feed, extrude })
    }

    /// With [`ParseOptions::rotary`]: emits the setup of the block's rotary words, if
    /// any. Returns `true` when the block has no other move words (nothing else moves).
    fn rotary_setup<S: MotionSink>(&mut self, sink: &mut S) -> Res<bool, S::Error> {
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
        let frame = rotary_frame(axes, self.rot);
        self.emit(sink, &Motion::Setup { frame, rotary })?;
        let others = bit(b'x') | bit(b'y') | bit(b'z') | bit(b'u') | bit(b'v') | bit(b'w') | bit(b'e');
        Ok(self.block.mask & others == 0)
    }

    fn plane_axes(&self) -> (usize, usize, usize) {
        match self.plane {
            Plane::XY => (0, 1, 2),
            Plane::ZX => (2, 0, 1),
            Plane::YZ => (1, 2, 0),
        }
    }

    fn arc<S: MotionSink>(
        &mut self,
        dir: ArcDirection,
        explicit_col: Option<usize>,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let (u, v, w) = self.plane_axes();
        let s = self.scale();
        let start = [self.work(0), self.work(1), self.work(2)];
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
            self.lenient(col0, GcodeErrorKind::ArcMissingCenter)?;
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
            let r_raw = self.block.get(b'r').unwrap_or(0.0) * s;
            let col = self.block.col(b'r');
            if su == eu && sv == ev {
                // Lenient fallback: the centre is unknown, so no move is reported.
                self.lenient(col, GcodeErrorKind::ArcDegenerate("R-format arc ends at its start".into()))?;
                return Ok(());
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
            cu = mu + off * theta.cos();
            cv = mv + off * theta.sin();
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
        self.need_feed(if dir == ArcDirection::Clockwise { "G2" } else { "G3" })?;
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
                feed: self.feed,
                extrude,
            },
        )
    }

    fn cycle<S: MotionSink>(&mut self, code: u16, prev: Option<Mode>, sink: &mut S) -> Res<(), S::Error> {
        let (ua, ub, uc) = self.plane_axes();
        let s = self.scale();
        let name = format!("G{}", fmt_code(code));
        let entering = prev != Some(Mode::Cycle(code));
        let blk = &self.block;
        let cc_word = match blk.get(AXES[uc]) {
            Some(z) => z * s,
            None if entering => {
                return Err(Fail::Line(
                    0,
                    GcodeErrorKind::MissingWord { code: name, letter: AXES[uc].to_ascii_uppercase() as char },
                ));
            }
            None => self.cycle_cc,
        };
        let r_word = match blk.get(b'r') {
            Some(r) => r * s,
            None if entering => {
                return Err(Fail::Line(0, GcodeErrorKind::MissingWord { code: name, letter: 'R' }));
            }
            None => self.cycle_r,
        };
        let p = match (code, blk.get(b'p')) {
            (820, Some(p)) if p >= 0.0 => p,
            (820, Some(_)) => {
                return Err(Fail::Line(blk.col(b'p'), GcodeErrorKind::BadValue("negative dwell".into())));
            }
            (820, None) if entering => {
                return Err(Fail::Line(0, GcodeErrorKind::MissingWord { code: name, letter: 'P' }));
            }
            _ => self.cycle_p,
        };
        let q = match (code, blk.get(b'q')) {
            (730 | 830, Some(q)) => q * s,
            (730 | 830, None) if entering => {
                return Err(Fail::Line(0, GcodeErrorKind::MissingWord { code: name, letter: 'Q' }));
            }
            _ => self.cycle_q,
        };
        if matches!(code, 730 | 830) && q <= 0.0 {
            return Err(Fail::Line(0, GcodeErrorKind::CannedCycle("Q must be positive".into())));
        }
        let repeats = match blk.get(b'l') {
            None => 1,
            Some(l) if l >= 0.0 && l.fract() == 0.0 && l <= 100_000.0 => l as u32,
            Some(l) => return Err(Fail::Line(blk.col(b'l'), GcodeErrorKind::BadValue(format!("L{l}")))),
        };
        let cur = [self.work(0), self.work(1), self.work(2)];
        let mut old_cc = self.cycle_il.unwrap_or(cur[uc]);
        let mut current_cc = cur[uc];
        let (mut aa, mut bb, inc_a, inc_b, r, cc);
        if self.absolute {
            inc_a = 0.0;
            inc_b = 0.0;
            r = r_word;
            cc = cc_word;
            aa = blk.get(AXES[ua]).map_or(cur[ua], |v| v * s);
            bb = blk.get(AXES[ub]).map_or(cur[ub], |v| v * s);
        } else {
            inc_a = blk.get(AXES[ua]).map_or(0.0, |v| v * s);
            inc_b = blk.get(AXES[ub]).map_or(0.0, |v| v * s);
            r = r_word + old_cc;
            cc = r + cc_word;
            aa = cur[ua];
            bb = cur[ub];
        }
        if r < cc {
            return Err(Fail::Line(
                0,
                GcodeErrorKind::CannedCycle("R plane below the bottom of the cycle".into()),
            ));
        }
        // Bound the expansion: hostile input must not turn one line into billions of moves.
        let pecks = if matches!(code, 730 | 830) { ((r - cc) / q).ceil() + 1.0 } else { 1.0 };
        if repeats as f64 * (3.0 * pecks + 4.0) > MAX_CYCLE_MOVES as f64 {
            return Err(Fail::Line(
                0,
                GcodeErrorKind::CannedCycle(format!("expands to more than {MAX_CYCLE_MOVES} moves")),
            ));
        }
        self.need_feed(&name)?;
        self.cycle_il = Some(old_cc);
        let mut pos = cur;
        macro_rules! go {
            ($rapid:expr, $a:expr, $b:expr, $c:expr) => {{
                pos[ua] = $a;
                pos[ub] = $b;
                pos[uc] = $c;
                self.set_work(pos);
                let to = Point3::new(pos[0], pos[1], pos[2]);
                if $rapid {
                    self.emit(sink, &Motion::Rapid { to })?;
                } else {
                    let extrude = if self.e_axis { Some(0.0) } else { None };
                    self.emit(sink, &Motion::Linear { to, feed: self.feed, extrude })?;
                }
            }};
        }
        if old_cc < r {
            go!(true, cur[ua], cur[ub], r);
            old_cc = r;
            current_cc = r;
        }
        let clear = if self.retract_r_plane { r } else { old_cc };
        // LinuxCNC's CYCLE_MACRO: the first positioning happens at the current height,
        // later ones at the clearance height.
        for rep in 0..repeats {
            aa += inc_a;
            bb += inc_b;
            if rep == 0 && current_cc > r {
                go!(true, aa, bb, current_cc);
                go!(true, aa, bb, r);
            } else {
                go!(true, aa, bb, clear);
                if clear > r {
                    go!(true, aa, bb, r);
                }
            }
            match code {
                810 => {
                    go!(false, aa, bb, cc);
                    go!(true, aa, bb, clear);
                }
                820 => {
                    go!(false, aa, bb, cc);
                    self.emit(sink, &Motion::Dwell { seconds: p })?;
                    go!(true, aa, bb, clear);
                }
                _ => {
                    let mut depth = r - q;
                    while depth > cc {
                        go!(false, aa, bb, depth);
                        if code == 830 {
                            go!(true, aa, bb, r);
                        }
                        go!(true, aa, bb, depth + PECK_RAPID_DELTA_MM);
                        depth -= q;
                    }
                    go!(false, aa, bb, cc);
                    go!(true, aa, bb, clear);
                }
            }
        }
        pos[ua] = aa;
        pos[ub] = bb;
        pos[uc] = clear;
        self.set_work(pos);
        self.cycle_cc = cc_word;
        self.cycle_r = r_word;
        self.cycle_p = p;
        self.cycle_q = q;
        Ok(())
    }

    fn g10<S: MotionSink>(&mut self, col: usize, sink: &mut S) -> Res<(), S::Error> {
        let Some(l) = self.block.get(b'l') else {
            if self.fdm || (!self.strict && !self.block.has(b'p')) {
                // Firmware retract.
                self.e_axis = true;
                let to = self.work_pos();
                return self
                    .emit(sink, &Motion::Linear { to, feed: self.feed, extrude: Some(-self.retract_len) });
            }
            return Err(Fail::Line(col, GcodeErrorKind::MissingWord { code: "G10".into(), letter: 'L' }));
        };
        match l as i64 {
            2 | 20 => {
                let p = self.block.get(b'p').unwrap_or(-1.0);
                if !(0.0..=9.0).contains(&p) || p.fract() != 0.0 {
                    return Err(Fail::Line(
                        col,
                        GcodeErrorKind::BadValue(format!("G10 coordinate system P{p}")),
                    ));
                }
                if self.block.has(b'r') {
                    return Err(Fail::Line(col, GcodeErrorKind::Unsupported("G10 R rotation".into())));
                }
                let idx = if p == 0.0 { self.coord } else { p as usize };
                let base = 5201 + 20 * idx;
                let s = self.scale();
                for (i, &axis) in AXES.iter().enumerate() {
                    if let Some(v) = self.block.get(axis) {
                        let v = v * s;
                        self.params.numbered[base + i] =
                            if l as i64 == 2 { v } else { self.mpos[i] - self.g92[i] - v };
                    }
                }
                if idx == self.coord {
                    self.load_g5x();
                }
                Ok(())
            }
            1 | 10 | 11 => Ok(()),
            _ => Err(Fail::Line(col, GcodeErrorKind::Unsupported(format!("G10 L{l}")))),
        }
    }

    fn home<S: MotionSink>(&mut self, code: u16, col: usize, sink: &mut S) -> Res<(), S::Error> {
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

    fn g92<E>(&mut self, code: u16, col: usize) -> Res<(), E> {
        match code {
            920 => {
                let s = self.scale();
                let mut any = false;
                for (i, &axis) in AXES.iter().enumerate() {
                    if let Some(v) = self.block.get(axis) {
                        any = true;
                        self.g92[i] = self.mpos[i] - self.g5x[i] - v * s;
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
                        for i in 0..3 {
                            self.g92[i] = self.mpos[i] - self.g5x[i];
                        }
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

/// `G91.1` style text of a code stored × 10.
fn fmt_code(code: u16) -> String {
    if code.is_multiple_of(10) { format!("{}", code / 10) } else { format!("{}.{}", code / 10, code % 10) }
}

/// An O word as read by [`read_o_word`].
struct OWord {
    /// Byte range of the label inside the line (`100`, `<name>`, `[expr]`).
    label: (usize, usize),
    /// The label lowercased, without blanks and leading zeros: what closing lines must repeat.
    norm: Vec<u8>,
    /// The value of an all-digit label.
    number: Option<u32>,
    /// The keyword (`sub`, `if`, ...), lowercased; empty when none.
    keyword: String,
    /// Where the line goes on after the keyword.
    end: usize,
}

/// Reads the O word whose letter is at `at`: its label and keyword.
fn read_o_word(b: &[u8], at: usize) -> Result<OWord, GcodeErrorKind> {
    let blank = |c: u8| c == b' ' || c == b'\t';
    let mut i = at + 1;
    while i < b.len() && blank(b[i]) {
        i += 1;
    }
    let start = i;
    match b.get(i) {
        Some(b'<') => match b[i..].iter().position(|&c| c == b'>') {
            Some(k) => i += k + 1,
            None => return Err(GcodeErrorKind::NotGcode("O-word name without '>'".into())),
        },
        Some(b'[') => {
            let mut depth = 0u32;
            while i < b.len() {
                match b[i] {
                    b'[' => depth += 1,
                    b']' => depth -= 1,
                    _ => {}
                }
                i += 1;
                if depth == 0 {
                    break;
                }
            }
            if depth != 0 {
                return Err(GcodeErrorKind::Expression("O-word label without ']'".into()));
            }
        }
        _ => {
            while i < b.len()
                && (b[i].is_ascii_digit()
                    || (blank(b[i]) && b[i + 1..].first().is_some_and(u8::is_ascii_digit)))
            {
                i += 1;
            }
        }
    }
    if i == start {
        return Err(GcodeErrorKind::NotGcode("expected a number or <name> after 'O'".into()));
    }
    let label = (start, i);
    let mut norm: Vec<u8> = b[start..i].iter().filter(|&&c| !blank(c)).map(u8::to_ascii_lowercase).collect();
    let digits = norm.iter().all(u8::is_ascii_digit);
    if digits {
        let z = norm.iter().take_while(|&&c| c == b'0').count().min(norm.len().saturating_sub(1));
        norm.drain(..z);
    }
    let number = if digits && norm.len() <= 9 {
        Some(norm.iter().fold(0u32, |a, &d| a * 10 + (d - b'0') as u32))
    } else {
        None
    };
    while i < b.len() && blank(b[i]) {
        i += 1;
    }
    let ks = i;
    while i < b.len() && b[i].is_ascii_alphabetic() && i - ks < 16 {
        i += 1;
    }
    let keyword = String::from_utf8_lossy(&b[ks..i]).to_ascii_lowercase();
    Ok(OWord { label, norm, number, keyword, end: i })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::MotionRecorder;

    /// Asserts that `other` parses `text` exactly as the one-stage fast path does.
    pub(super) fn assert_same_parse(
        text: &[u8],
        opts: &ParseOptions,
        what: &str,
        other: impl Fn(&[u8], &ParseOptions, &mut MotionRecorder) -> ParseSummary,
    ) {
        let mut a = MotionRecorder::default();
        let mut b = MotionRecorder::default();
        let sa = parse_bytes(text, opts, &mut a, true).expect("infallible sink");
        let sb = other(text, opts, &mut b);
        assert_eq!(sa, sb, "{what}: summaries differ\n{}", String::from_utf8_lossy(text));
        assert_eq!(a.motions, b.motions, "{what}: motions differ\n{}", String::from_utf8_lossy(text));
    }

    /// The fast path against the general interpreter.
    fn both(text: &[u8], opts: &ParseOptions, what: &str) {
        assert_same_parse(text, opts, what, |t, o, rec| {
            parse_bytes(t, o, rec, false).expect("infallible sink")
        });
    }

    pub(super) fn dialects() -> [ParseOptions; 3] {
        [ParseDialect::Auto, ParseDialect::Cnc, ParseDialect::Fdm]
            .map(|dialect| ParseOptions { dialect, ..ParseOptions::default() })
    }

    /// Every program of tests/data (CNC programs, FDM G-code, odd files): name and bytes.
    pub(super) fn sample_files() -> Vec<(String, Vec<u8>)> {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
        let mut out = Vec::new();
        for dir in ["cnc/programs", "fdm/gcode", "cnc/odd"] {
            let entries = std::fs::read_dir(root.join(dir)).unwrap_or_else(|e| panic!("{dir}: {e}"));
            for e in entries {
                let path = e.expect("dir entry").path();
                out.push((path.display().to_string(), std::fs::read(&path).expect("read")));
            }
        }
        assert!(out.len() >= 8, "only {} sample files", out.len());
        out
    }

    /// A SplitMix64 stream from `seed`.
    pub(super) fn splitmix(mut state: u64) -> impl FnMut() -> u64 {
        move || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
    }

    #[test]
    fn plain_codes_agree_with_the_number_reader() {
        let mut state = 0x9E37_u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let alphabet = b"0123456789.  X-";
        let mut taken = 0;
        for case in 0..100_000 {
            let len = 1 + (next() % 8) as usize;
            let mut t: Vec<u8> =
                (0..len).map(|_| alphabet[(next() % alphabet.len() as u64) as usize]).collect();
            if case % 2 == 0 {
                t[0] = b'0' + (next() % 10) as u8;
            }
            for g in [true, false] {
                let Some((code, end)) = plain_code(&t, 0, g) else { continue };
                taken += 1;
                let mut c = Cursor { b: &t, i: 0 };
                let v = c.number().unwrap_or_else(|e| panic!("{:?}: {e:?}", String::from_utf8_lossy(&t)));
                let want = if g { v * 10.0 } else { v };
                let shown = String::from_utf8_lossy(&t);
                assert!((want - code as f64).abs() < 1e-6, "{shown:?} (g {g}): {code} vs {v}");
                assert_eq!(c.i, end, "{shown:?} (g {g}): end");
            }
        }
        assert!(taken > 20_000, "only {taken} plain codes");
    }

    #[test]
    fn fast_path_agrees_with_the_general_interpreter_on_samples() {
        for (name, text) in sample_files() {
            for opts in dialects() {
                both(&text, &opts, &name);
            }
        }
    }

    #[test]
    fn fast_path_agrees_with_the_general_interpreter_on_random_blocks() {
        // Random blocks of the words the fast path takes and of their neighbours.
        let mut next = splitmix(0x5EED);
        let words = [
            "G0", "G1", "G2", "G3", "G20", "G21", "G90", "G91", "G80", "G53", "G4", "G92", "G10", "G11",
            "M3", "M82", "M83", "X", "Y", "Z", "E", "F", "N", "S", "T", "R", "I", "J", "P", "A", "(c)", ";t",
        ];
        for case in 0..400 {
            let mut text = String::new();
            for _ in 0..(next() % 30) {
                for _ in 0..(1 + next() % 4) {
                    let w = words[(next() % words.len() as u64) as usize];
                    text.push_str(w);
                    if w.len() == 1 {
                        let v = (next() % 4000) as f64 / 8.0 - 100.0;
                        text.push_str(&format!("{v}"));
                    }
                    text.push(' ');
                }
                text.push('\n');
            }
            for opts in dialects() {
                both(text.as_bytes(), &opts, &format!("random case {case}"));
            }
        }
    }
}
