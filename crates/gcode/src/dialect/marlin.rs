//! Marlin (FDM printers): `;` comments, an E axis, `G4 P<milliseconds>`, XY arcs only,
//! RepRap checksums on numbered lines, no program end (`M84` turns the motors off).

use super::spec::{AutoRetract, CommentStyle, DialectSpec, DrillCycles, DwellDecimals, DwellFormat, TimeUnit, ToolChange};

/// `G4 P<milliseconds>`.
const DWELL: DwellFormat =
    DwellFormat { letter: 'P', unit: TimeUnit::Milliseconds, decimals: DwellDecimals::Fixed(0) };

pub(super) const SPEC: DialectSpec = DialectSpec {
    name: "marlin",
    display_name: "Marlin",
    comments: CommentStyle::Semicolon,
    delimiters: false,
    header: &["G21", "G90"],
    keep_point: false,
    number_comment_lines: false,
    checksums: true,
    dwell: DWELL,
    tool_change: ToolChange::Select,
    tool_length_offset: false,
    rotary_axes: false,
    multi_turn_arcs: false,
    plane_select: false,
    drill_cycles: DrillCycles::Expanded { dwell: DWELL },
    optional_stop: None,
    program_end: None,
    footer_stops: &[],
    auto_retract: AutoRetract::Lift(5.0),
    footer_tail: &["M84"],
    extrusion: true,
    homing: true,
};
