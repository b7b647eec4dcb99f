//! grbl 1.1 (hobby CNC): LinuxCNC's syntax without a tool changer, multi-turn arcs,
//! canned cycles or rotary axes.

use super::linuxcnc::{DWELL, FOOTER_STOPS, HEADER};
use super::spec::{AutoRetract, CommentStyle, DialectSpec, DrillCycles, DwellDecimals, DwellFormat, TimeUnit, ToolChange};

pub(super) const SPEC: DialectSpec = DialectSpec {
    name: "grbl",
    display_name: "grbl",
    comments: CommentStyle::Parens,
    delimiters: false,
    header: HEADER,
    keep_point: false,
    number_comment_lines: true,
    checksums: false,
    dwell: DWELL,
    // grbl has no M6.
    tool_change: ToolChange::Pause,
    tool_length_offset: false,
    rotary_axes: false,
    multi_turn_arcs: false,
    plane_select: true,
    drill_cycles: DrillCycles::Expanded {
        dwell: DwellFormat { letter: 'P', unit: TimeUnit::Seconds, decimals: DwellDecimals::Fixed(3) },
    },
    optional_stop: Some("M1"),
    program_end: Some("M30"),
    footer_stops: FOOTER_STOPS,
    auto_retract: AutoRetract::Blocks(&["G53 G0 Z0"]),
    footer_tail: &[],
    extrusion: false,
    homing: false,
};
