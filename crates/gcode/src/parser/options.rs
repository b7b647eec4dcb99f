//! The parser's public options and summary.

use crate::error::GcodeError;
use crate::rotary::{RotaryAxes, RotaryMount};

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
    /// Stop at the first error (returned as [`ParseError::Gcode`](crate::ParseError::Gcode)) instead of collecting
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
    /// scaled by `G20`, incremental under `G91`) first emits a [`Motion::Setup`](crate::Motion::Setup) with
    /// [`crate::rotary_frame`] of the current angles and those angles in `rotary`, then the
    /// block's move, if it has other axis or `E` words (a block with rotary words only
    /// moves nothing else). Rotary words on arcs and cycles, and the other rotary letter,
    /// are ignored. Default `None`: rotary words are ignored, and a block of rotary words
    /// only is a zero-length move, as `rs274` reports it.
    pub rotary: Option<RotaryAxes>,
    /// What [`ParseOptions::rotary`]'s axes turn. Default [`RotaryMount::Table`]. Under
    /// [`RotaryMount::Head`] a block's rotary words emit a
    /// [`Motion::ToolAxis`](crate::Motion::ToolAxis) of [`crate::rotary_axis`] instead of a
    /// setup, and the block's X, Y, Z stay the tip in the part frame.
    pub rotary_mount: RotaryMount,
    /// Most blocks one program may execute when it uses O-word control flow (loops and
    /// calls run lines again); past it the program stops with
    /// [`GcodeErrorKind::StepLimit`](crate::GcodeErrorKind::StepLimit) at the line
    /// reached. Default: 10 000 000.
    pub max_steps: u64,
    /// Most nested O-word subroutine calls. Default: 100.
    pub max_call_depth: usize,
    /// Folders searched, in order, for `name.ngc` when a program calls `o<name>` without
    /// defining it (LinuxCNC's `SUBROUTINE_PATH`); the file's `o<name> sub` .. `endsub`
    /// is added after the program (errors in it are reported past the program's last
    /// line). Default: none.
    pub subroutine_path: Vec<std::path::PathBuf>,
    /// Most distance (mm) between a `G5`/`G5.1` spline and the straight feeds it becomes.
    /// Default: 0.001.
    pub spline_tolerance_mm: f64,
    /// Tool diameters (mm) by tool number, the tool table's that `G41`/`G42` `D` (or the
    /// tool in the spindle) reads for cutter radius compensation. A tool not listed has
    /// diameter 0: compensation then leaves the programmed path as it is (as `rs274`
    /// does with a table of zero diameters). `G41.1`/`G42.1` give the diameter in the
    /// block and need no table. Default: empty.
    pub tool_diameters: std::collections::BTreeMap<u32, f64>,
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
            rotary_mount: RotaryMount::Table,
            max_steps: 10_000_000,
            max_call_depth: 100,
            subroutine_path: Vec::new(),
            spline_tolerance_mm: 0.001,
            tool_diameters: std::collections::BTreeMap::new(),
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
