//! [`DialectSpec`]: what differs per controller, as data, and its parts.

/// What differs per controller, as data. Built once per dialect (see the
/// [dialect docs](crate::Dialect)); read it through [`Dialect::spec`](crate::Dialect::spec).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct DialectSpec {
    /// Canonical lower-case name (`linuxcnc`): what [`FromStr`](std::str::FromStr) accepts (any case) and
    /// [`Display`](std::fmt::Display) prints.
    pub name: &'static str,
    /// Name in the generated-by header comment (`LinuxCNC`).
    pub display_name: &'static str,
    /// Comment syntax.
    pub comments: CommentStyle,
    /// `%` lines around the program and an `O<nnnn>` program number after the first
    /// (Fanuc); the number must be in 1..=9999.
    pub delimiters: bool,
    /// Header blocks after the generated-by comment, in order.
    pub header: &'static [&'static str],
    /// Whole numbers keep their decimal point (`X1.`; Fanuc reads a number without a
    /// point as a count of least increments). Spindle speeds (`S`) drop it.
    pub keep_point: bool,
    /// With line numbers: comment-only lines get an `N` number too.
    pub number_comment_lines: bool,
    /// With line numbers: RepRap `*` checksums after each numbered block.
    pub checksums: bool,
    /// `G4` dwell of a [`Motion::Dwell`](crate::Motion::Dwell).
    pub dwell: DwellFormat,
    /// How a tool change is written.
    pub tool_change: ToolChange,
    /// `G43 H<n>` after a tool change when
    /// [`WriterOptions::tool_length_offset`](crate::WriterOptions::tool_length_offset) is set.
    pub tool_length_offset: bool,
    /// The machine has rotary axes for 3+2 programs (see [`Dialect::has_rotary_axes`](crate::Dialect::has_rotary_axes)).
    pub rotary_axes: bool,
    /// Arcs of more than one turn (`P` word); without, they are linearised.
    pub multi_turn_arcs: bool,
    /// `G17`/`G18`/`G19` plane selection; without it only XY arcs are written (arcs in
    /// other planes are linearised) and no plane words at all (the header sets none).
    pub plane_select: bool,
    /// Drill cycles: native canned cycles or expanded moves.
    pub drill_cycles: DrillCycles,
    /// Optional stop (`M1`); `None`: a comment `optional stop` instead.
    pub optional_stop: Option<&'static str>,
    /// Program end (`M30`) of a [`Motion::End`](crate::Motion::End) and of the footer;
    /// `None`: nothing is written, and the footer is written even after an end.
    pub program_end: Option<&'static str>,
    /// Footer blocks before the retract (spindle and coolant off).
    pub footer_stops: &'static [&'static str],
    /// The footer's retract for [`FooterRetract::Auto`](crate::FooterRetract::Auto).
    pub auto_retract: AutoRetract,
    /// Footer blocks after the retract and program end (`M84`: motors off).
    pub footer_tail: &'static [&'static str],
    /// FDM extrusion: `E` words on moves, `M82`/`M83` and `G92 E0` in the header.
    pub extrusion: bool,
    /// `G28` in the header when [`WriterOptions::home`](crate::WriterOptions::home) is set.
    pub homing: bool,
}

/// Comment syntax of a dialect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum CommentStyle {
    /// `(text)`; parentheses inside become brackets, and LinuxCNC command comments
    /// (`MSG,` ...) get a leading `_` so they stay plain comments.
    Parens,
    /// `;text` up to the end of the line.
    Semicolon,
}

/// How a dwell time is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DwellFormat {
    /// Word letter (`P`, or `X` on Fanuc).
    pub letter: char,
    /// Unit of the value.
    pub unit: TimeUnit,
    /// Decimals of the value.
    pub decimals: DwellDecimals,
}

/// Unit of a dwell word.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TimeUnit {
    /// Seconds.
    Seconds,
    /// Milliseconds.
    Milliseconds,
}

/// Decimals of a dwell word.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DwellDecimals {
    /// Exactly this many at most (trailing zeros trimmed).
    Fixed(usize),
    /// [`WriterOptions::decimals`](crate::WriterOptions::decimals), but at least this many.
    AtLeast(usize),
    /// A whole number without a point, even where [`DialectSpec::keep_point`] is set.
    Integer,
}

/// How a tool change is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ToolChange {
    /// `T<n> M6`.
    M6,
    /// `T<n>` alone (select and change in one word).
    Select,
    /// `M0` with a comment `tool change T<n>`: no tool changer, the operator changes it.
    Pause,
}

/// Drill cycles of a dialect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum DrillCycles {
    /// `G98 G81`/`G82`/`G83`, modal until `G80`; `dwell` is `G82`'s dwell word.
    Canned {
        /// The dwell word of `G82`.
        dwell: DwellFormat,
    },
    /// Expanded to `G0`/`G1` moves and `G4` dwells written with `dwell`.
    Expanded {
        /// The `G4` dwell of an expanded `G82`.
        dwell: DwellFormat,
    },
}

/// The footer's default retract.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum AutoRetract {
    /// These blocks, as written (`G53 G0 Z0`).
    Blocks(&'static [&'static str]),
    /// `G0` to this many mm above the highest Z written.
    Lift(f64),
}
