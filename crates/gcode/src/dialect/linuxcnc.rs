//! LinuxCNC / RS274NGC: the reference dialect.

use super::spec::{AutoRetract, CommentStyle, DialectSpec, DrillCycles, DwellDecimals, DwellFormat, TimeUnit, ToolChange};

/// `G4 P<seconds>`, at least millisecond resolution.
pub(super) const DWELL: DwellFormat =
    DwellFormat { letter: 'P', unit: TimeUnit::Seconds, decimals: DwellDecimals::AtLeast(3) };

/// The safe-start header of the milling dialects.
pub(super) const HEADER: &[&str] = &["G17 G21 G40 G49 G80 G90 G94"];

/// Spindle and coolant off before the footer's retract.
pub(super) const FOOTER_STOPS: &[&str] = &["M5", "M9"];

pub(super) const SPEC: DialectSpec = DialectSpec {
    name: "linuxcnc",
    display_name: "LinuxCNC",
    comments: CommentStyle::Parens,
    delimiters: false,
    header: HEADER,
    keep_point: false,
    number_comment_lines: true,
    checksums: false,
    dwell: DWELL,
    tool_change: ToolChange::M6,
    tool_length_offset: true,
    rotary_axes: true,
    multi_turn_arcs: true,
    plane_select: true,
    drill_cycles: DrillCycles::Canned { dwell: DWELL },
    optional_stop: Some("M1"),
    program_end: Some("M30"),
    footer_stops: FOOTER_STOPS,
    auto_retract: AutoRetract::Blocks(&["G53 G0 Z0"]),
    footer_tail: &[],
    extrusion: false,
    homing: false,
};
