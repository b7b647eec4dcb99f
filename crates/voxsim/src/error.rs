//! The crate's error type.

/// Everything the simulator can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// A cutter or bead description is impossible (non-finite or non-positive size, corner
    /// radius above the radius, flute shorter than the rounded end, ...).
    #[error("invalid tool: {0}")]
    InvalidTool(String),
    /// A motion carries a non-finite coordinate or frame.
    #[error("line {line}: invalid motion: {message}")]
    InvalidMotion {
        /// The source line the motion came from (0 when none was reported).
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// An option is out of its valid range.
    #[error("invalid option: {0}")]
    InvalidOption(String),
    /// Stock and target grids do not share the same [`s2g_geom::GridSpec`].
    #[error("the target grid does not match the stock grid (bounds or resolution differ)")]
    GridMismatch,
    /// A geometry operation failed.
    #[error(transparent)]
    Geom(#[from] s2g_geom::GeomError),
    /// Reading the program failed: its first G-code error (with its line and column) or an
    /// I/O error (its cause as the source).
    #[error(transparent)]
    Parse(s2g_gcode::ParseError<std::convert::Infallible>),
    /// The simulator refused a motion of the program; parsing stopped there.
    #[error("simulation stopped")]
    Stopped(#[source] Box<SimError>),
}

impl From<s2g_gcode::ParseError<SimError>> for SimError {
    /// A parse into the simulator that stopped: [`SimError::Stopped`] when the simulator
    /// refused a motion, [`SimError::Parse`] otherwise.
    fn from(e: s2g_gcode::ParseError<SimError>) -> Self {
        match e.into_sink() {
            Ok(e) => SimError::Stopped(Box::new(e)),
            Err(e) => SimError::Parse(e),
        }
    }
}

/// Shorthand for simulator results.
pub type Result<T, E = SimError> = std::result::Result<T, E>;
