//! Fanuc-style milling controls: `%` delimiters, an O program number, points on whole
//! numbers, `G4 X<seconds>`, `G82 P<milliseconds>`, reference return at the end.

use super::linuxcnc::{FOOTER_STOPS, HEADER};
use super::spec::{AutoRetract, CommentStyle, DialectSpec, DrillCycles, DwellDecimals, DwellFormat, TimeUnit, ToolChange};

pub(super) const SPEC: DialectSpec = DialectSpec {
    name: "fanuc",
    display_name: "Fanuc",
    comments: CommentStyle::Parens,
    delimiters: true,
    header: HEADER,
    keep_point: true,
    number_comment_lines: true,
    checksums: false,
    dwell: DwellFormat { letter: 'X', unit: TimeUnit::Seconds, decimals: DwellDecimals::Fixed(3) },
    tool_change: ToolChange::M6,
    tool_length_offset: true,
    rotary_axes: true,
    multi_turn_arcs: false,
    plane_select: true,
    // G82 P is an integer number of milliseconds.
    drill_cycles: DrillCycles::Canned {
        dwell: DwellFormat { letter: 'P', unit: TimeUnit::Milliseconds, decimals: DwellDecimals::Integer },
    },
    optional_stop: Some("M1"),
    program_end: Some("M30"),
    footer_stops: FOOTER_STOPS,
    auto_retract: AutoRetract::Blocks(&["G91 G28 Z0.", "G90"]),
    footer_tail: &[],
    extrusion: false,
    homing: false,
};
