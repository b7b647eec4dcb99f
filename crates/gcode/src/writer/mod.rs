//! Dialect writers: [`GcodeWriter`] is a [`MotionSink`] that prints motions as
//! LinuxCNC/RS274NGC, grbl, Fanuc or Marlin G-code.
//!
//! # What each dialect gets
//!
//! Each row is data of the dialect's [`DialectSpec`] ([`Dialect::spec`], one file per
//! dialect under `dialect/`); the writer branches on those fields, not on dialect names.
//!
//! | | LinuxCNC | grbl | Fanuc | Marlin |
//! |---|---|---|---|---|
//! | header | `G17 G21 G40 G49 G80 G90 G94` | same | `%`, `O0001`, same | `G21`, `G90`, `M82`/`M83`, `G92 E0`, optional `G28` |
//! | arcs | G2/G3 IJK (incremental), `P` for extra turns | IJK; extra turns linearised | IJK; extra turns linearised | XY IJK with `E`; other planes and extra turns linearised |
//! | dwell | `G4 P<seconds>` | `G4 P<seconds>` | `G4 X<seconds>` | `G4 P<milliseconds>` |
//! | tool change | `T1 M6` | `M0 (tool change T1)` (grbl has no M6) | `T1 M6` | `T1` |
//! | comments | `(text)` | `(text)` | `(text)` | `;text` |
//! | footer | `M5`, `M9`, `G53 G0 Z0`, `M30` | same | `M5`, `M9`, `G91 G28 Z0`, `G90`, `M30`, `%` | `G0 Z<top + lift>`, `M84` |
//! | drill cycles | `G98 G81`/`G82 P<s>`/`G83 Q<peck>`, `G80` before the next other block | expanded to `G0`/`G1`/`G4` | as LinuxCNC, `G82 P<ms>` | expanded |
//! | stops | `M0` / `M1` | same | same | `M0` / comment |
//! | tool length | `G43 H<n>` after `T<n> M6` with [`WriterOptions::tool_length_offset`] | never | as LinuxCNC (`H<n>` without a point) | never |
//! | work offset | `G54`-`G59` after the header with [`WriterOptions::work_offset`] | same | same | refused |
//!
//! Numbers have at most [`WriterOptions::decimals`] decimals, trailing zeros
//! trimmed (Fanuc keeps the point: `X1.`), never `-0`, never an exponent. A
//! non-finite number is a [`WriteError::NonFinite`], never a panic.
//!
//! Markers become `;LAYER:n` (or `;LAYER_CHANGE` and `;Z:z` when the index is
//! unknown) and `;TYPE:name` in Marlin, `(LAYER:n)` / `(TYPE:name)` elsewhere.
//!
//! # Setups
//!
//! Without [`WriterOptions::rotary`], a [`Motion::Setup`] becomes one comment line
//! (`;` instead of parentheses in Marlin), exactly:
//!
//! `(SETUP <n>: rotate part so that tool axis = <x> <y> <z>; frame quaternion w x y z = <w> <x> <y> <z>; translation = <x> <y> <z>)`
//!
//! where `n` counts setups from 1, the tool axis is `frame * +Z` in the part
//! frame, numbers carry an explicit sign and six decimals; setups after the
//! first are followed by `M0` (pause to re-fixture) when
//! [`WriterOptions::setup_pause`] is set. With a rotary option the same comment
//! is followed by `G0 A<a> C<c>` ([`RotaryAxes::AC`]) or `G0 B<b> C<c>`
//! ([`RotaryAxes::BC`]) in degrees: the setup's own `rotary` values when given,
//! otherwise [`crate::rotary_angles`] of its frame, solved from the tool axis
//! `t = frame * +Z` with the table-table conventions `t = Rz(C) Rx(A) +Z` (so
//! `A = acos(t.z)` in `[0, 180]`, `C = atan2(t.x, -t.y)`) and `t = Rz(C) Ry(B) +Z`
//! (`B = acos(t.z)`, `C = atan2(t.y, t.x)`). Only frames whose rotation is the
//! kinematic rotation of those angles are written exactly; for others the
//! machine cuts the path turned about the tool axis by [`crate::rotary_twist`] (see
//! [`crate::rotary_frame`]). After a setup every axis word is
//! written again.
//!
//! A [`Motion::ToolAxis`] (a tilting head under tool-centre-point control) is, with a
//! rotary option, `G0 A<a> C<c>` or `G0 B<b> C<c>`: its own `rotary` values when given,
//! otherwise [`crate::axis_angles`] of its axis; the tip does not move, so axis words stay
//! modal. Without a rotary option it is the comment `(TOOL AXIS = <x> <y> <z>)`, signed
//! with six decimals.

mod format;

use std::f64::consts::{PI, TAU};
use std::fmt::Write as _;
use std::io::Write;

use nalgebra::{Isometry3, Point3, Vector3};

use crate::arc::{ArcError, ArcFitOptions, ArcFitter, ArcSpec, plane_axes};
use crate::dialect::{
    AutoRetract, CommentStyle, Dialect, DialectSpec, DrillCycles, DwellDecimals, DwellFormat, TimeUnit,
    ToolChange,
};
use crate::motion::{
    ArcDirection, Coolant, CycleKind, DrillCycle, Marker, Motion, MotionSink, Plane, SpindleDirection,
};
use crate::rotary::{RotaryAxes, rotary_angles};

/// The least radius an arc is written with, at its start and its end (program units):
/// LinuxCNC's radius tolerance, 0.00005 inch in millimetres (stricter in an inch program).
const MIN_ARC_RADIUS: f64 = 0.00005 * 25.4;

pub(crate) use format::{push_num, rounded};

/// Marlin extrusion mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ExtrusionMode {
    /// `M82`: E words are the running filament total.
    #[default]
    Absolute,
    /// `M83`: E words are per-move amounts.
    Relative,
}

/// How the footer leaves the tool.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum FooterRetract {
    /// Dialect default: `G53 G0 Z0` (LinuxCNC, grbl), `G91 G28 Z0` then `G90`
    /// (Fanuc), `G0` to 5 mm above the highest Z written (Marlin).
    #[default]
    Auto,
    /// `G0` to this many mm above the highest Z written (all dialects).
    Lift(f64),
    /// No retract.
    None,
}

/// Writer options. Every field documents its default.
#[derive(Debug, Clone, PartialEq)]
pub struct WriterOptions {
    /// Decimals for coordinates, arc offsets and feeds. Default 4.
    pub decimals: usize,
    /// Decimals for Marlin E words. Default 5.
    pub e_decimals: usize,
    /// `N` numbers on every block (`%` and O lines excluded; Marlin adds `*` checksums
    /// and leaves comment-only lines unnumbered). Default false.
    pub line_numbers: bool,
    /// Step between line numbers. Default 10.
    pub line_number_step: u64,
    /// Suppress repeated motion G words, feeds, planes and unchanged axis words. Default true.
    pub modal: bool,
    /// Write comments (including markers and setup notes). Default true.
    pub comments: bool,
    /// Write the header (units, plane, absolute, feed mode, safe start). Default true.
    pub header: bool,
    /// Marlin only: home with `G28` in the header. Default false.
    pub home: bool,
    /// Write the footer on [`MotionSink::finish`]. Default true.
    pub footer: bool,
    /// How the footer retracts. Default [`FooterRetract::Auto`].
    pub retract: FooterRetract,
    /// Fanuc program number (1..=9999). Default 1.
    pub program_number: u32,
    /// Fit arcs to runs of linear moves before writing. Default `None`.
    pub arc_fit: Option<ArcFitOptions>,
    /// Chordal tolerance (mm) for arcs a dialect cannot write (linearised). Default 0.002.
    pub arc_tolerance: f64,
    /// Largest start/end radius mismatch (mm) after rounding before an arc is
    /// linearised instead (the controller could reject it; grbl allows 0.005). Default 0.002.
    pub max_arc_radius_error: f64,
    /// Rotary words for setups; `None` writes 3-axis programs with a setup comment. Default `None`.
    pub rotary: Option<RotaryAxes>,
    /// Pause (`M0`) after each setup but the first, when not using rotary axes. Default true.
    pub setup_pause: bool,
    /// Marlin extrusion mode. Default [`ExtrusionMode::Absolute`].
    pub extrusion: ExtrusionMode,
    /// LinuxCNC and Fanuc: write `G43 H<n>` (tool length offset of tool `n`) after each
    /// tool change. Default false.
    pub tool_length_offset: bool,
    /// Select a work coordinate system in the header's safe start block: 1 to 6 for
    /// `G54` to `G59` (every milling dialect has them). Default `None` (none selected: the
    /// controller's current one).
    pub work_offset: Option<u8>,
}

impl Default for WriterOptions {
    fn default() -> Self {
        WriterOptions {
            decimals: 4,
            e_decimals: 5,
            line_numbers: false,
            line_number_step: 10,
            modal: true,
            comments: true,
            header: true,
            home: false,
            footer: true,
            retract: FooterRetract::Auto,
            program_number: 1,
            arc_fit: None,
            arc_tolerance: 0.002,
            max_arc_radius_error: 0.002,
            rotary: None,
            setup_pause: true,
            extrusion: ExtrusionMode::Absolute,
            tool_length_offset: false,
            work_offset: None,
        }
    }
}

/// Errors of the writers.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WriteError {
    /// The output failed.
    #[error("writing G-code")]
    Io(#[from] std::io::Error),
    /// A coordinate, feed or other number is NaN or infinite.
    #[error("motion {index}: {what} is not finite ({value})")]
    NonFinite {
        /// 0-based index of the motion in the input.
        index: u64,
        /// Which number.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// An arc could not be linearised.
    #[error("motion {index}")]
    Arc {
        /// 0-based index of the motion in the input.
        index: u64,
        /// The cause.
        source: ArcError,
    },
    /// An option is out of range.
    #[error("bad writer option: {0}")]
    BadOption(&'static str),
    /// A motion arrived after [`MotionSink::finish`].
    #[error("motion after finish()")]
    Finished,
}

/// Writes motions as G-code of one [`Dialect`]; see the [module docs](self).
///
/// Call [`MotionSink::finish`] at the end: it writes the footer and flushes.
#[derive(Debug)]
pub struct GcodeWriter<W: Write> {
    inner: Inner<W>,
}

#[derive(Debug)]
enum Inner<W: Write> {
    Plain(Core<W>),
    Fitted(ArcFitter<Core<W>>),
}

impl<W: Write> GcodeWriter<W> {
    /// A writer printing to `out`.
    pub fn new(out: W, dialect: Dialect, opts: WriterOptions) -> Self {
        let fit = opts.arc_fit;
        let core = Core::new(out, dialect, opts);
        let inner = match fit {
            Some(f) => Inner::Fitted(ArcFitter::new(core, f)),
            None => Inner::Plain(core),
        };
        GcodeWriter { inner }
    }

    fn core(&self) -> &Core<W> {
        match &self.inner {
            Inner::Plain(c) => c,
            Inner::Fitted(f) => f.inner(),
        }
    }

    /// The dialect.
    pub fn dialect(&self) -> Dialect {
        self.core().dialect
    }

    /// Input moves per written move (1 without arc fitting).
    pub fn compression_ratio(&self) -> f64 {
        match &self.inner {
            Inner::Plain(_) => 1.0,
            Inner::Fitted(f) => f.compression_ratio(),
        }
    }

    /// Blocks written so far.
    pub fn lines_written(&self) -> u64 {
        self.core().lines
    }

    /// The output. Bytes written to it directly land between the blocks written so far and
    /// those after only once [`flush_blocks`](Self::flush_blocks) has passed the former on.
    pub fn get_mut(&mut self) -> &mut W {
        match &mut self.inner {
            Inner::Plain(c) => &mut c.out,
            Inner::Fitted(f) => &mut f.inner_mut().out,
        }
    }

    /// Passes every block finished so far to the output and flushes it, so that a reader at
    /// its other end has them all; the text is the same as without it. An arc-fitting
    /// writer's open run of moves stays held (a later move may yet extend it).
    pub fn flush_blocks(&mut self) -> Result<(), WriteError> {
        let core = match &mut self.inner {
            Inner::Plain(c) => c,
            Inner::Fitted(f) => f.inner_mut(),
        };
        core.out.write_all(core.buf.as_bytes())?;
        core.buf.clear();
        core.out.flush()?;
        Ok(())
    }

    /// The output (call [`MotionSink::finish`] first, or buffered text is lost).
    pub fn into_inner(self) -> W {
        match self.inner {
            Inner::Plain(c) => c.out,
            Inner::Fitted(f) => f.into_inner().out,
        }
    }
}

impl<W: Write> MotionSink for GcodeWriter<W> {
    type Error = WriteError;
    fn motion(&mut self, motion: &Motion<'_>) -> Result<(), WriteError> {
        match &mut self.inner {
            Inner::Plain(c) => c.motion(motion),
            Inner::Fitted(f) => f.motion(motion),
        }
    }
    fn finish(&mut self) -> Result<(), WriteError> {
        match &mut self.inner {
            Inner::Plain(c) => c.finish(),
            Inner::Fitted(f) => f.finish(),
        }
    }
}

/// Writes `motions` as one program of `dialect` (header and footer per `opts`).
///
/// ```
/// use nalgebra::Point3;
/// use s2g_gcode::{Dialect, Motion, WriterOptions, write_program};
///
/// let moves = [
///     Motion::Rapid { to: Point3::new(0.0, 0.0, 5.0) },
///     Motion::Linear { to: Point3::new(10.0, 0.0, -1.0), feed: 300.0, extrude: None },
/// ];
/// let opts = WriterOptions { header: false, footer: false, ..Default::default() };
/// let text = write_program(Dialect::LinuxCnc, opts, &moves)?;
/// assert_eq!(text, "G0 X0 Y0 Z5\nG1 X10 Z-1 F300\n");
/// # Ok::<(), s2g_gcode::WriteError>(())
/// ```
pub fn write_program<'m, 'a: 'm>(
    dialect: Dialect,
    opts: WriterOptions,
    motions: impl IntoIterator<Item = &'m Motion<'a>>,
) -> Result<String, WriteError> {
    let mut w = GcodeWriter::new(Vec::new(), dialect, opts);
    for m in motions {
        w.motion(m)?;
    }
    w.finish()?;
    // Only ASCII and the caller's comment text (valid UTF-8) are ever written.
    Ok(String::from_utf8_lossy(&w.into_inner()).into_owned())
}

#[derive(Debug)]
struct Core<W: Write> {
    out: W,
    dialect: Dialect,
    /// What `dialect` writes differently: every dialect decision reads this.
    spec: &'static DialectSpec,
    opts: WriterOptions,
    /// Pending output.
    buf: String,
    /// The block being built.
    block: String,
    /// Next line number.
    n: u64,
    lines: u64,
    index: u64,
    started: bool,
    finished: bool,
    ended: bool,
    /// Position as the machine will read it back (rounded), per axis.
    pos: [Option<f64>; 3],
    /// The last end point as given (unrounded), for arc decisions.
    exact: Option<Point3<f64>>,
    motion_mode: Option<u8>,
    feed: Option<f64>,
    plane: Option<Plane>,
    /// Running E total written (Marlin absolute mode), exact and as printed.
    e_total: f64,
    e_written: f64,
    max_z: f64,
    setups: u32,
    /// A canned cycle is modal and active (`G80` due before the next other block).
    cycle_active: bool,
}

impl<W: Write> Core<W> {
    fn new(out: W, dialect: Dialect, opts: WriterOptions) -> Self {
        let step = opts.line_number_step.max(1);
        Core {
            out,
            dialect,
            spec: dialect.spec(),
            opts,
            buf: String::with_capacity(1 << 16),
            block: String::with_capacity(128),
            n: step,
            lines: 0,
            index: 0,
            started: false,
            finished: false,
            ended: false,
            pos: [None; 3],
            exact: None,
            motion_mode: None,
            feed: None,
            plane: None,
            e_total: 0.0,
            e_written: 0.0,
            max_z: f64::NEG_INFINITY,
            setups: 0,
            cycle_active: false,
        }
    }

    fn check(&self, what: &'static str, v: f64) -> Result<f64, WriteError> {
        if v.is_finite() { Ok(v) } else { Err(WriteError::NonFinite { index: self.index, what, value: v }) }
    }

    fn check_point(&self, what: &'static str, p: &Point3<f64>) -> Result<(), WriteError> {
        for c in p.iter() {
            self.check(what, *c)?;
        }
        Ok(())
    }

    /// Appends ` L<v>` to the block (no leading space on the first word).
    fn word(&mut self, letter: char, v: f64, decimals: usize) {
        if !self.block.is_empty() {
            self.block.push(' ');
        }
        self.block.push(letter);
        push_num(&mut self.block, v, decimals, self.spec.keep_point);
    }

    fn raw(&mut self, text: &str) {
        if !self.block.is_empty() {
            self.block.push(' ');
        }
        self.block.push_str(text);
    }

    /// Ends the block: line number, checksum, newline.
    fn end_block(&mut self) -> Result<(), WriteError> {
        if self.block.is_empty() {
            return Ok(());
        }
        let comment_only = self.block.starts_with(';') || self.block.starts_with('(');
        let numbered = self.opts.line_numbers && (self.spec.number_comment_lines || !comment_only);
        let start = self.buf.len();
        if numbered {
            let _ = write!(self.buf, "N{} ", self.n);
            self.n += self.opts.line_number_step.max(1);
        }
        self.buf.push_str(&self.block);
        if numbered && self.spec.checksums {
            // RepRap checksum: XOR of every byte before '*'.
            let cs = self.buf.as_bytes()[start..].iter().fold(0u8, |a, b| a ^ b);
            let _ = write!(self.buf, "*{cs}");
        }
        self.buf.push('\n');
        self.block.clear();
        self.lines += 1;
        if self.buf.len() > (1 << 16) - 512 {
            self.out.write_all(self.buf.as_bytes())?;
            self.buf.clear();
        }
        Ok(())
    }

    /// A line that is never numbered (`%`, O-number).
    fn bare_line(&mut self, text: &str) {
        self.buf.push_str(text);
        self.buf.push('\n');
        self.lines += 1;
    }

    fn comment_line(&mut self, text: &str) -> Result<(), WriteError> {
        if !self.opts.comments {
            return Ok(());
        }
        self.push_comment(text);
        self.end_block()
    }

    /// Appends a comment to the block in the dialect's syntax, sanitised so it
    /// cannot end early or be taken as a LinuxCNC command comment.
    fn push_comment(&mut self, text: &str) {
        let parens = self.spec.comments == CommentStyle::Parens;
        let clean: String = text
            .chars()
            .map(|c| match c {
                '\n' | '\r' => ' ',
                '(' if parens => '[',
                ')' if parens => ']',
                c => c,
            })
            .collect();
        let lower = clean.trim_start().to_ascii_lowercase();
        let command = [
            "msg,",
            "debug,",
            "print,",
            "probeopen",
            "probeclose",
            "logopen",
            "logappend",
            "logclose",
            "log,",
        ]
        .iter()
        .any(|k| lower.starts_with(k));
        if !self.block.is_empty() {
            self.block.push(' ');
        }
        match self.spec.comments {
            CommentStyle::Semicolon => {
                self.block.push(';');
                self.block.push_str(&clean);
            }
            CommentStyle::Parens => {
                self.block.push('(');
                if command {
                    self.block.push('_');
                }
                self.block.push_str(&clean);
                self.block.push(')');
            }
        }
    }

    fn header(&mut self) -> Result<(), WriteError> {
        if self.started {
            return Ok(());
        }
        self.started = true;
        if !self.opts.header {
            return Ok(());
        }
        let spec = self.spec;
        if spec.delimiters {
            if !(1..=9999).contains(&self.opts.program_number) {
                return Err(WriteError::BadOption("Fanuc program_number must be in 1..=9999"));
            }
            self.bare_line("%");
            let o = format!("O{:04}", self.opts.program_number);
            self.bare_line(&o);
        }
        self.comment_line(&format!("generated by s2g-gcode for {}", spec.display_name))?;
        for l in spec.header {
            self.raw(l);
            self.end_block()?;
        }
        if let Some(k) = self.opts.work_offset {
            if !(1..=6).contains(&k) || spec.extrusion {
                return Err(WriteError::BadOption(
                    "work_offset must be 1..=6 (G54..G59), on a milling dialect",
                ));
            }
            self.raw(&format!("G{}", 53 + k));
            self.end_block()?;
        }
        if spec.extrusion {
            self.raw(match self.opts.extrusion {
                ExtrusionMode::Absolute => "M82",
                ExtrusionMode::Relative => "M83",
            });
            self.end_block()?;
            self.raw("G92 E0");
            self.end_block()?;
        }
        if spec.homing && self.opts.home {
            self.raw("G28");
            self.end_block()?;
        }
        if spec.plane_select {
            // The header's G17.
            self.plane = Some(Plane::XY);
            self.motion_mode = None;
        }
        Ok(())
    }

    fn footer(&mut self) -> Result<(), WriteError> {
        self.cancel_cycle()?;
        if !self.opts.footer {
            return Ok(());
        }
        let spec = self.spec;
        // After an explicit program end only the closing delimiter follows.
        if !(self.ended && spec.program_end.is_some()) {
            for m in spec.footer_stops {
                self.raw(m);
                self.end_block()?;
            }
            let lift = match (self.opts.retract, spec.auto_retract) {
                (FooterRetract::Auto, AutoRetract::Blocks(blocks)) => {
                    for b in blocks {
                        self.raw(b);
                        self.end_block()?;
                    }
                    None
                }
                (FooterRetract::Auto, AutoRetract::Lift(l)) => Some(l),
                (FooterRetract::Lift(l), _) => Some(self.check("footer lift", l)?),
                (FooterRetract::None, _) => None,
            };
            if let Some(l) = lift {
                let z = if self.max_z.is_finite() { self.max_z + l } else { l };
                self.raw("G0");
                self.word('Z', z, self.opts.decimals);
                self.end_block()?;
            }
            if let Some(end) = spec.program_end {
                self.raw(end);
                self.end_block()?;
            }
            for m in spec.footer_tail {
                self.raw(m);
                self.end_block()?;
            }
        }
        if spec.delimiters && self.opts.header {
            self.bare_line("%");
        }
        Ok(())
    }

    /// Rounded target per axis and whether it differs from the known position.
    fn target(&self, to: &Point3<f64>) -> ([f64; 3], [bool; 3]) {
        let d = self.opts.decimals;
        let r = [rounded(to.x, d), rounded(to.y, d), rounded(to.z, d)];
        let changed = [0, 1, 2].map(|i| self.pos[i] != Some(r[i]));
        (r, changed)
    }

    fn mode(&mut self, g: u8) {
        if !self.opts.modal || self.motion_mode != Some(g) {
            self.raw(match g {
                0 => "G0",
                1 => "G1",
                2 => "G2",
                _ => "G3",
            });
            self.motion_mode = Some(g);
        }
    }

    fn axes(&mut self, r: [f64; 3], changed: [bool; 3], force: [bool; 3]) {
        for (i, letter) in ['X', 'Y', 'Z'].into_iter().enumerate() {
            if changed[i] || force[i] || !self.opts.modal {
                self.word(letter, r[i], self.opts.decimals);
            }
            self.pos[i] = Some(r[i]);
        }
        self.max_z = self.max_z.max(r[2]);
    }

    fn feed_word(&mut self, feed: f64) {
        let f = rounded(feed, self.opts.decimals);
        if !self.opts.modal || self.feed != Some(f) {
            self.word('F', f, self.opts.decimals);
            self.feed = Some(f);
        }
    }

    /// Appends the E word for `extrude` (Marlin only); returns whether one was written.
    fn e_word(&mut self, extrude: Option<f64>) -> Result<bool, WriteError> {
        let Some(e) = extrude else { return Ok(false) };
        if !self.spec.extrusion {
            return Ok(false);
        }
        let e = self.check("extrusion", e)?;
        let d = self.opts.e_decimals;
        match self.opts.extrusion {
            ExtrusionMode::Absolute => {
                self.e_total += e;
                let w = rounded(self.e_total, d);
                if w == self.e_written {
                    return Ok(false);
                }
                self.e_written = w;
                self.word('E', w, d);
            }
            ExtrusionMode::Relative => {
                if rounded(e, d) == 0.0 {
                    return Ok(false);
                }
                self.word('E', e, d);
            }
        }
        Ok(true)
    }

    /// Whether `extrude` would print a non-zero E word.
    fn e_nonzero(&self, extrude: Option<f64>) -> bool {
        match extrude {
            Some(e) if self.spec.extrusion => match self.opts.extrusion {
                ExtrusionMode::Absolute => rounded(self.e_total + e, self.opts.e_decimals) != self.e_written,
                ExtrusionMode::Relative => rounded(e, self.opts.e_decimals) != 0.0,
            },
            _ => false,
        }
    }

    fn rapid(&mut self, to: &Point3<f64>) -> Result<(), WriteError> {
        self.check_point("rapid end point", to)?;
        let (r, changed) = self.target(to);
        self.exact = Some(*to);
        if !changed.iter().any(|&c| c) {
            return Ok(());
        }
        self.mode(0);
        self.axes(r, changed, [false; 3]);
        self.end_block()
    }

    fn linear(&mut self, to: &Point3<f64>, feed: f64, extrude: Option<f64>) -> Result<(), WriteError> {
        self.check_point("linear end point", to)?;
        self.check("feed", feed)?;
        if let Some(e) = extrude {
            self.check("extrusion", e)?;
        }
        let (r, changed) = self.target(to);
        self.exact = Some(*to);
        if !changed.iter().any(|&c| c) && !self.e_nonzero(extrude) {
            return Ok(());
        }
        self.mode(1);
        self.axes(r, changed, [false; 3]);
        self.e_word(extrude)?;
        self.feed_word(feed);
        self.end_block()
    }

    /// Writes an arc as chords at [`WriterOptions::arc_tolerance`].
    fn linearised(&mut self, spec: &ArcSpec, feed: f64, extrude: Option<f64>) -> Result<(), WriteError> {
        let mut pts = Vec::new();
        let index = self.index;
        spec.linearize(self.opts.arc_tolerance, |p| pts.push(p))
            .map_err(|source| WriteError::Arc { index, source })?;
        let n = pts.len().max(1) as f64;
        for p in pts {
            self.linear(&p, feed, extrude.map(|e| e / n))?;
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)] // The fields of one Motion::Arc.
    fn arc(
        &mut self,
        to: &Point3<f64>,
        center: &Point3<f64>,
        plane: Plane,
        direction: ArcDirection,
        turns: u32,
        feed: f64,
        extrude: Option<f64>,
    ) -> Result<(), WriteError> {
        self.check_point("arc end point", to)?;
        self.check_point("arc centre", center)?;
        self.check("feed", feed)?;
        if let Some(e) = extrude {
            self.check("extrusion", e)?;
        }
        let d = self.opts.decimals;
        let (u, v, w) = plane_axes(plane);
        // Without a known start the arc cannot be written incrementally: treat as a line.
        let Some(start) = (match self.pos {
            [Some(x), Some(y), Some(z)] => Some(Point3::new(x, y, z)),
            _ => None,
        }) else {
            return self.linear(to, feed, extrude);
        };
        let exact_start = self.exact.unwrap_or(start);
        let spec = ArcSpec { start: exact_start, end: *to, center: *center, plane, direction, turns };
        let cannot =
            (turns > 0 && !self.spec.multi_turn_arcs) || (plane != Plane::XY && !self.spec.plane_select);
        if cannot {
            return self.linearised(&spec, feed, extrude);
        }
        let (r, _) = self.target(to);
        let off_u = rounded(center[u] - start[u], d);
        let off_v = rounded(center[v] - start[v], d);
        let (cu, cv) = (start[u] + off_u, start[v] + off_v);
        let r1 = off_u.hypot(off_v);
        let r2 = (r[u] - cu).hypot(r[v] - cv);
        let quantum = 10f64.powi(-(d.min(300) as i32));
        // LinuxCNC (and this crate's parser) refuse an arc whose written radius at its
        // start or its end is under 0.00005 inch (0.00127 mm): such a move is a line.
        if r1.min(r2) < quantum.max(MIN_ARC_RADIUS) {
            // Zero radius: the move is a straight line.
            return self.linear(to, feed, extrude);
        }
        if (r1 - r2).abs() > self.opts.max_arc_radius_error {
            return self.linearised(&spec, feed, extrude);
        }
        // Rounding can move the end across the start: a tiny arc would read as a
        // full circle, a nearly full one as a tiny arc. Compare the sweeps.
        let mut written_center = start;
        written_center[u] = cu;
        written_center[v] = cv;
        let written = ArcSpec { start, end: Point3::from(r), center: written_center, ..spec };
        let intended = spec.sweep();
        if (written.sweep() - intended).abs() > PI {
            return if intended - TAU * turns as f64 <= PI {
                self.linear(to, feed, extrude)
            } else {
                self.linearised(&spec, feed, extrude)
            };
        }
        // Without plane selection only XY arcs get here: no plane words.
        if self.spec.plane_select && (!self.opts.modal || self.plane != Some(plane)) {
            self.raw(match plane {
                Plane::XY => "G17",
                Plane::ZX => "G18",
                Plane::YZ => "G19",
            });
            self.plane = Some(plane);
        }
        self.mode(match direction {
            ArcDirection::Clockwise => 2,
            ArcDirection::CounterClockwise => 3,
        });
        let mut force = [false; 3];
        force[u] = true;
        force[v] = true;
        let changed = [0, 1, 2].map(|i| self.pos[i] != Some(r[i]));
        let _ = w;
        self.exact = Some(*to);
        self.axes(r, changed, force);
        let letters = ['I', 'J', 'K'];
        // IJK in X, Y, Z order.
        let mut offs = [(u, off_u), (v, off_v)];
        offs.sort_by_key(|o| o.0);
        for (axis, off) in offs {
            self.word(letters[axis], off, d);
        }
        if turns > 0 {
            self.raw(&format!("P{}", turns as u64 + 1));
        }
        self.e_word(extrude)?;
        self.feed_word(feed);
        self.end_block()
    }

    /// `G80` when a canned cycle is active.
    fn cancel_cycle(&mut self) -> Result<(), WriteError> {
        if self.cycle_active {
            self.cycle_active = false;
            self.raw("G80");
            self.end_block()?;
        }
        Ok(())
    }

    /// A canned drilling cycle: native or expanded per [`DialectSpec::drill_cycles`].
    fn cycle(&mut self, c: &DrillCycle) -> Result<(), WriteError> {
        for (what, v) in [("cycle X", c.x), ("cycle Y", c.y), ("cycle clearance", c.clearance)] {
            self.check(what, v)?;
        }
        self.check("cycle R plane", c.r_plane)?;
        self.check("cycle bottom", c.bottom)?;
        self.check("feed", c.feed)?;
        let (extra, extra_ok) = match c.kind {
            CycleKind::Drill => (None, true),
            CycleKind::Dwell { seconds } => (Some(('P', seconds)), seconds.is_finite() && seconds >= 0.0),
            CycleKind::Peck { peck } => (Some(('Q', peck)), peck.is_finite() && peck > 0.0),
        };
        if !extra_ok {
            return Err(WriteError::NonFinite {
                index: self.index,
                what: "cycle dwell or peck",
                value: f64::NAN,
            });
        }
        let dwell = match self.spec.drill_cycles {
            DrillCycles::Canned { dwell } => dwell,
            DrillCycles::Expanded { dwell } => return self.expanded_cycle(c, dwell),
        };
        let d = self.opts.decimals;
        let top = c.clearance.max(c.r_plane);
        // The initial level is where the cycle starts: go there first.
        if self.pos[2] != Some(rounded(top, d)) {
            let mut p = Point3::new(c.x, c.y, top);
            if let (Some(x), Some(y)) = (self.pos[0], self.pos[1]) {
                p.x = x;
                p.y = y;
            }
            self.rapid(&p)?;
        }
        self.raw("G98");
        self.raw(match c.kind {
            CycleKind::Drill => "G81",
            CycleKind::Dwell { .. } => "G82",
            CycleKind::Peck { .. } => "G83",
        });
        self.word('X', c.x, d);
        self.word('Y', c.y, d);
        self.word('Z', c.bottom, d);
        self.word('R', c.r_plane, d);
        match extra {
            Some(('P', seconds)) => self.dwell_word(dwell, seconds),
            Some((letter, v)) => self.word(letter, v, d.max(3)),
            None => {}
        }
        let f = rounded(c.feed, d);
        self.word('F', f, d);
        self.feed = Some(f);
        self.end_block()?;
        self.cycle_active = true;
        // After the cycle the motion mode must be stated again (G80 cancels it).
        self.motion_mode = None;
        self.pos = [Some(rounded(c.x, d)), Some(rounded(c.y, d)), Some(rounded(top, d))];
        self.exact = Some(Point3::new(c.x, c.y, top));
        self.max_z = self.max_z.max(top);
        Ok(())
    }

    /// A drill cycle as `G0`/`G1` moves and `G4` dwells written with `dwell`.
    fn expanded_cycle(&mut self, c: &DrillCycle, dwell: DwellFormat) -> Result<(), WriteError> {
        let from = match self.pos {
            [Some(x), Some(y), Some(z)] => Some(Point3::new(x, y, z)),
            _ => None,
        };
        let mut moves = Vec::new();
        c.expand(from, |m| moves.push(m));
        for m in &moves {
            match m {
                Motion::Rapid { to } => self.rapid(to)?,
                Motion::Linear { to, feed, .. } => self.linear(to, *feed, None)?,
                Motion::Dwell { seconds } => {
                    self.raw("G4");
                    self.dwell_word(dwell, *seconds);
                    self.end_block()?;
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Appends the dwell word for `seconds` in `format`.
    fn dwell_word(&mut self, format: DwellFormat, seconds: f64) {
        let v = match format.unit {
            TimeUnit::Seconds => seconds,
            TimeUnit::Milliseconds => seconds * 1000.0,
        };
        match format.decimals {
            DwellDecimals::Fixed(n) => self.word(format.letter, v, n),
            DwellDecimals::AtLeast(n) => self.word(format.letter, v, self.opts.decimals.max(n)),
            DwellDecimals::Integer => self.raw(&format!("{}{}", format.letter, v.round() as u64)),
        }
    }

    fn setup(&mut self, frame: &Isometry3<f64>, rotary: &[Option<f64>; 3]) -> Result<(), WriteError> {
        for c in frame.translation.vector.iter().chain(frame.rotation.coords.iter()) {
            self.check("setup frame", *c)?;
        }
        self.setups += 1;
        let t = frame.rotation * Vector3::z();
        let q = frame.rotation;
        let tr = frame.translation.vector;
        let s = |v: f64| {
            let v = if v.abs() < 5e-7 { 0.0 } else { v };
            format!("{v:+.6}")
        };
        let text = format!(
            "SETUP {}: rotate part so that tool axis = {} {} {}; frame quaternion w x y z = {} {} {} {}; translation = {} {} {}",
            self.setups,
            s(t.x),
            s(t.y),
            s(t.z),
            s(q.w),
            s(q.i),
            s(q.j),
            s(q.k),
            s(tr.x),
            s(tr.y),
            s(tr.z)
        );
        self.comment_line(&text)?;
        match self.opts.rotary {
            None => {
                if self.setups > 1 && self.opts.setup_pause {
                    self.raw("M0");
                    self.end_block()?;
                }
            }
            // Shared with the parser: see crate::rotary.
            Some(axes) => self.rotary_block(axes, rotary_angles(axes, frame), rotary)?,
        }
        // The part moved: state every axis again.
        self.pos = [None; 3];
        self.exact = None;
        Ok(())
    }
}

impl<W: Write> Core<W> {
    /// A tilting head's new tool axis (module docs).
    fn tool_axis(&mut self, axis: &Vector3<f64>, rotary: &[Option<f64>; 3]) -> Result<(), WriteError> {
        for c in axis.iter() {
            self.check("tool axis", *c)?;
        }
        let Some(axes) = self.opts.rotary else {
            let s = |v: f64| {
                let v = if v.abs() < 5e-7 { 0.0 } else { v };
                format!("{v:+.6}")
            };
            return self.comment_line(&format!("TOOL AXIS = {} {} {}", s(axis.x), s(axis.y), s(axis.z)));
        };
        self.rotary_block(axes, crate::rotary::axis_angles(axes, axis), rotary)
    }

    /// `G0 A<a> C<c>` (or `B<b>`): the given `rotary` values where known, else `solved`.
    fn rotary_block(
        &mut self,
        axes: RotaryAxes,
        solved: [f64; 3],
        rotary: &[Option<f64>; 3],
    ) -> Result<(), WriteError> {
        let (li, letter) = match axes {
            RotaryAxes::AC => (0, 'A'),
            RotaryAxes::BC => (1, 'B'),
        };
        let a = rotary[li].unwrap_or(solved[li]);
        let c = rotary[2].unwrap_or(solved[2]);
        self.check("rotary angle", a)?;
        self.check("rotary angle", c)?;
        self.raw("G0");
        self.motion_mode = Some(0);
        self.word(letter, a, self.opts.decimals);
        self.word('C', c, self.opts.decimals);
        self.end_block()
    }
}

impl<W: Write> MotionSink for Core<W> {
    type Error = WriteError;

    fn motion(&mut self, motion: &Motion<'_>) -> Result<(), WriteError> {
        if self.finished {
            return Err(WriteError::Finished);
        }
        self.header()?;
        if !matches!(motion, Motion::Cycle(_) | Motion::Comment(_) | Motion::Marker(_)) {
            self.cancel_cycle()?;
        }
        let d = self.opts.decimals;
        match motion {
            Motion::Rapid { to } => self.rapid(to)?,
            Motion::Linear { to, feed, extrude } => self.linear(to, *feed, *extrude)?,
            Motion::Arc { to, center, plane, direction, turns, feed, extrude } => {
                self.arc(to, center, *plane, *direction, *turns, *feed, *extrude)?
            }
            Motion::ToolChange { tool } => {
                match self.spec.tool_change {
                    ToolChange::Pause => {
                        self.raw("M0");
                        if self.opts.comments {
                            self.push_comment(&format!("tool change T{tool}"));
                        }
                    }
                    ToolChange::Select => self.raw(&format!("T{tool}")),
                    ToolChange::M6 => self.raw(&format!("T{tool} M6")),
                }
                self.end_block()?;
                if self.opts.tool_length_offset && self.spec.tool_length_offset {
                    self.raw("G43");
                    self.word('H', f64::from(*tool), 0);
                    // H names an offset register: an integer, no point even on Fanuc.
                    if self.spec.keep_point && self.block.ends_with('.') {
                        self.block.pop();
                    }
                    self.end_block()?;
                }
            }
            Motion::Spindle { rpm, direction } => {
                let rpm = self.check("spindle speed", *rpm)?;
                match direction {
                    SpindleDirection::Off => self.raw("M5"),
                    dir => {
                        self.word('S', rpm, d);
                        // S is an integer: no point needed, even where whole numbers keep it.
                        if self.spec.keep_point && self.block.ends_with('.') {
                            self.block.pop();
                        }
                        self.raw(if *dir == SpindleDirection::Clockwise { "M3" } else { "M4" });
                    }
                }
                self.end_block()?;
            }
            Motion::Coolant(c) => {
                self.raw(match c {
                    Coolant::Mist => "M7",
                    Coolant::Flood => "M8",
                    Coolant::Off => "M9",
                });
                self.end_block()?;
            }
            Motion::Dwell { seconds } => {
                let s = self.check("dwell", *seconds)?.max(0.0);
                self.raw("G4");
                self.dwell_word(self.spec.dwell, s);
                self.end_block()?;
            }
            Motion::Comment(text) => self.comment_line(text)?,
            Motion::Marker(Marker::Layer { index, z }) => {
                if let Some(z) = z {
                    self.check("layer z", *z)?;
                }
                match index {
                    Some(i) => self.comment_line(&format!("LAYER:{i}"))?,
                    None => {
                        self.comment_line("LAYER_CHANGE")?;
                        if let Some(z) = z {
                            let mut t = String::from("Z:");
                            push_num(&mut t, *z, d, false);
                            self.comment_line(&t)?;
                        }
                    }
                }
            }
            Motion::Marker(Marker::Type(t)) => self.comment_line(&format!("TYPE:{t}"))?,
            Motion::Setup { frame, rotary } => self.setup(frame, rotary)?,
            Motion::ToolAxis { axis, rotary } => self.tool_axis(axis, rotary)?,
            Motion::End => {
                if let Some(end) = self.spec.program_end {
                    self.raw(end);
                    self.end_block()?;
                }
                self.ended = true;
            }
            Motion::Cycle(c) => self.cycle(c)?,
            Motion::Stop { optional } => {
                match (optional, self.spec.optional_stop) {
                    (true, Some(m1)) => self.raw(m1),
                    (true, None) => self.push_comment("optional stop"),
                    (false, _) => self.raw("M0"),
                }
                self.end_block()?;
            }
            // Future motion kinds: not representable yet; write them as a comment.
            #[allow(unreachable_patterns)] // Motion is non_exhaustive.
            other => self.comment_line(&format!("unsupported motion {other:?}"))?,
        }
        self.index += 1;
        Ok(())
    }

    fn finish(&mut self) -> Result<(), WriteError> {
        if self.finished {
            return Ok(());
        }
        self.header()?;
        self.finished = true;
        self.footer()?;
        self.out.write_all(self.buf.as_bytes())?;
        self.buf.clear();
        self.out.flush()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(d: Dialect, opts: WriterOptions, ms: &[Motion<'_>]) -> Vec<String> {
        write_program(d, opts, ms).expect("writes").lines().map(str::to_owned).collect()
    }

    #[test]
    fn modal_suppression_and_numbers() {
        let ms = [
            Motion::Rapid { to: Point3::new(0.0, 0.0, 5.0) },
            Motion::Linear { to: Point3::new(1.0, 0.0, 5.0), feed: 300.0, extrude: None },
            Motion::Linear { to: Point3::new(1.0, -0.00001, 5.0), feed: 300.0, extrude: None },
            Motion::Linear { to: Point3::new(2.5, 1.0, 5.0), feed: 300.0, extrude: None },
        ];
        let opts = WriterOptions { header: false, footer: false, ..Default::default() };
        assert_eq!(lines(Dialect::LinuxCnc, opts, &ms), ["G0 X0 Y0 Z5", "G1 X1 F300", "X2.5 Y1"]);
        let fanuc = WriterOptions { header: false, footer: false, modal: false, ..Default::default() };
        assert_eq!(lines(Dialect::Fanuc, fanuc, &ms[..2]), ["G0 X0. Y0. Z5.", "G1 X1. Y0. Z5. F300."]);
    }

    #[test]
    fn fanuc_frame_and_marlin_checksums() {
        let ms = [Motion::Rapid { to: Point3::new(1.0, 2.0, 3.0) }];
        let l = lines(Dialect::Fanuc, WriterOptions::default(), &ms);
        assert_eq!(l.first().map(String::as_str), Some("%"));
        assert_eq!(l.get(1).map(String::as_str), Some("O0001"));
        assert_eq!(l.last().map(String::as_str), Some("%"));
        assert!(l.iter().any(|x| x == "G91 G28 Z0."), "{l:?}");
        let opts = WriterOptions { line_numbers: true, ..Default::default() };
        for line in lines(Dialect::Marlin, opts, &ms) {
            if line.starts_with(';') {
                continue;
            }
            let (body, cs) = line.split_once('*').expect("checksum");
            let want = body.bytes().fold(0u8, |a, b| a ^ b);
            assert_eq!(cs.parse::<u8>().ok(), Some(want), "{line}");
            assert!(body.starts_with('N'), "{line}");
        }
    }

    #[test]
    fn non_finite_is_an_error() {
        let ms = [Motion::Rapid { to: Point3::new(f64::NAN, 0.0, 0.0) }];
        let e = write_program(Dialect::Grbl, WriterOptions::default(), &ms);
        assert!(matches!(e, Err(WriteError::NonFinite { index: 0, .. })), "{e:?}");
    }

    #[test]
    fn grbl_and_fanuc_linearise_multi_turn_arcs() {
        let ms = [
            Motion::Rapid { to: Point3::new(10.0, 0.0, 0.0) },
            Motion::Arc {
                to: Point3::new(10.0, 0.0, -2.0),
                center: Point3::origin(),
                plane: Plane::XY,
                direction: ArcDirection::CounterClockwise,
                turns: 1,
                feed: 100.0,
                extrude: None,
            },
        ];
        for d in [Dialect::Grbl, Dialect::Fanuc] {
            let l = lines(d, WriterOptions::default(), &ms);
            assert!(!l.iter().any(|x| x.contains("G3")), "{d:?}: {l:?}");
            assert!(l.iter().filter(|x| x.contains('X') || x.contains('Y')).count() > 100, "{d:?}");
        }
        let l = lines(Dialect::LinuxCnc, WriterOptions::default(), &ms);
        assert!(l.iter().any(|x| x == "G3 X10 Y0 Z-2 I-10 J0 P2 F100"), "{l:?}");
    }

    #[test]
    fn rotary_setup_words() {
        let frame = Isometry3::rotation(Vector3::x() * (-PI / 2.0));
        // Tool axis = frame * Z = (0, 1, 0) -> A = 90, C = atan2(0, -1) = 180.
        let ms = [Motion::Setup { frame, rotary: [None; 3] }];
        let opts = WriterOptions { rotary: Some(RotaryAxes::AC), ..Default::default() };
        let l = lines(Dialect::LinuxCnc, opts, &ms);
        assert!(l.iter().any(|x| x == "G0 A90 C180"), "{l:?}");
        assert!(
            l.iter()
                .any(|x| x
                    .starts_with("(SETUP 1: rotate part so that tool axis = +0.000000 +1.000000 +0.000000;")),
            "{l:?}"
        );
    }
}
