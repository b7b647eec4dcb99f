//! Parser errors: [`GcodeError`] (one bad line, with its position) and [`ParseError`]
//! (why a parse stopped).

use std::fmt;
use std::path::PathBuf;

/// What is wrong with one line of G-code.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GcodeErrorKind {
    /// The text is not G-code at all (a letter without a number, a stray character).
    #[error("not G-code: {0}")]
    NotGcode(String),
    /// A `(` comment that is not closed on the same line.
    #[error("unclosed comment: '(' without ')' on the same line")]
    UnclosedComment,
    /// A RepRap `*NN` checksum that does not match the XOR of the bytes before `*`.
    #[error("checksum mismatch: the line says *{stated}, its bytes give *{computed}")]
    BadChecksum {
        /// The checksum written in the line.
        stated: u32,
        /// The XOR of the bytes before `*`.
        computed: u8,
    },
    /// A malformed number.
    #[error("bad number: {0}")]
    BadNumber(String),
    /// A letter that may appear once per line appears twice.
    #[error("word {0} appears twice on one line")]
    RepeatedWord(char),
    /// Two codes of one modal group on one line, or too many codes.
    #[error("{0}")]
    ModalConflict(String),
    /// A G- or M-code this parser does not know.
    #[error("unknown code {0}")]
    UnknownCode(String),
    /// A feature that is recognised but not implemented (O-word control flow, ...).
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// A code needs a word that the line lacks (`G4` without `P`, `G83` without `Q`, ...).
    #[error("{code} needs a {letter} word")]
    MissingWord {
        /// The code, as written (`G4`).
        code: String,
        /// The missing letter.
        letter: char,
    },
    /// A word has a value out of its range (a negative tool number, `P0` turns, ...).
    #[error("bad value: {0}")]
    BadValue(String),
    /// O-word control flow that cannot run: an unmatched or misplaced O-word, a call of an
    /// undefined subroutine, calls nested too deeply, a bad condition.
    #[error("O-word control flow: {0}")]
    ControlFlow(String),
    /// More blocks executed than [`ParseOptions::max_steps`](crate::ParseOptions::max_steps)
    /// (a loop that never ends): the program stops at this line.
    #[error("more than {0} blocks executed (a loop that never ends?): program stopped")]
    StepLimit(u64),
    /// An arc with neither `I`/`J`/`K` nor `R`.
    #[error("arc without centre: I, J, K and R words all missing")]
    ArcMissingCenter,
    /// An `I`/`J`/`K` arc whose end point is not on the circle through its start (LinuxCNC's rule).
    #[error(
        "radius to end of arc differs from radius to start: start radius {start_radius:.4} mm, \
         end radius {end_radius:.4} mm"
    )]
    ArcRadiusMismatch {
        /// Distance from the centre to the start point, mm.
        start_radius: f64,
        /// Distance from the centre to the end point, mm.
        end_radius: f64,
    },
    /// An `R` arc whose radius cannot reach its end point.
    #[error(
        "arc radius {radius:.4} mm too small to reach an end point {half_chord:.4} mm away from the middle"
    )]
    ArcRadiusTooSmall {
        /// `|R|` in mm.
        radius: f64,
        /// Half the chord length in mm.
        half_chord: f64,
    },
    /// An arc of (nearly) zero radius, or an `R` arc ending at its start.
    #[error("degenerate arc: {0}")]
    ArcDegenerate(String),
    /// A feed move (G1/G2/G3 or a canned cycle) without a feed rate.
    #[error("cannot do {0} with zero feed rate")]
    ZeroFeed(String),
    /// Axis words without an active motion mode (after `G80`, or before any motion code).
    #[error("axis words without a motion mode (G0, G1, G2, G3 or a canned cycle)")]
    AxisWordsWithoutMotion,
    /// Cutter radius compensation (`G40`-`G42`, `G41.1`, `G42.1`) that cannot be made as
    /// LinuxCNC makes it: a gouging corner, an entry move shorter than the tool radius,
    /// a code not allowed while it is on (`G28`, `G92`, a canned cycle, ...).
    #[error("cutter radius compensation: {0}")]
    CutterComp(String),
    /// An invalid canned-cycle setup (R below Z, non-positive Q, ...).
    #[error("canned cycle: {0}")]
    CannedCycle(String),
    /// An expression error: syntax, division by zero, a function outside its domain.
    #[error("expression: {0}")]
    Expression(String),
    /// A named parameter that was read before being set.
    #[error("parameter #<{0}> is not defined")]
    UndefinedParameter(String),
    /// A numbered parameter outside LinuxCNC's range (1 to 5601 for writing).
    #[error("parameter number {0} out of range")]
    ParameterOutOfRange(i64),
}

/// One error in a G-code program: where it is and what it is.
///
/// Displays as `file:line:col: message` (the file is `<input>` when parsing text).
#[derive(Debug, Clone, PartialEq)]
pub struct GcodeError {
    /// The file, when parsing one ([`crate::parse_file`]).
    pub path: Option<PathBuf>,
    /// 1-based line number.
    pub line: u64,
    /// 1-based byte column of the offending word or character.
    pub column: u32,
    /// What is wrong.
    pub kind: GcodeErrorKind,
}

impl fmt::Display for GcodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.path {
            Some(p) => write!(f, "{}:{}:{}: {}", p.display(), self.line, self.column, self.kind),
            None => write!(f, "<input>:{}:{}: {}", self.line, self.column, self.kind),
        }
    }
}

impl std::error::Error for GcodeError {}

/// Why a parse stopped early.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ParseError<E> {
    /// The first G-code error, when [`crate::ParseOptions::stop_at_first_error`] is set.
    #[error("{0}")]
    Gcode(GcodeError),
    /// Reading the input failed.
    #[error("{path}: read error")]
    Io {
        /// The file (`<input>` for a reader).
        path: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The sink refused a motion; parsing stopped there.
    #[error("motion sink error: {0}")]
    Sink(E),
}

impl<E> ParseError<E> {
    /// The sink's error, or the parse error that is not one (which then holds no `E`).
    pub fn into_sink(self) -> Result<E, ParseError<std::convert::Infallible>> {
        match self {
            ParseError::Sink(e) => Ok(e),
            ParseError::Gcode(e) => Err(ParseError::Gcode(e)),
            ParseError::Io { path, source } => Err(ParseError::Io { path, source }),
        }
    }
}
